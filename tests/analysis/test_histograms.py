"""Histogram totals equal the feasible and Pareto counts; stages on common bins."""

import numpy as np
import pytest

from tests.analysis_helpers import make_store
from vectorid import Study
from vectorid.analysis.histograms import default_bins, histogram, histograms, stage_histograms
from vectorid.analysis.refine import propose_refine
from vectorid.space import Integer
from vectorid.workflows.extra import apply_refine


@pytest.fixture
def store(tmp_path):
    return make_store(tmp_path, trials=512)


def test_totals_equal_counts(store):
    with Study.open(store) as st:
        a = st.analysis({"f1": 50.0})
    hs = histograms(a, bins=13)
    assert [h.param for h in hs] == ["x1", "x2"]
    for h in hs:
        assert len(h.edges) == 14 and h.n_outside == 0
        assert h.all.sum() == a.n
        assert h.feasible.sum() == a.n_feasible
        assert h.pareto.sum() == a.n_pareto
        assert np.all(h.pareto <= h.feasible) and np.all(h.feasible <= h.all)


def test_counts_per_bin_match_a_direct_count():
    rng = np.random.default_rng(0)
    v = rng.uniform(0, 1, 1000)
    feas = v < 0.4
    par = v < 0.1
    h = histogram(v, feas, par, np.linspace(0, 1, 11))
    assert np.array_equal(h.all, np.histogram(v, np.linspace(0, 1, 11))[0])
    assert h.feasible[4:].sum() == 0 and h.pareto[1:].sum() == 0
    assert h.feasible.sum() == feas.sum()


def test_integer_variable_gets_one_bin_per_value(tmp_path):
    from vectorid.analysis.histograms import bin_edges

    edges = bin_edges(Integer("n", 2, 5), 2, 5, 20)
    assert np.allclose(edges, [1.5, 2.5, 3.5, 4.5, 5.5])


def test_default_bins_clipped():
    assert default_bins(4) == 10 and default_bins(10**6) == 50 and default_bins(400) == 20


def test_stage_histograms_after_refine(store):
    with Study.open(store, write=True) as st:
        a = st.analysis({"f1": 30.0})
        apply_refine(st.store, propose_refine(a, st.store.stages(), bounds={"x1": (0.5, 4.5)}))
        st.run(trials=768, executor="serial")
        a = st.analysis({"f1": 30.0})
        stages = [s for s in st.store.stages() if s.kind == "sample"]
    hs = stage_histograms(a, stages, "x1", bins=8)
    assert [h.stage for h in hs] == [0, 1]
    assert np.array_equal(hs[0].edges, hs[1].edges)
    assert hs[0].low == 0.0 and hs[0].high == 5.0
    assert [int(h.all.sum()) for h in hs] == [512, 256]
    assert sum(int(h.feasible.sum()) for h in hs) == a.n_feasible
    # the second stage drew only inside its box
    x1 = a.trials.X[a.trials.stage == 1, 0]
    assert x1.min() >= 0.5 and x1.max() <= 4.5
