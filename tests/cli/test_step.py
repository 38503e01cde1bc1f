"""``vectorid step``: the integration step an identification study needs."""

from __future__ import annotations

import itertools
import json
import shutil

import pytest

from vectorid.cli import main
from vectorid.demos.g12 import DEMO_DATA, identification_toml


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """The demo's step-2 study (the controlled drop: riser steps) next to the embedded data."""
    folder = tmp_path_factory.mktemp("step")
    shutil.copytree(DEMO_DATA, folder / "data")
    truth = json.loads((DEMO_DATA / "truth.json").read_text(encoding="utf-8"))
    path = folder / "g12-step2.toml"
    path.write_text(identification_toml(2, trials=64, truth=truth), encoding="utf-8")
    return path


@pytest.mark.slow  # minutes: a study per drop (CI runs the slow suite too)
def test_step_prints_errors_per_drop_and_a_recommendation(study, capsys):
    assert main(["step", str(study), "--trials", "2", "--tolerance", "0.05", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["tolerance_m"] == 0.05 and out["study_dt_s"] > 0
    (drop,) = out["drops"]
    errors = {float(k): v for k, v in drop["errors_m"].items()}
    assert out["study_dt_s"] in errors  # the study's own step is measured too
    steps = sorted(errors, reverse=True)
    assert all(errors[a] >= errors[b] * 0.9 for a, b in itertools.pairwise(steps))
    assert drop["trials"] + drop["failed_in_reference"] == 3  # nominal + 2 Sobol vectors
    assert drop["trials"] >= 1
    dt = out["recommended_dt_s"]
    assert dt == drop["dt_s"] and errors[dt] <= 0.05
    assert all(errors[s] > 0.05 for s in steps if s > dt)
    assert main(["step", str(study), "--trials", "2"]) == 0
    text = capsys.readouterr().out
    assert "recommended: dt = " in text and "the study's dt = " in text and " m " in text


def test_step_refuses_bad_input_in_one_line(study, tmp_path, capsys):
    assert main(["step", str(study), "--tolerance", "-1"]) == 2
    err = capsys.readouterr().err.strip()
    assert "tolerance" in err and len(err.splitlines()) == 1
    assert main(["step", str(tmp_path / "missing.toml")]) == 2
    assert "missing.toml" in capsys.readouterr().err
