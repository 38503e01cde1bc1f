import numpy as np
import pytest

from vectorid import Criterion, FunctionalConstraint, Problem, StudyDefinitionError, as_batch
from vectorid.problem import FAILED, OK

CRIT = [Criterion("f1"), Criterion("f2", sense="max")]
CON = [FunctionalConstraint("g", high=1.0)]


def batch_model(X):
    if np.any(X[:, 0] < 0):
        raise ValueError("negative x0 is outside the model's validity")
    f = np.column_stack([X[:, 0] ** 2, np.sqrt(X[:, 1])])  # sqrt(<0) gives NaN
    return f, X[:, :1]


def test_good_batch():
    res = Problem(batch_model, CRIT, CON).evaluate(np.array([[1.0, 4.0], [2.0, 9.0]]))
    np.testing.assert_allclose(res.criteria, [[1, 2], [4, 3]])
    np.testing.assert_allclose(res.functionals, [[1], [2]])
    assert (res.status == OK).all() and res.messages == {}
    assert res.wall.shape == (2,) and (res.wall >= 0).all()


def test_raising_trial_isolated_by_bisection_and_nan_flagged():
    X = np.array([[1.0, 4.0], [-1.0, 4.0], [2.0, -1.0], [3.0, 1.0], [0.5, 0.25]])
    with np.errstate(invalid="ignore"):
        res = Problem(batch_model, CRIT, CON).evaluate(X)
    assert res.status.tolist() == [OK, FAILED, FAILED, OK, OK]
    assert "ValueError: negative x0" in res.messages[1]
    assert "test_problem.py" in res.messages[1]  # where it came from
    assert "non-finite" in res.messages[2] and "f2=nan" in res.messages[2]
    assert np.isnan(res.criteria[[1, 2]]).all()
    # good trials get exactly what they get alone
    alone = Problem(batch_model, CRIT, CON).evaluate(X[[0, 3, 4]])
    np.testing.assert_array_equal(res.criteria[[0, 3, 4]], alone.criteria)


def test_wrong_shape_fails_whole_batch_with_expected_shape():
    res = Problem(lambda X: (X[:, :1], X[:, :1]), CRIT, CON).evaluate(np.ones((3, 2)))
    assert (res.status == FAILED).all()
    assert "expected (3, 2)" in res.messages[0]


def test_missing_functionals_named():
    res = Problem(lambda X: X, CRIT, CON).evaluate(np.ones((2, 2)))
    assert (res.status == FAILED).all()
    assert "no functionals" in res.messages[0] and "g" in res.messages[0]


def test_per_trial_function_wrapped_once():
    calls = []

    def one(x):
        calls.append(x.shape)
        if x[0] > 2:
            raise RuntimeError("diverged")
        return [x[0], x[1]], [x[0] - 1]

    res = Problem(as_batch(one), CRIT, CON).evaluate(np.array([[1.0, 2.0], [3.0, 1.0]]))
    assert calls == [(2,), (2,)]
    assert res.status.tolist() == [OK, FAILED]
    assert res.messages[1].startswith("RuntimeError: diverged")
    np.testing.assert_allclose(res.criteria[0], [1, 2])


def test_per_trial_wrong_length():
    res = Problem(as_batch(lambda x: [1.0]), CRIT).evaluate(np.ones((1, 2)))
    assert res.status[0] == FAILED and "expected (2,)" in res.messages[0]


def test_inf_is_a_failure():
    res = Problem(lambda X: np.full((len(X), 2), np.inf), CRIT).evaluate(np.ones((2, 2)))
    assert (res.status == FAILED).all() and "f1=inf" in res.messages[0]


def test_problem_needs_criteria_and_unique_names():
    with pytest.raises(StudyDefinitionError, match="at least one criterion"):
        Problem(batch_model, [])
    with pytest.raises(StudyDefinitionError, match="more than once"):
        Problem(batch_model, [Criterion("a")], [FunctionalConstraint("a", high=1)])
