"""Sensitivity: KS filtering and rank correlation on constructed data."""

import numpy as np
import pytest

from tests.analysis_helpers import make_store
from vectorid import Study
from vectorid.analysis.sensitivity import (
    ks_filtering,
    ks_of,
    ks_statistics,
    rank_correlation,
    sensitivity,
)
from vectorid.analysis.weights import weighted_ks


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


def test_ks_statistics_without_scipy_equal_scipys():
    """The numpy KS statistics (the UI's axis ranking) equal ks_filtering's (scipy's
    ks_2samp) unweighted and weighted_ks's weighted, on data with ties; NaN for an empty
    group; and ks_of(a) is sensitivity(a).ks."""
    rng = np.random.default_rng(5)
    X = np.column_stack([rng.random(700), rng.integers(0, 9, 700), rng.normal(size=700)])
    b = X[:, 0] + 0.05 * X[:, 1] < 0.6
    want, _ = ks_filtering(X, b)
    assert np.allclose(ks_statistics(X, b), want, rtol=0, atol=1e-12)
    w = rng.exponential(size=700)
    got = ks_statistics(X, b, w)
    for j in range(3):
        d, _ = weighted_ks(X[b, j], X[~b, j], w[b], w[~b])
        assert got[j] == pytest.approx(d, abs=1e-12)
    assert np.isnan(ks_statistics(X, np.zeros(700, bool))).all()
    assert want[0] > want[2]  # the deciding parameter ranks first: not a constant


def test_ks_of_equals_the_sensitivity_ks(tmp_path):
    path = make_store(tmp_path, trials=512)
    with Study.open(path) as s:
        a = s.analysis({"f1": 30.0})
    assert np.allclose(ks_of(a), sensitivity(a).ks, rtol=0, atol=1e-12)
