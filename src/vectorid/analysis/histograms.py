"""Histograms of the feasible and Pareto trials per parameter (seed 000 Fig. 7, seed 001
Figs. 5 and 10), and the side-by-side comparison of two stages after double tuning.

The histograms are aggregated here (counts per bin), so a figure built from them embeds a
few numbers per bin whatever the number of trials.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..space import Choice, Integer, Space, Variable
from ..store import Stage
from .results import Analysis
from .weights import how_weighted, trial_weights

__all__ = ["Histogram", "default_bins", "histogram", "histograms", "stage_histograms"]


@dataclass(frozen=True)
class Histogram:
    """Counts of trials per bin of one parameter.

    Attributes
    ----------
    param : str
        Variable name.
    edges : (m + 1,) float
        Bin edges, in the variable's unit; the last bin is closed on the right.
    all, feasible, pareto : (m,) int64
        Trials per bin: every trial of the selection, those in D, those in the Pareto set.
    low, high : float
        The box the histogram spans (the stage's or the study's box).
    stage : int or None
        The stage whose trials are counted (None: every sample stage).
    feasible_weighted : (m,) float or None
        Sequential stores: D's importance-weighted counts per bin, scaled to D's number of
        members (the density of D over the box; the plain ``feasible`` counts follow where
        the generations sampled). None where every trial weighs the same.
    weighted_by : str
        How ``feasible_weighted`` is weighted, in words (:func:`~.weights.how_weighted`).
    n_outside : int
        Trials of the selection outside ``[low, high]`` (not counted; happens when a
        histogram spans a narrower box than some trials were drawn in).
    """

    param: str
    edges: np.ndarray
    all: np.ndarray
    feasible: np.ndarray
    pareto: np.ndarray
    low: float
    high: float
    stage: int | None = None
    n_outside: int = 0
    feasible_weighted: np.ndarray | None = None
    weighted_by: str = "importance-weighted"

    @property
    def weighted(self) -> bool:
        """Whether D's density is importance-weighted (a sequential store)."""
        return self.feasible_weighted is not None

    @property
    def centres(self) -> np.ndarray:
        """Bin centres (m,)."""
        return 0.5 * (self.edges[:-1] + self.edges[1:])

    @property
    def widths(self) -> np.ndarray:
        """Bin widths (m,)."""
        return np.diff(self.edges)

    def to_dict(self) -> dict:
        return {
            "param": self.param,
            "stage": self.stage,
            "low": self.low,
            "high": self.high,
            "edges": self.edges.tolist(),
            "all": self.all.tolist(),
            "feasible": self.feasible.tolist(),
            "pareto": self.pareto.tolist(),
            "n_outside": self.n_outside,
            "feasible_weighted": None
            if self.feasible_weighted is None
            else self.feasible_weighted.tolist(),
            # what the weighted density's weights are (None where D's density is counts)
            "feasible_weighted_by": None if self.feasible_weighted is None else self.weighted_by,
        }


def default_bins(n: int) -> int:
    """Bins for ``n`` counted trials: ``ceil(sqrt(n))`` clipped to [10, 50]."""
    return int(min(50, max(10, math.ceil(math.sqrt(max(n, 1))))))


def bin_edges(var: Variable, low: float, high: float, bins: int) -> np.ndarray:
    if isinstance(var, Integer):
        lo, hi = math.floor(low), math.ceil(high)
        return np.arange(lo, hi + 2, dtype=float) - 0.5
    if isinstance(var, Choice):
        vals = np.array(sorted(v for v in var.values if low <= v <= high) or sorted(var.values))
        if len(vals) == 1:
            return np.array([vals[0] - 0.5, vals[0] + 0.5])
        mids = 0.5 * (vals[:-1] + vals[1:])
        first = vals[0] - (mids[0] - vals[0])
        last = vals[-1] + (vals[-1] - mids[-1])
        return np.concatenate([[first], mids, [last]])
    return np.linspace(low, high, bins + 1)


def histogram(
    values: np.ndarray,
    feasible: np.ndarray,
    pareto: np.ndarray,
    edges: np.ndarray,
    *,
    param: str = "",
    stage: int | None = None,
) -> Histogram:
    """Count ``values`` per bin of ``edges`` for all, feasible and Pareto rows.

    Parameters
    ----------
    values : (n,) float
        One parameter's values.
    feasible, pareto : (n,) bool
    edges : (m + 1,) float, increasing
    """
    values = np.asarray(values, dtype=float)
    edges = np.asarray(edges, dtype=float)
    inside = (values >= edges[0]) & (values <= edges[-1])
    m = len(edges) - 1
    idx = np.clip(np.searchsorted(edges, values, side="right") - 1, 0, m - 1)

    def count(mask: np.ndarray) -> np.ndarray:
        return np.bincount(idx[mask & inside], minlength=m).astype(np.int64)

    return Histogram(
        param=param,
        edges=edges,
        all=count(np.ones(len(values), bool)),
        feasible=count(np.asarray(feasible, bool)),
        pareto=count(np.asarray(pareto, bool)),
        low=float(edges[0]),
        high=float(edges[-1]),
        stage=stage,
        n_outside=int((~inside).sum()),
    )


def histograms(
    a: Analysis,
    params: Sequence[str] | None = None,
    *,
    bins: int | None = None,
    space: Space | None = None,
    stage: int | None = None,
) -> list[Histogram]:
    """Histograms of every (or the named) parameter over a box.

    Parameters
    ----------
    a : Analysis
        Trials and the feasible/Pareto sets under the chosen constraints.
    params : sequence of str, optional
        Variable names (default: all).
    bins : int, optional
        Bins of a continuous variable (default :func:`default_bins` of ND). Integer and
        choice variables get one bin per value.
    space : Space, optional
        The box the bins span (default: the study's box Π).
    stage : int, optional
        Count only this stage's trials (default: every sample stage loaded in ``a``).
    """
    space = space or a.spec.space
    names = list(params) if params is not None else space.names
    sel = np.ones(a.n, bool) if stage is None else a.trials.stage == stage
    nbins = bins or default_bins(int((a.feasible & sel).sum()))
    out = []
    d = a.feasible & sel
    w = trial_weights(a, d) if d.any() else None  # scaled to D's count
    word = how_weighted(a) if w is not None else "importance-weighted"
    for name in names:
        j = a.spec.space.index(name)
        var = space.variables[j]
        edges = bin_edges(var, var.low, var.high, nbins)
        h = histogram(
            a.trials.X[sel, j],
            a.feasible[sel],
            a.pareto[sel],
            edges,
            param=name,
            stage=stage,
        )
        if w is not None:
            x = a.trials.X[d, j]
            inside = (x >= edges[0]) & (x <= edges[-1])
            idx = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, len(edges) - 2)
            fw = np.bincount(idx[inside], weights=w[inside], minlength=len(edges) - 1)
            h = replace(h, feasible_weighted=fw, weighted_by=word)
        out.append(h)
    return out


def stage_histograms(
    a: Analysis, stages: Sequence[Stage], param: str, *, bins: int | None = None
) -> list[Histogram]:
    """One histogram per stage for ``param`` on common bins spanning the union of the stages'
    boxes (seed 001 Fig. 5: the same variable before and after double tuning).

    Parameters
    ----------
    a : Analysis
    stages : sequence of Stage
        Sample stages (``Store.stages()``), typically the one before and the one after a
        refinement.
    param : str
    bins : int, optional
        Bins over the union box (default :func:`default_bins` of ND).
    """
    j = a.spec.space.index(param)
    lo = min(s.space.variables[j].low for s in stages)
    hi = max(s.space.variables[j].high for s in stages)
    var = a.spec.space.variables[j]
    edges = bin_edges(var, lo, hi, bins or default_bins(a.n_feasible))
    out = []
    for s in stages:
        sel = a.trials.stage == s.stage
        out.append(
            histogram(
                a.trials.X[sel, j],
                a.feasible[sel],
                a.pareto[sel],
                edges,
                param=param,
                stage=s.stage,
            )
        )
    return out
