"""The gust allowance: seeded, linear in the gusts' size, growing with the height flown."""

from __future__ import annotations

import numpy as np
import pytest

from vectorid.identify.gusts import ETH_GUSTS, HeightGusts, gust_allowance


def test_stationary_sigma_of_the_height_process():
    g = ETH_GUSTS
    a = 1.0 + g.dh * g.k
    rng = np.random.default_rng(3)
    x = np.zeros((4000, 3))
    for _ in range(3000):  # far past the process's memory (1 / (1 - a) = 520 steps)
        x = a * x + g.dh * rng.normal(0.0, g.b, (4000, 3))
    assert np.std(x, axis=0) == pytest.approx(g.sigma, rel=0.05)


def test_allowance_is_seeded_linear_in_the_gusts_and_grows_with_the_flight():
    durations = {"short": 12.0, "long": 40.0}
    one = gust_allowance(durations, ETH_GUSTS, sink=1.23, draws=500, seed=2)
    assert one == gust_allowance(durations, ETH_GUSTS, sink=1.23, draws=500, seed=2)
    double = HeightGusts(ETH_GUSTS.dh, ETH_GUSTS.k, tuple(2 * b for b in ETH_GUSTS.b))
    two = gust_allowance(durations, double, sink=1.23, draws=500, seed=2)
    for name in durations:  # the deviation is linear in the gust: twice the gust, twice it
        for key in ("position_h", "position_v"):
            assert two[name][key] == pytest.approx(2 * one[name][key], rel=1e-9)
            assert one[name][key] > 0
    assert one["long"]["position_h"] > one["short"]["position_h"]
    # a sink rate per flight: a flight descending faster crosses more gusts
    fast = gust_allowance({"f": 20.0}, ETH_GUSTS, sink={"f": 6.0}, draws=500, seed=2)
    slow = gust_allowance({"f": 20.0}, ETH_GUSTS, sink={"f": 1.0}, draws=500, seed=2)
    assert fast["f"]["position_h"] > slow["f"]["position_h"]
