"""Analyses of a sequential store use its importance weights, checked against known answers.

The store is the slab of tests/samplers/sequential/test_sampler.py: D is uniform on
``[c - h, c + h]`` along the first K axes and on [0, 1] along the others, 2.6e-6 of the box,
so every statistic a plain Sobol table would give with unboundedly many trials is known. The
sequential sampler's trials crowd around the slab; unweighted, the same statistics describe
the sampler, and the tests check that they would (so they can fail).
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from tests.samplers.sequential.test_sampler import CENTRES, HALF, K, P, slab_spec, write_slab_study
from vectorid.analysis import Analysis
from vectorid.analysis.correlation import correlation_of
from vectorid.analysis.histograms import histograms
from vectorid.analysis.refine import propose_refine
from vectorid.analysis.sensitivity import ks_filtering, rank_correlation, sensitivity
from vectorid.analysis.weights import (
    how_weighted,
    trial_weights,
    weighted_ks,
    weighted_quantile,
    weighted_ranks,
)
from vectorid.run.loop import run_store
from vectorid.samplers import sampler_for
from vectorid.store import Store


def true_ks(half: float) -> np.ndarray:
    """KS distance between D's marginal (uniform on c ± half) and the box's (uniform on
    [0, 1], D being a negligible share of it): the larger of the two tails."""
    return np.array([max(c - half, 1 - c - half) for c in CENTRES] + [0.0] * (P - K))


@pytest.fixture(scope="module")
def slab_store(tmp_path_factory):
    db = tmp_path_factory.mktemp("w") / "slab.db"
    # population 150: a weighted Kolmogorov distance has noise ~0.9 / sqrt(ESS), so at an ESS
    # of 100 the 0.12 tolerances below are exceeded by chance on about one axis in ten
    with Store.create(db, slab_spec(population=150)) as st:
        s = run_store(st, executor="inline", progress=False)
    assert s.converged, s.describe()
    with Store.open(db) as st:
        t = st.load()
        stages = st.stages()
        t.weighting = sampler_for(st.spec).weighting(st, t)  # the sample's, kept beside it
    return db, t, stages


def test_weighted_statistics_reduce_to_the_plain_ones():
    rng = np.random.default_rng(1)
    x, y = rng.normal(size=300), rng.normal(0.3, 1, size=200)
    ones = np.ones(300)
    assert np.allclose(weighted_ranks(x, ones), weighted_ranks(x))
    from scipy import stats

    assert np.allclose(weighted_ranks(x), (stats.rankdata(x) - 0.5) / len(x))
    d, _ = weighted_ks(x, y, ones, np.ones(200))
    assert d == pytest.approx(stats.ks_2samp(x, y).statistic)
    q = weighted_quantile(x, [0.0, 0.5, 1.0], ones)
    assert q[0] == x.min() and q[2] == x.max() and q[1] == pytest.approx(np.median(x))
    # a weight of 3 is three copies of the value
    w = np.ones(300)
    w[:10] = 3.0
    xx = np.concatenate([x, x[:10], x[:10]])
    assert weighted_quantile(x, 0.3, w) == pytest.approx(np.quantile(xx, 0.3), abs=0.02)


def test_sensitivity_of_a_sequential_store_is_weighted_and_right(slab_store):
    db, t, _ = slab_store
    a = Analysis(Store.open(db).spec, t, weighting=t.weighting)
    s = sensitivity(a)
    assert s.weighted and 0 < s.ess_behavioural <= a.n_feasible
    # the known answer, weighted; unweighted the sampler's crowding shows (so this can fail)
    assert np.abs(s.ks - true_ks(HALF)).max() < 0.12, s.ks
    plain, _ = ks_filtering(t.X, a.feasible)
    assert np.abs(plain[:K] - true_ks(HALF)[:K]).max() > 0.15, plain
    # Spearman's rho of x_i and f_i = |x_i - c_i| over the box, from a large uniform sample
    U = np.random.default_rng(0).uniform(size=(200_000, K))
    truth = np.diag(rank_correlation(U, np.abs(U - CENTRES)))
    got = np.diag(s.spearman[:K])
    assert np.abs(got - truth).max() < 0.08, (got, truth)
    unweighted = np.diag(rank_correlation(t.X[a.ok][:, :K], t.F[a.ok]))
    assert np.abs(unweighted - truth).max() > 0.2, unweighted
    assert s.to_dict()["weighted"] is True


def test_correlation_refine_and_histograms_use_the_weights(slab_store):
    db, t, stages = slab_store
    a = Analysis(Store.open(db).spec, t, weighting=t.weighting)
    c = correlation_of(a, "feasible")
    assert c.weighted and c.to_dict()["weighted"]
    assert how_weighted(a) == "importance-weighted"  # the mixture (fewer than 20 variables)
    hd = histograms(a)[0].to_dict()  # `vectorid hist --json` names it too
    assert hd["feasible_weighted"] is not None
    assert hd["feasible_weighted_by"] == "importance-weighted"
    # D is a product of uniforms: no strong pair; the slab's axes could be fixed at c
    assert not c.pairs, c.pairs
    fixed = {d["name"]: d for d in c.fixed}
    assert sorted(fixed) == [f"x{i}" for i in range(K)]
    for i, ci in enumerate(CENTRES):
        assert abs(fixed[f"x{i}"]["median"] - ci) < 0.25 * HALF
        assert abs(fixed[f"x{i}"]["spread"] - 1.8 * HALF) < 0.5 * HALF
    prop = propose_refine(a, stages, quantile=0.05, margin=0.0)
    rows = {r["name"]: r for r in prop.rows()}
    for i, ci in enumerate(CENTRES):  # 5 % and 95 % of uniform on c ± h
        assert abs(rows[f"x{i}"]["new_low"] - (ci - 0.9 * HALF)) < 0.3 * HALF
        assert abs(rows[f"x{i}"]["new_high"] - (ci + 0.9 * HALF)) < 0.3 * HALF
    for h in histograms(a, ["x6"], bins=5):
        assert h.weighted
        share = h.feasible_weighted / h.feasible_weighted.sum()
        assert np.abs(share - 0.2).max() < 0.12, share  # D is uniform along a free axis
    w = trial_weights(a, a.feasible)
    assert w is not None and w.mean() == pytest.approx(1.0)


def test_loosened_limit_after_the_run_is_weighted_too(slab_store):
    """Loosening every limit ×2 after the run: D is then uniform on c ± 2h; the earlier
    generations hold its trials and the weights make them a uniform sample of it."""
    db, t, _ = slab_store
    loose = {f"f{i}": 2 * HALF for i in range(K)}
    a = Analysis(Store.open(db).spec, t, loose, weighting=t.weighting)
    tight = Analysis(Store.open(db).spec, t, weighting=t.weighting)
    assert a.n_feasible > tight.n_feasible
    s = sensitivity(a)
    assert s.weighted
    assert np.abs(s.ks - true_ks(2 * HALF)).max() < 0.12, s.ks
    x = t.X[a.feasible, 0]
    w = trial_weights(a, a.feasible)
    q = weighted_quantile(x, [0.25, 0.75], w)
    assert np.allclose(q, [CENTRES[0] - HALF, CENTRES[0] + HALF], atol=0.4 * HALF), q


def test_no_weight_is_claimed_for_a_plain_store_or_mixed_stages(slab_store):
    db, t, _ = slab_store
    spec = Store.open(db).spec
    plain = t.subset(np.ones(len(t), bool))
    a = Analysis(spec, plain)  # no weighting: a plain store's
    assert trial_weights(a) is None
    assert not sensitivity(a).weighted and not histograms(a, ["x0"])[0].weighted
    mixed = t.subset(np.ones(len(t), bool))
    mixed.stage = mixed.stage.copy()
    mixed.stage[:5] = 1  # as if a refined stage had been added after the run
    assert trial_weights(Analysis(spec, mixed, weighting=t.weighting)) is None


def _cli(*args):
    return subprocess.run(
        [sys.executable, "-m", "vectorid.cli", *map(str, args)],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip


def test_cli_says_weighted_wherever_a_statistic_is_printed(tmp_path):
    path = write_slab_study(tmp_path / "c", budget=5000, population=60)
    r = _cli("run", path, "--executor", "inline", "--quiet")
    assert r.returncode == 0, r.stderr
    db = tmp_path / "c" / "slab.db"
    for args in (("sensitivity",), ("correlation", "--set", "feasible")):
        r = _cli(args[0], db, *args[1:])
        assert r.returncode == 0, (args, r.stderr)
        assert "importance-weighted" in r.stdout, (args, r.stdout)
        assert "sequential sampler:" in r.stdout and "ESS" in r.stdout, (args, r.stdout)
    r = _cli("table", db)
    assert r.returncode == 0, r.stderr
    assert "sequential sampler:" in r.stdout and "count trials (unweighted)" in r.stdout
    # loosened after the run: still weighted, with more members
    r = _cli("sensitivity", db, "--limit", f"f0<={3 * HALF}", "--json")
    assert r.returncode == 0 and '"weighted": true' in r.stdout, r.stderr


def test_thinned_rest_keeps_the_known_answer(slab_store, monkeypatch):
    """Weighing every k-th trial outside D (each k times) still gives the known KS."""
    sens = sys.modules["vectorid.analysis.sensitivity"]  # the name is also the function's

    db, t, _ = slab_store
    monkeypatch.setattr(sens, "WEIGHED_REST", 1500)
    a = Analysis(Store.open(db).spec, t, weighting=t.weighting)
    s = sens.sensitivity(a)
    assert s.weighted and s.stride > 1 and s.n_other == a.n - a.n_feasible
    assert np.abs(s.ks - true_ks(HALF)).max() < 0.12, s.ks
    assert s.ess_other < s.n_other
