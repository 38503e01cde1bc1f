"""Importance weights of a sequential store's trials, and the weighted statistics that use them.

The sequential sampler (:mod:`vectorid.samplers.sequential`) draws later generations from
kernels around the accepted trials, so its trials are not uniform in the box: a density, a
quantile, a correlation or a KS statistic computed over them as if they were would describe the
sampler, not D. Each trial's importance weight ``p_box(x) / sum_g (n_g/N) q_g(x)`` (stored
generations, :mod:`vectorid.samplers.sequential.weights`) makes any set of them selected by
limits a weighted sample of the box's uniform density restricted to that set: the statistic a
plain Sobol table would give with unboundedly many trials. Plain stores have no weights (every
trial counts once); :func:`trial_weights` returns None for them and each statistic here reduces
to its unweighted form.

With 20 or more variables the sampler moves particles by Markov-chain steps instead
(:mod:`vectorid.samplers.sequential.moves`), and its trials carry no importance weight: the
weight of a member of D at the stated limits is its *holding time* — how many of the chains'
moves kept at the stated limits (after the warm-up) ended with a particle on it, rejected moves
included — which makes D's members an MCMC sample of the uniform density on D. Members never
held weigh 0; a set of rows that reaches outside D (limits loosened after the run, or trials
outside D) has no such weights, and its rows count once each.

Counts (N, ND, NP), the test tables, the Pareto set and ranges (min and max over D) are not
densities: they are the same with or without weights.
"""

from __future__ import annotations

import numpy as np

from ..samplers import kish_ess
from .results import Analysis

__all__ = [
    "WEIGHTED_NOTE",
    "how_weighted",
    "kish",
    "trial_weights",
    "weighted_ks",
    "weighted_pearson",
    "weighted_quantile",
    "weighted_ranks",
]

#: Said wherever a weighted statistic is printed.
WEIGHTED_NOTE = "importance-weighted (sequential sampler)"


def how_weighted(a: Analysis) -> str:
    """How D's densities are weighted on ``a``'s sequential store, in words: by importance
    weights (the mixture, fewer than 20 variables) or by the particles' holding times (the
    moves, 20 or more)."""
    if a.weighting is not None:
        return a.weighting.how
    return "importance-weighted"


def trial_weights(a: Analysis, mask: np.ndarray | None = None) -> np.ndarray | None:
    """Importance weights of ``a``'s trials (rows of ``mask``; all rows by default), scaled
    to mean 1 over those rows; None for a plain store (every trial counts once).

    Only trials of the sequential sampler's generations (sample stage 0) carry a weight. When
    the rows include trials of a later sample stage (e.g. a refined box added after the run),
    their density is not the generations' mixture, so no weight is claimed for any row: None.
    """
    if a.weighting is None:
        return None
    weigh = a.weighting.log_weight
    rows = np.ones(a.n, bool) if mask is None else np.asarray(mask, bool)
    if rows.any() and np.any(a.trials.stage[rows] != 0):
        return None
    if not rows.any():
        return np.empty(0)
    lw = np.asarray(weigh(a.trials.X[rows]), dtype=float)
    # a moved store (many variables) weighs only D's members at the stated limits, by their
    # holding times in the particles' chains (NaN elsewhere, -inf for a member never held):
    # rows that hold a NaN, or no weight at all, are counted once each
    if np.isnan(lw).any() or not np.isfinite(lw).any():
        return None
    w = np.exp(lw - np.max(lw))
    return w * (len(w) / w.sum())


def kish(w: np.ndarray | None, n: int) -> float:
    """Kish's effective sample size ``(Σw)² / Σw²`` of weights ``w``
    (:func:`vectorid.samplers.kish_ess`); ``n`` when unweighted."""
    if w is None:
        return float(n)
    with np.errstate(divide="ignore"):
        return kish_ess(np.log(np.asarray(w, dtype=float)))


def _w(x: np.ndarray, w: np.ndarray | None) -> np.ndarray:
    return np.ones(len(x)) if w is None else np.asarray(w, dtype=float)


def weighted_quantile(x: np.ndarray, q, w: np.ndarray | None = None) -> np.ndarray:
    """Quantiles ``q`` of ``x`` (n,) under weights ``w`` (``np.quantile`` when None).

    The weighted version interpolates the midpoints of each sample's weight on the CDF
    (Hyndman–Fan type 5 generalised to weights), so equal weights give np.quantile's
    'hazen' method up to the ends.
    """
    x = np.asarray(x, dtype=float)
    if w is None:
        return np.quantile(x, q)
    o = np.argsort(x, kind="stable")
    xs, ws = x[o], np.asarray(w, float)[o]
    c = (np.cumsum(ws) - 0.5 * ws) / ws.sum()
    return np.interp(q, c, xs)


def weighted_ranks(x: np.ndarray, w: np.ndarray | None = None) -> np.ndarray:
    """Weighted mid-ranks of ``x`` (n,) on [0, 1]: the weight of the values below plus half
    the weight of the values equal (ties share it), over the total; with equal weights
    ``(rank - 0.5) / n``."""
    x = np.asarray(x, dtype=float)
    ww = _w(x, w)
    o = np.argsort(x, kind="stable")
    xs, ws = x[o], ww[o]
    below = np.concatenate([[0.0], np.cumsum(ws)])
    # ties: every member of a run of equal values gets the run's mid weight
    starts = np.searchsorted(xs, xs, side="left")
    ends = np.searchsorted(xs, xs, side="right")
    mid = 0.5 * (below[starts] + below[ends])
    out = np.empty(len(x))
    out[o] = mid / below[-1] if below[-1] > 0 else 0.0
    return out


def weighted_pearson(A: np.ndarray, B: np.ndarray, w: np.ndarray | None = None) -> np.ndarray:
    """Weighted Pearson correlation between the columns of ``A`` (n, p) and ``B`` (n, k):
    (p, k); 0 where a column is constant, NaN where fewer than 3 rows."""
    A = np.asarray(A, float)
    B = np.asarray(B, float)
    p, k = A.shape[1], B.shape[1]
    if len(A) < 3:
        return np.full((p, k), np.nan)
    ww = _w(A, w)
    ww = ww / ww.sum()

    def z(M: np.ndarray) -> np.ndarray:
        Z = M - ww @ M
        sd = np.sqrt(ww @ Z**2)
        scale = np.abs(M).max(axis=0) if len(M) else np.ones(M.shape[1])
        ok = sd > 1e-12 * np.where(scale > 0, scale, 1.0)
        Z[:, ok] /= sd[ok]
        Z[:, ~ok] = 0.0
        return Z

    return np.clip((z(A) * ww[:, None]).T @ z(B), -1.0, 1.0)


def weighted_ks(
    x: np.ndarray, y: np.ndarray, wx: np.ndarray | None = None, wy: np.ndarray | None = None
) -> tuple[float, float]:
    """Two-sample Kolmogorov–Smirnov statistic between weighted samples ``x`` and ``y`` and
    its asymptotic p-value with Kish's effective sizes in place of the counts.

    Unweighted (both None) it is ``scipy.stats.ks_2samp`` (exact p-value where scipy gives
    one). Returns ``(nan, nan)`` when a sample is empty.
    """
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    if not len(x) or not len(y):
        return float("nan"), float("nan")
    from scipy import stats  # imported where used: it loads slowly

    if wx is None and wy is None:
        r = stats.ks_2samp(x, y)
        return float(r.statistic), float(r.pvalue)
    a, b = _w(x, wx), _w(y, wy)
    grid = np.sort(np.concatenate([x, y]))

    def cdf(v: np.ndarray, wv: np.ndarray) -> np.ndarray:
        o = np.argsort(v, kind="stable")
        c = np.concatenate([[0.0], np.cumsum(wv[o])]) / wv.sum()
        return c[np.searchsorted(v[o], grid, side="right")]

    d = float(np.max(np.abs(cdf(x, a) - cdf(y, b))))
    n1, n2 = kish(a, len(a)), kish(b, len(b))
    en = np.sqrt(n1 * n2 / (n1 + n2)) if n1 + n2 > 0 else 0.0
    return d, float(stats.kstwobign.sf(d * en)) if en > 0 else float("nan")
