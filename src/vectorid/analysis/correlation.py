"""Correlation among near-optimal vectors (seed 000 Fig. 14) and parameter spread relative
to nominal (seed 000 Figs. 12–13).

Over the feasible or Pareto trials, strongly correlated parameter pairs show that the
criteria constrain a combination of the two rather than each one: such a pair could be
merged into one parameter (the fitted line is reported). A parameter whose near-optimal
values span a small part of its box is well determined and could be fixed at its median.

On a sequential store the trials are not uniform in the box, so the correlation, the fitted
line, the quantiles and the median use the trials' importance weights
(:mod:`vectorid.analysis.weights`); :attr:`CorrelationResult.weighted` says so.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import StudyDefinitionError
from .results import Analysis
from .weights import trial_weights, weighted_pearson, weighted_quantile, weighted_ranks

__all__ = [
    "CorrelationResult",
    "Spread",
    "correlation",
    "correlation_of",
    "parameter_spread",
]


@dataclass
class CorrelationResult:
    """Correlation of parameters over a set of trials.

    Attributes
    ----------
    names : list of str
        Parameter names (rows and columns of ``matrix``).
    matrix : (p, p) float
        Pearson or Spearman correlation; 0 off the diagonal for a constant parameter.
    n : int
        Trials used.
    method : str
    threshold : float
        ``|r|`` at or above which a pair is "strong".
    pairs : list of dict
        Strong pairs, strongest first: ``a``, ``b``, ``r``, and the least-squares line
        ``b ≈ intercept + slope · a`` with its coefficient of determination.
    groups : list of list of str
        Connected groups of strongly correlated parameters (candidates for merging).
    fixed : list of dict
        Parameters whose relative spread ``(Q95 − Q05) / box width`` is at most
        ``spread_threshold``: name, spread, median (candidates for fixing).
    relative_spread : (p,) float
    weighted : bool
        The statistics use a sequential store's importance weights.
    """

    names: list[str]
    matrix: np.ndarray
    n: int
    method: str
    threshold: float
    pairs: list[dict[str, Any]] = field(default_factory=list)
    groups: list[list[str]] = field(default_factory=list)
    fixed: list[dict[str, Any]] = field(default_factory=list)
    relative_spread: np.ndarray | None = None
    weighted: bool = False

    def to_dict(self) -> dict[str, Any]:
        return {
            "names": self.names,
            "n": self.n,
            "method": self.method,
            "threshold": self.threshold,
            "matrix": self.matrix.tolist(),
            "pairs": self.pairs,
            "groups": self.groups,
            "fixed": self.fixed,
            "weighted": self.weighted,
        }


def _corr(X: np.ndarray, method: str, w: np.ndarray | None = None) -> np.ndarray:
    if w is not None and method in ("pearson", "spearman"):
        if method == "spearman":
            X = np.column_stack([weighted_ranks(c, w) for c in X.T]) if len(X) else X
        p = X.shape[1]
        if len(X) < 2:
            return np.eye(p)
        R = np.nan_to_num(weighted_pearson(X, X, w) if len(X) >= 3 else np.eye(p))
        np.fill_diagonal(R, 1.0)
        return R
    if method == "spearman":
        from scipy import stats  # imported where used: it loads slowly

        X = np.apply_along_axis(stats.rankdata, 0, X) if len(X) else X
    elif method != "pearson":
        raise StudyDefinitionError(
            "--method", f"expected 'pearson' or 'spearman', got {method!r}", "use --method pearson"
        )
    p = X.shape[1]
    if len(X) < 2:
        return np.eye(p)
    Z = X - X.mean(axis=0)
    sd = np.sqrt((Z**2).sum(axis=0))
    # a column constant up to rounding (x - mean(x) of a constant is ~1e-16 |x|) is constant
    scale = np.abs(X).max(axis=0) * np.sqrt(len(X))
    ok = sd > 1e-12 * np.where(scale > 0, scale, 1.0)
    Z[:, ok] /= sd[ok]
    R = Z.T @ Z
    R[~ok, :] = 0.0
    R[:, ~ok] = 0.0
    np.fill_diagonal(R, 1.0)
    return np.clip(R, -1.0, 1.0)


def correlation(
    X: np.ndarray,
    names: Sequence[str],
    *,
    method: str = "pearson",
    threshold: float = 0.8,
    lows: np.ndarray | None = None,
    highs: np.ndarray | None = None,
    spread_threshold: float = 0.1,
    weights: np.ndarray | None = None,
) -> CorrelationResult:
    """Correlation matrix, strong pairs, merge groups and fixable parameters.

    Parameters
    ----------
    X : (n, p) float
        Parameter vectors (e.g. the Pareto trials).
    names : sequence of str
    method : {"pearson", "spearman"}
    threshold : float in (0, 1]
        Strong pairs have ``|r| >= threshold``.
    lows, highs : (p,) float, optional
        The box, for the relative spread (default: the range of ``X``).
    spread_threshold : float
        Relative spread at or below which a parameter is proposed for fixing.
    weights : (n,) float, optional
        Importance weights of the rows (a sequential store's): the correlation, the fitted
        lines, the quantiles and the median are weighted.
    """
    X = np.asarray(X, dtype=float)
    w = None if weights is None else np.asarray(weights, dtype=float)
    if X.ndim != 2 or X.shape[1] != len(names):
        raise ValueError(f"expected X of shape (n, {len(names)}), got {X.shape}")
    if not 0.0 < threshold <= 1.0:
        raise StudyDefinitionError(
            "--threshold", f"expected 0 < threshold <= 1, got {threshold}", "e.g. 0.8"
        )
    R = _corr(X, method, w)
    p = len(names)
    pairs = []
    for i in range(p):
        for j in range(i + 1, p):
            r = float(R[i, j])
            if abs(r) >= threshold:
                ww = np.ones(len(X)) if w is None else w
                slope, intercept = np.polyfit(X[:, i], X[:, j], 1, w=np.sqrt(ww))
                pred = intercept + slope * X[:, i]
                mean_j = float(np.average(X[:, j], weights=ww))
                ss = float((ww * (X[:, j] - mean_j) ** 2).sum())
                r2 = 1.0 - float((ww * (X[:, j] - pred) ** 2).sum()) / ss if ss > 0 else 1.0
                pairs.append(
                    {
                        "a": names[i],
                        "b": names[j],
                        "r": r,
                        "slope": float(slope),
                        "intercept": float(intercept),
                        "r2": r2,
                    }
                )
    pairs.sort(key=lambda d: -abs(d["r"]))
    # connected components of the strong-pair graph
    parent = list(range(p))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    index = {n: i for i, n in enumerate(names)}
    for d in pairs:
        parent[root(index[d["a"]])] = root(index[d["b"]])
    comps: dict[int, list[str]] = {}
    for i, n in enumerate(names):
        comps.setdefault(root(i), []).append(n)
    groups = [g for g in comps.values() if len(g) > 1]
    lo = X.min(axis=0) if lows is None else np.asarray(lows, float)
    hi = X.max(axis=0) if highs is None else np.asarray(highs, float)
    width = np.where(hi - lo > 0, hi - lo, 1.0)
    if len(X):
        if w is None:
            q05, q95 = np.quantile(X, 0.05, axis=0), np.quantile(X, 0.95, axis=0)
            med = np.median(X, axis=0)
        else:
            qs = np.array([weighted_quantile(c, [0.05, 0.5, 0.95], w) for c in X.T]).T
            q05, med, q95 = qs[0], qs[1], qs[2]
        rel = (q95 - q05) / width
    else:
        rel = np.full(p, np.nan)
        med = np.full(p, np.nan)
    fixed = [
        {"name": names[j], "spread": float(rel[j]), "median": float(med[j])}
        for j in np.argsort(rel)
        if rel[j] <= spread_threshold
    ]
    return CorrelationResult(
        names=list(names),
        matrix=R,
        n=len(X),
        method=method,
        threshold=float(threshold),
        pairs=pairs,
        groups=groups,
        fixed=fixed,
        relative_spread=rel,
        weighted=w is not None,
    )


def correlation_of(
    a: Analysis,
    subset: str = "pareto",
    *,
    method: str = "pearson",
    threshold: float = 0.8,
    spread_threshold: float = 0.1,
) -> CorrelationResult:
    """:func:`correlation` over the Pareto (``subset="pareto"``) or feasible trials of an
    analysis, with the study box for the relative spread (importance-weighted on a
    sequential store)."""
    if subset not in ("pareto", "feasible"):
        raise StudyDefinitionError(
            "--set", f"expected 'pareto' or 'feasible', got {subset!r}", "use --set feasible"
        )
    mask = a.pareto if subset == "pareto" else a.feasible
    if mask.sum() < 3:
        raise StudyDefinitionError(
            "correlation",
            f"the {subset} set holds {int(mask.sum())} trials; a correlation needs at least 3",
            "relax a criteria constraint, use --set feasible, or run more trials",
        )
    space = a.spec.space
    return correlation(
        a.trials.X[mask],
        space.names,
        method=method,
        threshold=threshold,
        lows=space.lows,
        highs=space.highs,
        spread_threshold=spread_threshold,
        weights=trial_weights(a, mask),
    )


@dataclass
class Spread:
    """Chosen parameter vectors shown relative to nominal (seed 000 Figs. 12–13).

    Attributes
    ----------
    names : list of str
        Parameters (p).
    labels : list of str
        One label per chosen vector (m), e.g. ``"trial 110"``.
    values : (m, p) float
    relative : (m, p) float
        ``value / nominal`` where the nominal is set and non-zero, else the position in
        the box ``(value − low) / (high − low)``.
    mode : (p,) str array
        ``"nominal"`` or ``"box"``: which of the two ``relative`` holds per parameter.
    nominal, lows, highs : (p,) float
    """

    names: list[str]
    labels: list[str]
    values: np.ndarray
    relative: np.ndarray
    mode: np.ndarray
    nominal: np.ndarray
    lows: np.ndarray
    highs: np.ndarray

    def to_dict(self) -> dict[str, Any]:
        return {
            "names": self.names,
            "labels": self.labels,
            "values": self.values.tolist(),
            "relative": self.relative.tolist(),
            "mode": self.mode.tolist(),
            "nominal": self.nominal.tolist(),
        }


def parameter_spread(
    values: np.ndarray,
    names: Sequence[str],
    nominal: np.ndarray,
    lows: np.ndarray,
    highs: np.ndarray,
    labels: Sequence[str] | None = None,
) -> Spread:
    """Chosen vectors relative to nominal.

    Parameters
    ----------
    values : (m, p) float
        The chosen vectors (e.g. several near-optimal trials).
    names : sequence of str
    nominal, lows, highs : (p,) float
        ``Space.nominal`` (NaN where none), ``Space.lows``, ``Space.highs``.
    labels : sequence of str, optional
    """
    V = np.atleast_2d(np.asarray(values, dtype=float))
    nominal = np.asarray(nominal, float)
    lows = np.asarray(lows, float)
    highs = np.asarray(highs, float)
    use_nom = np.isfinite(nominal) & (nominal != 0)
    width = np.where(highs > lows, highs - lows, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(use_nom, V / np.where(use_nom, nominal, 1.0), (V - lows) / width)
    return Spread(
        names=list(names),
        labels=list(labels) if labels is not None else [f"set {i + 1}" for i in range(len(V))],
        values=V,
        relative=rel,
        mode=np.where(use_nom, "nominal", "box"),
        nominal=nominal,
        lows=lows,
        highs=highs,
    )
