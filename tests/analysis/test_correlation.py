"""Correlation on constructed data with known correlation; merge and fix candidates."""

import numpy as np
import pytest

from vectorid.analysis.correlation import correlation, parameter_spread
from vectorid.errors import StudyDefinitionError


def _data(n=20_000, rho=0.9, seed=1):
    rng = np.random.default_rng(seed)
    a = rng.standard_normal(n)
    b = rho * a + np.sqrt(1 - rho**2) * rng.standard_normal(n)
    c = rng.standard_normal(n)
    d = -2.0 * c + 3.0  # exactly linear in c
    e = np.full(n, 0.7)  # constant
    return np.column_stack([a, b, c, d, e])


def test_known_correlation_recovered():
    X = _data()
    r = correlation(X, list("abcde"), threshold=0.8)
    assert r.matrix.shape == (5, 5)
    assert abs(r.matrix[0, 1] - 0.9) < 0.01
    assert abs(r.matrix[0, 2]) < 0.03
    assert r.matrix[2, 3] == pytest.approx(-1.0)
    assert np.allclose(np.diag(r.matrix), 1.0)
    assert np.allclose(r.matrix, r.matrix.T)
    # constant parameter: no correlation, proposed for fixing
    assert np.all(r.matrix[4, :4] == 0)
    assert r.fixed[0]["name"] == "e" and r.fixed[0]["median"] == 0.7
    pairs = {(d["a"], d["b"]): d for d in r.pairs}
    assert set(pairs) == {("a", "b"), ("c", "d")}
    cd = pairs[("c", "d")]
    assert cd["slope"] == pytest.approx(-2.0) and cd["intercept"] == pytest.approx(3.0)
    assert cd["r2"] == pytest.approx(1.0)
    assert r.pairs[0]["a"] == "c"  # strongest first
    assert sorted(map(sorted, r.groups)) == [["a", "b"], ["c", "d"]]


def test_spearman_sees_monotone_nonlinear_dependence():
    rng = np.random.default_rng(2)
    x = rng.uniform(0, 3, 5000)
    X = np.column_stack([x, np.exp(3 * x)])
    assert correlation(X, ["x", "y"], method="spearman").matrix[0, 1] == pytest.approx(1.0)
    assert correlation(X, ["x", "y"], method="pearson").matrix[0, 1] < 0.9


def test_groups_are_transitive_and_errors():
    rng = np.random.default_rng(3)
    a = rng.standard_normal(3000)
    X = np.column_stack(
        [a, a + 0.1 * rng.standard_normal(3000), a + 0.2 * rng.standard_normal(3000)]
    )
    r = correlation(X, ["p", "q", "s"], threshold=0.95)
    assert r.groups == [["p", "q", "s"]]
    with pytest.raises(StudyDefinitionError):
        correlation(X, ["p", "q", "s"], method="kendall")
    with pytest.raises(StudyDefinitionError):
        correlation(X, ["p", "q", "s"], threshold=0)


def test_parameter_spread_relative_to_nominal():
    V = np.array([[1.0, 0.5, 3.0], [2.0, 1.0, 4.0]])
    sp = parameter_spread(
        V, ["a", "b", "c"], np.array([1.0, 0.5, np.nan]), np.zeros(3), np.array([2.0, 2.0, 5.0])
    )
    np.testing.assert_allclose(sp.relative, [[1.0, 1.0, 0.6], [2.0, 2.0, 0.8]])
    assert list(sp.mode) == ["nominal", "nominal", "box"]
    assert sp.labels == ["set 1", "set 2"]
