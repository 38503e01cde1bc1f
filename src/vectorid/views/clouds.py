"""Point clouds and per-set histograms that stay truthful at any number of trials.

Each set keeps its colour (seed 001 Fig. 6: infeasible red, feasible blue, Pareto green) and
is drawn so that it stays visible at 1e6 trials:

* **infeasible** trials, usually the bulk, are drawn as a *density* (a 2-D histogram of every
  infeasible trial, log-scaled red shades) when there are more of them than the point budget,
  otherwise as points;
* **feasible** and **Pareto** trials are drawn as points; a set larger than the budget is
  thinned to a uniform random subset (fixed seed), so one fraction applies to the whole set and
  its density on screen is proportional to its density in the data; the legend says
  "N drawn of M (f %)" for every thinned set;
* the legend toggles each set; the selection is drawn *in the set colours* (larger points
  with a dark outline) so it never hides which set a trial is in.

Histograms are drawn per set on its own scale (share of the set, %), as step lines, so the
Pareto set's 30 trials are as readable as the feasible set's 30,000; the counts are in the
hover text.

Every trace's ``meta`` holds ``{"class", "count", "shown", "drawn_as"}`` (point clouds) or
``{"class", "total"}`` (histograms).
"""

from __future__ import annotations

import base64
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import plotly.graph_objects as go

from ..analysis.classes import CLASS_COLOURS, PointClasses, point_classes, subsample
from ..analysis.histograms import Histogram
from ..analysis.results import Analysis
from ..errors import StudyDefinitionError, suggest

__all__ = [
    "HIST_SETS",
    "SET_LABEL",
    "axis_title",
    "cloud_traces",
    "column",
    "counts_title",
    "criterion_vs_parameter_figure",
    "density_grid",
    "density_of_cells",
    "fitted_range",
    "grid_cells",
    "histograms_figure",
    "limits_of",
    "scatter_figure",
    "thin",
]

#: A small light template (the full "plotly_white" costs ~40 ms to copy into each figure and
#: ~10 kB of JSON per figure).
LIGHT_LAYOUT: dict[str, Any] = {
    "paper_bgcolor": "white",
    "plot_bgcolor": "white",
    "font": {"color": "#2a3f5f"},
    "colorway": ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b"],
    # ticklabeloverflow "allow": plotly.js otherwise measures every tick label of every axis
    # (a forced layout per label) to hide those past the figure's edge, which ours never
    # pass: a third of the histogram grid's drawing in the browser
    "xaxis": {
        "gridcolor": "#ebf0f8",
        "zerolinecolor": "#ebf0f8",
        "linecolor": "#bbb",
        "ticklabeloverflow": "allow",
    },
    "yaxis": {
        "gridcolor": "#ebf0f8",
        "zerolinecolor": "#ebf0f8",
        "linecolor": "#bbb",
        "ticklabeloverflow": "allow",
    },
    "hoverlabel": {"align": "left"},
}
TEMPLATE = go.layout.Template(layout=LIGHT_LAYOUT)
LIMIT_LINE = {"color": "#444", "width": 1.2, "dash": "dash"}
#: Legend names of the three colour classes; they partition the trials, so their counts add
#: up to N, and "in D, not Pareto" + "Pareto" to ND.
SET_LABEL = {"infeasible": "infeasible", "feasible": "in D, not Pareto", "pareto": "Pareto"}
#: The chosen trial (orange star) and the proposed refine box (purple).
CHOSEN_COLOUR = "#ff7f0e"
PROPOSED_COLOUR = "#9467bd"
_DENSITY_SCALE = [[0.0, "rgba(214,39,40,0.0)"], [0.001, "rgba(214,39,40,0.12)"], [1.0, "#8b0000"]]
#: D's density (blue, translucent so that the red density under it shows through).
_DENSITY_SCALE_D = [
    [0.0, "rgba(31,119,180,0.0)"],
    [0.001, "rgba(31,119,180,0.18)"],
    [1.0, "rgba(8,48,107,0.85)"],
]


def b64(v: Any) -> dict[str, str]:
    """A numpy array as plotly.js's typed-array spec (``{"dtype", "bdata"}``): a fraction of
    the JSON text of a list of numbers, and decoded without parsing in the browser."""
    a = np.ascontiguousarray(v)
    if a.dtype == np.float64:
        a = a.astype(np.float32)
    elif a.dtype == np.int64:
        a = a.astype(np.int32)
    elif a.dtype == np.bool_:
        a = a.astype(np.uint8)
    code = {"float32": "f4", "int32": "i4", "int8": "i1", "uint8": "u1", "int16": "i2"}[
        str(a.dtype)
    ]
    out = {"dtype": code, "bdata": base64.b64encode(a.tobytes()).decode()}
    if a.ndim == 2:
        out["shape"] = f"{a.shape[0]}, {a.shape[1]}"
    return out


def _plain(v: Any) -> Any:
    return v


def figure(d: dict[str, Any], raw: bool) -> Any:
    """``d`` itself (``raw``: the UI sends it as it is) or a validated ``go.Figure``."""
    if raw:
        return d
    return go.Figure(d)


def grid_layout(
    n: int,
    ncol: int,
    titles: Sequence[str] | None = None,
    *,
    hspace: float = 0.05,
    vspace: float | None = None,
    shared_y: bool = False,
) -> tuple[dict[str, Any], list[tuple[str, str]]]:
    """Axes of an ``n``-panel grid (``ncol`` columns) as layout entries, with panel titles
    as annotations; returns the layout and each panel's ``(xaxis, yaxis)`` names (what
    ``make_subplots`` does, without its cost)."""
    ncol = max(1, min(ncol, n))
    nrow = max(1, math.ceil(n / ncol))
    vspace = min(0.12, 0.55 / nrow) if vspace is None else vspace
    w = (1.0 - hspace * (ncol - 1)) / ncol
    h = (1.0 - vspace * (nrow - 1)) / nrow
    layout: dict[str, Any] = {"annotations": []}
    names = []
    for i in range(n):
        r, c = divmod(i, ncol)
        k = "" if i == 0 else str(i + 1)
        x0 = c * (w + hspace)
        y1 = 1.0 - r * (h + vspace)
        xa, ya = f"xaxis{k}", f"yaxis{k}"
        clip = lambda v: min(1.0, max(0.0, round(v, 9)))  # noqa: E731 - float residue
        layout[xa] = {"domain": [clip(x0), clip(x0 + w)], "anchor": f"y{k}"}
        layout[ya] = {"domain": [clip(y1 - h), clip(y1)], "anchor": f"x{k}"}
        if shared_y and c > 0:
            first = "" if r * ncol == 0 else str(r * ncol + 1)
            layout[ya]["matches"] = f"y{first}"
            layout[ya]["showticklabels"] = False
        names.append((f"x{k}", f"y{k}"))
        if titles is not None and i < len(titles):
            layout["annotations"].append(
                {
                    "text": titles[i],
                    "x": x0 + w / 2,
                    "y": y1,
                    "xref": "paper",
                    "yref": "paper",
                    "xanchor": "center",
                    "yanchor": "bottom",
                    "showarrow": False,
                    "font": {"size": 11},
                }
            )
    return layout, names


def compact(v: np.ndarray) -> np.ndarray:
    """float32 copy (halves the payload; ~7 significant digits, enough to draw and hover)."""
    return np.asarray(v, dtype=np.float32)


def ids32(v: np.ndarray) -> np.ndarray:
    v = np.asarray(v)
    return v.astype(np.int32) if len(v) == 0 or int(v.max()) < 2**31 - 1 else v.astype(float)


def column(a: Analysis, name: str) -> tuple[np.ndarray, str]:
    """Values of a criterion, functional or parameter over the trials, and its kind."""
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


def limits_of(a: Analysis, name: str) -> list[float]:
    """Finite constraint values on ``name`` (criteria and functional constraints)."""
    if name not in a.bounds:
        return []
    return [v for v in a.bounds[name] if math.isfinite(v)]


def axis_title(name: str, labels: Any = None) -> str:
    """``labels.axis(name)`` when labels are given (unit and meaning), else the name."""
    return labels.axis(name) if labels is not None else name


def thin(
    classes: PointClasses, budget: int | None, seed: int = 0
) -> tuple[dict[str, np.ndarray], dict[str, int]]:
    """Rows drawn per set (failed trials excluded: their criteria are NaN).

    Each set holding more than ``budget`` drawable trials is thinned to ``budget`` of them
    (a uniform random subset, ``seed``); a smaller set is drawn whole. So within a set the
    drawn density is proportional to the data's, and the legend names the fraction.

    Returns
    -------
    rows : dict
        Set name -> row indices drawn.
    counts : dict
        Set name -> drawable trials in the set.
    """
    rows: dict[str, np.ndarray] = {}
    counts: dict[str, int] = {}
    for name, mask in classes.items():
        m = mask & ~classes.failed
        counts[name] = int(m.sum())
        rows[name] = subsample(m, budget, seed)
    return rows, counts


def _legend(name: str, count: int, shown: int, n_failed: int, density: bool) -> str:
    label = SET_LABEL[name]
    if density:
        text = f"{label} ({count:,}, all as a density)"
    elif shown < count:
        text = f"{label} ({count:,}; {shown:,} drawn, {100.0 * shown / count:.2g} %)"
    else:
        text = f"{label} ({count:,})"
    if name == "infeasible" and n_failed:
        text += f"; {n_failed:,} failed not drawn"
    return text


def _grid_edges(
    x: np.ndarray, y: np.ndarray, bins: int, span: tuple[float, float, float, float] | None
) -> tuple[np.ndarray, np.ndarray]:
    x0, x1, y0, y1 = span or (float(x.min()), float(x.max()), float(y.min()), float(y.max()))
    xe = np.linspace(x0, x1 or 1.0, bins + 1)
    ye = np.linspace(y0, y1 or 1.0, bins + 1)
    if xe[-1] <= xe[0]:
        xe = np.linspace(xe[0] - 0.5, xe[0] + 0.5, bins + 1)
    if ye[-1] <= ye[0]:
        ye = np.linspace(ye[0] - 0.5, ye[0] + 0.5, bins + 1)
    return xe, ye


def density_grid(
    x: np.ndarray,
    y: np.ndarray,
    bins: int = 80,
    span: tuple[float, float, float, float] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """2-D histogram of finite ``(x, y)``: cell centres (bins,), (bins,) and counts
    (bins, bins) indexed ``[y, x]``; over ``span`` = (x low, x high, y low, y high) when
    given (so that several sets share one grid), else over the data's range."""
    ok = np.isfinite(x) & np.isfinite(y)
    x, y = x[ok], y[ok]
    if len(x) == 0:
        return np.zeros(0), np.zeros(0), np.zeros((0, 0))
    xe, ye = _grid_edges(x, y, bins, span)
    h, _, _ = np.histogram2d(x, y, bins=(xe, ye))
    return 0.5 * (xe[1:] + xe[:-1]), 0.5 * (ye[1:] + ye[:-1]), h.T


def grid_cells(
    x: np.ndarray, y: np.ndarray, bins: int, span: tuple[float, float, float, float]
) -> np.ndarray:
    """Each point's cell of :func:`density_grid`'s grid over ``span`` (``ix * bins + iy``,
    as ``np.histogram2d`` bins it: the last edge closed), ``bins * bins`` where the point is
    not finite or off the grid; uint16 up to 255 bins. Kept per store, the density of any
    subset is one ``bincount`` (:func:`density_of_cells`)."""
    xe, ye = _grid_edges(x, y, bins, span)
    out = None
    for v, e in ((x, xe), (y, ye)):
        with np.errstate(invalid="ignore"):
            i = np.searchsorted(e, v, side="right")
            i[v == e[-1]] -= 1
            i -= 1
            bad = (i < 0) | (i >= bins) | ~np.isfinite(v)
        i[bad] = -1
        out = i if out is None else np.where((out < 0) | (i < 0), -1, out * bins + i)
    out = np.where(out < 0, bins * bins, out)
    return out.astype(np.uint16 if bins < 256 else np.int32)


def density_of_cells(
    cells: np.ndarray, mask: np.ndarray, bins: int, span: tuple[float, float, float, float]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`density_grid` of the points ``mask`` picks, from their :func:`grid_cells`."""
    xe, ye = _grid_edges(np.zeros(1), np.zeros(1), bins, span)
    h = np.bincount(cells[mask], minlength=bins * bins + 1)[: bins * bins]
    h = h.reshape(bins, bins).astype(float)
    return 0.5 * (xe[1:] + xe[:-1]), 0.5 * (ye[1:] + ye[:-1]), h.T


def _finite_range(v: np.ndarray) -> tuple[float, float]:
    f = v[np.isfinite(v)]
    if not len(f):
        return 0.0, 1.0
    lo, hi = float(f.min()), float(f.max())
    return (lo, hi) if hi > lo else (lo - 0.5, hi + 0.5)


def data_span(xv: np.ndarray, yv: np.ndarray) -> tuple[float, float, float, float]:
    """``(x low, x high, y low, y high)`` over the finite values."""
    return (*_finite_range(xv), *_finite_range(yv))


def _memo(memo: dict[Any, Any] | None, key: Any, make: Any) -> Any:
    if memo is None:
        return make()
    hit = memo.get(key)
    if hit is None:
        hit = memo[key] = make()
    return hit


def fitted_range(v: np.ndarray, pad: float = 0.04) -> list[float]:
    """An axis range fitted to the finite values of ``v`` (a margin of ``pad`` of the span on
    each side)."""
    lo, hi = _finite_range(v)
    d = (hi - lo) * pad
    return [lo - d, hi + d]


def cloud_traces(
    a: Analysis,
    xv: np.ndarray,
    yv: np.ndarray,
    xname: str,
    yname: str,
    *,
    budget: int | None,
    seed: int = 0,
    classes: PointClasses | None = None,
    axes: tuple[str, str] = ("x", "y"),
    showlegend: bool = True,
    size: float = 4.0,
    bins: int = 80,
    selected: np.ndarray | None = None,
    gl: bool = True,
    enc: Any = _plain,
    memo: dict[Any, Any] | None = None,
    density_above: int | None = None,
) -> list[dict[str, Any]]:
    """The traces (plain dicts) of one point cloud: infeasible density (or points), feasible
    and Pareto points (thinned per set), and, when ``selected`` is given, the selection in
    the set colours on top. ``enc`` encodes arrays (:func:`b64` for the browser). ``memo``
    (a dict kept with the loaded trials, the browser UI) keeps the data's span and each
    point's density cell per pair of columns, so a new constraint set counts its
    densities with one ``bincount`` each. ``density_above`` (default: ``budget``) is the
    size above which the infeasible set and D's non-Pareto trials are drawn as a density
    of every one of them instead of as points."""
    pc = classes or point_classes(a)
    rows, counts = thin(pc, budget, seed)
    n_failed = int(pc.failed.sum())
    if density_above is None:
        density_above = budget
    elif budget is not None:
        density_above = min(density_above, budget)
    span = None
    if density_above is not None and max(counts["infeasible"], counts["feasible"]) > density_above:
        # the densities of both sets on one grid
        span = _memo(memo, ("span", xname, yname), lambda: data_span(xv, yv))
    out: list[dict[str, Any]] = []
    ids = a.trials.id
    kind = "scattergl" if gl else "scatter"
    hover = f"trial %{{customdata}}<br>{xname}=%{{x:.5g}}<br>{yname}=%{{y:.5g}}"
    sel = selected is not None and bool(selected.any())
    for name in ("infeasible", "feasible", "pareto"):
        r = rows[name]
        # the bulk sets as densities where their points would overplot; Pareto as points
        density = name != "pareto" and density_above is not None and counts[name] > density_above
        meta = {
            "class": name,
            "count": counts[name],
            "shown": counts[name] if density else len(r),
            "drawn_as": "density" if density else "points",
        }
        legend = _legend(name, counts[name], len(r), n_failed, density)
        if density:
            m = (pc.infeasible if name == "infeasible" else pc.feasible) & ~pc.failed
            if memo is None:
                cx, cy, z = density_grid(xv[m], yv[m], bins, span=span)
            else:
                cells = _memo(
                    memo,
                    ("cells", xname, yname, span, bins),
                    lambda: grid_cells(xv, yv, bins, span),
                )
                cx, cy, z = density_of_cells(cells, m, bins, span)
            zl = np.where(z > 0, np.log10(np.maximum(z, 1)) + 1, np.nan)
            out.append(
                {
                    "type": "heatmap",
                    "x": enc(compact(cx)),
                    "y": enc(compact(cy)),
                    "z": enc(compact(zl)),
                    "customdata": (
                        z.astype(np.int32).tolist()
                        if enc is not _plain
                        else z.astype(np.int16 if z.max(initial=0) < 32767 else np.int32)
                    ),
                    "colorscale": _DENSITY_SCALE if name == "infeasible" else _DENSITY_SCALE_D,
                    "showscale": False,
                    "zsmooth": False,
                    "name": legend,
                    "legendgroup": name,
                    "showlegend": showlegend,
                    "hoverongaps": False,
                    "hovertemplate": f"{xname}≈%{{x:.4g}}, {yname}≈%{{y:.4g}}<br>"
                    f"%{{customdata}} {SET_LABEL[name]} trials in this cell<extra></extra>",
                    "xaxis": axes[0],
                    "yaxis": axes[1],
                    "meta": meta,
                }
            )
            continue
        if name == "pareto":
            opacity = 0.35 if sel else 0.95
        else:
            opacity = 0.12 if sel else 0.5
        # Pareto points as open rings the size of the others: what lies under them shows
        marker = {"color": CLASS_COLOURS[name], "size": size, "opacity": opacity}
        if name == "pareto":
            marker.update(symbol="circle-open", size=size + 2, line={"width": 1.5})
        out.append(
            {
                "type": kind,
                "x": enc(compact(xv[r])),
                "y": enc(compact(yv[r])),
                "customdata": enc(ids32(ids[r])),
                "mode": "markers",
                "name": legend,
                "legendgroup": name,
                "showlegend": showlegend,
                "marker": marker,
                "hovertemplate": hover + f"<extra>{SET_LABEL[name]}</extra>",
                "xaxis": axes[0],
                "yaxis": axes[1],
                "meta": meta,
            }
        )
    if sel:
        assert selected is not None
        n_sel = int(selected.sum())
        for name, mask in pc.items():
            m = mask & selected & np.isfinite(xv) & np.isfinite(yv)
            r = subsample(m, budget, seed)
            if not len(r):
                continue
            out.append(
                {
                    "type": kind,
                    "x": enc(compact(xv[r])),
                    "y": enc(compact(yv[r])),
                    "customdata": enc(ids32(ids[r])),
                    "mode": "markers",
                    "name": f"selected: {SET_LABEL[name]} ({int(m.sum()):,})",
                    "legendgroup": "selected",
                    "showlegend": showlegend,
                    "marker": {
                        "color": CLASS_COLOURS[name],
                        "size": size + 4,
                        "line": {"color": "#111", "width": 1.2},
                    },
                    "hovertemplate": hover + "<extra>selected</extra>",
                    "xaxis": axes[0],
                    "yaxis": axes[1],
                    "meta": {"class": "selected", "set": name, "count": n_sel, "shown": len(r)},
                }
            )
    return out


def _limit_shapes(
    a: Analysis,
    x: str,
    y: str,
    xref: str = "x",
    yref: str = "y",
    xr: Sequence[float] | None = None,
    yr: Sequence[float] | None = None,
) -> list[dict]:
    """Dashed lines at the constraints on ``x`` and ``y``; with the axes' ranges ``xr``,
    ``yr`` given, a constraint outside them is not drawn as a line (it would stretch the
    axis) but named at that edge ("off scale") by :func:`_offscale_notes`."""
    shapes = []
    for v in limits_of(a, x) if x else []:
        if xr is not None and not xr[0] <= v <= xr[1]:
            continue
        shapes.append(
            {
                "type": "line",
                "xref": xref,
                "yref": f"{yref} domain",
                "x0": v,
                "x1": v,
                "y0": 0,
                "y1": 1,
                "line": LIMIT_LINE,
            }
        )
    for v in limits_of(a, y) if y else []:
        if yr is not None and not yr[0] <= v <= yr[1]:
            continue
        shapes.append(
            {
                "type": "line",
                "xref": f"{xref} domain",
                "yref": yref,
                "x0": 0,
                "x1": 1,
                "y0": v,
                "y1": v,
                "line": LIMIT_LINE,
            }
        )
    return shapes


def _offscale_notes(
    a: Analysis,
    x: str,
    y: str,
    xr: Sequence[float],
    yr: Sequence[float],
    xref: str = "x",
    yref: str = "y",
) -> list[dict]:
    """Annotations naming the constraints beyond the fitted axes, at the edge they lie
    beyond (e.g. "f1 ≤ 200 (off scale) →")."""
    out = []
    for name, rng, axis in ((x, xr, "x"), (y, yr, "y")):
        if not name or name not in a.bounds:
            continue
        lo, hi = a.bounds[name]
        for side, v in (("low", lo), ("high", hi)):
            if not math.isfinite(v) or rng[0] <= v <= rng[1]:
                continue
            op = "≥" if side == "low" else "≤"
            above = v > rng[1]
            if axis == "x":
                text = f"{name} {op} {v:.4g} (off scale) " + ("→" if above else "←")
                pos = {"x": 1 if above else 0, "xanchor": "right" if above else "left"}
                pos.update(y=0.02, yanchor="bottom", xref=f"{xref} domain", yref=f"{yref} domain")
            else:
                text = f"{name} {op} {v:.4g} (off scale) " + ("↑" if above else "↓")
                pos = {"y": 1 if above else 0, "yanchor": "top" if above else "bottom"}
                pos.update(x=0.99, xanchor="right", xref=f"{xref} domain", yref=f"{yref} domain")
            out.append(
                {"text": text, "showarrow": False, "font": {"size": 10, "color": "#444"}, **pos}
            )
    return out


def counts_title(a: Analysis) -> str:
    """The counts as the legend splits them, adding up: "N=…: ND=… (… not Pareto + NP …) +
    … infeasible (… failed)"."""
    inf = a.n - a.n_feasible
    failed = f", of which {a.n_failed:,} failed" if a.n_failed else ""
    return (
        f"N={a.n:,} = ND {a.n_feasible:,} (in D, not Pareto {a.n_feasible - a.n_pareto:,} "
        f"+ NP {a.n_pareto:,}) + infeasible {inf:,}{failed}"
    )


def _base_layout(**kw: Any) -> dict[str, Any]:
    out: dict[str, Any] = {"template": {"layout": LIGHT_LAYOUT}}
    out.update(kw)
    return out


def scatter_figure(
    a: Analysis,
    x: str,
    y: str,
    *,
    max_points: int | None = None,
    seed: int = 0,
    title: str | None = None,
    labels: Any = None,
    selected: np.ndarray | None = None,
    gl: bool = True,
    raw: bool = False,
    memo: dict[Any, Any] | None = None,
    density_above: int | None = None,
) -> Any:
    """Criterion vs criterion (seed 001 Figs. 6, 11; seed 000 Fig. 8), or any two of
    criteria, functionals and parameters: every set in its colour, constraints as dashed
    lines.

    Parameters
    ----------
    a : Analysis
    x, y : str
        Criterion, functional or parameter names.
    max_points : int, optional
        Points drawn per set (see the module docstring); None draws every trial as a point.
    seed : int
        Seed of the thinning subsets.
    labels : Labels, optional
        Units and meanings for the axis titles (:func:`vectorid.views.ui.context.labels_of`).
    selected : (n,) bool, optional
        Trials to draw on top, in their set colours.
    gl : bool
        WebGL points (``Scattergl``); False draws SVG points (the report, where every figure
        is drawn at once and WebGL contexts are few).
    raw : bool
        Return the figure as a plain dict with base64 arrays (what the browser UI sends)
        instead of a ``go.Figure``.
    memo : dict, optional
        Kept with the loaded trials (the browser UI): spans, axis ranges and density cells
        that do not depend on the constraints (see :func:`cloud_traces`).
    density_above : int, optional
        Draw the infeasible set and D's non-Pareto trials as a density above this many
        points (default: ``max_points``; the Pareto set stays points).
    """
    xv, _ = column(a, x)
    yv, _ = column(a, y)
    enc = b64 if raw else _plain
    data = cloud_traces(
        a,
        xv,
        yv,
        x,
        y,
        budget=max_points,
        seed=seed,
        selected=selected,
        gl=gl,
        enc=enc,
        memo=memo,
        density_above=density_above,
    )
    xr = _memo(memo, ("range", x), lambda: fitted_range(xv))
    yr = _memo(memo, ("range", y), lambda: fitted_range(yv))
    layout = _base_layout(
        title={"text": title or f"{y} vs {x}   ({counts_title(a)})", "font": {"size": 13}},
        xaxis={"title": {"text": axis_title(x, labels)}, "range": xr},
        yaxis={"title": {"text": axis_title(y, labels)}, "range": yr},
        shapes=_limit_shapes(a, x, y, xr=xr, yr=yr),
        annotations=_offscale_notes(a, x, y, xr, yr),
        legend={"orientation": "h", "y": -0.2, "yanchor": "top", "x": 0},
        margin={"t": 40, "b": 130},
        height=560,
    )
    return figure({"data": data, "layout": layout}, raw)


def criterion_vs_parameter_figure(
    a: Analysis,
    criterion: str,
    params: Sequence[str] | None = None,
    *,
    max_points: int | None = None,
    seed: int = 0,
    cols: int = 4,
    labels: Any = None,
    selected: np.ndarray | None = None,
    gl: bool = True,
    raw: bool = False,
) -> Any:
    """One criterion against each parameter over all trials (seed 000 Fig. 9), one panel
    per parameter; ``max_points`` applies per set and panel (the same trials in every
    panel)."""
    params = list(params) if params is not None else a.spec.space.names
    yv, _ = column(a, criterion)
    pc = point_classes(a)
    enc = b64 if raw else _plain
    ncol = min(cols, len(params))
    nrow = math.ceil(len(params) / ncol)
    titles = [labels.short(p) if labels is not None else p for p in params]
    layout, axes = grid_layout(len(params), ncol, titles, hspace=0.03, shared_y=True)
    data: list[dict[str, Any]] = []
    shapes: list[dict] = []
    for i, p in enumerate(params):
        xv, _ = column(a, p)
        data += cloud_traces(
            a,
            xv,
            yv,
            p,
            criterion,
            budget=max_points,
            seed=seed,
            classes=pc,
            axes=axes[i],
            showlegend=i == 0,
            size=3,
            bins=30,
            selected=selected,
            gl=gl,
            enc=enc,
        )
        shapes += _limit_shapes(a, "", criterion, axes[i][0], axes[i][1])
    for r in range(nrow):
        k = "" if r * ncol == 0 else str(r * ncol + 1)
        layout[f"yaxis{k}"]["title"] = {"text": axis_title(criterion, labels), "font": {"size": 11}}
    layout.update(
        _base_layout(
            title={
                "text": f"{criterion} vs parameters   ({counts_title(a)})",
                "font": {"size": 13},
            },
            shapes=shapes,
            height=max(360, 250 * nrow),
            legend={"orientation": "h", "y": -0.08 if nrow > 1 else -0.2},
        )
    )
    return figure({"data": data, "layout": layout}, raw)


def _share(counts: np.ndarray) -> np.ndarray:
    tot = counts.sum()
    return 100.0 * counts / tot if tot else np.zeros_like(counts, dtype=float)


#: Codes of the sets in a histogram click's customdata ``[count, panel, set, bin]``.
HIST_SETS = ("all", "feasible", "pareto", "selected")


def _step(
    h: Histogram,
    counts: np.ndarray,
    set_label: str,
    cls: str,
    panel: int,
    enc: Any,
    density: np.ndarray | None = None,
    **kw: Any,
) -> dict[str, Any]:
    """A histogram as a step line over the bin edges (one SVG path, cheap at any size).
    Each point's customdata is ``[count, panel, set code, bin]`` (a click selects the bin).
    ``density`` (a sequential store's importance-weighted counts) sets the height instead of
    ``counts``; the hover still gives the trials in the bin."""
    share = _share((counts if density is None else density).astype(float))
    x = np.repeat(h.edges, 2)[1:-1]
    y = np.repeat(share, 2)
    nb = len(counts)
    cd = np.column_stack(
        [
            np.repeat(counts.astype(np.int64), 2),
            np.full(2 * nb, panel),
            np.full(2 * nb, HIST_SETS.index(cls)),
            np.repeat(np.arange(nb), 2),
        ]
    ).astype(np.int32)
    out = {
        "type": "scatter",
        "x": enc(compact(x)),
        "y": enc(compact(y)),
        "customdata": cd.tolist() if enc is not _plain else cd,
        "mode": "lines",
        "hovertemplate": f"{h.param}=%{{x:.4g}}: %{{y:.3g}} % of the set"
        + (f" ({h.weighted_by})" if density is not None else "")
        + f" (%{{customdata[0]}} trials)<extra>{set_label}</extra>",
        "meta": {"class": cls, "total": int(counts.sum())},
    }
    out.update(kw)
    return out


def histograms_figure(
    hists: Sequence[Histogram],
    *,
    cols: int = 4,
    show_all: bool = True,
    title: str = "Parameters per set (each set on its own scale: share of the set, %)",
    labels: Any = None,
    selection: Sequence[np.ndarray] | None = None,
    chosen: Sequence[float] | None = None,
    boxes: Mapping[str, Sequence[tuple[float, float, str, str]]] | None = None,
    raw: bool = False,
) -> Any:
    """Histograms per parameter (seed 000 Fig. 7, seed 001 Fig. 10), each set on its own
    scale: all trials (grey), feasible (blue, filled), Pareto (green) as the share of the
    set in each bin; counts in the hover.

    Parameters
    ----------
    hists : sequence of Histogram
    selection : sequence of (bins,) int, optional
        Counts of the selected trials per bin, one per histogram (a dotted black line).
    chosen : sequence of float, optional
        The chosen trial's value per parameter (an orange line).
    boxes : mapping parameter -> [(low, high, colour, label)], optional
        Intervals shaded on each panel (the refine view: the current and proposed box).
    raw : bool
        Return a plain dict with base64 arrays (the browser UI) instead of a ``go.Figure``.
    """
    enc = b64 if raw else _plain
    n = max(1, len(hists))
    ncol = min(cols, n)
    nrow = math.ceil(n / ncol)
    titles = [
        (labels.short(h.param) if labels is not None else h.param)
        + ("" if h.stage is None else f" (stage {h.stage})")
        for h in hists
    ]
    layout, axes = grid_layout(n, ncol, titles, hspace=0.05, vspace=min(0.12, 0.55 / nrow))
    data: list[dict[str, Any]] = []
    shapes: list[dict] = []
    for i, h in enumerate(hists):
        xa, ya = axes[i]
        first = i == 0
        common = {"xaxis": xa, "yaxis": ya, "showlegend": first}
        if show_all:
            data.append(
                _step(
                    h,
                    h.all,
                    "all trials",
                    "all",
                    i,
                    enc,
                    name=f"all trials (N {int(h.all.sum()):,})",
                    legendgroup="all",
                    line={"color": "#999", "width": 1},
                    **common,
                )
            )
        weighted = h.feasible_weighted is not None
        data.append(
            _step(
                h,
                h.feasible,
                f"in D, {h.weighted_by}" if weighted else "in D",
                "feasible",
                i,
                enc,
                density=h.feasible_weighted,
                name=f"in D, {h.weighted_by} (ND {int(h.feasible.sum()):,})"
                if weighted
                else f"in D (ND {int(h.feasible.sum()):,})",
                legendgroup="feasible",
                line={"color": CLASS_COLOURS["feasible"], "width": 1.5},
                fill="tozeroy",
                fillcolor="rgba(31,119,180,0.18)",
                **common,
            )
        )
        data.append(
            _step(
                h,
                h.pareto,
                "Pareto",
                "pareto",
                i,
                enc,
                name=f"Pareto (NP {int(h.pareto.sum()):,})",
                legendgroup="pareto",
                line={"color": CLASS_COLOURS["pareto"], "width": 2.2},
                **common,
            )
        )
        if selection is not None and i < len(selection):
            sc = np.asarray(selection[i])
            data.append(
                _step(
                    h,
                    sc,
                    "selected",
                    "selected",
                    i,
                    enc,
                    name=f"selected ({int(sc.sum()):,})",
                    legendgroup="selected",
                    line={"color": "#111", "width": 1.5, "dash": "dot"},
                    **common,
                )
            )
        layout[f"yaxis{xa[1:]}"]["rangemode"] = "tozero"
        if i % ncol == 0:
            layout[f"yaxis{xa[1:]}"]["title"] = {"text": "% of set", "font": {"size": 11}}
        if chosen is not None and i < len(chosen) and np.isfinite(chosen[i]):
            shapes.append(
                {
                    "type": "line",
                    "xref": xa,
                    "yref": f"{ya} domain",
                    "x0": float(chosen[i]),
                    "x1": float(chosen[i]),
                    "y0": 0,
                    "y1": 1,
                    "line": {"color": CHOSEN_COLOUR, "width": 2},
                }
            )
        for lo, hi, colour, _label in (boxes or {}).get(h.param, ()):
            shapes.append(
                {
                    "type": "rect",
                    "xref": xa,
                    "yref": f"{ya} domain",
                    "x0": float(lo),
                    "x1": float(hi),
                    "y0": 0,
                    "y1": 1,
                    "fillcolor": colour,
                    "opacity": 0.16,
                    "line": {"color": colour, "width": 1.5},
                    "layer": "below",
                }
            )
    if boxes:
        seen: dict[str, str] = {}
        for items in boxes.values():
            for _lo, _hi, colour, label in items:
                seen.setdefault(label, colour)
        for label, colour in seen.items():
            data.append(
                {
                    "type": "scatter",
                    "x": [None],
                    "y": [None],
                    "mode": "markers",
                    "marker": {"symbol": "square", "size": 12, "color": colour, "opacity": 0.5},
                    "name": label,
                    "meta": {"class": "box"},
                }
            )
    weighted = [h for h in hists if h.feasible_weighted is not None]
    if weighted:
        title += (
            f"; D's density {weighted[0].weighted_by} (sequential sampler), all trials and "
            "Pareto as sampled"
        )
    layout.update(
        _base_layout(
            title={"text": title},
            shapes=shapes,
            height=max(320, 210 * nrow + 60),
            margin={"t": 100, "b": 40, "l": 50, "r": 20},
            legend={"orientation": "h", "y": 1.0, "yanchor": "top", "x": 0, "yref": "container"},
            hovermode="closest",
        )
    )
    return figure({"data": data, "layout": layout}, raw)
