"""What any constant-drag descent can do with a series: the closest a descent whose rate never
increases comes to it (:func:`monotone_rate_bound`), and how much of one altimeter's fast
variation a second altimeter of the same flight shares (:func:`fast_variation`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vectorid.descent.events import _series

__all__ = ["FastVariation", "RateBound", "fast_variation", "monotone_rate_bound"]


@dataclass(frozen=True)
class RateBound:
    """The closest a descent whose rate never increases comes to an altitude series.

    Attributes
    ----------
    rms : float
        Smallest altitude RMS (m) over the comparison grid of any such descent.
    rate_first, rate_last : float
        Its descent rates at the start and the end, m/s.
    """

    rms: float
    rate_first: float
    rate_last: float


def monotone_rate_bound(t, h, grid) -> RateBound:
    """A lower bound of the altitude RMS of any constant-drag descent in still air.

    A point mass of constant drag area falling in still air at (or above) its steady rate
    slows down as the air thickens: its descent rate never increases (in pressure height as
    well, in any atmosphere without an inversion steeper than about 20 K/km). The altitude
    curve of *any* such descent, whatever its drag area, mass, atmosphere and initial state,
    is therefore one of h₀ − ∫v dt with v non-increasing, and none comes closer to the data
    than the best of those: the least-squares fit (``scipy.optimize.lsq_linear``) of h₀ and
    a rate that is constant between grid points and never increases, to the data sampled on
    the comparison grid (as the criteria sample them). A residual above it is the
    identification's; the bound itself is what the data hold that no such descent follows
    (measurement error slower than the grid, vertical air motion, a drag area that changes).

    Parameters
    ----------
    t, h : array_like
        Times (s) and altitudes (m) covering the grid.
    grid : array_like
        Comparison grid, s (increasing, at least 3 points).

    Returns
    -------
    RateBound
    """
    from scipy.optimize import lsq_linear

    t, h = _series(t, h)
    grid = np.asarray(grid, dtype=float)
    if grid.size < 3 or np.any(np.diff(grid) <= 0):
        raise ValueError("monotone_rate_bound: the grid needs at least 3 increasing points")
    y = np.interp(grid, t, h)
    n = grid.size - 1  # one rate per interval
    step = np.diff(grid)
    # rate of interval i = r_last + sum of the non-negative decrements after it
    # r_i = r_last + sum_{j > i} e_j, e_j = r_{j-1} - r_j >= 0: columns r_last, e_1..e_{n-1}
    B = np.triu(np.ones((n, n)), k=1)
    B[:, 0] = 1.0
    drop = np.zeros((grid.size, n))  # altitude lost by grid point k: sum_{i<k} step_i r_i
    drop[1:] = np.tril(np.ones((n, n))) * step[None, :]
    A = np.hstack([np.ones((grid.size, 1)), -drop @ B])
    lb = np.r_[-np.inf, -np.inf, np.zeros(n - 1)]
    fit = lsq_linear(A, y, bounds=(lb, np.full(n + 1, np.inf)), method="bvls")
    rate = B @ fit.x[1:]
    res = A @ fit.x - y
    return RateBound(float(np.sqrt(np.mean(res**2))), float(rate[0]), float(rate[-1]))


@dataclass(frozen=True)
class FastVariation:
    """How much of one altimeter's fast variation another altimeter of the same flight shares.

    Attributes
    ----------
    rms, rms_ref : float
        RMS (m) of each series about its own local quadratic trend.
    correlation : float
        Correlation of the two residuals (at the reference's sample times).
    span : float
        Width of the local trend, s.
    """

    rms: float
    rms_ref: float
    correlation: float
    span: float


def fast_variation(t, h, t_ref, h_ref, t0: float, t1: float, span: float = 20.0):
    """Compare the variation of two altitude series faster than ``span`` s over [t0, t1].

    Each series is put on a 0.1-s grid and its local quadratic trend (Savitzky–Golay over
    ``span`` s) is removed; the residuals are read at the reference's sample times (the
    first and last ``span``/2 s left out, where the trends are extrapolated). Real motion
    faster than the trend shows in both; the error of one instrument only in its own (a
    barometer against the GPS heights of the same log).

    Parameters
    ----------
    t, h : array_like
        The series examined (e.g. barometric heights), s and m.
    t_ref, h_ref : array_like
        The reference (e.g. GPS heights), s and m.
    t0, t1 : float
        s.
    span : float
        s.

    Returns
    -------
    FastVariation or None
        None when [t0, t1] is shorter than 3 ``span`` or holds fewer than 10 reference
        samples.
    """
    from scipy.signal import savgol_filter

    t, h = _series(t, h)
    t_ref, h_ref = _series(t_ref, h_ref, "reference altitude")
    lo, hi = max(t0, t[0], t_ref[0]), min(t1, t[-1], t_ref[-1])
    if hi - lo < 3 * span:
        return None
    step = 0.1
    grid = np.arange(lo, hi + 1e-9, step)
    n = round(span / step) | 1
    at = t_ref[(t_ref >= lo + span / 2) & (t_ref <= hi - span / 2)]
    if at.size < 10:
        return None
    out = []
    for tt, hh in ((t, h), (t_ref, h_ref)):
        y = np.interp(grid, tt, hh)
        out.append(np.interp(at, grid, y - savgol_filter(y, n, 2)))
    a, b = out
    return FastVariation(
        float(np.sqrt(np.mean(a**2))),
        float(np.sqrt(np.mean(b**2))),
        float(np.corrcoef(a, b)[0, 1]),
        float(span),
    )
