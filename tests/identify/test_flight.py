"""Channels and flights: interpolation, windows by times and events, errors."""

from __future__ import annotations

import numpy as np
import pytest

from vectorid.errors import VectoridError
from vectorid.identify import FlightChannel, FlightData, FlightDataError


def make() -> FlightData:
    t1 = np.arange(0.0, 10.01, 0.5)
    t2 = np.arange(1.0, 9.01, 1.0)
    alt = FlightChannel("altitude", t1, 100 - 2 * t1, ("altitude",), "m")
    pos = FlightChannel(
        "position", t2, np.stack([t2, 0 * t2, -t2], 1), ("north", "east", "down"), "m"
    )
    return FlightData("f", {"altitude": alt, "position": pos}, {"main": 3.0, "landed": 9.5})


def test_channel_at_interpolates_and_refuses_extrapolation():
    c = FlightChannel("x", np.array([0.0, 1.0, 3.0]), np.array([0.0, 2.0, 6.0]), ("x",), "m")
    assert c.values.shape == (3, 1)
    assert c.at([0.5, 2.0]) == pytest.approx(np.array([[1.0], [4.0]]))
    with pytest.raises(FlightDataError, match=r"covers \[0 s, 3 s\]"):
        c.at([3.5])
    with pytest.raises(ValueError):  # FlightDataError is a ValueError
        c.at([-1.0])


@pytest.mark.parametrize(
    ("t", "v", "comps", "match"),
    [
        ([0.0, 1.0, 1.0], [1.0, 2.0, 3.0], ("x",), "strictly increasing, but sample 2"),
        ([0.0, 2.0, 1.0], [1.0, 2.0, 3.0], ("x",), "strictly increasing"),
        ([0.0, 1.0, 2.0], [1.0, np.nan, 3.0], ("x",), "finite"),
        ([0.0, 1.0, 2.0], [1.0, 2.0], ("x",), "shape"),
        ([0.0, 1.0], [[1.0, 2.0], [3.0, 4.0]], ("x",), "component names"),
    ],
)
def test_channel_validation(t, v, comps, match):
    with pytest.raises(FlightDataError, match=match):
        FlightChannel("x", np.array(t), np.array(v), comps, "m")


def test_getitem_lists_channels():
    fd = make()
    assert fd["altitude"].unit == "m"
    with pytest.raises(VectoridError, match="did you mean 'altitude'"):
        fd["altitud"]


def test_window_by_times_and_events_keeps_absolute_times():
    fd = make()
    w = fd.window("main", 8.0)
    assert w.time_range() == (3.0, 8.0)
    a = w["altitude"]
    assert a.t[0] == 3.0 and a.t[-1] == 8.0
    assert a.at([5.25])[0, 0] == pytest.approx(100 - 10.5)
    assert w.events == {"main": 3.0}
    assert w["position"].t[0] == 3.0
    w2 = fd.window(2.25, 4.75)
    assert w2["altitude"].t[0] == 2.25 and w2["altitude"].values[0, 0] == pytest.approx(95.5)


@pytest.mark.parametrize(
    ("start", "end", "match"),
    [
        (5.0, 4.0, "must come after"),
        (-1.0, 4.0, "outside the data"),
        ("drogue", 4.0, "no event 'drogue'"),
        (0.5, 4.0, r"position \[1 s, 9 s\]"),  # position starts at 1 s
        ("main", "landed", r"position \[1 s, 9 s\]"),
    ],
)
def test_window_errors(start, end, match):
    with pytest.raises(FlightDataError, match=match):
        make().window(start, end)


def test_window_require_and_optional_channels():
    fd = make()
    w = fd.window(0.5, 4.0, require=["altitude"])
    assert w["position"].t[0] == 1.0 and w["position"].t[-1] == 4.0
    extra = FlightChannel("temp", np.array([6.0, 7.0]), np.array([1.0, 2.0]), ("temp",), "degC")
    fd.channels["temp"] = extra
    w = fd.window(2.0, 5.0)  # temp has no data there: left out
    assert "temp" not in w and "altitude" in w


def test_grid_and_sample():
    fd = make()
    g = fd.grid(0.5)
    assert g[0] == 1.0 and g[-1] == 9.0 and g.size == 17
    s = fd.sample(["altitude", "position"], g)
    assert s["altitude"].shape == (17, 1) and s["position"].shape == (17, 3)
    assert s["position"][:, 0] == pytest.approx(g)
    with pytest.raises(FlightDataError, match="dt must be"):
        fd.grid(0.0)


def test_bad_event_time():
    with pytest.raises(FlightDataError, match="finite time"):
        FlightData("f", {}, {"x": float("nan")})
