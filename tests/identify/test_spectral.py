"""Dominant frequencies from Welch spectra."""

from __future__ import annotations

import numpy as np
import pytest

from vectorid.identify import eigenfrequencies
from vectorid.identify.flight import FlightDataError
from vectorid.identify.spectral import resample_uniform


def test_finds_a_known_oscillation_frequency_between_bins():
    fs = 20.0
    t = np.arange(0.0, 60.0, 1 / fs)
    f0 = 0.437  # not on a bin of 256-sample segments (0.078 Hz bins)
    rng = np.random.default_rng(1)
    x = 0.3 * np.sin(2 * np.pi * f0 * t) + 0.05 * rng.standard_normal(t.size) + 0.02 * t
    f = eigenfrequencies(x, fs)
    assert f.shape == (1,)
    assert f[0] == pytest.approx(f0, abs=0.01)


def test_batch_and_nan_rows():
    fs = 10.0
    t = np.arange(0.0, 100.0, 1 / fs)
    x = np.stack([np.sin(2 * np.pi * f * t) for f in (0.2, 0.5, 1.3)])
    x = np.concatenate([x, np.full((1, t.size), np.nan)])
    f = eigenfrequencies(x, fs, nperseg=512)
    assert f.shape == (4, 1)
    assert f[:3, 0] == pytest.approx([0.2, 0.5, 1.3], abs=0.005)
    assert np.isnan(f[3, 0])


def test_two_peaks_sorted_by_frequency_and_band():
    fs = 10.0
    t = np.arange(0.0, 200.0, 1 / fs)
    x = 1.0 * np.sin(2 * np.pi * 1.1 * t) + 0.5 * np.sin(2 * np.pi * 0.3 * t)
    f = eigenfrequencies(x, fs, n_peaks=2, nperseg=1024)
    assert f == pytest.approx([0.3, 1.1], abs=0.01)
    # a band that excludes the stronger peak finds the weaker one
    assert eigenfrequencies(x, fs, fmax=0.8, nperseg=1024)[0] == pytest.approx(0.3, abs=0.01)


def test_resample_uniform_and_errors():
    t = np.array([0.0, 0.1, 0.2, 0.35, 0.4, 0.5])
    x = 2 * t
    tu, xu, fs = resample_uniform(t, x)
    assert fs == pytest.approx(10.0)
    assert xu == pytest.approx(2 * tu)
    with pytest.raises(FlightDataError, match="at least 4 samples"):
        eigenfrequencies(np.ones(3), 10.0)
    with pytest.raises(FlightDataError, match="fs must be"):
        eigenfrequencies(np.ones(30), 0.0)


# -- robust spectra: short windows, noise, turns, band powers ----------------------------------

from vectorid.identify.spectral import (  # noqa: E402
    band_powers,
    peak_prominence,
    psd,
    segment_length,
    spectral_peak,
    spectrum_distance,
)

FS = 5.0  # Hz, the comparison grid of a drop (output_dt = 0.2 s)


def _mode(t, f0, amp, rng, noise, phase=0.0):
    """A mode at f0 Hz plus white noise, a turn's step and a slow drift (a yaw-rate record)."""
    step = 0.3 * (t > t[-1] / 2)
    return amp * np.sin(2 * np.pi * f0 * t + phase) + noise * rng.standard_normal(t.size) + step


@pytest.mark.parametrize(("duration", "tol"), [(40.0, 0.01), (130.0, 0.003)])
def test_peak_frequency_holds_on_short_noisy_windows_with_a_turn(duration, tol):
    t = np.arange(0.0, duration, 1 / FS)
    errors = []
    for seed in range(20):
        rng = np.random.default_rng(seed)
        x = _mode(t, 0.42, 0.5, rng, noise=0.5, phase=seed) + 0.01 * t
        errors.append(spectral_peak(x, FS, band=(0.25, 1.5)) - 0.42)
    # 20 records with the mode's power equal to the noise's: every estimate within tol
    assert np.max(np.abs(errors)) < tol
    # without the band, the turn's step (power at the lowest frequencies) wins
    rng = np.random.default_rng(1)
    x = _mode(t, 0.42, 0.05, rng, noise=0.01)
    assert spectral_peak(x, FS) < 0.2
    assert spectral_peak(x, FS, band=(0.25, 1.5)) == pytest.approx(0.42, abs=tol)


def test_prominence_tells_a_mode_from_noise():
    t = np.arange(0.0, 130.0, 1 / FS)
    rng = np.random.default_rng(2)
    noise = [peak_prominence(rng.standard_normal(t.size), FS, band=(0.25, 1.5)) for _ in range(20)]
    mode = peak_prominence(_mode(t, 0.6, 0.5, rng, noise=0.5), FS, band=(0.25, 1.5))
    assert max(noise) < 8.0 < 20.0 < mode


def test_default_segments_average_short_records():
    assert segment_length(200, FS) == 80  # four segments at 50 % overlap
    assert segment_length(10, FS) == 10
    assert segment_length(650, FS, resolution=0.05) == 100
    f, p = psd(np.random.default_rng(0).standard_normal(200), FS)
    assert f[-1] == pytest.approx(FS / 2) and f[1] - f[0] < FS / 80  # zero padded


def test_band_powers_integrate_the_variance():
    t = np.arange(0.0, 200.0, 1 / FS)
    sine = 2.0 * np.sin(2 * np.pi * 0.42 * t)  # variance 2
    bp = band_powers(sine, FS, [0.1, 0.3, 0.6, 2.5])
    assert bp[1] == pytest.approx(2.0, rel=0.02) and bp[0] + bp[2] < 0.01
    white = np.random.default_rng(3).standard_normal(5000)
    assert band_powers(white, FS, [0.0, 2.5])[0] == pytest.approx(white.var(), rel=0.02)
    with pytest.raises(FlightDataError, match="Nyquist"):
        band_powers(white, FS, [0.1, 3.0])


def test_spectrum_distance_compares_shapes_not_amplitudes():
    t = np.arange(0.0, 130.0, 1 / FS)
    rng = np.random.default_rng(4)
    meas = _mode(t, 0.42, 1.0, rng, noise=0.3)
    same_shape = 3.0 * _mode(t, 0.42, 1.0, np.random.default_rng(5), noise=0.3, phase=1.0)
    other_mode = _mode(t, 0.8, 1.0, np.random.default_rng(6), noise=0.3)
    d = spectrum_distance(np.stack([same_shape, other_mode]), meas, FS, band=(0.2, 2.0))
    assert d[0] < 0.3 < 1.0 < d[1]
    assert spectrum_distance(meas, meas, FS, band=(0.2, 2.0)) == pytest.approx(0.0, abs=1e-12)
    nan_row = np.full(t.size, np.nan)
    assert np.isnan(spectrum_distance(np.stack([nan_row]), meas, FS, band=(0.2, 2.0))[0])


def test_spectral_criteria_with_a_band_on_batches():
    from vectorid.identify.criteria import CriterionError, evaluate_criteria, get_criterion

    t = np.arange(0.0, 100.0, 1 / FS)
    rng = np.random.default_rng(7)

    def rates(f_yaw):
        r = np.zeros((t.size, 3))
        r[:, 2] = _mode(t, f_yaw, 0.2, rng, noise=0.05)
        r[:, 0] = 0.1 * np.sin(2 * np.pi * 0.3 * t) + 0.01 * rng.standard_normal(t.size)
        r[:, 1] = 0.1 * np.sin(2 * np.pi * 0.7 * t) + 0.01 * rng.standard_normal(t.size)
        return r

    meas = rates(0.45)
    sim = np.stack([rates(0.45), rates(0.6), rates(0.45)])
    sim[2, 10, 2] = np.nan  # a failed trial
    names = ["peak_yaw@0.25-1.5", "band_yaw@0.25-1.5", "peak_roll", "band_pitch"]
    F = evaluate_criteria(names, {"rates": sim}, {"rates": meas}, t)
    assert F.shape == (3, 4)
    assert F[0, 0] < 0.01 and F[1, 0] == pytest.approx(0.15, abs=0.02)
    assert F[0, 1] < F[1, 1]
    assert F[0, 2] < 0.01 and F[0, 3] < 0.3
    assert np.all(np.isnan(F[2]))
    assert get_criterion("peak_yaw@0.25-1.5").unit == "Hz"
    assert "0.25-1.5 Hz" in get_criterion("peak_yaw@0.25-1.5").meaning
    assert get_criterion("peak_psi@0.1-1:relerr").unit == "1"
    with pytest.raises(CriterionError, match="low-high"):
        get_criterion("peak_yaw@0.25")
    with pytest.raises(CriterionError, match="spectral criteria only"):
        get_criterion("pos_h_abs@0.1-1")
    with pytest.raises(CriterionError, match="empty"):
        evaluate_criteria(["peak_yaw@3-4"], {"rates": sim[:1]}, {"rates": meas}, t)


@pytest.mark.parametrize("detrend", ["linear", "constant", False])
@pytest.mark.parametrize(
    ("T", "seg", "nfft"),
    # nfft == seg (odd and even): eigenfrequencies' unpadded segments
    [(750, 300, 1200), (101, 40, 256), (200, 80, 321), (130, 45, 45), (256, 64, 64)],
)
def test_batched_welch_equals_scipy(detrend, T, seg, nfft):
    from scipy import signal

    from vectorid.identify.spectral import _welch

    rng = np.random.default_rng(8)
    x = rng.standard_normal((6, T)) + np.linspace(0.0, 3.0, T)
    _, ref = signal.welch(x, fs=FS, window="hann", nperseg=seg, noverlap=seg // 2, nfft=nfft,
                          detrend=detrend, axis=-1)  # fmt: skip
    np.testing.assert_allclose(_welch(x, FS, seg, nfft, detrend), ref, rtol=1e-12, atol=1e-15)


def test_rate_peaks_per_column_and_band():
    from vectorid.identify.spectral import rate_peaks

    fs = 10.0
    t = np.arange(0, 200, 1 / fs)
    rng = np.random.default_rng(3)
    R = np.column_stack([np.sin(2 * np.pi * 0.2 * t), np.sin(2 * np.pi * 0.8 * t)])
    R += 0.05 * rng.standard_normal(R.shape)
    peaks = rate_peaks(R, fs, {"roll": (0.05, 0.5), "pitch": (0.25, 1.5)})
    assert peaks["roll"][0] == pytest.approx(0.2, abs=0.02)
    assert peaks["pitch"][0] == pytest.approx(0.8, abs=0.03)
    assert peaks["roll"][1] > 10 and peaks["pitch"][1] > 10
    with pytest.raises(ValueError, match="one column per band"):
        rate_peaks(R[:, 0], fs, {"roll": (0.05, 0.5)})
