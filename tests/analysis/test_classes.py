"""Colour classes partition the trials into N−ND, ND−NP and NP; decimation is seeded."""

import numpy as np
import pytest

from tests.analysis_helpers import make_store
from vectorid import Study
from vectorid.analysis.classes import point_classes, subsample


@pytest.fixture(scope="module")
def analysis(tmp_path_factory):
    path = make_store(tmp_path_factory.mktemp("cls"), trials=512)
    with Study.open(path) as st:
        yield st.analysis({"f1": 60.0})


def test_counts_are_n_minus_nd_nd_minus_np_np(analysis):
    a = analysis
    pc = point_classes(a)
    c = pc.counts()
    assert c["infeasible"] == a.n - a.n_feasible
    assert c["feasible"] == a.n_feasible - a.n_pareto
    assert c["pareto"] == a.n_pareto
    stacked = pc.infeasible.astype(int) + pc.feasible.astype(int) + pc.pareto.astype(int)
    assert np.all(stacked == 1)
    assert 0 < a.n_pareto < a.n_feasible < a.n


def test_subsample_is_seeded_sorted_subset():
    mask = np.zeros(1000, bool)
    mask[::3] = True
    a = subsample(mask, 50, seed=3)
    b = subsample(mask, 50, seed=3)
    assert np.array_equal(a, b) and len(a) == 50
    assert np.all(mask[a]) and np.all(np.diff(a) > 0)
    assert not np.array_equal(a, subsample(mask, 50, seed=4))
    assert np.array_equal(subsample(mask, None), np.flatnonzero(mask))
    assert np.array_equal(subsample(mask, 10_000), np.flatnonzero(mask))
