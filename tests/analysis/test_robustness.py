"""Robustness: neighbourhood construction, stored stage, verdicts on known functions."""

import numpy as np
import pytest

from tests.analysis_helpers import make_store
from vectorid import Study, analytic
from vectorid.analysis.robustness import (
    chosen_table,
    load_robustness,
    neighbourhood,
    robustness_stats,
)
from vectorid.errors import StudyDefinitionError
from vectorid.problem import FAILED, OK
from vectorid.space import Continuous, Integer, Space
from vectorid.workflows.extra import run_robustness


def test_neighbourhood_two_scales_inside_radius_and_box():
    space = Space([Continuous("a", 0, 10), Continuous("b", -1, 1), Integer("n", 0, 100)])
    x0 = np.array([9.95, 0.0, 50.0])
    X = neighbourhood(space, x0, radius=0.05, points=16, seed=4)
    assert X.shape == (17, 3) and np.array_equal(X[0], x0)
    assert np.all(space.contains(X))
    assert np.all(np.abs(X[:, :2] - x0[:2]) <= 0.05 * np.array([10, 2]) + 1e-12)
    assert np.all(X[:, 2] == np.round(X[:, 2]))
    d = X[1:5, :2] - x0[:2]
    np.testing.assert_allclose(X[5:9, :2] - x0[:2], -d)  # antithetic
    np.testing.assert_allclose(X[9:13, :2] - x0[:2], d / 2)  # half scale
    np.testing.assert_allclose(X[13:17, :2] - x0[:2], -d / 2)
    assert np.array_equal(X, neighbourhood(space, x0, radius=0.05, points=16, seed=4))
    assert len(neighbourhood(space, x0)) == 33
    with pytest.raises(StudyDefinitionError, match="radius"):
        neighbourhood(space, x0, radius=0)


def _stats(f, status=None, n=40, p=3, seed=0, x0=0.5):
    space = Space([Continuous(f"x{i}", 0, 1) for i in range(p)])
    X = neighbourhood(space, np.full(p, x0), radius=0.05, points=n, seed=seed)
    F = f(X)[:, None]
    st = np.zeros(len(X), np.int8) if status is None else status
    return robustness_stats(F, st, F[0])


def test_verdicts_on_known_functions():
    smooth = _stats(lambda X: np.sin(X.sum(axis=1)))
    assert smooth["verdicts"] == ["smooth"] and smooth["verdict"] == "smooth"
    assert smooth["score"][0] > 0.99
    # at an optimum (zero slope, cross curvature) a smooth response is still smooth
    bowl = _stats(
        lambda X: (
            (X - 0.5) @ np.array([[2.0, 1.0, 0], [1.0, 2.0, 0], [0, 0, 1.0]]) * (X - 0.5)
        ).sum(axis=1)
    )
    assert bowl["verdicts"] == ["smooth"] and bowl["score"][0] > 0.999
    rng = np.random.default_rng(0)
    rough = _stats(lambda X: rng.standard_normal(len(X)))
    assert rough["verdicts"] == ["rough"] and rough["verdict"].startswith("rough")
    kink = _stats(lambda X: np.abs(X[:, 0] - 0.5) + np.abs(X[:, 1] - 0.5))
    assert kink["verdicts"] == ["rough"]
    flat = _stats(lambda X: np.full(len(X), 3.0))
    assert flat["verdicts"] == ["flat"] and flat["verdict"] == "smooth"
    status = np.zeros(41, np.int8)
    status[5] = FAILED
    failed = _stats(lambda X: X[:, 0], status=status)
    assert failed["verdicts"] == ["failed"] and failed["verdict"].startswith("failed: 1 of 41")


def test_run_robustness_stores_a_stage_and_reads_back(tmp_path):
    path = make_store(tmp_path, trials=256)
    with Study.open(path, write=True) as s:
        a = s.analysis({"f1": 60.0})
        n = s.store.count_sample()
        r = run_robustness(s.store, 37, radius=0.01, points=12, seed=2, analysis=a)
        assert s.store.count_sample() == n and len(s.store.load()) == n
        kinds = {st.stage: st.kind for st in s.store.stages()}
        assert kinds[r.stage] == "robustness"
        back = load_robustness(s.store, a)
    direct, _ = analytic.get("binh-korn").evaluate(r.X)
    np.testing.assert_allclose(r.F, direct)
    np.testing.assert_allclose(r.F[0], r.f0)  # the trial re-evaluated equals the stored one
    assert r.verdict == "smooth" and all(v == "smooth" for v in r.verdicts)
    assert np.all(r.status == OK) and len(r.X) == 13
    assert 0.0 <= r.feasible_fraction <= 1.0
    assert len(back) == 1 and back[0].trial == 37 and back[0].radius == 0.01
    np.testing.assert_allclose(back[0].F, r.F)
    assert back[0].verdict == r.verdict


def test_chosen_table_min_max(tmp_path):
    path = make_store(tmp_path, trials=128)
    with Study.open(path) as s:
        a = s.analysis()
    t = chosen_table(a, [110, 71, 88])
    assert list(t.ids) == [110, 71, 88]
    F = np.array([a.trials.F[a.trials.id == i][0] for i in (110, 71, 88)])
    np.testing.assert_allclose(t.F, F)
    np.testing.assert_allclose(t.min, F.min(axis=0))
    np.testing.assert_allclose(t.max, F.max(axis=0))
    with pytest.raises(StudyDefinitionError):
        chosen_table(a, [99999])
