"""Events of a descent read from its altitude alone: apogee, touchdown, trigger crossings and
changes of drag area.

Every detector takes an altitude series ``(t, h)`` (s, m) and works on a uniform grid of it,
smoothed by a running median (so that single-sample spikes and ejection disturbances shorter
than the median do not decide an event).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from vectorid.identify.outliers import find_spikes
from vectorid.models.atmosphere import ISA

__all__ = [
    "RateChange",
    "Touchdown",
    "crossing_time",
    "detect_apogee",
    "detect_rate_change",
    "detect_touchdown",
]


def _series(t, h, what: str = "altitude") -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    t = np.asarray(t, dtype=float).ravel()
    h = np.asarray(h, dtype=float).ravel()
    if t.shape != h.shape:
        raise ValueError(f"{what}: t and h differ in length ({t.size} and {h.size})")
    if t.size < 5:
        raise ValueError(f"{what}: needs at least 5 samples, got {t.size}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(h))):
        raise ValueError(f"{what}: t and h must be finite (drop missing samples first)")
    if np.any(np.diff(t) <= 0):
        raise ValueError(f"{what}: t must be strictly increasing")
    return t, h


def _uniform(t, h, dt_max: float = 1.0):
    """The series on a uniform grid at its median sample interval (clipped to [0.01, dt_max] s)."""
    dt = float(np.clip(np.median(np.diff(t)), 0.01, dt_max))
    n = int(np.floor((t[-1] - t[0]) / dt + 1e-9)) + 1
    g = t[0] + dt * np.arange(n)
    return g, np.interp(g, t, h), dt


def _running_median(x: NDArray, n: int, mode: str = "nearest") -> NDArray:
    from scipy.ndimage import median_filter

    n = max(1, int(n)) | 1
    return median_filter(x, size=n, mode=mode) if n > 1 else x.copy()


def _rate(s: NDArray, dt: float, half: int) -> NDArray:
    """Rate of change (per s) of ``s`` by differences over ±``half`` samples (one-sided at the
    ends)."""
    n = s.size
    idx = np.arange(n)
    lo = np.clip(idx - half, 0, n - 1)
    hi = np.clip(idx + half, 0, n - 1)
    span = (hi - lo) * dt
    return np.where(span > 0, (s[hi] - s[lo]) / np.where(span > 0, span, 1.0), 0.0)


def detect_apogee(t, h, *, smooth: float = 1.0) -> tuple[float, float]:
    """Apogee of an altitude series: the maximum of its running median.

    Parameters
    ----------
    t, h : array_like
        Times (s, strictly increasing) and altitudes (m).
    smooth : float
        Width of the running median, s (ejection spikes shorter than half of it are ignored).

    Returns
    -------
    time, altitude : float
        s and m.
    """
    t, h = _series(t, h)
    g, hg, dt = _uniform(t, h)
    s = _running_median(hg, round(smooth / dt))
    i = int(np.argmax(s))
    # a running median flattens the top of the curve: the vertex of a parabola through it
    near = np.abs(g - g[i]) <= smooth
    if near.sum() >= 5:
        c = np.polyfit(g[near] - g[i], s[near], 2)
        if c[0] < 0:
            tv = -c[1] / (2 * c[0])
            if abs(tv) <= smooth:
                return float(g[i] + tv), float(s[i])
    return float(g[i]), float(s[i])


def crossing_time(t, h, level: float, *, after: float | None = None, smooth: float = 1.0):
    """First time after ``after`` (default: the apogee) at which the altitude, smoothed by a
    running median of ``smooth`` s, comes down through ``level`` (m). None if it never does.
    """
    t, h = _series(t, h)
    if after is None:
        after = detect_apogee(t, h, smooth=smooth)[0]
    g, hg, dt = _uniform(t, h)
    s = _running_median(hg, round(smooth / dt))
    sel = np.flatnonzero(g >= after)
    if sel.size < 2:
        return None
    below = np.flatnonzero(s[sel] <= level)
    if below.size == 0:
        return None
    k = int(sel[below[0]])
    if k == sel[0]:
        return float(g[k])
    h0, h1 = s[k - 1], s[k]
    frac = 0.0 if h0 == h1 else (h0 - level) / (h0 - h1)
    return float(g[k - 1] + frac * dt)


@dataclass(frozen=True)
class Touchdown:
    """Where a descent ends on the ground, read from the altitude alone.

    Attributes
    ----------
    time : float
        Touchdown, s: where the descent line meets the ground level (a continuous two-segment
        fit, descending then level, around the settling).
    ground : float
        Altitude the data read on the ground, m.
    rate : float
        Descent rate just before touchdown, m/s (the fit's slope).
    settled : float
        Time from which the vertical speed and the height stay settled, s.
    after : float
        Seconds of data after touchdown.
    """

    time: float
    ground: float
    rate: float
    settled: float
    after: float


def detect_touchdown(
    t,
    h,
    *,
    after: float | None = None,
    smooth: float = 1.0,
    settle_speed: float = 1.0,
    settle_fraction: float = 0.25,
    hold: float = 1.0,
    sustain: float = 5.0,
    fit_span: float = 8.0,
) -> Touchdown | None:
    """Touchdown of a descent from its altitude series: where altitude and vertical speed
    settle, not where a logger's state machine says "landed" (often many seconds later).

    Single-sample spikes are left out first (:func:`vectorid.identify.outliers.find_spikes`,
    3 m floor). The altitude is put on a uniform grid and smoothed by a running median of
    ``smooth`` s; its vertical speed is the difference over ±``smooth`` s. The descent has
    *settled* at the first time after ``after`` from which, for ``sustain`` s (or to the end
    of the data, at least ``hold`` s), nine speeds in ten stay below
    ``max(settle_speed, settle_fraction × descent rate)`` and the smoothed height stays within
    a band of its median there (5 × the smoothed series' noise, at least 2 m), after a descent
    rate (median over the 5 s before) above twice ``settle_speed``. What the data do later
    (a noisy ground barometer, a last-sample outlier, the rocket carried away) does not
    decide it. A continuous two-segment line (descending, then level) fitted to the samples
    from ``fit_span`` s before to 3 s after that time places the touchdown where the two meet.

    Parameters
    ----------
    t, h : array_like
        Times (s, strictly increasing) and altitudes (m) of the whole log or its descent.
    after : float, optional
        Search from this time, s (default: the apogee).
    smooth, settle_speed, settle_fraction, hold, sustain, fit_span : float
        As above (s, m/s, -, s, s, s).

    Returns
    -------
    Touchdown or None
        None when the data end before the descent settles (a log that stops in the air, or
        one that stops less than about ``smooth + hold`` s after touchdown).
    """

    t, h = _series(t, h)
    sp = find_spikes(t, h, floor=10.0)
    if len(sp):
        keep = np.ones(t.size, dtype=bool)
        keep[sp.index] = False
        t, h = t[keep], h[keep]
    if after is None:
        after = detect_apogee(t, h, smooth=smooth)[0]
    g, hg, dt = _uniform(t, h)
    n_s = max(1, round(smooth / dt))
    # "mirror": the last sample counts once at the edge (with "nearest" a last-sample outlier
    # fills half the window and moves the median: a false speed at the end of the data)
    s = _running_median(hg, n_s, mode="mirror")
    v = _rate(s, dt, n_s)
    start = int(np.searchsorted(g, after))
    if g.size - start < 3:
        return None
    speed = np.abs(v)
    d2 = np.diff(hg[start:], 2)  # white noise of the samples, from second differences
    sigma_raw = 1.4826 * float(np.median(np.abs(d2 - np.median(d2)))) / np.sqrt(6) if d2.size else 0
    band = max(2.0, 5.0 * 1.25 * sigma_raw / np.sqrt(n_s))
    from scipy.ndimage import median_filter, percentile_filter

    w = max(1, round(5.0 / dt))
    gap = n_s
    m_sus = max(1, round(sustain / dt))
    n = g.size
    idx = np.arange(n)
    # descent rate before each sample: the median of -v over [i - gap - w, i - gap)
    med = median_filter(-v, size=w, mode="nearest")
    j = idx - gap - (w + 1) // 2
    rate = np.where(j >= start, med[np.clip(j, 0, n - 1)], -np.inf)
    # nine speeds in ten below the threshold over [i, i + sustain]: the 90th percentile of a
    # window starting at i (the end of the data shortens it)
    q90 = percentile_filter(speed, 90, size=m_sus + 1, mode="nearest")
    k = np.clip(idx + m_sus // 2, 0, n - 1)
    thr = np.maximum(settle_speed, settle_fraction * np.maximum(rate, 0.0))
    ok = (idx >= start + gap) & (g[-1] - g >= hold) & (rate >= 2 * settle_speed)
    ok &= (q90[k] < thr) | (idx + m_sus >= n - 1)  # near the end: checked below
    found = None
    for i in np.flatnonzero(ok):
        jj = min(n, i + m_sus + 1)
        if np.quantile(speed[i:jj], 0.9) >= thr[i]:
            continue
        seg = s[i:jj]
        if np.max(np.abs(seg - np.median(seg))) > band:
            continue
        found = int(i)
        break
    if found is None:
        return None
    t_set = float(g[found])
    sel = (t >= t_set - fit_span) & (t <= min(t_set + 3.0, t[-1]))
    ts, hs = t[sel], h[sel]
    if ts.size < 5:
        return None
    # continuous hinge h = g0 + r * min(t - tau, 0): linear in (g0, r) for each tau
    cand = ts[(ts > ts[0] + 0.5) & (ts <= t_set)]
    if cand.size == 0:
        return None
    best = (np.inf, float(t_set), 0.0, 0.0)
    for tau in cand:
        A = np.stack([np.ones_like(ts), np.minimum(ts - tau, 0.0)], axis=1)
        coef, *_ = np.linalg.lstsq(A, hs, rcond=None)
        sse = float(np.sum((A @ coef - hs) ** 2))
        if sse < best[0]:
            best = (sse, float(tau), float(coef[0]), float(coef[1]))
    _, tau, ground, slope = best
    return Touchdown(time=tau, ground=ground, rate=slope, settled=t_set, after=float(t[-1] - tau))


@dataclass(frozen=True)
class RateChange:
    """A change of drag area during a descent (a canopy opening, or losing one), read from the
    altitude alone.

    Attributes
    ----------
    time : float
        Where the descent rate, scaled to one density, steps from one level to the other, s.
    altitude : float
        Altitude of the data there, m.
    rate_before, rate_after : float
        Steady descent rates (m/s, positive down) before and after, both scaled to the density
        at ``altitude``.
    """

    time: float
    altitude: float
    rate_before: float
    rate_after: float

    @property
    def drag_area_ratio(self) -> float:
        """Drag area after the change over the drag area before, (v_before / v_after)² (the
        steady descent rate at one density scales with 1/sqrt(C_D S))."""
        return (self.rate_before / self.rate_after) ** 2


def detect_rate_change(
    t,
    h,
    t0: float,
    t1: float,
    *,
    origin_altitude: float = 0.0,
    margin: float = 2.0,
    min_ratio: float = 1.2,
) -> RateChange | None:
    """The largest change of drag area between ``t0`` and ``t1`` (s).

    The altitude is smoothed (running median of 1 s on a grid of at least 0.1 s), its descent
    rate v (differences over ±1 s) is scaled to sea-level density, v sqrt(ρ(h) / ρ(0)) in ISA
    air (constant for a constant drag area), and split into two constant levels where that
    fits best (least squares; the split at least ``margin`` s from the ends).

    Parameters
    ----------
    t, h : array_like
        Times (s) and altitudes (m above ``origin_altitude``).
    t0, t1 : float
        Span searched, s.
    origin_altitude : float
        Altitude of the data's zero above mean sea level, m (for the density).
    margin : float
        s.
    min_ratio : float
        Smallest drag-area ratio (larger over smaller) reported as a change.

    Returns
    -------
    RateChange or None
        None when the drag areas of the two levels differ by less than ``min_ratio``, or the
        span is too short.
    """

    t, h = _series(t, h)
    sel = (t >= t0) & (t <= t1)
    if sel.sum() < 10 or t1 - t0 < 3 * margin:
        return None
    g, hg, dt = _uniform(t[sel], h[sel], dt_max=1.0)
    if dt < 0.1:
        g2 = np.arange(g[0], g[-1], 0.1)
        hg, g, dt = np.interp(g2, g, hg), g2, 0.1
    s = _running_median(hg, round(1.0 / dt))
    v = -_rate(s, dt, max(1, round(1.0 / dt)))
    isa = ISA()
    rho = isa.density(origin_altitude + s)
    rho0 = float(isa.density(0.0))
    veq = v * np.sqrt(rho / rho0)
    n = veq.size
    m = max(2, round(margin / dt))
    if n < 2 * m + 2:
        return None
    c1 = np.cumsum(veq)
    c2 = np.cumsum(veq**2)
    k = np.arange(m, n - m)  # split before index k
    n1, n2 = k.astype(float), (n - k).astype(float)
    s1, s2 = c1[k - 1], c1[-1] - c1[k - 1]
    q1, q2 = c2[k - 1], c2[-1] - c2[k - 1]
    sse = (q1 - s1**2 / n1) + (q2 - s2**2 / n2)
    j = int(np.argmin(sse))
    kb = int(k[j])
    a, b = s1[j] / n1[j], s2[j] / n2[j]
    if min(a, b) <= 0 or max(a, b) ** 2 < min_ratio * min(a, b) ** 2:
        return None
    scale = float(np.sqrt(rho0 / rho[kb]))
    return RateChange(
        time=float(g[kb]), altitude=float(s[kb]), rate_before=a * scale, rate_after=b * scale
    )
