"""The batch RK4 driver on toy models with known solutions: order, status codes, isolation."""

import numpy as np
import pytest
from numba import njit, prange

from vectorid.models.integrate import (
    STATUS_NONFINITE,
    STATUS_RUNAWAY,
    Environment,
    allocate_outputs,
    rk4_trial,
)


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


def _run(x0, p, t_final, dt, stride=1, x_max=None, u=0.0):
    n = x0.shape[0]
    n_steps = round(t_final / dt)
    env = Environment.build()
    y = allocate_outputs(n, n_steps, stride, 2)
    status = np.zeros(n, dtype=np.int64)
    t_fail = np.full(n, np.nan)
    x_max = np.full(2, np.inf) if x_max is None else x_max
    _kernel(
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
    return y, status, t_fail


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
