"""Figures of what the identified set predicts (:mod:`vectorid.workflows.predict`).

* :func:`band_figure`: one channel of one drop against time — the credible band (the
  members' 5–95 %, D's spread), the with-noise band (where a measured sample is expected),
  the median, and the measured samples over them;
* :func:`landing_figure`: every member's landing (or end-of-window) point, the R50/R90/R95
  circles around the ensemble's centre, the 1/2/3-σ covariance ellipses labelled with the
  share of points each actually holds, and the measured point;
* :func:`prediction_page` / :func:`write_prediction`: one self-contained HTML page of them
  (``vectorid predict ... --out DIR``); :func:`report_parts` the same for the study report
  (``vectorid report STORE --predict DROP.toml``).

Needs plotly (a core dependency).
"""

from __future__ import annotations

import html
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from vectorid.workflows.predict import ChannelPrediction, DropPrediction, Prediction

__all__ = [
    "band_figure",
    "landing_figure",
    "prediction_page",
    "report_parts",
    "write_prediction",
]

_CREDIBLE = "rgba(31, 119, 180, 0.45)"
_NOISY = "rgba(31, 119, 180, 0.15)"
_CIRCLES = {"r50": "#2ca02c", "r90": "#ff7f0e", "r95": "#d62728"}
_SHARE = {"r50": 50, "r90": 90, "r95": 95}


def band_figure(drop: DropPrediction, channel: ChannelPrediction) -> Any:
    """The bands of one channel against time, one panel per component, with the measured
    samples where the drop has data."""
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    m = len(channel.components)
    fig = make_subplots(
        rows=m, cols=1, shared_xaxes=True, vertical_spacing=0.04,
        subplot_titles=[f"{c} [{channel.unit}]" for c in channel.components],
    )  # fmt: skip
    t = channel.t
    for j in range(m):
        row = j + 1
        first = j == 0
        if channel.with_noise is not None and np.isfinite(channel.with_noise[:, :, j]).any():
            lo, hi = channel.with_noise[0, :, j], channel.with_noise[1, :, j]
            fig.add_trace(
                go.Scatter(x=t, y=hi, mode="lines", line={"width": 0}, showlegend=False,
                           hoverinfo="skip"),
                row=row, col=1,
            )  # fmt: skip
            fig.add_trace(
                go.Scatter(x=t, y=lo, mode="lines", line={"width": 0}, fill="tonexty",
                           fillcolor=_NOISY, name="with-noise band 5-95 % (a measured sample)",
                           legendgroup="noisy", showlegend=first),
                row=row, col=1,
            )  # fmt: skip
        lo, hi = channel.credible[0, :, j], channel.credible[1, :, j]
        fig.add_trace(
            go.Scatter(x=t, y=hi, mode="lines", line={"width": 0}, showlegend=False,
                       hoverinfo="skip"),
            row=row, col=1,
        )  # fmt: skip
        fig.add_trace(
            go.Scatter(x=t, y=lo, mode="lines", line={"width": 0}, fill="tonexty",
                       fillcolor=_CREDIBLE, name="credible band 5-95 % (D's spread)",
                       legendgroup="credible", showlegend=first),
            row=row, col=1,
        )  # fmt: skip
        fig.add_trace(
            go.Scatter(x=t, y=channel.median[:, j], mode="lines", line={"color": "#1f4e79"},
                       name="median of the members", legendgroup="median", showlegend=first),
            row=row, col=1,
        )  # fmt: skip
        if channel.measured is not None:
            fig.add_trace(
                go.Scatter(x=channel.measured_t, y=channel.measured[:, j], mode="markers",
                             marker={"size": 3, "color": "#222"}, name="measured",
                             legendgroup="measured", showlegend=first),
                row=row, col=1,
            )  # fmt: skip
    cov = ""
    if channel.coverage_with_noise is not None:
        cov = (
            f" — measured samples inside: credible {100 * channel.coverage_credible:.0f} %, "  # type: ignore[operator]
            f"with-noise {100 * channel.coverage_with_noise:.0f} %"
        )
    fig.update_layout(
        title=f"{drop.name}: {channel.name} [{channel.unit}]{cov}",
        height=max(300, 230 * m),
        legend={"orientation": "h", "y": -0.12},
        margin={"t": 70},
    )
    fig.update_xaxes(title_text="time from the drop's start [s]", row=m, col=1)
    return fig


def _circle(cx: float, cy: float, r: float, n: int = 120) -> tuple[np.ndarray, np.ndarray]:
    a = np.linspace(0.0, 2.0 * math.pi, n)
    return cx + r * np.cos(a), cy + r * np.sin(a)


def landing_figure(drop: DropPrediction) -> Any:
    """The landing (or end-of-window) scatter with the R50/R90/R95 circles and the labelled
    covariance ellipses (east on the horizontal axis, north up, m from the origin)."""
    import plotly.graph_objects as go

    d = drop.dispersion
    if d is None:
        raise ValueError(f"drop {drop.name!r} has no dispersion to draw")
    fig = go.Figure()
    size = 3 + 5 * d.weights / max(float(d.weights.max()), 1e-300)
    fig.add_trace(
        go.Scatter(x=d.points[:, 1], y=d.points[:, 0], mode="markers",
                   marker={"size": size, "color": "#1f77b4", "opacity": 0.6},
                   name=f"members ({len(d.points)}; size: weight)"),
    )  # fmt: skip
    ce, cn = float(d.centre[1]), float(d.centre[0])
    for key, colour in _CIRCLES.items():
        x, y = _circle(ce, cn, d.radii[key])
        lo, hi = d.intervals[key]
        fig.add_trace(
            go.Scatter(x=x, y=y, mode="lines", line={"color": colour},
                       name=f"{key.upper()} {d.radii[key]:.1f} m [{lo:.1f}, {hi:.1f}]: holds "
                       f"{_SHARE[key]} % of the points"),
        )  # fmt: skip
    for e in d.ellipses:
        a, b = e["semi_axes_m"]
        ang = math.radians(e["angle_deg"])  # of the major axis, from north towards east
        s = np.linspace(0.0, 2.0 * math.pi, 120)
        u, v = a * np.cos(s), b * np.sin(s)
        north = cn + u * math.cos(ang) - v * math.sin(ang)
        east = ce + u * math.sin(ang) + v * math.cos(ang)
        fig.add_trace(
            go.Scatter(x=east, y=north, mode="lines", line={"color": "#7f7f7f", "dash": "dot"},
                       name=f"{e['sigma']}-σ ellipse: holds {100 * e['share']:.1f} % "
                       f"(a normal's {100 * e['nominal_share']:.1f} %)"),
        )  # fmt: skip
    fig.add_trace(
        go.Scatter(x=[ce], y=[cn], mode="markers", marker={"symbol": "x", "size": 10,
                   "color": "#111"}, name="centre"),
    )  # fmt: skip
    if d.measured is not None:
        where = "inside" if d.measured_inside_r95 else "outside"
        fig.add_trace(
            go.Scatter(x=[d.measured[1]], y=[d.measured[0]], mode="markers",
                       marker={"symbol": "star", "size": 14, "color": "#d62728"},
                       name=f"measured ({where} R95)"),
        )  # fmt: skip
    fig.update_layout(
        title=f"{drop.name}: {d.kind} dispersion at {d.time_s:.1f} s",
        xaxis_title="east of the origin [m]",
        yaxis_title="north of the origin [m]",
        height=560,
        legend={"orientation": "h", "y": -0.15},
    )
    fig.update_yaxes(scaleanchor="x", scaleratio=1)
    return fig


def _figures(prediction: Prediction) -> list[tuple[str, Any]]:
    out = []
    for d in prediction.drops:
        for c in d.channels:
            out.append((f"{d.name}: {c.name}", band_figure(d, c)))
        if d.dispersion is not None:
            out.append((f"{d.name}: {d.dispersion.kind}", landing_figure(d)))
    return out


def report_parts(prediction: Prediction) -> list[tuple[str, Any]]:
    """What the report's "Predictions" section holds, in order: ``("html", text)`` parts and
    ``("figure", plotly figure)`` parts."""
    parts: list[tuple[str, Any]] = [
        ("html", "<pre>" + html.escape(prediction.describe()) + "</pre>"),
        (
            "html",
            "<p class=muted>credible band: 5–95 % of the members' outputs (the spread of D, "
            "not a prediction interval); with-noise band: 5–95 % of a measured sample (outputs "
            "plus the stated measurement noise).</p>",
        ),
    ]
    for _, fig in _figures(prediction):
        parts.append(("figure", fig))
    return parts


def prediction_page(prediction: Prediction) -> str:
    """One self-contained HTML page: the text of :meth:`Prediction.describe` and every figure."""
    import plotly.offline

    body = [
        "<pre>" + html.escape(prediction.describe()) + "</pre>",
    ]
    for i, (title, fig) in enumerate(_figures(prediction)):
        payload = fig.to_json().replace("</", "<\\/")
        body.append(f"<h2>{html.escape(title)}</h2><div id=f{i}></div>")
        body.append(
            f"<script>(function(){{var f={payload};Plotly.newPlot('f{i}',f.data,f.layout);}})()"
            "</script>"
        )
    title = f"vectorid predict: {Path(prediction.store).name}"
    return (
        "<!DOCTYPE html><html lang=en><head><meta charset=utf-8>"
        f"<title>{html.escape(title)}</title>"
        "<style>body{font-family:system-ui,sans-serif;max-width:1200px;margin:0 auto;"
        "padding:0 16px}pre{white-space:pre-wrap}</style>"
        f"<script>{plotly.offline.get_plotlyjs()}</script></head><body>"
        f"<h1>{html.escape(title)}</h1>" + "".join(body) + "</body></html>"
    )


def write_prediction(prediction: Prediction, out: str | Path) -> list[Path]:
    """Write ``prediction.json`` and ``prediction.html`` into the folder ``out``; returns the
    files written."""
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    js = folder / "prediction.json"
    js.write_text(json.dumps(prediction.to_dict(), indent=1) + "\n", encoding="utf-8")
    page = folder / "prediction.html"
    page.write_text(prediction_page(prediction), encoding="utf-8")
    return [js, page]
