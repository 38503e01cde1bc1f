"""vectorid: multicriteria (vector) parametric identification by the PSI method.

The public face is small::

    from vectorid import Study, StudySpec, load_study, Continuous, Integer, Choice, Space
    from vectorid import Criterion, FunctionalConstraint, Problem, as_batch, pareto_mask

Subpackages: :mod:`vectorid.analysis` (tables, feasible and Pareto sets),
:mod:`vectorid.store` (SQLite study store), :mod:`vectorid.run` (executors),
:mod:`vectorid.analytic` (test problems with known Pareto sets), :mod:`vectorid.models`
(flight-dynamics models).
"""

__version__ = "0.1.0"

from .analysis import Analysis, pareto_mask
from .errors import StoreError, StoreLockedError, StudyDefinitionError, VectoridError
from .problem import Criterion, FunctionalConstraint, Problem, as_batch
from .sampling import Sampler
from .space import Choice, Continuous, Integer, Space
from .spec import StudySpec, load_study
from .study import Study

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
