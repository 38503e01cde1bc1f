"""`vectorid init own-model`: the starting point of docs/own-model.md (the tutorial itself
runs in tests/test_docs.py, truth check included)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.test_docs import ROOT, blocks
from vectorid import load_study
from vectorid.cli import main
from vectorid.demos.own_model import NOISE, TRUTH


def test_init_writes_a_study_that_loads_and_a_record_with_its_truth(tmp_path, capsys):
    out = tmp_path / "own"
    assert main(["init", "own-model", "--out", str(out), "--trials", "512"]) == 0
    said = capsys.readouterr().out
    assert "wrote" in said and f"run {out / 'study.toml'}" in said
    spec = load_study(out / "study.toml")
    assert spec.trials == 512 and spec.space.names == ["m", "c", "k"]
    lines = (out / "run1.csv").read_text(encoding="utf-8").splitlines()
    assert "m = 1.2, c = 0.8, k = 42" in lines[0] and "x 2 mm, a 0.2 m/s^2" in lines[1]
    t, x_mm, a = np.loadtxt(out / "run1.csv", delimiter=",", skiprows=3, unpack=True)
    assert t[0] == 0.0 and t[-1] == pytest.approx(6.0) and len(t) == 61
    # the stated noise is the noise: the record minus the model at the truth
    import sys

    sys.path.insert(0, str(out))
    try:
        from msd.dynamics import MassSpringDamper
    finally:
        sys.path.remove(str(out))
        for name in ("msd", "msd.dynamics"):
            sys.modules.pop(name, None)
    res = MassSpringDamper().simulate(
        [[TRUTH[n] for n in "mck"]], t_final=6.0, dt=0.001, output_dt=0.1, initial={"x": 0.02}
    )
    assert np.std(x_mm / 1e3 - res["x"][0]) == pytest.approx(NOISE["x"], rel=0.3)
    assert np.std(a - res["a"][0]) == pytest.approx(NOISE["a"], rel=0.3)
    assert main(["init", "own-model", "--out", str(out)]) == 2  # nothing is overwritten
    assert "exists and is not an empty folder" in capsys.readouterr().err


def test_the_tutorial_shows_the_files_init_writes():
    """docs/own-model.md shows (and writes) the model, the numba model and the study file:
    they must be the ones `init own-model` writes."""
    shown = {
        b.directives["file"]: b.text
        for b in blocks(ROOT / "docs" / "own-model.md")
        if "file" in b.directives
    }
    template = Path(ROOT / "src" / "vectorid" / "data" / "own_model")
    for name in ("msd/dynamics.py", "msd/fast.py", "study.toml"):
        assert shown[f"own-model/{name}"] == (template / name).read_text(encoding="utf-8"), name
