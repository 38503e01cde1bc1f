"""``parafoil6dof``: the rigid 6-DoF parafoil-payload model (payload locked to the canopy).

The same aerodynamics (the 33 gain factors c1..c33 of seed 000, Figure 12), apparent masses,
geometry and mass as :mod:`vectorid.models.parafoil8dof`, with the payload joint locked: the
generalised speeds are the inertial velocity of the joint J and the body rates of the single
rigid body, and the mass-inertia matrix is the leading 6x6 block of the 8-DoF one at zero joint
angles. This is the model the seed's section VII compares the 8-DoF one with ("not much
difference ... the only noticeable difference was in ... the natural eigenvalues for pitch and
yaw").

State (12): ``[N, E, D, phi, theta, psi, u, v, w, p, q, r]``. Outputs: the base channels
(payload mass-centre position and velocity, body Euler angles and rates, canopy airspeed, angle
of attack and sideslip).
"""

from __future__ import annotations

from typing import Any, ClassVar

from numba import njit, prange

from vectorid.models._parafoil_core import parafoil_observe, parafoil_rhs
from vectorid.models.base import BASE_CHANNELS, Channel
from vectorid.models.integrate import env_at, rk4_trial
from vectorid.models.parafoil8dof import ParafoilModelBase
from vectorid.models.parafoil_aero import I_WE, I_WN, NPROP

__all__ = ["Parafoil6DoF"]


@njit(cache=True, inline="always")
def _rhs(t, x, p, u, atm, gust, dx):  # pragma: no cover - compiled
    rho, g, wn, we, wd = env_at(atm, gust, t, -x[2])
    parafoil_rhs(p, x, rho, g, wn + p[I_WN], we + p[I_WE], wd, u[0], u[1], True, dx, p[NPROP:])


@njit(cache=True)
def _observe(t, x, p, u, atm, gust, y):  # pragma: no cover - compiled
    rho, g, wn, we, wd = env_at(atm, gust, t, -x[2])
    parafoil_observe(p, x, wn + p[I_WN], we + p[I_WE], wd, True, y, p[NPROP:])


@njit(parallel=True, cache=True)
def _kernel(
    x0, p, ctrl_t, ctrl_v, ctrl_mode, atm, gust, dt, n_steps, stride, x_max, y, status, t_fail
):  # pragma: no cover - compiled
    for i in prange(x0.shape[0]):
        if status[i] != 0:  # rejected before integration: leave NaN outputs
            continue
        status[i], t_fail[i] = rk4_trial(
            _rhs, _observe, x0[i], p[i], ctrl_t, ctrl_v, ctrl_mode, atm, gust,
            dt, n_steps, stride, x_max, y[i],
        )  # fmt: skip


class Parafoil6DoF(ParafoilModelBase):
    """Rigid 6-DoF parafoil-payload model with the aerodynamics of ``parafoil8dof``.

    Options as :class:`~vectorid.models.parafoil8dof.ParafoilModelBase` (the joint stiffness and
    damping are ignored: the joint is locked).
    """

    name: ClassVar[str] = "parafoil6dof"
    #: First compilation in an empty numba cache, s (benchmarks/startup.py --compile: 49.5 CPU s
    #: with imports; 115 s wall at load 8-11).
    compile_seconds = 45.0
    outputs: tuple[Channel, ...] = BASE_CHANNELS
    rigid: ClassVar[bool] = True
    #: As the 8-DoF count with a 6x6 LDL^T (~230 instead of ~420) and 12 states.
    flops_per_step: ClassVar[int] = 4 * 1160 + 144 + 40

    def _run_kernel(self, *args: Any) -> None:
        _kernel(*args)
