"""Power spectra and envelopes on synthetic signals."""

import numpy as np
import pytest

from vectorid.analysis.signals import dominant_frequency, envelope, power_spectrum, uniform


def test_dominant_frequency_of_a_sine_non_uniform_time():
    rng = np.random.default_rng(0)
    t = np.sort(rng.uniform(0, 120, 6000))
    y = np.column_stack([np.sin(2 * np.pi * 0.5 * t), 0.3 * np.sin(2 * np.pi * 2.0 * t)])
    f, p = power_spectrum(t, y, nperseg=1024)
    assert p.shape == (len(f), 2)
    np.testing.assert_allclose(dominant_frequency(f, p), [0.5, 2.0], atol=0.03)


def test_uniform_and_errors():
    t = np.array([0.0, 0.1, 0.25, 0.3])
    tu, yu = uniform(t, 2 * t, dt=0.1)
    np.testing.assert_allclose(tu, [0.0, 0.1, 0.2, 0.3])
    np.testing.assert_allclose(yu, 2 * tu)
    with pytest.raises(ValueError, match="increasing"):
        uniform(np.array([0.0, 0.2, 0.1]), np.zeros(3))


def test_envelope_of_runs():
    t = np.linspace(0, 10, 101)
    runs = [(t, np.sin(t) + k) for k in (-1.0, 0.0, 2.0)]
    lo, med, hi = envelope(t, runs)
    np.testing.assert_allclose(lo, np.sin(t) - 1)
    np.testing.assert_allclose(med, np.sin(t))
    np.testing.assert_allclose(hi, np.sin(t) + 2)
    short = [(np.linspace(0, 5, 51), np.ones(51))]
    lo, _, _ = envelope(t, short)
    assert np.isnan(lo[-1]) and lo[0] == 1.0
