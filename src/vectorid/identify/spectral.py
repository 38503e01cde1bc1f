"""Spectral tools for the "natural frequency" criteria: power spectra that hold up on short,
noisy flight windows, their peak frequencies and band powers.

Seed 001 (Table I, criteria 13–15) and seed 000 (§VII: "adequacy of the natural eigenvalues
(power spectrum) for all channels") compare the spectra of the roll, pitch and yaw channels of
a drop with the model's. A drop gives a window of one to a few minutes with sensor noise, turns
(ramps in yaw, steps in the rates) and gusts, so the estimate must be chosen with care:

* **Window and segments** (:func:`segment_length`): Welch's method with a Hann window and 50 %
  overlap. By default the segment length gives ``min_segments`` (4) averaged segments — a
  single periodogram has a relative standard deviation of 100 % per bin, four halve it — but
  never fewer than 16 samples; ``resolution`` (Hz) asks for a bin width instead. Segments are
  zero-padded to at least 4× their length (``nfft``) so that the peak interpolation has bins
  to work with on short windows.
* **Detrending**: every segment has its least-squares line removed (``detrend="linear"``), so
  that a turn's ramp in yaw or a slow drift does not leak into the low bins; pass the
  unwrapped yaw angle.
* **Peak frequency** (:func:`spectral_peak`): the largest bin inside a band, refined by a
  parabola through the log-power of that bin and its neighbours. The band matters: a drop's
  attitude spectra are dominated below ~0.15 Hz by the turns themselves, so an oscillation mode
  is looked for in a band above them (e.g. 0.25–1.5 Hz for a parafoil's payload modes).
  :func:`peak_prominence` says how far the peak stands above the band's median power (a
  peak of pure noise stands ~3–8× above it; a real mode much more). ``whiten=True`` looks for
  the peak in the spectrum of the derivative, (2πf)² P(f): steps and ramps (power ∝ 1/f²)
  become flat there, so a mode above the turns' frequencies is not buried under their tail
  (the spectral criteria use it).
* **Band powers** (:func:`band_powers`, :func:`spectrum_distance`): the power in contiguous
  sub-bands, and the distance between two spectra's *shapes* — the mean absolute difference of
  the log of each sub-band's share of the band's power. Shares make it insensitive to the
  excitation level (a model flown without gusts oscillates less than the drop but at the same
  frequencies), the logarithm to the dynamic range of spectra.

Everything is batch-first: signals of shape (n, T) give (n, ...) results; a row with NaN gives
NaN.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import signal

from vectorid.identify.flight import FlightDataError

__all__ = [
    "band_powers",
    "eigenfrequencies",
    "peak_prominence",
    "psd",
    "rate_peaks",
    "resample_uniform",
    "segment_length",
    "spectral_peak",
    "spectrum_distance",
]

#: Fewest samples a spectrum is estimated from.
MIN_SAMPLES = 8
#: Added to each sub-band's share of power before the logarithm in :func:`spectrum_distance`:
#: sub-bands holding less than about 1 % of the band's power count as empty in both spectra, so
#: a model's noise-free output is not punished without limit where the measurement holds only
#: its sensors' noise floor (a difference is at most ln(1.01 / 0.01) = 4.6).
SHARE_FLOOR = 0.01


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


def segment_length(
    n_samples: int, fs: float, *, resolution: float | None = None, min_segments: int = 4
) -> int:
    """Welch segment length (samples) for a record of ``n_samples`` at ``fs`` Hz.

    With ``resolution`` (Hz): ``fs / resolution`` samples. Otherwise the longest segment that
    still gives ``min_segments`` segments at 50 % overlap, ``2 T / (min_segments + 1)``. Either
    is clipped to ``[min(16, T), T]``.
    """
    T = int(n_samples)
    if resolution is not None:
        if not (np.isfinite(resolution) and resolution > 0):
            raise FlightDataError(f"resolution must be > 0 Hz, got {resolution!r}")
        seg = round(fs / resolution)
    else:
        if min_segments < 1:
            raise FlightDataError(f"min_segments must be >= 1, got {min_segments}")
        seg = int(2 * T // (min_segments + 1))
    return int(min(T, max(min(16, T), seg)))


def _check(x: ArrayLike, fs: float) -> tuple[NDArray[np.float64], bool]:
    arr = np.asarray(x, dtype=float)
    single = arr.ndim == 1
    if single:
        arr = arr[None, :]
    if arr.ndim != 2:
        raise FlightDataError(f"expected a signal of shape (T,) or (n, T), got {arr.shape}")
    if not (np.isfinite(fs) and fs > 0):
        raise FlightDataError(f"fs must be a sampling frequency > 0 Hz, got {fs!r}")
    if arr.shape[1] < MIN_SAMPLES:
        raise FlightDataError(
            f"a spectrum needs at least {MIN_SAMPLES} samples, got {arr.shape[1]}; use a longer "
            "window or a faster output rate"
        )
    return arr, single


def psd(
    x: ArrayLike,
    fs: float,
    *,
    nperseg: int | None = None,
    resolution: float | None = None,
    min_segments: int = 4,
    detrend: str | bool = "linear",
    nfft: int | None = None,
    whiten: bool = False,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """One-sided power spectral density by Welch's method (Hann window, 50 % overlap).

    Parameters
    ----------
    x : array_like, shape (T,) or (n, T)
        Uniformly sampled signal(s) in their unit (rad, rad/s, ...).
    fs : float
        Sampling frequency, Hz.
    nperseg : int, optional
        Segment length, samples (default :func:`segment_length`).
    resolution : float, optional
        Wanted bin width of the segments, Hz (instead of ``nperseg``).
    min_segments : int
        Segments the default length aims at.
    detrend : {"linear", "constant", False}
        Detrending of each segment.
    nfft : int, optional
        FFT length (zero padding), default ``max(4 * nperseg, 256)`` capped at 4096.
    whiten : bool
        Return the PSD of the signal's time derivative, ``(2πf)² P(f)`` (unit²/s²/Hz): a
        record whose power falls off as 1/f² (steps and ramps of turns, random walks) becomes
        flat, so that a mode stands out as a peak above it.

    Returns
    -------
    f : ndarray, shape (F,)
        Frequencies, Hz.
    p : ndarray, shape (F,) or (n, F)
        PSD, unit²/Hz; rows of NaN for signals with NaN/inf.
    """
    arr, single = _check(x, fs)
    n, T = arr.shape
    if nperseg is None:
        seg = segment_length(T, fs, resolution=resolution, min_segments=min_segments)
    else:
        seg = int(nperseg)
        if not MIN_SAMPLES <= seg <= T:
            raise FlightDataError(f"nperseg must be in [{MIN_SAMPLES}, {T}] samples, got {nperseg}")
    nf = int(min(4096, max(4 * seg, 256))) if nfft is None else int(nfft)
    if nf < seg:
        raise FlightDataError(f"nfft ({nf}) must be >= nperseg ({seg})")
    ok = np.all(np.isfinite(arr), axis=1)
    f = np.fft.rfftfreq(nf, 1.0 / fs)
    p = np.full((n, f.size), np.nan)
    if np.any(ok):
        p[ok] = _welch(arr[ok], fs, seg, nf, detrend)
    if whiten:
        p *= (2 * np.pi * f) ** 2
    return f, (p[0] if single else p)


def _welch(x: NDArray[np.float64], fs: float, seg: int, nfft: int, detrend) -> NDArray[np.float64]:
    """Welch PSD of the rows of ``x`` (n, T): Hann window, 50 % overlap, one-sided, density —
    the one Welch estimate of this module (:func:`psd` and :func:`eigenfrequencies`).

    Equal to ``scipy.signal.welch(x, fs, "hann", seg, seg // 2, nfft, detrend)`` (tested to
    1e-12) but written for whole batches: all segments of all rows are cut with a strided view,
    detrended by one matrix product and transformed by one ``rfft``, which is about 8x faster
    than scipy's general short-time-Fourier path on (16384, 750) batches, where the spectral
    criteria would otherwise cost as much as the flight simulations.
    """
    n, T = x.shape
    step = seg - seg // 2
    k = 1 + (T - seg) // step
    segs = np.lib.stride_tricks.sliding_window_view(x, seg, axis=1)[:, ::step][:, :k]
    if detrend == "linear":
        tt = np.arange(seg, dtype=float)
        basis = np.stack([np.ones(seg), tt - tt.mean()])
        basis /= np.linalg.norm(basis, axis=1, keepdims=True)  # orthonormal: 1 ⟂ centred t
        segs = segs - (segs @ basis.T) @ basis
    elif detrend == "constant":
        segs = segs - segs.mean(axis=2, keepdims=True)
    elif detrend not in (False, None):
        raise FlightDataError(f"detrend must be 'linear', 'constant' or False, got {detrend!r}")
    win = signal.get_window("hann", seg)
    spec = np.fft.rfft(segs * win, n=nfft, axis=2)
    p = (spec.real**2 + spec.imag**2).mean(axis=1)
    p *= 1.0 / (fs * (win * win).sum())
    if nfft % 2:
        p[:, 1:] *= 2.0
    else:
        p[:, 1:-1] *= 2.0
    return p


def _band_mask(f: NDArray[np.float64], band: tuple[float, float] | None) -> NDArray[np.bool_]:
    lo, hi = (0.0, float(f[-1])) if band is None else (float(band[0]), float(band[1]))
    if not (np.isfinite(lo) and np.isfinite(hi) and 0 <= lo < hi):
        raise FlightDataError(f"band must be (low, high) Hz with 0 <= low < high, got {band!r}")
    mask = (f > 0) & (f >= lo) & (f <= hi)
    if mask.sum() < 3:
        raise FlightDataError(
            f"the band [{lo:g}, {hi:g}] Hz holds fewer than 3 frequency bins (bins every "
            f"{f[1] - f[0]:.3g} Hz up to {f[-1]:.3g} Hz); widen it or use a faster output rate"
        )
    return mask


def spectral_peak(
    x: ArrayLike,
    fs: float,
    *,
    band: tuple[float, float] | None = None,
    **psd_options,
) -> NDArray[np.float64]:
    """Frequency (Hz) of the largest spectral peak of each signal inside ``band``.

    The largest PSD bin in the band is refined by a parabola through the log-power of the bin
    and its two neighbours (the zero-padded spectrum is smooth enough for it). A maximum on the
    band's edge is returned as it is.

    Parameters
    ----------
    x : array_like, shape (T,) or (n, T)
    fs : float
        Sampling frequency, Hz.
    band : (float, float), optional
        Frequencies searched, Hz (default: above 0 up to the Nyquist frequency).
    **psd_options
        Passed to :func:`psd`.

    Returns
    -------
    ndarray, shape () or (n,)
        NaN for a signal with NaN/inf or no power in the band.
    """
    f, p = psd(x, fs, **psd_options)
    single = p.ndim == 1
    P = np.atleast_2d(p)
    mask = _band_mask(f, band)
    idx = np.flatnonzero(mask)
    pb = np.where(np.isfinite(P[:, idx]), P[:, idx], -np.inf)
    k = np.argmax(pb, axis=1)
    j = idx[k]
    out = f[j].astype(float)
    df = f[1] - f[0]
    inner = (k > 0) & (k < idx.size - 1)
    rows = np.arange(P.shape[0])
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.log(P[rows, np.clip(j - 1, 0, f.size - 1)])
        b = np.log(P[rows, j])
        c = np.log(P[rows, np.clip(j + 1, 0, f.size - 1)])
        den = a - 2 * b + c
        shift = np.where(inner & (den < 0), 0.5 * (a - c) / den, 0.0)
    out = out + np.clip(np.nan_to_num(shift), -0.5, 0.5) * df
    bad = ~np.isfinite(P[:, idx]).all(axis=1) | ~(P[rows, j] > 0)
    out[bad] = np.nan
    return out[0] if single else out


def peak_prominence(
    x: ArrayLike, fs: float, *, band: tuple[float, float] | None = None, **psd_options
) -> NDArray[np.float64]:
    """Largest PSD value in ``band`` over the band's median PSD (≥ 1; NaN for bad rows).

    A guide to whether a peak is a mode or noise: with 4 averaged segments, white noise gives
    about 3–5; a lightly damped mode excited by gusts gives tens to thousands.
    """
    f, p = psd(x, fs, **psd_options)
    single = p.ndim == 1
    P = np.atleast_2d(p)[:, _band_mask(f, band)]
    with np.errstate(divide="ignore", invalid="ignore"):
        out = P.max(axis=1) / np.median(P, axis=1)
    out = np.where(np.isfinite(out), out, np.nan)
    return out[0] if single else out


def _edges(band: tuple[float, float], n_bands: int, log: bool) -> NDArray[np.float64]:
    lo, hi = float(band[0]), float(band[1])
    if log and lo > 0:
        return np.geomspace(lo, hi, n_bands + 1)
    return np.linspace(lo, hi, n_bands + 1)


def band_powers(
    x: ArrayLike,
    fs: float,
    edges: ArrayLike,
    **psd_options,
) -> NDArray[np.float64]:
    """Power of each signal in the contiguous bands ``edges[k] .. edges[k+1]`` (unit²).

    The PSD is integrated over each band by the trapezoidal rule on the (zero-padded) grid.

    Returns
    -------
    ndarray, shape (K,) or (n, K)
    """
    e = np.asarray(edges, dtype=float)
    if e.ndim != 1 or e.size < 2 or not np.all(np.diff(e) > 0) or e[0] < 0:
        raise FlightDataError(f"edges must be increasing frequencies >= 0 Hz, got {edges!r}")
    f, p = psd(x, fs, **psd_options)
    if e[-1] > f[-1] * (1 + 1e-9):
        raise FlightDataError(
            f"the last band edge {e[-1]:g} Hz is above the Nyquist frequency {f[-1]:g} Hz"
        )
    single = p.ndim == 1
    P = np.atleast_2d(p)
    out = np.empty((P.shape[0], e.size - 1))
    for k in range(e.size - 1):
        fk = np.concatenate([[e[k]], f[(f > e[k]) & (f < e[k + 1])], [e[k + 1]]])
        pos = np.clip(np.searchsorted(f, fk, side="right") - 1, 0, f.size - 2)
        w = (fk - f[pos]) / (f[pos + 1] - f[pos])  # linear interpolation, all rows at once
        pk = P[:, pos] * (1 - w) + P[:, pos + 1] * w
        out[:, k] = np.trapezoid(pk, fk, axis=1)
    return out[0] if single else out


def spectrum_distance(
    x: ArrayLike,
    reference: ArrayLike,
    fs: float,
    *,
    band: tuple[float, float],
    n_bands: int = 6,
    log_bands: bool = True,
    **psd_options,
) -> NDArray[np.float64]:
    """Distance between the spectral shapes of signals and one reference signal in a band.

    ``mean_k | ln(s_k + ε) - ln(r_k + ε) |`` over ``n_bands`` sub-bands of ``band``
    (logarithmically spaced by default), where ``s_k`` and ``r_k`` are each signal's share of its
    power in the band and ε = :data:`SHARE_FLOOR`. 0 for the same shape at any amplitude; about
    ln 2 ≈ 0.69 when each sub-band's share is off by a factor of two. A signal with no power in
    the band gets NaN.

    Parameters
    ----------
    x : array_like, shape (T,) or (n, T)
        Signals (e.g. simulated rates of a batch of trials).
    reference : array_like, shape (T,)
        The measured signal on the same grid.
    fs : float
        Sampling frequency, Hz.
    band : (float, float)
        Frequency band compared, Hz.
    n_bands : int
        Sub-bands (>= 2).
    log_bands : bool
        Logarithmically spaced sub-bands (equal relative width); linear otherwise.
    **psd_options
        Passed to :func:`psd`.

    Returns
    -------
    ndarray, shape () or (n,)
    """
    if n_bands < 2:
        raise FlightDataError(f"n_bands must be >= 2, got {n_bands}")
    ref = np.asarray(reference, dtype=float)
    if ref.ndim != 1:
        raise FlightDataError(f"reference must be one signal (T,), got shape {ref.shape}")
    arr = np.asarray(x, dtype=float)
    single = arr.ndim == 1
    arr = np.atleast_2d(arr)
    if arr.shape[1] != ref.size:
        raise FlightDataError(
            f"signals have {arr.shape[1]} samples but the reference has {ref.size}"
        )
    edges = _edges(band, n_bands, log_bands)
    both = band_powers(np.vstack([ref[None, :], arr]), fs, edges, **psd_options)
    with np.errstate(divide="ignore", invalid="ignore"):
        share = both / both.sum(axis=1, keepdims=True)
        logs = np.log(share + SHARE_FLOOR)
        d = np.abs(logs[1:] - logs[0][None, :]).mean(axis=1)
    d = np.where(np.isfinite(d) & (both[1:].sum(axis=1) > 0), d, np.nan)
    if not (both[0].sum() > 0):
        raise FlightDataError(
            f"the reference signal has no power in the band [{band[0]:g}, {band[1]:g}] Hz; "
            "choose a band where the measurement oscillates"
        )
    return d[0] if single else d


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
        Welch segment length in samples; default :func:`segment_length` (4 segments at 50 %
        overlap, at most 256 samples). Longer segments give finer frequency bins (resolution
        ``fs / nperseg``), shorter ones a smoother spectrum.
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
    seg = min(256, segment_length(T, fs)) if nperseg is None else int(nperseg)
    if not 4 <= seg <= T:
        raise FlightDataError(f"nperseg must be in [4, {T}] samples, got {nperseg}")
    out = np.full((n, n_peaks), np.nan)
    ok = np.all(np.isfinite(arr), axis=1)
    if not np.any(ok):
        return out[0] if single else out
    f = np.fft.rfftfreq(seg, 1.0 / fs)
    pxx = _welch(arr[ok], fs, seg, seg, detrend)  # Welch as psd(): Hann, 50 %, no padding
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


def rate_peaks(
    rates: ArrayLike,
    fs: float,
    bands: Mapping[str, tuple[float, float]],
    *,
    whiten: bool = True,
) -> dict[str, tuple[float, float]]:
    """Spectral peak (frequency, prominence) of each column of a rate history in its band.

    Parameters
    ----------
    rates : array_like, shape (T, m)
        Uniformly sampled signals, one per column (e.g. roll, pitch and yaw rates, rad/s).
    fs : float
        Sampling frequency, Hz.
    bands : mapping
        Column name -> band (low, high) in Hz, in column order: the first name is column 0.
    whiten : bool
        Whiten the spectrum before searching (:func:`psd`), so that a mode stands out of the
        low-frequency manoeuvres.

    Returns
    -------
    dict
        Name -> (peak frequency in Hz, prominence: largest PSD in the band over its median,
        dimensionless, >= 1); NaN for a column with no power or NaN.
    """
    R = np.asarray(rates, dtype=float)
    if R.ndim != 2 or R.shape[1] < len(bands):
        raise ValueError(
            f"rates: expected a (T, {len(bands)}) array (one column per band), got shape "
            f"{R.shape}; pass the rate history with time down the rows"
        )
    out = {}
    for j, (name, band) in enumerate(bands.items()):
        s = R[:, j]
        out[name] = (
            float(spectral_peak(s, fs, band=band, whiten=whiten)),
            float(peak_prominence(s, fs, band=band, whiten=whiten)),
        )
    return out
