"""vectorid: multicriteria (vector) parametric identification by the PSI method.

The public face is small::

    from vectorid import Study, StudySpec, load_study, Continuous, Integer, Choice, Space
    from vectorid import Criterion, FunctionalConstraint, Problem, as_batch, pareto_mask

Subpackages: :mod:`vectorid.analysis` (tables, feasible and Pareto sets),
:mod:`vectorid.store` (SQLite study store), :mod:`vectorid.run` (executors),
:mod:`vectorid.analytic` (test problems with known Pareto sets), :mod:`vectorid.models`
(flight-dynamics models).

The names are imported on first use (PEP 562), so ``vectorid --help`` and the analysis
verbs start without loading numba, scipy or the models they do not need.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"

#: Public name -> module (relative to this package) that defines it.
_EXPORTS = {
    "Analysis": ".analysis.results",
    "pareto_mask": ".analysis.pareto",
    "StoreError": ".errors",
    "StoreLockedError": ".errors",
    "StudyDefinitionError": ".errors",
    "VectoridError": ".errors",
    "Criterion": ".problem",
    "FunctionalConstraint": ".problem",
    "Problem": ".problem",
    "as_batch": ".problem",
    "Sampler": ".sampling",
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
    "Choice",
    "Continuous",
    "Criterion",
    "FunctionalConstraint",
    "Integer",
    "Problem",
    "Sampler",
    "Space",
    "StoreError",
    "StoreLockedError",
    "Study",
    "StudyDefinitionError",
    "StudySpec",
    "VectoridError",
    "__version__",
    "as_batch",
    "load_study",
    "pareto_mask",
]

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs only
    from .analysis.pareto import pareto_mask
    from .analysis.results import Analysis
    from .errors import StoreError, StoreLockedError, StudyDefinitionError, VectoridError
    from .problem import Criterion, FunctionalConstraint, Problem, as_batch
    from .sampling import Sampler
    from .space import Choice, Continuous, Integer, Space
    from .spec import StudySpec, load_study
    from .study import Study


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
