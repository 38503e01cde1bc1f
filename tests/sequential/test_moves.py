"""Moves inside the tolerance region (many variables): the parts, a known answer in 24
dimensions, and exact resume after an interrupt."""

from __future__ import annotations

import numpy as np
import pytest

from vectorid.problem import Criterion
from vectorid.run.loop import RunInterrupted, run_store
from vectorid.run.sequential import assess
from vectorid.sequential.moves import (
    MOVE_FROM,
    TARGET_ACCEPT,
    adapt_scale,
    copy_evenly,
    move_draws,
)
from vectorid.space import Continuous, Space
from vectorid.spec import StudySpec
from vectorid.store.sqlite import Store

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
    part = np.unique(state.particles)
    assert np.all(state.members[part]) and len(part) >= 200 and state.ess == len(part)
    assert np.all(state.log_w[state.members] == 0.0)  # the members weigh the same
    assert getattr(t, "log_weight", None) is None  # so histograms count them unweighted
    X = t.X[state.members]
    assert np.all(np.abs(X[:, :K] - CENTRES) <= HALF)
    for j in range(K):  # the pinned axes: the slab's width covered
        assert X[:, j].min() < CENTRES[j] - 0.8 * HALF and X[:, j].max() > CENTRES[j] + 0.8 * HALF
    for j in range(K + 2, P):  # the free axes: end to end
        assert X[:, j].min() < 0.15 and X[:, j].max() > 0.85, j
    # both arms of the banana (x[K] from about 0.24 to 0.76 where x[K + 1] stays in the box)
    assert X[:, K].min() < 0.3 and X[:, K].max() > 0.7


def test_interrupted_moves_resume_exactly(tmp_path):
    """Ctrl-C in the middle of a generation of moves, then resume: the same trials, none lost
    or repeated, as one uninterrupted run."""
    calls = {"n": 0}

    def stops(X):
        calls["n"] += len(X)
        if calls["n"] > 9000:
            raise KeyboardInterrupt
        return banana(X)

    kw = {"budget": 12_000, "trials": 2048, "batch_size": 64}
    with Store.create(tmp_path / "a.db", banana_spec(model=stops, **kw)) as st:
        with pytest.raises(RunInterrupted):
            run_store(st, executor="inline", progress=False)
        n_stopped = st.count()
        assert 2048 < n_stopped < 12_000
        calls["n"] = -(10**9)
        run_store(st, executor="inline", progress=False)
    with Store.create(tmp_path / "b.db", banana_spec(**kw)) as st:
        run_store(st, executor="inline", progress=False)
    with Store.open(tmp_path / "a.db") as a, Store.open(tmp_path / "b.db") as b:
        ta, tb = a.load(), b.load()
        ga, gb = a.generations(), b.generations()
    assert len(np.unique(ta.seq)) == len(ta.seq), "a trial was stored twice"
    np.testing.assert_array_equal(ta.seq, tb.seq)
    np.testing.assert_array_equal(ta.X, tb.X)
    np.testing.assert_array_equal(ta.F, tb.F)
    assert [(g.seq_start, g.n, g.proposal) for g in ga] == [
        (g.seq_start, g.n, g.proposal) for g in gb
    ]
