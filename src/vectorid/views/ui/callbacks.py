"""The UI's callbacks as plain functions: browser values in, data and Plotly figures out.

Every function here takes a :class:`UIContext` and the raw values the browser sent (text of
the constraint fields, role toggles, axis names, selection events), validates them, and
returns plain data (dicts, lists, :class:`plotly.graph_objects.Figure`). The Dash layer
(:mod:`vectorid.views.ui.app`) only wires them to components; tests and
``benchmarks/ui.py`` call them directly. Numbers come from :mod:`vectorid.analysis`, figures
from :mod:`vectorid.views.figures`: nothing is computed twice. What is added here is view
glue only: overlays of the selected and chosen trials, and table rows.

Errors a user can cause raise :class:`~vectorid.errors.VectoridError` subclasses with a
message naming the fix; the Dash layer shows them in the page.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import plotly.graph_objects as go

from ...analysis.choice import best_per_criterion, suggest_choice
from ...analysis.classes import point_classes
from ...analysis.correlation import parameter_spread
from ...analysis.histograms import histogram, histograms
from ...analysis.refine import propose_refine, refine_history
from ...analysis.results import Analysis
from ...analysis.robustness import load_robustness
from ...analysis.sections import load_sections
from ...errors import StudyDefinitionError, VectoridError
from .. import figures as fg
from .data import Constraints, StoreCache, finite, parse_constraints, parse_number, parse_trial_id
from .jobs import JobBusy, JobManager

__all__ = [
    "UIContext",
    "box_to_limits",
    "job_action",
    "job_message",
    "job_view",
    "limits_to_save",
    "overview_view",
    "panel_view",
    "refine_view",
    "scatter_view",
    "selection_from_event",
    "selection_mask",
    "start_job",
    "summary_view",
    "trial_view",
]

SELECTED = {"color": "#000000", "symbol": "circle-open", "size": 9, "line": {"width": 1.5}}
CHOSEN = {"color": "#ff7f0e", "symbol": "star", "size": 16, "line": {"width": 1, "color": "#000"}}
_MAX_IDS = 5000  # ids a selection may list (lasso); boxes and bins are kept as ranges


@dataclass
class UIContext:
    """Everything the callbacks share: the store cache, the job manager and display sizes.

    Attributes
    ----------
    cache : StoreCache
    jobs : JobManager
    max_points : int
        Points drawn in the criterion-vs-criterion plot (decimated beyond, with a note).
    panel_points : int
        Points per panel of the criterion-vs-parameter grid.
    table_rows : int
        Rows of each test-table column.
    set_rows : int
        Rows of the simplified feasible/Pareto table.
    """

    cache: StoreCache
    jobs: JobManager
    max_points: int = 20_000
    panel_points: int = 3_000
    table_rows: int = 50
    set_rows: int = 200
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def spec(self):
        return self.cache.spec


def _g(v: Any) -> float | None:
    """Rounded (6 significant digits), JSON-safe number for tables."""
    f = finite(v)
    return None if f is None else float(f"{f:.6g}")


def _analysis(
    ctx: UIContext, limit_texts: Any, roles: Any, functional: Any = None
) -> tuple[Analysis, Constraints]:
    c = parse_constraints(ctx.spec, limit_texts, roles, functional)
    return ctx.cache.analysis(c), c


# -- test tables and counts ----------------------------------------------------------------------


def summary_view(
    ctx: UIContext, limit_texts: Any, roles: Any, functional: Any = None
) -> dict[str, Any]:
    """Counts, messages, test tables and the simplified feasible/Pareto table.

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
        ``in_force`` (text), ``ranges`` (min/max per criterion), ``table`` (columns, data,
        styles of the test tables), ``sets`` (columns, data, styles).
    """
    a, c = _analysis(ctx, limit_texts, roles, functional)
    messages = list(c.messages)
    if a.n == 0:
        messages.append("the store holds no trial yet; start a stage on the Refine tab")
    elif a.n_feasible == 0:
        messages.append(a.diagnose_empty().describe())
    # test tables (seed 000 Fig. 6): ids and values best first, red outside D. The order is
    # cached per store version (it does not depend on criteria constraints); whether a row
    # is in D is read from this analysis.
    tables = ctx.cache.test_tables(c)
    columns: list[dict[str, Any]] = []
    styles: list[dict[str, Any]] = []
    m = ctx.table_rows
    data: list[dict[str, Any]] = [
        {} for _ in range(min(m, max((len(t.ids) for t in tables), default=0)))
    ]
    ranges = []
    for j, t in enumerate(tables):
        head = f"{t.name} ({t.sense})"
        columns += [
            {"id": f"c{j}_id", "name": [head, "trial"], "type": "numeric"},
            {"id": f"c{j}_v", "name": [head, "value"], "type": "numeric"},
        ]
        ranges.append({"name": t.name, "min": _g(t.min), "max": _g(t.max)})
        top = min(m, len(t.ids))
        rows = ctx.cache.rows_of(t.ids[:top], a.trials)  # -1: appended since `a` was made
        inside = np.zeros(len(rows), dtype=bool)
        inside[rows >= 0] = a.feasible[rows[rows >= 0]]
        for i in range(top):
            data[i][f"c{j}_id"] = int(t.ids[i])
            data[i][f"c{j}_v"] = _g(t.values[i])
            if not inside[i]:
                for col in (f"c{j}_id", f"c{j}_v"):
                    styles.append({"if": {"row_index": i, "column_id": col}, "color": "#d62728"})
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
        "in_force": ", ".join(str(b) for b in a.active_bounds()) or "none",
        "pure": [a.crit_names[i] for i in a.pure],
        "ranges": ranges,
        "table": {"columns": columns, "data": data, "styles": styles},
        "sets": _set_table(ctx, a),
    }


def _set_table(ctx: UIContext, a: Analysis) -> dict[str, Any]:
    """Pareto trials, then the other feasible ones, best first by the first pure criterion."""
    rows = []
    j = a.pure[0] if a.pure else 0
    sign = -1.0 if a.crit_names and a.senses[j] == "max" else 1.0
    for mask, label in ((a.pareto, "Pareto"), (a.feasible & ~a.pareto, "feasible")):
        idx = np.flatnonzero(mask)
        if len(idx) and a.crit_names:
            idx = idx[np.argsort(sign * a.trials.F[idx, j], kind="stable")]
        rows += [(i, label) for i in idx[: max(0, ctx.set_rows - len(rows))]]
    names = a.spec.space.names
    columns = [{"id": "id", "name": "trial"}, {"id": "set", "name": "set"}]
    columns += [{"id": f"f:{n}", "name": n, "type": "numeric"} for n in a.crit_names]
    columns += [{"id": f"x:{n}", "name": n, "type": "numeric"} for n in names]
    data = []
    for i, label in rows:
        row: dict[str, Any] = {"id": int(a.trials.id[i]), "set": label}
        row.update({f"f:{n}": _g(v) for n, v in zip(a.crit_names, a.trials.F[i])})
        row.update({f"x:{n}": _g(v) for n, v in zip(names, a.trials.X[i])})
        data.append(row)
    styles = [{"if": {"filter_query": '{set} = "Pareto"'}, "color": "#2ca02c", "fontWeight": 600}]
    note = f"{min(len(data), a.n_pareto)} of {a.n_pareto} Pareto and " + (
        f"{max(0, len(data) - a.n_pareto)} of {a.n_feasible - a.n_pareto} other feasible trials"
    )
    return {"columns": columns, "data": data, "styles": styles, "note": note}


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
        xv = fg._column(a, ctx.cache.check_name(spec["x"], "any"))[0]
        yv = fg._column(a, ctx.cache.check_name(spec["y"], "any"))[0]
        (x0, x1), (y0, y1) = sorted(map(float, spec["xr"])), sorted(map(float, spec["yr"]))
        with np.errstate(invalid="ignore"):
            return (xv >= x0) & (xv <= x1) & (yv >= y0) & (yv <= y1)
    if kind == "bin":
        xv = fg._column(a, ctx.cache.check_name(spec["param"], "parameter"))[0]
        lo, hi = float(spec["lo"]), float(spec["hi"])
        cls = a.pareto if spec.get("class") == "pareto" else a.feasible
        return cls & (xv >= lo) & ((xv < hi) if not spec.get("last") else (xv <= hi))
    raise StudyDefinitionError("selection", f"unknown selection kind {kind!r}", "clear it")


def _describe_selection(spec: Mapping[str, Any] | None, count: int) -> str:
    if not spec:
        return "no selection (box- or lasso-select points, or click a histogram bar)"
    kind = spec.get("kind")
    if kind == "box":
        what = f"box on {spec['y']} vs {spec['x']}"
    elif kind == "bin":
        what = (
            f"{spec.get('class', 'feasible')} trials with {spec['param']} in "
            f"[{spec['lo']:.4g}, {spec['hi']:.4g}]"
        )
    else:
        what = "picked points"
    return f"selection: {count} trials ({what})"


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
        The constraint fields (for ``hist``: the bins are those of the feasible set).

    Returns
    -------
    dict or None
        ``{"kind": "box", "x", "y", "xr", "yr"}`` for a box (resolved over *all* trials,
        not only those drawn), ``{"kind": "ids", "ids"}`` for a lasso,
        ``{"kind": "bin", "param", "lo", "hi", "class"}`` for a histogram bar; None when the
        event selects nothing.
    """
    if not event:
        return None
    if source == "hist":
        pt = (event.get("points") or [None])[0]
        if not pt:
            return None
        a, _ = _analysis(ctx, limit_texts, roles, functional)
        hists = histograms(a)
        curve = int(pt.get("curveNumber", -1))
        panel, trace = divmod(curve, 2)  # two traces per panel: feasible, Pareto
        if not 0 <= panel < len(hists):
            return None
        h = hists[panel]
        b = int(pt.get("pointNumber", pt.get("pointIndex", -1)))
        if not 0 <= b < len(h.edges) - 1:
            return None
        return {
            "kind": "bin",
            "param": h.param,
            "lo": float(h.edges[b]),
            "hi": float(h.edges[b + 1]),
            "last": b == len(h.edges) - 2,
            "class": "pareto" if trace == 1 else "feasible",
        }
    rng = event.get("range")
    if source == "scatter":
        x = ctx.cache.check_name(x, "any")
        y = ctx.cache.check_name(y, "any")
        if rng and "x" in rng and "y" in rng:
            return {"kind": "box", "x": x, "y": y, "xr": list(rng["x"]), "yr": list(rng["y"])}
    elif source == "cvp":
        y = ctx.cache.check_name(y, "criterion")
        if rng:
            xk = next((k for k in rng if k.startswith("x")), None)
            yk = next((k for k in rng if k.startswith("y")), None)
            if xk and yk:
                n = int(xk[1:] or 1)
                names = ctx.spec.space.names
                if 1 <= n <= len(names):
                    return {
                        "kind": "box",
                        "x": names[n - 1],
                        "y": y,
                        "xr": list(rng[xk]),
                        "yr": list(rng[yk]),
                    }
    else:
        raise StudyDefinitionError("selection", f"unknown view {source!r}", "reload the page")
    ids = [p.get("customdata") for p in event.get("points") or []]
    ids = [int(i) for i in ids if isinstance(i, int | float) and not isinstance(i, bool)]
    return {"kind": "ids", "ids": ids[:_MAX_IDS]} if ids else None


def box_to_limits(
    ctx: UIContext, selection: Mapping[str, Any] | None, limit_texts: Sequence[Any]
) -> tuple[list[Any], str]:
    """New constraint fields from a box selection (a ``"box"`` selection spec of
    :func:`selection_from_event`): for each of its two axes that is a criterion, the
    worse-side bound becomes the box's edge on that side (upper edge for ``min``, lower for
    ``max``).

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
    if not selection or selection.get("kind") != "box":
        raise StudyDefinitionError(
            "box selection",
            "no box is selected",
            "choose the box-select tool on the criterion plot, drag a box, then press the button",
        )
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
        texts[names.index(name)] = f"{value:.6g}"
        done.append(f"{name} {'<=' if sense == 'min' else '>='} {value:.6g}")
    if not done:
        raise StudyDefinitionError(
            "box selection",
            f"neither {selection['x']} nor {selection['y']} is a criterion",
            "select the box on a plot of two criteria",
        )
    return texts, "set from the box: " + ", ".join(done)


# -- figures -------------------------------------------------------------------------------------


def _overlay(
    fig: go.Figure,
    a: Analysis,
    xv: np.ndarray,
    yv: np.ndarray,
    sel: np.ndarray,
    chosen_row: int | None,
    axes: tuple[str, str] = ("x", "y"),
    showlegend: bool = True,
    max_points: int = 5000,
) -> None:
    """Rings on the selected trials and a star on the chosen one."""
    from ...analysis.classes import subsample

    idx = subsample(sel & np.isfinite(xv) & np.isfinite(yv), max_points, 0)
    if len(idx):
        fig.add_trace(
            go.Scattergl(
                x=fg._compact(xv[idx]),
                y=fg._compact(yv[idx]),
                customdata=fg._ids(a.trials.id[idx]),
                mode="markers",
                marker=SELECTED,
                name=f"selected ({int(sel.sum())})",
                legendgroup="selected",
                showlegend=showlegend,
                xaxis=axes[0],
                yaxis=axes[1],
                hovertemplate="trial %{customdata}<extra>selected</extra>",
                meta={"class": "selected"},
            )
        )
    if chosen_row is not None:
        fig.add_trace(
            go.Scattergl(
                x=[float(xv[chosen_row])],
                y=[float(yv[chosen_row])],
                customdata=[int(a.trials.id[chosen_row])],
                mode="markers",
                marker=CHOSEN,
                name=f"chosen {int(a.trials.id[chosen_row])}",
                legendgroup="chosen",
                showlegend=showlegend,
                xaxis=axes[0],
                yaxis=axes[1],
                hovertemplate="trial %{customdata}<extra>chosen</extra>",
                meta={"class": "chosen"},
            )
        )


def _chosen_row(ctx: UIContext, chosen: Any) -> int | None:
    if chosen in (None, ""):
        return None
    try:
        return ctx.cache.row_of(parse_trial_id(chosen))
    except VectoridError:
        return None


def scatter_view(
    ctx: UIContext,
    limit_texts: Any,
    roles: Any,
    x: str,
    y: str,
    selection: Mapping[str, Any] | None = None,
    chosen: Any = None,
    functional: Any = None,
) -> tuple[go.Figure, str]:
    """Criterion vs criterion (red/blue/green, constraints as lines, seed 001 Fig. 6) with
    the selection ringed and the chosen trial starred.

    Returns
    -------
    figure, selection text
    """
    x = ctx.cache.check_name(x, "any")
    y = ctx.cache.check_name(y, "any")
    a, _ = _analysis(ctx, limit_texts, roles, functional)
    fig = fg.scatter_figure(a, x, y, max_points=ctx.max_points)
    sel = selection_mask(ctx, a, selection)
    xv, yv = fg._column(a, x)[0], fg._column(a, y)[0]
    _overlay(fig, a, xv, yv, sel, _chosen_row(ctx, chosen))
    fig.update_layout(
        dragmode="select", uirevision=f"{x}|{y}", height=500, clickmode="event+select"
    )
    return fig, _describe_selection(selection, int(sel.sum()))


def panel_view(
    ctx: UIContext,
    limit_texts: Any,
    roles: Any,
    panel: str,
    criterion: str | None = None,
    selection: Mapping[str, Any] | None = None,
    chosen: Any = None,
    functional: Any = None,
) -> go.Figure:
    """The lower panel: ``"histograms"`` (feasible and Pareto per parameter, seed 000 Fig. 7,
    with the selection's own histogram outlined) or ``"cvp"`` (one criterion against every
    parameter, seed 000 Fig. 9, selection ringed)."""
    a, _ = _analysis(ctx, limit_texts, roles, functional)
    sel = selection_mask(ctx, a, selection)
    row = _chosen_row(ctx, chosen)
    if panel == "histograms":
        hists = histograms(a)
        fig = fg.histograms_figure(hists)
        if sel.any() or row is not None:
            for i, h in enumerate(hists):
                base = fig.data[2 * i]
                j = a.spec.space.index(h.param)
                if sel.any():
                    hs = histogram(a.trials.X[:, j], sel, sel, h.edges, param=h.param)
                    fig.add_trace(
                        go.Bar(
                            x=hs.centres,
                            y=hs.feasible,
                            width=hs.widths,
                            name=f"selected ({int(sel.sum())})",
                            legendgroup="selected",
                            showlegend=i == 0,
                            marker={
                                "color": "rgba(0,0,0,0)",
                                "line": {"color": "#000", "width": 1.5},
                            },
                            xaxis=base.xaxis,
                            yaxis=base.yaxis,
                            meta={"class": "selected", "total": int(hs.feasible.sum())},
                        )
                    )
                if row is not None:
                    fig.add_vline(
                        x=float(a.trials.X[row, j]),
                        line={"color": CHOSEN["color"], "width": 2},
                        row=i // min(4, len(hists)) + 1,
                        col=i % min(4, len(hists)) + 1,
                    )
        fig.update_layout(uirevision="hist", clickmode="event")
        return fig
    if panel == "cvp":
        crit = ctx.cache.check_name(criterion or a.crit_names[0], "criterion")
        fig = fg.criterion_vs_parameter_figure(a, crit, max_points=ctx.panel_points)
        yv = fg._column(a, crit)[0]
        for i in range(len(a.spec.space)):
            base = fig.data[3 * i]
            _overlay(
                fig,
                a,
                a.trials.X[:, i],
                yv,
                sel,
                row,
                axes=(base.xaxis, base.yaxis),
                showlegend=i == 0,
                max_points=1000,
            )
        fig.update_layout(dragmode="select", uirevision=f"cvp|{crit}")
        return fig
    raise StudyDefinitionError("panel", f"unknown panel {panel!r}", "use the tabs")


# -- the chosen trial -------------------------------------------------------------------------


def trial_view(
    ctx: UIContext, trial_text: Any, limit_texts: Any, roles: Any, functional: Any = None
) -> dict[str, Any]:
    """Details of one sample trial: status, criteria against the constraints in force,
    parameters against nominal (seed 000 Fig. 13), its stored sections and robustness
    checks, and trajectories against the flight data for an identification study.

    Returns
    -------
    dict
        ``id``, ``summary`` (text), ``criteria`` and ``params`` (table rows), ``spread``
        (figure), ``sections`` and ``robustness`` (figures), ``robustness_text``,
        ``identification`` (figure or None) and ``identification_note``.
    """
    tid = parse_trial_id(trial_text)
    row = ctx.cache.row_of(tid)
    a, _ = _analysis(ctx, limit_texts, roles, functional)
    t = a.trials
    pc = point_classes(a)
    cls = "Pareto" if pc.pareto[row] else "feasible (in D)" if pc.feasible[row] else "infeasible"
    status = "ok" if t.status[row] == 0 else f"failed: {t.message(row) or 'no message'}"
    summary = (
        f"trial {tid}: {cls}; stage {int(t.stage[row])}, sequence index {int(t.seq[row])}; "
        f"{status}; {t.wall[row]:.3g} s"
    )
    crit_rows = []
    for j, name in enumerate(a.crit_names):
        lo, hi = a.bounds[name]
        v = t.F[row, j]
        ok = bool(np.isfinite(v) and lo <= v <= hi)
        crit_rows.append(
            {
                "name": name,
                "sense": a.senses[j],
                "role": a.roles[j],
                "value": _g(v),
                "bound": _g(hi if a.senses[j] == "min" else lo),
                "meets": "yes" if ok else "no",
            }
        )
    for j, name in enumerate(a.con_names):
        lo, hi = a.bounds[name]
        v = t.G[row, j]
        ok = bool(np.isfinite(v) and lo <= v <= hi)
        crit_rows.append(
            {
                "name": name,
                "sense": "functional",
                "role": f"[{lo:.6g}, {hi:.6g}]",
                "value": _g(v),
                "bound": None,
                "meets": "yes" if ok else "no",
            }
        )
    space = a.spec.space
    x = t.X[row]
    params = []
    for j, v in enumerate(space):
        nom = v.nominal
        params.append(
            {
                "name": v.name,
                "value": _g(x[j]),
                "nominal": _g(nom),
                "relative": _g(x[j] / nom) if nom not in (None, 0) else None,
                "low": _g(v.low),
                "high": _g(v.high),
                "unit": v.unit or "",
            }
        )
    spread = fg.spread_figure(
        parameter_spread(
            x[None, :], space.names, space.nominal, space.lows, space.highs, [f"trial {tid}"]
        )
    )
    with ctx.cache.open() as st:
        sections = [s for s in load_sections(st) if s.trial == tid]
        checks = [r for r in load_robustness(st, a) if r.trial == tid]
    ident, note = identification_view(ctx, tid, x)
    return {
        "id": tid,
        "summary": summary,
        "criteria": crit_rows,
        "params": params,
        "spread": spread,
        "sections": [fg.section_figure(s, a.bounds) for s in sections],
        "robustness": fg.robustness_figure(checks) if checks else None,
        "robustness_text": [f"stage {r.stage}, radius {r.radius:g}: {r.verdict}" for r in checks],
        "identification": ident,
        "identification_note": note,
    }


def identification_view(ctx: UIContext, tid: int, x: np.ndarray) -> tuple[go.Figure | None, str]:
    """Trajectories of a trial against the flight data (seed 000 Fig. 11), when the study is
    an identification (an ``[identification]`` table) and
    ``vectorid.identify.trial_trajectories(spec, x) -> (flight (n, 3), model (m, 3))``
    (positions north, east, up in m) is available; otherwise None and a note."""
    spec = ctx.spec
    if "identification" not in spec.extra:
        return None, "Not an identification study (no [identification] table): no flight data."
    try:
        from ...identify import trial_trajectories  # type: ignore[attr-defined]
    except ImportError:
        return None, (
            "This is an identification study, but this version of vectorid.identify has no "
            "trial_trajectories(spec, x); trajectories will appear once it does."
        )
    try:
        flight, model = trial_trajectories(spec, np.asarray(x, float))
    except VectoridError as exc:
        return None, f"cannot simulate trial {tid}: {exc}"
    return fg.trajectory_figure(flight, {f"trial {tid}": model}), ""


# -- refine and continue --------------------------------------------------------------------------


def _refine_args(basis: Any, quantile: Any, margin: Any) -> dict[str, Any]:
    if basis not in ("feasible", "pareto"):
        raise StudyDefinitionError("basis", f"expected feasible or pareto, got {basis!r}", "")
    q = parse_number(quantile, "quantile", allow_empty=False, example="0.05")
    mg = parse_number(margin, "margin", allow_empty=False, example="0.1")
    return {"basis": basis, "quantile": q, "margin": mg}


def refine_view(
    ctx: UIContext,
    limit_texts: Any,
    roles: Any,
    basis: Any,
    quantile: Any,
    margin: Any,
    functional: Any = None,
) -> dict[str, Any]:
    """The proposed box (double tuning, :func:`~vectorid.analysis.propose_refine`) under the
    constraints in force: editable rows (old and new bounds per variable), the figure of the
    old and new box, and a summary line."""
    args = _refine_args(basis, quantile, margin)
    a, _ = _analysis(ctx, limit_texts, roles, functional)
    _, _, stages = ctx.cache.state()
    prop = propose_refine(a, stages, **args)
    rows = [
        {
            "name": r["name"],
            "old_low": _g(r["old_low"]),
            "old_high": _g(r["old_high"]),
            "new_low": finite(r["new_low"]),  # full precision: an unedited row is no override
            "new_high": finite(r["new_high"]),
            "width_ratio": _g(r["width_ratio"]),
        }
        for r in prop.rows()
    ]
    summary = (
        f"from the {prop.basis} set ({prop.n_basis} trials): volume ratio {prop.volume_ratio:.3g}, "
        f"{prop.feasible_inside} of {prop.n_feasible} feasible trials inside, "
        f"{prop.pareto_outside} Pareto trials outside"
    )
    return {"rows": rows, "figure": fg.refine_figure(prop, a), "summary": summary}


def _overrides(
    ctx: UIContext, a: Analysis, stages: Any, args: Mapping[str, Any], rows: Any
) -> dict[str, tuple[float, float]]:
    """Bounds the user edited in the proposal table (rows that differ from the proposal)."""
    prop = propose_refine(a, stages, **args)
    proposed = {r["name"]: (r["new_low"], r["new_high"]) for r in prop.rows()}
    out: dict[str, tuple[float, float]] = {}
    for r in rows or []:
        if not isinstance(r, Mapping):
            continue
        name = ctx.cache.check_name(r.get("name"), "parameter")
        lo = parse_number(r.get("new_low"), f"new low of {name}", allow_empty=False, example="0.3")
        hi = parse_number(r.get("new_high"), f"new high of {name}", allow_empty=False, example="1")
        assert lo is not None and hi is not None
        plo, phi = proposed[name]
        tol = 1e-9 * max(1.0, abs(plo), abs(phi))
        if abs(lo - plo) > tol or abs(hi - phi) > tol:
            if not lo < hi:
                raise StudyDefinitionError(
                    f"box of {name}", f"expected low < high, got {lo:g} .. {hi:g}", "swap them"
                )
            out[name] = (lo, hi)
    return out


def limits_to_save(
    ctx: UIContext, limit_texts: Any, roles: Any = None, functional: Any = None
) -> dict[str, Any]:
    """The constraints in force, as :meth:`~vectorid.store.sqlite.Store.set_limits` saves
    them (the rule of ``vectorid table --save``: a criterion's saved limit is its worse-side
    bound; functional constraints keep both bounds).

    Returns
    -------
    dict
        ``criteria`` (name -> limit or None), ``constraints`` (name -> [low, high], None for
        no bound) and ``text`` (the bounds in words).

    Raises
    ------
    StudyDefinitionError
        When a field does not parse (nothing is saved while one is marked red), or a
        criterion has a better-side bound (which a study cannot hold).
    """
    a, c = _analysis(ctx, limit_texts, roles, functional)
    if c.errors:
        raise StudyDefinitionError(
            "save constraints",
            f"{len(c.errors)} field(s) do not hold a number: " + "; ".join(c.errors.values()),
            "correct or clear the fields outlined in red, then save",
        )
    criteria: dict[str, float | None] = {}
    for i, name in enumerate(a.crit_names):
        lo, hi = a.bounds[name]
        worse, other = (hi, lo) if a.senses[i] == "min" else (lo, hi)
        if math.isfinite(other):
            side = ">=" if a.senses[i] == "min" else "<="
            raise StudyDefinitionError(
                "save constraints",
                f"cannot save '{name}{side}{other:g}': a criteria constraint is the worst "
                f"accepted value of a {a.senses[i]} criterion",
                "remove that bound before saving",
            )
        criteria[name] = float(worse) if math.isfinite(worse) else None
    constraints = {
        name: [None if math.isinf(v) else float(v) for v in a.bounds[name]] for name in a.con_names
    }
    text = ", ".join(str(b) for b in a.active_bounds()) or "no limits"
    return {"criteria": criteria, "constraints": constraints, "text": text}


def start_job(ctx: UIContext, kind: str, **values: Any) -> str:
    """Validate the browser's values for a job and start it in the background.

    Parameters
    ----------
    kind : {"section", "robustness", "refine", "continue", "limits"}
    values
        ``trial`` (text), ``param``, ``points``, ``lo``, ``hi`` (section); ``trial``,
        ``radius``, ``points`` (robustness); ``limit_texts``, ``roles``, ``basis``,
        ``quantile``, ``margin``, ``rows``, ``trials`` (refine); ``trials`` (continue);
        ``limit_texts``, ``roles`` (robustness, refine, limits) and ``functional``
        (robustness, refine, limits: ``(low, high)`` field texts per functional constraint).

    Returns
    -------
    str
        What was started.

    Raises
    ------
    JobBusy
        When another job runs.
    StudyDefinitionError
        For a malformed value.
    """
    if kind == "section":
        tid = parse_trial_id(values.get("trial"))
        ctx.cache.row_of(tid)
        param = ctx.cache.check_name(values.get("param"), "parameter")
        points = parse_number(values.get("points"), "points", allow_empty=False, example="21")
        assert points is not None
        if not (points.is_integer() and 2 <= points <= 10_000):
            raise StudyDefinitionError("points", f"expected 2..10000, got {points:g}", "e.g. 21")
        lo = parse_number(values.get("lo"), f"range low of {param}", empty_means="the full box")
        hi = parse_number(values.get("hi"), f"range high of {param}", empty_means="the full box")
        rng = None
        if (lo is None) != (hi is None):
            raise StudyDefinitionError(
                "section range", "only one end of the range was given", "give both or neither"
            )
        if lo is not None and hi is not None:
            if not lo < hi:
                raise StudyDefinitionError(
                    "section range", f"expected low < high, got {lo:g} .. {hi:g}", "swap them"
                )
            rng = [lo, hi]
        params = {"trial": tid, "param": param, "points": int(points), "range": rng}
        label = f"section through trial {tid} along {param} ({int(points)} points)"
    elif kind == "robustness":
        tid = parse_trial_id(values.get("trial"))
        ctx.cache.row_of(tid)
        radius = parse_number(values.get("radius"), "radius", allow_empty=False, example="0.02")
        points = parse_number(values.get("points"), "points", allow_empty=False, example="32")
        assert radius is not None and points is not None
        if not 0 < radius <= 1:
            raise StudyDefinitionError(
                "radius", f"expected 0 < radius <= 1, got {radius:g}", "0.02"
            )
        if not (points.is_integer() and 4 <= points <= 4096):
            raise StudyDefinitionError("points", f"expected 4..4096, got {points:g}", "e.g. 32")
        c = parse_constraints(
            ctx.spec, values.get("limit_texts"), values.get("roles"), values.get("functional")
        )
        params = {
            "trial": tid,
            "radius": radius,
            "points": int(points),
            "limits": c.overrides,
            "roles": c.roles,
        }
        label = f"robustness check of trial {tid} (radius {radius:g}, {int(points)} points)"
    elif kind in ("refine", "continue"):
        n = parse_number(values.get("trials"), "trials", allow_empty=False, example="1024")
        assert n is not None
        if not (n.is_integer() and 1 <= n <= 100_000_000):
            raise StudyDefinitionError("trials", f"expected a whole number >= 1, got {n:g}", "1024")
        params = {"trials": int(n)}
        label = f"{int(n)} more trials in the current box"
        if kind == "refine":
            args = _refine_args(values.get("basis"), values.get("quantile"), values.get("margin"))
            a, c = _analysis(
                ctx, values.get("limit_texts"), values.get("roles"), values.get("functional")
            )
            _, _, stages = ctx.cache.state()
            bounds = _overrides(ctx, a, stages, args, values.get("rows"))
            propose_refine(a, stages, bounds=bounds, **args)  # validate here, visibly
            params.update(args, bounds=bounds, limits=c.overrides, roles=c.roles)
            label = f"new stage in the refined box, {int(n)} trials" + (
                f" (edited: {', '.join(bounds)})" if bounds else ""
            )
    elif kind == "limits":
        params = limits_to_save(
            ctx, values.get("limit_texts"), values.get("roles"), values.get("functional")
        )
        label = "saving the constraints in force with the study"
    else:
        raise StudyDefinitionError("job", f"unknown job {kind!r}", "use the buttons")
    ctx.jobs.start(kind, params, label)
    return f"started: {label}"


def job_action(ctx: UIContext, action: str, **values: Any) -> dict[str, Any]:
    """A job button pressed: start the job (:func:`start_job`) or, for ``"stop"``, stop the
    running one; never raises for what a user can cause.

    Returns
    -------
    dict
        ``text`` (the message to show) and ``busy``: the id of the running job when the
        request was refused because that job runs (the message then lasts only while it
        runs, see :func:`job_message`), else None.
    """
    try:
        if action == "stop":
            text = "stopping the job…" if ctx.jobs.stop() else "no job is running"
            return {"text": text, "busy": None}
        return {"text": start_job(ctx, action, **values), "busy": None}
    except JobBusy as exc:
        return {"text": str(exc), "busy": ctx.jobs.status().id}
    except VectoridError as exc:
        return {"text": str(exc), "busy": None}


def job_message(ctx: UIContext, note: Mapping[str, Any] | None) -> str:
    """The message under the job bar for a note of :func:`job_action`: its text, except
    that "a job is already running" clears once the job it names is no longer running."""
    if not note:
        return ""
    busy = note.get("busy")
    if busy is not None:
        st = ctx.jobs.status()
        if st.id != busy or not st.running:
            return ""
    return str(note.get("text", ""))


def job_view(ctx: UIContext) -> dict[str, Any]:
    """The job's status for the progress bar: ``state``, ``label``, ``message``,
    ``progress`` (0..1 or None), ``elapsed`` (s), ``id``, and ``text`` (one line)."""
    st = ctx.jobs.status().to_dict()
    if st["state"] == "idle":
        text = "no background job"
    elif st["state"] == "running":
        pct = "" if st["progress"] is None else f" {100 * st['progress']:.0f}%"
        text = f"running{pct}: {st['label']} ({st['elapsed']:.0f} s)"
    else:
        text = f"{st['state']}: {st['label']} — {st['message']} ({st['elapsed']:.1f} s)"
    st["text"] = text
    return st


# -- overview -----------------------------------------------------------------------------------


def overview_view(ctx: UIContext) -> dict[str, Any]:
    """Study definition, stages and boxes, failures by reason, timing and the run log.

    Returns
    -------
    dict
        ``study`` (key/value rows), ``variables``, ``criteria``, ``constraints``, ``stages``,
        ``boxes`` (variable rows, a low..high column per sample stage), ``failures``
        (reason, count, example trial), ``runs`` and ``timing`` (text).
    """
    from ...run.loop import group_failures

    _, t, stages = ctx.cache.state()  # first: it re-reads a definition saved meanwhile
    spec = ctx.spec
    d = spec.to_dict()["study"]
    study = [{"key": k, "value": str(v)} for k, v in d.items()]
    study.append({"key": "store", "value": str(ctx.cache.path)})
    variables = [
        {
            "name": v.name,
            "kind": v.kind,
            "low": _g(v.low),
            "high": _g(v.high),
            "nominal": _g(v.nominal),
            "unit": v.unit or "",
        }
        for v in spec.space
    ]
    criteria = [
        {"name": c.name, "sense": c.sense, "role": c.role, "limit": _g(c.limit)}
        for c in spec.criteria
    ]
    constraints = [{"name": c.name, "low": _g(c.low), "high": _g(c.high)} for c in spec.constraints]
    with ctx.cache.open() as st:
        counts = {s.stage: st.count(s.stage) for s in stages}
        runs = st.runs()
        hist = {h["stage"]: h for h in refine_history(st)}
    stage_rows = []
    for s in stages:
        changed = hist.get(s.stage, {}).get("changed", [])
        stage_rows.append(
            {
                "stage": s.stage,
                "kind": s.kind,
                "start_seq": s.start_seq,
                "trials": counts.get(s.stage, 0),
                "created": time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(s.created)),
                "note": s.note,
                "box changes": "; ".join(
                    f"{c['name']} [{c['old'][0]:.4g}, {c['old'][1]:.4g}] → "
                    f"[{c['new'][0]:.4g}, {c['new'][1]:.4g}]"
                    for c in changed
                ),
            }
        )
    boxes = []
    sample = [s for s in stages if s.kind == "sample"]
    for j, v in enumerate(spec.space):
        row: dict[str, Any] = {"name": v.name}
        for s in sample:
            var = s.space.variables[j]
            row[f"stage {s.stage}"] = f"[{var.low:.6g}, {var.high:.6g}]"
        boxes.append(row)
    # grouped by reason; each shown with the real message of its first trial (no masked digits)
    ids = {(int(s), int(q)): int(i) for s, q, i in zip(t.stage, t.seq, t.id)}
    failures = [
        {"reason": g.message, "count": g.count, "example trial": g.trial}
        for g in group_failures(t.messages, ids)
    ]
    n_failed = int((t.status != 0).sum())
    if n_failed and not failures:
        failures = [{"reason": "(no message stored)", "count": n_failed, "example trial": None}]
    run_rows = []
    total = 0.0
    for r in runs:
        dur = None if r["finished"] is None else r["finished"] - r["started"]
        total += dur or 0.0
        run_rows.append(
            {
                "run": r["run"],
                "started": time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(r["started"])),
                "duration, s": _g(dur),
                "executor": f"{r['executor']} × {r['workers']}",
                "target": r["target"],
                "outcome": r["outcome"],
            }
        )
    cpu = float(t.wall.sum()) if len(t) else 0.0
    timing = (
        f"{len(t)} sample trials; model time {cpu:.3g} s in all, "
        f"{(cpu / len(t) if len(t) else math.nan):.3g} s per trial; runs took {total:.3g} s "
        f"of wall time ({len(t) / total if total > 0 else math.nan:.0f} trials/s)"
    )
    return {
        "study": study,
        "variables": variables,
        "criteria": criteria,
        "constraints": constraints,
        "stages": stage_rows,
        "boxes": boxes,
        "failures": failures,
        "n_failed": n_failed,
        "runs": run_rows,
        "timing": timing,
    }


def initial_choice(ctx: UIContext) -> int | None:
    """The trial to show first: the suggested choice (Pareto trial nearest the ideal point),
    else the best trial of the first criterion, else None."""
    a = ctx.cache.analysis()
    s = suggest_choice(a)
    if s is None:
        best = best_per_criterion(a, feasible_only=False)
        s = next(iter(best.values()), None)
    return s
