"""Descent identification end to end on synthetic altimeter logs of known drag areas (the
model itself plus seeded noise): values, ranges, touchdown, the convention, verdicts; the
``vectorid descent`` verb; bad input."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from vectorid.cli import main
from vectorid.descent import (
    Canopy,
    DescentPlan,
    RocketDescentCdS,
    discrepancy,
    identify_descent,
    parse_length,
)
from vectorid.errors import StudyDefinitionError
from vectorid.identify import FlightDataError
from vectorid.models.base import InitialState
from vectorid.models.controls import ControlSchedule

from .test_story import story_is_one

PAD = 500.0  # m above sea level
MASS = 12.0
FT = 0.3048


def synthetic_log(
    path,
    *,
    drogue=0.5,
    main=6.0,
    convention="adds",
    trigger=300.0,
    lag=1.0,
    opens=True,
    noise=0.5,
    seed=0,
    feet=False,
):
    """A descent from a 1200 m apogee: the drogue from apogee, the main triggered at
    ``trigger`` m above the pad (opening over 2 s after ``lag``), touchdown, 10 s on the ground.
    Written as CSV (t_s, alt) with seeded white noise; returns the true touchdown time, s."""
    m = RocketDescentCdS(mass=MASS, drag_convention=convention)
    init = InitialState(altitude=PAD + 1200.0, velocity=(0.0, 0.0, 0.0))
    dt = 0.05
    first = m.simulate(np.array([[drogue, main]]), t_final=400.0, dt=dt, output_dt=dt,
                       initial=init)  # fmt: skip
    h = -first.position[0, :, 2] - PAD
    t_trig = float(np.interp(-trigger, -h, first.t))
    t_open = t_trig + lag
    if opens:
        ctrl = ControlSchedule(
            np.array([0.0, t_open, t_open + 2.0]), np.array([[0.0], [0.0], [1.0]]), ("main",),
            "linear",
        )  # fmt: skip
    else:
        ctrl = ControlSchedule(np.array([0.0]), np.array([[0.0]]), ("main",), "previous")
    res = m.simulate(np.array([[drogue, main]]), t_final=400.0, dt=dt, inputs=ctrl,
                     output_dt=dt, initial=init)  # fmt: skip
    t = res.t
    h = -res.position[0, :, 2] - PAD
    k = int(np.flatnonzero(h <= 0.0)[0])
    td = float(np.interp(0.0, [h[k], h[k - 1]], [t[k], t[k - 1]]))
    t = np.concatenate([np.arange(-3.0, 0.0, dt), t[t < td], np.arange(td, td + 10.0, dt)[1:]])
    # a short climb to apogee before t = 0 (the logger's boost), then the descent, the ground
    h = np.concatenate(
        [1200.0 - 4.9 * np.arange(-3.0, 0.0, dt) ** 2, h[: np.sum(res.t < td)],
         np.zeros(np.arange(td, td + 10.0, dt)[1:].size)]
    )  # fmt: skip
    rng = np.random.default_rng(seed)
    h = h + rng.normal(0.0, noise, h.size)
    col = h / FT if feet else h
    name = "alt_ft" if feet else "alt_m"
    path.write_text(f"t_s,{name}\n" + "".join(f"{a:.3f},{b:.3f}\n" for a, b in zip(t, col)))
    return td, t_trig


def _plan(path, **kw):
    base = {
        "file": path,
        "mass": MASS,
        "mapping": {"time": "t_s", "time_unit": "s", "altitude": {"column": "alt_m", "unit": "m"}},
        "drogue": Canopy(cds=0.5),
        "main": Canopy(cds=6.0),
        "convention": "adds",
        "main_at": "300m",
        "main_lag": 1.0,
        "pad_altitude": PAD,
        "trials": 128,
    }
    base.update(kw)
    return DescentPlan(**base)


@pytest.fixture(scope="module")
def adds_log(tmp_path_factory):
    path = tmp_path_factory.mktemp("log") / "adds.csv"
    td, t_trig = synthetic_log(path, convention="adds")
    return path, td, t_trig


@pytest.fixture(scope="module")
def adds_result(adds_log, tmp_path_factory):
    path, _, _ = adds_log
    return identify_descent(_plan(path), tmp_path_factory.mktemp("out"))


def test_twin_drag_areas_lie_in_their_ranges_and_agree(adds_result, adds_log):
    _, td, t_trig = adds_log
    r = adds_result
    assert r.touchdown is not None and r.touchdown["time_s"] == pytest.approx(td, abs=0.3)
    assert r.events["main_trigger"] == pytest.approx(t_trig, abs=0.3)
    for name, truth in (("drogue", 0.5), ("main", 6.0)):
        p = r.phase(name)
        assert p.status == "identified", p.verdict
        lo, hi = p.cds_feasible
        assert lo <= truth <= hi, (name, p.cds_feasible)
        assert p.cds_pareto[0] <= p.cds <= p.cds_pareto[1]
        assert p.cds == pytest.approx(truth, rel=0.03)
        assert p.alt_rms_m <= p.limits.alt_rms
        assert p.summary.startswith("agrees")
    story_is_one(r)  # each number of each phase's story once (test_story.py)
    # windows: drogue ends before the trigger, main ends 1 s before the touchdown
    assert r.phase("drogue").window[1] == pytest.approx(t_trig - 1.0, abs=0.3)
    assert r.phase("main").window[1] == pytest.approx(td - 1.0, abs=0.3)


def test_twin_json_has_the_documented_fields(adds_result):
    d = json.loads(json.dumps(adds_result.to_dict()))
    assert {"flight", "phases", "touchdown", "apogee", "events_s"} <= set(d)
    for p in d["phases"]:
        assert {"name", "cd", "pareto", "alt_rms_m", "vz_rms_ms", "cds", "cds_pareto"} <= set(p)
        assert p["cd"] is None  # no diameter stated
        assert p["cds_pareto"][0] <= p["cds"] <= p["cds_pareto"][1]


@pytest.mark.slow
def test_the_same_log_under_the_other_convention_gives_the_total(adds_log, tmp_path):
    # "replaces" calls the whole drag area under the main the main's: drogue + main of truth
    path, _, _ = adds_log
    r = identify_descent(_plan(path, convention="replaces", main=Canopy(cds=6.5)), tmp_path)
    assert r.phase("main").cds == pytest.approx(6.5, rel=0.03)
    assert r.phase("drogue").cds == pytest.approx(0.5, rel=0.03)


@pytest.mark.slow
def test_diameters_give_drag_coefficients(adds_log, tmp_path):
    path, _, _ = adds_log
    d_main = 2.0  # m: area pi
    r = identify_descent(
        _plan(path, main=Canopy(diameter=d_main, cd=6.0 / math.pi), trials=64), tmp_path
    )
    p = r.phase("main")
    assert p.stated_cds == pytest.approx(6.0)
    assert p.cd == pytest.approx(p.cds / math.pi)
    lo, hi = p.to_dict()["pareto"]
    assert lo == pytest.approx(p.cds_pareto[0] / math.pi)


def test_a_main_that_did_not_open_is_said_so(tmp_path):
    path = tmp_path / "streamer.csv"
    synthetic_log(path, opens=False, seed=3)
    r = identify_descent(_plan(path, convention="replaces"), tmp_path / "out")
    p = r.phase("main")
    assert "did not open" in p.verdict
    story_is_one(r)  # each number of each phase's story once
    # the drogue's drag area, under the "main" (6 s of window: a range, maybe not a value)
    assert p.compared_cds == pytest.approx(0.5, rel=0.05)
    lo, hi = p.cds_feasible
    assert lo <= 0.5 <= hi


def test_a_stated_drag_area_the_descent_does_not_fit_is_said_so(adds_log, tmp_path):
    path, _, _ = adds_log
    # 256 trials: with 64, D holds too few members for a value (a thin set, at best "weak")
    r = identify_descent(_plan(path, drogue=Canopy(cds=0.3), trials=256), tmp_path)
    p = r.phase("drogue")
    assert p.cds == pytest.approx(0.5, rel=0.05)
    assert "does not fit the stated drag area" in p.verdict
    assert p.stated_alt_rms_m > p.limits.alt_rms
    story_is_one(r)


def test_one_canopy_from_apogee_in_feet(tmp_path):
    path = tmp_path / "feet.csv"
    synthetic_log(path, trigger=1199.0, lag=0.0, convention="replaces", feet=True, seed=5)
    r = identify_descent(
        _plan(
            path,
            mapping={
                "time": "t_s",
                "time_unit": "s",
                "altitude": {"column": "alt_ft", "unit": "ft"},
            },
            drogue=None,
            main=Canopy(cds=6.0),
            convention=None,
            main_at=None,
            main_settle=8.0,
            trials=256,
        ),
        tmp_path / "out",
    )
    assert [p.name for p in r.phases] == ["main"]
    assert r.phase("main").cds == pytest.approx(6.0, rel=0.05)


def test_a_log_that_ends_in_the_air_uses_it_to_the_end(adds_log, tmp_path):
    path, td, _ = adds_log
    r = identify_descent(_plan(path, end=td - 5.0, trials=64), tmp_path)
    assert r.touchdown is None
    # the window ends 1 s before the last sample: the end of the data decides nothing
    assert r.phase("main").window[1] == pytest.approx(td - 6.0, abs=0.06)
    assert "no touchdown" in r.format_text()


def test_discrepancy_allowance_grows_with_the_phase():
    assert discrepancy(1000.0, 20.0, allowance=3.0, allowance_fraction=0.0) == (3.0, 3.0)
    d_h, d_v = discrepancy(1000.0, 20.0)
    assert d_h == pytest.approx(3.0 + 5.0) and d_v == pytest.approx(1.0 + 2.0)


def test_limits_come_from_the_noise_floor_machinery(adds_result):
    """Each phase's criteria constraints are the study's noise floors (estimated altitude
    noise) plus the stated allowance, saved with their source in the phase's store."""
    from vectorid.store import Store

    for p in adds_result.phases:
        lim = p.limits
        assert p.noise_sigma_m == pytest.approx(0.5, rel=0.1)  # the log's white noise
        assert "estimated" in p.noise
        d_h, d_v = discrepancy(p.altitude_loss, p.descent_rate)
        assert lim.allowance_alt == pytest.approx(d_h) and lim.allowance_vz == pytest.approx(d_v)
        # the altitude floor of a 0.5 m white noise is about 0.5 m RMS
        assert 0.3 < lim.floor_alt_rms < 1.0
        assert lim.alt_rms == pytest.approx(lim.floor_alt_rms + d_h)
        assert {c["limit_source"] for c in lim.criteria} == {"noise"}
        assert "noise floor" in lim.source and "discrepancy altitude" in lim.source
        with Store.open(p.store) as st:
            held = {c.name: c for c in st.spec.criteria}
        for c in lim.criteria:
            assert held[c["name"]].source == "noise"
            assert held[c["name"]].limit == pytest.approx(c["limit"])
        # the verdict is the shared identifiability's
        assert p.identifiability["verdict"] == p.status == "identified"
        assert p.identifiability["feasible"] == pytest.approx(list(p.cds_feasible))


def test_parse_length():
    assert parse_length("24in", "d") == pytest.approx(0.6096)
    assert parse_length("550 ft", "d") == pytest.approx(167.64)
    assert parse_length("24 inches", "d") == pytest.approx(0.6096)
    with pytest.raises(StudyDefinitionError, match="inches, or metres"):
        parse_length("0.61", "d")  # a length needs its unit
    with pytest.raises(StudyDefinitionError, match="24in, 0.61m or 550ft"):
        parse_length("24 parsec", "d")


@pytest.mark.parametrize(
    ("kw", "match"),
    [
        ({"convention": None}, "convention: with two parachutes"),
        ({"drogue": None, "main": None}, "no parachute stated"),
        ({"mass": -1.0}, "mass"),
        ({"pad_altitude": None}, "pad_altitude"),
        ({"main_at": None}, "no 'main' event"),
        ({"windows": {"drogue": [5.0]}}, "expected \\[start, end\\]"),
        ({"main_at": "300"}, "a height or a time"),
    ],
)
def test_plans_that_cannot_run_say_why(adds_log, tmp_path, kw, match):
    path, _, _ = adds_log
    with pytest.raises(StudyDefinitionError, match=match):
        identify_descent(_plan(path, trials=32, **kw), tmp_path)


def test_a_log_without_the_altitude_column_says_which(adds_log, tmp_path):
    path, _, _ = adds_log
    with pytest.raises(FlightDataError, match="'alt'.*alt_m"):
        identify_descent(
            _plan(
                path,
                mapping={
                    "time": "t_s",
                    "time_unit": "s",
                    "altitude": {"column": "alt", "unit": "m"},
                },
            ),
            tmp_path,
        )


# -- the verb -----------------------------------------------------------------------------------


def _cli(capsys, *args):
    code = main(["descent", *map(str, args)])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_verb_json(adds_log, tmp_path, capsys):
    path, td, _ = adds_log
    code, out, err = _cli(
        capsys, path, "--columns", "time=t_s,altitude=alt_m", "--mass", MASS,
        "--drogue-cds", 0.5, "--main-diameter", "2m", "--main-cd", 6.0 / math.pi,
        "--convention", "adds", "--main-at", "300m", "--main-lag", 1, "--pad-altitude", PAD,
        "--trials", 64, "--out", tmp_path, "--json",
    )  # fmt: skip
    assert code == 0, err
    d = json.loads(out)
    assert [p["name"] for p in d["phases"]] == ["drogue", "main"]
    main_ = d["phases"][1]
    assert main_["cd"] == pytest.approx(6.0 / math.pi, rel=0.05)
    assert main_["pareto"][0] <= main_["cd"] <= main_["pareto"][1]
    assert d["touchdown"]["time_s"] == pytest.approx(td, abs=0.3)
    assert (tmp_path / f"{path.stem}-main.db").exists()


def test_verb_stated_noise_and_data_start(adds_log, tmp_path, capsys):
    path, _, _ = adds_log
    code, out, err = _cli(
        capsys, path, "--columns", "time=t_s,altitude=alt_m", "--mass", MASS,
        "--drogue-cds", 0.5, "--pad-altitude", PAD, "--trials", 64, "--out", tmp_path,
        "--drogue-window", "apogee+5", "apogee+40", "--noise", 0.5, "--initial-speed", "data",
        "--json",
    )  # fmt: skip
    assert code == 0, err
    p = json.loads(out)["phases"][0]
    assert p["noise_sigma_m"] == 0.5 and p["noise"].startswith("stated")
    assert p["limits"]["criteria"][0]["limit_source"] == "noise"


def test_verb_text_has_units(adds_log, tmp_path, capsys):
    path, _, _ = adds_log
    code, out, err = _cli(
        capsys, path, "--columns", "time=t_s,altitude=alt_m", "--mass", MASS,
        "--drogue-cds", 0.5, "--pad-altitude", PAD, "--trials", 32, "--out", tmp_path,
        "--drogue-window", "apogee+5", "main_trigger-1", "--main-cds", 6, "--main-at", "300m",
        "--convention", "adds",
    )  # fmt: skip
    assert code == 0, err
    assert "C_D S = " in out and " m²" in out and "altitude RMS" in out and "touchdown at" in out


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["nope.csv", "--mass", 3, "--drogue-cds", 1], "no such file"),
        (["LOG", "--mass", 3, "--drogue-cds", 1, "--columns", "t=t_s"], "--columns"),
        (["LOG", "--mass", 3, "--drogue-cds", 1, "--columns", "time=t_s,altitude=h"], "'h'"),
        (["LOG", "--mass", 3, "--drogue-cds", 1, "--main-cds", 5, "--columns",
          "time=t_s,altitude=alt_m", "--pad-altitude", 0], "convention"),
        (["LOG", "--mass", 3, "--drogue-diameter", "24 parsec", "--columns",
          "time=t_s,altitude=alt_m", "--pad-altitude", 0], "--drogue-diameter"),
        (["LOG", "--mass", 3, "--drogue-cd", 1.5, "--columns", "time=t_s,altitude=alt_m"],
         "--drogue-cd"),
        (["LOG", "--mass", 3, "--drogue-cds", 1, "--columns", "time=t_s,altitude=alt_m",
          "--pad-altitude", 0, "--noise", "loud"], "--noise"),
        (["LOG", "--mass", 3, "--drogue-cds", 1, "--columns", "time=t_s,altitude=alt_m",
          "--pad-altitude", 0, "--box-factor", 50], "box_factor"),
    ],
)  # fmt: skip
def test_verb_bad_input_is_one_line_and_exit_2(adds_log, tmp_path, capsys, args, match):
    path, _, _ = adds_log
    args = [str(path) if a == "LOG" else a for a in args]
    code, out, err = _cli(capsys, *args, "--out", tmp_path)
    assert code == 2
    assert match in err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_verb_bad_number_is_an_argparse_error(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["descent", "x.csv", "--mass", "heavy"])
    assert exc.value.code == 2
    assert "expected a number" in capsys.readouterr().err
