"""The batch RK4 driver on toy models with known solutions: order, status codes, isolation."""

import numpy as np
import pytest
from numba import njit, prange

from vectorid.models.integrate import (
    LANE_WORK,
    LANES,
    STATUS_NONFINITE,
    STATUS_RUNAWAY,
    Environment,
    allocate_outputs,
    env_at,
    env_gather,
    rk4_lanes,
    rk4_trial,
    table_position,
)
from vectorid.models.wind import DrydenTurbulence, Wind, WindProfile


@njit(cache=True)
def _rhs(t, x, p, u, atm, gust, dx):
    # p[0] = 0: damped driven oscillator x'' = -w² x - c x' + u ; p[0] = 1: x' = x² (blow-up)
    if p[0] == 0.0:
        dx[0] = x[1]
        dx[1] = -p[1] * x[0] - p[2] * x[1] + u[0]
    else:
        dx[0] = x[0] * x[0]
        dx[1] = 0.0


@njit(cache=True)
def _observe(t, x, p, u, atm, gust, y):
    y[0] = x[0]
    y[1] = x[1]


@njit(parallel=True, cache=True)
def _kernel(x0, p, ct, cv, cm, atm, gust, dt, n_steps, stride, x_max, y, status, t_fail):
    for i in prange(x0.shape[0]):
        if status[i] != 0:
            continue
        status[i], t_fail[i] = rk4_trial(
            _rhs, _observe, x0[i], p[i], ct, cv, cm, atm, gust, dt, n_steps, stride, x_max, y[i]
        )


@njit(inline="always", error_model="numpy")
def _rhs_lanes(t, X, P, u, atm, gust, DX, W):
    # the same equations as _rhs, one trial per column, written with selects
    for i in range(X.shape[1]):
        osc = P[0, i] == 0.0
        d0 = X[1, i] if osc else X[0, i] * X[0, i]
        d1 = -P[1, i] * X[0, i] - P[2, i] * X[1, i] + u[0]
        DX[0, i] = d0
        DX[1, i] = d1 if osc else 0.0


@njit(inline="always", error_model="numpy")
def _observe_lanes(t, X, P, u, atm, gust, W, Y):
    for i in range(X.shape[1]):
        Y[0, i] = X[0, i]
        Y[1, i] = X[1, i]


@njit(parallel=True, error_model="numpy")
def _kernel_lanes(x0, p, rows, ct, cv, cm, atm, gust, dt, n_steps, stride, x_max, y, st, tf):
    for g in prange((rows.shape[0] + LANES - 1) // LANES):
        lo = g * LANES
        hi = min(lo + LANES, rows.shape[0])
        rk4_lanes(
            _rhs_lanes, _observe_lanes, x0, p, rows[lo:hi], ct, cv, cm, atm, gust, dt,
            n_steps, stride, x_max, y, st, tf,
        )  # fmt: skip


def _run(x0, p, t_final, dt, stride=1, x_max=None, u=0.0, lanes=False):
    n = x0.shape[0]
    n_steps = round(t_final / dt)
    env = Environment.build()
    y = allocate_outputs(n, n_steps, stride, 2)
    status = np.zeros(n, dtype=np.int64)
    t_fail = np.full(n, np.nan)
    x_max = np.full(2, np.inf) if x_max is None else x_max
    args = (
        x0,
        p,
        np.zeros(1),
        np.array([[u]]),
        0,
        env.atm,
        env.gust,
        dt,
        n_steps,
        stride,
        x_max,
        y,
        status,
        t_fail,
    )
    if lanes:
        _kernel_lanes(*args[:2], np.flatnonzero(status == 0), *args[2:])
    else:
        _kernel(*args)
    return y, status, t_fail


@pytest.mark.slow
def test_harmonic_oscillator_fourth_order():
    w2 = 4.0
    x0 = np.array([[1.0, 0.0]])
    p = np.array([[0.0, w2, 0.0]])
    exact = np.cos(2.0 * 5.0)
    errs = []
    for dt in (0.05, 0.025, 0.0125):
        y, status, _ = _run(x0, p, 5.0, dt)
        assert status[0] == 0
        errs.append(abs(y[0, -1, 0] - exact))
    ratios = np.array(errs[:-1]) / np.array(errs[1:])
    assert np.all((ratios > 14) & (ratios < 17)), ratios  # 2^4 = 16


def test_output_stride_and_constant_forcing():
    # x'' = -x + 1 from rest: x = 1 - cos t
    y, status, _ = _run(
        np.array([[0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]), 10.0, 0.01, stride=100, u=1.0
    )
    assert y.shape == (1, 11, 2)
    np.testing.assert_allclose(y[0, :, 0], 1 - np.cos(np.arange(11.0)), atol=1e-9)


def test_blow_up_is_flagged_and_isolated():
    # x' = x², x(0) = 1 blows up at t = 1; the oscillator rows must not notice
    x0 = np.array([[1.0, 0.0], [1.0, 0.0], [0.5, 0.0]])
    p = np.array([[0.0, 4.0, 0.1], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    y, status, t_fail = _run(x0, p, 3.0, 0.01, stride=10)
    assert status[1] in (STATUS_NONFINITE, STATUS_RUNAWAY)
    assert 0.9 < t_fail[1] < 1.2
    assert np.all(np.isnan(y[1, 12:]))  # frozen after the failure
    assert np.all(np.isfinite(y[1, :9]))
    assert status[0] == 0 and status[2] == 0
    alone, _, _ = _run(x0[[0]], p[[0]], 3.0, 0.01, stride=10)
    np.testing.assert_array_equal(alone[0], y[0])


def test_runaway_bound():
    x_max = np.array([10.0, np.inf])
    y, status, t_fail = _run(
        np.array([[1.0, 0.0]]), np.array([[1.0, 0.0, 0.0]]), 3.0, 0.01, x_max=x_max
    )
    assert status[0] == STATUS_RUNAWAY
    assert t_fail[0] == pytest.approx(0.9, abs=0.02)  # x = 1/(1-t) reaches 10 at t = 0.9


def _mixed_batch(n):
    """Oscillators with different damping, and every 7th trial blowing up (x' = x²)."""
    rng = np.random.default_rng(5)
    x0 = np.column_stack([rng.uniform(0.2, 1.5, n), rng.uniform(-1, 1, n)])
    p = np.column_stack([np.zeros(n), rng.uniform(0.5, 4, n), rng.uniform(0, 0.3, n)])
    p[::7, 0] = 1.0
    x0[::7, 0] = 1.0
    return x0, p


@pytest.mark.parametrize("n", [1, 5, LANES, 2 * LANES + 3])
def test_lockstep_driver_equals_the_trial_driver_bit_for_bit(n):
    """rk4_lanes: same outputs, status codes and failure times as rk4_trial, group sizes
    from 1 to several groups with a partial last group."""
    x0, p = _mixed_batch(n)
    x_max = np.array([50.0, np.inf])
    want = _run(x0, p, 3.0, 0.01, stride=10, x_max=x_max, u=0.3)
    got = _run(x0, p, 3.0, 0.01, stride=10, x_max=x_max, u=0.3, lanes=True)
    for w, g in zip(want, got):
        np.testing.assert_array_equal(g, w)
    assert np.all(got[1][::7] == STATUS_RUNAWAY)
    assert np.all(got[1][np.arange(n) % 7 != 0] == 0)


def test_lockstep_driver_result_does_not_depend_on_the_group():
    x0, p = _mixed_batch(2 * LANES + 3)
    y, status, t_fail = _run(x0, p, 3.0, 0.01, stride=10, lanes=True)
    order = np.random.default_rng(1).permutation(x0.shape[0])
    y2, status2, t_fail2 = _run(x0[order], p[order], 3.0, 0.01, stride=10, lanes=True)
    np.testing.assert_array_equal(y2, y[order])
    np.testing.assert_array_equal(status2, status[order])
    np.testing.assert_array_equal(t_fail2, t_fail[order])
    alone = _run(x0[[3]], p[[3]], 3.0, 0.01, stride=10, lanes=True)[0]
    np.testing.assert_array_equal(alone[0], y[3])


@njit
def _gather(atm, gust, t, h):
    W = np.empty((LANE_WORK, h.shape[0]))
    for k in range(h.shape[0]):
        W[5, k], W[6, k] = table_position(h[k], atm[0, 0], atm[0, 1], int(atm[0, 2]))
    env_gather(atm, gust, t, W)
    return W[:5]


@pytest.mark.parametrize("windy", [False, True])
def test_env_gather_equals_env_at_bit_for_bit(windy):
    wind = Wind(WindProfile([0, 2000], [3, -4], [1, 6]), DrydenTurbulence(5.0, seed=2))
    env = Environment.build(wind=wind if windy else None, t_final=10.0, h0=1000.0)
    assert env.atm[0, 3] == (1.0 if windy else 0.0)
    h = np.array([-500.0, -200.0, -199.5, 0.0, 123.456, 999.999, 2999.5, 3000.0, 4000.0, np.nan])
    for t in (0.0, 3.33, 50.0):
        got = _gather(env.atm, env.gust, t, h)
        for k, hk in enumerate(h):
            want = env_at(env.atm, env.gust, t, hk if np.isfinite(hk) else -1e9)
            np.testing.assert_array_equal(got[:, k], want)
