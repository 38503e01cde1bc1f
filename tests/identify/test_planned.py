"""Drop files: planned drops (no data) and drops copied from a study, parsed and checked."""

from __future__ import annotations

import numpy as np
import pytest

from tests.workflows.predict_helpers import MAPPING, ORIGIN, drop_file, planned, write_track
from vectorid import models
from vectorid.errors import StudyDefinitionError
from vectorid.identify.planned import read_drop_file
from vectorid.identify.predictor import Predictor

PARAFOIL = models.get("parafoil6dof")


def test_a_planned_drop_reads_its_state_schedule_wind_and_noise(tmp_path):
    (tmp_path / "wind.csv").write_text(
        "altitude_m,u_ms,v_ms\n1000,1.0,2.0\n4000,3.0,4.0\n", encoding="utf-8"
    )
    d = planned(
        origin=[32.85, -114.39, ORIGIN],
        initial={"altitude": ORIGIN + 900.0, "north": 5.0, "velocity": [1.0, 2.0, 3.0],
                 "euler": [0.0, 0.1, 1.2], "rates": [0.0, 0.0, 0.05]},
        channels={"position": 4.0, "euler": 10.0, "alpha": 2.0},
        wind="wind.csv", wind_format="dropsonde",
        wind_options={"altitude": "altitude_m", "u": "u_ms", "v": "v_ms"},
        controls={"time": [0.0, 30.0, 31.0], "flap_left": [0.0, 0.0, 0.5]},
        inputs={"flap_right": 0.1}, interpolation="linear",
        noise={"position_h": 1.5}, ground_altitude=ORIGIN - 20.0,
    )  # fmt: skip
    d.pop("origin_altitude")
    (p,) = read_drop_file(drop_file(tmp_path / "p.toml", [d]), PARAFOIL, dt=0.05)
    assert p.kind == "planned" and p.flight is None and p.t0 == 0.0
    assert p.initial.altitude == ORIGIN + 900.0 and p.initial.north == 5.0
    assert p.initial.velocity == (1.0, 2.0, 3.0) and p.initial.euler == (0.0, 0.1, 1.2)
    assert p.origin_altitude == ORIGIN and p.ground_altitude == ORIGIN - 20.0
    assert p.channels == {"position": 4.0, "euler": 10.0, "alpha": 2.0}
    assert p.wind is not None and "wind.csv" in p.wind_text
    u = p.inputs.reorder(PARAFOIL.input_names, [0.0, 0.0])
    assert np.allclose(u(np.array([0.0, 30.5, 40.0]))[:, 0], [0.0, 0.25, 0.5])
    assert (
        p.noise.component("position", 0).sigma == 1.5 and p.noise.component("position", 2) is None
    )
    assert "the drop's own" in p.noise_text


@pytest.mark.parametrize(
    "change, needle",
    [
        ({"channels": {"position": 7.0}}, "not a whole number"),
        ({"channels": {"pressure": 1.0}}, "no channel 'pressure'"),
        ({"initial": {"altitude": ORIGIN}}, "at or below the ground"),
        ({"initial": {"height": 100.0}}, "unknown key 'height'"),
        ({"initial": {"north": 1.0}}, "missing: the altitude"),
        ({"duration": -1.0}, "expected a number > 0"),
        ({"origin": [1.0, 2.0]}, "expected [latitude deg, longitude deg, altitude m]"),
        ({"inputs": {"riser1": 1.0}}, "not an input of model"),
        ({"controls": {"time": [0.0, 1.0], "flap_left": [0.0]}}, "1 values for 2 times"),
        ({"controls": {"time": [1.0, 0.0], "flap_left": [0.0, 1.0]}}, "increase strictly"),
        ({"parameters": {"CD00": 1.0}}, "not a parameter of model"),
        ({"parameters": {"CD0": "often"}}, "expected a number or one of"),
        ({"wind": "nowhere.csv"}, "not found"),
        ({"window": [0, 10]}, "unknown key 'window' for a planned drop"),
    ],
)
def test_bad_planned_drops_name_the_field_and_the_fix(tmp_path, change, needle):
    with pytest.raises(StudyDefinitionError, match=None) as exc:
        read_drop_file(drop_file(tmp_path / "p.toml", [planned(**change)]), PARAFOIL, dt=0.05)
    assert needle in str(exc.value) and "drops[0]" in str(exc.value)


def test_a_drop_file_is_checked_as_a_whole(tmp_path):
    f = tmp_path / "p.toml"
    f.write_text('[study]\nname = "x"\n', encoding="utf-8")
    with pytest.raises(StudyDefinitionError, match="unknown top-level key 'study'"):
        read_drop_file(f, PARAFOIL)
    f.write_text("[identification]\ndt = 0.1\n", encoding="utf-8")
    with pytest.raises(StudyDefinitionError, match="unknown key 'dt'"):
        read_drop_file(f, PARAFOIL)
    drop_file(f, [planned(), planned()])
    with pytest.raises(StudyDefinitionError, match="used twice"):
        read_drop_file(f, PARAFOIL)
    drop_file(f, [planned()], model="parachute6dof")
    with pytest.raises(StudyDefinitionError, match="the store identifies 'parafoil6dof'"):
        read_drop_file(f, PARAFOIL)
    f.write_text("not = [toml", encoding="utf-8")
    with pytest.raises(StudyDefinitionError, match="not a TOML file"):
        read_drop_file(f, PARAFOIL)


def test_a_drop_with_data_is_built_as_the_study_builds_it(tmp_path):
    write_track(tmp_path / "d.csv")
    d = {"name": "d", "file": "d.csv", "mapping": MAPPING, "window": [1.0, 31.0],
         "origin_altitude": ORIGIN, "noise": {"position_v": 2.0}}  # fmt: skip
    (p,) = read_drop_file(
        drop_file(tmp_path / "d.toml", [d]), PARAFOIL, study_noise={"position_h": 1.0},
        output_dt=0.5, init_span=1.0,
    )  # fmt: skip
    assert p.kind == "data" and p.t0 == 1.0 and p.duration == 30.0
    assert p.channels == {"position": None} and p.ground_altitude is None
    assert p.initial.altitude == pytest.approx(ORIGIN + 1500.0 - 6.0)  # fitted at 1 s
    assert p.noise.component("position", 0).sigma == 1.0  # the study's
    assert p.noise.component("position", 2).sigma == 2.0  # the drop's own
    d["window"] = [1.0, 99.0]
    with pytest.raises(StudyDefinitionError, match=r"d\.toml: drops\[0\]"):
        read_drop_file(drop_file(tmp_path / "d.toml", [d]), PARAFOIL)


def test_per_drop_variables_need_a_rule_for_a_new_drop(tmp_path):
    """The several-flights convention: wind_north.<flight> per flight; a new flight takes a
    value, one flight's (drawn per member) or the mean."""
    m = models.get("parafoil6dof", extra_parameters=("wind_north", "wind_east"))
    pred = Predictor(m, ["CD0", "wind_north.f1", "wind_north.f2", "wind_east.f1", "wind_east.f2"])
    assert pred.study_drops == ["f1", "f2"]
    (d,) = read_drop_file(drop_file(tmp_path / "p.toml", [planned()]), m, dt=0.05)
    with pytest.raises(StudyDefinitionError, match="wind_north, wind_east is unknown"):
        pred.check_drop(d)
    X = np.array([[1.1, 1.0, 3.0, -1.0, -3.0], [0.9, 2.0, 4.0, -2.0, -4.0]])
    d.parameters = {"wind_north": "mean", "wind_east": 0.5}
    pred.check_drop(d)
    P = pred.parameters(X, d)
    names = list(m.parameter_names)
    assert P[:, names.index("wind_north")].tolist() == [2.0, 3.0]
    assert P[:, names.index("wind_east")].tolist() == [0.5, 0.5]
    assert P[:, names.index("CD0")].tolist() == [1.1, 0.9]
    d.parameters = {"wind_north": "drawn", "wind_east": "drawn"}
    P = pred.parameters(np.repeat(X[:1], 200, axis=0), d, np.random.default_rng(1))
    assert set(P[:, names.index("wind_north")]) == {1.0, 3.0}
    pairs = set(zip(P[:, names.index("wind_north")], P[:, names.index("wind_east")]))
    assert pairs == {(1.0, -1.0), (3.0, -3.0)}  # one flight's wind, whole
    d.name = "f2"
    d.parameters = {}
    P = pred.parameters(X, d)
    assert P[:, names.index("wind_east")].tolist() == [-3.0, -4.0]
    d.parameters = {"CD0": 1.0}
    with pytest.raises(StudyDefinitionError, match="is a design variable"):
        pred.check_drop(d)


def test_the_initial_position_is_the_mean_of_fixes_moved_back_along_the_velocity():
    """A curved start (decelerating), noisy fixes, exact velocity: the moved-back mean is off
    by the mean noise of the first 10 s of fixes (plus the trapezoid's error)."""
    from vectorid.identify.drops import fit_initial_state
    from vectorid.identify.flight import FlightChannel, FlightData
    from vectorid.identify.planned import fit_prediction_state

    t = np.arange(0.0, 30.0, 0.25)
    vn = 2.0 + 8.0 * np.exp(-t / 2.0)  # decelerating from 10 to 2 m/s
    north = 2.0 * t + 16.0 * (1.0 - np.exp(-t / 2.0))
    rng = np.random.default_rng(3)
    noise = rng.normal(0.0, 3.0, (t.size, 3))
    pos = np.column_stack([north, 0 * t, -1000.0 + 6.0 * t]) + noise
    vel = np.column_stack([vn, 0 * t, 6.0 + 0 * t])
    fl = FlightData("f", {
        "position": FlightChannel("position", t, pos, ("north", "east", "down"), "m"),
        "velocity": FlightChannel("velocity", t, vel, ("north", "east", "down"), "m/s"),
    })  # fmt: skip
    ours = fit_prediction_state(fl, 0.0, 1.0, ORIGIN, None, "f")
    line = fit_initial_state(fl, 0.0, 1.0, ORIGIN, None, "f")
    assert abs(line.north) > 5 * abs(ours.north)  # a line through 1 s of noisy fixes
    n = int(np.sum(t <= 10.0))
    assert abs(ours.north - noise[:n, 0].mean()) < 0.05  # the mean noise (+ the trapezoid)
    assert abs(ours.altitude - (ORIGIN + 1000.0)) < 3 * 3.0 / np.sqrt(n)
    assert ours.velocity == line.velocity  # only the position changes
    # without a velocity channel it is the study's fit
    del fl.channels["velocity"]
    assert fit_prediction_state(fl, 0.0, 1.0, ORIGIN, None, "f") == fit_initial_state(
        fl, 0.0, 1.0, ORIGIN, None, "f"
    )
