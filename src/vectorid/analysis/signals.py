"""Plain-array tools behind the identification views (seed 000 Fig. 11, seed 001 Figs. 7–9
and 12): power spectra of Euler angles and envelopes of channels over several runs.

They take arrays (time, values), not flight-data objects, so the identification package
can use them unchanged.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["dominant_frequency", "envelope", "power_spectrum", "uniform"]


def _check_time(t: np.ndarray, y: np.ndarray) -> None:
    if t.ndim != 1 or len(t) < 2:
        raise ValueError(f"expected a time vector of at least 2 samples, got shape {t.shape}")
    if y.shape[0] != len(t):
        raise ValueError(f"time has {len(t)} samples but the values have {y.shape[0]}")
    if np.any(np.diff(t) <= 0):
        raise ValueError("time must be strictly increasing; sort it and drop repeated samples")


def uniform(t: np.ndarray, y: np.ndarray, dt: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Resample ``y`` (n,) or (n, c) on a uniform grid of step ``dt`` s (default: the median
    step) by linear interpolation."""
    t = np.asarray(t, float)
    y = np.asarray(y, float)
    _check_time(t, y)
    step = float(np.median(np.diff(t))) if dt is None else float(dt)
    n = int(np.floor((t[-1] - t[0]) / step + 1e-9)) + 1
    tu = t[0] + step * np.arange(n)
    if y.ndim == 1:
        return tu, np.interp(tu, t, y)
    return tu, np.column_stack([np.interp(tu, t, c) for c in y.T])


def power_spectrum(
    t: np.ndarray, y: np.ndarray, *, nperseg: int | None = None, detrend: str = "linear"
) -> tuple[np.ndarray, np.ndarray]:
    """One-sided power spectral density by Welch's method.

    Parameters
    ----------
    t : (n,) float
        Time in s (uniform or not; a non-uniform base is resampled at its median step).
    y : (n,) or (n, c) float
        Signal(s), e.g. Euler angles in rad.
    nperseg : int, optional
        Segment length (default: min(n, 256)).
    detrend : str
        Passed to :func:`scipy.signal.welch`.

    Returns
    -------
    freq : (m,) float
        Frequency in Hz.
    psd : (m,) or (m, c) float
        Power spectral density in unit² / Hz.
    """
    tu, yu = uniform(t, y)
    fs = 1.0 / float(tu[1] - tu[0])
    seg = min(len(tu), 256) if nperseg is None else int(nperseg)
    from scipy import signal  # imported where used: it loads slowly

    f, p = signal.welch(yu, fs=fs, nperseg=seg, detrend=detrend, axis=0)
    return f, p


def dominant_frequency(freq: np.ndarray, psd: np.ndarray) -> np.ndarray | float:
    """Frequency (Hz) of the largest peak of a PSD, ignoring the zero frequency."""
    psd = np.asarray(psd, float)
    sl = slice(1, None) if len(freq) > 1 else slice(None)
    idx = np.argmax(psd[sl], axis=0) + (1 if len(freq) > 1 else 0)
    return np.asarray(freq)[idx] if np.ndim(idx) else float(freq[int(idx)])


def envelope(
    t: np.ndarray, runs: Sequence[tuple[np.ndarray, np.ndarray]]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pointwise min, median and max of several runs of one channel on the time base ``t``.

    Parameters
    ----------
    t : (n,) float
        Common time base, s.
    runs : sequence of (time (m,), values (m,))
        Each run on its own time base; values are linearly interpolated onto ``t`` (NaN
        outside a run's time span).

    Returns
    -------
    low, median, high : (n,) float
    """
    t = np.asarray(t, float)
    if not runs:
        raise ValueError("expected at least one run")
    Y = np.empty((len(runs), len(t)))
    for i, (tr, yr) in enumerate(runs):
        tr, yr = np.asarray(tr, float), np.asarray(yr, float)
        _check_time(tr, yr)
        Y[i] = np.interp(t, tr, yr, left=np.nan, right=np.nan)
    with np.errstate(all="ignore"):
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            return np.nanmin(Y, axis=0), np.nanmedian(Y, axis=0), np.nanmax(Y, axis=0)
