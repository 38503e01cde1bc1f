"""Data of the parallel-coordinates and history views: the axes and lines under the
constraints in force with the selection's brushes (two-sided, several per axis, any axis; a
brush is a selection), drawn by the page itself (:mod:`vectorid.views.ui.client`); which axes
are shown and in what order (by default the criteria, the functionals and the gains D depends
on most, by sensitivity); the brushes made constraints on request (criterion axis: its
criteria constraint Φ**; functional axis: its bounds); and N/ND/NP against the number of
trials."""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ...analysis.sensitivity import ks_of, ks_statistics
from ...analysis.weights import trial_weights
from ...errors import StudyDefinitionError
from ..history import history, history_figure
from ..parallel import parallel_axes
from .context import UIContext, analysis_of, fmt
from .data import page_table
from .explore import range_list

__all__ = [
    "AXES_AT_LOAD",
    "axis_groups",
    "axis_order",
    "axis_presets",
    "brushes_to_limits",
    "default_hidden",
    "default_view",
    "history_view",
    "parallel_view",
]

#: Axes shown at page load: the criteria and functionals, then the gains D depends on most
#: (sensitivity) up to this many axes in all (at least four gains); 16 axes on a 1,500-px
#: screen are 86 px apart, room for every title across. The others are a click away.
AXES_AT_LOAD = 16
#: Trials the sensitivity ranking reads (a seeded random subset beyond; the ranking of the
#: axes, not a printed number).
RANK_ROWS = 20_000


def _ranges(selection: Mapping[str, Any] | None) -> dict[str, list[tuple[float, float]]]:
    selection = page_table(selection, "brushes")
    if selection and selection.get("kind") == "ranges":
        ranges = page_table(selection.get("ranges"), "brushes") or {}
        return {str(k): range_list(v) for k, v in ranges.items()}
    return {}


def _ks_ranking(a: Any) -> dict[str, float]:
    """Each parameter's KS statistic between D and the other trials (Monte Carlo filtering,
    :func:`vectorid.analysis.sensitivity.sensitivity`; importance-weighted on a sequential
    store), over at most :data:`RANK_ROWS` trials (a seeded random subset beyond). NaN where
    D or its complement is empty. The statistics alone, with numpy
    (:func:`~vectorid.analysis.sensitivity.ks_statistics`): the p-values' ``scipy.stats``
    would add ~22 MB to the server at its first page load."""
    names = a.spec.space.names
    if a.n <= RANK_ROWS:
        return dict(zip(names, map(float, ks_of(a))))
    keep = np.zeros(a.n, bool)
    keep[np.random.default_rng(0).choice(a.n, RANK_ROWS, replace=False)] = True
    w = trial_weights(a, keep)
    ks = ks_statistics(a.trials.X[keep], a.feasible[keep], w)
    return dict(zip(names, map(float, ks)))


def axis_groups(ctx: UIContext) -> dict[str, Any]:
    """What the axis controls offer, under the limits saved with the study (once per store
    version): ``criteria``, ``functionals``, ``gains`` (by decreasing sensitivity, KS
    statistic between D and the rest; NaN last, in the study's order), ``ks`` (name -> KS)
    and ``verdict`` (name -> identified / weak / not identified)."""
    from .verdicts import verdicts_of

    key = ctx.cache.version()
    hit = ctx.extra.get("axis-groups")
    if hit is not None and hit[0] == key:
        return hit[1]
    spec = ctx.spec
    a = ctx.cache.analysis()
    ks = _ks_ranking(a) if a.n else {}
    names = spec.space.names
    order = sorted(
        range(len(names)),
        key=lambda j: (
            not np.isfinite(ks.get(names[j], np.nan)),
            -np.nan_to_num(ks.get(names[j], 0.0)),
            j,
        ),
    )
    verdict = {v.name: v.verdict for v in verdicts_of(ctx, a)} if a.n else {}
    out = {
        "criteria": spec.criterion_names,
        "functionals": spec.constraint_names,
        "gains": [names[j] for j in order],
        "ks": ks,
        "verdict": verdict,
    }
    ctx.extra["axis-groups"] = (key, out)
    return out


def _top_gains(g: dict[str, Any]) -> list[str]:
    room = max(4, AXES_AT_LOAD - len(g["criteria"]) - len(g["functionals"]))
    return g["gains"][:room]


def axis_presets(ctx: UIContext) -> dict[str, Any]:
    """The axis sets and orders the page offers (computed here, applied in the page).

    Returns
    -------
    dict
        ``shown``: preset -> the axes shown (``top``: criteria, functionals and the gains D
        depends on most, :data:`AXES_AT_LOAD` axes in all; ``verdict``: criteria,
        functionals and the identified and weak gains; ``all``: every axis; ``criteria``:
        criteria and functionals only); ``order``: preset -> every axis in order
        (``sensitivity``: gains by decreasing sensitivity; ``study``: the study's order;
        ``verdict``: gains grouped identified, weak, not identified, each by sensitivity);
        ``labels``: the presets in words.
    """
    g = axis_groups(ctx)
    head = g["criteria"] + g["functionals"]
    by_verdict = [
        n
        for v in ("identified", "weak", "not identified", "")
        for n in g["gains"]
        if g["verdict"].get(n, "") == v
    ]
    return {
        "shown": {
            "top": head + _top_gains(g),
            "verdict": head
            + [n for n in g["gains"] if g["verdict"].get(n) in ("identified", "weak")],
            "all": head + g["gains"],
            "criteria": head,
        },
        "order": {
            "sensitivity": head + g["gains"],
            "study": head + ctx.spec.space.names,
            "verdict": head + by_verdict,
        },
    }


def default_view(ctx: UIContext) -> dict[str, Any]:
    """The axes' order at page load: criteria, functionals, then the gains by decreasing
    sensitivity (lines coloured by set)."""
    return {"order": axis_presets(ctx)["order"]["sensitivity"]}


def default_hidden(ctx: UIContext) -> list[str]:
    """The axes hidden at page load: the gains beyond the :data:`AXES_AT_LOAD` first (the
    criteria and functionals, then the gains D depends on most)."""
    p = axis_presets(ctx)
    top = set(p["shown"]["top"])
    return [n for n in p["order"]["sensitivity"] if n not in top]


def axis_order(ctx: UIContext, order: Sequence[Any] | None) -> list[str]:
    """Every axis once: those of ``order`` that exist, in that order, then the others in the
    study's order (criteria, functionals, parameters)."""
    spec = ctx.spec
    names = spec.criterion_names + spec.constraint_names + spec.space.names
    first = [n for n in dict.fromkeys(str(v) for v in order or []) if n in names]
    return first + [n for n in names if n not in first]


def _tips(ctx: UIContext) -> dict[str, str]:
    g = axis_groups(ctx)
    out = {}
    for n in g["gains"]:
        parts = []
        if g["verdict"].get(n):
            parts.append(g["verdict"][n] + " (saved limits)")
        ks = g["ks"].get(n, float("nan"))
        if np.isfinite(ks):
            parts.append(f"sensitivity KS {ks:.2f} (D against the rest)")
        if parts:
            out[n] = ", ".join(parts)
    return out


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
    a column), the selection's brushes on their axes, the axes in the order the user left
    them (``view["order"]``) with ``hidden`` ones left out; drawn by the page itself (no
    plotly.js: :data:`vectorid.views.ui.client.VID_JS`, ``vid.parRender``).

    plotly.js's parcoords drew 41 axes in 4-14 s on the first draw in software WebGL (its
    three WebGL layers, each read back per panel), and redrew every line at each brush
    move; the page's SVG axes and its 2D canvas in a Web Worker take milliseconds.

    Returns
    -------
    dict
        :func:`vectorid.views.parallel.parallel_axes`'s, with ``rev`` (a new number per
        answer)."""
    a, _ = analysis_of(ctx, limit_texts, roles, functional)
    names = axis_order(ctx, (view or {}).get("order"))
    if colour not in (None, "", "set"):
        colour = ctx.cache.check_name(colour, "any")
    hide = [n for n in (hidden or []) if n in names]
    out = parallel_axes(
        a,
        names,
        lines=ctx.parallel_lines,
        labels=ctx.labels,
        ranges=_ranges(selection),
        hidden=hide,
        colour=colour or "set",
        tips=_tips(ctx),
    )
    ctx.extra["par-rev"] = ctx.extra.get("par-rev", 0) + 1
    out["rev"] = ctx.extra["par-rev"]
    return out


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
