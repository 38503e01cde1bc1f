"""Spectral tools: dominant ("eigen") frequencies from Welch power spectra.

Seed 001 (Table I, criteria 13–15) compares the eigen-frequencies of the Euler angles found from
their power spectra. :func:`eigenfrequencies` estimates them batch-wise with
:func:`scipy.signal.welch`, refining the peak between bins by a parabola through the log-power of
the peak bin and its neighbours.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import signal

from vectorid.identify.flight import FlightDataError

__all__ = ["eigenfrequencies", "resample_uniform"]


def resample_uniform(
    t: ArrayLike, x: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """Put ``x`` (..., T) sampled at times ``t`` (T,) on a uniform grid of the median step.

    Returns
    -------
    t_uniform : ndarray, shape (T',)
    x_uniform : ndarray, shape (..., T')
    fs : float
        Sampling frequency of the uniform grid, Hz.
    """
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    if t.ndim != 1 or t.size < 2 or x.shape[-1] != t.size:
        raise FlightDataError(
            f"expected times (T,) with T >= 2 matching the last axis of x, got t {t.shape}, "
            f"x {x.shape}"
        )
    dt = float(np.median(np.diff(t)))
    if not dt > 0:
        raise FlightDataError("times must be strictly increasing to estimate a spectrum")
    if np.allclose(np.diff(t), dt, rtol=1e-6, atol=1e-12):
        return t, x, 1.0 / dt
    n = int(np.floor((t[-1] - t[0]) / dt + 1e-9)) + 1
    tu = t[0] + dt * np.arange(n)
    flat = x.reshape(-1, t.size)
    xu = np.stack([np.interp(tu, t, row) for row in flat]).reshape((*x.shape[:-1], n))
    return tu, xu, 1.0 / dt


def eigenfrequencies(
    x: ArrayLike,
    fs: float,
    *,
    n_peaks: int = 1,
    nperseg: int | None = None,
    fmin: float = 0.0,
    fmax: float | None = None,
    detrend: str = "linear",
) -> NDArray[np.float64]:
    """Dominant oscillation frequencies of signals from their Welch power spectra.

    Parameters
    ----------
    x : array_like, shape (T,) or (n, T)
        Uniformly sampled signal(s); for an angle that turns continuously (yaw of a spiralling
        descent) pass the unwrapped angle — the linear trend is removed.
    fs : float
        Sampling frequency, Hz.
    n_peaks : int
        How many spectral peaks to return per signal (the strongest, sorted by frequency).
    nperseg : int, optional
        Welch segment length in samples; default ``min(T, 256)``. Longer segments give finer
        frequency bins (resolution ``fs / nperseg``), shorter ones a smoother spectrum.
    fmin, fmax : float
        Frequency band searched, Hz (``fmin`` excludes slow drifts; ``fmax`` defaults to the
        Nyquist frequency). The zero-frequency bin is never a peak.
    detrend : {"linear", "constant", False}
        Detrending of each Welch segment.

    Returns
    -------
    ndarray, shape (n_peaks,) or (n, n_peaks)
        Peak frequencies, Hz, ascending; NaN for a signal containing NaN or with fewer peaks.

    Notes
    -----
    The peak is refined between bins by fitting a parabola to the log-power at the peak bin and
    its two neighbours (accuracy much finer than ``fs / nperseg`` for a clean oscillation).
    """
    arr = np.asarray(x, dtype=float)
    single = arr.ndim == 1
    if single:
        arr = arr[None, :]
    if arr.ndim != 2:
        raise FlightDataError(f"expected a signal of shape (T,) or (n, T), got {arr.shape}")
    if not (np.isfinite(fs) and fs > 0):
        raise FlightDataError(f"fs must be a sampling frequency > 0 Hz, got {fs!r}")
    if n_peaks < 1:
        raise FlightDataError(f"n_peaks must be >= 1, got {n_peaks}")
    n, T = arr.shape
    if T < 4:
        raise FlightDataError(
            f"a spectrum needs at least 4 samples, got {T}; use a longer window or faster rate"
        )
    seg = min(T, 256) if nperseg is None else int(nperseg)
    if not 4 <= seg <= T:
        raise FlightDataError(f"nperseg must be in [4, {T}] samples, got {nperseg}")
    out = np.full((n, n_peaks), np.nan)
    ok = np.all(np.isfinite(arr), axis=1)
    if not np.any(ok):
        return out[0] if single else out
    f, pxx = signal.welch(arr[ok], fs=fs, nperseg=seg, detrend=detrend, axis=-1)
    hi = fs / 2 if fmax is None else float(fmax)
    band = (f > 0) & (f >= fmin) & (f <= hi)
    if not np.any(band):
        raise FlightDataError(
            f"no frequency bin in [{fmin}, {hi}] Hz at fs={fs} Hz and nperseg={seg}; widen the "
            "band or use longer segments"
        )
    idx_band = np.flatnonzero(band)
    df = f[1] - f[0]
    res = np.full((pxx.shape[0], n_peaks), np.nan)
    for i, p in enumerate(pxx):
        pb = p[idx_band]
        if n_peaks == 1:
            cand = [int(np.argmax(pb))]
        else:
            peaks, _ = signal.find_peaks(np.concatenate([[-np.inf], pb, [-np.inf]]))
            peaks = peaks - 1
            cand = [int(k) for k in peaks[np.argsort(pb[peaks])[::-1][:n_peaks]]]
        freqs = []
        for k in cand:
            j = idx_band[k]
            fj = f[j]
            if 0 < j < f.size - 1 and p[j] > 0 and p[j - 1] > 0 and p[j + 1] > 0:
                a, b, c = np.log(p[j - 1]), np.log(p[j]), np.log(p[j + 1])
                den = a - 2 * b + c
                if den < 0:
                    fj = f[j] + 0.5 * (a - c) / den * df
            freqs.append(fj)
        freqs.sort()
        res[i, : len(freqs)] = freqs
    out[ok] = res
    return out[0] if single else out
