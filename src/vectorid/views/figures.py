"""Plotly figures of the PSI analysis, built from the data functions of
:mod:`vectorid.analysis.toolkit` (no number is computed here that a test could not check
on the data function).

Colour convention (seed 001 Fig. 6): infeasible red, feasible blue, Pareto green; criteria
constraints Φ** are drawn as dashed lines. Point clouds use WebGL (``Scattergl``,
``Splom``) so 1e5 trials stay responsive. Every point-cloud figure takes ``max_points``:
when a class holds more trials than its share, a uniform random subset (fixed seed) is
drawn and the figure says so in an annotation; each trace's ``meta`` holds
``{"class", "count", "shown"}``.

Plotly is an optional dependency (extra ``plot``); importing this module without it raises
an ImportError with the install hint.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

try:
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots
except ModuleNotFoundError as exc:  # pragma: no cover - exercised without plotly only
    raise ImportError(
        "vectorid.views needs plotly: pip install 'vectorid[plot]' (or pip install plotly)"
    ) from exc

from ..analysis.classes import CLASS_COLOURS, PointClasses, point_classes, subsample
from ..analysis.correlation import CorrelationResult, Spread
from ..analysis.histograms import Histogram
from ..analysis.refine import RefineProposal
from ..analysis.results import Analysis
from ..analysis.robustness import Robustness
from ..analysis.sections import Section
from ..analysis.sensitivity import Sensitivity
from ..analysis.signals import envelope, power_spectrum
from ..errors import StudyDefinitionError, suggest

__all__ = [
    "channels_figure",
    "correlation_figure",
    "criterion_vs_parameter_figure",
    "histograms_figure",
    "history_figure",
    "parallel_figure",
    "refine_figure",
    "robustness_figure",
    "scatter_figure",
    "scatter_matrix_figure",
    "section_figure",
    "sensitivity_figure",
    "spectra_figure",
    "spread_figure",
    "stage_histograms_figure",
    "trajectory3d_figure",
    "trajectory_figure",
]

from .clouds import (  # the point clouds and per-set histograms
    TEMPLATE,
    criterion_vs_parameter_figure,
    histograms_figure,
    scatter_figure,
)
from .history import history_figure
from .parallel import parallel_figure

LIMIT_LINE = {"color": "#444", "width": 1.2, "dash": "dash"}
_CLASS_LABEL = {"infeasible": "infeasible", "feasible": "feasible", "pareto": "Pareto"}
_RUN_COLOURS = [
    "#1f77b4",
    "#ff7f0e",
    "#2ca02c",
    "#9467bd",
    "#8c564b",
    "#e377c2",
    "#17becf",
    "#bcbd22",
    "#7f7f7f",
]


# -- helpers -----------------------------------------------------------------------------------


def _compact(v: np.ndarray) -> np.ndarray:
    """float32 copy of a coordinate array (halves the embedded size; ~7 significant
    digits, enough to draw and hover)."""
    return np.asarray(v, dtype=np.float32)


def _ids(v: np.ndarray) -> np.ndarray:
    v = np.asarray(v)
    return v.astype(np.int32) if len(v) == 0 or int(v.max()) < 2**31 - 1 else v.astype(float)


def _column(a: Analysis, name: str) -> tuple[np.ndarray, str]:
    """Values of a criterion, functional or parameter, and its kind."""
    if name in a.crit_names:
        return a.trials.F[:, a.crit_names.index(name)], "criterion"
    if name in a.con_names:
        return a.trials.G[:, a.con_names.index(name)], "functional"
    names = a.spec.space.names
    if name in names:
        return a.trials.X[:, names.index(name)], "parameter"
    raise StudyDefinitionError(
        "name",
        f"unknown criterion, functional or parameter {name!r}",
        suggest(name, a.crit_names + a.con_names + names),
    )


def _limits_of(a: Analysis, name: str) -> list[float]:
    """Finite constraint values on ``name`` (criteria and functional constraints)."""
    if name not in a.bounds:
        return []
    return [v for v in a.bounds[name] if math.isfinite(v)]


def allocate(counts: Mapping[str, int], budget: int | None) -> dict[str, int]:
    """Share ``budget`` points among classes by water-filling: each class gets an equal
    share, and what a small class does not use goes to the others."""
    if budget is None:
        return dict(counts)
    out = {}
    remaining = int(budget)
    left = sorted(counts, key=lambda c: counts[c])
    for i, c in enumerate(left):
        share = remaining // (len(left) - i)
        out[c] = min(counts[c], share)
        remaining -= out[c]
    return out


def _selection(
    a: Analysis, max_points: int | None, seed: int, classes: PointClasses | None = None
) -> tuple[dict[str, np.ndarray], dict[str, int], PointClasses]:
    """Rows to draw per class (failed trials excluded: their criteria are NaN)."""
    pc = classes or point_classes(a)
    drawable = {name: mask & ~pc.failed for name, mask in pc.items()}
    counts = {name: int(m.sum()) for name, m in drawable.items()}
    shares = allocate(counts, max_points)
    rows = {name: subsample(m, shares[name], seed) for name, m in drawable.items()}
    return rows, counts, pc


def _decimation_note(rows: dict[str, np.ndarray], counts: dict[str, int], seed: int) -> str:
    parts = [
        f"{len(rows[c]):,} of {counts[c]:,} {_CLASS_LABEL[c]}"
        for c in rows
        if len(rows[c]) < counts[c]
    ]
    if not parts:
        return ""
    return "decimated for display: showing " + ", ".join(parts) + f" (random subset, seed {seed})"


def _annotate(fig: go.Figure, text: str, y: float = 1.0) -> None:
    if text:
        fig.add_annotation(
            text=text,
            xref="paper",
            yref="paper",
            x=0,
            y=y,
            yshift=18,
            showarrow=False,
            xanchor="left",
            font={"size": 11, "color": "#a33"},
        )


def _class_trace(
    name: str,
    rows: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    ids: np.ndarray,
    count: int,
    n_failed: int,
    xname: str,
    yname: str,
    *,
    showlegend: bool = True,
    size: float | None = None,
) -> go.Scattergl:
    label = _CLASS_LABEL[name]
    legend = f"{label} ({count:,})"
    if name == "infeasible" and n_failed:
        legend = f"{label} ({count:,} drawn; {n_failed:,} failed not drawn)"
    return go.Scattergl(
        x=_compact(x[rows]),
        y=_compact(y[rows]),
        customdata=_ids(ids[rows]),
        mode="markers",
        name=legend,
        legendgroup=name,
        showlegend=showlegend,
        marker={
            "color": CLASS_COLOURS[name],
            "size": size or (7 if name == "pareto" else 4),
            "opacity": 0.9 if name == "pareto" else 0.6,
        },
        hovertemplate=f"trial %{{customdata}}<br>{xname}=%{{x:.6g}}<br>{yname}=%{{y:.6g}}"
        f"<extra>{label}</extra>",
        meta={"class": name, "count": count, "shown": len(rows)},
    )


# -- criterion plots ---------------------------------------------------------------------------


def scatter_matrix_figure(
    a: Analysis,
    names: Sequence[str] | None = None,
    *,
    max_points: int | None = None,
    seed: int = 0,
    title: str | None = None,
) -> go.Figure:
    """All pairs of criteria (or of any named columns) in one WebGL scatter matrix, lower
    triangle, with constraint lines in every cell. The data of each trial is embedded once
    whatever the number of pairs.

    Parameters
    ----------
    names : sequence of str, optional
        Columns (default: every criterion).
    """
    names = list(names) if names is not None else list(a.crit_names)
    cols = [_column(a, n)[0] for n in names]
    rows, counts, pc = _selection(a, max_points, seed)
    k = len(names)
    fig = go.Figure()
    for name in ("infeasible", "feasible", "pareto"):
        r = rows[name]
        label = _CLASS_LABEL[name]
        fig.add_trace(
            go.Splom(
                dimensions=[{"label": n, "values": _compact(c[r])} for n, c in zip(names, cols)],
                customdata=_ids(a.trials.id[r]),
                name=f"{label} ({counts[name]:,})",
                marker={
                    "color": CLASS_COLOURS[name],
                    "size": 5 if name == "pareto" else 3,
                    "opacity": 0.9 if name == "pareto" else 0.5,
                },
                diagonal={"visible": False},
                showupperhalf=False,
                hovertemplate="trial %{customdata}<br>%{xaxis.title.text}=%{x:.6g}<br>"
                f"%{{yaxis.title.text}}=%{{y:.6g}}<extra>{label}</extra>",
                meta={"class": name, "count": counts[name], "shown": len(r)},
            )
        )
    shapes = []
    # Splom cell (row r, column c) draws x = dimension c on axis x{c+1}, y = dimension r on
    # y{r+1}; with the diagonal hidden and the upper half off, cells r > c are shown.
    for c in range(k):
        for r in range(k):
            if r <= c:
                continue
            xa = "x" if c == 0 else f"x{c + 1}"
            ya = "y" if r == 0 else f"y{r + 1}"
            for v in _limits_of(a, names[c]):
                shapes.append(
                    {
                        "type": "line",
                        "xref": xa,
                        "yref": f"{ya} domain",
                        "x0": v,
                        "x1": v,
                        "y0": 0,
                        "y1": 1,
                        "line": LIMIT_LINE,
                    }
                )
            for v in _limits_of(a, names[r]):
                shapes.append(
                    {
                        "type": "line",
                        "xref": f"{xa} domain",
                        "yref": ya,
                        "x0": 0,
                        "x1": 1,
                        "y0": v,
                        "y1": v,
                        "line": LIMIT_LINE,
                    }
                )
    side = max(420, min(1100, 190 * k))
    fig.update_layout(
        template=TEMPLATE,
        title=title or f"All criterion pairs   (N={a.n}, ND={a.n_feasible}, NP={a.n_pareto})",
        shapes=shapes,
        height=side,
        dragmode="select",
        legend={"orientation": "h", "y": 1.02, "x": 0.5},
    )
    _annotate(fig, _decimation_note(rows, counts, seed), y=1.04)
    return fig


# -- histograms -------------------------------------------------------------------------------


def _hist_traces(h: Histogram, show_all: bool, showlegend: bool) -> list[go.Bar]:
    out = []
    if show_all:
        out.append(
            go.Bar(
                x=h.centres,
                y=h.all,
                width=h.widths,
                name="all trials",
                legendgroup="all",
                showlegend=showlegend,
                marker={"color": "#cccccc"},
                meta={"class": "all", "total": int(h.all.sum())},
            )
        )
    out.append(
        go.Bar(
            x=h.centres,
            y=h.feasible,
            width=h.widths,
            name="feasible (in D)",
            legendgroup="feasible",
            showlegend=showlegend,
            marker={"color": CLASS_COLOURS["feasible"]},
            meta={"class": "feasible", "total": int(h.feasible.sum())},
        )
    )
    out.append(
        go.Bar(
            x=h.centres,
            y=h.pareto,
            width=h.widths,
            name="Pareto",
            legendgroup="pareto",
            showlegend=showlegend,
            marker={"color": CLASS_COLOURS["pareto"]},
            meta={"class": "pareto", "total": int(h.pareto.sum())},
        )
    )
    return out


def stage_histograms_figure(hists: Sequence[Histogram], *, show_all: bool = True) -> go.Figure:
    """The same parameter's histogram in successive stages, one above the other on common
    bins (seed 001 Fig. 5: before and after double tuning)."""
    titles = []
    for h in hists:
        tot = int(h.all.sum())
        share = 100.0 * h.feasible.sum() / tot if tot else float("nan")
        titles.append(
            f"stage {h.stage}: {tot} trials, {int(h.feasible.sum())} feasible ({share:.0f}%)"
        )
    fig = make_subplots(rows=len(hists), cols=1, subplot_titles=titles, shared_xaxes=True)
    for i, h in enumerate(hists):
        for tr in _hist_traces(h, show_all, i == 0):
            fig.add_trace(tr, row=i + 1, col=1)
    fig.update_layout(
        template=TEMPLATE,
        title=f"Double tuning: {hists[0].param if hists else ''} by stage",
        barmode="overlay",
        bargap=0,
        height=260 * max(len(hists), 1) + 80,
    )
    fig.update_xaxes(title_text=hists[0].param if hists else "", row=len(hists), col=1)
    return fig


# -- sections, refine, correlation, spread, robustness, sensitivity ---------------------------


def section_figure(
    section: Section, limits: Mapping[str, Sequence[float]] | None = None
) -> go.Figure:
    """Each criterion along a section through a trial (seed 000 Fig. 10, seed 001 Fig. 12),
    one panel per criterion; the chosen trial is marked and criteria constraints drawn.

    Parameters
    ----------
    section : Section
    limits : mapping criterion -> (low, high), optional
        E.g. ``Analysis.bounds``; infinite values are skipped.
    """
    k = len(section.crit_names)
    fig = make_subplots(
        rows=k, cols=1, shared_xaxes=True, subplot_titles=section.crit_names, vertical_spacing=0.06
    )
    # the row of the section that is the chosen trial itself (absent if outside the range)
    at = np.flatnonzero(np.all(section.X == section.x0[None, :], axis=1))
    ok = section.status == 0
    for c, name in enumerate(section.crit_names):
        y = np.where(ok, section.F[:, c], np.nan)
        fig.add_trace(
            go.Scatter(
                x=section.values,
                y=y,
                mode="lines+markers",
                name=name,
                showlegend=False,
                customdata=_ids(section.ids),
                hovertemplate=f"{section.param}=%{{x:.6g}}<br>{name}=%{{y:.6g}}<extra></extra>",
                line={"color": CLASS_COLOURS["feasible"]},
                marker={"size": 5},
            ),
            row=c + 1,
            col=1,
        )
        fig.add_trace(
            go.Scatter(
                x=[section.values[at[0]]] if len(at) else [],
                y=[section.f0[c]] if len(at) else [],
                mode="markers",
                name=f"trial {section.trial}",
                showlegend=c == 0,
                marker={"color": CLASS_COLOURS["pareto"], "size": 11, "symbol": "diamond"},
            ),
            row=c + 1,
            col=1,
        )
        if limits and name in limits:
            for v in limits[name]:
                if math.isfinite(v):
                    fig.add_hline(y=v, line=LIMIT_LINE, row=c + 1, col=1)
    failed = int((~ok).sum())
    fig.update_layout(
        template=TEMPLATE,
        title=f"Section through trial {section.trial} along {section.param} "
        f"({len(section.values)} points{f', {failed} failed' if failed else ''})",
        height=max(320, 200 * k + 100),
    )
    fig.update_xaxes(title_text=section.param, row=k, col=1)
    return fig


def refine_figure(proposal: RefineProposal, a: Analysis | None = None) -> go.Figure:
    """Old and proposed box per parameter, normalised to the study box, with the feasible
    and Pareto trials' values as ticks (double tuning, seed 001 Sec. VI)."""
    space = a.spec.space if a is not None else proposal.old
    lows, highs = space.lows, space.highs
    width = np.where(highs > lows, highs - lows, 1.0)
    names = space.names
    fig = go.Figure()
    y = list(range(len(names)))
    for label, box, colour, thick in (
        ("current box", proposal.old, "#bbbbbb", 18),
        ("proposed box", proposal.new, CLASS_COLOURS["feasible"], 8),
    ):
        lo = (box.lows - lows) / width
        hi = (box.highs - lows) / width
        fig.add_trace(
            go.Bar(
                y=y,
                x=hi - lo,
                base=lo,
                orientation="h",
                name=label,
                width=0.8 if thick == 18 else 0.35,
                marker={"color": colour},
                customdata=np.column_stack([box.lows, box.highs]),
                text=names,
                hovertemplate="%{text}: [%{customdata[0]:.6g}, %{customdata[1]:.6g}]<extra>"
                + label
                + "</extra>",
            )
        )
    if a is not None:
        for name, mask in (("feasible", a.feasible & ~a.pareto), ("pareto", a.pareto)):
            idx = subsample(mask, 2000, 0)
            if not len(idx):
                continue
            U = (a.trials.X[idx] - lows) / width
            fig.add_trace(
                go.Scatter(
                    x=_compact(U.ravel()),
                    y=np.repeat(
                        np.arange(len(names), dtype=np.int16)[None, :], len(idx), axis=0
                    ).ravel(),
                    mode="markers",
                    name=_CLASS_LABEL[name] + " trials",
                    marker={
                        "symbol": "line-ns-open",
                        "size": 10,
                        "color": CLASS_COLOURS[name],
                        "opacity": 0.5,
                    },
                    hoverinfo="skip",
                )
            )
    fig.update_layout(
        template=TEMPLATE,
        barmode="overlay",
        title=f"Double tuning proposal from the {proposal.basis} set "
        f"(quantile {proposal.quantile:g}, margin {proposal.margin:g}): volume ratio "
        f"{proposal.volume_ratio:.3g}, Pareto trials outside {proposal.pareto_outside}",
        xaxis={"title": "position in the study box (0 = low, 1 = high)", "range": [-0.02, 1.02]},
        yaxis={"autorange": "reversed", "tickvals": y, "ticktext": names},
        height=max(300, 28 * len(y) + 140),
    )
    return fig


def correlation_figure(corr: CorrelationResult) -> go.Figure:
    """Correlation matrix of parameters among near-optimal vectors (seed 000 Fig. 14);
    cells with ``|r|`` at or above the threshold carry their value."""
    R = corr.matrix
    text = np.where(
        (np.abs(R) >= corr.threshold) & ~np.eye(len(R), dtype=bool),
        np.vectorize(lambda v: f"{v:.2f}")(R),
        "",
    )
    fig = go.Figure(
        go.Heatmap(
            z=R,
            x=corr.names,
            y=corr.names,
            zmin=-1,
            zmax=1,
            colorscale="RdBu",
            reversescale=True,
            text=text,
            texttemplate="%{text}",
            hovertemplate="%{y} – %{x}: r = %{z:.3f}<extra></extra>",
            colorbar={"title": "r"},
        )
    )
    groups = "; ".join("{" + ", ".join(g) + "}" for g in corr.groups) or "none"
    fig.update_layout(
        template=TEMPLATE,
        title=f"{corr.method.title()} correlation over {corr.n} trials"
        + (" (importance-weighted)" if corr.weighted else "")
        + "; |r| ≥ "
        f"{corr.threshold:g} groups: {groups}",
        yaxis={"autorange": "reversed"},
        height=max(420, 24 * len(corr.names) + 160),
        width=max(520, 24 * len(corr.names) + 240),
    )
    return fig


def spread_figure(spread: Spread, verdicts: Sequence[Any] | None = None) -> go.Figure:
    """Chosen vectors relative to nominal (seed 000 Fig. 13): one line per vector over the
    parameters; the nominal is the line at 1 (parameters without a nominal are shown as the
    position in their box, marked ``[box]``).

    With ``verdicts`` (:func:`vectorid.analysis.identifiability.identifiability`, one per
    parameter), each parameter's feasible range (blue band) and Pareto range (green) are
    drawn on the same scale and its verdict is written under its name: a vector's value of a
    parameter the data do not identify is one value among those the band allows, not an
    estimate (its marker is hollow)."""
    ver = {getattr(v, "name", ""): v for v in verdicts or ()}
    labels = [n + (" [box]" if m == "box" else "") for n, m in zip(spread.names, spread.mode)]
    if ver:
        labels = [
            lab + (f"<br>{ver[n].verdict}" if n in ver else "")
            for lab, n in zip(labels, spread.names)
        ]

    def rel(j: int, x: float) -> float:
        if spread.mode[j] == "nominal":
            return x / spread.nominal[j]
        w = spread.highs[j] - spread.lows[j]
        return (x - spread.lows[j]) / (w if w > 0 else 1.0)

    fig = go.Figure()
    for kind, width, name in (
        ("feasible", 16, "feasible range (D)"),
        ("pareto", 5, "Pareto range"),
    ):
        xs: list[Any] = []
        ys: list[Any] = []
        text: list[Any] = []
        for j, n in enumerate(spread.names):
            v = ver.get(n)
            r = getattr(v, kind, None) if v is not None else None
            if r is None:
                continue
            xs += [labels[j], labels[j], None]
            ys += [rel(j, r[0]), rel(j, r[1]), None]
            span = f"{n} {kind}: [{r[0]:.4g}, {r[1]:.4g}] ({v.verdict})"
            text += [span, span, None]
        if xs:
            fig.add_trace(
                go.Scatter(
                    x=xs,
                    y=ys,
                    mode="lines",
                    name=name,
                    text=text,
                    hoverinfo="text",
                    opacity=0.35 if kind == "feasible" else 0.8,
                    line={"color": CLASS_COLOURS[kind], "width": width},
                )
            )
    open_ = [n in ver and not ver[n].identified for n in spread.names]
    for i, lab in enumerate(spread.labels):
        colour = _RUN_COLOURS[i % len(_RUN_COLOURS)]
        fig.add_trace(
            go.Scatter(
                x=labels,
                y=spread.relative[i],
                mode="lines+markers",
                name=lab,
                customdata=spread.values[i],
                hovertemplate="%{x}: %{customdata:.6g} (relative %{y:.3f})<extra>"
                + lab
                + "</extra>",
                line={"color": colour},
                marker={
                    "symbol": ["circle-open" if o else "circle" for o in open_],
                    "size": 9,
                    "color": colour,
                },
            )
        )
    if np.any(spread.mode == "nominal"):
        fig.add_hline(y=1.0, line=LIMIT_LINE, annotation_text="nominal")
    title = "Parameter spread of the chosen vectors relative to nominal"
    if ver:
        title += (
            "<br><sub>bands: feasible (blue) and Pareto (green) ranges; hollow marker: "
            "not identified, one value the data allow</sub>"
        )
    fig.update_layout(
        template=TEMPLATE,
        title=title,
        yaxis_title="value / nominal",
        height=460,
    )
    return fig


def robustness_figure(checks: Sequence[Robustness]) -> go.Figure:
    """Criteria over the neighbourhood of each checked trial (seed 001 Table 4 and
    Sec. VI.D): one panel per criterion, a box of the neighbourhood's values per trial, the
    trial's own value as a diamond, and the verdict in the axis label."""
    if not checks:
        return go.Figure().update_layout(template=TEMPLATE, title="No robustness check stored")
    names = checks[0].crit_names
    fig = make_subplots(rows=1, cols=len(names), subplot_titles=names)
    for c in range(len(names)):
        for i, chk in enumerate(checks):
            ok = chk.status == 0
            lab = f"{chk.trial}<br>{chk.verdicts[c]}"
            fig.add_trace(
                go.Box(
                    y=chk.F[ok, c],
                    x=[lab] * int(ok.sum()),
                    name=str(chk.trial),
                    marker={"color": _RUN_COLOURS[i % len(_RUN_COLOURS)]},
                    boxpoints="all",
                    jitter=0.4,
                    pointpos=0,
                    showlegend=False,
                ),
                row=1,
                col=c + 1,
            )
            fig.add_trace(
                go.Scatter(
                    x=[lab],
                    y=[chk.f0[c]],
                    mode="markers",
                    marker={"symbol": "diamond", "size": 12, "color": "black"},
                    showlegend=False,
                    hovertemplate="stored value %{y:.6g}<extra></extra>",
                ),
                row=1,
                col=c + 1,
            )
    fig.update_layout(
        template=TEMPLATE,
        title="Robustness: criteria in the neighbourhood of the chosen trials ("
        + "; ".join(f"{c.trial}: {c.verdict}" for c in checks)
        + ")",
        height=460,
        width=max(600, 260 * len(names)),
    )
    return fig


def sensitivity_figure(sens: Sensitivity) -> go.Figure:
    """Spearman rank correlation parameter × criterion, and the KS statistic per parameter
    between the feasible set and the rest (Monte Carlo filtering)."""
    fig = make_subplots(
        rows=1,
        cols=2,
        column_widths=[0.6, 0.4],
        subplot_titles=[
            "Spearman ρ (parameter, criterion)"
            + (", importance-weighted" if sens.weighted else ""),
            f"KS statistic: D ({sens.n_behavioural}) vs rest ({sens.n_other})"
            + (", importance-weighted" if sens.weighted else ""),
        ],
        horizontal_spacing=0.18,
    )
    fig.add_trace(
        go.Heatmap(
            z=sens.spearman,
            x=sens.criteria,
            y=sens.params,
            zmin=-1,
            zmax=1,
            colorscale="RdBu",
            reversescale=True,
            texttemplate="%{z:.2f}",
            colorbar={"x": 0.5, "title": "ρ"},
            hovertemplate="%{y} → %{x}: ρ = %{z:.3f}<extra></extra>",
        ),
        row=1,
        col=1,
    )
    fig.add_trace(
        go.Bar(
            x=sens.ks,
            y=sens.params,
            orientation="h",
            marker={"color": CLASS_COLOURS["feasible"]},
            customdata=sens.ks_pvalue,
            hovertemplate="%{y}: KS = %{x:.3f}, p = %{customdata:.2g}<extra></extra>",
            showlegend=False,
        ),
        row=1,
        col=2,
    )
    fig.update_yaxes(autorange="reversed")
    fig.update_layout(
        template=TEMPLATE,
        title="Sensitivity from the existing trials",
        height=max(380, 26 * len(sens.params) + 160),
    )
    return fig


# -- identification views (plain arrays) --------------------------------------------------------


def _xyz(a: Any, what: str) -> np.ndarray:
    a = np.asarray(a, float)
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(
            f"{what}: expected positions of shape (n, 3) [north, east, up], got {a.shape}"
        )
    return a


def trajectory_figure(
    flight: np.ndarray,
    runs: Mapping[str, np.ndarray] | None = None,
    *,
    title: str = "Trajectories: flight and model",
) -> go.Figure:
    """Horizontal projection and altitude vs horizontal distance from the start, for the
    flight and any number of simulated runs (seed 000 Fig. 11: the best trial per
    criterion and the nominal model).

    Parameters
    ----------
    flight : (n, 3) float
        Flight positions in a local tangent plane: north, east, up (m).
    runs : mapping label -> (m, 3) float
        Simulated positions, same frame.
    """
    series = {"flight": _xyz(flight, "flight")}
    for k, v in (runs or {}).items():
        series[k] = _xyz(v, k)
    fig = make_subplots(
        rows=1,
        cols=2,
        subplot_titles=["horizontal projection", "altitude vs distance from start"],
    )
    for i, (lab, P) in enumerate(series.items()):
        colour = "black" if lab == "flight" else _RUN_COLOURS[i % len(_RUN_COLOURS)]
        dash = "solid" if lab == "flight" else None
        dist = np.hypot(P[:, 0] - P[0, 0], P[:, 1] - P[0, 1])
        fig.add_trace(
            go.Scatter(
                x=P[:, 1],
                y=P[:, 0],
                mode="lines",
                name=lab,
                legendgroup=lab,
                line={"color": colour, "width": 3 if lab == "flight" else 1.6, "dash": dash},
            ),
            row=1,
            col=1,
        )
        fig.add_trace(
            go.Scatter(
                x=dist,
                y=P[:, 2],
                mode="lines",
                name=lab,
                legendgroup=lab,
                showlegend=False,
                line={"color": colour, "width": 3 if lab == "flight" else 1.6},
            ),
            row=1,
            col=2,
        )
    fig.update_xaxes(title_text="east, m", row=1, col=1)
    fig.update_yaxes(title_text="north, m", scaleanchor="x", scaleratio=1, row=1, col=1)
    fig.update_xaxes(title_text="horizontal distance, m", row=1, col=2)
    fig.update_yaxes(title_text="altitude, m", row=1, col=2)
    fig.update_layout(template=TEMPLATE, title=title, height=520)
    return fig


def trajectory3d_figure(
    flight: np.ndarray,
    runs: Mapping[str, np.ndarray] | None = None,
    *,
    title: str = "3-D trajectories",
) -> go.Figure:
    """3-D projection of the flight and simulated trajectories (seed 001 Fig. 7).

    Parameters are as :func:`trajectory_figure` (positions north, east, up in m)."""
    series = {"flight": _xyz(flight, "flight")}
    for k, v in (runs or {}).items():
        series[k] = _xyz(v, k)
    fig = go.Figure()
    for i, (lab, P) in enumerate(series.items()):
        fig.add_trace(
            go.Scatter3d(
                x=P[:, 1],
                y=P[:, 0],
                z=P[:, 2],
                mode="lines",
                name=lab,
                line={
                    "color": "black" if lab == "flight" else _RUN_COLOURS[i % len(_RUN_COLOURS)],
                    "width": 6 if lab == "flight" else 3,
                },
            )
        )
    fig.update_layout(
        template=TEMPLATE,
        title=title,
        scene={"xaxis_title": "east, m", "yaxis_title": "north, m", "zaxis_title": "up, m"},
        height=560,
    )
    return fig


def channels_figure(
    t: np.ndarray,
    flight: Mapping[str, np.ndarray],
    runs: Sequence[tuple[np.ndarray, Mapping[str, np.ndarray]]] = (),
    *,
    labels: Sequence[str] | None = None,
    units: Mapping[str, str] | None = None,
    show_runs: bool | Sequence[int] = True,
    bands: Mapping[str, tuple[np.ndarray, np.ndarray]] | None = None,
    title: str = "Channels: flight and model runs",
) -> go.Figure:
    """Time histories of channels (e.g. Euler angles, velocities), the flight against the
    envelope (min–max band and median) of several simulated runs (seed 001 Figs. 1–2, 9).

    Parameters
    ----------
    t : (n,) float
        Flight time base, s.
    flight : mapping channel -> (n,) float
    runs : sequence of (time (m,), mapping channel -> (m,))
        Simulated runs, each on its own time base.
    labels : sequence of str, optional
        One per run (legend when ``show_runs``).
    units : mapping channel -> unit, optional
    show_runs : bool or sequence of int
        Draw every run (True), none (False: envelope and median only), or the runs at these
        indices (drawn bold, e.g. the chosen vector over the envelope of the Pareto set).
    bands : mapping channel -> (low (n,), high (n,)), optional
        A band on the flight's time base drawn as dashed red lines, e.g. the drop-out
        envelope ``measurement ± band`` of seed 001 Fig. 2.
    """
    names = list(flight)
    t = np.asarray(t, float)
    fig = make_subplots(
        rows=len(names), cols=1, shared_xaxes=True, subplot_titles=names, vertical_spacing=0.05
    )
    for c, ch in enumerate(names):
        row = c + 1
        chan_runs = [(tr, vals[ch]) for tr, vals in runs if ch in vals]
        if chan_runs:
            lo, med, hi = envelope(t, chan_runs)
            fig.add_trace(
                go.Scatter(
                    x=t, y=hi, mode="lines", line={"width": 0}, showlegend=False, hoverinfo="skip"
                ),
                row=row,
                col=1,
            )
            fig.add_trace(
                go.Scatter(
                    x=t,
                    y=lo,
                    mode="lines",
                    line={"width": 0},
                    fill="tonexty",
                    fillcolor="rgba(31,119,180,0.2)",
                    name="model envelope (min–max)",
                    legendgroup="env",
                    showlegend=c == 0,
                ),
                row=row,
                col=1,
            )
            fig.add_trace(
                go.Scatter(
                    x=t,
                    y=med,
                    mode="lines",
                    line={"color": CLASS_COLOURS["feasible"], "dash": "dot"},
                    name="model median",
                    legendgroup="med",
                    showlegend=c == 0,
                ),
                row=row,
                col=1,
            )
            if isinstance(show_runs, bool):
                shown = list(range(len(chan_runs))) if show_runs else []
                bold = False
            else:
                shown = [int(i) for i in show_runs if 0 <= int(i) < len(chan_runs)]
                bold = True
            for k, i in enumerate(shown):
                tr, yr = chan_runs[i]
                lab = labels[i] if labels and i < len(labels) else f"run {i + 1}"
                colour = _RUN_COLOURS[(k + 1 if bold else i) % len(_RUN_COLOURS)]
                fig.add_trace(
                    go.Scatter(
                        x=tr,
                        y=yr,
                        mode="lines",
                        line={"width": 2 if bold else 0.8, "color": colour},
                        opacity=1.0 if bold else 0.6,
                        name=lab,
                        legendgroup=lab,
                        showlegend=c == 0,
                    ),
                    row=row,
                    col=1,
                )
        if bands and ch in bands:
            lo_b, hi_b = (np.asarray(b, float) for b in bands[ch])
            for j, yb in enumerate((lo_b, hi_b)):
                fig.add_trace(
                    go.Scatter(
                        x=t,
                        y=yb,
                        mode="lines",
                        line={"color": CLASS_COLOURS["infeasible"], "width": 1.2, "dash": "dash"},
                        name="drop-out envelope",
                        legendgroup="dropout",
                        showlegend=j == 0 and ch == next(n for n in names if n in bands),
                    ),
                    row=row,
                    col=1,
                )
        fig.add_trace(
            go.Scatter(
                x=t,
                y=np.asarray(flight[ch], float),
                mode="lines",
                line={"color": "black", "width": 2},
                name="flight",
                legendgroup="flight",
                showlegend=c == 0,
            ),
            row=row,
            col=1,
        )
        unit = (units or {}).get(ch, "")
        fig.update_yaxes(title_text=f"{ch}{', ' + unit if unit else ''}", row=row, col=1)
    fig.update_xaxes(title_text="time, s", row=len(names), col=1)
    fig.update_layout(template=TEMPLATE, title=title, height=max(320, 220 * len(names) + 80))
    return fig


def spectra_figure(
    t: np.ndarray,
    flight: Mapping[str, np.ndarray],
    runs: Mapping[str, tuple[np.ndarray, Mapping[str, np.ndarray]]] | None = None,
    *,
    nperseg: int | None = None,
    title: str = "Power spectra of the Euler angles",
    unit: str = "rad",
) -> go.Figure:
    """Power spectral densities (Welch) of the flight's channels and of simulated runs,
    one panel per channel, log scale (seed 000 Sec. VII, seed 001 Table I criteria 13–15).

    Parameters
    ----------
    t : (n,) float
        Flight time, s.
    flight : mapping channel -> (n,) float
        E.g. ``{"roll": phi, "pitch": theta, "yaw": psi}`` in rad.
    runs : mapping label -> (time, mapping channel -> values)
    nperseg : int, optional
        Welch segment length.
    unit : str
        Unit of the channels (the PSD is in unit²/Hz).
    """
    names = list(flight)
    fig = make_subplots(rows=1, cols=len(names), subplot_titles=names)
    series = {"flight": (t, flight)}
    series.update(runs or {})
    for i, (lab, (tt, chans)) in enumerate(series.items()):
        colour = "black" if lab == "flight" else _RUN_COLOURS[i % len(_RUN_COLOURS)]
        for c, ch in enumerate(names):
            if ch not in chans:
                continue
            f, p = power_spectrum(tt, chans[ch], nperseg=nperseg)
            fig.add_trace(
                go.Scatter(
                    x=f[1:],
                    y=p[1:],
                    mode="lines",
                    name=lab,
                    legendgroup=lab,
                    showlegend=c == 0,
                    line={"color": colour, "width": 2 if lab == "flight" else 1.3},
                ),
                row=1,
                col=c + 1,
            )
    fig.update_yaxes(type="log", title_text=f"PSD, {unit}²/Hz", col=1)
    fig.update_yaxes(type="log")
    fig.update_xaxes(type="log", title_text="frequency, Hz")
    fig.update_layout(template=TEMPLATE, title=title, height=420)
    return fig
