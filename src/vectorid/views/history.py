"""History of a study: N, ND and NP against the number of trials, per sample stage — to judge
whether more trials would still change the feasible and Pareto sets (seed 000: the expert
decides when the tables have settled).

For ``n`` trials in sequence order, ND(n) counts the first ``n`` trials that are in D under the
constraints in force, and NP(n) the Pareto set *of those ND(n) trials* (it can shrink when a
new trial dominates old ones). Sample stages are drawn as vertical lines where they start.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import plotly.graph_objects as go

from ..analysis.classes import CLASS_COLOURS
from ..analysis.pareto import pareto_mask
from ..analysis.results import Analysis
from .clouds import TEMPLATE

__all__ = ["History", "history", "history_figure"]


@dataclass(frozen=True)
class History:
    """N, ND, NP at growing numbers of trials.

    Attributes
    ----------
    n, nd, np_ : (m,) int64
        Trials, feasible trials and Pareto trials among the first ``n`` (sequence order).
    stages : list of (stage, first n)
        Where each sample stage starts (trial count before its first trial).
    """

    n: np.ndarray
    nd: np.ndarray
    np_: np.ndarray
    stages: list[tuple[int, int]]


def history(a: Analysis, points: int = 40) -> History:
    """N, ND and NP over the first ``n`` trials for ``points`` values of ``n`` spread
    geometrically from 1 to N (each stage's start and N itself included)."""
    t = a.trials
    order = np.lexsort((t.seq, t.stage))
    feas = a.feasible[order]
    N = len(order)
    stages: list[tuple[int, int]] = []
    if N:
        st = t.stage[order]
        starts = np.flatnonzero(np.r_[True, st[1:] != st[:-1]])
        stages = [(int(st[i]), int(i)) for i in starts]
    if N == 0:
        e = np.zeros(0, np.int64)
        return History(e, e, e, stages)
    grid = np.unique(
        np.r_[
            np.geomspace(1, N, max(2, points)).round().astype(np.int64),
            [s for _, s in stages if s > 0],
            N,
        ]
    )
    grid = grid[(grid >= 1) & (grid <= N)].astype(np.int64)
    cum = np.cumsum(feas)
    nd = cum[grid - 1].astype(np.int64)
    npar = np.zeros(len(grid), np.int64)
    if a.pure:
        # The Pareto set of the first n2 trials is that of the first n1's Pareto set and the
        # trials n1..n2 (a trial dominated among the first n1 stays dominated, and by one of
        # their Pareto set: dominance is transitive), so each prefix scans only its new
        # trials and the last front, not the whole prefix again.
        senses = [a.senses[i] for i in a.pure]
        rows = order[feas]  # the trials of D in sequence order
        front = rows[:0]
        done = 0
        for k, m in enumerate(nd):  # m: the trials of D among the first n
            if m > done:
                cand = np.r_[front, rows[done:m]]
                front = cand[pareto_mask(t.F[np.ix_(cand, a.pure)], senses)]
                done = m
            npar[k] = len(front)
    return History(grid.astype(np.int64), nd, npar, stages)


def history_figure(h: History, *, title: str | None = None) -> go.Figure:
    """N, ND and NP against the number of trials (log–log), stage starts as dashed lines."""
    fig = go.Figure()
    for y, name, colour, dash in (
        (h.n, "N (trials)", "#777", "dot"),
        (h.nd, "ND (feasible)", CLASS_COLOURS["feasible"], None),
        (h.np_, "NP (Pareto)", CLASS_COLOURS["pareto"], None),
    ):
        fig.add_trace(
            go.Scatter(
                x=h.n,
                y=np.where(y > 0, y, np.nan),
                mode="lines+markers",
                name=name,
                line={"color": colour, "dash": dash, "width": 2},
                marker={"size": 4},
                hovertemplate="after %{x:,} trials: %{y:,}<extra>" + name + "</extra>",
                meta={"class": name.split()[0]},
            )
        )
    top = float(max(h.n.max(), 1)) if len(h.n) else 1.0
    for stage, start in h.stages:
        if start > 0:
            # a trace, not add_vline: on log axes plotly.js reads a shape's annotation x as
            # log10, so the annotation of a line at 32 trials stretched the axis to 1e32
            fig.add_trace(
                go.Scatter(
                    x=[start, start],
                    y=[1, top],
                    mode="lines",
                    line={"color": "#444", "dash": "dash", "width": 1},
                    showlegend=False,
                    hovertemplate=f"stage {stage} starts after %{{x:,}} trials<extra></extra>",
                )
            )
            fig.add_annotation(
                x=math.log10(start),
                y=math.log10(top),
                text=f"stage {stage}",
                showarrow=False,
                xanchor="right",
                yanchor="bottom",
            )
    last = (int(h.n[-1]), int(h.nd[-1]), int(h.np_[-1])) if len(h.n) else (0, 0, 0)
    fig.update_layout(
        template=TEMPLATE,
        title=title or f"History: after {last[0]:,} trials ND = {last[1]:,}, NP = {last[2]:,}",
        xaxis={"type": "log", "title": "trials in sequence order (count)"},
        yaxis={"type": "log", "title": "count (trials)"},
        height=380,
        legend={"orientation": "h", "y": -0.22},
    )
    return fig
