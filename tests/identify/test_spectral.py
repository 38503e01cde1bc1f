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
