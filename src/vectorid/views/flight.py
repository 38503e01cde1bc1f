"""A chosen trial's flight against the measured one: position, velocity, attitude and (a
barometric descent) altitude over time, one panel per component, with the RMS difference
per channel component for each trial (two or three trials overlaid)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import plotly.graph_objects as go
from plotly.subplots import make_subplots

from .clouds import TEMPLATE

__all__ = ["CHANNELS", "flight_figure", "rms_table"]

#: Channels shown, in order (those the drop measures).
CHANNELS = ("position", "velocity", "euler", "altitude")
_COLOURS = ["#ff7f0e", "#9467bd", "#17becf", "#8c564b"]


def rms_table(runs: Any, rows: Sequence[int]) -> list[dict[str, Any]]:
    """RMS over the window of (simulated − measured) per channel component, one row per
    trial (angles in deg, as drawn), to four significant digits. Failed simulations get no
    value."""
    out = []
    for r in rows:
        row: dict[str, Any] = {"trial": runs.labels[r]}
        for ch in CHANNELS:
            if ch not in runs.measured:
                continue
            h = runs.channel_histories(ch, [r])
            for comp, meas in h.flight.items():
                key = f"{ch}.{comp} RMS [{h.unit}]"
                if not h.runs:
                    row[key] = None
                    continue
                d = h.runs[0][1][comp] - meas
                d = d[np.isfinite(d)]
                # four significant digits: the RMS of a few hundred residuals of noisy
                # telemetry is not known better than that
                row[key] = float(f"{np.sqrt(np.mean(d**2)):.4g}") if len(d) else None
        out.append(row)
    return out


def flight_figure(runs: Any, rows: Sequence[int], *, title: str | None = None) -> go.Figure:
    """Measured (black) and simulated (one colour per trial) channels over time, one panel
    per component of position, velocity and Euler angles; the legend gives each trial's
    RMS per channel."""
    chans = [ch for ch in CHANNELS if ch in runs.measured]
    panels: list[tuple[str, str, Any]] = []
    for ch in chans:
        h = runs.channel_histories(ch, list(rows))
        for comp in h.flight:
            panels.append((ch, comp, h))
    fig = make_subplots(
        rows=max(1, len(panels)),
        cols=1,
        shared_xaxes=True,
        vertical_spacing=0.025,
        subplot_titles=[f"{ch}: {comp} [{h.unit}]" for ch, comp, h in panels],
    )
    for i, (_ch, comp, h) in enumerate(panels):
        fig.add_trace(
            go.Scatter(
                x=h.t,
                y=h.flight[comp],
                mode="lines",
                line={"color": "black", "width": 2},
                name="flight (measured)",
                legendgroup="flight",
                showlegend=i == 0,
            ),
            row=i + 1,
            col=1,
        )
        for k, (t, vals) in enumerate(h.runs):
            d = vals[comp] - h.flight[comp]
            d = d[np.isfinite(d)]
            rms = float(np.sqrt(np.mean(d**2))) if len(d) else float("nan")
            fig.add_trace(
                go.Scatter(
                    x=t,
                    y=vals[comp],
                    mode="lines",
                    line={"color": _COLOURS[k % len(_COLOURS)], "width": 1.6},
                    name=h.labels[k],
                    legendgroup=h.labels[k],
                    showlegend=i == 0,
                    hovertemplate=f"t=%{{x:.3g}} s: %{{y:.4g}} {h.unit} (RMS {rms:.3g})"
                    f"<extra>{h.labels[k]}</extra>",
                ),
                row=i + 1,
                col=1,
            )
    fig.update_xaxes(title_text="time from the window start, s", row=len(panels), col=1)
    fig.update_layout(
        template=TEMPLATE,
        title=title or "Flight vs model: position, velocity, attitude",
        height=max(320, 150 * len(panels) + 100),
        legend={"orientation": "h", "y": 1.02, "yanchor": "bottom"},
        margin={"t": 90},
    )
    for ann in fig.layout.annotations:
        ann.font = {"size": 11}
    return fig
