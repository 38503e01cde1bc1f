"""What every view of the UI shares: the :class:`UIContext`, number formatting for people
(about five significant digits), and the units and meanings of every name of the study.

Nothing here draws or lays out; the views' data functions (:mod:`.explore`, :mod:`.trial`,
...) use it, and so do their Dash pages (:mod:`.pages`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from ...analysis.results import Analysis
from ..labels import Labels, labels_of, relaxed_of
from .data import Constraints, StoreCache, finite, parse_constraints
from .jobs import JobManager

__all__ = [
    "DIGITS",
    "SOURCE_LABELS",
    "Labels",
    "UIContext",
    "analysis_of",
    "fmt",
    "labels_of",
    "limit_source_of",
    "num",
]

#: How the UI names each ``Criterion.limit_source``.
SOURCE_LABELS = {"noise": "noise floor", "quantile": "quantile stand-in", "expert": "expert"}

#: Significant digits shown for a number a person reads (limits, table cells, ranges).
DIGITS = 5


def fmt(v: Any, digits: int = DIGITS) -> str:
    """``v`` with ``digits`` significant digits ("" for None, "nan" for NaN)."""
    if v is None:
        return ""
    try:
        f = float(v)
    except (TypeError, ValueError):
        return str(v)
    if math.isnan(f):
        return "nan"
    if math.isinf(f):
        return "inf" if f > 0 else "-inf"
    return f"{f:.{digits}g}"


def num(v: Any, digits: int = DIGITS) -> float | None:
    """``v`` rounded to ``digits`` significant digits, JSON-safe (None for NaN/inf)."""
    f = finite(v)
    return None if f is None else float(f"{f:.{digits}g}")


@dataclass
class UIContext:
    """Everything the callbacks share: the store cache, the job manager and display sizes.

    Attributes
    ----------
    cache : StoreCache
    jobs : JobManager
    max_points : int
        Points drawn per set in the criterion-vs-criterion plot (beyond it the set is thinned
        at one fraction, and the legend says which).
    panel_points : int
        Points per set in each panel of the criterion-vs-parameter grid.
    table_rows : int
        Rows of each test-table column.
    set_rows : int
        Rows per page of the trial table.
    parallel_lines : int
        Lines per set in the parallel-coordinates view.
    """

    cache: StoreCache
    jobs: JobManager
    max_points: int = 20_000
    panel_points: int = 3_000
    table_rows: int = 50
    set_rows: int = 25
    parallel_lines: int = 600
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def spec(self):
        return self.cache.spec

    @property
    def labels(self) -> Labels:
        key = id(self.cache.spec)
        hit = self.extra.get("labels")
        if hit is None or hit[0] != key:
            hit = (key, labels_of(self.cache.spec))
            self.extra["labels"] = hit
        return hit[1]


def analysis_of(
    ctx: UIContext, limit_texts: Any, roles: Any, functional: Any = None
) -> tuple[Analysis, Constraints]:
    """The analysis under the constraint fields (memoised by the cache) and the parsed
    constraints."""
    c = parse_constraints(ctx.spec, limit_texts, roles, functional)
    return ctx.cache.analysis(c), c


def limit_source_of(criterion: Any) -> str:
    """Where a criterion's saved limit comes from, in words: "noise floor", "quantile
    stand-in" or "expert", with its note ("" when the study saves no limit for it); a limit
    relaxed as the last resort says so first, with its factor and the stated limit
    (:func:`vectorid.views.labels.relaxed_of`)."""
    src = getattr(criterion, "source", "")
    if not src or getattr(criterion, "limit", None) is None:
        return ""
    rel = relaxed_of(criterion)
    if rel is not None:
        return rel.text(getattr(criterion, "unit", ""))
    label = SOURCE_LABELS.get(src, src)
    note = getattr(criterion, "limit_note", "") or ""
    if not note:
        return label
    return note if note.lower().startswith(label.lower()) else f"{label}: {note}"
