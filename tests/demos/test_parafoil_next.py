"""`vectorid demo parafoil --next-drop`: the best planned drop flown on the twin, and the 33
gains identified again with both drops (vectorid.demos.parafoil_next)."""

from __future__ import annotations

import json
import re
import shutil
import tomllib
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from vectorid.cli import main
from vectorid.cli.main import _parser as build_parser
from vectorid.demos.parafoil import DEMO_DATA, DEMO_DISCREPANCY, _planned_drop_lines
from vectorid.demos.parafoil_next import (
    NEXT_DATA,
    _judged_span,
    _round_up,
    fly_plan,
    plan_allowance,
    plan_criteria,
    run_next_drop,
    two_drop_toml,
)

#: A short plan (20 s from 1000 m: a left flap step), the demo drop's sensors and noise.
CHANNELS = {"position": 4.0, "velocity": 4.0, "euler": 10.0, "rates": 10.0}
PROGRAM = ((0.0, 0.0, 0.0), (5.0, 0.5, 0.0), (15.0, 0.0, 0.0))


def _truth() -> dict:
    return json.loads((DEMO_DATA / "truth.json").read_text(encoding="utf-8"))


def _plan(folder: Path, name: str, duration: float, height: float | None = None) -> Path:
    from vectorid._toml import toml_value

    lines = _planned_drop_lines(_truth(), PROGRAM, duration,
                                f"channels = {toml_value(CHANNELS)}")  # fmt: skip
    if height is not None:  # a lower release: the payload reaches the ground in the record
        origin = _truth()["origin_altitude_m"]
        lines[0] = re.sub(r"altitude = [0-9.]+", f"altitude = {origin + height!r}", lines[0])
    text = "\n".join(["[identification]", 'model = "parafoil8dof"', "",
                      "[[identification.drops]]", f'name = "{name}"', *lines])  # fmt: skip
    p = folder / f"next-{name}.toml"
    p.write_text(text, encoding="utf-8")
    return p


@pytest.fixture(scope="module")
def flown(tmp_path_factory):
    """The demo's folder with its data, a short plan flown with noise and without (the same
    seed: the same gusts)."""
    out = tmp_path_factory.mktemp("next")
    shutil.copytree(DEMO_DATA, out / "data")
    plan = _plan(out, "step", 20.0)
    truth = _truth()
    noisy = fly_plan(plan, truth, out / NEXT_DATA, seed=7)
    exact = fly_plan(plan, truth, out / "exact", seed=7, noise=False)
    return SimpleNamespace(out=out, plan=plan, noisy=noisy, exact=exact)


def _csv(path: Path) -> tuple[list[str], np.ndarray]:
    head = path.read_text(encoding="utf-8").splitlines()[0].split(",")
    return head, np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


def test_the_flown_plan_is_recorded_at_its_channels_rates_and_noise(flown):
    f = flown.noisy
    assert f.name == "step" and f.channels == CHANNELS and f.landed is None
    assert f.span == pytest.approx(20.0)
    names = sorted(p.name for p in (flown.out / NEXT_DATA).iterdir())
    assert names == sorted([*(f"{c}.csv" for c in CHANNELS), "controls.csv", "flight.json"])
    info = json.loads((flown.out / NEXT_DATA / "flight.json").read_text(encoding="utf-8"))
    assert info["seed"] == 7 and info["actuator_lag_s"] == 0.8 and info["w20_ms"] == 2.0
    assert info["channels_hz"] == CHANNELS and info["landed_s"] is None
    for ch, hz in CHANNELS.items():
        head, a = _csv(flown.out / NEXT_DATA / f"{ch}.csv")
        assert head[0] == "time_s" and len(head) == 4
        assert np.allclose(np.diff(a[:, 0]), 1.0 / hz) and a.shape[0] == round(20 * hz) + 1
        assert f.samples[ch] == a.shape[0]
    # the logged commands are the plan's (left flap 50 % from 5 s, 1-s ramps), at 10 Hz
    head, c = _csv(flown.out / NEXT_DATA / "controls.csv")
    assert head == ["time_s", "flap_left", "flap_right"] and np.allclose(np.diff(c[:, 0]), 0.1)
    assert c[c[:, 0] == 10.0, 1] == pytest.approx(0.5) and np.all(c[:, 2] == 0.0)
    # the noise: the record minus the truth's exact outputs in the same gusts, against the
    # generator's statement (white: velocity 0.15 m/s, euler 0.2 deg, rates 0.004 rad/s;
    # position: 1.5 / 2.5 m Gauss-Markov of 20 s, which 20 s cannot estimate: only bounded)
    noise = _truth()["sensor_noise"]
    sd = {}
    for ch in CHANNELS:
        _, a = _csv(flown.out / NEXT_DATA / f"{ch}.csv")
        _, b = _csv(flown.out / "exact" / f"{ch}.csv")
        e = a[:, 1:] - b[:, 1:]
        if ch == "euler":
            e[:, 2] = (e[:, 2] + 180.0) % 360.0 - 180.0
        sd[ch] = e.std(axis=0)
    assert sd["velocity"] == pytest.approx([noise["velocity"]] * 3, rel=0.2)
    assert sd["euler"] == pytest.approx([noise["euler_deg"]] * 3, rel=0.15)
    assert sd["rates"] == pytest.approx([noise["rates"]] * 3, rel=0.15)
    assert np.all(sd["position"] > 0.1) and np.all(sd["position"] < 3 * 2.5)


def test_the_record_ends_where_the_payload_reaches_the_ground(tmp_path):
    shutil.copytree(DEMO_DATA, tmp_path / "data")
    f = fly_plan(_plan(tmp_path, "low", 30.0, height=60.0), _truth(), tmp_path / NEXT_DATA, seed=3)
    assert f.landed is not None and 3.0 < f.landed < 30.0
    _, pos = _csv(tmp_path / NEXT_DATA / "position.csv")
    assert pos[-1, 0] < f.landed and f.span < f.landed
    info = json.loads((tmp_path / NEXT_DATA / "flight.json").read_text(encoding="utf-8"))
    assert info["landed_s"] == pytest.approx(f.landed)


def _candidate(name="next-step", notes=(), criteria=None):
    crit = criteria or {
        "pos_h_abs@step": {"limit": 1.0, "unit": "m·s", "from": "pos_h"},
        "heading_profile@step": {"limit": 1.0, "unit": "rad·s", "from": "heading"},
        "peak_yaw@0.25-1.5@step": {"limit": 0.1, "unit": "Hz", "from": "peak_yaw"},
    }
    return SimpleNamespace(name=name, file=f"{name}.toml", notes=list(notes), criteria=crit)


def test_drop_two_is_judged_by_the_rankings_criteria_over_its_span(flown):
    c = _candidate(notes=["step: judged over its first 12.35 s (a member lands then)"])
    assert _judged_span(c, flown.noisy) == pytest.approx(12.2)  # on the 0.2-s grid
    assert _judged_span(_candidate(), flown.noisy) == pytest.approx(20.0)  # the record's
    assert plan_criteria(c) == [
        ("pos_h_2", "pos_h_abs", "pure", "m·s", "pos_h"),
        ("heading_2", "heading_profile", "pure", "rad·s", "heading"),
        ("peak_yaw_2", "peak_yaw@0.25-1.5", "pseudo", "Hz", "peak_yaw"),
    ]


def test_the_two_drop_study_file_puts_criteria_on_both_drops(flown):
    from vectorid.identify import Identification
    from vectorid.spec import load_study

    crit2 = plan_criteria(_candidate())
    text = two_drop_toml(_truth(), flown.noisy, crit2, window_end=18.0, trials=64, budget=500,
                         population=20, plan="next-step.toml")  # fmt: skip
    f = flown.out / "parafoil-two-drops.toml"
    f.write_text(text, encoding="utf-8")
    spec = load_study(f)
    assert len(spec.space.names) == 33 and spec.sampler == "sequential"
    assert spec.budget == 500 and spec.population == 20
    names = [c.name for c in spec.criteria]
    assert names[:8] == ["pos_h", "pos_v", "heading", "speed", "turn", "peak_roll",
                         "peak_pitch", "peak_yaw"]  # fmt: skip
    assert names[8:] == ["pos_h_2", "heading_2", "peak_yaw_2"]
    table = tomllib.loads(text)["identification"]
    assert table["limits"] == "noise"
    for n in names:
        assert table["criteria"][n]["drops"] == (["step"] if n.endswith("_2") else ["drop"])
    # the same allowance: the drop-1 criterion's goes to its drop-2 namesake
    assert table["discrepancy"]["heading_2"] == DEMO_DISCREPANCY["heading"]
    assert "pos_h_2" not in table["discrepancy"]  # its allowance is the channel's position_h
    ident = Identification.from_spec(spec)
    d1, d2 = ident.drops
    assert (d1.name, d2.name) == ("drop", "step")
    assert d2.grid[0] == pytest.approx(0.0) and d2.grid[-1] == pytest.approx(18.0)
    assert {"position", "velocity", "euler", "rates"} <= set(d2.flight.channels)


def test_drop_two_allowance_is_read_from_twins_of_the_plan(flown):
    """The extra allowance a drop-2 criterion needs is the truth's excess over its limit on
    twins of the plan (other seeds): none under limits it meets, positive under limits it
    cannot meet; the twins' files are removed; a stated allowance replaces the namesake's."""
    crit2 = plan_criteria(_candidate())
    names = [c[0] for c in crit2]
    loose = dict.fromkeys(names, 1e9)
    extra, worst, met = plan_allowance(flown.plan, _truth(), flown.out, crit2, loose,
                                       window_end=18.0, twins=4)  # fmt: skip
    assert extra == dict.fromkeys(names, 0.0) and met == 1.0
    assert all(0.0 <= w < 1e-3 for w in worst.values())
    tight = dict.fromkeys(names, 1e-12)
    extra, worst, met = plan_allowance(flown.plan, _truth(), flown.out, crit2, tight,
                                       window_end=18.0, twins=4)  # fmt: skip
    assert met == 0.0 and extra["pos_h_2"] > 1.0 and extra["heading_2"] > 0.0
    assert not (flown.out / f"{NEXT_DATA}-twins").exists()
    text = two_drop_toml(_truth(), flown.noisy, crit2, window_end=18.0, trials=64, budget=500,
                         population=20, allowance={"peak_yaw_2": 1.2},
                         allowance_note="twins")  # fmt: skip
    disc = tomllib.loads(text)["identification"]["discrepancy"]
    assert disc["peak_yaw_2"] == 1.2 and disc["heading_2"] == DEMO_DISCREPANCY["heading"]
    assert "# twins:" in text
    assert [_round_up(v) for v in (1.1044, 0.0123, 0.0, 47.0)] == pytest.approx(
        [1.2, 0.013, 0.0, 47.0]
    )


def test_cli_next_drop_flag():
    p = build_parser()
    assert p.parse_args(["demo", "parafoil", "--next-drop"]).next_drop is True
    assert p.parse_args(["demo", "parafoil"]).next_drop is False


def test_next_drop_on_the_g12_demo_is_a_one_line_error(capsys, tmp_path):
    code = main(["demo", "g12", "--next-drop", "--out", str(tmp_path / "g")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and "--next-drop" in err
    assert "parafoil" in err and not (tmp_path / "g").exists()


def _design(kept, truth_kept):
    from vectorid.workflows.design import Candidate, Design, _rank
    from vectorid.workflows.predict import Members

    cands = [
        Candidate(f"next-{n}", f"next-{n}.toml", [n], ["position"], k, (k - 0.01, k + 0.01),
                  n_flown=150, truth_kept=t)
        for n, k, t in zip(("brakes", "spiral"), kept, truth_kept, strict=True)
    ]  # fmt: skip
    _rank(cands)
    return Design("s.db", Members.__new__(Members), cands, [], 0, 1)


def test_nothing_is_flown_when_no_plan_informs(capsys, tmp_path):
    run = {"trials": 8, "budget": 8, "population": 2}
    assert run_next_drop(tmp_path, _truth(), None, None, **run) is None
    assert "there is no ranking" in capsys.readouterr().out
    rejects, idle = _design((0.05, 0.4), (0.1, 0.2)), _design((0.93, 0.96), (0.95, 0.9))
    assert run_next_drop(tmp_path, _truth(), None, rejects, **run) is None
    assert "every plan would reject the truth" in capsys.readouterr().out
    assert run_next_drop(tmp_path, _truth(), None, idle, **run) is None
    assert "no plan would shrink D" in capsys.readouterr().out
    assert not (tmp_path / NEXT_DATA).exists()


@pytest.mark.long
@pytest.mark.slow  # minutes: the reduced demo, then a two-drop study
def test_parafoil_demo_next_drop_end_to_end_reduced(tmp_path, capsys):
    out = tmp_path / "demo"
    code = main(["demo", "parafoil", "--out", str(out), "--trials", "256", "--budget", "1500",
                 "--population", "20", "--quiet", "--next-drop"])  # fmt: skip
    text = capsys.readouterr().out
    assert code == 0
    part = text.split("--next-drop: fly the best planned drop", 1)[1]
    if "nothing flown" in part:  # said plainly, and nothing written
        assert not (out / NEXT_DATA).exists()
        return
    for needle in ("flown: next-", "by the generator's truth", "one drop against two",
                   "gains identified", "combinations identified", "members of D",
                   "model evaluations", "does drop 1's allowance cover what the model lacks",
                   "the check of the ranking: the share of stage 2's D",
                   "under the ranking's limits (drop 1's allowance)"):  # fmt: skip
        assert needle in part, needle
    doc = json.loads((out / "next-drop.json").read_text(encoding="utf-8"))
    assert 0.0 <= doc["flown_share_kept"] <= 1.0
    assert doc["two_drops"]["n"] >= 256 and (out / "parafoil-two-drops.db").exists()
    assert (out / NEXT_DATA / "flight.json").exists()
    # the study file reruns as it is written
    assert main(["info", str(out / "parafoil-two-drops.db")]) == 0
