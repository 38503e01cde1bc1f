import numpy as np
import pytest

from vectorid import Choice, Continuous, Integer, Space, StudyDefinitionError


def test_continuous_scaling_is_eq_10():
    v = Continuous("x", -2.0, 6.0)
    q = np.array([0.0, 0.25, 0.5, 0.999])
    np.testing.assert_allclose(v.from_unit(q), -2.0 + q * 8.0)


@pytest.mark.parametrize(
    ("low", "high", "match"),
    [(1.0, 0.0, "swap the bounds"), (1.0, 1.0, "equal bounds is a constant")],
)
def test_inverted_or_equal_bounds_rejected(low, high, match):
    with pytest.raises(StudyDefinitionError, match=match) as err:
        Continuous("x", low, high)
    assert err.value.field == "variables.x"


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), "abc", None])
def test_non_finite_bounds_rejected(bad):
    with pytest.raises(StudyDefinitionError, match="variables.x.low"):
        Continuous("x", bad, 1.0)


def test_nominal_outside_box_rejected():
    with pytest.raises(StudyDefinitionError, match="outside"):
        Continuous("x", 0.0, 1.0, nominal=2.0)


def test_integer_values_are_unbiased():
    v = Integer("n", 1, 4)
    q = (np.arange(40000) + 0.5) / 40000
    vals = v.from_unit(q)
    counts = np.array([(vals == k).sum() for k in range(1, 5)])
    # Equal cells: each value exactly a quarter (rounding eq. 10 would halve the ends).
    assert set(np.unique(vals)) == {1, 2, 3, 4}
    np.testing.assert_array_equal(counts, 10000)


def test_integer_rejects_fractional_bounds():
    with pytest.raises(StudyDefinitionError, match="whole-number"):
        Integer("n", 0.5, 3)


def test_choice_maps_cells_to_values():
    v = Choice("c", [10.0, 20.0, 40.0])
    q = np.array([0.0, 0.33, 0.34, 0.66, 0.67, 0.9999])
    np.testing.assert_array_equal(v.from_unit(q), [10, 10, 20, 20, 40, 40])


def test_choice_without_values_rejected():
    with pytest.raises(StudyDefinitionError, match="at least one value"):
        Choice("c", [])


def test_space_duplicate_names_rejected():
    with pytest.raises(StudyDefinitionError, match="duplicate"):
        Space([Continuous("x", 0, 1), Continuous("x", 0, 2)])


def test_space_scale_and_contains():
    s = Space([Continuous("a", 0, 10), Integer("b", 0, 2), Choice("c", [1.5, 2.5])])
    X = s.scale(np.array([[0.5, 0.5, 0.5], [0.0, 0.99, 0.1]]))
    np.testing.assert_allclose(X, [[5.0, 1.0, 2.5], [0.0, 2.0, 1.5]])
    assert s.contains(X).all()
    assert not s.contains(np.array([[11.0, 0, 1.5]])).any()


def test_with_bounds_narrows_and_checks_names():
    s = Space([Continuous("a", 0, 10, nominal=1.0), Continuous("b", 0, 1)])
    t = s.with_bounds({"a": (2.0, 4.0)})
    assert (t.variables[0].low, t.variables[0].high) == (2.0, 4.0)
    assert t.variables[0].nominal is None  # no longer inside
    with pytest.raises(StudyDefinitionError, match="did you mean 'a'"):
        s.with_bounds({"aa": (0, 1)})
