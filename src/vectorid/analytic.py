"""Analytic multicriteria test problems with known Pareto sets.

These problems have a closed-form (or root-finding-exact) Edgeworth–Pareto set, so they
serve as ground truth for the PSI pipeline: Sobol trials over the box Π, the feasible set
under functional constraints ``c*_j <= g_j(x) <= c**_j``, and the non-dominated subset.

Registry (``available()``; dimensions p variables / k criteria / q functionals):

===================  ==  ==  ==  ===========================================================
name                 p   k   q   notes
===================  ==  ==  ==  ===========================================================
``binh-korn``        2   2   2   Binh & Korn (1997); both criteria minimised
``binh-korn-max``    2   2   2   same, second criterion negated with sense ``"max"``
``dtlz2-3``          12  3   0   Deb et al. (2002), M = 3, k = 10
``dtlz2-5``          14  5   0   Deb et al. (2002), M = 5, k = 10
``osyczka-kundu``    6   2   6   Osyczka & Kundu (1995)
``tanaka``           2   2   2   Tanaka et al. (1995)
``zdt1``             30  2   0   Zitzler, Deb & Thiele (2000), convex front
``zdt2``             30  2   0   same, concave front
``zdt3``             30  2   0   same, disconnected front (5 pieces)
===================  ==  ==  ==  ===========================================================

Parametrised names are also accepted by :func:`get` (not listed by :func:`available`):
``"zdt1-6"`` (ZDT1/2/3 with 6 variables, any p >= 2; small p lets Sobol sampling get close
to the Pareto set) and ``"dtlz2-4"`` / ``"dtlz2-4-k3"`` (DTLZ2 with M = 4 criteria and
k = 10 / k = 3 distance variables, p = M + k - 1).

Note for sampling demos: unscrambled Sobol sequences start at the origin, which is
Pareto-optimal for ZDT (f = (0, 1)); with the standard 30 variables it dominates every other
of the first 4096 points, so the non-dominated subset is that single point. Use few
variables (``"zdt1-2"``, ``"zdt1-3"``) to watch the trials approach the Pareto set.

All criteria and variables are dimensionless. All functions are batch-vectorised: inputs are
``(n, p)`` arrays, ``n`` may be 0. Formulas are evaluated outside the box Π as well, but
the Pareto-set residual is only meaningful (and only guaranteed ``>= 0``) inside Π.

Where the Pareto set has isolated seam points (the disconnected fronts of ZDT3 and Tanaka),
the residual is zero on the *closure* of the Pareto set; the added seam points are weakly
dominated (a set of measure zero) and are never returned by ``pareto_front``/``pareto_set``.
"""

from __future__ import annotations

import difflib
import functools
import itertools
import math
import operator
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
from scipy.optimize import brentq

__all__ = [
    "AnalyticProblem",
    "available",
    "get",
    "osyczka_kundu_vertices",
    "tanaka_angle_intervals",
    "zdt3_intervals",
]

FloatArray = npt.NDArray[np.float64]

_HALF_PI = 0.5 * math.pi


# --------------------------------------------------------------------------------------
# The problem object
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class AnalyticProblem:
    """A multicriteria test problem with a known Pareto set.

    Parameters
    ----------
    name : str
        Registry name, e.g. ``"zdt1"``.
    title : str
        Human-readable title with the reference (author, year).
    variables : tuple of (str, float, float)
        ``(name, low, high)`` for every design variable; together they form the box Π.
    criteria : tuple of (str, str)
        ``(name, sense)`` with sense ``"min"`` or ``"max"``.
    constraints : tuple of (str, float or None, float or None)
        ``(name, low, high)`` for the functional constraints ``low <= g_j(x) <= high``;
        ``None`` means unbounded on that side.
    residual_definition : str
        What :meth:`pareto_set_residual` measures for this problem.
    _evaluate, _pareto_set, _residual, _front
        Vectorised implementations (internal; use :func:`get` to build problems).
    """

    name: str
    title: str
    variables: tuple[tuple[str, float, float], ...]
    criteria: tuple[tuple[str, str], ...]
    constraints: tuple[tuple[str, float | None, float | None], ...]
    residual_definition: str = field(default="", compare=False)
    _evaluate: Callable[[FloatArray], tuple[FloatArray, FloatArray]] | None = field(
        default=None, repr=False, compare=False
    )
    _pareto_set: Callable[[int], FloatArray] | None = field(default=None, repr=False, compare=False)
    _residual: Callable[[FloatArray], FloatArray] | None = field(
        default=None, repr=False, compare=False
    )
    _front: Callable[[int], FloatArray] | None = field(default=None, repr=False, compare=False)

    def __post_init__(self) -> None:
        for vname, low, high in self.variables:
            if not (np.isfinite(low) and np.isfinite(high) and low < high):
                raise ValueError(
                    f"{self.name}: variable {vname!r} needs finite bounds low < high, "
                    f"got ({low}, {high})"
                )
        for cname, sense in self.criteria:
            if sense not in ("min", "max"):
                raise ValueError(
                    f"{self.name}: criterion {cname!r} sense must be 'min' or 'max', got {sense!r}"
                )
        for gname, low, high in self.constraints:
            if low is None and high is None:
                raise ValueError(f"{self.name}: constraint {gname!r} has neither bound")

    # ---- metadata ---------------------------------------------------------------------

    @property
    def n_var(self) -> int:
        """Number of design variables p."""
        return len(self.variables)

    @property
    def n_obj(self) -> int:
        """Number of criteria k."""
        return len(self.criteria)

    @property
    def n_con(self) -> int:
        """Number of constrained functionals q."""
        return len(self.constraints)

    @property
    def lower(self) -> FloatArray:
        """Lower corner of the box Π, shape ``(p,)``."""
        return np.array([v[1] for v in self.variables], dtype=np.float64)

    @property
    def upper(self) -> FloatArray:
        """Upper corner of the box Π, shape ``(p,)``."""
        return np.array([v[2] for v in self.variables], dtype=np.float64)

    @property
    def senses(self) -> tuple[str, ...]:
        """Sense (``"min"``/``"max"``) of each criterion."""
        return tuple(c[1] for c in self.criteria)

    # ---- computations -----------------------------------------------------------------

    def _as_points(self, X: npt.ArrayLike) -> FloatArray:
        arr = np.asarray(X, dtype=np.float64)
        if arr.ndim != 2 or arr.shape[1] != self.n_var:
            raise ValueError(
                f"{self.name}: expected design points of shape (n, {self.n_var}), got shape "
                f"{arr.shape}; pass a 2-D array (use X[None, :] for a single point)"
            )
        return arr

    def _need(self, impl: Callable | None, what: str) -> Callable:
        if impl is None:
            raise NotImplementedError(f"{self.name}: {what} is not implemented for this problem")
        return impl

    def evaluate(self, X: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Evaluate criteria and constrained functionals.

        Parameters
        ----------
        X : array_like, shape (n, p)
            Design points (dimensionless).

        Returns
        -------
        F : ndarray, shape (n, k), float64
            Criteria values, in the problem's own senses (see :attr:`criteria`).
        G : ndarray, shape (n, q), float64
            Functional values ``g_j(x)``, to be checked against :attr:`constraints`;
            shape ``(n, 0)`` if the problem has no functional constraints.
        """
        arr = self._as_points(X)
        F, G = self._need(self._evaluate, "evaluate")(arr)
        n = arr.shape[0]
        return (
            np.asarray(F, dtype=np.float64).reshape(n, self.n_obj),
            np.asarray(G, dtype=np.float64).reshape(n, self.n_con),
        )

    def feasible(self, X: npt.ArrayLike, atol: float = 0.0) -> npt.NDArray[np.bool_]:
        """Whether each point satisfies every functional constraint (box not checked).

        Parameters
        ----------
        X : array_like, shape (n, p)
            Design points.
        atol : float, default 0
            Absolute tolerance on each bound (same units as the functional). Pareto-set
            points on an active constraint satisfy it only up to rounding (about 1e-15),
            so checks of :meth:`pareto_set` output need e.g. ``atol=1e-12``.

        Returns
        -------
        ndarray of bool, shape (n,)
        """
        if not (np.isfinite(atol) and atol >= 0):
            raise ValueError(f"{self.name}: atol must be a finite number >= 0, got {atol}")
        _, G = self.evaluate(X)
        ok = np.ones(G.shape[0], dtype=bool)
        for j, (_, low, high) in enumerate(self.constraints):
            if low is not None:
                ok &= G[:, j] >= low - atol
            if high is not None:
                ok &= G[:, j] <= high + atol
        return ok

    def pareto_set(self, n: int) -> FloatArray:
        """Design points on the Pareto set.

        Parameters
        ----------
        n : int
            Requested number of points (>= 0).

        Returns
        -------
        ndarray, shape (m, p)
            ``m == n`` for the bi-criteria problems (points evenly spaced along the front in
            range-normalised criteria arc length, ordered by increasing first criterion);
            for DTLZ2, ``m`` is the size of the Das–Dennis lattice closest to ``n``.
            Points on an active functional constraint (Tanaka, Osyczka–Kundu) satisfy it
            up to rounding only (about 1e-15).
        """
        n = _check_count(n, self.name)
        return self._need(self._pareto_set, "pareto_set")(n)

    def pareto_front(self, n: int) -> FloatArray:
        """Points on the true Pareto front in criteria space.

        Parameters
        ----------
        n : int
            Requested number of points (>= 0).

        Returns
        -------
        ndarray, shape (m, k)
            Criteria values (problem's own senses) of :meth:`pareto_set` points; ``m ≈ n``
            as described there.
        """
        n = _check_count(n, self.name)
        if self._front is not None:
            return self._front(n)
        return self.evaluate(self.pareto_set(n))[0]

    def pareto_set_residual(self, X: npt.ArrayLike) -> FloatArray:
        """Non-negative residual that is exactly zero on the Pareto set.

        The meaning is problem specific, see :attr:`residual_definition`
        (e.g. ZDT: ``g(x) - 1``; DTLZ2: ``g(x)``; Binh–Korn: Euclidean distance in design
        space to the Pareto set).

        Parameters
        ----------
        X : array_like, shape (n, p)
            Design points inside Π.

        Returns
        -------
        ndarray, shape (n,), float64
        """
        arr = self._as_points(X)
        res = self._need(self._residual, "pareto_set_residual")(arr)
        return np.asarray(res, dtype=np.float64).reshape(arr.shape[0])


def _check_count(n: int, name: str) -> int:
    try:
        n = operator.index(n)
    except TypeError:
        raise TypeError(
            f"{name}: number of points must be an integer, got {type(n).__name__}"
        ) from None
    if n < 0:
        raise ValueError(f"{name}: number of points must be >= 0, got {n}")
    return n


# --------------------------------------------------------------------------------------
# Shared helpers
# --------------------------------------------------------------------------------------

# A Pareto-set piece: t in [0, 1] (shape (m,)) -> design points (m, p), plus whether its
# start / end point is excluded (weakly dominated seam point of a disconnected front).
_Piece = tuple[Callable[[FloatArray], FloatArray], bool, bool]

_SEAM_OFFSET = 1e-9  # parameter offset that keeps samples off excluded seam points
_DENSE = 2049  # samples per piece used to measure arc length


def _sample_pieces(
    pieces: Sequence[_Piece],
    evaluate: Callable[[FloatArray], tuple[FloatArray, FloatArray]],
    n: int,
    n_var: int,
) -> FloatArray:
    """``n`` design points evenly spaced in normalised criteria arc length over pieces."""
    if n == 0:
        return np.empty((0, n_var), dtype=np.float64)
    t = np.linspace(0.0, 1.0, _DENSE)
    fronts = [evaluate(piece(t))[0] for piece, _, _ in pieces]
    allf = np.concatenate(fronts)
    span = np.ptp(allf, axis=0)
    span[span == 0] = 1.0
    cums = []
    for f in fronts:
        step = np.sqrt((np.diff(f / span, axis=0) ** 2).sum(axis=1))
        cums.append(np.concatenate(([0.0], np.cumsum(step))))
    lengths = np.array([c[-1] for c in cums])
    ends = np.cumsum(lengths)
    starts = ends - lengths
    s = np.linspace(0.0, ends[-1], n)
    # s exactly at a seam goes to the earlier piece (its end point).
    which = np.minimum(np.searchsorted(ends, s, side="left"), len(pieces) - 1)
    out = np.empty((n, n_var), dtype=np.float64)
    for i, (piece, open_start, open_end) in enumerate(pieces):
        sel = which == i
        if not sel.any():
            continue
        ti = np.interp(s[sel] - starts[i], cums[i], t)
        lo = _SEAM_OFFSET if open_start else 0.0
        hi = 1.0 - _SEAM_OFFSET if open_end else 1.0
        out[sel] = piece(np.clip(ti, lo, hi))
    return out


def _segment(a: Sequence[float], b: Sequence[float]) -> Callable[[FloatArray], FloatArray]:
    """Straight design-space segment ``a + t (b - a)``."""
    a_ = np.asarray(a, dtype=np.float64)
    b_ = np.asarray(b, dtype=np.float64)
    return lambda t: a_[None, :] + np.asarray(t, dtype=np.float64)[:, None] * (b_ - a_)[None, :]


def _distance_to_segments(X: FloatArray, A: FloatArray, B: FloatArray) -> FloatArray:
    """Euclidean distance from each row of ``X`` to the union of segments ``[A_i, B_i]``."""
    best = np.full(X.shape[0], np.inf)
    for a, b in zip(A, B):
        d = b - a
        dd = float(d @ d)
        t = np.zeros(X.shape[0]) if dd == 0 else np.clip((X - a) @ d / dd, 0.0, 1.0)
        dist = np.sqrt(((X - a - t[:, None] * d) ** 2).sum(axis=1))
        best = np.minimum(best, dist)
    return best


def _distance_to_intervals(x: FloatArray, intervals: FloatArray) -> FloatArray:
    """Distance from each value of ``x`` to the union of closed intervals (rows [lo, hi])."""
    lo = intervals[:, 0][None, :]
    hi = intervals[:, 1][None, :]
    xx = x[:, None]
    return np.maximum(np.maximum(lo - xx, xx - hi), 0.0).min(axis=1)


def _no_constraints(n: int) -> FloatArray:
    return np.empty((n, 0), dtype=np.float64)


def _unit_vars(p: int) -> tuple[tuple[str, float, float], ...]:
    return tuple((f"x{i + 1}", 0.0, 1.0) for i in range(p))


# --------------------------------------------------------------------------------------
# Binh–Korn
# --------------------------------------------------------------------------------------


def _binh_korn(maximise_second: bool) -> AnalyticProblem:
    """Binh–Korn problem (BNH).

    Binh, T. T. & Korn, U. (1997). MOBES: A multiobjective evolution strategy for
    constrained optimization problems. Proc. 3rd Int. Conf. on Genetic Algorithms
    (MENDEL'97), Brno, pp. 176–182. Also Deb, K. (2001), *Multi-Objective Optimization
    using Evolutionary Algorithms*, Wiley, problem BNH.

    ``f1 = 4 x1² + 4 x2²``, ``f2 = (x1 - 5)² + (x2 - 5)²`` (both minimised) on
    ``x1 ∈ [0, 5]``, ``x2 ∈ [0, 3]``, subject to ``g1 = (x1 - 5)² + x2² <= 25`` and
    ``g2 = (x1 - 8)² + (x2 + 3)² >= 7.7``. Pareto set: ``x1 = x2 ∈ [0, 3]`` and
    ``x1 ∈ [3, 5], x2 = 3`` (constraints inactive there); front from (0, 50) to (136, 4).

    With ``maximise_second`` the second criterion is ``-f2`` with sense ``"max"``
    (``binh-korn-max``), which has the same Pareto set and exercises mixed senses.
    """

    def evaluate(X: FloatArray) -> tuple[FloatArray, FloatArray]:
        x1, x2 = X[:, 0], X[:, 1]
        f1 = 4.0 * x1**2 + 4.0 * x2**2
        f2 = (x1 - 5.0) ** 2 + (x2 - 5.0) ** 2
        g1 = (x1 - 5.0) ** 2 + x2**2
        g2 = (x1 - 8.0) ** 2 + (x2 + 3.0) ** 2
        F = np.stack([f1, -f2 if maximise_second else f2], axis=1)
        return F, np.stack([g1, g2], axis=1)

    vertices = np.array([[0.0, 0.0], [3.0, 3.0], [5.0, 3.0]])
    pieces: list[_Piece] = [
        (_segment(vertices[0], vertices[1]), False, False),
        (_segment(vertices[1], vertices[2]), False, False),
    ]

    def residual(X: FloatArray) -> FloatArray:
        return _distance_to_segments(X, vertices[:-1], vertices[1:])

    name = "binh-korn-max" if maximise_second else "binh-korn"
    title = "Binh–Korn (Binh & Korn 1997)"
    crit: tuple[tuple[str, str], ...] = (("f1", "min"), ("f2", "min"))
    if maximise_second:
        title += ", second criterion negated and maximised"
        crit = (("f1", "min"), ("neg_f2", "max"))
    return AnalyticProblem(
        name=name,
        title=title,
        variables=(("x1", 0.0, 5.0), ("x2", 0.0, 3.0)),
        criteria=crit,
        constraints=(("g1", None, 25.0), ("g2", 7.7, None)),
        residual_definition=(
            "Euclidean design-space distance to the Pareto set (polyline (0,0)-(3,3)-(5,3))"
        ),
        _evaluate=evaluate,
        _pareto_set=lambda n: _sample_pieces(pieces, evaluate, n, 2),
        _residual=residual,
    )


# --------------------------------------------------------------------------------------
# ZDT1, ZDT2, ZDT3
# --------------------------------------------------------------------------------------


def _zdt3_h(x: FloatArray) -> FloatArray:
    return 1.0 - np.sqrt(x) - x * np.sin(10.0 * math.pi * x)


def _zdt3_dh(x: npt.ArrayLike) -> FloatArray:
    """Derivative of :func:`_zdt3_h` (x > 0)."""
    x = np.asarray(x, dtype=np.float64)
    w = 10.0 * math.pi
    return -0.5 / np.sqrt(x) - np.sin(w * x) - w * x * np.cos(w * x)


@functools.cache
def zdt3_intervals() -> FloatArray:
    """The ``x1`` intervals of the ZDT3 Pareto set, shape ``(5, 2)``.

    Computed by root finding on ``h(f1) = 1 - sqrt(f1) - f1 sin(10 π f1)`` (the front is
    ``f2 = h(f1)``): each interval ends at a local minimum of ``h`` that is lower than all
    earlier ones, and starts where ``h`` first falls back to the previous such minimum.
    Literature values (e.g. Deb 2001): [0, 0.0830015349], [0.1822287280, 0.2577623634],
    [0.4093136748, 0.4538821041], [0.6183967944, 0.6525117038],
    [0.8233317983, 0.8518328654].
    """
    grid = np.linspace(1e-6, 1.0, 20001)
    dh = _zdt3_dh(grid)
    idx = np.nonzero(np.sign(dh[:-1]) != np.sign(dh[1:]))[0]
    crit = [brentq(lambda x: float(_zdt3_dh(x)), grid[i], grid[i + 1], xtol=1e-15) for i in idx]
    is_min = [dh[i] < 0 for i in idx]  # derivative goes - to +
    intervals = []
    level = math.inf
    prev_crit = 0.0
    start = 0.0
    for c, m in zip(crit, is_min):
        if m:
            val = float(_zdt3_h(np.array(c)))
            if val < level:
                if math.isfinite(level):
                    lvl = level
                    start = brentq(
                        lambda x, lvl=lvl: float(_zdt3_h(np.array(x))) - lvl,
                        prev_crit,
                        c,
                        xtol=1e-15,
                    )
                intervals.append((start, c))
                level = val
        prev_crit = c
    return np.array(intervals)


def _zdt(which: int, p: int) -> AnalyticProblem:
    """ZDT1/ZDT2/ZDT3.

    Zitzler, E., Deb, K. & Thiele, L. (2000). Comparison of multiobjective evolutionary
    algorithms: empirical results. *Evolutionary Computation* 8(2), 173–195.

    ``x ∈ [0, 1]^p`` (standard p = 30), ``f1 = x1``,
    ``g = 1 + 9 Σ_{i>=2} x_i / (p - 1)``, ``f2 = g h(f1, g)`` with
    ZDT1 ``h = 1 - sqrt(f1/g)``, ZDT2 ``h = 1 - (f1/g)²``,
    ZDT3 ``h = 1 - sqrt(f1/g) - (f1/g) sin(10 π f1)``. Both criteria minimised.
    Pareto set: ``x2 = … = xp = 0`` (g = 1), and for ZDT3 additionally ``x1`` in
    :func:`zdt3_intervals`. Residual: ``g - 1`` (ZDT3: plus the distance of ``x1`` to
    those intervals).
    """

    def evaluate(X: FloatArray) -> tuple[FloatArray, FloatArray]:
        f1 = X[:, 0]
        g = 1.0 + 9.0 * X[:, 1:].sum(axis=1) / (p - 1)
        r = f1 / g
        if which == 1:
            h = 1.0 - np.sqrt(r)
        elif which == 2:
            h = 1.0 - r**2
        else:
            h = 1.0 - np.sqrt(r) - r * np.sin(10.0 * math.pi * f1)
        return np.stack([f1, g * h], axis=1), _no_constraints(X.shape[0])

    def on_set(lo: float, hi: float) -> Callable[[FloatArray], FloatArray]:
        def piece(t: FloatArray) -> FloatArray:
            X = np.zeros((t.shape[0], p))
            X[:, 0] = lo + t * (hi - lo)
            return X

        return piece

    if which == 3:
        iv = zdt3_intervals()
        pieces: list[_Piece] = [(on_set(a, b), i > 0, False) for i, (a, b) in enumerate(iv)]

        def residual(X: FloatArray) -> FloatArray:
            g1 = 9.0 * X[:, 1:].sum(axis=1) / (p - 1)
            return g1 + _distance_to_intervals(X[:, 0], iv)

        rdef = "g(x) - 1 plus the distance of x1 to the ZDT3 Pareto intervals"
    else:
        pieces = [(on_set(0.0, 1.0), False, False)]

        def residual(X: FloatArray) -> FloatArray:
            return 9.0 * X[:, 1:].sum(axis=1) / (p - 1)

        rdef = "g(x) - 1 = 9 Σ_{i>=2} x_i / (p - 1)"

    base = f"zdt{which}"
    shape = {1: "convex", 2: "concave", 3: "disconnected"}[which]
    return AnalyticProblem(
        name=base if p == 30 else f"{base}-{p}",
        title=f"ZDT{which}, {shape} front, {p} variables (Zitzler, Deb & Thiele 2000)",
        variables=_unit_vars(p),
        criteria=(("f1", "min"), ("f2", "min")),
        constraints=(),
        residual_definition=rdef,
        _evaluate=evaluate,
        _pareto_set=lambda n: _sample_pieces(pieces, evaluate, n, p),
        _residual=residual,
    )


# --------------------------------------------------------------------------------------
# DTLZ2
# --------------------------------------------------------------------------------------


def _das_dennis(n: int, M: int) -> FloatArray:
    """Das–Dennis simplex lattice with size closest to ``n`` (rows sum to 1)."""
    if n == 0:
        return np.empty((0, M))
    if n == 1:
        return np.full((1, M), 1.0 / M)
    best_h, best_gap = 1, math.inf
    h = 1
    while True:
        size = math.comb(h + M - 1, M - 1)
        gap = abs(size - n)
        if gap < best_gap:
            best_h, best_gap = h, gap
        if size >= n:
            break
        h += 1
    H = best_h
    bars = np.array(list(itertools.combinations(range(H + M - 1), M - 1)), dtype=np.int64)
    bars = bars.reshape(-1, M - 1)
    edges = np.concatenate(
        [np.full((bars.shape[0], 1), -1), bars, np.full((bars.shape[0], 1), H + M - 1)], axis=1
    )
    return (np.diff(edges, axis=1) - 1) / H


def _dtlz2(M: int, k: int) -> AnalyticProblem:
    """DTLZ2.

    Deb, K., Thiele, L., Laumanns, M. & Zitzler, E. (2002). Scalable multi-objective
    optimization test problems. Proc. IEEE CEC 2002, pp. 825–830 (also in *Evolutionary
    Multiobjective Optimization*, Springer, 2005, pp. 105–145).

    ``x ∈ [0, 1]^p``, ``p = M + k - 1`` (standard k = 10),
    ``g = Σ_{i>=M} (x_i - 0.5)²``, ``θ_i = x_i π/2``,
    ``f_1 = (1+g) Π_{i=1}^{M-1} cos θ_i``,
    ``f_m = (1+g) Π_{i=1}^{M-m} cos θ_i · sin θ_{M-m+1}`` (m = 2..M), all minimised.
    Pareto set: ``x_M = … = x_p = 0.5``; front: the unit sphere in the positive orthant.
    Residual: ``g(x)``. ``pareto_front(n)`` returns a Das–Dennis lattice of the size
    closest to ``n`` projected onto the sphere (``n = 1``: the centre direction).
    """
    p = M + k - 1

    def evaluate(X: FloatArray) -> tuple[FloatArray, FloatArray]:
        n = X.shape[0]
        g = ((X[:, M - 1 :] - 0.5) ** 2).sum(axis=1)
        theta = X[:, : M - 1] * _HALF_PI
        C = np.concatenate([np.ones((n, 1)), np.cumprod(np.cos(theta), axis=1)], axis=1)
        S = np.concatenate([np.sin(theta), np.ones((n, 1))], axis=1)
        F = (1.0 + g)[:, None] * (C * S)[:, ::-1]
        return F, _no_constraints(n)

    def front(n: int) -> FloatArray:
        W = _das_dennis(n, M)
        return W / np.linalg.norm(W, axis=1, keepdims=True) if W.size else W

    def pareto_set(n: int) -> FloatArray:
        F = front(n)
        u = F[:, ::-1]  # u_0 = sin θ_1, ..., u_{M-1} = Π cos θ_i
        tail = np.sqrt(np.cumsum((u**2)[:, ::-1], axis=1)[:, ::-1])  # ||u_j..u_{M-1}||
        theta = np.arctan2(u[:, : M - 1], tail[:, 1:])
        X = np.full((F.shape[0], p), 0.5)
        X[:, : M - 1] = np.clip(theta / _HALF_PI, 0.0, 1.0)
        return X

    std = f"dtlz2-{M}"
    return AnalyticProblem(
        name=std if k == 10 else f"{std}-k{k}",
        title=f"DTLZ2, {M} criteria, k = {k}, {p} variables (Deb, Thiele, Laumanns & Zitzler 2002)",
        variables=_unit_vars(p),
        criteria=tuple((f"f{m + 1}", "min") for m in range(M)),
        constraints=(),
        residual_definition="g(x) = Σ_{i>=M} (x_i - 0.5)^2",
        _evaluate=evaluate,
        _pareto_set=pareto_set,
        _residual=lambda X: ((X[:, M - 1 :] - 0.5) ** 2).sum(axis=1),
        _front=front,
    )


# --------------------------------------------------------------------------------------
# Tanaka
# --------------------------------------------------------------------------------------


def _tanaka_r(phi: FloatArray) -> FloatArray:
    """Radius of the constraint-1 boundary at polar angle ``phi = atan2(x1, x2)``."""
    return np.sqrt(1.0 + 0.1 * np.cos(16.0 * phi))


@functools.cache
def tanaka_angle_intervals() -> FloatArray:
    """Polar-angle intervals ``phi = atan2(x1, x2)`` (radians) of the Tanaka Pareto set.

    The Pareto set lies on the boundary ``r = sqrt(1 + 0.1 cos 16 phi)`` of constraint 1.
    On ``phi ∈ [0, π/4]``, ``x1`` increases monotonically with ``phi`` and the
    non-dominated part is found from ``x2(phi) = r cos phi``: it starts where the curve
    enters the disk of constraint 2 (``r = sin phi + cos phi``), ends at local minima of
    ``x2``, and resumes where ``x2`` falls back to the previous minimum. The set is symmetric
    under ``x1 <-> x2`` (``phi -> π/2 - phi``). Returns shape ``(5, 2)``, increasing.
    """
    d = math.radians

    def r(q: float) -> float:
        return math.sqrt(1.0 + 0.1 * math.cos(16.0 * q))

    def x2(q: float) -> float:
        return r(q) * math.cos(q)

    def dx2(q: float) -> float:
        return -0.8 * math.sin(16.0 * q) / r(q) * math.cos(q) - r(q) * math.sin(q)

    tol = 1e-15
    phi_a = brentq(lambda q: r(q) - math.sin(q) - math.cos(q), d(1.0), d(4.0), xtol=tol)
    phi_b = brentq(dx2, d(10.0), d(14.0), xtol=tol)  # local min of x2
    phi_c = brentq(lambda q: x2(q) - x2(phi_b), d(21.0), d(30.0), xtol=tol)
    phi_d = brentq(dx2, d(30.0), d(38.57), xtol=tol)  # local min of x2
    phi_e = brentq(lambda q: x2(q) - x2(phi_d), d(38.66), d(45.0), xtol=tol)
    h = _HALF_PI
    return np.array(
        [
            [phi_a, phi_b],
            [phi_c, phi_d],
            [phi_e, h - phi_e],
            [h - phi_d, h - phi_c],
            [h - phi_b, h - phi_a],
        ]
    )


def _tanaka() -> AnalyticProblem:
    """Tanaka problem (TNK).

    Tanaka, M., Watanabe, H., Furukawa, Y. & Tanino, T. (1995). GA-based decision support
    system for multicriteria optimization. Proc. IEEE Int. Conf. on Systems, Man and
    Cybernetics, vol. 2, pp. 1556–1561. Also Deb (2001), problem TNK.

    ``f1 = x1``, ``f2 = x2`` (minimised) on ``x1, x2 ∈ [0, π]`` subject to
    ``c1 = x1² + x2² - 1 - 0.1 cos(16 arctan(x1/x2)) >= 0`` and
    ``c2 = (x1 - 0.5)² + (x2 - 0.5)² <= 0.5``. ``arctan(x1/x2)`` is evaluated as
    ``atan2(x1, x2)`` (defined at ``x2 = 0``). The Pareto set has no closed form: it is the
    part of the ``c1 = 0`` boundary with polar angle in :func:`tanaka_angle_intervals`
    (five pieces). Residual: ``| ||x|| - r(phi) | + dist(phi, intervals)`` with
    ``phi = atan2(x1, x2)`` (design = criteria space here; units mixed: length + radians).
    """

    def evaluate(X: FloatArray) -> tuple[FloatArray, FloatArray]:
        x1, x2 = X[:, 0], X[:, 1]
        c1 = x1**2 + x2**2 - 1.0 - 0.1 * np.cos(16.0 * np.arctan2(x1, x2))
        c2 = (x1 - 0.5) ** 2 + (x2 - 0.5) ** 2
        return X.copy(), np.stack([c1, c2], axis=1)

    iv = tanaka_angle_intervals()

    def on_curve(a: float, b: float) -> Callable[[FloatArray], FloatArray]:
        def piece(t: FloatArray) -> FloatArray:
            phi = a + t * (b - a)
            r = _tanaka_r(phi)
            return np.stack([r * np.sin(phi), r * np.cos(phi)], axis=1)

        return piece

    # Seams: piece 2 and 3 starts share x2 with the previous piece's end (dominated);
    # piece 3 and 4 ends share x1 with the next piece's start (dominated).
    opens = [(False, False), (True, False), (True, True), (False, True), (False, False)]
    pieces: list[_Piece] = [(on_curve(a, b), o[0], o[1]) for (a, b), o in zip(iv, opens)]

    def residual(X: FloatArray) -> FloatArray:
        phi = np.arctan2(X[:, 0], X[:, 1])
        radius = np.hypot(X[:, 0], X[:, 1])
        return np.abs(radius - _tanaka_r(phi)) + _distance_to_intervals(phi, iv)

    return AnalyticProblem(
        name="tanaka",
        title="Tanaka (Tanaka, Watanabe, Furukawa & Tanino 1995)",
        variables=(("x1", 0.0, math.pi), ("x2", 0.0, math.pi)),
        criteria=(("f1", "min"), ("f2", "min")),
        constraints=(("c1", 0.0, None), ("c2", None, 0.5)),
        residual_definition=(
            "| ||x|| - r(phi) | + distance of phi = atan2(x1, x2) to the Pareto angle "
            "intervals, r(phi) = sqrt(1 + 0.1 cos 16 phi)"
        ),
        _evaluate=evaluate,
        _pareto_set=lambda n: _sample_pieces(pieces, evaluate, n, 2),
        _residual=residual,
    )


# --------------------------------------------------------------------------------------
# Osyczka–Kundu
# --------------------------------------------------------------------------------------


def _osy_F(
    x1: npt.ArrayLike, x2: npt.ArrayLike, x3: npt.ArrayLike, x4: npt.ArrayLike, x5: npt.ArrayLike
) -> FloatArray:
    """Bracket of the Osyczka–Kundu first criterion (``f1 = -F``)."""
    return 25.0 * (x1 - 2) ** 2 + (x2 - 2) ** 2 + (x3 - 1) ** 2 + (x4 - 4) ** 2 + (x5 - 1) ** 2


@functools.cache
def osyczka_kundu_vertices() -> FloatArray:
    """End points of the five Osyczka–Kundu Pareto-set segments, shape ``(5, 2, 6)``.

    Segments (Deb 2001, all with ``x4 = x6 = 0``), ordered by increasing ``f1``:
    AB ``x1=5, x2=1, x3 ∈ [1,5], x5=5``; BC ``x1=5, x2=1, x3 ∈ [1,5], x5=1``;
    CD ``x1 ∈ [u_D, 5], x2=(x1-2)/3, x3=1, x5=1``; DE ``x1=0, x2=2, x3 ∈ [1, s_D], x5=1``;
    EF ``x1 ∈ [0,1], x2=2-x1, x3=1, x5=1``. ``u_D ≈ 4.0565`` and ``s_D ≈ 3.7317``
    (literature: 4.056 and 3.732) are where the CD and DE front pieces cross in criteria
    space, computed here by root finding.
    """

    def cd(u: float) -> tuple[float, float]:
        v = (u - 2.0) / 3.0
        return float(_osy_F(u, v, 1.0, 0.0, 1.0)), u * u + v * v + 2.0

    def de_F(f2: float) -> float:  # DE: f2 = 5 + s², F = 116 + (s - 1)²
        return 116.0 + (math.sqrt(f2 - 5.0) - 1.0) ** 2

    u_d = brentq(lambda u: cd(u)[0] - de_F(cd(u)[1]), 3.5, 5.0, xtol=1e-15)
    s_d = math.sqrt(cd(u_d)[1] - 5.0)
    v_d = (u_d - 2.0) / 3.0
    return np.array(
        [
            [[5, 1, 5, 0, 5, 0], [5, 1, 1, 0, 5, 0]],  # A -> B
            [[5, 1, 5, 0, 1, 0], [5, 1, 1, 0, 1, 0]],  # B -> C
            [[5, 1, 1, 0, 1, 0], [u_d, v_d, 1, 0, 1, 0]],  # C -> D
            [[0, 2, s_d, 0, 1, 0], [0, 2, 1, 0, 1, 0]],  # D -> E
            [[0, 2, 1, 0, 1, 0], [1, 1, 1, 0, 1, 0]],  # E -> F
        ],
        dtype=np.float64,
    )


def _osyczka_kundu() -> AnalyticProblem:
    """Osyczka–Kundu problem (OSY).

    Osyczka, A. & Kundu, S. (1995). A new method to solve generalized multicriteria
    optimization problems using the simple genetic algorithm. *Structural Optimization*
    10(2), 94–99. Pareto set as tabulated in Deb (2001), *Multi-Objective Optimization
    using Evolutionary Algorithms*, Wiley, problem OSY.

    ``f1 = -[25 (x1-2)² + (x2-2)² + (x3-1)² + (x4-4)² + (x5-1)²]``,
    ``f2 = Σ x_i²`` (both minimised) on ``x1, x2, x6 ∈ [0, 10]``, ``x3, x5 ∈ [1, 5]``,
    ``x4 ∈ [0, 6]``, subject to (all ``>= 0``): ``c1 = x1 + x2 - 2``,
    ``c2 = 6 - x1 - x2``, ``c3 = 2 - x2 + x1``, ``c4 = 2 - x1 + 3 x2``,
    ``c5 = 4 - (x3-3)² - x4``, ``c6 = (x5-3)² + x6 - 4``. Pareto set: five segments, see
    :func:`osyczka_kundu_vertices`; front from (-274, 76) to (-42, 4).
    Residual: Euclidean design-space distance to the union of these segments.
    """

    def evaluate(X: FloatArray) -> tuple[FloatArray, FloatArray]:
        x1, x2, x3, x4, x5, x6 = X.T
        f1 = -_osy_F(x1, x2, x3, x4, x5)
        f2 = (X**2).sum(axis=1)
        G = np.stack(
            [
                x1 + x2 - 2.0,
                6.0 - x1 - x2,
                2.0 - x2 + x1,
                2.0 - x1 + 3.0 * x2,
                4.0 - (x3 - 3.0) ** 2 - x4,
                (x5 - 3.0) ** 2 + x6 - 4.0,
            ],
            axis=1,
        )
        return np.stack([f1, f2], axis=1), G

    V = osyczka_kundu_vertices()
    pieces: list[_Piece] = [(_segment(a, b), False, False) for a, b in V]

    return AnalyticProblem(
        name="osyczka-kundu",
        title="Osyczka–Kundu (Osyczka & Kundu 1995)",
        variables=(
            ("x1", 0.0, 10.0),
            ("x2", 0.0, 10.0),
            ("x3", 1.0, 5.0),
            ("x4", 0.0, 6.0),
            ("x5", 1.0, 5.0),
            ("x6", 0.0, 10.0),
        ),
        criteria=(("f1", "min"), ("f2", "min")),
        constraints=tuple((f"c{j + 1}", 0.0, None) for j in range(6)),
        residual_definition="Euclidean design-space distance to the five Pareto-set segments",
        _evaluate=evaluate,
        _pareto_set=lambda n: _sample_pieces(pieces, evaluate, n, 6),
        _residual=lambda X: _distance_to_segments(X, V[:, 0], V[:, 1]),
    )


# --------------------------------------------------------------------------------------
# Registry
# --------------------------------------------------------------------------------------

_FIXED: dict[str, Callable[[], AnalyticProblem]] = {
    "binh-korn": lambda: _binh_korn(False),
    "binh-korn-max": lambda: _binh_korn(True),
    "dtlz2-3": lambda: _dtlz2(3, 10),
    "dtlz2-5": lambda: _dtlz2(5, 10),
    "osyczka-kundu": _osyczka_kundu,
    "tanaka": _tanaka,
    "zdt1": lambda: _zdt(1, 30),
    "zdt2": lambda: _zdt(2, 30),
    "zdt3": lambda: _zdt(3, 30),
}

_ZDT_RE = re.compile(r"zdt([123])-(\d+)")
_DTLZ2_RE = re.compile(r"dtlz2-(\d+)(?:-k(\d+))?")


def available() -> list[str]:
    """Registry names of the built-in problems (sorted).

    Parametrised variants (``"zdt1-6"``, ``"dtlz2-4"``, ``"dtlz2-4-k3"``) are accepted by
    :func:`get` but not listed.
    """
    return sorted(_FIXED)


@functools.cache
def _build(key: str) -> AnalyticProblem:
    if key in _FIXED:
        return _FIXED[key]()
    m = _ZDT_RE.fullmatch(key)
    if m:
        p = int(m.group(2))
        if p < 2:
            raise ValueError(f"ZDT needs at least 2 variables, got {key!r}; use e.g. 'zdt1-6'")
        return _zdt(int(m.group(1)), p)
    m = _DTLZ2_RE.fullmatch(key)
    if m:
        M = int(m.group(1))
        k = 10 if m.group(2) is None else int(m.group(2))
        if M < 2 or k < 1:
            raise ValueError(
                f"DTLZ2 needs M >= 2 criteria and k >= 1, got {key!r}; use e.g. 'dtlz2-3'"
            )
        return _dtlz2(M, k)
    names = available()
    nearest = difflib.get_close_matches(key, names, n=1, cutoff=0.0)
    hint = f" Did you mean {nearest[0]!r}?" if nearest else ""
    raise ValueError(
        f"unknown analytic problem {key!r}; available: {', '.join(names)} "
        f"(also 'zdtN-<p>' for p variables and 'dtlz2-<M>[-k<k>]').{hint}"
    )


def get(name: str) -> AnalyticProblem:
    """Return the analytic problem registered under ``name``.

    Parameters
    ----------
    name : str
        A name from :func:`available` or a parametrised variant (``"zdt1-6"``,
        ``"dtlz2-4"``, ``"dtlz2-4-k3"``). Case-insensitive; ``_`` and spaces count as ``-``.

    Returns
    -------
    AnalyticProblem

    Raises
    ------
    ValueError
        For an unknown name; the message lists the available names and the nearest one.
    """
    if not isinstance(name, str):
        raise TypeError(f"problem name must be a string, got {type(name).__name__}")
    key = re.sub(r"[\s_]+", "-", name.strip().lower())
    return _build(key)
