"""The worth of a planned drop (issue 34, item 2) on the closed-form kinematic model: D is the
disc |v_H - v0_H| <= ρ; a planned drop whose velocity sensor (σ per axis, n samples) is its only
one — so its initial state is taken as known — keeps on average about 3σ²·√(2/(3n))·1.666/ρ²
of D (derivation in the test); a plan with no information keeps about the limits' coverage,
95 %, and is said not to shrink D; a drop seen by GPS has its initial state fitted to its noisy
first seconds, as the study would, which keeps more of D than a known start would."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.workflows.predict_helpers import RHO, drop_file, kinematic_store, planned
from vectorid.workflows.design import COVERAGE, design

SIGMA = 0.18  # m/s, the velocity sensor's noise


@pytest.fixture(scope="module")
def plans(tmp_path_factory):
    folder = tmp_path_factory.mktemp("design")
    store = kinematic_store(folder)
    vel = {"channels": {"velocity": 2.0}, "noise": {"velocity": SIGMA}}
    files = {
        "long": drop_file(folder / "long.toml", [planned(duration=60.0, **vel)]),
        "gps": drop_file(folder / "gps.toml",
                         [planned(duration=60.0, noise={"position_h": 2.0, "position_v": 3.0})]),
        "short": drop_file(folder / "short.toml", [planned(duration=4.0, **vel)]),
        "blind": drop_file(folder / "blind.toml",
                           [planned(duration=60.0, noise={"position_h": 1e4, "position_v": 1e4})]),
    }  # fmt: skip
    return store, files


def test_plans_are_ranked_by_the_share_of_d_they_keep(plans):
    store, files = plans
    d = design(store, [files["blind"], files["short"], files["long"]], members=300, seed=1)
    by = {c.name: c for c in d.candidates}
    assert [by[n].rank for n in ("long", "short", "blind")] == [1, 2, 3]
    # the long drop: a member Δv from the truth shows S = mean((Δv - ε)²/σ²) over n samples
    # of 3 axes (down: the same sink, noise only), the truth S_t = mean(ε²/σ²); it is kept
    # when |Δv|²/(3σ²) <= L - S_t, with L - S_t = √(2/(3n))(1.645 - z), z normal; averaged,
    # E[(1.645 - z)+] = 1.666, over a disc of radius ρ (its edges and the cross term ignored)
    n = np.arange(0.0, 60.0 + 1e-9, 0.5).size
    expect = 3 * SIGMA**2 * math.sqrt(2 / (3 * n)) * 1.666 / RHO**2
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
    assert "initial state cannot be fitted" in text and "taken as known" in text


def test_no_plan_would_shrink_d_is_said_plainly(plans):
    store, files = plans
    d = design(store, [files["blind"]], members=150, seed=2)
    assert d.none_shrinks
    assert "No plan would shrink D" in d.describe()
    assert d.to_dict()["none_shrinks"] is True


def test_a_plan_that_pins_both_speeds_names_them(plans):
    """GPS at 2 m for 60 s, its start fitted to its first noisy seconds: a few per cent of the
    disc kept around each truth, a radius of about 0.25ρ, a width of about 12 % of the box (4ρ)
    in each speed: both newly identified (now both are weak: D spans 25 % of the box)."""
    store, files = plans
    d = design(store, [files["gps"], files["long"]], members=300, seed=1)
    c = next(c for c in d.candidates if c.name == "gps")
    assert d.identified_now == [] and not c.notes
    assert c.newly_identified == ["vn", "ve"] and c.identified_share["vn"] > 0.6
    assert 0.02 < c.expected_fraction_kept < 0.15
    assert "newly identified: vn, ve" in d.describe()
