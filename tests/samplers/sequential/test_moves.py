"""Moves inside the tolerance region (many variables): the parts, a known answer in 24
dimensions, and exact resume after an interrupt."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from vectorid.analysis.histograms import histograms
from vectorid.analysis.results import Analysis
from vectorid.analysis.weights import how_weighted, trial_weights
from vectorid.problem import Criterion
from vectorid.run.loop import RunInterrupted, run_store
from vectorid.samplers.sequential import assess, generations
from vectorid.samplers.sequential.moves import (
    MIN_FINAL_MOVES,
    MOVE_FROM,
    TARGET_ACCEPT,
    adapt_scale,
    chain_ess,
    copy_evenly,
    kept_moves,
    move_draws,
)
from vectorid.space import Continuous, Space
from vectorid.spec import StudySpec
from vectorid.store import Store
from vectorid.views.clouds import histograms_figure

# 24 variables: the first K pinned to within HALF of CENTRES, a curved (banana) band between
# x[K] and x[K + 1], the others free. D is (2 HALF)^K x 0.12 = 2.6e-10 of the box.
P, K, HALF, BAND = 24, 8, 0.03, 0.03
CENTRES = np.linspace(0.3, 0.7, K)


def banana(X):
    pinned = np.abs(X[:, :K] - CENTRES)
    band = np.abs(X[:, K + 1] - 0.2 - 3.0 * (X[:, K] - 0.5) ** 2)[:, None]
    return np.hstack([pinned, band]), np.zeros((len(X), 0))


def banana_spec(**kw) -> StudySpec:
    opts = {"trials": 2048, "budget": 60_000, "population": 200, "seed": 0} | kw
    return StudySpec(
        name="banana",
        model=opts.pop("model", banana),
        space=Space([Continuous(f"x{i}", 0.0, 1.0) for i in range(P)]),
        criteria=(
            *[Criterion(f"f{i}", limit=HALF) for i in range(K)],
            Criterion("band", limit=BAND),
        ),
        sampler="sequential",
        **opts,
    )


def test_copy_evenly_copies_each_alive_particle_alike():
    rng = np.random.default_rng(0)
    out = copy_evenly(np.array([3, 7, 9]), 10, rng)
    counts = np.bincount(out, minlength=10)[[3, 7, 9]]
    assert len(out) == 10 and sorted(counts) == [3, 3, 4]
    assert len(np.unique(copy_evenly(np.arange(50), 20, rng))) == 20


def test_step_scale_follows_the_acceptance():
    assert adapt_scale(0.1, TARGET_ACCEPT + 0.2) > 0.1 > adapt_scale(0.1, TARGET_ACCEPT - 0.2)
    assert adapt_scale(0.1, TARGET_ACCEPT) == pytest.approx(0.1)


def test_draws_outside_the_box_are_refused_unevaluated():
    rng = np.random.default_rng(1)
    U = np.full((500, 3), 0.02)
    draws, parents = move_draws(U, np.eye(3) * 0.05, rng)
    assert np.all((draws >= 0) & (draws <= 1))
    assert 0 < len(draws) < 500 and np.all(np.diff(parents) > 0)


@pytest.mark.slow
def test_banana_in_24_dimensions_is_reached_and_covered(tmp_path):
    """2.6e-10 of the box, curved: the moves reach D at the stated limits, every member lies
    in D, the particles cover its free axes end to end and its curve from end to end."""
    assert P >= MOVE_FROM
    with Store.create(tmp_path / "banana.db", banana_spec()) as st:
        summary = run_store(st, executor="inline", progress=False)
        text = summary.describe()
        assert summary.converged, text
        assert "ESS" in text and summary.evaluations <= 60_000
        state = assess(st)
        t = st.load(stages=[0])
        a = Analysis.of_store(st)
        part = np.unique(state.particles)
    assert np.all(state.members[part]) and len(part) >= 200 and state.ess >= 200
    # D's weights: each member's holding time over the kept moves at the stated limits
    m = len(state.chains)
    assert m >= MIN_FINAL_MOVES
    held = np.exp(state.log_w[state.members])
    assert held.sum() == pytest.approx(kept_moves(m) * state.chains.shape[1])
    assert a.weighting is not None  # so histograms weigh them
    w = trial_weights(a, state.members)
    assert w is not None and np.allclose(w / w.sum(), held / held.sum())
    # and the CLI, the report and the UI say so (not "importance-weighted")
    assert how_weighted(a) == "weighted by the particles' holding times"
    hs = histograms(a)
    assert all(h.weighted_by == "weighted by the particles' holding times" for h in hs)
    held_by = "weighted by the particles' holding times"
    assert all(h.to_dict()["feasible_weighted_by"] == held_by for h in hs)  # hist --json
    assert "D's density weighted by the particles' holding times" in str(
        histograms_figure(hs).layout.title.text
    )
    X = t.X[state.members]
    assert np.all(np.abs(X[:, :K] - CENTRES) <= HALF)
    for j in range(K):  # the pinned axes: the slab's width covered
        assert X[:, j].min() < CENTRES[j] - 0.8 * HALF and X[:, j].max() > CENTRES[j] + 0.8 * HALF
    for j in range(K + 2, P):  # the free axes: end to end
        assert X[:, j].min() < 0.15 and X[:, j].max() > 0.85, j
    # both arms of the banana (they reach x[K] = 0 and 1; their thin far ends are not reached
    # by the moves: docs/sequential.md, Known limits)
    assert X[:, K].min() < 0.3 and X[:, K].max() > 0.7


def ar1_chains(phi: float, n: int, m: int, seed: int) -> np.ndarray:
    """``m`` stationary AR(1) chains of ``n`` states: x_t = φ x_{t-1} + N(0, 1 - φ²)."""
    rng = np.random.default_rng(seed)
    x = np.empty((n, m))
    x[0] = rng.standard_normal(m)
    e = rng.standard_normal((n, m)) * np.sqrt(1.0 - phi**2)
    for t in range(1, n):
        x[t] = phi * x[t - 1] + e[t]
    return x


@pytest.mark.parametrize("phi", [0.0, 0.5, 0.9])
def test_chain_ess_of_long_ar1_chains_is_n_over_tau(phi):
    """Four long chains: ESS = M n / τ with τ = (1 + φ) / (1 - φ), within the estimator's
    scatter (sd about 5-8 % here)."""
    tau = (1 + phi) / (1 - phi)
    for seed in range(3):
        ess = chain_ess(ar1_chains(phi, 4000, 4, seed))
        assert ess == pytest.approx(4 * 4000 / tau, rel=0.2), (seed, ess)


@pytest.mark.parametrize("phi", [0.5, 0.9])
def test_chain_ess_of_many_short_chains_errs_on_the_low_side(phi):
    """The sampler's shape: 400 chains of 15 states. The ESS of their mean is
    M n / (1 + 2 Σ_{t<n} (1 - t/n) φ^t) for stationary starts; the estimator (lags cut by
    Geyer's sequence) may report fewer, never many more."""
    n, m = 15, 400
    exact = m * n / (1 + 2 * sum((1 - t / n) * phi**t for t in range(1, n)))
    ess = [chain_ess(ar1_chains(phi, n, m, seed)) for seed in range(5)]
    assert 0.5 * exact < np.mean(ess) < 1.15 * exact, (exact, ess)
    assert chain_ess(np.ones((n, m))) == 0.0  # a constant variable has no ESS


# 20 variables, the first SLAB_K pinned within SLAB_HALF of 0.5, the others free: uniform on D
# has known marginals (uniform on each axis's interval)
SLAB_P, SLAB_K, SLAB_HALF = 20, 6, 0.05


def slab(X):
    return np.abs(X[:, :SLAB_K] - 0.5), np.zeros((len(X), 0))


def test_moved_population_is_a_faithful_sample_of_d(tmp_path):
    """The holding-time weights make D's members a sample of uniform-on-D: every axis's
    weighted marginal passes a KS test against the exact one (family-wise 1 %, n = the
    chains' ESS), where counting each member once — what histograms of a moved store did —
    fails on every axis."""
    spec = StudySpec(
        name="slab20",
        model=slab,
        space=Space([Continuous(f"x{i}", 0.0, 1.0) for i in range(SLAB_P)]),
        criteria=tuple(Criterion(f"f{i}", limit=SLAB_HALF) for i in range(SLAB_K)),
        sampler="sequential",
        trials=2048,
        budget=40_000,
        population=200,
        seed=0,
    )
    with Store.create(tmp_path / "slab.db", spec) as st:
        summary = run_store(st, executor="inline", progress=False)
        assert summary.converged, summary.describe()
        state = assess(st)
        a = Analysis.of_store(st)
    d = a.feasible
    w = trial_weights(a, d)
    assert w is not None and np.any(w == 0)  # members never held weigh 0
    crit = stats.kstwobign.isf(0.01 / SLAB_P)
    X = a.trials.X[d]

    def worst(weights, n):
        z = []
        for j in range(SLAB_P):
            lo, hi = (0.5 - SLAB_HALF, 0.5 + SLAB_HALF) if j < SLAB_K else (0.0, 1.0)
            o = np.argsort(X[:, j])
            c = np.cumsum(weights[o]) / weights.sum()
            f = (X[o, j] - lo) / (hi - lo)
            z.append(max(np.max(c - f), np.max(f - (c - weights[o] / weights.sum()))))
        return np.sqrt(n) * np.array(z)

    weighted = worst(w, state.ess)
    assert np.all(weighted < crit), (weighted.round(2), crit)
    counted = worst(np.ones(len(X)), len(X))
    assert np.sum(counted > crit) >= SLAB_P // 2, (counted.round(2), crit)


def test_interrupted_moves_resume_exactly(tmp_path):
    """Ctrl-C in the middle of a generation of moves, then resume: the same trials, none lost
    or repeated, as one uninterrupted run."""
    calls = {"n": 0}

    def stops(X):
        calls["n"] += len(X)
        if calls["n"] > 6000:
            raise KeyboardInterrupt
        return banana(X)

    kw = {"budget": 8_000, "trials": 2048, "batch_size": 64}
    with Store.create(tmp_path / "a.db", banana_spec(model=stops, **kw)) as st:
        with pytest.raises(RunInterrupted):
            run_store(st, executor="inline", progress=False)
        n_stopped = st.count()
        assert 2048 < n_stopped < 8_000
        calls["n"] = -(10**9)
        run_store(st, executor="inline", progress=False)
    with Store.create(tmp_path / "b.db", banana_spec(**kw)) as st:
        run_store(st, executor="inline", progress=False)
    with Store.open(tmp_path / "a.db") as a, Store.open(tmp_path / "b.db") as b:
        ta, tb = a.load(), b.load()
        ga, gb = generations(a), generations(b)
    assert len(np.unique(ta.seq)) == len(ta.seq), "a trial was stored twice"
    np.testing.assert_array_equal(ta.seq, tb.seq)
    np.testing.assert_array_equal(ta.X, tb.X)
    np.testing.assert_array_equal(ta.F, tb.F)
    assert [(g.seq_start, g.n, g.proposal) for g in ga] == [
        (g.seq_start, g.n, g.proposal) for g in gb
    ]
    with Store.open(tmp_path / "a.db") as a, Store.open(tmp_path / "b.db") as b:
        sa, sb = assess(a), assess(b)
    assert sa.ess == sb.ess  # the chains, their ESS and D's weights are the same
    np.testing.assert_array_equal(sa.log_w, sb.log_w)
