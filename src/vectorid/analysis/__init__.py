"""Analysis of stored trials: test tables, feasible set D, Edgeworth–Pareto set.

Everything here is derived from the store and the constraints chosen at analysis time;
nothing re-runs a model.
"""

from .pareto import pareto_indices, pareto_mask
from .results import Analysis, Bound, EmptyDiagnosis, TestTable, parse_limit, parse_limits
from .toolkit import *  # noqa: F403 - histograms, sections, refine, correlation, ...
from .toolkit import __all__ as _toolkit_all

__all__ = [
    "Analysis",
    "Bound",
    "EmptyDiagnosis",
    "TestTable",
    "pareto_indices",
    "pareto_mask",
    "parse_limit",
    "parse_limits",
    *_toolkit_all,
]
