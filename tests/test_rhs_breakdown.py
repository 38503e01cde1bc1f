"""scripts/rhs_breakdown.py: its source substitutions still match the parachute model."""

from __future__ import annotations

import ast
import importlib.util
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _script():
    spec = importlib.util.spec_from_file_location(
        "rhs_breakdown", ROOT / "scripts" / "rhs_breakdown.py"
    )
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.parametrize("name", ["full", "euler", "atan2", "sin", "none"])
def test_each_variant_changes_what_it_names_and_stays_python(name):
    mod = _script()
    shipped = mod.SOURCE.read_text(encoding="utf-8")
    text = mod.variant_source(name)
    ast.parse(text)
    subs = mod.VARIANTS[name][1]
    assert (text == shipped) == (not subs)
    for old, _new in subs:
        assert old not in text


def test_a_substitution_that_no_longer_matches_stops_the_script(monkeypatch):
    mod = _script()
    monkeypatch.setitem(mod.VARIANTS, "stale", ("gone", [("no such text(", "x")], [1]))
    with pytest.raises(SystemExit, match="found 0"):
        mod.variant_source("stale")
