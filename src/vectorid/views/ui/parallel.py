"""Data of the parallel-coordinates and history views: the figure under the constraints in
force with the selection's brushes (two-sided, several per axis, any axis; a brush is a
selection), the brushes made constraints on request (criterion axis: its criteria constraint
Φ**; functional axis: its bounds), and N/ND/NP against the number of trials."""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Mapping, Sequence
from typing import Any

from ...analysis.classes import CLASS_COLOURS
from ...errors import StudyDefinitionError
from ..history import history, history_figure
from ..parallel import parallel_figure
from .context import UIContext, analysis_of, fmt
from .data import page_table
from .explore import range_list

__all__ = [
    "axis_order",
    "brushes_to_limits",
    "default_view",
    "history_view",
    "lines_apart",
    "parallel_view",
]


def _ranges(selection: Mapping[str, Any] | None) -> dict[str, list[tuple[float, float]]]:
    selection = page_table(selection, "brushes")
    if selection and selection.get("kind") == "ranges":
        ranges = page_table(selection.get("ranges"), "brushes") or {}
        return {str(k): range_list(v) for k, v in ranges.items()}
    return {}


def default_view(ctx: UIContext) -> dict[str, Any]:
    """The axes of the parallel coordinates at page load: criteria, functionals, then
    parameters (an empty ``order``), none hidden, lines coloured by set."""
    return {"order": []}


def axis_order(ctx: UIContext, order: Sequence[Any] | None) -> list[str]:
    """Every axis once: those of ``order`` that exist, in that order, then the others in the
    study's order (criteria, functionals, parameters)."""
    spec = ctx.spec
    names = spec.criterion_names + spec.constraint_names + spec.space.names
    first = [n for n in dict.fromkeys(str(v) for v in order or []) if n in names]
    return first + [n for n in names if n not in first]


def parallel_view(
    ctx: UIContext,
    limit_texts: Any,
    roles: Any,
    functional: Any = None,
    selection: Mapping[str, Any] | None = None,
    view: Mapping[str, Any] | None = None,
    colour: Any = "set",
    hidden: Sequence[Any] | None = None,
) -> Any:
    """Parallel coordinates of criteria, functionals and parameters, coloured by set (or by
    a column), the selection's brushes drawn on their axes, the axes in the order the user
    left them (``view["order"]``) with ``hidden`` ones left out."""
    a, _ = analysis_of(ctx, limit_texts, roles, functional)
    names = axis_order(ctx, (view or {}).get("order"))
    if colour not in (None, "", "set"):
        colour = ctx.cache.check_name(colour, "any")
    hide = [n for n in (hidden or []) if n in names]
    fig = parallel_figure(
        a,
        names,
        lines=ctx.parallel_lines,
        labels=ctx.labels,
        ranges=_ranges(selection),
        bounds_as_brushes=False,
        hidden=hide,
        colour=colour or "set",
        raw=True,
    )
    fig["layout"]["uirevision"] = "parallel"
    return lines_apart(fig, by_set=colour in (None, "", "set"))


def lines_apart(fig: dict[str, Any], by_set: bool = True) -> dict[str, Any]:
    """The parallel coordinates' lines moved out of plotly.js's way: plotly.js keeps the
    axes, their brushes and their order (two placeholder lines per axis, its WebGL canvases
    hidden by the page's style), and the page draws the lines itself on a 2D canvas in a
    Web Worker (``vid.par`` in :mod:`vectorid.views.ui.client`) from ``layout.meta.lines``:
    ``values`` (axis name -> float32 values, one per line), ``color`` (set code 0/1/2, or
    the colour-by column's values), ``cmin``/``cmax``, ``mode`` (``set`` or ``column``).

    plotly.js redraws every line on its WebGL canvases at each brush move (software WebGL
    in a headless or GPU-less browser: 0.3-1 s per redraw at 1,800 lines on a loaded
    2-core machine, holding the page's main thread while it waits for the GPU process); the
    page's own drawing takes a few milliseconds off the main thread."""
    tr = fig["data"][0]
    line = tr["line"]
    lines = {
        "values": {d["name"]: d["values"] for d in tr["dimensions"]},
        "color": line["color"],
        "cmin": line.get("cmin", 0),
        "cmax": line.get("cmax", 2),
        "mode": "set" if by_set else "column",
        "colours": [CLASS_COLOURS[k] for k in ("infeasible", "feasible", "pareto")],
        "unselected": tr.get("unselected", {}).get("line", {}),
    }
    for d in tr["dimensions"]:
        lo, hi = d["range"]
        d["values"] = [lo, hi]
    tr["line"] = dict(line, color=[lines["cmin"], lines["cmax"]])
    fig["layout"]["meta"] = dict(fig["layout"].get("meta") or {}, lines=lines)
    return fig


def brushes_to_limits(
    ctx: UIContext,
    selection: Mapping[str, Any] | None,
    limit_texts: Sequence[Any],
    lows: Sequence[Any],
    highs: Sequence[Any],
) -> tuple[list[Any], list[Any], list[Any], str]:
    """The brushes of the selection made constraints (one explicit action): a brushed
    criterion axis sets its criteria constraint Φ** to the worse-side edge of its brushes
    (the upper edge for ``min``, the lower for ``max``), a brushed functional axis sets
    both bounds to the edges of its brushes; parameter axes stay a selection.

    Returns
    -------
    texts, lows, highs : list
        The constraint fields after the action.
    message : str
        What was set.

    Raises
    ------
    StudyDefinitionError
        When no criterion or functional axis is brushed.
    """
    spec = ctx.spec
    crit, cons = spec.criterion_names, spec.constraint_names
    texts = list(limit_texts) if limit_texts else [""] * len(crit)
    lo_t = list(lows) if lows else [""] * len(cons)
    hi_t = list(highs) if highs else [""] * len(cons)
    done = []
    for name, rs in _ranges(selection).items():
        if not rs:
            continue
        lo, hi = min(r[0] for r in rs), max(r[1] for r in rs)
        if name in crit:
            j = crit.index(name)
            sense = spec.criteria[j].sense
            v = hi if sense == "min" else lo
            texts[j] = fmt(v)
            done.append(f"{name} {'<=' if sense == 'min' else '>='} {fmt(v)}")
        elif name in cons:
            j = cons.index(name)
            lo_t[j], hi_t[j] = fmt(lo), fmt(hi)
            done.append(f"{fmt(lo)} <= {name} <= {fmt(hi)}")
    if not done:
        raise StudyDefinitionError(
            "brushes",
            "no criterion or functional axis is brushed",
            "drag along a criterion's axis first, then press the button",
        )
    return texts, lo_t, hi_t, "constraints set from the brushes: " + ", ".join(done)


def history_view(ctx: UIContext, limit_texts: Any, roles: Any, functional: Any = None) -> Any:
    """N, ND, NP against the number of trials (memoised per constraint set and store
    version; 4 kept)."""
    a, c = analysis_of(ctx, limit_texts, roles, functional)
    memo: OrderedDict = ctx.extra.setdefault("history", OrderedDict())
    key = (ctx.cache.version(), c.key())
    h = memo.get(key)
    if h is None:
        h = history(a)
        memo[key] = h
        while len(memo) > 4:
            memo.popitem(last=False)
    fig = history_figure(h)
    fig.update_layout(uirevision="history")
    return fig
