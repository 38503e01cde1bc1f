"""Parallel coordinates of criteria, functionals and parameters, coloured by set, whose axis
constraints in force may be drawn as brushes (the report). In the browser UI a brush is a
selection (two-sided, several per axis, any axis), made a constraint only on request.

Lines are thinned per set as the point clouds are (:func:`vectorid.views.clouds.thin`: each
set above the budget keeps a uniform random subset, and the title says so); the Pareto set is
drawn last, on top.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..analysis.classes import CLASS_COLOURS, point_classes
from ..analysis.results import Analysis
from .clouds import _base_layout, _plain, b64, column, figure, thin

__all__ = ["brush_event", "parallel_axes", "parallel_figure"]

_CODE = {"infeasible": 0, "feasible": 1, "pareto": 2}
_SCALE = [
    [0.0, CLASS_COLOURS["infeasible"]],
    [0.33, CLASS_COLOURS["infeasible"]],
    [0.34, CLASS_COLOURS["feasible"]],
    [0.66, CLASS_COLOURS["feasible"]],
    [0.67, CLASS_COLOURS["pareto"]],
    [1.0, CLASS_COLOURS["pareto"]],
]


def _range(v: np.ndarray) -> tuple[float, float]:
    f = v[np.isfinite(v)]
    if not len(f):
        return 0.0, 1.0
    lo, hi = float(f.min()), float(f.max())
    return (lo, hi) if hi > lo else (lo - 0.5, hi + 0.5)


def parallel_figure(
    a: Analysis,
    names: Sequence[str] | None = None,
    *,
    lines: int | None = 1500,
    seed: int = 0,
    labels: Any = None,
    ranges: Mapping[str, Sequence[Any]] | None = None,
    title: str | None = None,
    raw: bool = False,
    bounds_as_brushes: bool = True,
    hidden: Sequence[str] = (),
    colour: str = "set",
) -> Any:
    """Parallel coordinates (criteria, functionals, then parameters), one line per trial,
    coloured by set (infeasible red, feasible blue, Pareto green).

    Parameters
    ----------
    a : Analysis
    names : sequence of str, optional
        Axes, in order (default: criteria, functionals, parameters).
    lines : int, optional
        Lines drawn per set (thinned beyond; None draws every trial).
    labels : Labels, optional
        Units for the axis labels.
    ranges : mapping name -> (low, high) or list of them, optional
        A selection drawn as brushes (several ranges per axis allowed), on any axis.
    raw : bool
        Return a plain dict with base64 arrays (the browser UI) instead of a ``go.Figure``.
    bounds_as_brushes : bool
        Draw the constraints in force as brushes on criterion and functional axes (the
        report); the browser UI draws its selection there instead.
    hidden : sequence of str
        Axes left out of the drawing (kept in the figure, ``visible`` false).
    colour : str
        ``"set"`` (infeasible red, feasible blue, Pareto green) or a column's name: the lines
        coloured by its value (colour bar).

    Returns
    -------
    go.Figure
        ``layout.meta`` holds ``{"names": [...]}``, the axis order, so that a brush event
        (which names the dimension by index) maps back to a name.
    """
    names = list(names) if names is not None else a.crit_names + a.con_names + a.spec.space.names
    enc = b64 if raw else _plain
    pc = point_classes(a)
    rows, counts = thin(pc, lines, seed)
    order = np.concatenate([rows["infeasible"], rows["feasible"], rows["pareto"]])
    code = np.concatenate(
        [
            np.full(len(rows[k]), _CODE[k], dtype=np.int8)
            for k in ("infeasible", "feasible", "pareto")
        ]
    )
    dims = []
    for name in names:
        v, kind = column(a, name)
        lo, hi = _range(v)
        d: dict[str, Any] = {
            "label": labels.short(name) if labels is not None else name,
            "name": name,
            "values": enc(np.asarray(v[order], dtype=np.float32)),
            "range": [lo, hi],
        }
        if name in hidden:
            d["visible"] = False
        if ranges and name in ranges:
            rs = ranges[name]
            rs = [rs] if rs and not isinstance(rs[0], list | tuple) else list(rs)
            rs = [[float(min(r)), float(max(r))] for r in rs]
            if rs:
                d["constraintrange"] = rs[0] if len(rs) == 1 else rs
        elif bounds_as_brushes and kind in ("criterion", "functional"):
            blo, bhi = a.bounds[name]
            if math.isfinite(blo) or math.isfinite(bhi):
                d["constraintrange"] = (
                    [max(blo, lo), min(bhi, hi)] if blo <= hi and bhi >= lo else [lo, lo]
                )
        dims.append(d)
    shown = {k: len(rows[k]) for k in rows}

    def part(k: str, label: str) -> str:
        if shown[k] < counts[k]:
            return f"{label} {shown[k]:,} of {counts[k]:,}"
        return f"{label} {counts[k]:,}"

    line: dict[str, Any] = {"color": enc(code), "colorscale": _SCALE, "cmin": 0, "cmax": 2}
    if colour != "set":
        cv = np.asarray(column(a, colour)[0][order], dtype=np.float32)
        clo, chi = _range(cv)
        line = {
            "color": enc(cv),
            "colorscale": "Viridis",
            "cmin": clo,
            "cmax": chi,
            "showscale": True,
            "colorbar": {"title": {"text": labels.short(colour) if labels else colour}},
        }
    trace = {
        "type": "parcoords",
        "line": line,
        "dimensions": dims,
        "unselected": {"line": {"color": "#bbb", "opacity": 0.08}},
        "labelangle": -25,
        "labelfont": {"size": 11},
        "meta": {"class": "parallel", "shown": shown, "count": counts},
    }
    text = title or (
        f"Parallel coordinates (N={a.n:,}, ND={a.n_feasible:,}, NP={a.n_pareto:,}); lines: "
        + ", ".join(
            [
                part("pareto", "Pareto (green)"),
                part("feasible", "in D, not Pareto (blue)"),
                part("infeasible", "infeasible (red, grey outside a brush)"),
            ]
        )
    )
    layout = _base_layout(
        title={"text": text, "font": {"size": 13}},
        height=460,
        margin={"t": 110, "l": 60, "r": 60, "b": 30},
        meta={"names": names},
    )
    return figure({"data": [trace], "layout": layout}, raw)


def parallel_axes(
    a: Analysis,
    names: Sequence[str],
    *,
    lines: int | None = 600,
    seed: int = 0,
    labels: Any = None,
    ranges: Mapping[str, Sequence[Any]] | None = None,
    hidden: Sequence[str] = (),
    colour: str = "set",
    tips: Mapping[str, str] | None = None,
) -> dict[str, Any]:
    """The parallel coordinates as the browser UI draws them itself (no plotly.js): the axes
    (name, title with unit, hover text, range, the criteria constraint in force), the lines
    thinned per set (float32, base64) and the selection's brushes.

    Parameters
    ----------
    a : Analysis
    names : sequence of str
        Every axis, in order (the hidden ones too: a brush on a hidden axis still selects).
    lines : int, optional
        Lines drawn per set (a uniform random subset beyond; None draws every trial).
    labels : Labels, optional
        Units and meanings (:func:`vectorid.views.labels.labels_of`).
    ranges : mapping name -> list of (low, high), optional
        The selection's brushes (several per axis).
    hidden : sequence of str
        Axes not drawn.
    colour : str
        ``"set"`` or a column's name (the lines coloured by its value, ten steps).
    tips : mapping, optional
        Extra hover text per axis (its verdict, its sensitivity).

    Returns
    -------
    dict
        ``title``; ``axes`` (``name``, ``title`` — "name [unit]", the unit always said —,
        ``unit``, ``tip``, ``kind``, ``range``, ``limit`` — ``[side, value]`` of a criteria
        constraint or functional bound in force, or None —, ``hidden``); ``lines``
        (``values`` per axis, ``color``, ``cmin``, ``cmax``, ``mode``, ``colours``,
        ``unselected``); ``colour`` (the colour-by column's title and range, or None);
        ``ranges``; ``shown`` and ``count`` per set.
    """
    pc = point_classes(a)
    rows, counts = thin(pc, lines, seed)
    order = np.concatenate([rows["infeasible"], rows["feasible"], rows["pareto"]])
    code = np.concatenate(
        [
            np.full(len(rows[k]), _CODE[k], dtype=np.int8)
            for k in ("infeasible", "feasible", "pareto")
        ]
    )
    hide = set(hidden)
    axes, values = [], {}
    for name in names:
        v, kind = column(a, name)
        lo, hi = _range(v)
        values[name] = b64(np.asarray(v[order], dtype=np.float32))
        limit = None
        if kind in ("criterion", "functional"):
            blo, bhi = a.bounds[name]
            if kind == "criterion":
                sense = a.senses[a.crit_names.index(name)]
                worse = bhi if sense == "min" else blo
                if math.isfinite(worse):
                    limit = ["<=" if sense == "min" else ">=", float(worse)]
            elif math.isfinite(blo) or math.isfinite(bhi):
                limit = ["in", [blo if math.isfinite(blo) else None,
                                bhi if math.isfinite(bhi) else None]]  # fmt: skip
        tip = labels.hover(name) if labels is not None else name
        extra = (tips or {}).get(name)
        axes.append(
            {
                "name": name,
                "title": labels.title(name) if labels is not None else name,
                "unit": labels.unit_text(name) if labels is not None else "",
                "tip": f"{tip}; {extra}" if extra else tip,
                "kind": kind,
                "range": [lo, hi],
                "limit": limit,
                "hidden": name in hide,
            }
        )
    shown = {k: len(rows[k]) for k in rows}

    def part(k: str, label: str) -> str:
        if shown[k] < counts[k]:
            return f"{label} {shown[k]:,} of {counts[k]:,}"
        return f"{label} {counts[k]:,}"

    line = {
        "values": values,
        "color": b64(code),
        "cmin": 0,
        "cmax": 2,
        "mode": "set",
        "colours": [CLASS_COLOURS[k] for k in ("infeasible", "feasible", "pareto")],
        "unselected": {"color": "#bbb", "opacity": 0.08},
    }
    colour_of = None
    if colour != "set":
        cv = np.asarray(column(a, colour)[0][order], dtype=np.float32)
        clo, chi = _range(cv)
        line.update(color=b64(cv), cmin=clo, cmax=chi, mode="column")
        colour_of = {
            "name": colour,
            "title": labels.title(colour) if labels is not None else colour,
            "min": clo,
            "max": chi,
        }
    kept = {}
    for name, rs in (ranges or {}).items():
        rs = [rs] if rs and not isinstance(rs[0], list | tuple) else list(rs)
        rs = [[float(min(r)), float(max(r))] for r in rs]
        if rs and name in values:
            kept[name] = rs
    title = (
        f"Parallel coordinates (N={a.n:,}, ND={a.n_feasible:,}, NP={a.n_pareto:,}); lines: "
        + ", ".join(
            [
                part("pareto", "Pareto (green)"),
                part("feasible", "in D, not Pareto (blue)"),
                part("infeasible", "infeasible (red, grey outside a brush)"),
            ]
        )
    )
    return {
        "title": title,
        "axes": axes,
        "lines": line,
        "colour": colour_of,
        "ranges": kept,
        "shown": shown,
        "count": counts,
        "height": 470,
    }


_KEY = re.compile(r"^dimensions\[(\d+)\]\.constraintrange$")


def brush_event(event: Any, names: Sequence[str]) -> dict[str, tuple[float, float] | None]:
    """Brushed ranges from a Plotly ``restyleData`` event of :func:`parallel_figure`.

    Parameters
    ----------
    event : list
        ``[{"dimensions[i].constraintrange": [[lo, hi]] | [lo, hi] | None}, [0]]`` as Plotly
        sends it.
    names : sequence of str
        The figure's axis order (``layout.meta["names"]``).

    Returns
    -------
    dict
        Axis name -> ``(low, high)``, or None where the brush was removed. Several ranges on
        one axis are merged into their hull. Keys that are not brushes are ignored.
    """
    out: dict[str, tuple[float, float] | None] = {}
    if not isinstance(event, list | tuple) or not event or not isinstance(event[0], Mapping):
        return out
    for key, value in event[0].items():
        m = _KEY.match(str(key))
        if not m:
            continue
        i = int(m.group(1))
        if not 0 <= i < len(names):
            continue
        v = value
        while isinstance(v, list | tuple) and len(v) == 1 and isinstance(v[0], list | tuple):
            v = v[0]
        if v is None or (isinstance(v, list | tuple) and not v):
            out[names[i]] = None
            continue
        flat = np.asarray(v, dtype=float).ravel()
        flat = flat[np.isfinite(flat)]
        if len(flat) < 2:
            out[names[i]] = None
            continue
        out[names[i]] = (float(flat.min()), float(flat.max()))
    return out
