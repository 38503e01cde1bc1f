"""A flight model whose feasible set and predictions are known in closed form (for tests).

The load drifts at a constant ground velocity (``vn``, ``ve``, m/s) and sinks at ``sink`` m/s:
``north(t) = north0 + vn t``, ``east(t) = east0 + ve t``, ``down(t) = -altitude0 + sink t``.
Identified on noise-free data of a truth ``(vn0, ve0)`` with the criterion
``pos_h_abs = ∫ |ΔP_H| dt = |Δv_H| T²/2`` (exact under the trapezoidal rule, the integrand
being linear in t) limited by ``L``, D is the disc ``|v_H - v0_H| <= ρ = 2 L / T²``; the
members' ``north(t)`` is ``north0 + t vn`` with ``vn`` distributed as the disc's marginal
(:func:`disc_cdf`), and a planned drop from a height ``h`` lands on the disc scaled by the
time to the ground ``h / sink``: the share of landings within ``r`` of the centre is
``(r / (ρ h / sink))²``.
"""

from __future__ import annotations

import math

import numpy as np

from vectorid.models.base import Model, Parameter

__all__ = ["Kinematic", "disc_cdf", "disc_quantile"]


class Kinematic(Model):
    """Constant drift and sink (see the module docstring)."""

    name = "kinematic"
    parameters = (
        Parameter("vn", 0.0, -20.0, 20.0, "m/s", "ground speed north"),
        Parameter("ve", 0.0, -20.0, 20.0, "m/s", "ground speed east"),
        Parameter("sink", 5.0, 0.5, 20.0, "m/s", "sink rate"),
    )

    def _simulate(self, X, status, t_fail, *, dt, n_steps, stride, controls, env, initial):
        t = np.arange(n_steps // stride + 1) * stride * dt
        n = X.shape[0]
        out = np.zeros((n, t.size, len(self.outputs)))
        out[:, :, 0] = initial.north + X[:, 0:1] * t
        out[:, :, 1] = initial.east + X[:, 1:2] * t
        out[:, :, 2] = -initial.altitude + X[:, 2:3] * t
        out[:, :, 3] = X[:, 0:1]
        out[:, :, 4] = X[:, 1:2]
        out[:, :, 5] = X[:, 2:3]
        out[:, :, 12] = np.sqrt(X[:, 0:1] ** 2 + X[:, 1:2] ** 2 + X[:, 2:3] ** 2)
        return out


def disc_cdf(x: float) -> float:
    """CDF of one coordinate of a point uniform on the unit disc, at ``x`` in [-1, 1]."""
    x = min(max(x, -1.0), 1.0)
    return 0.5 + (x * math.sqrt(1.0 - x * x) + math.asin(x)) / math.pi


def disc_quantile(q: float) -> float:
    """Inverse of :func:`disc_cdf` (bisection to 1e-12)."""
    lo, hi = -1.0, 1.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if disc_cdf(mid) < q:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)
