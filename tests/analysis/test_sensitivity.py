"""Sensitivity: KS filtering and rank correlation on constructed data."""

import numpy as np
import pytest

from tests.analysis_helpers import make_store
from vectorid import Study
from vectorid.analysis.sensitivity import ks_filtering, rank_correlation, sensitivity


def test_ks_separates_the_parameter_that_decides_feasibility():
    rng = np.random.default_rng(0)
    X = rng.uniform(size=(4000, 3))
    feasible = X[:, 1] < 0.3
    ks, p = ks_filtering(X, feasible)
    assert ks[1] == pytest.approx(1.0)  # disjoint supports
    assert ks[0] < 0.06 and ks[2] < 0.06
    assert p[1] < 1e-10 and p[0] > 1e-4
    nan_ks, _ = ks_filtering(X, np.zeros(4000, bool))
    assert np.all(np.isnan(nan_ks))


def test_rank_correlation_of_monotone_and_independent():
    rng = np.random.default_rng(1)
    X = rng.uniform(size=(3000, 2))
    F = np.column_stack([X[:, 0] ** 3, -np.exp(X[:, 1]), rng.uniform(size=3000)])
    F[5, 2] = np.nan  # rows with a NaN criterion are dropped
    R = rank_correlation(X, F)
    assert R.shape == (2, 3)
    assert R[0, 0] == pytest.approx(1.0) and R[1, 1] == pytest.approx(-1.0)
    assert abs(R[0, 2]) < 0.06 and abs(R[1, 0]) < 0.06


def test_sensitivity_of_a_study(tmp_path):
    path = make_store(tmp_path, trials=512)
    with Study.open(path) as s:
        a = s.analysis({"f1": 30.0})
    sens = sensitivity(a)
    assert sens.n_behavioural == a.n_feasible and sens.n_other == a.n - a.n_feasible
    assert sens.spearman.shape == (2, 2)
    # f1 = 4 x1² + 4 x2² increases with both parameters
    assert np.all(sens.spearman[:, 0] > 0.3)
    assert [n for n, _ in sens.ranking()] == sorted(
        sens.params, key=lambda n: -sens.ks[sens.params.index(n)]
    )
