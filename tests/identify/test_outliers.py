"""Single-sample spikes (vectorid.identify.outliers): a wrapping angle is not one; the threshold
is relative to the channel's own noise (a noisy stretch's excursions stay, a quiet glitch goes)."""

import warnings
from pathlib import Path

import numpy as np
import pytest

from vectorid.identify.flight import FlightChannel, FlightData
from vectorid.identify.loaders import load_telemega
from vectorid.identify.outliers import SPIKE_FLOORS, drop_spikes, find_spikes


def _flight(values, unit="rad"):
    t = np.arange(len(values)) * 0.1
    ch = FlightChannel("euler", t, values, ("roll", "pitch", "yaw"), unit)
    return FlightData("f", {"euler": ch}, {})


def test_a_heading_that_touches_zero_for_one_sample_is_not_a_spike():
    # a heading hovering just under 2 pi: one sample wraps to just above 0 rad
    yaw = 6.27 + 0.01 * np.sin(np.arange(60) / 3.0)
    yaw[30] = 0.0002
    values = np.column_stack([np.zeros(60), np.zeros(60), yaw])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = drop_spikes(_flight(values), "log")
    assert out.channels["euler"].t.size == 60 and not out.notes


def test_a_real_glitch_in_an_angle_is_still_one():
    yaw = np.linspace(1.0, 1.6, 60)
    yaw[30] = 4.5
    values = np.column_stack([np.zeros(60), np.zeros(60), yaw])
    out = drop_spikes(_flight(values), "log", "note")
    assert out.channels["euler"].t.size == 59 and "3.00 s" in out.notes[0]


# -- the threshold is relative to the channel's own noise -----------------------------------------

TELEMEGA = (
    Path(__file__).resolve().parents[2].parent
    / "shared" / "data" / "prometheus-2022" / "2022-06-24-serial-6583-flight-0003-TeleMega.csv"
)  # fmt: skip


def test_excursions_within_a_noisy_stretch_stay_and_a_quiet_glitch_goes():
    rng = np.random.default_rng(4)
    t = np.arange(0.0, 60.0, 0.1)
    h = 3000.0 - 25.0 * t + rng.normal(0.0, 0.3, t.size)
    noisy = (t > 20) & (t < 30)  # an ejection's pressure disturbance: ±4 m sample to sample
    h[noisy] += rng.normal(0.0, 4.0, noisy.sum())
    i_noisy = int(np.flatnonzero(noisy)[40])
    h[i_noisy] += 12.0  # a 12-m excursion among ±4-m scatter: that stretch's noise
    h[450] += 12.0  # the same 12 m where the barometer is quiet: a spike
    sp = find_spikes(t, h, floor=10.0)
    assert 450 in sp.index and i_noisy not in sp.index
    # true single-sample spikes are found in the noisy stretch too
    for bad in (300.0, 1e6, 1e300):
        h2 = h.copy()
        h2[i_noisy] = h[i_noisy] + bad
        assert i_noisy in find_spikes(t, h2, floor=10.0).index, bad


def test_prometheus_keeps_its_barometric_excursions_and_finds_real_spikes():
    if not TELEMEGA.exists():
        pytest.skip(f"shared data not found at {TELEMEGA}")
    a = load_telemega(TELEMEGA, spikes="keep")["altitude"]
    t, h = a.t, a.values[:, 0]
    sp = find_spikes(t, h, floor=SPIKE_FLOORS["altitude"])
    found = {round(float(x), 2) for x in sp.times}
    # the 12-13 m excursions after the drogue's ejection (samples scattering by ±8 m) stay
    assert not found & {44.21, 46.51, 51.91}, sorted(found)
    # the 155-m one-sample drop at the main's ejection charge (neighbours within 3 m) goes
    assert 157.91 in found
    # injected: +300 m among the scatter, 1e6 and 1e300 m, +30 m in the quiet drogue descent
    hits = {}
    for at, bad in ((44.5, 300.0), (100.0, 1e6), (120.0, 1e300), (80.0, 30.0)):
        i = int(np.argmin(np.abs(t - at)))
        hits[i] = bad
    h2 = h.copy()
    for i, bad in hits.items():
        h2[i] = h[i] + bad
    got = set(find_spikes(t, h2, floor=SPIKE_FLOORS["altitude"]).index.tolist())
    assert set(hits) <= got, (sorted(set(hits) - got), [t[i] for i in hits])
    # and the apogee, read from the loader's output, is not one of them
    fd = load_telemega(TELEMEGA, spikes="note")
    assert fd["altitude"].values.max() < 5500
