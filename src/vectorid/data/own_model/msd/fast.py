"""The same mass-spring-damper with a compiled (numba) kernel: the whole batch is
integrated by fixed-step RK4 in one call, trials spread over the CPU cores.

It overrides SystemModel._simulate instead of writing rhs: same parameters, states,
outputs and results as msd.dynamics.MassSpringDamper (to rounding), several times faster.
"""

import numba
import numpy as np

from msd.dynamics import MassSpringDamper


@numba.njit(cache=True, inline="always")
def _acc(t, x, v, m, c, k, f0, w):
    return (f0 * np.sin(w * t) - c * v - k * x) / m


@numba.njit(parallel=True, cache=True)
def _kernel(P, x0, dt, n_steps, stride, f0, w, out):
    n = P.shape[0]
    for i in numba.prange(n):
        m, c, k = P[i, 0], P[i, 1], P[i, 2]
        x, v = x0[i, 0], x0[i, 1]
        out[i, 0, 0] = x
        out[i, 0, 1] = _acc(0.0, x, v, m, c, k, f0, w)
        for s in range(n_steps):
            t = s * dt
            a1 = _acc(t, x, v, m, c, k, f0, w)
            x2, v2 = x + 0.5 * dt * v, v + 0.5 * dt * a1
            a2 = _acc(t + 0.5 * dt, x2, v2, m, c, k, f0, w)
            x3, v3 = x + 0.5 * dt * v2, v + 0.5 * dt * a2
            a3 = _acc(t + 0.5 * dt, x3, v3, m, c, k, f0, w)
            x4, v4 = x + dt * v3, v + dt * a3
            a4 = _acc(t + dt, x4, v4, m, c, k, f0, w)
            x += dt / 6 * (v + 2 * v2 + 2 * v3 + v4)
            v += dt / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
            if (s + 1) % stride == 0:
                j = (s + 1) // stride
                out[i, j, 0] = x
                out[i, j, 1] = _acc(t + dt, x, v, m, c, k, f0, w)


class MassSpringDamperNumba(MassSpringDamper):
    name = "mass-spring-damper-numba"

    def _simulate(self, X, x0, status, t_fail, *, dt, n_steps, stride):
        out = np.full((X.shape[0], n_steps // stride + 1, 2), np.nan)
        w = 2 * np.pi * self.force_frequency
        _kernel(X, x0, dt, n_steps, stride, self.force_amplitude, w, out)
        bad = ~np.all(np.isfinite(out), axis=(1, 2))
        status[bad & (status == 0)] = 1  # a state became NaN or inf: a failed trial
        return out
