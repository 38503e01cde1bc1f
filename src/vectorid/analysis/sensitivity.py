"""Which parameters drive which criteria, from the trials already computed (no new runs).

* Rank correlation: Spearman's ρ between every parameter and every criterion over the
  successful trials (a monotone association, insensitive to scale).
* Monte Carlo filtering (Hornberger–Spear regional sensitivity analysis): the trials are
  split into behavioural (in the feasible set D) and non-behavioural (all others); for each
  parameter the two-sample Kolmogorov–Smirnov statistic between the two groups' values. A
  large statistic means the constraints select a part of that parameter's range (the
  parameter matters for feasibility); a statistic near 0 means D does not depend on it.
  Uniform Sobol sampling makes the marginal of every parameter uniform, so the test is
  meaningful without weighting. A sequential store's trials are not uniform: there both
  statistics use the trials' importance weights (:mod:`vectorid.analysis.weights`: weighted
  mid-ranks, weighted empirical CDFs, p-values from Kish's effective sizes), and
  :attr:`Sensitivity.weighted` says so.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .results import Analysis
from .weights import kish, trial_weights, weighted_ks, weighted_pearson, weighted_ranks

__all__ = [
    "Sensitivity",
    "ks_filtering",
    "ks_of",
    "ks_statistics",
    "rank_correlation",
    "sensitivity",
]


def rank_correlation(X: np.ndarray, F: np.ndarray, w: np.ndarray | None = None) -> np.ndarray:
    """Spearman's ρ between the columns of ``X`` (n, p) and ``F`` (n, k) over the rows
    where ``F`` is finite. Returns (p, k); 0 where a column is constant, NaN where fewer than
    3 rows are usable.

    With importance weights ``w`` (n,), the weighted Pearson correlation of the weighted
    mid-ranks: Spearman's ρ of the distribution the weighted sample stands for.
    """
    X = np.asarray(X, float)
    F = np.asarray(F, float)
    ok = np.all(np.isfinite(F), axis=1) & np.all(np.isfinite(X), axis=1)
    p, k = X.shape[1], F.shape[1]
    if ok.sum() < 3:
        return np.full((p, k), np.nan)
    if w is not None:
        wo = np.asarray(w, float)[ok]
        RX = np.column_stack([weighted_ranks(c, wo) for c in X[ok].T]) if p else X[ok]
        RF = np.column_stack([weighted_ranks(c, wo) for c in F[ok].T])
        return weighted_pearson(RX, RF, wo)
    from scipy import stats  # imported where used: it loads slowly

    RX = np.column_stack([stats.rankdata(c) for c in X[ok].T]) if p else np.empty((ok.sum(), 0))
    RF = np.column_stack([stats.rankdata(c) for c in F[ok].T])

    def z(R: np.ndarray) -> np.ndarray:
        Z = R - R.mean(axis=0)
        sd = np.sqrt((Z**2).sum(axis=0))
        return Z / np.where(sd > 0, sd, np.inf)

    return np.clip(z(RX).T @ z(RF), -1.0, 1.0)


def ks_filtering(
    X: np.ndarray, behavioural: np.ndarray, w: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Two-sample KS statistic and p-value per parameter between behavioural rows and the
    others. Returns ``(statistic (p,), pvalue (p,))``; NaN when a group is empty.

    With importance weights ``w`` (n,): the weighted empirical CDFs, p-values from Kish's
    effective sizes (:func:`~vectorid.analysis.weights.weighted_ks`)."""
    X = np.asarray(X, float)
    b = np.asarray(behavioural, bool)
    p = X.shape[1]
    stat = np.full(p, np.nan)
    pval = np.full(p, np.nan)
    if b.any() and (~b).any():
        wb = None if w is None else np.asarray(w, float)[b]
        wo = None if w is None else np.asarray(w, float)[~b]
        for j in range(p):
            stat[j], pval[j] = weighted_ks(X[b, j], X[~b, j], wb, wo)
    return stat, pval


def ks_statistics(
    X: np.ndarray, behavioural: np.ndarray, w: np.ndarray | None = None
) -> np.ndarray:
    """The KS statistics of :func:`ks_filtering` alone (no p-value), with numpy only: the
    largest gap between the (weighted) empirical CDFs of the behavioural rows and of the
    others, per parameter; NaN when a group is empty. For a caller that needs no p-value
    (the UI's axis ranking), without loading ``scipy.stats`` (~22 MB resident)."""
    X = np.asarray(X, float)
    b = np.asarray(behavioural, bool)
    stat = np.full(X.shape[1], np.nan)
    if not (b.any() and (~b).any()):
        return stat
    w = np.ones(len(b)) if w is None else np.asarray(w, float)

    def cdf(v: np.ndarray, wv: np.ndarray, grid: np.ndarray) -> np.ndarray:
        o = np.argsort(v, kind="stable")
        c = np.concatenate([[0.0], np.cumsum(wv[o])]) / wv.sum()
        return c[np.searchsorted(v[o], grid, side="right")]

    for j in range(X.shape[1]):
        x, y = X[b, j], X[~b, j]
        grid = np.sort(np.concatenate([x, y]))
        stat[j] = float(np.max(np.abs(cdf(x, w[b], grid) - cdf(y, w[~b], grid))))
    return stat


def _ks_rows(a: Analysis) -> tuple[np.ndarray, np.ndarray | None, float]:
    """The rows :func:`sensitivity` weighs (all; on a sequential store D's and at most
    :data:`WEIGHED_REST` others), their weights (None: every trial counts once) over all
    trials, and the stride of the others."""
    n_rest = a.n - a.n_feasible
    rows = np.ones(a.n, bool)
    stride = 1.0
    if a.weighting is not None and n_rest > WEIGHED_REST:
        # a seeded random subset, not every k-th row: every k-th point of a Sobol sequence
        # is not uniform (generation 0 is one)
        rest = np.flatnonzero(~a.feasible)
        keep = np.random.default_rng(0).choice(rest, WEIGHED_REST, replace=False)
        rows = a.feasible.copy()
        rows[keep] = True
        stride = n_rest / WEIGHED_REST
    w_rows = trial_weights(a, rows)
    if w_rows is None:  # a plain store (or stages mixed in): every trial counts once
        return np.ones(a.n, bool), None, 1.0
    w = np.zeros(a.n)
    w[rows] = w_rows
    w[rows & ~a.feasible] *= stride
    return rows, w, stride


def ks_of(a: Analysis) -> np.ndarray:
    """The KS statistics :func:`sensitivity` gives (``Sensitivity.ks``: D against the other
    trials per parameter, weighted alike), computed by :func:`ks_statistics` (numpy only)."""
    rows, w, _ = _ks_rows(a)
    return ks_statistics(a.trials.X[rows], a.feasible[rows], None if w is None else w[rows])


@dataclass
class Sensitivity:
    """Sensitivity of the criteria and of feasibility to each parameter.

    Attributes
    ----------
    params, criteria : list of str
    spearman : (p, k) float
    ks : (p,) float
        KS statistic between D and its complement per parameter.
    ks_pvalue : (p,) float
    n_behavioural, n_other : int
    weighted : bool
        Both statistics use a sequential store's importance weights.
    ess_behavioural, ess_other : float
        Kish's effective sizes of the two groups (their counts when unweighted).
    stride : float
        Weighted: one in ``stride`` trials outside D was weighed (a seeded random subset, each
        weighing ``stride`` times as much; 1: all of them).
    """

    params: list[str]
    criteria: list[str]
    spearman: np.ndarray
    ks: np.ndarray
    ks_pvalue: np.ndarray
    n_behavioural: int
    n_other: int
    weighted: bool = False
    ess_behavioural: float = float("nan")
    ess_other: float = float("nan")
    stride: float = 1.0

    def ranking(self) -> list[tuple[str, float]]:
        """Parameters by decreasing KS statistic."""
        order = np.argsort(-np.nan_to_num(self.ks, nan=-1.0), kind="stable")
        return [(self.params[j], float(self.ks[j])) for j in order]

    def to_dict(self) -> dict[str, Any]:
        return {
            "params": self.params,
            "criteria": self.criteria,
            "spearman": self.spearman.tolist(),
            "ks": self.ks.tolist(),
            "ks_pvalue": self.ks_pvalue.tolist(),
            "n_behavioural": self.n_behavioural,
            "n_other": self.n_other,
            "weighted": self.weighted,
            "ess_behavioural": self.ess_behavioural,
            "ess_other": self.ess_other,
            "stride": self.stride,
            "ranking": [{"param": n, "ks": v} for n, v in self.ranking()],
        }


#: A sequential store's weights cost a pass over every generation's kernel per trial (about
#: 5 ms a trial for 50,000 trials in 59 generations on a loaded 2-core machine), so the trials
#: outside D are weighed at most this many (a seeded random subset, each weighing n_rest /
#: WEIGHED_REST times as much); D's are all weighed. The effective sizes printed are those of
#: the trials weighed.
WEIGHED_REST = 3000


def sensitivity(a: Analysis) -> Sensitivity:
    """Rank correlations over successful trials and KS filtering on D vs the rest
    (importance-weighted on a sequential store, the rest thinned to :data:`WEIGHED_REST`)."""

    X, F = a.trials.X, a.trials.F
    n_rest = a.n - a.n_feasible
    rows, w, stride = _ks_rows(a)
    d, ok = a.feasible[rows], a.ok[rows]
    wr = None if w is None else w[rows]
    ks, pv = ks_filtering(X[rows], d, wr)
    return Sensitivity(
        params=a.spec.space.names,
        criteria=list(a.crit_names),
        spearman=rank_correlation(X[rows][ok], F[rows][ok], None if wr is None else wr[ok]),
        ks=ks,
        ks_pvalue=pv,
        n_behavioural=a.n_feasible,
        n_other=n_rest,
        weighted=w is not None,
        ess_behavioural=kish(None if wr is None else wr[d], int(d.sum())),
        ess_other=kish(None if wr is None else wr[~d], int((~d).sum())),
        stride=stride,
    )
