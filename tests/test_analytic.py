"""Tests for vectorid.analytic: analytic test problems with known Pareto sets."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.stats import qmc

from vectorid.analytic import (
    AnalyticProblem,
    available,
    get,
    osyczka_kundu_vertices,
    tanaka_angle_intervals,
    zdt3_intervals,
)

# (p, k, q) from the literature definitions (standard sizes: ZDT p = 30, DTLZ2 k = 10).
EXPECTED_DIMS = {
    "binh-korn": (2, 2, 2),
    "binh-korn-max": (2, 2, 2),
    "dtlz2-3": (12, 3, 0),
    "dtlz2-5": (14, 5, 0),
    "osyczka-kundu": (6, 2, 6),
    "tanaka": (2, 2, 2),
    "zdt1": (30, 2, 0),
    "zdt2": (30, 2, 0),
    "zdt3": (30, 2, 0),
}
ALL = sorted(EXPECTED_DIMS)
ALL_PLUS_VARIANTS = [*ALL, "zdt1-4", "zdt3-3", "dtlz2-4-k3"]

# ZDT3 Pareto-set x1 intervals as published (Deb 2001; pymoo, jMetal reference fronts).
ZDT3_LITERATURE = np.array(
    [
        [0.0, 0.0830015349],
        [0.1822287280, 0.2577623634],
        [0.4093136748, 0.4538821041],
        [0.6183967944, 0.6525117038],
        [0.8233317983, 0.8518328654],
    ]
)


# ---- helpers (independent of vectorid.analysis) ------------------------------------------


def to_min(problem: AnalyticProblem, F: np.ndarray) -> np.ndarray:
    sign = np.array([-1.0 if s == "max" else 1.0 for s in problem.senses])
    return F * sign


def dominated(F: np.ndarray) -> np.ndarray:
    """Brute force: True where some other row is <= everywhere and < somewhere (minimise)."""
    le = (F[:, None, :] <= F[None, :, :]).all(axis=2)  # le[i, j]: i weakly better than j
    lt = (F[:, None, :] < F[None, :, :]).any(axis=2)
    return (le & lt).any(axis=0)


def dominated_by(A: np.ndarray, B: np.ndarray, margin: float = 0.0) -> np.ndarray:
    """For each row of B: whether some row of A is better by > margin in all criteria."""
    out = np.zeros(B.shape[0], dtype=bool)
    for start in range(0, A.shape[0], 2000):
        a = A[start : start + 2000]
        out |= (a[:, None, :] < B[None, :, :] - margin).all(axis=2).any(axis=0)
    return out


def dominated_by_2d(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Bi-criteria ``dominated_by`` (strict in both criteria) via a sorted prefix minimum."""
    order = np.argsort(A[:, 0], kind="stable")
    a1 = A[order, 0]
    prefix_min = np.minimum.accumulate(A[order, 1])
    count = np.searchsorted(a1, B[:, 0], side="left")  # rows with a1 < b1
    best = np.where(count > 0, prefix_min[np.maximum(count - 1, 0)], np.inf)
    return best < B[:, 1]


def nearest_distance(P: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """Euclidean distance from each row of P to the nearest row of Q."""
    return np.sqrt(((P[:, None, :] - Q[None, :, :]) ** 2).sum(axis=2)).min(axis=1)


def random_box(problem: AnalyticProblem, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return problem.lower + rng.random((n, problem.n_var)) * (problem.upper - problem.lower)


def front_distance(problem: AnalyticProblem, F: np.ndarray) -> np.ndarray:
    """Range-normalised distance of criteria points to a dense sample of the true front."""
    dense = problem.pareto_front(20001)
    span = np.ptp(dense, axis=0)
    return nearest_distance(F / span, dense / span)


# ---- registry --------------------------------------------------------------------------


def test_available_matches_documented_registry() -> None:
    assert available() == ALL
    for name, (p, k, q) in EXPECTED_DIMS.items():
        prob = get(name)
        assert prob.name == name
        assert (prob.n_var, prob.n_obj, prob.n_con) == (p, k, q)
        assert prob.lower.shape == prob.upper.shape == (p,)
        assert np.all(prob.lower < prob.upper)
        assert set(prob.senses) <= {"min", "max"}
        assert prob.title and prob.residual_definition


def test_get_unknown_name_lists_names_and_suggests_nearest() -> None:
    with pytest.raises(ValueError, match="binh-kron") as info:
        get("binh-kron")
    msg = str(info.value)
    assert "Did you mean 'binh-korn'?" in msg
    for name in ALL:
        assert name in msg
    with pytest.raises(ValueError, match="Did you mean 'tanaka'"):
        get("tanka")
    with pytest.raises(TypeError):
        get(3)  # type: ignore[arg-type]


def test_get_parametrised_and_normalised_names() -> None:
    z = get("zdt1-6")
    assert (z.name, z.n_var, z.n_obj) == ("zdt1-6", 6, 2)
    d = get("dtlz2-4-k3")
    assert (d.name, d.n_var, d.n_obj) == ("dtlz2-4-k3", 6, 4)
    assert get("dtlz2-4").n_var == 13
    assert get("ZDT2").name == "zdt2"
    assert get("binh_korn max").name == "binh-korn-max"
    assert get("zdt1-30").n_var == 30
    for bad in ("zdt1-1", "dtlz2-1", "dtlz2-3-k0", "zdt4"):
        with pytest.raises(ValueError):
            get(bad)


def test_problem_validation_and_not_implemented() -> None:
    with pytest.raises(ValueError, match="sense"):
        AnalyticProblem("x", "t", (("a", 0.0, 1.0),), (("f", "best"),), ())
    with pytest.raises(ValueError, match="low < high"):
        AnalyticProblem("x", "t", (("a", 1.0, 1.0),), (("f", "min"),), ())
    bare = AnalyticProblem("x", "t", (("a", 0.0, 1.0),), (("f", "min"),), ())
    with pytest.raises(NotImplementedError):
        bare.evaluate(np.zeros((1, 1)))
    with pytest.raises(NotImplementedError):
        bare.pareto_front(3)


# ---- shapes, dtypes, vectorisation ------------------------------------------------------


@pytest.mark.parametrize("name", ALL_PLUS_VARIANTS)
@pytest.mark.parametrize("n", [0, 1, 1000])
def test_shapes_and_dtypes(name: str, n: int) -> None:
    prob = get(name)
    X = random_box(prob, n, seed=n)
    F, G = prob.evaluate(X)
    assert F.shape == (n, prob.n_obj) and F.dtype == np.float64
    assert G.shape == (n, prob.n_con) and G.dtype == np.float64
    r = prob.pareto_set_residual(X)
    assert r.shape == (n,) and r.dtype == np.float64
    assert prob.feasible(X).shape == (n,)
    front = prob.pareto_front(n)
    pset = prob.pareto_set(n)
    assert front.dtype == np.float64 and pset.dtype == np.float64
    assert front.shape[1] == prob.n_obj and pset.shape[1] == prob.n_var
    assert front.shape[0] == pset.shape[0]
    if prob.n_obj == 2 or n <= 1:
        assert front.shape[0] == n
    else:  # Das–Dennis lattice closest in size
        assert abs(front.shape[0] - n) <= 0.1 * n


@pytest.mark.parametrize("name", ALL)
def test_bad_inputs_are_rejected(name: str) -> None:
    prob = get(name)
    with pytest.raises(ValueError, match=r"shape \(n, "):
        prob.evaluate(np.zeros(prob.n_var))
    with pytest.raises(ValueError, match="shape"):
        prob.pareto_set_residual(np.zeros((3, prob.n_var + 1)))
    with pytest.raises(ValueError, match=">= 0"):
        prob.pareto_front(-1)
    with pytest.raises(TypeError):
        prob.pareto_front(2.5)  # type: ignore[arg-type]


@pytest.mark.parametrize("name", ALL_PLUS_VARIANTS)
def test_batch_equals_row_by_row(name: str) -> None:
    prob = get(name)
    X = random_box(prob, 40, seed=7)
    X[0] = prob.lower  # box corners included (e.g. x2 = 0 for Tanaka's atan2)
    X[1] = prob.upper
    F, G = prob.evaluate(X)
    r = prob.pareto_set_residual(X)
    for i in range(X.shape[0]):
        Fi, Gi = prob.evaluate(X[i : i + 1])
        assert_allclose(Fi[0], F[i], rtol=1e-13, atol=1e-13)
        assert_allclose(Gi[0], G[i], rtol=1e-13, atol=1e-13)
        assert_allclose(prob.pareto_set_residual(X[i : i + 1])[0], r[i], rtol=1e-13, atol=1e-15)


# ---- generic Pareto-set properties --------------------------------------------------------


@pytest.mark.parametrize("name", ALL_PLUS_VARIANTS)
def test_pareto_set_is_feasible_in_box_with_zero_residual(name: str) -> None:
    prob = get(name)
    S = prob.pareto_set(400)
    assert np.all(S >= prob.lower) and np.all(S <= prob.upper)
    assert prob.feasible(S, atol=1e-12).all()
    assert_allclose(prob.pareto_set_residual(S), 0.0, atol=1e-12)
    assert_allclose(prob.evaluate(S)[0], prob.pareto_front(400), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("name", ALL_PLUS_VARIANTS)
def test_front_points_are_mutually_non_dominated(name: str) -> None:
    prob = get(name)
    F = to_min(prob, prob.pareto_front(600))
    assert not dominated(F).any()


@pytest.mark.parametrize("name", ALL_PLUS_VARIANTS)
def test_random_points_have_non_negative_residual_and_do_not_beat_front(name: str) -> None:
    prob = get(name)
    X = random_box(prob, 20000, seed=11)
    r = prob.pareto_set_residual(X)
    assert np.all(np.isfinite(r)) and np.all(r >= 0)
    assert np.mean(r > 1e-6) > 0.99  # random points are almost never on the Pareto set
    feas = prob.feasible(X)
    front = to_min(prob, prob.pareto_front(500))
    Fr = to_min(prob, prob.evaluate(X[feas])[0])
    assert not dominated_by(Fr, front, margin=1e-9).any()


# ---- Binh–Korn --------------------------------------------------------------------------


def test_binh_korn_known_pareto_solutions_and_literature_front() -> None:
    prob = get("binh-korn")
    t = np.linspace(0.0, 3.0, 31)
    s = np.linspace(3.0, 5.0, 21)
    X = np.concatenate([np.c_[t, t], np.c_[s, np.full_like(s, 3.0)]])
    F, _ = prob.evaluate(X)
    # closed forms on the two branches
    assert_allclose(F[:31], np.c_[8 * t**2, 2 * (5 - t) ** 2], rtol=1e-14)
    assert_allclose(F[31:], np.c_[4 * s**2 + 36, (s - 5) ** 2 + 4], rtol=1e-14)
    assert_allclose(prob.pareto_set_residual(X), 0.0, atol=1e-14)
    assert front_distance(prob, F).max() < 1e-3
    # literature extremes: f1 ∈ [0, 136], f2 ∈ [4, 50]
    front = prob.pareto_front(1001)
    assert_allclose(front[0], [0.0, 50.0], atol=1e-12)
    assert_allclose(front[-1], [136.0, 4.0], atol=1e-12)
    assert_allclose(front.min(axis=0), [0.0, 4.0], atol=1e-12)
    assert_allclose(front.max(axis=0), [136.0, 50.0], atol=1e-12)
    # every front point on the analytic curve f2(f1)
    f1 = front[:, 0]
    lower = f1 <= 72.0
    t_ = np.sqrt(f1[lower] / 8.0)
    assert_allclose(front[lower, 1], 2 * (5 - t_) ** 2, rtol=1e-10)
    s_ = np.sqrt((f1[~lower] - 36.0) / 4.0)
    assert_allclose(front[~lower, 1], (s_ - 5) ** 2 + 4, rtol=1e-10)


def test_binh_korn_constraints_and_residual_values() -> None:
    prob = get("binh-korn")
    X = np.array([[0.0, 0.0], [5.0, 3.0], [0.0, 3.0], [7.0, -2.0], [1.0, 0.0]])
    _, G = prob.evaluate(X)
    assert_allclose(G, [[25.0, 73.0], [9.0, 45.0], [34.0, 100.0], [8.0, 2.0], [16.0, 58.0]])
    assert prob.feasible(X).tolist() == [True, True, False, False, True]
    # (1, 0) is feasible but off the Pareto set: distance to the line x1 = x2 is 1/sqrt(2)
    assert_allclose(prob.pareto_set_residual(X[4:]), [1.0 / math.sqrt(2.0)], rtol=1e-14)
    # (5, 0): nearest Pareto point is (5, 3)
    assert_allclose(prob.pareto_set_residual(np.array([[5.0, 0.0]])), [3.0], rtol=1e-14)


def test_binh_korn_max_is_negated_second_criterion() -> None:
    base, mx = get("binh-korn"), get("binh-korn-max")
    assert mx.senses == ("min", "max") and base.senses == ("min", "min")
    X = random_box(base, 100, seed=3)
    Fb, Gb = base.evaluate(X)
    Fm, Gm = mx.evaluate(X)
    assert_allclose(Fm, np.c_[Fb[:, 0], -Fb[:, 1]])
    assert_allclose(Gm, Gb)
    assert_allclose(mx.pareto_set_residual(X), base.pareto_set_residual(X))
    assert_allclose(to_min(mx, mx.pareto_front(50)), base.pareto_front(50))
    # treating the max column as min would make the front dominated almost everywhere
    assert dominated(mx.pareto_front(50)).any()


# ---- ZDT ------------------------------------------------------------------------------------


def zdt_h(which: int, f1: np.ndarray, g: float = 1.0) -> np.ndarray:
    """Literature ZDT shapes: f2 = g h(f1, g); the Pareto front is f2 = h(f1, 1)."""
    r = f1 / g
    if which == 1:
        return 1 - np.sqrt(r)
    if which == 2:
        return 1 - r**2
    return 1 - np.sqrt(r) - r * np.sin(10 * np.pi * f1)


@pytest.mark.parametrize("name", ["zdt1", "zdt2", "zdt3", "zdt1-4", "zdt2-2", "zdt3-3"])
def test_zdt_known_pareto_solutions(name: str) -> None:
    prob = get(name)
    which = int(name[3])
    rng = np.random.default_rng(5)
    if which == 3:
        iv = ZDT3_LITERATURE
        k = rng.integers(0, 5, 300)
        x1 = iv[k, 0] + rng.random(300) * (iv[k, 1] - iv[k, 0])
    else:
        x1 = rng.random(300)
    X = np.zeros((300, prob.n_var))
    X[:, 0] = x1
    F, G = prob.evaluate(X)
    assert G.shape == (300, 0)
    assert_allclose(F[:, 0], x1)
    assert_allclose(F[:, 1], zdt_h(which, x1), rtol=1e-12, atol=1e-14)
    assert_allclose(prob.pareto_set_residual(X), 0.0, atol=1e-7 if which == 3 else 0.0)
    assert front_distance(prob, F).max() < 1e-3
    front = prob.pareto_front(2001)
    assert_allclose(front[:, 1], zdt_h(which, front[:, 0]), rtol=1e-12, atol=1e-14)
    # off the set: x2..xp = 0.5 gives g = 5.5, residual g - 1 = 4.5
    X[:, 1:] = 0.5
    assert_allclose(prob.pareto_set_residual(X), 4.5, rtol=1e-13, atol=1e-7)
    F_off, _ = prob.evaluate(X)
    assert_allclose(F_off[:, 1], 5.5 * zdt_h(which, x1, 5.5), rtol=1e-12)


def test_zdt3_intervals_match_literature_and_front_is_disconnected() -> None:
    assert_allclose(zdt3_intervals(), ZDT3_LITERATURE, atol=5e-10)
    prob = get("zdt3")
    front = prob.pareto_front(3000)
    assert np.all(np.diff(front[:, 0]) > 0)
    gaps = np.diff(front[:, 0]) > 0.05
    assert gaps.sum() == 4  # five pieces
    for lo, hi in ZDT3_LITERATURE:
        inside = (front[:, 0] >= lo - 1e-9) & (front[:, 0] <= hi + 1e-9)
        assert inside.any()
    inside_any = np.zeros(len(front), dtype=bool)
    for lo, hi in ZDT3_LITERATURE:
        inside_any |= (front[:, 0] >= lo - 1e-9) & (front[:, 0] <= hi + 1e-9)
    assert inside_any.all()
    # lowest point at the right end of the last interval; literature f2 ∈ [-0.7734, 1]
    assert_allclose(front[:, 1].min(), zdt_h(3, ZDT3_LITERATURE[-1, 1]), atol=1e-9)
    assert_allclose(front[:, 1].min(), -0.7734, atol=5e-5)
    # x1 between pieces (g = 1) is dominated: residual = distance to the nearest interval
    X = np.zeros((2, 30))
    X[:, 0] = [0.12, 0.3]
    assert_allclose(
        prob.pareto_set_residual(X), [0.12 - 0.0830015349, 0.3 - 0.2577623634], atol=1e-9
    )


# ---- DTLZ2 -------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["dtlz2-3", "dtlz2-5", "dtlz2-4-k3"])
def test_dtlz2_known_pareto_solutions_on_unit_sphere(name: str) -> None:
    prob = get(name)
    M = prob.n_obj
    rng = np.random.default_rng(9)
    X = np.full((500, prob.n_var), 0.5)
    X[:, : M - 1] = rng.random((500, M - 1))
    F, _ = prob.evaluate(X)
    assert np.all(F >= -1e-15)
    assert_allclose((F**2).sum(axis=1), 1.0, rtol=1e-13)
    assert_allclose(prob.pareto_set_residual(X), 0.0, atol=0.0)
    # distance variables at 0: g = (p - M + 1) / 4, |f| = 1 + g
    X[:, M - 1 :] = 0.0
    g = (prob.n_var - M + 1) / 4.0
    assert_allclose(prob.pareto_set_residual(X), g, rtol=1e-14)
    assert_allclose(np.linalg.norm(prob.evaluate(X)[0], axis=1), 1.0 + g, rtol=1e-13)
    front = prob.pareto_front(300)
    assert_allclose((front**2).sum(axis=1), 1.0, rtol=1e-13)
    assert np.all(front >= 0)
    # the lattice contains the M corner points e_m
    for m in range(M):
        e = np.zeros(M)
        e[m] = 1.0
        assert nearest_distance(e[None], front)[0] < 1e-12


def test_dtlz2_literature_values() -> None:
    prob = get("dtlz2-3")
    X = np.full((3, 12), 0.5)
    X[1, :2] = [0.0, 0.0]  # theta = 0 -> f = (1, 0, 0)
    X[2, :2] = [1.0, 0.3]  # x1 = 1 -> f = (0, 0, 1)
    F, _ = prob.evaluate(X)
    c = math.cos(math.pi / 4)
    assert_allclose(F[0], [c * c, c * c, c], rtol=1e-14)
    assert_allclose(F[1], [1.0, 0.0, 0.0], atol=1e-15)
    assert_allclose(F[2], [0.0, 0.0, 1.0], atol=1e-15)
    # f1 = cos θ1 cos θ2, f2 = cos θ1 sin θ2, f3 = sin θ1 (Deb et al. 2002)
    x = np.array([[0.2, 0.7] + [0.5] * 10])
    t1, t2 = 0.2 * math.pi / 2, 0.7 * math.pi / 2
    expected = [math.cos(t1) * math.cos(t2), math.cos(t1) * math.sin(t2), math.sin(t1)]
    assert_allclose(prob.evaluate(x)[0][0], expected, rtol=1e-14)


# ---- Tanaka -------------------------------------------------------------------------------


def test_tanaka_constraints_on_known_points() -> None:
    prob = get("tanaka")
    X = np.array([[1.0, 1.0], [0.5, 0.5], [1.5, 1.5], [1.0, 0.0], [1.05, 0.2]])
    F, G = prob.evaluate(X)
    assert_allclose(F, X)
    c1_last = 1.05**2 + 0.2**2 - 1 - 0.1 * math.cos(16 * math.atan(1.05 / 0.2))
    assert_allclose(G[:, 0], [0.9, -0.6, 3.4, -0.1, c1_last], rtol=1e-13, atol=1e-15)
    assert_allclose(G[:, 1], [0.5, 0.0, 2.0, 0.5, 0.3925], rtol=1e-14)
    assert prob.feasible(X).tolist() == [True, False, False, False, True]


def test_tanaka_front_matches_brute_force_grid() -> None:
    prob = get("tanaka")
    S = prob.pareto_set(800)
    F, G = prob.evaluate(S)
    assert_allclose(G[:, 0], 0.0, atol=1e-12)  # on the c1 boundary
    assert np.all(G[:, 1] <= 0.5 + 1e-12)
    assert_allclose(np.sort(F[:, 0]), np.sort(F[:, 1]), atol=2e-3)  # x1 <-> x2 symmetry
    h = 1.2 / 1200
    g = np.arange(0.0, 1.2 + h / 2, h)
    X = np.stack(np.meshgrid(g, g), axis=-1).reshape(-1, 2)
    X = X[prob.feasible(X)]
    # (1) no feasible grid point dominates a front point
    assert not dominated_by_2d(X, F).any()
    assert dominated_by_2d(X, F + 2 * h).all()  # ... but the grid does reach the front
    # (2) every non-dominated grid point lies within a few grid steps of the front
    order = np.lexsort((X[:, 1], X[:, 0]))
    Xs = X[order]
    run_min = np.minimum.accumulate(Xs[:, 1])
    nd = np.r_[True, Xs[1:, 1] < run_min[:-1]]
    dense = prob.pareto_front(20001)
    assert nd.sum() > 100
    assert nearest_distance(Xs[nd], dense).max() < 3 * h
    # five disconnected pieces, symmetric intervals
    iv = tanaka_angle_intervals()
    assert iv.shape == (5, 2)
    assert_allclose(iv[::-1, ::-1], np.pi / 2 - iv, atol=1e-14)


# ---- Osyczka–Kundu ------------------------------------------------------------------------


def osy_deb_table(n: int, seed: int) -> np.ndarray:
    """Interior points of the five Pareto regions tabulated by Deb (2001), x4 = x6 = 0."""
    rng = np.random.default_rng(seed)
    u = rng.random(n)
    rows = []
    rows.append(np.c_[np.full(n, 5.0), np.ones(n), 1 + 4 * u, 0 * u, np.full(n, 5.0), 0 * u])
    rows.append(np.c_[np.full(n, 5.0), np.ones(n), 1 + 4 * u, 0 * u, np.ones(n), 0 * u])
    x1 = 4.057 + (5 - 4.057) * u
    rows.append(np.c_[x1, (x1 - 2) / 3, np.ones(n), 0 * u, np.ones(n), 0 * u])
    rows.append(np.c_[0 * u, np.full(n, 2.0), 1 + 2.731 * u, 0 * u, np.ones(n), 0 * u])
    rows.append(np.c_[u, 2 - u, np.ones(n), 0 * u, np.ones(n), 0 * u])
    return np.concatenate(rows)


def test_osyczka_kundu_known_pareto_solutions() -> None:
    prob = get("osyczka-kundu")
    X = osy_deb_table(100, seed=2)
    assert prob.feasible(X, atol=1e-12).all()
    assert_allclose(prob.pareto_set_residual(X), 0.0, atol=1e-12)
    F, _ = prob.evaluate(X)
    assert front_distance(prob, F).max() < 1e-3
    # literature vertices: D at x1 ≈ 4.056 (CD) and x3 ≈ 3.732 (DE); extremes of the front
    V = osyczka_kundu_vertices()
    assert abs(V[2, 1, 0] - 4.056) < 1e-3
    assert abs(V[3, 0, 2] - 3.732) < 1e-3
    front = prob.pareto_front(1000)
    assert_allclose(front[0], [-274.0, 76.0], atol=1e-10)
    assert_allclose(front[-1], [-42.0, 4.0], atol=1e-10)
    for vertex in ([-258.0, 52.0], [-242.0, 28.0], [-116.0, 6.0]):  # B, C, E
        assert nearest_distance(np.array([vertex]), prob.pareto_front(20001))[0] < 0.05


def test_osyczka_kundu_constraints_on_known_points() -> None:
    prob = get("osyczka-kundu")
    X = np.array(
        [
            [5.0, 1.0, 5.0, 0.0, 5.0, 0.0],  # A: feasible, c5 = c6 = 0
            [0.0, 0.0, 3.0, 0.0, 1.0, 0.0],  # c1 = -2
            [5.0, 1.0, 5.0, 0.0, 3.0, 0.0],  # c6 = -4
            [3.0, 4.0, 3.0, 5.0, 1.0, 0.0],  # c2 = -1, c5 = -1
        ]
    )
    _, G = prob.evaluate(X)
    assert_allclose(
        G,
        [
            [4.0, 0.0, 6.0, 0.0, 0.0, 0.0],
            [-2.0, 6.0, 2.0, 2.0, 4.0, 0.0],
            [4.0, 0.0, 6.0, 0.0, 0.0, -4.0],
            [5.0, -1.0, 1.0, 11.0, -1.0, 0.0],
        ],
    )
    assert prob.feasible(X).tolist() == [True, False, False, False]
    F, _ = prob.evaluate(X[:1])
    assert_allclose(F, [[-274.0, 76.0]])
    # feasible but off the set: distance to the nearest segment point (A-B line at x6 = 0)
    off = np.array([[5.0, 1.0, 3.0, 0.0, 5.0, 2.0]])
    assert prob.feasible(off).all()
    assert_allclose(prob.pareto_set_residual(off), [2.0], rtol=1e-14)


# ---- sampling: Sobol trials approach the Pareto set -----------------------------------------


@pytest.mark.parametrize("name", ["zdt1-2", "zdt1-3"])
def test_sobol_non_dominated_subset_approaches_pareto_set(name: str) -> None:
    prob = get(name)
    X = qmc.Sobol(prob.n_var, scramble=False).random(4096)  # starts at the origin
    assert np.all(X[0] == 0)
    means, igd = [], []
    front = prob.pareto_front(500)
    for n in (1024, 4096):
        F, _ = prob.evaluate(X[:n])
        nd = ~dominated(F)
        means.append(prob.pareto_set_residual(X[:n][nd]).mean())
        igd.append(nearest_distance(front, F[nd]).mean())
    assert means[0] > 0
    assert means[1] < means[0]
    assert igd[1] < igd[0]


def test_sobol_origin_dominates_all_trials_for_30_variable_zdt1() -> None:
    """Degenerate case worth knowing: in 30 variables the origin (f = (0, 1), Pareto-optimal)
    dominates every other of the first 4096 unscrambled Sobol points, so the non-dominated
    subset is that single point; use few variables (e.g. "zdt1-3") to see convergence."""
    prob = get("zdt1")
    X = qmc.Sobol(30, scramble=False).random(4096)
    F, _ = prob.evaluate(X)
    nd = ~dominated(F)
    assert np.flatnonzero(nd).tolist() == [0]
    assert_allclose(F[0], [0.0, 1.0])
    assert prob.pareto_set_residual(X[:1])[0] == 0.0
    assert np.all(prob.pareto_set_residual(X[1:]) > 1.0)
