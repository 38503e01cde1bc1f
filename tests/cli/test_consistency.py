"""One option, one meaning: the options several verbs take, help on every argument (issue 37).

The rules are checked on the parser as built, so a verb added later (by a module of
``vectorid.cli``) is held to them too: it gets the shared options from the helpers of
``vectorid.cli.main`` (``add_quiet_option``, ``add_json_option``, ``add_save_option``,
``add_executor_options``, ``add_limit_options``, ``add_store_argument``).
"""

from __future__ import annotations

import argparse
import json

import pytest

from vectorid.cli import main
from vectorid.cli.main import _parser

#: Options that mean the same on every verb that has them (help, choices, type, action).
SHARED = ("--quiet", "--json", "--save", "--executor", "--workers", "--scheduler", "--timeout",
          "--limit", "--role")  # fmt: skip
#: Verbs that take --executor but show no progress of their own (the browser UI's runs are
#: followed in the browser), so have no --quiet.
NO_PROGRESS = {"ui"}
#: Verbs with --limit whose result is a file, not data printed (no --json).
WRITES_A_FILE = {"report", "plot"}


def _verbs() -> dict[str, argparse.ArgumentParser]:
    sub = next(a for a in _parser()._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


def _options(parser: argparse.ArgumentParser) -> dict[str, argparse.Action]:
    return {s: a for a in parser._actions for s in a.option_strings if s.startswith("--")}


def _meaning(action: argparse.Action) -> tuple:
    return (type(action).__name__, action.help, action.choices and tuple(action.choices),
            getattr(action.type, "__name__", action.type), action.metavar)  # fmt: skip


def test_every_argument_of_every_verb_has_help():
    missing = [
        f"{verb} {a.option_strings[0] if a.option_strings else a.dest}"
        for verb, p in _verbs().items()
        for a in p._actions
        if not isinstance(a, argparse._HelpAction)
        and (not a.help or a.help == argparse.SUPPRESS or not a.help.strip())
    ]
    assert not missing, f"arguments without help text: {missing}"


def test_shared_options_mean_the_same_on_every_verb():
    seen: dict[str, dict[tuple, list[str]]] = {}
    for verb, p in _verbs().items():
        for name, action in _options(p).items():
            if name in SHARED:
                seen.setdefault(name, {}).setdefault(_meaning(action), []).append(verb)
    for name, meanings in seen.items():
        assert len(meanings) == 1, f"{name} means different things: {meanings}"
    # each is used by at least two verbs (else it is not shared, and this test checks nothing)
    for name in ("--quiet", "--json", "--save", "--executor", "--workers", "--limit"):
        assert sum(len(v) for v in seen[name].values()) >= 2, name


def test_verbs_that_can_take_an_option_have_it():
    for verb, p in _verbs().items():
        opts = _options(p)
        if "--executor" in opts:  # it runs a model's trials
            assert "--workers" in opts, verb
            if verb not in NO_PROGRESS:
                assert "--quiet" in opts, f"{verb} runs trials (shows progress) but has no --quiet"
        if "--limit" in opts:  # an analysis under constraints chosen now
            assert "--save" in opts, f"{verb} takes --limit but cannot --save them"
            if verb not in WRITES_A_FILE:
                assert "--json" in opts, f"{verb} prints an analysis but has no --json"
    verbs = _verbs()
    for verb in ("run", "repair", "demo"):  # the verbs that run a study
        assert {"--executor", "--workers", "--quiet"} <= set(_options(verbs[verb])), verb
    for verb in ("run", "repair", "info", "verify", "table", "pareto", "export"):
        assert "--json" in _options(verbs[verb]), verb


def run_cli(capsys, *args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def ran(tmp_path, user_study, capsys):
    store = tmp_path / "u.db"
    code, out, err = run_cli(capsys, "run", user_study, "--store", store, "--executor", "serial",
                             "--trials", 128, "--quiet", "--json")  # fmt: skip
    assert code == 0, err
    doc = json.loads(out)  # standard output is one JSON document
    assert doc["stored"] == 128 and doc["total_stored"] == 128 and doc["target"] == 128
    assert doc["failed"] == sum(g["count"] for g in doc["failures"]) > 0
    assert doc["elapsed_s"] > 0 and "note" not in out.lower().replace('"notes"', "")
    return store


def test_save_on_any_analysis_verb_saves_the_same_limits(ran, capsys):
    _, out, _ = run_cli(capsys, "pareto", ran, "--json")
    before = json.loads(out)
    # hist (not table or pareto) saves them: main() does it the same way for every verb
    code, out, err = run_cli(capsys, "hist", ran, "--limit", "f1<=0.8", "--save", "--json")
    assert code == 0 and "saved in" in err and "f1 <= 0.8" in err
    json.loads(out)  # the verb's own JSON, untouched by the note on standard error
    _, out, _ = run_cli(capsys, "pareto", ran, "--json")
    after = json.loads(out)
    assert "f1 <= 0.8" in after["constraints_in_force"]
    assert after["n_feasible"] < before["n_feasible"]
    # an unknown name is refused before anything is saved
    code, _, err = run_cli(capsys, "sensitivity", ran, "--limit", "nope<=1", "--save")
    assert code == 2 and "nope" in err


def test_export_json_is_format_json(ran, capsys):
    code, out, _ = run_cli(capsys, "export", ran, "--json")
    assert code == 0
    same = run_cli(capsys, "export", ran, "--format", "json")[1]
    assert out == same and json.loads(out)
    code, _, err = run_cli(capsys, "export", ran, "--json", "--format", "csv")
    assert code == 2 and "--json" in err


def test_repair_json(ran, capsys):
    code, out, _ = run_cli(capsys, "repair", ran, "--executor", "serial", "--quiet", "--json")
    assert code == 0
    doc = json.loads(out)
    assert doc["dropped"] == [] and doc["recomputed"] == 0 and doc["store"] == str(ran)
