"""The worth of a planned drop (issue 34, item 2) on the closed-form kinematic model: D is the
disc |v_H - v0_H| <= ρ (``pos_h_abs`` on drop 1 at a stated limit); each plan carries a GPS
and is judged by the study's own ``pos_h_abs`` on the planned drop, limited by the noise floor
the study itself would compute for it (checked against the study's own limit machinery on a
drop built from the plan). Under those limits the truth itself is kept in about 95 % of its
records (the coverage); a plan whose noise swamps every difference keeps about 95 % of D and
is said not to shrink it; a long precise drop keeps a few per cent and identifies both speeds.
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.workflows.predict_helpers import MAPPING, ORIGIN, drop_file, kinematic_store, planned
from vectorid.spec import StudySpec
from vectorid.study import Study
from vectorid.workflows.design import (
    ADEQUACY_NOTE,
    COVERAGE,
    FLOOR_SEED_OFFSET,
    _rank,
    design,
    kept_interval,
)

GPS = {"position_h": 2.0, "position_v": 3.0}  # m


@pytest.fixture(scope="module")
def plans(tmp_path_factory):
    folder = tmp_path_factory.mktemp("design")
    store = kinematic_store(folder)
    files = {
        "long": drop_file(folder / "long.toml", [planned(duration=60.0, noise=GPS)]),
        "short": drop_file(folder / "short.toml", [planned(duration=6.0, noise=GPS)]),
        "blind": drop_file(folder / "blind.toml",
                           [planned(duration=60.0, noise={"position_h": 1e4, "position_v": 1e4})]),
    }  # fmt: skip
    d = design(store, [files["blind"], files["short"], files["long"]], members=300, seed=1)
    return folder, store, files, d


def test_plans_are_ranked_by_the_share_of_d_they_keep(plans):
    _, _, _, d = plans
    by = {c.name: c for c in d.candidates}
    assert [by[n].rank for n in ("long", "short", "blind")] == [1, 2, 3]
    # judged by the study's own criterion on the planned drop, nothing else
    assert all(list(c.criteria) == ["pos_h_abs@next"] for c in d.candidates)
    assert by["long"].criteria["pos_h_abs@next"]["unit"] == "m·s"
    lo, hi = by["long"].interval
    assert lo <= by["long"].expected_fraction_kept <= hi
    assert 0.02 < by["long"].expected_fraction_kept < 0.15
    # the blind plan: the truth and every member meet the limits alike
    assert by["blind"].expected_fraction_kept == pytest.approx(COVERAGE, abs=0.04)
    assert not by["blind"].shrinks and by["long"].shrinks and not d.none_shrinks
    doc = d.to_dict()
    assert [c["rank"] for c in doc["candidates"]] == [1, 2, 3]
    assert set(doc["candidates"][0]) >= {"name", "rank", "expected_fraction_kept", "interval",
                                         "newly_identified", "criteria", "truth_kept"}  # fmt: skip
    text = d.describe()
    assert "1. long" in text and "would not shrink D" in text and "Most informative: long" in text
    assert "judged by pos_h_abs@next <=" in text and "the truth itself meets them in" in text
    # what every estimate assumes is said with every ranking, for people and in JSON
    assert f"Read with care: {ADEQUACY_NOTE}." in text and doc["assumes"] == ADEQUACY_NOTE


def test_the_truth_meets_the_plans_limits_as_often_as_the_coverage(plans):
    """Each member plays the truth against its own noisy record (its start fitted to it): it
    is kept as often as the noise floor's coverage says (300 truths: ± 2.5 % binomial)."""
    _, _, _, d = plans
    for c in d.candidates:
        assert c.truth_kept == pytest.approx(COVERAGE, abs=0.05), c.name
        assert not c.rejects_truth


def test_the_plans_limit_is_the_one_the_study_would_set(plans):
    """The same study with the plan flown as a second drop (the reference member's record,
    the study's criterion on it limited by the noise): its own noise limit for that criterion
    equals the one the plan was judged by: with the plan's draws (the study's noise seed plus
    FLOOR_SEED_OFFSET), to rounding; the same machinery, not a second criterion."""
    folder, store, _, d = plans
    long = next(c for c in d.candidates if c.name == "long")
    with Study.open(store) as st:
        data = st.spec.to_dict()
    ref = {v["name"]: 0.5 * (v["low"] + v["high"]) for v in data["variables"]}
    t = np.arange(0.0, 60.0 + 1e-9, 0.5)
    n, e = ref["vn"] * t, ref["ve"] * t
    down = -1200.0 + 6.0 * t  # the kinematic study's sink, from the planned height
    lines = ["t,n,e,d"] + [f"{a:.2f},{b:.6f},{c:.6f},{x:.6f}" for a, b, c, x in zip(t, n, e, down)]
    (folder / "next.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
    ident = data["identification"]
    ident["drops"] = [
        ident["drops"][0],
        {"name": "next", "file": str(folder / "next.csv"), "mapping": MAPPING,
         "window": [0.0, 60.0], "origin_altitude": ORIGIN, "noise": GPS},
    ]  # fmt: skip
    ident["criteria"] = {"pos_h_abs": {"use": "pos_h_abs", "drops": ["drop1"]},
                         "next": {"use": "pos_h_abs", "drops": ["next"]}}  # fmt: skip
    ident["noise_seed"] = ident.get("noise_seed", 0) + FLOOR_SEED_OFFSET
    data["criteria"] = [*data["criteria"], {"name": "next", "limit": "noise"}]
    spec = StudySpec.from_dict(data, base_dir=folder)
    with Study.create(spec, folder / "two.db") as st:
        limit = next(c.limit for c in st.spec.criteria if c.name == "next")
    assert long.criteria["pos_h_abs@next"]["limit"] == pytest.approx(limit, rel=1e-9)
    short = next(c for c in d.candidates if c.name == "short")
    assert short.criteria["pos_h_abs@next"]["limit"] < 0.2 * limit  # 6 s, not 60 s: its own


def test_no_plan_would_shrink_d_is_said_plainly(plans):
    _, store, files, _ = plans
    d = design(store, [files["blind"]], members=150, seed=2)
    assert d.none_shrinks
    assert "No plan would shrink D" in d.describe()
    assert d.to_dict()["none_shrinks"] is True


def test_a_plan_that_pins_both_speeds_names_them(plans):
    """GPS at 2/3 m for 60 s, its start fitted to its first noisy seconds: a few per cent of
    the disc kept around each truth, a width of about 12 % of the box (4ρ) in each speed: both
    newly identified (now both are weak: D spans 25 % of the box)."""
    _, _, _, d = plans
    c = next(c for c in d.candidates if c.name == "long")
    assert d.identified_now == [] and not c.notes
    assert c.newly_identified == ["vn", "ve"] and c.identified_share["vn"] > 0.6
    assert "newly identified: vn, ve" in d.describe()


def test_plans_that_reject_the_truth_are_ranked_last_and_said_so(plans):
    """A plan under which the truth fails its own limits in most records (its start cannot be
    fitted as the study would) is no information, however little of D it keeps."""
    from dataclasses import replace

    _, _, _, d = plans
    by = {c.name: c for c in d.candidates}
    broken = replace(by["short"], name="broken", expected_fraction_kept=0.0, truth_kept=0.1)
    assert broken.rejects_truth and not broken.below_resolution
    long = replace(by["long"])
    mixed = replace(d, candidates=[broken, long])
    _rank(mixed.candidates)
    assert (long.rank, broken.rank) == (1, 2)
    text = mixed.describe()
    assert "would reject the truth" in text and "Most informative: long" in text
    alone = replace(d, candidates=[broken])
    assert "No plan keeps the truth" in alone.describe()
    assert alone.to_dict()["none_keeps_truth"] is True


def test_the_interval_counts_the_members_judged_as_well_as_the_truths():
    # every truth keeps the same half of the members: resampling the truths alone would give
    # an interval of zero width, yet another draw of members from D would keep another share
    rng = np.random.default_rng(5)
    n = 200
    K = np.zeros((n, n), dtype=bool)
    K[:, rng.permutation(n)[: n // 2]] = True
    p = np.full(n, 1.0 / n)
    lo, hi = kept_interval(K, p, np.random.default_rng(1))
    se = np.sqrt(0.25 / n)  # binomial standard error of a share of 1/2 over n members
    assert lo < 0.5 < hi
    assert 2.5 * se < hi - lo < 5.5 * se  # about 2 x 1.96 standard errors
    # a plan that keeps everything keeps everything in every resample
    assert kept_interval(np.ones((n, n), dtype=bool), p, np.random.default_rng(1)) == (1.0, 1.0)
