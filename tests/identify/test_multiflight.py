"""Several flights at once: shared and per-flight variables, criteria averaged over the
flights, noise floors averaged the same way (twin flights of the rocket-descent model)."""

from __future__ import annotations

import numpy as np
import pytest

from vectorid.descent import RocketDescent
from vectorid.errors import StudyDefinitionError
from vectorid.identify import FlightChannel, FlightData
from vectorid.identify.multiflight import MultiFlight
from vectorid.identify.noise import parse_noise
from vectorid.models import ControlSchedule, InitialState
from vectorid.workflows import check_truth

ORIGIN = 1300.0
TRUTH = {"cd_drogue": 1.7, "f1": 2.4, "f2": 2.9}  # one drogue, each flight its own main


def _flight(name: str, cd_main: float, seed: int) -> FlightData:
    res = RocketDescent().simulate(
        np.array([[TRUTH["cd_drogue"], cd_main]]),
        t_final=30.0,
        dt=0.01,
        output_dt=0.1,
        initial=InitialState(altitude=ORIGIN + 500.0),
        inputs=ControlSchedule.constant(["main"], [1.0]),
    )
    h = -res.position[0, :, 2] - ORIGIN + np.random.default_rng(seed).normal(0.0, 0.5, res.t.size)
    alt = FlightChannel("altitude", res.t, h[:, None], ("altitude",), "m")
    return FlightData(name, {"altitude": alt}, {}, None)


@pytest.fixture(scope="module")
def model() -> MultiFlight:
    flights = {"f1": _flight("f1", TRUTH["f1"], 1), "f2": _flight("f2", TRUTH["f2"], 2)}
    table = {"model": "rocket-descent", "dt": 0.05, "output_dt": 0.5, "init_span": 1.0}
    drop = {"inputs": {"main": 1.0}, "origin_altitude": ORIGIN}
    return MultiFlight.from_flights(
        flights, table, ("cd_drogue",), ["alt_abs"], per_flight=("cd_main",),
        window_channels=("altitude",), drop=drop,
    )  # fmt: skip


def test_columns_and_the_mean_over_the_flights(model):
    assert model.variables == ["cd_drogue", "cd_main.f1", "cd_main.f2"]
    X = np.array([[1.7, 2.4, 2.9], [1.2, 3.5, 2.0]])
    per = model.per_flight(X)
    assert per.shape == (2, 2, 1)
    for k, name in enumerate(model.names):  # flight k sees the shared column and its own
        own = model.idents[name].evaluate(X[:, [0, 1 + k]])[0]
        np.testing.assert_array_equal(per[:, k], own)
    np.testing.assert_allclose(model(X), per.mean(axis=1))
    # the truth fits both flights; swapping the flights' own variables does not
    truth = np.array([TRUTH["cd_drogue"], TRUTH["f1"], TRUTH["f2"]])
    swapped = np.array([TRUTH["cd_drogue"], TRUTH["f2"], TRUTH["f1"]])
    assert model(truth[None])[0, 0] < 0.5 * model(swapped[None])[0, 0]
    err = model.rms_errors(truth)
    assert set(err) == {"f1", "f2"} and "horizontal" not in err["f1"]
    assert all(0.2 < e["altitude"] < 0.9 for e in err.values())  # the 0.5-m noise
    assert err["f1"]["duration"] == pytest.approx(model.idents["f1"].drops[0].duration)


def test_noise_limits_average_the_flights_and_hold_the_truth(model):
    noise = {n: parse_noise({"altitude": 0.5}) for n in model.names}
    allowance = {"f1": {"altitude": 1.0}, "f2": {"altitude": 2.0}}
    limits, used = model.noise_limits(allowance, draws=300, channels=("altitude",), noise=noise)
    assert set(limits) == {"alt_abs"} and set(used) == {"f1", "f2"}
    value, note = limits["alt_abs"]
    assert note.startswith("noise floor") and "discrepancy altitude 1-2 m by flight" in note
    truth = {"cd_drogue": TRUTH["cd_drogue"], "cd_main.f1": TRUTH["f1"], "cd_main.f2": TRUTH["f2"]}
    check = check_truth(model, truth, model.variables, ["alt_abs"], {"alt_abs": value})
    assert check.meets, check.ratios
    # without the allowance the floor is lower; an estimated noise says it is estimated
    tight, _ = model.noise_limits({"f1": {}, "f2": {}}, draws=300, channels=("altitude",))
    assert tight["alt_abs"][0] < value
    assert all(s.startswith("estimated") for s in model.noise_limits(
        {"f1": {}, "f2": {}}, draws=100, channels=("altitude",))[1].values())  # fmt: skip


def test_flights_must_share_variables_and_criteria(model):
    ident = model.idents["f1"]
    with pytest.raises(StudyDefinitionError, match="shared ones, then the flight's own"):
        MultiFlight({"f1": ident}, ("cd_main",), ("cd_drogue",))
    with pytest.raises(StudyDefinitionError, match="no flight"):
        MultiFlight({}, ("cd_drogue",))
