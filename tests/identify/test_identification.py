"""Identification → Problem: study-file format, twin experiment, errors, drop-outs, winds."""

from __future__ import annotations

import numpy as np
import pytest

from vectorid.descent import RocketDescent
from vectorid.errors import StudyDefinitionError
from vectorid.identify import Identification
from vectorid.models import ControlSchedule, InitialState
from vectorid.spec import StudySpec
from vectorid.study import Study

TRUTH = {"cd_drogue": 1.7, "cd_main": 2.6}
ORIGIN = 1300.0


def _write_phase(path, main: float, h0: float, seconds: float, seed: int) -> None:
    """Twin data: the model itself with TRUTH, barometric altitude at 10 Hz with 0.5 m noise."""
    m = RocketDescent()
    x = np.array([[TRUTH["cd_drogue"], TRUTH["cd_main"]]])
    res = m.simulate(
        x,
        t_final=seconds,
        dt=0.01,
        output_dt=0.1,
        initial=InitialState(altitude=ORIGIN + h0),
        inputs=ControlSchedule.constant(["main"], [main]),
    )
    rng = np.random.default_rng(seed)
    h = -res.position[0, :, 2] - ORIGIN + rng.normal(0.0, 0.5, res.t.size)
    lines = ["t,height"] + [f"{t:.2f},{v:.3f}" for t, v in zip(res.t, h)]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def _study(tmp_path, *, extra=None, criteria=None, constraints=None, trials=256) -> StudySpec:
    _write_phase(tmp_path / "drogue.csv", 0.0, 2500.0, 60.0, 1)
    _write_phase(tmp_path / "main.csv", 1.0, 400.0, 40.0, 2)
    mapping = {"time": "t", "time_unit": "s", "altitude": {"column": "height", "unit": "m"}}
    drops = [
        {"name": n, "file": f"{n}.csv", "mapping": mapping, "window": [1.0, s],
         "inputs": {"main": u}, "origin_altitude": ORIGIN}
        for n, u, s in (("drogue", 0.0, 55.0), ("main", 1.0, 35.0))
    ]  # fmt: skip
    ident = {
        "dt": 0.05,
        "output_dt": 0.5,
        "drops": drops,
        "criteria": {
            "alt_drogue": {"use": "alt_abs", "drops": ["drogue"]},
            "vz_drogue": {"use": "vz_abs", "drops": ["drogue"]},
            "alt_main": {"use": "alt_abs", "drops": ["main"]},
        },
    }
    ident.update(extra or {})
    data = {
        "study": {"name": "twin", "model": "rocket-descent", "trials": trials, "seed": 1},
        "variables": [
            {"name": "cd_drogue", "low": 1.0, "high": 2.5},
            {"name": "cd_main", "low": 1.5, "high": 3.5},
        ],
        "criteria": criteria
        or [{"name": "alt_drogue"}, {"name": "vz_drogue", "role": "pseudo"}, {"name": "alt_main"}],
        "identification": ident,
    }
    if constraints:
        data["constraints"] = constraints
    return StudySpec.from_dict(data, base_dir=tmp_path)


def test_twin_experiment_recovers_drag_coefficients(tmp_path):
    spec = _study(tmp_path)
    with Study.create(spec, tmp_path / "twin.db") as st:
        st.run(trials=256, executor="serial")
        a = st.analysis()
        assert a.n == 256 and a.n_failed == 0
        F, X = a.trials.F, a.trials.X
        # stated tolerances: the best trial of each phase's altitude criterion within 3 %
        best_d = X[np.argmin(F[:, 0]), 0]
        best_m = X[np.argmin(F[:, 2]), 1]
        assert abs(best_d - TRUTH["cd_drogue"]) / TRUTH["cd_drogue"] < 0.03
        assert abs(best_m - TRUTH["cd_main"]) / TRUTH["cd_main"] < 0.03
        # the truth lies inside the feasible set under criteria constraints at the 10 % quantile
        ident = Identification.from_spec(spec)
        f_true, _ = ident.evaluate(np.array([[TRUTH["cd_drogue"], TRUTH["cd_main"]]]))
        q = np.quantile(F, 0.1, axis=0)
        assert np.all(f_true[0] <= q)
        # and the Pareto set of the pure criteria brackets it
        P = X[a.pareto]
        assert (
            P[:, 0].min() <= TRUTH["cd_drogue"] * 1.03
            and P[:, 0].max() >= TRUTH["cd_drogue"] * 0.97
        )


def test_simulate_gives_positions_relative_to_the_drops_origin(tmp_path):
    """What a user sees: the truth's simulated altitude lies on the measured one (0.5 m noise),
    not ~1300 m away (the origin's altitude above sea level); the model's own frame on demand."""
    ident = Identification.from_spec(_study(tmp_path))
    d = ident.drop("drogue")
    x = np.array([[TRUTH["cd_drogue"], TRUTH["cd_main"]]])
    res = ident.simulate(x, d)
    assert res.origin_altitude == ORIGIN
    meas = d.measured("altitude")[:, 0]
    assert np.sqrt(np.mean((-res.position[0, :, 2] - meas) ** 2)) < 1.0
    sea = ident.simulate(x, d, frame="sea level")
    assert sea.origin_altitude == 0.0
    np.testing.assert_allclose(sea.position[0, :, 2] + ORIGIN, res.position[0, :, 2])
    with pytest.raises(StudyDefinitionError, match="frame"):
        ident.simulate(x, d, frame="ground")


def test_problem_from_spec_is_what_the_study_runs(tmp_path):
    spec = _study(tmp_path)
    prob = spec.problem()
    res = prob.evaluate(np.array([[1.7, 2.6], [1.2, 3.0]]))
    assert res.criteria.shape == (2, 3) and np.all(res.status == 0)
    assert res.criteria[0, 0] < res.criteria[1, 0]  # truth closer on the drogue phase


def test_dropout_constraint_separates_truth_from_far_vector(tmp_path):
    spec = _study(
        tmp_path,
        extra={"dropout": {"out_alt": {"channel": "altitude", "band": 15.0}}},
        constraints=[{"name": "out_alt", "high": 0.0}],
    )
    res = spec.problem().evaluate(np.array([[1.7, 2.6], [1.0, 1.5]]))
    assert res.functionals[0, 0] == 0.0
    assert res.functionals[1, 0] > 15.0


def test_wind_realisations_are_seeded_and_averaged(tmp_path):
    (tmp_path / "wind.csv").write_text(
        "altitude,speed,direction\n1000,3,270\n2000,8,280\n4000,12,290\n", encoding="utf-8"
    )
    extra = {
        "wind_realisations": 3,
        "seed": 5,
        "wind_uncertainty": {
            "sigma_speed": 1.0,
            "sigma_direction_deg": 10.0,
            "correlation_length_m": 300.0,
        },
    }
    spec = _study(tmp_path, extra=extra)
    table = spec.extra["identification"]
    for d in table["drops"]:
        d["wind"] = "wind.csv"
    a = Identification.from_spec(spec)
    b = Identification.from_spec(spec)
    X = np.array([[1.7, 2.6]])
    assert len(a.winds["drogue"]) == 3
    np.testing.assert_array_equal(a.evaluate(X)[0], b.evaluate(X)[0])
    assert np.all(np.isfinite(a.evaluate(X)[0]))


def test_wind_uncertainty_without_realisations_is_refused(tmp_path):
    spec = _study(tmp_path, extra={"wind_uncertainty": {"sigma_speed": 1.0}})
    with pytest.raises(StudyDefinitionError, match="wind_uncertainty.*wind_realisations = 1"):
        Identification.from_spec(spec)


@pytest.mark.parametrize(
    ("mutate", "needle"),
    [
        (lambda d: d["variables"][0].update(name="cd_drogeu"), "cd_drogue"),
        (lambda d: d["identification"]["criteria"]["alt_main"].update(use="alt_ab"), "alt_ab"),
        (lambda d: d["identification"]["drops"][0].update(file="nope.csv"), "not found"),
        (lambda d: d["identification"]["drops"][0].update(window=[1.0]), "[start, end]"),
        (lambda d: d["identification"].update(dtt=0.1), "dt"),
        (lambda d: d["identification"]["criteria"]["alt_main"].update(drops=["mian"]), "main"),
    ],
)
def test_bad_identification_tables_say_how_to_fix(tmp_path, mutate, needle):
    spec = _study(tmp_path)
    data = spec.to_dict()
    mutate(data)
    with pytest.raises(StudyDefinitionError) as err:
        StudySpec.from_dict(data, base_dir=tmp_path).problem()
    assert needle in str(err.value)


def test_constraint_without_dropout_definition_is_rejected(tmp_path):
    spec = _study(tmp_path, constraints=[{"name": "g1", "high": 0.0}])
    with pytest.raises(StudyDefinitionError, match="drop-out"):
        spec.problem()


def test_failed_simulation_is_a_failed_trial_not_an_error(tmp_path):
    spec = _study(tmp_path)
    res = spec.problem().evaluate(np.array([[-1.0, 2.6], [1.7, 2.6]]))
    assert res.status[0] != 0 and res.status[1] == 0


def _as_before_units_were_stated(store) -> None:
    """Rewrite the store's definition as a store made before mappings had to state units:
    no ``time_unit``, ``altitude`` as a bare column name (then read as s and m)."""
    import json
    import sqlite3
    import zlib

    con = sqlite3.connect(store)
    with con:
        data = json.loads(con.execute("SELECT value FROM meta WHERE key='study'").fetchone()[0])
        for d in data["identification"]["drops"]:
            m = d["mapping"]
            del m["time_unit"]
            m["altitude"] = m["altitude"]["column"]
        text = json.dumps(data)
        con.execute("UPDATE meta SET value=? WHERE key='study'", (text,))
        crc = f"{zlib.crc32(text.encode()):08x}"
        con.execute("UPDATE meta SET value=? WHERE key='study_checksum'", (crc,))
    con.close()


def test_a_store_made_before_units_were_stated_resumes_from_a_file_that_states_them(tmp_path):
    from vectorid.errors import StoreError, VectoridError, VectoridNote

    spec = _study(tmp_path, trials=8)
    store = tmp_path / "old.db"
    with Study.create(spec, store) as st:
        st.run(trials=4, executor="serial")
        before = st.analysis().trials.F
    _as_before_units_were_stated(store)
    # the stored definition alone no longer loads: the loader says which unit is missing
    with Study.open(store, write=True) as st:
        with pytest.raises(VectoridError, match=r"mapping\['altitude'\] \(column\(s\) 'height'"):
            st.run(trials=8, executor="serial")
    # the study file that states s and m (the units the trials were read in) is taken, the
    # definition in the store is updated, and the run goes on without repeating a trial
    with pytest.warns(VectoridNote, match="time_unit.*the unit the store's trials read"):
        st = Study.create_or_open(spec, store)
    with st:
        assert st.spec.to_dict()["identification"]["drops"][0]["mapping"]["time_unit"] == "s"
        st.run(trials=8, executor="serial")
        after = st.analysis().trials.F
    assert after.shape[0] == 8 and np.array_equal(after[:4], before)
    # a unit other than the one the trials were read in would change them: refused
    _as_before_units_were_stated(store)
    data = _study(tmp_path, trials=8).to_dict()
    for d in data["identification"]["drops"]:
        d["mapping"] = {**d["mapping"], "altitude": {"column": "height", "unit": "ft"}}
    with pytest.raises(StoreError, match="altitude.unit"):
        Study.create_or_open(StudySpec.from_dict(data, base_dir=tmp_path), store)
