"""Single-sample spikes (vectorid.identify.outliers): a wrapping angle is not one."""

import warnings

import numpy as np

from vectorid.identify.flight import Channel, FlightData
from vectorid.identify.outliers import drop_spikes


def _flight(values, unit="rad"):
    t = np.arange(len(values)) * 0.1
    ch = Channel("euler", t, values, ("roll", "pitch", "yaw"), unit)
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
