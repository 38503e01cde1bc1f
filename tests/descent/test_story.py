"""One story per phase: in the text of a phase (``DescentResult.format_text``), each number is
printed once, with its unit. The lines of a phase give the window, the noise, the limits, the
ranges, the best fit and the stated value; the verdict under them refers to those ("above")
and adds only what they do not say, and the table's short summary says each of its numbers
once.

A number printed twice is the same value at two precisions as well (``30.37 m`` and ``30.4 m``):
two numbers are the same when the more precise one rounds to the other, which has at least two
significant digits. Counts (integers up to 20: "8 sub-windows", "2 criteria") are not values.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from vectorid.descent import Canopy, DescentPlan, identify_descent
from vectorid.descent.result import _phase_lines

ROOT = Path(__file__).resolve().parents[2]
RP = ROOT.parent / "shared" / "data" / "rocketpy-descents"

_NUMBER = re.compile(r"(?<![\w.])\d+(?:\.\d+)?(?:e[-+]?\d+)?")


def _values(lines: list[str]) -> list[str]:
    text = "\n".join(ln for ln in lines if not ln.strip().startswith("store:"))
    text = re.sub(r"`[^`]*`", "", text)  # commands and file names quoted in suggestions
    return [
        m.group(0)
        for m in _NUMBER.finditer(text)
        if "." in m.group(0) or "e" in m.group(0) or abs(int(m.group(0))) > 20
    ]


def _sig(a: str) -> int:
    return len(a.replace(".", "").lstrip("0"))


def _same(a: str, b: str) -> bool:
    da = len(a.split(".")[1]) if "." in a else 0
    db = len(b.split(".")[1]) if "." in b else 0
    if da < db or (da == db and _sig(a) < _sig(b)):
        a, b, da, db = b, a, db, da  # a: the more precise
    return _sig(b) >= 2 and round(float(a), db) == float(b)


def repeated_numbers(lines: list[str]) -> list[tuple[str, str]]:
    """The pairs of numbers of ``lines`` that are the same value printed twice."""
    vals = _values(lines)
    return [(a, b) for i, a in enumerate(vals) for b in vals[i + 1 :] if _same(a, b)]


def repeated_from_above(lines: list[str], told: list[str]) -> list[tuple[str, str]]:
    """The numbers of ``told`` (a verdict) that repeat one of ``lines`` (the lines above)."""
    above = _values(lines)
    return [(a, b) for b in _values(told) for a in above if _same(a, b)]


def test_the_rule_finds_a_number_printed_twice():
    assert repeated_numbers(["altitude RMS 30.37 m", "verdict: 30.4 m against 21.3 m"]) == [
        ("30.37", "30.4")
    ]
    assert repeated_numbers(["over 8 sub-windows of 49 s", "2 criteria, 2000 draws"]) == []
    assert repeated_numbers(["C_D S [2.203, 3.127] m²", "changes: 2.2-3.13 m²"]) == [
        ("2.203", "2.2"),
        ("3.127", "3.13"),
    ]


def story_is_one(r) -> None:
    """Each number of each phase's story once (the twins of test_study.py check theirs)."""
    for p in r.phases:
        lines = _phase_lines(p)
        told = [ln for ln in lines if ln.startswith("  verdict:")]
        above = [ln for ln in lines if not ln.startswith(("  verdict:", "  to identify it:"))]
        assert told, lines
        dup = repeated_from_above(above, told) + repeated_numbers(told)
        assert not dup, (dup, "\n".join(lines))
        assert not repeated_numbers([p.summary]), p.summary


@pytest.mark.slow
def test_an_empty_feasible_set_tells_each_number_once(tmp_path):
    path = RP / "lince" / "main_data.csv"
    if not path.exists():
        pytest.skip(f"shared data not found at {path}")
    plan = DescentPlan(file=path, mass=10.3521352, main=Canopy(cds=3.9), pad_altitude=158.0,
                       trials=64, seed=1, name="lince")  # fmt: skip
    r = identify_descent(plan, tmp_path)
    p = r.phase("main")
    assert p.n_feasible == 0 and "empties D" in p.verdict  # the case of the issue
    assert "drag area changes along the descent" in p.verdict
    story_is_one(r)
