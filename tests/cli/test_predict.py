"""``vectorid predict``: JSON, figures, and bad input (one line, exit 2, nothing written to the
store), an empty D and the nearest generation only when named."""

from __future__ import annotations

import hashlib
import json

import pytest

from tests.workflows.predict_helpers import LIMIT, drop_file, kinematic_store, planned
from vectorid.cli import main
from vectorid.study import Study
from vectorid.workflows.predict import EmptySetError, members_of


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    return kinematic_store(tmp_path_factory.mktemp("kinematic"))


def _digest(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _cli(capsys, *args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def _refused(code: int, err: str, needle: str) -> bool:
    """Exit 2 with one line on stderr that names the problem, and no traceback."""
    return (
        code == 2
        and needle in err
        and err.startswith("error: ")
        and err.count("\n") == 1
        and "Traceback" not in err
    )


def test_cli_prints_json_and_writes_figures(store, tmp_path, capsys):
    f = drop_file(tmp_path / "next.toml", [planned(noise={"position_h": 2.0})])
    code, out, err = _cli(capsys, "predict", store, f, "--members", 100, "--json", "--out",
                          tmp_path / "out")  # fmt: skip
    assert code == 0, err
    doc = json.loads(out)
    assert doc["members"] == 100 and doc["drops"][0]["landing"]["r95_m"] > 0
    assert (tmp_path / "out" / "prediction.json").exists()
    page = (tmp_path / "out" / "prediction.html").read_text(encoding="utf-8")
    assert "credible band 5-95 %" in page and "with-noise band 5-95 %" in page
    assert "R95" in page and "holds" in page
    code, out, _ = _cli(capsys, "predict", store, f, "--members", 50)
    assert code == 0 and "R50" in out and "credible" in out and "with-noise" in out
    assert "prediction interval" in out  # said of the credible band: it is NOT one


BAD = [
    (planned(speed=3.0), "unknown key 'speed'"),
    (planned(channels={"airspeed": 2.0, "pressure": 2.0}), "no channel 'pressure'"),
    (planned(height=-50.0), "below the ground"),
    (planned(channels={"position": 3.0}), "not a whole number"),
    ({**planned(), "origin_altitude": None}, "needs its origin or its ground"),
    (planned(parameters={"vn": 1.0}), "design variable"),
    (planned(controls={"time": [0.0], "flap": [1.0]}), "not an input"),
]


@pytest.mark.parametrize("drop, needle", BAD)
def test_bad_drops_say_one_line_exit_2_and_write_nothing(store, tmp_path, capsys, drop, needle):
    drop = {k: v for k, v in drop.items() if v is not None}
    f = drop_file(tmp_path / "bad.toml", [drop])
    before = _digest(store)
    code, out, err = _cli(capsys, "predict", store, f, "--out", tmp_path / "out")
    assert _refused(code, err, needle), err
    assert _digest(store) == before and not (tmp_path / "out").exists()


def test_a_store_of_another_model_or_no_flight_model(store, tmp_path, capsys, user_study):
    f = drop_file(tmp_path / "p.toml", [planned()], model="parachute6dof")
    before = _digest(store)
    code, _, err = _cli(capsys, "predict", store, f, "--out", tmp_path / "out")
    assert _refused(code, err, "the store identifies"), err
    assert _digest(store) == before and not (tmp_path / "out").exists()
    other = tmp_path / "user.db"
    assert (
        _cli(capsys, "run", user_study, "--store", other, "--executor", "inline", "--quiet")[0] == 0
    )
    capsys.readouterr()
    before = _digest(other)
    code, _, err = _cli(capsys, "predict", other, drop_file(tmp_path / "q.toml", [planned()]),
                        "--out", tmp_path / "out")  # fmt: skip
    assert _refused(code, err, "identifies no flight model"), err
    assert _digest(other) == before and not (tmp_path / "out").exists()


def test_an_empty_d_says_so(store, tmp_path, capsys):
    f = drop_file(tmp_path / "p.toml", [planned()])
    before = _digest(store)
    code, _, err = _cli(capsys, "predict", store, f, "--limit", "pos_h_abs<=-1", "--out",
                        tmp_path / "out")  # fmt: skip
    assert _refused(code, err, "D is empty") and "nearest generation" not in err, err
    assert _digest(store) == before and not (tmp_path / "out").exists()
    with pytest.raises(EmptySetError):
        members_of(store, limits={"pos_h_abs": -1.0})


def test_nearest_generation_only_when_named(tmp_path, capsys):
    """A sequential study stopped before it reached D: the error offers the nearest generation,
    which is flown only when asked, and named as not D in every output."""
    store = kinematic_store(tmp_path, trials=64, sampler="sequential", budget=200,
                            population=100, limit=LIMIT / 1e5)  # fmt: skip
    with Study.open(store) as st:
        assert st.analysis().n_feasible == 0
    f = drop_file(tmp_path / "p.toml", [planned()])
    before = _digest(store)
    code, _, err = _cli(capsys, "predict", store, f, "--out", tmp_path / "out")
    assert _refused(code, err, "D is empty") and "--nearest-generation" in err, err
    assert _digest(store) == before and not (tmp_path / "out").exists()
    code, out, err = _cli(capsys, "predict", store, f, "--nearest-generation", "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert doc["set"]["is_d"] is False and "NOT D" in doc["set"]["set"]
    code, out, _ = _cli(capsys, "predict", store, f, "--nearest-generation")
    assert "NOT D" in out.splitlines()[0] and "NOTE: these members are" in out


def test_the_report_takes_the_predictions(store, tmp_path, capsys):
    f = drop_file(tmp_path / "next.toml", [planned(noise={"position_h": 2.0})])
    out = tmp_path / "r.html"
    code, _, err = _cli(capsys, "report", store, "--predict", f, "--members", 40, "--out", out,
                        "--max-points", 200)  # fmt: skip
    assert code == 0, err
    page = out.read_text(encoding="utf-8")
    assert "Predictions" in page and "landing dispersion" in page
    code, _, err = _cli(capsys, "report", store, "--predict", tmp_path / "none.toml", "--out",
                        tmp_path / "r2.html")  # fmt: skip
    assert code == 2 and "no such drop file" in err and not (tmp_path / "r2.html").exists()
