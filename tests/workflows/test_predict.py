"""Predictions of the identified set: a known answer in closed form, a predictive check that
passes and one that fails, the members' weights and the JSON contract."""

from __future__ import annotations

import hashlib
import json
import math

import numpy as np
import pytest
from scipy import optimize, stats

from tests.workflows.kinematic import disc_cdf, disc_quantile
from tests.workflows.predict_helpers import (
    ORIGIN,
    RHO,
    TRUTH,
    drop_file,
    kinematic_store,
    planned,
)
from vectorid.study import Study
from vectorid.workflows.predict import (
    members_of,
    predict,
    weighted_quantiles,
)


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    return kinematic_store(tmp_path_factory.mktemp("kinematic"))


def _digest(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_known_answer_bands_and_landing(store, tmp_path):
    """D is the disc |v_H - v0_H| <= ρ: the members' north(t) = t·vn has the disc's marginal,
    so the credible band is t·(vn0 + ρ x_q) exactly; with white noise σ the with-noise band is
    its convolution with N(0, σ²); the landing points from h above the ground fill a disc of
    radius ρ h / sink, whose share within r is (r / R)²: R_q = R √q, and its covariance
    ellipse of 1 σ = R/2 holds 25 % of the points, not a normal's 39 %."""
    sigma = 20.0
    f = drop_file(tmp_path / "next.toml", [planned(noise={"position_h": sigma})])
    p = predict(store, f, seed=3)
    n_d = p.members.n_set
    assert n_d > 300 and p.members.is_d and len(p.members) == n_d
    d = p.drop("next")
    pos = d.channel("position")
    k = int(np.flatnonzero(np.isclose(pos.t, 100.0))[0])
    for i, q in enumerate((0.05, 0.95)):
        exact = 100.0 * (TRUTH["vn"] + RHO * disc_quantile(q))
        assert pos.credible[i, k, 0] == pytest.approx(exact, abs=0.06 * 100 * RHO)
    assert pos.median[k, 0] == pytest.approx(100.0 * TRUTH["vn"], abs=0.03 * 100 * RHO)

    def noisy_cdf(y: float) -> float:  # the disc's marginal (scale 100 ρ) convolved with N(0, σ²)
        e = np.linspace(-6 * sigma, 6 * sigma, 2001)
        u = (y - e - 100.0 * TRUTH["vn"]) / (100.0 * RHO)
        vals = np.array([disc_cdf(x) for x in u]) * stats.norm.pdf(e, scale=sigma)
        return float(np.trapezoid(vals, e))

    for i, q in enumerate((0.05, 0.95)):
        exact = optimize.brentq(lambda y, q=q: noisy_cdf(y) - q, 0.0, 700.0)
        assert pos.with_noise[i, k, 0] == pytest.approx(exact, abs=5.0)
    assert (
        pos.with_noise[1, k, 0] - pos.with_noise[0, k, 0]
        > pos.credible[1, k, 0] - pos.credible[0, k, 0] + 20
    )
    # landing: 1200 m above the ground at 6 m/s, 200 s
    disp = d.dispersion
    assert disp.kind == "landing" and disp.time_s == pytest.approx(200.0, abs=0.01)
    R = RHO * 200.0
    np.testing.assert_allclose(disp.centre, [600.0, -400.0], atol=0.03 * R)
    for key, q, tol in (("r50", 0.5, 0.05), ("r90", 0.9, 0.03), ("r95", 0.95, 0.03)):
        assert disp.radii[key] == pytest.approx(R * math.sqrt(q), rel=tol)
        lo, hi = disp.intervals[key]
        assert lo <= disp.radii[key] <= hi
    one = disp.ellipses[0]
    assert one["sigma"] == 1 and one["share"] == pytest.approx(0.25, abs=0.04)
    assert one["nominal_share"] == pytest.approx(0.393, abs=1e-3)
    assert disp.ellipses[1]["share"] == pytest.approx(1.0, abs=0.01)
    # bands end where the members have landed: nothing below the ground
    assert np.all(np.isnan(pos.median[pos.t > 201.0]))
    assert d.verdict.startswith("a planned drop") and d.within is None


def test_a_drop_with_data_is_checked(store, tmp_path):
    """The study's own drop copied (its data are the truth, noise-free): every sample inside
    both bands, the median's error near zero, and the note that D was identified from it."""
    drop = {"name": "drop1", "file": str(store.parent / "drop1.csv"),
            "mapping": {"time": "t", "time_unit": "s",
                        "position": {"north": "n", "east": "e", "down": "d", "unit": "m"}},
            "window": [0.0, 60.0], "origin_altitude": ORIGIN}  # fmt: skip
    p = predict(store, drop_file(tmp_path / "d.toml", [drop]), members=200, seed=1)
    d = p.drop("drop1")
    pos = d.channel("position")
    assert pos.coverage_credible == 1.0 and pos.coverage_with_noise == 1.0
    assert pos.median_rms < 0.05 * RHO * 60.0
    assert d.within is True and "lie within what D predicts" in d.verdict
    assert any("one of the study's own drops" in n for n in d.notes)
    assert d.dispersion.kind == "end of window" and d.dispersion.measured_inside_r95
    doc = p.to_dict()
    assert set(doc) >= {"members", "drops"} and doc["members"] == len(p.members)
    ch = doc["drops"][0]["channels"][0]
    assert set(ch) >= {"name", "unit", "coverage_credible", "coverage_with_noise", "median_rms"}
    land = doc["drops"][0]["landing"]
    assert set(land) >= {"r50_m", "r90_m", "r95_m", "centre_ne_m", "measured_ne_m",
                         "measured_inside_r95"}  # fmt: skip
    assert isinstance(doc["drops"][0]["verdict"], str)
    json.dumps(doc)  # plain JSON


def test_a_drop_outside_what_d_predicts_fails_plainly(store, tmp_path):
    """A track flown 1 m/s faster north than any member of D: the check fails, and says which
    channel, when and by how much."""
    import tests.workflows.predict_helpers as h

    t = np.arange(0.0, 62.0, 0.25)
    lines = ["t,n,e,d"] + [
        f"{a:.2f},{(TRUTH['vn'] + 1.0) * a:.4f},{TRUTH['ve'] * a:.4f},{-1500 + 6 * a:.4f}"
        for a in t
    ]
    (tmp_path / "fast.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
    drop = {"name": "fast", "file": "fast.csv", "mapping": h.MAPPING, "window": [0.0, 60.0],
            "origin_altitude": ORIGIN}  # fmt: skip
    d = predict(store, drop_file(tmp_path / "f.toml", [drop]), members=100).drop("fast")
    assert d.within is False and "do NOT lie within" in d.verdict and "position" in d.verdict
    pos = d.channel("position")
    assert pos.coverage_with_noise < 0.7  # north is outside from 1.25 s on; east, down inside
    span = pos.outside[0]
    assert span["component"] == "north" and span["samples"] > 200 and span["max_excess"] > 30.0
    assert d.dispersion.measured_inside_r95 is False


def test_members_keep_the_weights(tmp_path):
    """On a sequential store fewer members are drawn in proportion to the importance weights:
    their weighted mean is the whole set's, and draws add up."""
    from vectorid.analysis.weights import trial_weights

    store = kinematic_store(tmp_path, trials=256, sampler="sequential", budget=3000,
                            population=150)  # fmt: skip
    with Study.open(store) as st:
        a = st.analysis()
        w = trial_weights(a, a.feasible)
        assert w is not None  # weighted
        X = a.trials.X[a.feasible]
        full = (w / w.sum()) @ X
        allm = members_of(st)
        assert len(allm) == a.n_feasible and "with their weights" in allm.chosen
        np.testing.assert_allclose(allm.weights @ allm.X, full, atol=1e-9)
        few = members_of(st, 100, seed=5)
        assert "systematic resampling" in few.chosen and len(few) <= 100
        np.testing.assert_allclose(few.weights @ few.X, full, atol=0.05 * RHO)
        assert members_of(st, 100, seed=5).ids.tolist() == few.ids.tolist()  # seeded


def test_weighted_quantiles_match_the_analysis_quantile():
    from vectorid.analysis.weights import weighted_quantile

    rng = np.random.default_rng(0)
    Y = rng.normal(size=(300, 4, 2))
    w = rng.random(300)
    q = weighted_quantiles(Y, w, (0.05, 0.5, 0.95))
    np.testing.assert_allclose(q[:, 2, 1], weighted_quantile(Y[:, 2, 1], [0.05, 0.5, 0.95], w))
    np.testing.assert_allclose(
        weighted_quantiles(Y, np.ones(300), (0.1,))[0, 1, 0],
        np.quantile(Y[:, 1, 0], 0.1, method="hazen"),
    )
    Y[:200, 0, 0] = np.nan  # too few still flying: no band there
    assert np.isnan(weighted_quantiles(Y, np.ones(300), (0.5,), 0.5)[0, 0, 0])
