"""Sections: new trials equal direct model evaluations and stay out of the sample."""

import numpy as np
import pytest

from tests.analysis_helpers import make_store
from vectorid import Study, analytic
from vectorid.analysis.sections import load_sections, section_points
from vectorid.errors import StudyDefinitionError
from vectorid.space import Choice, Continuous, Integer, Space
from vectorid.workflows.extra import run_section


@pytest.fixture
def store(tmp_path):
    return make_store(tmp_path, trials=256)


def test_section_values_equal_direct_evaluations(store):
    with Study.open(store, write=True) as st:
        n_before = st.store.count_sample()
        sec = run_section(st.store, 100, "x2", points=11, value_range=(0.5, 2.5))
        trials = st.store.load()
        x0 = trials.X[trials.id == 100][0]
        f0 = trials.F[trials.id == 100][0]
        assert st.store.count_sample() == n_before  # sample statistics untouched
        assert len(trials) == n_before
        kinds = {s.stage: s.kind for s in st.store.stages()}
        assert kinds[sec.stage] == "section"
        loaded = load_sections(st.store)
    direct, _ = analytic.get("binh-korn").evaluate(sec.X)
    np.testing.assert_allclose(sec.F, direct, rtol=0, atol=0)
    assert sec.values[0] == 0.5 and sec.values[-1] == 2.5
    assert np.all(np.diff(sec.values) > 0)
    # every other parameter is fixed at the trial's value
    assert np.all(sec.X[:, 0] == x0[0])
    if 0.5 <= x0[1] <= 2.5:  # the trial itself is on the section, with its stored criteria
        row = np.flatnonzero(sec.values == x0[1])
        np.testing.assert_allclose(sec.F[row[0]], f0)
    assert len(loaded) == 1
    np.testing.assert_array_equal(loaded[0].values, sec.values)
    np.testing.assert_array_equal(loaded[0].F, sec.F)
    assert loaded[0].trial == 100 and loaded[0].param == "x2"
    assert loaded[0].ids[0] == sec.stage * 1_000_000_000 + 1


def test_section_points_kinds():
    space = Space([Continuous("a", 0, 1), Integer("n", 1, 40), Choice("c", [1.0, 2.0, 5.0])])
    x0 = np.array([0.3, 7.0, 2.0])
    vals, X = section_points(space, x0, "a", 5)
    assert np.allclose(vals, [0, 0.25, 0.3, 0.5, 0.75, 1.0])
    assert np.all(X[:, 1:] == x0[1:])
    vals, _ = section_points(space, x0, "n", 5)
    assert np.all(vals == np.round(vals)) and vals.min() == 1 and vals.max() == 40
    assert 7.0 in vals
    vals, _ = section_points(space, x0, "c", 5, (1.5, 10))
    assert list(vals) == [2.0, 5.0]


def test_section_input_errors(store):
    space = Space([Continuous("a", 0, 1)])
    with pytest.raises(StudyDefinitionError, match="LO < HI"):
        section_points(space, np.array([0.5]), "a", 5, (1.0, 0.0))
    with pytest.raises(StudyDefinitionError, match="at least 2"):
        section_points(space, np.array([0.5]), "a", 1)
    with pytest.raises(StudyDefinitionError, match="unknown variable"):
        section_points(space, np.array([0.5]), "b", 5)
    with Study.open(store, write=True) as st:
        with pytest.raises(StudyDefinitionError, match="no stored trial"):
            run_section(st.store, 10**6, "x1")


def test_sections_through_a_point_are_the_intervals_inside_the_limits():
    from vectorid.analysis.sections import sections_through

    def evaluate(X):  # f = |x - 1| + |y - 2|, g = |y - 2|
        F = np.column_stack([np.abs(X[:, 0] - 1) + np.abs(X[:, 1] - 2), np.abs(X[:, 1] - 2)])
        return F, np.zeros((len(X), 0))

    boxes = {"x": (0.0, 4.0), "y": (0.0, 4.0)}
    sec = sections_through(evaluate, [1.0, 2.0], ["x", "y"], ["f", "g"], {"f": 0.5}, boxes,
                           points=41)  # fmt: skip
    assert sec["x"] == pytest.approx((0.5, 1.5), abs=0.1)
    assert sec["y"] == pytest.approx((1.5, 2.5), abs=0.1)
    assert sec["x"][0] <= 1.0 <= sec["x"][1]
    # a second limit cuts y only
    sec = sections_through(evaluate, [1.0, 2.0], ["x", "y"], ["f", "g"],
                           {"f": 0.5, "g": 0.2}, boxes, points=41)  # fmt: skip
    assert sec["y"][1] - sec["y"][0] < 0.5 and sec["x"] == pytest.approx((0.5, 1.5), abs=0.1)
    # a point outside the limits: no interval
    assert sections_through(evaluate, [3.0, 2.0], ["x", "y"], ["f", "g"], {"f": 0.5},
                            boxes)["x"] is None  # fmt: skip
    with pytest.raises(StudyDefinitionError):
        sections_through(evaluate, [1.0], ["x", "y"], ["f", "g"], {"f": 0.5}, boxes)
