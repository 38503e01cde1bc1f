"""Acceptance test: a real small parafoil's glide and turn-control gains from four flights at
once (shared ETH Zürich data), starting from the authors' stated parameter set."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data" / "eth-parafoil"


def _example(name: str):
    spec = importlib.util.spec_from_file_location(name, ROOT / "examples" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod  # the study names its model "eth_parafoil:evaluate"
    spec.loader.exec_module(mod)
    return mod


def test_stated_set_as_model_options_reproduces_the_stated_apparent_masses():
    eth = _example("eth_parafoil")
    from vectorid import models

    m = models.get("parafoil6dof", **eth.model_options())
    k = m.constants(m.nominal[None])[0]
    from vectorid.models.parafoil_aero import I_MAM

    am = k[I_MAM : I_MAM + 36].reshape(6, 6)
    # translational diagonal = README's diag(Im) = 0.00789, 0.0690, 0.692 m^3 (no rigging)
    assert np.diag(am)[:3] == pytest.approx([0.00789, 0.0690, 0.692], rel=2e-3)
    assert m.coefficients["CLalpha"] == pytest.approx(2.14 / np.degrees(1.0))
    assert m.geometry.canopy_mass + m.geometry.payload_mass == pytest.approx(1.2)


@pytest.mark.slow
@pytest.mark.skipif(not (DATA / "flight1_states.csv").exists(), reason=f"no data at {DATA}")
def test_eth_flights_glide_and_turn_control(tmp_path):
    eth = _example("eth_parafoil")
    r = eth.identify(DATA, tmp_path, trials=512, budget=3000)
    a = r["step"].analysis
    assert 512 <= a.n <= 3000 and a.n_pareto >= 1
    # the sequential sampler says how far it got; where no trial met the limits, a local
    # search from the best trials says by how much the model misses them
    seq = r["stage"].sequential
    assert seq is not None and seq.evaluations == a.n
    if seq.members == 0:
        assert seq.search is not None and seq.search.factor > 0
    calm, wind, ident = (r[k] for k in ("rms_stated_calm", "rms_stated_wind", "rms_identified"))
    assert set(calm) == set(eth.FLIGHTS)
    for table in (calm, wind, ident):
        assert all(np.isfinite(v) and v >= 0 for v in table.values())
    # each flight's own wind explains much of the stated model's miss; identifying the gains
    # as well fits the four flights together better than the stated gains in calm air
    assert np.mean(list(wind.values())) < np.mean(list(calm.values()))
    assert np.mean(list(ident.values())) < np.mean(list(calm.values()))
    # every gain's chosen value lies in its feasible range, which the printout gives
    for g in r["gains"]:
        j = a.spec.space.names.index(g)
        col = a.trials.X[a.feasible, j]
        assert col.min() <= r["step"].chosen[g] <= col.max()
    # the limits are noise-grounded (estimated GNSS noise + the authors' gust model); where D
    # under them is too small, the relaxation is a stand-in saved as such, never silent
    st = r["stage"]
    assert set(st.noise_limits) == {"pos_h", "pos_v"}
    assert all(note.startswith("noise floor") for note in st.noise_notes.values())
    assert all(0 < r["allowance"][f]["position_h"] < 10 for f in eth.FLIGHTS)
    src = {k: v[0] for k, v in r["step"].sources.items()}
    if st.factor > 1:  # only where the sampler did not converge: the named last resort
        assert not seq.converged
        assert set(src.values()) == {"quantile"} and a.n_feasible >= 50
        assert all("last resort" in n for _, n in r["step"].sources.values())
        assert all(f"x {st.factor:g}" in n for _, n in r["step"].sources.values())
    else:
        assert set(src.values()) == {"noise"}
    # verdicts for every design variable, a value printed only for identified ones
    assert [v.name for v in r["step"].verdicts] == a.spec.space.names


@pytest.mark.long
@pytest.mark.slow
def test_eth_flights_reach_the_physical_floor_not_a_misfit(tmp_path_factory):
    """Issue 22 on the real flights, as docs/identification.md runs them (its slow block, run
    once per session and shared with tests/test_docs.py): D at the stated limits is not reached
    within physical gains, but the sampler's nearest generation and the local search come within
    a few per cent of the limits, pressed against Cnr's physical floor, so the run says the box
    may be too narrow there and never that the model or the limits do not fit. (A faster
    tightening stalled at x1.11-x1.33 inside the box and said the model may not fit.)"""
    import re

    from tests.test_docs import SLOW_BLOCKS, run_slow_block

    found = [b for b in SLOW_BLOCKS if b.path.name == "identification.md"
             and "examples/eth_parafoil.py" in b.text]  # fmt: skip
    assert len(found) == 1, [b.where for b in found]
    _, text = run_slow_block(found[0], tmp_path_factory)
    line = next(ln for ln in text.splitlines() if "sequential sampler:" in ln)
    assert "may not fit" not in text and "do not fit" not in text, line
    if "D reached" not in line:
        nearest = float(re.search(r"nearest generation meets the limits relaxed ×([\d.]+)", line)
                        .group(1))  # fmt: skip
        assert nearest <= 1.05, line
        assert "pressed against the box" in line and "Cnr" in line, line


@pytest.mark.long
@pytest.mark.slow
@pytest.mark.skipif(not (DATA / "flight1_states.csv").exists(), reason=f"no data at {DATA}")
def test_a_held_out_flight_is_predicted_with_the_json_of_vectorid_predict(tmp_path, capsys):
    """--predict K: identified from the other flights, flight K predicted with its wind drawn
    from theirs; --json prints exactly the document of vectorid predict on the written files."""
    import json

    from vectorid.cli import main

    eth = _example("eth_parafoil")
    code = eth.main([str(DATA), "--predict", "3", "--trials", "256", "--budget", "1500",
                     "--members", "60", "--json", "--out", str(tmp_path)])  # fmt: skip
    out = capsys.readouterr().out
    assert code == 0
    doc = json.loads(out)
    (drop,) = doc["drops"]
    assert drop["name"] == "flight3" and [c["name"] for c in drop["channels"]] == ["position"]
    assert "drawn at random" in drop["parameters"] and drop["landing"]["kind"] == "end of window"
    assert isinstance(drop["within"], bool) and drop["verdict"]
    store = tmp_path / "eth-without-flight3.db"
    assert main(["predict", str(store), str(tmp_path / "flight3.toml"), "--members", "60",
                 "--seed", "3", "--json"]) == 0  # fmt: skip
    again = json.loads(capsys.readouterr().out)
    assert again["drops"][0]["channels"] == drop["channels"]
