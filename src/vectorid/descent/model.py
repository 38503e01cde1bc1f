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
channel (0 stowed, 1 fully inflated; a ramp between models the inflation). ``C_{D,b} S_b`` is an
optional fixed drag area of the body (default 0: the body's drag is lumped into the drogue's
coefficient, which is then an *effective* coefficient).

The drag areas' convention (``drag_convention``) says what a main parachute's drag area means:

- ``"adds"`` (the equation above): the drogue stays attached after the main opens (the usual
  dual-deploy rigging) and keeps its drag, so under the main the drag area is the sum
  C_D,d S_d + C_D,m S_m; the main's own drag area is what the main adds.
- ``"replaces"``: under the main the drag area is the main's alone,
  (1 - u_main) C_D,d S_d + u_main C_D,m S_m (+ C_D,b S_b). This is the convention of RocketPy,
  whose stated parachute ``cd_s`` is the whole drag area of the phase that parachute opens; a
  main's drag area in it includes whatever the drogue still adds.

The two identify the same total drag area under the main; they differ in what is called the
main's. :class:`RocketDescent` takes drag coefficients referred to the canopies' nominal areas
π D²/4 (``cd_drogue``, ``cd_main``); :class:`RocketDescentCdS` (``"rocket-descent-cds"``) takes
the drag areas themselves (``cds_drogue``, ``cds_main``, m²), for a rocket whose recovery is
stated as C_D S.

Outputs are the 15 base channels (Euler angles, body rates, angle of attack and sideslip are 0:
a point mass has no attitude) plus ``drag_area`` (m²).

The data side of a descent (:func:`detect_apogee`, :func:`detect_touchdown`,
:func:`crossing_time`, :func:`detect_rate_change`, :func:`monotone_rate_bound`,
:func:`fast_variation`) reads an altitude series: where the descent starts, where it ends on
the ground, when it passes a trigger height, where its drag area changes, how close any
constant-drag descent can come, how much of its fast variation a second altimeter shares.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

from vectorid.models.base import BASE_CHANNELS, Channel, InitialState, Model, Parameter
from vectorid.models.integrate import STATUS_REJECTED, allocate_outputs, env_at, rk4_trial

__all__ = [
    "DRAG_CONVENTIONS",
    "INCH",
    "INITIAL_SPEEDS",
    "RocketDescent",
    "RocketDescentCdS",
]

INCH = 0.0254

#: What a main parachute's drag area means (see the module docstring).
DRAG_CONVENTIONS = ("adds", "replaces")
#: Where the simulated descent starts its velocity (see :class:`RocketDescent`).
INITIAL_SPEEDS = ("data", "steady")

# Per-trial constants vector P (_REPL: 1 when the main replaces the drogue, 0 when it adds).
_MASS, _SD, _SM, _CDD, _CDM, _CDAB, _REPL = range(7)
_NP = 7
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
    cda = (1.0 - P[_REPL] * f) * P[_CDD] * P[_SD] + f * P[_CDM] * P[_SM] + P[_CDAB]
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
    y[15] = (1.0 - P[_REPL] * f) * P[_CDD] * P[_SD] + f * P[_CDM] * P[_SM] + P[_CDAB]


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


def _check_positive(name: str, v: float) -> None:
    if not (np.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be a finite number > 0, got {v!r}")


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
    drag_convention : {"adds", "replaces"}
        Whether the main's drag adds to the drogue's (default: the drogue stays attached) or
        replaces it once the main is out (RocketPy's convention); see the module docstring.
    initial_speed : {"data", "steady"}
        The velocity the simulation starts from: the initial state's (default: fitted to the
        data at the window start) or, ``"steady"``, each trial's own steady descent rate
        sqrt(2 m g / (ρ C_D S)) with the horizontal velocity of the wind (drifting with it).
        A canopy some seconds after it opened descends at its steady rate (the speed's time
        constant is v / 2g, about 1.4 s at 27 m/s); a slope fitted over a few seconds of a
        barometric height whose error is correlated over seconds is not (the TeleMega's
        drogue phase: 25-32 m/s from 2-s lines at successive starts).

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
        drag_convention: str = "adds",
        initial_speed: str = "data",
    ) -> None:
        for name, v in (
            ("mass", mass),
            ("drogue_diameter", drogue_diameter),
            ("main_diameter", main_diameter),
        ):
            _check_positive(name, v)
        self._set_common(mass, body_drag_area, drag_convention, initial_speed)
        self.drogue_area = float(np.pi * drogue_diameter**2 / 4)
        self.main_area = float(np.pi * main_diameter**2 / 4)

    def _set_common(
        self, mass: float, body_drag_area: float, drag_convention: str, initial_speed: str
    ) -> None:
        _check_positive("mass", mass)
        if initial_speed not in INITIAL_SPEEDS:
            raise ValueError(
                f"initial_speed must be 'data' (the initial state's velocity) or 'steady' (each "
                f"trial's own steady descent rate, drifting with the wind), got {initial_speed!r}"
            )
        self.initial_speed = initial_speed
        if not (np.isfinite(body_drag_area) and body_drag_area >= 0):
            raise ValueError(f"body_drag_area must be >= 0 m², got {body_drag_area!r}")
        if drag_convention not in DRAG_CONVENTIONS:
            raise ValueError(
                f"drag_convention must be 'adds' (the main's drag adds to the drogue's) or "
                f"'replaces' (the main's drag area is the whole drag area under it), got "
                f"{drag_convention!r}"
            )
        self.mass = float(mass)
        self.body_drag_area = float(body_drag_area)
        self.drag_convention = drag_convention

    def constants(self, X: NDArray[np.float64]) -> NDArray[np.float64]:
        """Per-trial constants (n, 7): mass, areas, coefficients, body drag area, convention."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        P = np.empty((X.shape[0], _NP))
        P[:, _MASS] = self.mass
        P[:, _SD] = self.drogue_area
        P[:, _SM] = self.main_area
        P[:, _CDD] = X[:, 0]
        P[:, _CDM] = X[:, 1]
        P[:, _CDAB] = self.body_drag_area
        P[:, _REPL] = 1.0 if self.drag_convention == "replaces" else 0.0
        return P

    def drag_area(self, X, main: float = 0.0) -> NDArray[np.float64]:
        """Total drag area C_D S (m²) per trial with the main in state ``main`` (0 to 1)."""
        P = self.constants(X)
        f = min(max(float(main), 0.0), 1.0)
        return (
            (1.0 - P[:, _REPL] * f) * P[:, _CDD] * P[:, _SD]
            + f * P[:, _CDM] * P[:, _SM]
            + P[:, _CDAB]
        )

    def steady_descent_rate(self, X, rho: float, g: float = 9.80665, main: float = 0.0):
        """Steady descent rate sqrt(2 m g / (ρ S_e)), m/s, per trial (S_e: total drag area)."""
        cda = self.drag_area(X, main)
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
        if initial.velocity is None or self.initial_speed == "steady":
            h = initial.altitude
            i = int(np.clip(round((h - env.atm[0, 0]) / env.atm[0, 1]), 0, env.atm[0, 2] - 1)) + 1
            rho, g, wn, we, wd = env.atm[i, :5]
            u0 = float(controls(np.array(0.0))[0])
            x0[:, 3] = wn
            x0[:, 4] = we
            x0[:, 5] = wd + self.steady_descent_rate(X, rho, g, min(max(u0, 0.0), 1.0))
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


class RocketDescentCdS(RocketDescent):
    """:class:`RocketDescent` with the drag areas themselves as parameters (m²).

    Parameters
    ----------
    mass : float
        Descending mass, kg (default 16.881 kg, the Prometheus rocket as in
        :class:`RocketDescent`; state the rocket's own: the steady descent rate scales with
        sqrt(m)).
    body_drag_area : float
        Fixed drag area of the body C_D S, m² (default 0).
    drag_convention : {"adds", "replaces"}
        What the main's drag area means (see the module docstring); default ``"adds"``.
    initial_speed : {"data", "steady"}
        As in :class:`RocketDescent`.

    Notes
    -----
    Parameters: ``cds_drogue`` and ``cds_main``, m². With a canopy of nominal diameter D its
    drag coefficient is C_D = C_D S / (π D² / 4).
    """

    name = "rocket-descent-cds"
    parameters = (
        Parameter("cds_drogue", 0.5, 0.01, 5.0, "m²", "drogue drag area C_D,d S_d"),
        Parameter(
            "cds_main", 5.0, 0.1, 50.0, "m²", "main drag area C_D,m S_m (see drag_convention)"
        ),
    )

    def __init__(
        self,
        *,
        mass: float = 13.9 + 2.981,
        body_drag_area: float = 0.0,
        drag_convention: str = "adds",
        initial_speed: str = "data",
    ) -> None:
        self._set_common(mass, body_drag_area, drag_convention, initial_speed)
        self.drogue_area = 1.0
        self.main_area = 1.0
