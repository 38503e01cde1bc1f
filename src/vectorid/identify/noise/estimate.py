"""Noise estimated from the data: the white part by the robust spread of third
differences (:func:`estimate_sigma`, :func:`estimate_noise`), a correlated part from their
growth with the lag (:func:`estimate_correlated`), and what the estimator sees of a stated
noise (:func:`highfreq_sigma`). See :mod:`vectorid.identify.noise` for the formulas.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vectorid.identify.flight import FlightData
from vectorid.identify.noise.statements import ComponentNoise, NoiseModel

__all__ = ["estimate_correlated", "estimate_noise", "estimate_sigma", "highfreq_sigma"]

_ORDER = 3
_MAD = 1.482602218505602  # 1 / Φ⁻¹(3/4): MAD -> σ for a normal distribution


def estimate_sigma(t: ArrayLike, y: ArrayLike, order: int = _ORDER) -> NDArray[np.float64]:
    """Standard deviation of the white measurement noise of each column of ``y``.

    σ̂ = 1.4826 · MAD(d), d the k-th differences (default k = 3) of consecutive samples,
    each divided by the norm of its weights: on evenly spaced samples d = Δᵏy / √C(2k, k)
    (the k-th difference of white noise has variance C(2k, k) σ²); on uneven ones the k-th
    divided difference Σⱼ wⱼ yⱼ, wⱼ = 1 / Πₗ≠ⱼ (tⱼ − tₗ), over ‖w‖, which has variance σ²
    for white noise whatever the steps (loggers whose rows come at jittered times). A
    smooth signal contributes s⁽ᵏ⁾Δtᵏ / k! · (k!/‖w‖Δtᵏ), negligible at the sampling rates of
    flight logs; the MAD, recomputed without the differences beyond 5 σ̂, ignores spikes.
    Differences that span a step outside [0.5, 2] × the
    median step (a gap, or two rows almost at one time) are left out. A correlated error
    slower than the sampling contributes only its high-frequency share
    (:func:`highfreq_sigma`).

    Parameters
    ----------
    t : (T,) float
        Sample times, s, increasing.
    y : (T,) or (T, m) float
        Samples.
    order : int
        k, the order of the differences.

    Returns
    -------
    (m,) float
        σ̂ per column, unit of ``y``; NaN when fewer than 10 differences are usable.
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    if y.ndim == 1:
        y = y[:, None]
    k = int(order)
    if t.size < k + 10:
        return np.full(y.shape[1], np.nan)
    dt = np.diff(t)
    med = float(np.median(dt))
    even = (dt >= 0.5 * med) & (dt <= 2.0 * med)
    # a k-th difference at i uses samples i..i+k: all k steps must be usable
    n = t.size - k
    ok = np.ones(n, dtype=bool)
    for j in range(k):
        ok &= even[j : j + n]
    if ok.sum() < 10:
        return np.full(y.shape[1], np.nan)
    # divided-difference weights w_j = 1 / prod_{l != j} (t_{i+j} - t_{i+l}), in units of the
    # median step (so that they stay of order one)
    tau = np.stack([t[j : j + n] for j in range(k + 1)]) / med  # (k+1, n)
    w = np.ones((k + 1, n))
    for j in range(k + 1):
        for m in range(k + 1):
            if m != j:
                w[j] /= tau[j] - tau[m]
    w /= np.sqrt(np.sum(w * w, axis=0))
    d = np.einsum("jn,jnc->nc", w, np.stack([y[j : j + n] for j in range(k + 1)]))[ok]
    out = np.empty(d.shape[1])
    for c in range(d.shape[1]):
        x = d[:, c]
        dev = np.abs(x - np.median(x))
        s0 = _MAD * np.median(dev)
        # one reweighting step: differences beyond 5 σ (spikes, each spoiling k + 1 of them)
        # are left out; for normal noise this trims nothing that matters (P < 1e-6)
        keep = dev <= 5.0 * s0 if s0 > 0 else np.ones(x.size, dtype=bool)
        x = x[keep]
        out[c] = _MAD * np.median(np.abs(x - np.median(x)))
    return out


def estimate_correlated(t: ArrayLike, y: ArrayLike, max_lag: float = 5.0) -> ComponentNoise | None:
    """White plus first-order Gauss–Markov noise of one series, from the variances of its
    third differences at increasing lags.

    On a uniform grid at the median step Δ, the third difference at lag k,
    y(t + 3kΔ) − 3y(t + 2kΔ) + 3y(t + kΔ) − y(t), removes a signal up to a quadratic (a
    descent that slows down) and has, for white noise of σ_w plus a Gauss–Markov error of σ_c
    and correlation time τ (ρ_j = exp(−jkΔ/τ)), the variance

        V(k) = 20 σ_w² + σ_c² (20 − 30 ρ_1 + 12 ρ_2 − 2 ρ_3).

    The robust variances (1.4826 MAD)² at lags Δ … ``max_lag`` are fitted by that curve
    (least squares on their logarithms, ``scipy.optimize.least_squares``). White noise gives
    a flat curve; an error correlated over a few samples (a logger's filter, a barometer whose
    static port feels the flow as the body swings) a curve that rises to its plateau over
    about τ — what the lag-1 differences of :func:`estimate_sigma` cannot see. Errors slower
    than ``max_lag`` are seen only in part, and real motion whose third derivative is large
    over 3 ``max_lag`` is counted as noise.

    Parameters
    ----------
    t, y : (T,) array_like
        Sample times (s, increasing) and values.
    max_lag : float
        Longest lag, s.

    Returns
    -------
    ComponentNoise or None
        ``ComponentNoise(σ_c, τ, σ_w)`` with τ between half a step and ``max_lag`` / 3 (a
        curve still rising at ``max_lag`` is given τ = ``max_lag`` / 3: an error slower than
        the lags is seen only in part); white noise only (``ComponentNoise(√(V(1)/20))``)
        when the fitted σ_c is under 0.3 σ_w or τ under half a step; None when the series
        holds fewer than 4 ``max_lag`` s or 4 lags.
    """
    from scipy.optimize import least_squares

    t = np.asarray(t, dtype=float).ravel()
    y = np.asarray(y, dtype=float).ravel()
    if t.size < 20 or t[-1] - t[0] < 4 * max_lag:
        return None
    step = float(np.median(np.diff(t)))
    K = int(max_lag / step + 1e-9)
    if K < 4:
        return None
    grid = np.arange(t[0], t[-1] + 1e-9, step)
    yg = np.interp(grid, t, y)
    lags = np.arange(1, K + 1)
    V = np.empty(K)
    n = yg.size
    for i, k in enumerate(lags):
        if n <= 3 * k + 10:
            return None
        d = yg[3 * k :] - 3 * yg[2 * k : n - k] + 3 * yg[k : n - 2 * k] - yg[: n - 3 * k]
        V[i] = (_MAD * np.median(np.abs(d - np.median(d)))) ** 2
    if not np.all(V > 0):
        return None

    def model(p):
        sw, sc, tau = np.exp(p)
        rho = np.exp(-lags * step / tau)
        return 20 * sw**2 + sc**2 * (20 - 30 * rho + 12 * rho**2 - 2 * rho**3)

    # τ at most max_lag / 3, so that the curve reaches its plateau within the lags; the σ's
    # within 1e-4 .. 1e2 of the scale
    v0 = float(V[0])
    scale = math.sqrt(float(V.max()) / 20)
    lo = np.log([1e-4 * scale, 1e-4 * scale, 0.5 * step])
    hi = np.log([1e2 * scale, 1e2 * scale, max_lag / 3])
    best = None
    for tau0 in (step, max_lag / 10, max_lag / 3.5):
        p0 = np.clip(np.log([math.sqrt(v0 / 20), scale, tau0]), lo + 1e-9, hi - 1e-9)
        fit = least_squares(lambda p: np.log(model(p)) - np.log(V), p0, bounds=(lo, hi))
        if best is None or fit.cost < best.cost:
            best = fit
    sw, sc, tau = (float(v) for v in np.exp(best.x))
    if sc < 0.3 * sw or tau < 0.55 * step:
        return ComponentNoise(math.sqrt(v0 / 20))
    return ComponentNoise(sc, tau, sw)


def highfreq_sigma(noise: ComponentNoise, dt: float, order: int = _ORDER) -> float:
    """What :func:`estimate_sigma` sees of ``noise`` sampled every ``dt`` s: the σ of white
    noise whose k-th differences have the same variance (exact for stationary noise)."""
    k = int(order)
    c = np.array([(-1) ** (k - i) * math.comb(k, i) for i in range(k + 1)], dtype=float)
    var = noise.white**2 * float(c @ c)
    if noise.correlation_time > 0:
        a = math.exp(-dt / noise.correlation_time)
        lag = np.abs(np.subtract.outer(np.arange(k + 1), np.arange(k + 1)))
        var += noise.sigma**2 * float(c @ (a**lag) @ c)
    else:
        var += noise.sigma**2 * float(c @ c)
    return math.sqrt(var / math.comb(2 * k, k))


def estimate_noise(flight: FlightData, channels: Sequence[str] | None = None) -> NoiseModel:
    """White-noise σ of each component of a flight's channels (:func:`estimate_sigma`).

    ``flight`` is a :class:`~vectorid.identify.FlightData` (e.g. a drop's windowed data);
    ``channels`` default to all. A yaw that wraps is unwrapped first. Components whose
    estimate is not available (too few regularly spaced samples) stay unstated (None)."""
    out: dict[str, list[ComponentNoise | None]] = {}
    for name in channels or list(flight.channels):
        if name not in flight.channels:
            continue
        c = flight.channels[name]
        v = np.array(c.values)
        if name == "euler" and v.shape[1] >= 3:
            v[:, 2] = np.unwrap(v[:, 2])
        s = estimate_sigma(c.t, v)
        out[name] = [ComponentNoise(float(x)) if np.isfinite(x) else None for x in s]
    return NoiseModel(out, estimated=True)
