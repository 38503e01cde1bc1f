"""`vectorid demo parafoil`: seed 000's workflow on the embedded parafoil drop, reduced size."""

from __future__ import annotations

import importlib.util
import json
import tomllib
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from vectorid.cli import main
from vectorid.demo_parafoil import DEMO_DATA, chosen_values, stage_toml
from vectorid.space import Continuous, Space
from vectorid.spec import load_study

ROOT = Path(__file__).resolve().parents[1]


def test_parafoil_demo_end_to_end_reduced(tmp_path, capsys):
    out = tmp_path / "demo"
    code = main(["demo", "parafoil", "--out", str(out), "--trials", "256", "--quiet"])
    text = capsys.readouterr().out
    assert code == 0
    for needle in (
        "Stage 1: delcon, CLalpha, CD0, Rig, CnDanom, Cnr",
        "double tuning: box after the coarse run",
        "Stage 2: all 33 gains (256 trials)",
        "Quasi-optimal sets (seed 000 Fig. 12)",
        "Correlation and sensitivity over stage 2 (seed 000 Fig. 14)",
        "reduced set:",
        "Stage 3: the reduced set",
        "is the fit kept?",
        "6-DoF model, the reduced set",
        "spectral peaks of the payload rates",
        "truth in D-range",
        "c33 kC_star",  # the parameter legend with units and meanings
        "[  m·s] pure",  # the criteria legend with units
    ):
        assert needle in text, needle
    # Fig. 12: one row per gain, then the cost row
    rows = [ln.split() for ln in text.splitlines() if ln[:6].strip().isdigit()]
    assert [int(r[0]) for r in rows[:33]] == list(range(1, 34))
    cost = next(ln for ln in text.splitlines() if ln.strip().startswith("cost "))
    assert len(cost.split()) == 1 + 2 + 5 + 1  # label, Set 0, Set 1, five sets, truth
    for name in ("stage1", "stage2", "stage3", "6dof"):
        assert (out / f"parafoil-{name}.db").exists() and (out / f"parafoil-{name}.toml").exists()
        assert (out / f"parafoil-{name}.html").exists()
    spec3 = load_study(out / "parafoil-stage3.toml")
    assert 0 < len(spec3.space.names) < 33  # the reduced set
    fixed = spec3.extra["identification"].get("parameters", {})
    assert set(fixed).isdisjoint(spec3.space.names) and len(fixed) + len(spec3.space.names) == 33
    assert main(["pareto", str(out / "parafoil-stage2.db"), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["n"] == 256 and {c["name"] for c in doc["criteria"]} >= {"pos_h", "peak_yaw"}


def test_stage_files_are_valid_and_carry_the_criteria():
    truth = json.loads((DEMO_DATA / "truth.json").read_text(encoding="utf-8"))
    text = stage_toml("s", [("CD0", 0.2, 2.0)], truth=truth, trials=8, fixed={"Clp": 1.3})
    doc = tomllib.loads(text)
    ident = doc["identification"]
    assert ident["model_options"]["attitude"] == "payload" and ident["parameters"] == {"Clp": 1.3}
    assert ident["criteria"]["peak_yaw"]["use"] == "peak_yaw@0.25-1.5"
    limits = {c["name"]: c.get("limit") for c in doc["criteria"]}
    assert limits["peak_yaw"] == 0.05 and limits["pos_h"] is None
    six = tomllib.loads(stage_toml("s", [("CD0", 0.2, 2.0)], truth=truth, trials=8,
                                   model="parafoil6dof", limits=False))  # fmt: skip
    assert "model_options" not in six["identification"]
    assert all("limit" not in c for c in six["criteria"])


def test_embedded_data_are_the_seeded_generators_output(tmp_path):
    spec = importlib.util.spec_from_file_location(
        "make_parafoil_demo_data", ROOT / "scripts" / "make_parafoil_demo_data.py"
    )
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    gen.OUT = tmp_path
    gen.main()
    for f in sorted(DEMO_DATA.iterdir()):
        assert (tmp_path / f.name).read_bytes() == f.read_bytes(), f.name
    # the data are what the README says: GPS at 4 Hz, IMU at 50 Hz
    gps = np.genfromtxt(DEMO_DATA / "gps.csv", delimiter=",", names=True)
    imu = np.genfromtxt(DEMO_DATA / "imu.csv", delimiter=",", names=True)
    assert np.median(np.diff(gps["time_s"])) == pytest.approx(0.25)
    assert np.median(np.diff(imu["time_s"])) == pytest.approx(0.02)


def test_chosen_values_print_a_range_where_the_data_do_not_pin_it():
    space = Space([Continuous("a", 0.0, 1.0), Continuous("b", 0.0, 1.0)])
    rng = np.random.default_rng(0)
    X = np.column_stack([rng.uniform(0, 1, 200), 0.5 + 0.05 * rng.uniform(-1, 1, 200)])
    feasible = np.ones(200, bool)
    pareto = np.zeros(200, bool)
    pareto[:5] = True
    a = SimpleNamespace(spec=SimpleNamespace(space=space), trials=SimpleNamespace(X=X),
                        feasible=feasible, pareto=pareto)  # fmt: skip
    rows = {r.name: r for r in chosen_values(a, {"a": 0.3, "b": 0.5})}
    assert rows["a"].verdict == "wide" and rows["b"].verdict == "narrow"
    assert rows["b"].feasible[0] >= 0.45 and rows["b"].feasible[1] <= 0.55
    # measured against a wider a-priori box, "a" is pinned too
    rows = {r.name: r for r in chosen_values(a, {"a": 0.3}, boxes={"a": (-10.0, 10.0)})}
    assert rows["a"].verdict == "narrow" and rows["a"].spread == pytest.approx(0.05, abs=0.01)
