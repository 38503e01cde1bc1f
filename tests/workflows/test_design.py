"""The worth of a planned drop (issue 34, item 2) on the closed-form kinematic model: D is the
disc |v_H - v0_H| <= ρ, a planned drop of T s seen by position at σ per axis keeps, on average,
about 3σ²·√(2/(3n))·1.666 / (mean(t²)·ρ²) of it (module docstring of the test below); a plan
with no information keeps about the limits' coverage, 95 %, and is said not to shrink D."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.workflows.predict_helpers import RHO, drop_file, kinematic_store, planned
from vectorid.workflows.design import COVERAGE, design

SIGMA = 2.0


@pytest.fixture(scope="module")
def plans(tmp_path_factory):
    folder = tmp_path_factory.mktemp("design")
    store = kinematic_store(folder)
    noise = {"position_h": SIGMA, "position_v": 3.0}
    files = {
        "long": drop_file(folder / "long.toml", [planned(duration=60.0, noise=noise)]),
        "medium": drop_file(folder / "medium.toml",
                            [planned(duration=60.0, noise={**noise, "position_h": 8.0})]),
        "short": drop_file(folder / "short.toml", [planned(duration=4.0, noise=noise)]),
        "blind": drop_file(folder / "blind.toml",
                           [planned(duration=60.0, noise={"position_h": 1e4, "position_v": 1e4})]),
    }  # fmt: skip
    return store, files


def test_plans_are_ranked_by_the_share_of_d_they_keep(plans):
    store, files = plans
    d = design(store, [files["blind"], files["short"], files["long"]], members=300, seed=1)
    by = {c.name: c for c in d.candidates}
    assert [by[n].rank for n in ("long", "short", "blind")] == [1, 2, 3]
    # the long drop: D's members kept only where |Δv| is within the noise's reach. For
    # |Δv|² mean(t²)/(3σ²) <= L - S_truth, with L - S_truth = √(2/(3n))(1.645 - z), z normal,
    # averaged: E[(1.645 - z)+] = 1.666 (edges of the disc and the cross term ignored)
    t = np.arange(0.0, 60.0 + 1e-9, 0.5)
    expect = 3 * SIGMA**2 * math.sqrt(2 / (3 * t.size)) * 1.666 / (np.mean(t**2) * RHO**2)
    assert 0.5 * expect < by["long"].expected_fraction_kept < 1.5 * expect
    lo, hi = by["long"].interval
    assert lo <= by["long"].expected_fraction_kept <= hi
    # the blind plan: the truth and every member meet the limits alike
    assert by["blind"].expected_fraction_kept == pytest.approx(COVERAGE, abs=0.04)
    assert not by["blind"].shrinks and by["long"].shrinks and not d.none_shrinks
    doc = d.to_dict()
    assert [c["rank"] for c in doc["candidates"]] == [1, 2, 3]
    assert set(doc["candidates"][0]) >= {"name", "rank", "expected_fraction_kept", "interval",
                                         "newly_identified"}  # fmt: skip
    text = d.describe()
    assert "1. long" in text and "would not shrink D" in text and "Most informative: long" in text


def test_no_plan_would_shrink_d_is_said_plainly(plans):
    store, files = plans
    d = design(store, [files["blind"]], members=150, seed=2)
    assert d.none_shrinks
    assert "No plan would shrink D" in d.describe()
    assert d.to_dict()["none_shrinks"] is True


def test_a_plan_that_pins_both_speeds_names_them(plans):
    """σ = 8 m: about 8 % of the disc kept around each truth, a radius of about 0.28ρ, so a
    width of about 14 % of the box (4ρ) in each speed: both newly identified."""
    store, files = plans
    d = design(store, [files["medium"]], members=300, seed=1)
    (c,) = d.candidates
    assert d.identified_now == []
    assert c.newly_identified == ["vn", "ve"] and c.identified_share["vn"] > 0.6
    assert 0.04 < c.expected_fraction_kept < 0.15
    assert "newly identified: vn, ve" in d.describe()
