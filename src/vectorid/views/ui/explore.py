"""Data of the explorer view (test tables & plots): counts, test tables, the criterion plot,
the lower panels (histograms, criterion vs parameter), selections and the box-to-constraints
rule. Plain functions: browser values in, plain data and Plotly figures out.
"""

from __future__ import annotations

import re
import weakref
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ...analysis.histograms import Histogram, bin_edges, default_bins, histogram, histograms
from ...analysis.results import Analysis
from ...analysis.weights import how_weighted
from ...errors import StudyDefinitionError, VectoridError
from ...samplers import sampler_for
from .. import clouds
from ..labels import relaxation_line
from .context import UIContext, analysis_of, fmt, num
from .data import page_numbers, page_table, parse_trial_id, refused
from .verdicts import (
    combination_items,
    combinations_of,
    limit_sources,
    verdict_groups,
    verdict_line,
    verdicts_of,
)

__all__ = [
    "box_to_limits",
    "counts_view",
    "fast_histograms",
    "histogram_rows",
    "panel_view",
    "scatter_view",
    "selection_counts_view",
    "selection_from_event",
    "selection_mask",
    "summary_view",
]

CHOSEN = {"color": clouds.CHOSEN_COLOUR, "symbol": "star", "size": 16, "line": {"width": 1}}
_MAX_IDS = 5000  # ids a selection may list (lasso); boxes, bins and ranges are kept as ranges
#: Colour of a test-table cell outside D (the method's red) and inside (blue).
OUTSIDE, INSIDE = "#d62728", "#1f77b4"


def histograms_of(ctx: UIContext, a: Analysis) -> list[Any]:
    """The per-parameter histograms of ``a`` (memoised per analysis: a selection or a
    chosen trial redraws the panel without recounting a million trials)."""
    memo = ctx.extra.setdefault("hists", weakref.WeakKeyDictionary())
    hit = memo.get(a)
    if hit is None:  # two requests at once may both count: the same answer, no lock held
        hit = fast_histograms(ctx, a)
        memo[a] = hit
    return hit


def sampler_note(ctx: UIContext, a: Analysis) -> str | None:
    """A sequential store's line under the constraints in force: evaluations, generations,
    D's members and ESS, and how D's densities are weighted (memoised per
    analysis); None for a plain store."""
    memo = ctx.extra.setdefault("sampler_note", weakref.WeakKeyDictionary())
    if a not in memo:
        with ctx.cache.open() as st:
            note = sampler_for(ctx.spec).describe(st, a.limits, a.trials)
        memo[a] = (
            None
            if note is None
            else f"{note}. Histograms of D are {how_weighted(a)}; N, ND, NP count trials."
        )
    return memo[a]


def trials_memo(ctx: UIContext, a: Analysis, name: str) -> dict[Any, Any]:
    """A dict kept with the loaded trials of ``a`` (emptied when the store's trials are
    reloaded): what a view computes from the trials alone, whatever the constraints."""
    kept = ctx.extra.get(f"memo-{name}")  # (weak reference to the trials, the dict)
    if kept is None or kept[0]() is not a.trials:
        kept = ctx.extra[f"memo-{name}"] = (weakref.ref(a.trials), {})
    return kept[1]


def fast_histograms(ctx: UIContext, a: Analysis, min_trials: int = 50_000) -> list[Any]:
    """:func:`~vectorid.analysis.histograms.histograms` of ``a`` (every parameter over the
    study's box, bins from ND), the same counts, counted faster for a new constraint set:
    each trial's bin (one byte at up to 255 bins) is kept per loaded trials and bins, so a
    new D and Pareto set are two ``bincount`` calls over their rows per parameter. A store
    of fewer than ``min_trials`` trials, or a sequential one (weighted D), goes the plain
    way."""
    t = a.trials
    if a.n < min_trials or a.weighting is not None:
        return histograms(a)
    nbins = default_bins(a.n_feasible)
    per = trials_memo(ctx, a, "histograms")
    rows_d, rows_p = np.flatnonzero(a.feasible), np.flatnonzero(a.pareto)
    out = []
    for j, var in enumerate(a.spec.space.variables):
        edges = bin_edges(var, var.low, var.high, nbins)
        m = len(edges) - 1
        key = (var.name, edges.tobytes())
        hit = per.get(key)
        if hit is None:  # as analysis.histograms.histogram bins them; m: outside the box
            v = t.X[:, j]
            with np.errstate(invalid="ignore"):
                inside = (v >= edges[0]) & (v <= edges[-1])
            b = np.clip(np.searchsorted(edges, v, side="right") - 1, 0, m - 1)
            b[~inside] = m
            b = b.astype(np.uint8 if m < 255 else np.int32)
            every = np.bincount(b, minlength=m + 1)
            hit = per[key] = (b, every[:m].astype(np.int64), int(every[m]))
        b, every, outside = hit

        def count(rows: np.ndarray, b: np.ndarray = b, m: int = m) -> np.ndarray:
            return np.bincount(b[rows], minlength=m + 1)[:m].astype(np.int64)

        out.append(
            Histogram(
                param=var.name,
                edges=edges,
                all=every,
                feasible=count(rows_d),
                pareto=count(rows_p),
                low=float(edges[0]),
                high=float(edges[-1]),
                stage=None,
                n_outside=outside,
            )
        )
    return out


#: Panels per row of the histogram grid (:func:`histogram_rows`).
HIST_COLUMNS = 4
#: Heights (px) of the first row of a histogram grid (title, legend) and of the others.
ROW_HEIGHTS = (300, 226)


def histogram_rows(fig: Mapping[str, Any], cols: int = HIST_COLUMNS) -> list[dict[str, Any]]:
    """The histogram grid of :func:`panel_view` (``cols`` panels a row) as one figure per
    row, the same traces, shapes, panel titles and bins: the page draws each in a task of its
    own, so that no single task lays out the twelve panels' axes (plotly.js's costliest
    drawing in the page). The first row keeps the title and the legend, each row the
    layout's ``meta`` and ``uirevision``; a trace's ``customdata`` keeps its panel's index in
    the whole grid, so a click selects the same bin."""
    lay = fig["layout"]
    n = sum(1 for k in lay if k.startswith("xaxis"))
    nrow = max(1, -(-n // cols))
    rows: list[dict[str, Any]] = []
    for r in range(nrow):
        first, last = r * cols, min(n, (r + 1) * cols)
        names = {}  # the grid's axis ids -> this row's
        out_lay: dict[str, Any] = {
            k: v
            for k, v in lay.items()
            if not k.startswith(("xaxis", "yaxis")) and k not in ("annotations", "shapes")
        }
        for i in range(first, last):
            old, new = ("" if i == 0 else str(i + 1)), ("" if i == first else str(i - first + 1))
            names[f"x{old}"], names[f"y{old}"] = f"x{new}", f"y{new}"
            out_lay[f"xaxis{new}"] = dict(lay[f"xaxis{old}"], anchor=f"y{new}")
            out_lay[f"yaxis{new}"] = dict(lay[f"yaxis{old}"], anchor=f"x{new}", domain=[0.0, 1.0])
        out_lay["annotations"] = [
            dict(a, y=1.0) for a in lay.get("annotations", [])[first:last] if a.get("y") is not None
        ]
        out_lay["shapes"] = [
            dict(sh, xref=names[sh["xref"]], yref=names[sh["yref"].split()[0]] + " domain")
            for sh in lay.get("shapes", [])
            if sh.get("xref") in names
        ]
        # the rows below the first: their panel titles under the mode bar, not behind it
        out_lay["height"] = ROW_HEIGHTS[r > 0]
        out_lay["margin"] = dict(lay.get("margin", {}), t=100 if r == 0 else 44, b=36)
        if r:
            out_lay.pop("title", None)
            out_lay["showlegend"] = False
        data = [
            dict(t, xaxis=names[t["xaxis"]], yaxis=names[t["yaxis"]])
            for t in fig["data"]
            if t.get("xaxis") in names
        ]
        if r == 0:  # traces of no panel (a legend's entries)
            data += [t for t in fig["data"] if "xaxis" not in t]
        rows.append({"data": data, "layout": out_lay})
    return rows


def counts_view(ctx: UIContext, limit_texts: Any, roles: Any, functional: Any = None) -> dict:
    """N, ND, NP, failed trials and trials meeting the functional constraints under the
    constraint fields (the fast path: nothing else is computed)."""
    a, _ = analysis_of(ctx, limit_texts, roles, functional)
    return {
        "n": a.n,
        "nd": a.n_feasible,
        "np": a.n_pareto,
        "failed": a.n_failed,
        "functional": a.n_functional,
    }


def summary_view(
    ctx: UIContext, limit_texts: Any, roles: Any, functional: Any = None
) -> dict[str, Any]:
    """Counts, messages, constraints in force and the test tables.

    Parameters
    ----------
    limit_texts : sequence
        One constraint field per criterion (text; empty for no limit).
    roles : sequence
        ``"pure"``/``"pseudo"`` per criterion.
    functional : sequence, optional
        One ``(low, high)`` pair of field texts per functional constraint (empty for no
        bound); None keeps the study's bounds.

    Returns
    -------
    dict
        ``counts`` (n, nd, np, failed, functional), ``invalid`` (per criterion),
        ``invalid_functional`` (``[low, high]`` per functional constraint), ``messages``,
        ``in_force`` (text), ``pure``, ``ranges`` (min/max per criterion), ``table``
        (columns, data, styles of the test tables), ``sources`` (where each criterion's
        limit in force came from, :func:`~vectorid.views.ui.verdicts.limit_sources`) and
        ``verdicts`` (the identifiability verdicts in one line,
        :func:`~vectorid.views.ui.verdicts.verdict_line`), ``verdict_groups`` (the verdict
        panel, :func:`~vectorid.views.ui.verdicts.verdict_groups`), ``thin`` (D too small
        to show a spread, in words, or ""), ``relaxed`` (the study's saved limits relaxed
        as the last resort, in words, or "", :func:`vectorid.views.labels.
        relaxation_line`), ``combinations`` (the combinations of gains D pins down,
        :func:`~vectorid.views.ui.verdicts.combination_items`) and ``nd``.
    """
    a, c = analysis_of(ctx, limit_texts, roles, functional)
    vs = verdicts_of(ctx, a)
    combos = combination_items(combinations_of(ctx, a))
    messages = list(c.messages)
    note = sampler_note(ctx, a)
    if note:
        messages.insert(0, note)
    if a.n == 0:
        messages.append("the store holds no trial yet; start a stage on the Refine tab")
    elif a.n_feasible == 0:
        messages.append(a.diagnose_empty().describe())
    # test tables (seed 000 Fig. 6): ids and values best first, red outside D, blue inside.
    # The order is cached per store version (it does not depend on criteria constraints).
    tables = ctx.cache.test_tables(c, top=ctx.table_rows)
    lab = ctx.labels
    columns: list[dict[str, Any]] = []
    styles: list[dict[str, Any]] = []
    m = ctx.table_rows
    data: list[dict[str, Any]] = [
        {} for _ in range(min(m, max((len(t.ids) for t in tables), default=0)))
    ]
    ranges = []
    for j, t in enumerate(tables):
        head = f"{lab.short(t.name)} ({t.sense})"
        columns += [
            {"id": f"c{j}_id", "name": [head, "trial"], "type": "numeric"},
            {"id": f"c{j}_v", "name": [head, "value"], "type": "numeric"},
        ]
        ranges.append({"name": t.name, "min": num(t.min), "max": num(t.max)})
        top = min(m, len(t.ids))
        rows = ctx.cache.rows_of(t.ids[:top], a.trials)  # -1: appended since `a` was made
        inside = np.zeros(len(rows), dtype=bool)
        inside[rows >= 0] = a.feasible[rows[rows >= 0]]
        for i in range(top):
            data[i][f"c{j}_id"] = int(t.ids[i])
            data[i][f"c{j}_v"] = num(t.values[i])
        # two styles per column (rows inside D blue, outside red) keep the payload small
        rows_in = [i for i in range(top) if inside[i]]
        rows_out = [i for i in range(top) if not inside[i]]
        for col in (f"c{j}_id", f"c{j}_v"):
            for rows, colour in ((rows_in, INSIDE), (rows_out, OUTSIDE)):
                if rows:
                    styles.append({"if": {"row_index": rows, "column_id": col}, "color": colour})
    return {
        "counts": {
            "n": a.n,
            "nd": a.n_feasible,
            "np": a.n_pareto,
            "failed": a.n_failed,
            "functional": a.n_functional,
        },
        "invalid": [name in c.errors for name in a.crit_names],
        "invalid_functional": [
            [f"{name}.low" in c.errors, f"{name}.high" in c.errors] for name in a.con_names
        ],
        "messages": messages,
        "in_force": ", ".join(_bound_text(b) for b in a.active_bounds()) or "none",
        "pure": [a.crit_names[i] for i in a.pure],
        "ranges": ranges,
        "table": {"columns": columns, "data": data, "styles": styles},
        "sources": limit_sources(ctx, a, c),
        "verdicts": verdict_line(vs),
        "verdict_groups": verdict_groups(vs),
        "thin": (
            f"thin: D holds {vs[0].n_feasible} trials, fewer than the {vs[0].n_needed} needed "
            'to show its spread (run more trials, or sampler = "sequential")'
            if vs and vs[0].thin
            else ""
        ),
        "relaxed": relaxation_line(ctx.spec),
        "combinations": combos,
        "nd": a.n_feasible,
    }


def _bound_text(b: Any) -> str:
    op = "<=" if b.side == "high" else ">="
    return f"{b.name} {op} {fmt(b.value)}"


# -- selection --------------------------------------------------------------------------------


def selection_mask(ctx: UIContext, a: Analysis, spec: Mapping[str, Any] | None) -> np.ndarray:
    """The trials a selection spec picks (see :func:`selection_from_event`); all False for
    None."""
    t = a.trials
    if not spec:
        return np.zeros(a.n, bool)
    kind = spec.get("kind")
    if kind == "ids":
        ids = np.asarray([int(i) for i in spec.get("ids", [])[:_MAX_IDS]], dtype=np.int64)
        return np.isin(t.id, ids)
    if kind == "box":
        xv = clouds.column(a, ctx.cache.check_name(spec["x"], "any"))[0]
        yv = clouds.column(a, ctx.cache.check_name(spec["y"], "any"))[0]
        (x0, x1), (y0, y1) = sorted(map(float, spec["xr"])), sorted(map(float, spec["yr"]))
        with np.errstate(invalid="ignore"):
            return (xv >= x0) & (xv <= x1) & (yv >= y0) & (yv <= y1)
    if kind == "ranges":
        m = np.ones(a.n, bool)
        for name, rngs in dict(spec.get("ranges") or {}).items():
            v = clouds.column(a, ctx.cache.check_name(name, "any"))[0]
            hit = np.zeros(a.n, bool)
            for lo, hi in range_list(rngs):
                with np.errstate(invalid="ignore"):
                    hit |= (v >= lo) & (v <= hi)
            m &= hit
        return m
    if kind == "bin":
        xv = clouds.column(a, ctx.cache.check_name(spec["param"], "parameter"))[0]
        lo, hi = float(spec["lo"]), float(spec["hi"])
        cls = {"pareto": a.pareto, "all": np.ones(a.n, bool)}.get(
            str(spec.get("class")), a.feasible
        )
        return cls & (xv >= lo) & ((xv < hi) if not spec.get("last") else (xv <= hi))
    raise StudyDefinitionError("selection", f"unknown selection kind {kind!r}", "clear it")


def range_list(value: Any) -> list[tuple[float, float]]:
    """The ranges of one brushed axis, ``[lo, hi]`` or ``[[lo, hi], ...]`` (as the browser
    sends them), as sorted ``(low, high)`` pairs.

    Raises
    ------
    StudyDefinitionError
        When a range is not two finite numbers.
    """
    items = value if value and isinstance(value[0], list | tuple) else [value]
    out = []
    for r in items[:64]:
        try:
            lo, hi = sorted(float(v) for v in r)
        except (TypeError, ValueError):
            raise StudyDefinitionError(
                "brush", f"expected a range [low, high], got {r!r}", "clear the brush"
            ) from None
        if not (np.isfinite(lo) and np.isfinite(hi)):
            raise StudyDefinitionError("brush", f"expected finite ends, got {r!r}", "clear it")
        out.append((lo, hi))
    return sorted(out)


def selection_counts_view(
    ctx: UIContext,
    limit_texts: Any,
    roles: Any,
    functional: Any,
    selection: Mapping[str, Any] | None,
) -> dict[str, Any] | None:
    """How many trials the selection holds, and how many of them are in D and in the
    Pareto set (None without a selection).

    Returns
    -------
    dict or None
        ``n``, ``nd``, ``np`` and ``text`` ("selected 1,234 trials: 120 in D, of which 4
        Pareto").
    """
    if not selection:
        return None
    a, _ = analysis_of(ctx, limit_texts, roles, functional)
    m = selection_mask(ctx, a, selection)
    n, nd, np_ = int(m.sum()), int((m & a.feasible).sum()), int((m & a.pareto).sum())
    return {
        "n": n,
        "nd": nd,
        "np": np_,
        "text": f"selected {n:,} trials: {nd:,} in D, of which {np_:,} Pareto",
    }


def describe_selection(spec: Mapping[str, Any] | None, count: int) -> str:
    """The selection in words, with its size."""
    if not spec:
        return (
            "no selection (box- or lasso-select points, click a histogram bin, or brush "
            "axes of the parallel coordinates)"
        )
    kind = spec.get("kind")
    if kind == "box":
        what = f"box on {spec['y']} vs {spec['x']}"
    elif kind == "bin":
        what = (
            f"{spec.get('class', 'feasible')} trials with {spec['param']} in "
            f"[{fmt(spec['lo'])}, {fmt(spec['hi'])}]"
        )
    elif kind == "ranges":
        what = "brushes: " + "; ".join(
            f"{n} in " + " or ".join(f"[{fmt(lo)}, {fmt(hi)}]" for lo, hi in range_list(r))
            for n, r in dict(spec["ranges"]).items()
        )
    else:
        what = "picked points"
    return f"selection: {count:,} trials ({what})"


def selection_from_event(
    ctx: UIContext,
    source: str,
    event: Mapping[str, Any] | None,
    *,
    x: str | None = None,
    y: str | None = None,
    limit_texts: Any = None,
    roles: Any = None,
    functional: Any = None,
) -> dict[str, Any] | None:
    """A selection spec from a Plotly selection or click event.

    Parameters
    ----------
    source : {"scatter", "cvp", "hist"}
        The view the event came from.
    event : dict
        ``selectedData`` (scatter, cvp) or ``clickData`` (hist) as Plotly sends it.
    x, y : str
        Axes of the scatter; for ``cvp``, ``y`` is the criterion.
    limit_texts, roles, functional
        The constraint fields (for ``hist``: the bins are those of the histograms shown).

    Returns
    -------
    dict or None
        ``{"kind": "box", "x", "y", "xr", "yr"}`` for a box (resolved over *all* trials,
        not only those drawn), ``{"kind": "ids", "ids"}`` for a lasso,
        ``{"kind": "bin", "param", "lo", "hi", "class"}`` for a histogram bin; None when the
        event selects nothing.
    """
    event = page_table(event, "selection event")
    if not event:
        return None
    points = event.get("points") or []
    if not isinstance(points, list) or not all(isinstance(p, Mapping) for p in points[:_MAX_IDS]):
        raise refused("selection event", f"expected a list of points, got {points!r}"[:120])
    if source == "hist":
        pt = (points or [None])[0]
        if not pt:
            return None
        cd = pt.get("customdata")
        if not isinstance(cd, list) or len(cd) != 4:
            return None
        _, panel, code, b = (int(v) for v in page_numbers(cd, 4, "histogram bin"))
        a, _ = analysis_of(ctx, limit_texts, roles, functional)
        hists = histograms_of(ctx, a)
        if not 0 <= panel < len(hists):
            return None
        h = hists[panel]
        if not 0 <= b < len(h.edges) - 1:
            return None
        cls = clouds.HIST_SETS[code] if 0 <= code < len(clouds.HIST_SETS) else "feasible"
        return {
            "kind": "bin",
            "param": h.param,
            "lo": float(h.edges[b]),
            "hi": float(h.edges[b + 1]),
            "last": b == len(h.edges) - 2,
            "class": "feasible" if cls == "selected" else cls,
        }
    rng = page_table(event.get("range"), "selection range")
    if source == "scatter":
        x = ctx.cache.check_name(x, "any")
        y = ctx.cache.check_name(y, "any")
        if rng and "x" in rng and "y" in rng:
            xr = page_numbers(rng["x"], 2, "selection range x")
            yr = page_numbers(rng["y"], 2, "selection range y")
            return {"kind": "box", "x": x, "y": y, "xr": xr, "yr": yr}
    elif source == "cvp":
        y = ctx.cache.check_name(y, "criterion")
        if rng:
            xk = next((k for k in rng if re.fullmatch(r"x\d*", str(k))), None)
            yk = next((k for k in rng if re.fullmatch(r"y\d*", str(k))), None)
            if xk and yk:
                n = int(xk[1:] or 1)
                names = ctx.spec.space.names
                if 1 <= n <= len(names):
                    return {
                        "kind": "box",
                        "x": names[n - 1],
                        "y": y,
                        "xr": page_numbers(rng[xk], 2, "selection range x"),
                        "yr": page_numbers(rng[yk], 2, "selection range y"),
                    }
    else:
        raise StudyDefinitionError("selection", f"unknown view {source!r}", "reload the page")
    ids = [p.get("customdata") for p in points]
    ids = [int(i) for i in ids if isinstance(i, int | float) and not isinstance(i, bool)]
    return {"kind": "ids", "ids": ids[:_MAX_IDS]} if ids else None


def box_to_limits(
    ctx: UIContext, selection: Mapping[str, Any] | None, limit_texts: Sequence[Any]
) -> tuple[list[Any], str]:
    """New constraint fields from a box selection (a ``"box"`` selection spec of
    :func:`selection_from_event`): for each of its two axes that is a criterion, the
    worse-side bound becomes the box's edge on that side (upper edge for ``min``, lower for
    ``max``), rounded to five significant digits.

    Returns
    -------
    texts : list
        The constraint fields, one per criterion.
    message : str
        What was set.

    Raises
    ------
    StudyDefinitionError
        When the selection is not a box or neither axis is a criterion.
    """
    selection = page_table(selection, "box selection")
    if not selection or selection.get("kind") != "box":
        raise StudyDefinitionError(
            "box selection",
            "no box is selected",
            "choose the box-select tool on the criterion plot, drag a box, then press the button",
        )
    for key, n in (("xr", 2), ("yr", 2)):
        selection[key] = page_numbers(selection.get(key), n, f"box selection {key}")
    for key in ("x", "y"):
        if not isinstance(selection.get(key), str):
            raise refused("box selection", f"expected an axis name, got {selection.get(key)!r}")
    spec = ctx.spec
    names = spec.criterion_names
    texts = list(limit_texts) if limit_texts else [""] * len(names)
    done = []
    for axis, rng in (("x", selection["xr"]), ("y", selection["yr"])):
        name = selection[axis]
        if name not in names:
            continue
        lo, hi = sorted(float(v) for v in rng)
        sense = spec.criteria[names.index(name)].sense
        value = hi if sense == "min" else lo
        texts[names.index(name)] = fmt(value)
        done.append(f"{name} {'<=' if sense == 'min' else '>='} {fmt(value)}")
    if not done:
        raise StudyDefinitionError(
            "box selection",
            f"neither {selection['x']} nor {selection['y']} is a criterion",
            "select the box on a plot of two criteria",
        )
    return texts, "set from the box: " + ", ".join(done)


# -- figures -------------------------------------------------------------------------------------


def chosen_row(ctx: UIContext, chosen: Any) -> int | None:
    """Row of the chosen trial in the cached trials (None when none or unknown)."""
    if chosen in (None, ""):
        return None
    try:
        return ctx.cache.row_of(parse_trial_id(chosen))
    except VectoridError:
        return None


def _star(fig: dict, a: Analysis, xv: np.ndarray, yv: np.ndarray, row: int | None, **kw: Any):
    """The chosen trial as an orange star (appended to a figure dict)."""
    if row is None or not (np.isfinite(xv[row]) and np.isfinite(yv[row])):
        return
    gl = any(t.get("type") == "scattergl" for t in fig["data"])
    fig["data"].append(
        {
            "type": "scattergl" if gl else "scatter",
            "x": [float(xv[row])],
            "y": [float(yv[row])],
            "customdata": [int(a.trials.id[row])],
            "mode": "markers",
            "marker": CHOSEN,
            "name": f"chosen trial {int(a.trials.id[row])}",
            "legendgroup": "chosen",
            "hovertemplate": "trial %{customdata}<extra>chosen</extra>",
            "meta": {"class": "chosen"},
            **kw,
        }
    )


#: Up to this many points, the criterion plot draws SVG points, not WebGL: a plot at scale
#: draws its bulk sets as densities and only the Pareto set (and a selection) as points, and
#: a WebGL context (with plotly.js's shader set-up) cost the page 0.2-0.5 s of main thread
#: at load in software WebGL.
SVG_POINTS = 3000

#: Above this many points (or ``--max-points`` if smaller), the criterion plot draws the
#: infeasible set and D's non-Pareto trials as a density of every one of them: 18,000
#: WebGL points of D at 1e5 trials took the page 0.2-0.3 s to redraw after each limit in
#: software WebGL, a density heatmap a few ms. The Pareto set stays points.
DENSITY_POINTS = 3000


def _points_drawn(ctx: UIContext, a: Analysis, sel: np.ndarray) -> int:
    """Points the criterion plot draws (sets under the density threshold, Pareto, the
    selection), as :func:`~vectorid.views.clouds.cloud_traces` decides (an upper bound)."""
    budget = ctx.max_points
    dense = min(budget, DENSITY_POINTS)
    n = min(a.n_pareto, budget)
    for count in (a.n - a.n_feasible, a.n_feasible - a.n_pareto):
        n += count if count <= dense else 0
    return n + min(int(sel.sum()), 3 * budget)


def scatter_view(
    ctx: UIContext,
    limit_texts: Any,
    roles: Any,
    x: str,
    y: str,
    selection: Mapping[str, Any] | None = None,
    chosen: Any = None,
    functional: Any = None,
) -> tuple[dict[str, Any], str]:
    """Criterion vs criterion (seed 001 Fig. 6): sets in their colours (infeasible as a
    density at scale), constraints as lines, the selection in the set colours, the chosen
    trial as a star.

    Returns
    -------
    figure, selection text
    """
    x = ctx.cache.check_name(x, "any")
    y = ctx.cache.check_name(y, "any")
    a, _ = analysis_of(ctx, limit_texts, roles, functional)
    sel = selection_mask(ctx, a, selection)
    fig = clouds.scatter_figure(
        a,
        x,
        y,
        max_points=ctx.max_points,
        labels=ctx.labels,
        selected=sel if sel.any() else None,
        raw=True,
        memo=trials_memo(ctx, a, "scatter"),
        gl=_points_drawn(ctx, a, sel) > SVG_POINTS,
        density_above=DENSITY_POINTS,
    )
    xv, yv = clouds.column(a, x)[0], clouds.column(a, y)[0]
    _star(fig, a, xv, yv, chosen_row(ctx, chosen))
    fig["layout"].update(
        dragmode="select",
        uirevision=f"{x}|{y}",
        height=520,
        clickmode="event+select",
        margin={"t": 30, "b": 130, "l": 60, "r": 10},
        title={"text": clouds.counts_title(a), "font": {"size": 12}, "x": 0.01, "xanchor": "left"},
    )
    return fig, describe_selection(selection, int(sel.sum()))


def panel_view(
    ctx: UIContext,
    limit_texts: Any,
    roles: Any,
    panel: str,
    criterion: str | None = None,
    selection: Mapping[str, Any] | None = None,
    chosen: Any = None,
    functional: Any = None,
) -> dict[str, Any]:
    """The lower panel: ``"histograms"`` (per parameter, each set on its own scale, seed
    000 Fig. 7, with the selection's own histogram dotted and the chosen trial's value as a
    line) or ``"cvp"`` (one criterion against every parameter, seed 000 Fig. 9)."""
    a, _ = analysis_of(ctx, limit_texts, roles, functional)
    sel = selection_mask(ctx, a, selection)
    row = chosen_row(ctx, chosen)
    if panel == "histograms":
        hists = histograms_of(ctx, a)
        names = a.spec.space.names
        sel_counts = None
        if sel.any():
            sel_counts = [
                histogram(
                    a.trials.X[:, names.index(h.param)], sel, sel, h.edges, param=h.param
                ).feasible
                for h in hists
            ]
        chosen_x = None
        if row is not None:
            chosen_x = [float(a.trials.X[row, names.index(h.param)]) for h in hists]
        fig = clouds.histograms_figure(
            hists, labels=ctx.labels, selection=sel_counts, chosen=chosen_x, raw=True
        )
        fig["layout"].update(uirevision="hist", clickmode="event", meta={"nd": a.n_feasible})
        return fig
    if panel == "cvp":
        crit = ctx.cache.check_name(criterion or a.crit_names[0], "criterion")
        fig = clouds.criterion_vs_parameter_figure(
            a,
            crit,
            max_points=ctx.panel_points,
            labels=ctx.labels,
            selected=sel if sel.any() else None,
            raw=True,
        )
        if row is not None:
            yv = clouds.column(a, crit)[0]
            for i in range(len(a.spec.space)):
                n = i + 1
                _star(
                    fig,
                    a,
                    a.trials.X[:, i],
                    yv,
                    row,
                    xaxis=f"x{n if n > 1 else ''}",
                    yaxis=f"y{n if n > 1 else ''}",
                    showlegend=i == 0,
                )
        fig["layout"].update(dragmode="select", uirevision=f"cvp|{crit}")
        return fig
    raise StudyDefinitionError("panel", f"unknown panel {panel!r}", "use the tabs")
