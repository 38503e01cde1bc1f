"""``vectorid design``: text, JSON, and bad input (one line, exit 2): a plan with an unknown
channel, zero duration, no stated noise, a drop with data, an empty D."""

from __future__ import annotations

import json

import pytest

from tests.workflows.predict_helpers import (
    MAPPING,
    ORIGIN,
    drop_file,
    kinematic_store,
    planned,
    write_track,
)
from vectorid.cli import main

NOISE = {"position_h": 2.0, "position_v": 3.0}


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    return kinematic_store(tmp_path_factory.mktemp("kinematic"))


def _cli(capsys, *args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def test_design_text_and_json(store, tmp_path, capsys):
    a = drop_file(tmp_path / "long.toml", [planned(duration=60.0, noise=NOISE)])
    b = drop_file(tmp_path / "short.toml", [planned(duration=4.0, noise=NOISE)])
    code, out, err = _cli(capsys, "design", store, b, a, "--members", 120, "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert [(c["name"], c["rank"]) for c in doc["candidates"]] == [("long", 1), ("short", 2)]
    assert all(len(c["interval"]) == 2 for c in doc["candidates"])
    code, out, _ = _cli(capsys, "design", store, a, "--members", 120)
    assert code == 0 and "1. long" in out and "keeps" in out


@pytest.mark.parametrize(
    "drop, needle",
    [
        (planned(channels={"pressure": 2.0}, noise=NOISE), "no channel 'pressure'"),
        (planned(duration=0.0, noise=NOISE), "duration"),
        (planned(channels={"velocity": 2.0}), "no criterion of the study reads one of them"),
        (
            {
                "name": "old",
                "file": "track.csv",
                "mapping": MAPPING,
                "window": [0.0, 30.0],
                "origin_altitude": ORIGIN,
            },
            "a drop with data files is no plan",
        ),
    ],
)
def test_bad_plans_say_one_line_exit_2(store, tmp_path, capsys, drop, needle):
    write_track(tmp_path / "track.csv")
    f = drop_file(tmp_path / "bad.toml", [drop])
    code, _, err = _cli(capsys, "design", store, f, "--members", 50)
    assert code == 2 and needle in err, err
    assert err.startswith("error: ") and err.count("\n") == 1 and "Traceback" not in err


def test_an_empty_d_exits_2(store, tmp_path, capsys):
    f = drop_file(tmp_path / "p.toml", [planned(noise=NOISE)])
    code, _, err = _cli(capsys, "design", store, f, "--limit", "pos_h_abs<=-1")
    assert code == 2 and "D is empty" in err and err.count("\n") == 1
