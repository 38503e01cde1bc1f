"""vectorid: multicriteria (vector) parametric identification by the PSI method.

The public face is small, and everything a user needs is importable from ``vectorid``:

- define a study: :class:`StudySpec` (or :func:`load_study` of a TOML file), :class:`Space`
  of :class:`Continuous`, :class:`Integer` and :class:`Choice` variables, :class:`Criterion`,
  :class:`FunctionalConstraint`, :class:`Problem`, :func:`as_batch`, :class:`PointSequence`
  (Sobol LP_tau, Latin hypercubes), :class:`Limits` (the bounds that define D);
- sample it: :class:`Sampler`, the seam every sampler implements (the plain table, the
  sequential sampler; :mod:`vectorid.samplers`);
- run it and keep it: :class:`Study` (``Study.create``, ``Study.open``,
  ``Study.create_or_open``, ``study.run``) with its :class:`RunSummary`; the stored trials
  as arrays, :class:`Trials`;
- analyse it: :class:`Analysis` (the feasible set D and the Edgeworth–Pareto set as bool
  masks, test tables (:class:`TestTable`), why D is empty (:class:`EmptyDiagnosis`), pandas
  frames with the flags), :class:`Bound`, :func:`pareto_mask`;
- judge it: :func:`identifiability` and its :class:`ParameterVerdict` per design variable;
- errors: :class:`VectoridError` and its kinds.

Subpackages for more: :mod:`vectorid.models` (flight-dynamics models and the model protocol),
:mod:`vectorid.identify` (flight data, adequacy criteria), :mod:`vectorid.analysis` (the whole
analysis toolkit), :mod:`vectorid.analytic` (test problems with known Pareto sets).

The names are imported on first use (PEP 562), so ``vectorid --help`` and the analysis
verbs start without loading numba, scipy or the models they do not need.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from ._version import __version__

#: Public name -> module (relative to this package) that defines it.
_EXPORTS = {
    "Analysis": ".analysis.results",
    "Bound": ".limits",
    "EmptyDiagnosis": ".analysis.results",
    "TestTable": ".analysis.results",
    "ParameterVerdict": ".analysis.identifiability",
    "identifiability": ".analysis.identifiability",
    "RunSummary": ".summary",
    "Trials": ".store",
    "pareto_mask": ".analysis.pareto",
    "StoreError": ".errors",
    "StoreLockedError": ".errors",
    "StudyDefinitionError": ".errors",
    "VectoridError": ".errors",
    "Criterion": ".problem",
    "FunctionalConstraint": ".problem",
    "Problem": ".problem",
    "as_batch": ".problem",
    "PointSequence": ".sampling",
    "Sampler": ".samplers",
    "Limits": ".limits",
    "Choice": ".space",
    "Continuous": ".space",
    "Integer": ".space",
    "Space": ".space",
    "StudySpec": ".spec",
    "load_study": ".spec",
    "Study": ".study",
}

__all__ = [
    "Analysis",
    "Bound",
    "Choice",
    "Continuous",
    "Criterion",
    "EmptyDiagnosis",
    "FunctionalConstraint",
    "Integer",
    "Limits",
    "ParameterVerdict",
    "PointSequence",
    "Problem",
    "RunSummary",
    "Sampler",
    "Space",
    "StoreError",
    "StoreLockedError",
    "Study",
    "StudyDefinitionError",
    "StudySpec",
    "TestTable",
    "Trials",
    "VectoridError",
    "__version__",
    "as_batch",
    "identifiability",
    "load_study",
    "pareto_mask",
]

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs only
    from .analysis.identifiability import ParameterVerdict, identifiability
    from .analysis.pareto import pareto_mask
    from .analysis.results import Analysis, EmptyDiagnosis, TestTable
    from .errors import StoreError, StoreLockedError, StudyDefinitionError, VectoridError
    from .limits import Bound, Limits
    from .problem import Criterion, FunctionalConstraint, Problem, as_batch
    from .samplers import Sampler
    from .sampling import PointSequence
    from .space import Choice, Continuous, Integer, Space
    from .spec import StudySpec, load_study
    from .store import Trials
    from .study import Study
    from .summary import RunSummary


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None and not name.startswith("_"):
        # Subpackages (``vectorid.models``, ``vectorid.analytic``...) as attributes.
        try:
            return importlib.import_module(f".{name}", __name__)
        except ModuleNotFoundError as exc:
            if exc.name != f"{__name__}.{name}":
                raise
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_EXPORTS])
