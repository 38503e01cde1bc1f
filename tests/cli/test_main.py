"""The CLI verbs on a small study, including --json (a contract)."""

import argparse
import csv
import io
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from vectorid.cli import main


def run_cli(capsys, *args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def ran(tmp_path, user_study, capsys):
    store = tmp_path / "u.db"
    code, out, err = run_cli(
        capsys,
        "run",
        user_study,
        "--store",
        store,
        "--executor",
        "serial",
        "--trials",
        128,
        "--quiet",
    )
    assert code == 0, err
    assert "128 trials computed" in out and "failed" in out
    return store


def test_run_extends_with_larger_trials_and_default_store(tmp_path, user_study, capsys):
    code, out, _ = run_cli(capsys, "run", user_study, "--executor", "serial", "--quiet")
    assert code == 0
    default = user_study.with_suffix(".db")
    assert default.exists() and "256 trials computed" in out
    code, out, _ = run_cli(
        capsys, "run", default, "--trials", 300, "--executor", "serial", "--quiet"
    )
    assert code == 0 and "44 trials computed" in out and "holds 300 of 300" in out


def test_info(ran, capsys):
    code, out, _ = run_cli(capsys, "info", ran)
    assert code == 0
    assert "N=128" in out and "x1" in out and "RuntimeError" in out and "completed" in out
    code, out, _ = run_cli(capsys, "info", ran, "--json")
    info = json.loads(out)
    assert info["n"] == 128 and info["study"]["study"]["name"] == "user"
    assert info["stages"][0]["n"] == 128 and info["n_failed"] > 0


def test_table_text_and_json(ran, capsys):
    code, out, _ = run_cli(capsys, "table", ran, "--top", 3, "--limit", "f1<=0.5")
    assert code == 0 and "N = 128" in out and "f1 (min)" in out and "limit 0.5" in out
    code, out, _ = run_cli(capsys, "table", ran, "--top", 3, "--json")
    doc = json.loads(out)
    assert [t["name"] for t in doc["tables"]] == ["f1", "f2"]
    rows = doc["tables"][0]["rows"]
    assert len(rows) == 3 and rows[0]["value"] <= rows[1]["value"] <= rows[2]["value"]
    assert doc["tables"][0]["min"] == rows[0]["value"]


def test_pareto_json_contract(ran, capsys):
    code, out, _ = run_cli(capsys, "pareto", ran, "--json", "--limit", "f1<=1.2")
    doc = json.loads(out)
    for key in ("n", "n_feasible", "n_pareto", "pareto"):
        assert key in doc
    assert doc["n"] == 128 and doc["n_pareto"] == len(doc["pareto"]) > 0
    assert "f1 <= 1.2" in doc["constraints_in_force"]
    for row in doc["pareto"]:
        assert set(row) >= {"id", "criteria", "params"}
        assert row["criteria"]["f1"] <= 1.2 and row["criteria"]["f2"] <= 1.0
    # loosening a constraint never shrinks D
    _, out2, _ = run_cli(capsys, "pareto", ran, "--json", "--limit", "f1<=inf")
    assert json.loads(out2)["n_feasible"] >= doc["n_feasible"]


def test_pareto_empty_set_explained(ran, capsys):
    code, out, _ = run_cli(capsys, "pareto", ran, "--limit", "f1<=-1")
    assert code == 0 and "ND = 0" in out and "empties it" in out and "f1 <=" in out
    _, out, _ = run_cli(capsys, "pareto", ran, "--limit", "f1<=-1", "--json")
    assert json.loads(out)["empty"]["relaxations"]


def test_export_all_formats(ran, tmp_path, capsys):
    code, out, _ = run_cli(capsys, "export", ran)
    rows = list(csv.DictReader(io.StringIO(out)))
    assert len(rows) == 128
    assert list(rows[0])[:6] == ["id", "seq", "stage", "status", "message", "wall_time"]
    assert list(rows[0])[6:] == [
        "x1", "x2", "x3", "f1", "f2", "g", "functional_ok", "feasible", "pareto",
    ]  # fmt: skip
    failed = [r for r in rows if r["status"] == "failed"]
    assert failed and all(r["message"] for r in failed)
    # the flags are those of `vectorid pareto` under the same constraints
    _, out_p, _ = run_cli(capsys, "pareto", ran, "--json")
    doc = json.loads(out_p)
    assert sum(r["feasible"] == "true" for r in rows) == doc["n_feasible"] > 0
    assert {int(r["id"]) for r in rows if r["pareto"] == "true"} == {p["id"] for p in doc["pareto"]}
    assert all(r["feasible"] == "false" for r in failed)
    _, out_l, _ = run_cli(capsys, "export", ran, "--limit", "f1<=0.5")
    rows_l = list(csv.DictReader(io.StringIO(out_l)))
    assert all(float(r["f1"]) <= 0.5 for r in rows_l if r["feasible"] == "true")
    assert sum(r["feasible"] == "true" for r in rows_l) < doc["n_feasible"]
    # each limit with its source
    _, out_c, _ = run_cli(capsys, "export", ran, "--constraints", "--limit", "f1<=0.9")
    cons = {r["name"]: r for r in csv.DictReader(io.StringIO(out_c))}
    assert cons["f2"]["source"] == "expert" and cons["f2"]["value"] == "1.0"
    assert cons["f1"]["source"] == "analysis" and cons["f1"]["bound"] == "<="
    assert cons["g"]["source"] == "study" and cons["g"]["value"] == "1.5"
    code, out, _ = run_cli(capsys, "export", ran, "--format", "json")
    doc = json.loads(out)
    assert len(doc["trials"]) == 128 and doc["columns"][0] == "id"
    assert isinstance(doc["trials"][0]["feasible"], bool)
    assert {c["name"]: c["source"] for c in doc["constraints"]}["f2"] == "expert"
    pq = tmp_path / "t.parquet"
    code, _, err = run_cli(capsys, "export", ran, "--format", "parquet", "--out", pq)
    assert code == 0 and "128 trials" in err
    import pyarrow.parquet as pqm

    table = pqm.read_table(pq)
    assert table.num_rows == 128
    np.testing.assert_array_equal(table.column("id").to_numpy(), np.arange(1, 129))
    assert table.column("pareto").to_numpy().sum() == len(json.loads(out_p)["pareto"])
    meta = json.loads(table.schema.metadata[b"vectorid.constraints"])
    assert {c["name"] for c in meta} == {"f2", "g"}


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["table", "{store}", "--limit", "f1=3"], "NAME<=VALUE"),
        (["pareto", "{store}", "--limit", "f9<=3"], "unknown criterion"),
        (["info", "{tmp}/nope.db"], "no store"),
        (["pareto", "{store}", "--role", "f1:pseudo"], "NAME=pure"),
        (["run", "{tmp}/missing.toml"], "not found"),
    ],
)
def test_errors_exit_2_with_one_line(ran, tmp_path, capsys, args, match):
    args = [a.format(store=ran, tmp=tmp_path) for a in args]
    code, out, err = run_cli(capsys, *args)
    assert code == 2 and match in err and err.startswith("error: ")
    assert "Traceback" not in err


def test_bad_trials_argument_is_a_usage_error(user_study, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["run", str(user_study), "--trials", "-5"])
    assert exc.value.code == 2
    assert "expected a number >= 1" in capsys.readouterr().err


def test_run_on_store_of_other_study_refused(ran, tmp_path, capsys):
    other = tmp_path / "other.toml"
    other.write_text(
        '[study]\nname = "o"\nmodel = "binh-korn"\n'
        '[[variables]]\nname = "x1"\nlow = 0.0\nhigh = 5.0\n'
        '[[variables]]\nname = "x2"\nlow = 0.0\nhigh = 3.0\n'
        '[[criteria]]\nname = "f1"\n[[criteria]]\nname = "f2"\n'
    )
    code, _, err = run_cli(capsys, "run", other, "--store", ran)
    assert code == 2 and "differ" in err


def test_init_writes_runnable_study(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, out, _ = run_cli(capsys, "init", "tanaka", "--trials", 64)
    assert code == 0 and (tmp_path / "tanaka.toml").exists()
    code, out, _ = run_cli(capsys, "run", "tanaka.toml", "--executor", "serial", "--quiet")
    assert code == 0 and "64 trials computed" in out
    code, _, err = run_cli(capsys, "init", "tanaka")
    assert code == 2 and "exists already" in err


def test_init_unknown_problem_is_one_line_exit_2_without_traceback(tmp_path):
    # the installed console script, as a user runs it (README: one line, exit 2)
    exe = shutil.which("vectorid", path=str(Path(sys.executable).parent))
    out = subprocess.run([exe, "init", "foo"], cwd=tmp_path, capture_output=True, text=True)
    assert out.returncode == 2
    assert "Traceback" not in out.stderr and out.stdout == ""
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1, out.stderr
    assert "unknown analytic problem 'foo'" in lines[0] and "binh-korn" in lines[0]
    assert "vectorid init binh-korn" in lines[0]  # how to fix it
    assert not (tmp_path / "foo.toml").exists()


def test_limit_on_the_better_side_of_a_criterion_is_refused(ran, capsys):
    # f1 is minimised: 'f1>=0.4' would keep the worse trials; one line, exit 2, the form to write
    for verb in ("table", "pareto", "hist"):
        code, out, err = run_cli(capsys, verb, ran, "--limit", "f1>=0.4")
        assert code == 2 and out == ""
        assert len(err.strip().splitlines()) == 1
        assert "f1 is minimised" in err and "--limit 'f1<=0.4'" in err
    # the right side, functional constraints on either side, and removing bounds still work
    for limit in ("f1<=0.4", "g>=0.1", "g<=1.2", "f1>=-inf"):
        code, _, err = run_cli(capsys, "table", ran, "--limit", limit)
        assert code == 0, err


def test_demo_end_to_end_reduced(tmp_path, capsys):
    code, out, _ = run_cli(
        capsys, "demo", "--analytic", "--out", tmp_path / "d", "--trials", 512, "--quiet"
    )
    assert code == 0
    assert "N = 512" in out and "Edgeworth–Pareto set" in out and "Known answer check" in out
    assert (tmp_path / "d" / "binh-korn.db").exists()
    code, out, _ = run_cli(capsys, "pareto", tmp_path / "d" / "binh-korn.db", "--json")
    assert json.loads(out)["n_pareto"] > 0


def test_console_script_installed():
    exe = shutil.which("vectorid") or str(
        __import__("pathlib").Path(sys.executable).with_name("vectorid")
    )
    out = subprocess.run([exe, "--version"], capture_output=True, text=True, check=True)
    assert out.stdout.startswith("vectorid ")


def test_save_limits_persists_and_reruns_keep_working(ran, user_study, capsys):
    # before: the study's own limit (f2 <= 1.0) only
    _, out, _ = run_cli(capsys, "pareto", ran, "--json")
    before = json.loads(out)
    code, _, err = run_cli(capsys, "pareto", ran, "--limit", "f1<=0.8", "--save", "--json")
    assert code == 0 and "saved in" in err and "f1 <= 0.8" in err
    _, out, _ = run_cli(capsys, "pareto", ran, "--json")
    after = json.loads(out)
    assert "f1 <= 0.8" in after["constraints_in_force"]
    assert after["n_feasible"] <= before["n_feasible"]
    # removing a saved limit with inf, saved again
    run_cli(capsys, "table", ran, "--limit", "f1<=inf", "--save")
    _, out, _ = run_cli(capsys, "pareto", ran, "--json")
    assert json.loads(out)["n_feasible"] == before["n_feasible"]
    # a bound on the better side of a criterion cannot be saved as Φ**
    code, _, err = run_cli(capsys, "pareto", ran, "--limit", "f1>=0.1", "--save")
    assert code == 2 and "worst accepted value" in err
    # the study file (without those limits) still runs on the store: limits are not identity
    code, out, _ = run_cli(capsys, "run", user_study, "--store", ran, "--executor", "serial",
                           "--trials", 130, "--quiet")  # fmt: skip
    assert code == 0 and "2 trials computed" in out


def test_help_lists_every_verb_once_grouped_by_workflow(capsys):
    from vectorid.cli.main import VERB_GROUPS, _parser

    with pytest.raises(SystemExit) as info:
        main(["--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: vectorid [-h] [--version] COMMAND ...")
    sub = next(a for a in _parser()._actions if isinstance(a, argparse._SubParsersAction))
    verbs = set(sub.choices)
    grouped = [v for _, vs in VERB_GROUPS for v in vs]
    assert len(grouped) == len(set(grouped)), "a verb is in two groups"
    assert verbs == set(grouped), (
        f"verbs without a group in vectorid.cli.VERB_GROUPS: {sorted(verbs - set(grouped))}; "
        f"groups naming no verb: {sorted(set(grouped) - verbs)}"
    )
    assert "\nother:" not in out
    titles = [t for t, _ in VERB_GROUPS]
    assert titles == ["set up", "run", "analyse", "identify from flight data", "view"]
    at = [out.index(f"\n{t}:\n") for t in titles]
    assert at == sorted(at)  # in the order of the work
    for title, vs in VERB_GROUPS:  # each verb, with its help, under its own title
        block = out[out.index(f"\n{title}:\n") :].split("\n\n", 1)[0]
        for v in vs:
            assert re.search(rf"^  {re.escape(v)}\s", block, re.M), f"{v} not under {title}"
