"""Point-mass descent under a drogue and a main parachute (a rocket's recovery), for identification.

A small batch model (registered as ``"rocket-descent"`` when :mod:`vectorid.identify` is
imported) for the real-descent example: the rocket after burn-out hangs under its parachutes as a
point mass. The parachutes are round canopies of known nominal diameters; the design variables
are their drag coefficients (referred to the nominal area π D²/4):

.. math::

    m \\dot{\\mathbf v} = m \\mathbf g
        - \\tfrac12 \\rho(h) \\lVert \\mathbf v_a \\rVert \\mathbf v_a\\,
          \\bigl(C_{D,d} S_d + u_{main}\\, C_{D,m} S_m + C_{D,b} S_b\\bigr),
    \\qquad \\mathbf v_a = \\mathbf v - \\mathbf w(h, t),

in NED (m, m/s), with ``u_main`` in [0, 1] the main parachute's deployment state, an input
channel (0 stowed, 1 fully inflated; a ramp between models the inflation). The drogue stays
attached after the main opens (the usual dual-deploy rigging), so under the main the drag area
is the sum. ``C_{D,b} S_b`` is an optional fixed drag area of the body (default 0: the body's drag
is lumped into the drogue's coefficient, which is then an *effective* coefficient).

Outputs are the 15 base channels (Euler angles, body rates, angle of attack and sideslip are 0:
a point mass has no attitude) plus ``drag_area`` (m²).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

from vectorid.models.base import BASE_CHANNELS, Channel, InitialState, Model, Parameter
from vectorid.models.integrate import STATUS_REJECTED, allocate_outputs, env_at, rk4_trial

__all__ = ["INCH", "RocketDescent"]

INCH = 0.0254

# Per-trial constants vector P.
_MASS, _SD, _SM, _CDD, _CDM, _CDAB = range(6)
_NP = 6
_NS = 6


@njit(cache=True, inline="always")
def _rhs(t, x, P, u, atm, gust, dx):  # pragma: no cover - compiled
    rho, g, wn, we, wd = env_at(atm, gust, t, -x[2])
    van = x[3] - wn
    vae = x[4] - we
    vad = x[5] - wd
    va = np.sqrt(van * van + vae * vae + vad * vad)
    f = u[0]
    if f < 0.0:
        f = 0.0
    elif f > 1.0:
        f = 1.0
    cda = P[_CDD] * P[_SD] + f * P[_CDM] * P[_SM] + P[_CDAB]
    k = 0.5 * rho * va * cda / P[_MASS]
    dx[0] = x[3]
    dx[1] = x[4]
    dx[2] = x[5]
    dx[3] = -k * van
    dx[4] = -k * vae
    dx[5] = g - k * vad


@njit(cache=True)
def _observe(t, x, P, u, atm, gust, y):  # pragma: no cover - compiled
    rho, g, wn, we, wd = env_at(atm, gust, t, -x[2])
    for j in range(6):
        y[j] = x[j]
    for j in range(6, 12):
        y[j] = 0.0
    van = x[3] - wn
    vae = x[4] - we
    vad = x[5] - wd
    y[12] = np.sqrt(van * van + vae * vae + vad * vad)
    y[13] = 0.0
    y[14] = 0.0
    f = min(max(u[0], 0.0), 1.0)
    y[15] = P[_CDD] * P[_SD] + f * P[_CDM] * P[_SM] + P[_CDAB]


@njit(parallel=True, cache=True)
def _kernel(
    x0, p, ctrl_t, ctrl_v, ctrl_mode, atm, gust, dt, n_steps, stride, x_max, y, status, t_fail
):  # pragma: no cover - compiled
    for i in prange(x0.shape[0]):
        if status[i] != 0:
            continue
        status[i], t_fail[i] = rk4_trial(
            _rhs,
            _observe,
            x0[i],
            p[i],
            ctrl_t,
            ctrl_v,
            ctrl_mode,
            atm,
            gust,
            dt,
            n_steps,
            stride,
            x_max,
            y[i],
        )


class RocketDescent(Model):
    """Point mass under a drogue and a main round parachute (see the module docstring).

    Parameters
    ----------
    mass : float
        Descending mass, kg (default 16.881 kg: the Prometheus rocket of the shared data,
        13.9 kg dry without motor plus the 2.981 kg motor casing after burn-out).
    drogue_diameter, main_diameter : float
        Nominal canopy diameters, m (default 24 in and 72 in).
    body_drag_area : float
        Fixed drag area of the body C_D S, m² (default 0: lumped into the drogue).

    Notes
    -----
    Parameters: ``cd_drogue`` (nominal 1.6) and ``cd_main`` (nominal 2.2), drag coefficients
    referred to the nominal areas. Input: ``main`` (0 stowed, 1 inflated). Steady descent rate
    under a drag area S_e: sqrt(2 m g / (ρ S_e)).
    """

    name = "rocket-descent"
    #: First compilation in an empty numba cache, s (benchmarks/startup.py --compile: 8.9 CPU s
    #: with imports; 23 s wall at load 8-11).
    compile_seconds = 7.0
    parameters = (
        Parameter("cd_drogue", 1.6, 0.5, 3.5, "-", "drogue drag coefficient on π D_d²/4"),
        Parameter("cd_main", 2.2, 0.8, 4.5, "-", "main drag coefficient on π D_m²/4"),
    )
    inputs = (Channel("main", "-", "main parachute state: 0 stowed, 1 fully inflated", 0.0),)
    outputs = (*BASE_CHANNELS, Channel("drag_area", "m²", "total drag area C_D S"))
    presets: ClassVar[dict[str, NDArray[np.float64]]] = {}

    def __init__(
        self,
        *,
        mass: float = 13.9 + 2.981,
        drogue_diameter: float = 24 * INCH,
        main_diameter: float = 72 * INCH,
        body_drag_area: float = 0.0,
    ) -> None:
        for name, v in (
            ("mass", mass),
            ("drogue_diameter", drogue_diameter),
            ("main_diameter", main_diameter),
        ):
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {v!r}")
        if not (np.isfinite(body_drag_area) and body_drag_area >= 0):
            raise ValueError(f"body_drag_area must be >= 0 m², got {body_drag_area!r}")
        self.mass = float(mass)
        self.drogue_area = float(np.pi * drogue_diameter**2 / 4)
        self.main_area = float(np.pi * main_diameter**2 / 4)
        self.body_drag_area = float(body_drag_area)

    def constants(self, X: NDArray[np.float64]) -> NDArray[np.float64]:
        """Per-trial constants (n, 6): mass, areas, coefficients, body drag area."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        P = np.empty((X.shape[0], _NP))
        P[:, _MASS] = self.mass
        P[:, _SD] = self.drogue_area
        P[:, _SM] = self.main_area
        P[:, _CDD] = X[:, 0]
        P[:, _CDM] = X[:, 1]
        P[:, _CDAB] = self.body_drag_area
        return P

    def steady_descent_rate(self, X, rho: float, g: float = 9.80665, main: float = 0.0):
        """Steady descent rate sqrt(2 m g / (ρ S_e)), m/s, per trial (S_e: total drag area)."""
        P = self.constants(X)
        cda = P[:, _CDD] * P[:, _SD] + main * P[:, _CDM] * P[:, _SM] + P[:, _CDAB]
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.sqrt(2 * self.mass * g / (rho * cda))

    def altitude_range(self, initial: InitialState, t_final: float) -> tuple[float, float]:
        return max(-4_900.0, min(-500.0, initial.altitude - 8_000.0)), initial.altitude + 1_000.0

    def _check_parameters(self, X: NDArray[np.float64]) -> NDArray[np.int64]:
        bad = (X[:, 0] < 0) | (X[:, 1] < 0)
        return np.where(bad, STATUS_REJECTED, 0).astype(np.int64)

    def _simulate(self, X, status, t_fail, *, dt, n_steps, stride, controls, env, initial):
        P = self.constants(X)
        n = X.shape[0]
        x0 = np.zeros((n, _NS))
        x0[:, 0] = initial.north
        x0[:, 1] = initial.east
        x0[:, 2] = -initial.altitude
        if initial.velocity is None:
            h = initial.altitude
            i = int(np.clip(round((h - env.atm[0, 0]) / env.atm[0, 1]), 0, env.atm[0, 2] - 1)) + 1
            rho, g, wn, we = env.atm[i, 0], env.atm[i, 1], env.atm[i, 2], env.atm[i, 3]
            u0 = float(controls(np.array(0.0))[0])
            x0[:, 3] = wn
            x0[:, 4] = we
            x0[:, 5] = self.steady_descent_rate(X, rho, g, min(max(u0, 0.0), 1.0))
        else:
            x0[:, 3:6] = np.asarray(initial.velocity)
        x_max = np.full(_NS, np.inf)
        x_max[0:3] = 1e7
        x_max[3:6] = 1_000.0
        y = allocate_outputs(n, n_steps, stride, len(self.outputs))
        _kernel(
            np.ascontiguousarray(x0),
            P,
            controls.times,
            controls.values,
            controls.mode,
            env.atm,
            env.gust,
            float(dt),
            int(n_steps),
            int(stride),
            x_max,
            y,
            status,
            t_fail,
        )
        return y
