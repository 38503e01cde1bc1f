"""``parafoil8dof``: the 8-DoF parafoil-payload model of seed 000, eq. (1)-(3).

Six degrees of freedom of the canopy (with its suspension lines) plus the payload's pitch and yaw
relative to the canopy about the confluence point J, which is modelled as a two-axis joint with a
spring-damper on each axis (``joint_stiffness``, ``joint_damping``; very stiff joints make the
model approach the rigid :mod:`vectorid.models.parafoil6dof`). The aerodynamics carry the 33 gain
factors c1..c33 of the seed's Figure 12 (:data:`vectorid.models.parafoil_aero.GAINS`); the
mass-inertia matrix includes the Lissaman-Brown apparent masses.

Equations as implemented (``docs/models.md`` derives them and records how the scanned
eq. (1) is read)::

    A(q) dV*/dt = {F; M_c; M_p} - Sigma(V*) A V*          (1)  Kirchhoff/Kane form
    dLambda_c/dt = R_E(Lambda_c) omega_c,  d(theta_r, psi_r)/dt = (q_p, r_p)       (2)
    dP/dt = R_ib V                                                                  (3)

with ``V* = [V, omega_c, (0, q_p, r_p)]``, ``V`` the inertial velocity of J in canopy axes and
``q_p, r_p`` the payload's relative pitch and yaw rates (the roll slot of omega_p is zero: the
joint does not let the payload roll relative to the canopy).

Outputs: the base channels (position and velocity of the payload mass centre, where the GPS/IMU
of a drop sits; canopy Euler angles and rates; canopy airspeed, angle of attack and sideslip)
then ``payload_phi``, ``payload_theta``, ``payload_psi`` (rad), ``payload_p``, ``payload_q``,
``payload_r`` (rad/s, payload axes), ``rel_pitch``, ``rel_yaw`` (rad).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any, ClassVar

import numpy as np
from numba import njit, prange
from numpy.typing import ArrayLike, NDArray

from vectorid.errors import suggest
from vectorid.models._parafoil_core import (
    NWORK,
    NX6,
    NX8,
    mechanical_energy,
    parafoil_observe,
    parafoil_rhs,
    reference_matrices,
    rhs_reference,
    trim_glide,
)
from vectorid.models.atmosphere import ISA, UniformAtmosphere
from vectorid.models.base import BASE_CHANNELS, Channel, InitialState, Model, Parameter
from vectorid.models.controls import ControlSchedule
from vectorid.models.integrate import (
    STATUS_REJECTED,
    Environment,
    allocate_outputs,
    env_at,
    rk4_trial,
)
from vectorid.models.parafoil_aero import (
    EXTRA_COEFFICIENTS,
    GAIN_NAMES,
    GAINS,
    I_MAM,
    I_MP,
    I_MRB,
    I_RP,
    I_WE,
    I_WN,
    NGAIN,
    NPROP,
    ParafoilGeometry,
    ParafoilOptionError,
    build_properties,
    dcm_body_to_ned,
    nominal_gains,
    reference_coefficients,
)
from vectorid.models.wind import Wind, WindProfile

__all__ = ["EXTRA_PARAMETERS", "Parafoil8DoF", "ParafoilModelBase"]

#: Highest air density the mass-matrix check assumes (cold day at sea level), kg/m^3.
RHO_MAX = 1.5


#: Parameters a model option may add after the 33 gains (``extra_parameters = [...]``):
#: name -> (unit, meaning). ``payload_mass`` makes the wing loading a design variable;
#: ``wind_north`` / ``wind_east`` a uniform wind added to the drop's profile (the seed's
#: uncertain-wind parameters k_U, for flights without a wind measurement).
EXTRA_PARAMETERS: dict[str, tuple[str, str]] = {
    "payload_mass": ("kg", "payload mass (wing loading = (m_c + payload_mass) g / S)"),
    "wind_north": ("m/s", "uniform wind added to the profile, towards north (velocity of the air)"),
    "wind_east": ("m/s", "uniform wind added to the profile, towards east (velocity of the air)"),
}


def _parameters(
    reference: np.ndarray | None = None,
    extra: tuple[str, ...] = (),
    geometry: ParafoilGeometry | None = None,
) -> tuple[Parameter, ...]:
    ref = [g.reference for g in GAINS] if reference is None else list(reference)
    out = []
    for g, r in zip(GAINS, ref):
        if g.additive:
            meaning = (
                f"c{g.index}: additive gain, {g.name} = {r:g} + c{g.index} "
                f"[{g.coef_unit}]; {g.meaning}"
            )
            out.append(Parameter(g.name, 0.0, g.lower, g.upper, g.coef_unit, meaning))
        else:
            meaning = f"c{g.index}: gain, {g.name} = {r:g} {g.coef_unit} * c{g.index}; {g.meaning}"
            if r == 0.0:
                meaning += " (reference 0: this gain has no effect)"
            out.append(Parameter(g.name, 1.0, g.lower, g.upper, "-", meaning))
    for name in extra:
        unit, meaning = EXTRA_PARAMETERS[name]
        if name == "payload_mass":
            m = (geometry or ParafoilGeometry()).payload_mass
            out.append(Parameter(name, m, 0.25 * m, 4.0 * m, unit, meaning))
        else:
            out.append(Parameter(name, 0.0, -10.0, 10.0, unit, meaning))
    return tuple(out)


_INPUTS = (
    Channel(
        "flap_left",
        "-",
        "left trailing-edge deflection, fraction of full pull (0 none, 1 full); scaled by delcon",
        0.0,
    ),
    Channel(
        "flap_right",
        "-",
        "right trailing-edge deflection, fraction of full pull (0 none, 1 full); scaled by delcon",
        0.0,
    ),
)

_PAYLOAD_CHANNELS = (
    Channel("payload_phi", "rad", "payload roll angle (3-2-1 Euler)"),
    Channel("payload_theta", "rad", "payload pitch angle (3-2-1 Euler)"),
    Channel("payload_psi", "rad", "payload yaw angle (3-2-1 Euler), not wrapped"),
    Channel("payload_p", "rad/s", "payload roll rate, payload axes (what a payload IMU reads)"),
    Channel("payload_q", "rad/s", "payload pitch rate, payload axes"),
    Channel("payload_r", "rad/s", "payload yaw rate, payload axes"),
    Channel("rel_pitch", "rad", "payload pitch relative to the canopy (joint angle theta_r)"),
    Channel("rel_yaw", "rad", "payload yaw (twist) relative to the canopy (joint angle psi_r)"),
)


@njit(cache=True)
def _initial_states(
    pc, rigid, h0, north, east, vel_given, vel, euler, rates, dl, dr, atm, gust, x0, trimmed
):  # pragma: no cover - compiled
    """Initial state of every trial: trim glide (or the given velocity), output point at start."""
    n = pc.shape[0]
    nx = x0.shape[1]
    vo = 6 if rigid else 8
    rho, g, wn0, we0, wd = env_at(atm, gust, 0.0, h0)
    rmat = np.zeros((3, 3))
    for i in range(n):
        k = pc[i, :NPROP]
        work = pc[i, NPROP:]
        wn = wn0 + k[I_WN]
        we = we0 + k[I_WE]
        x = x0[i]
        for j in range(nx):
            x[j] = 0.0
        x[3] = euler[0]
        x[4] = euler[1]
        x[5] = euler[2]
        if vel_given:
            trimmed[i] = True
            dcm_body_to_ned(x[3], x[4], x[5], rmat)
            for j in range(3):
                x[vo + j] = rmat[0, j] * vel[0] + rmat[1, j] * vel[1] + rmat[2, j] * vel[2]
        else:
            trimmed[i] = trim_glide(k, rho, g, dl, dr, rigid, x, work)
            x[3] = euler[0]
            x[5] = euler[2]
            dcm_body_to_ned(x[3], x[4], x[5], rmat)
            for j in range(3):
                x[vo + j] += rmat[0, j] * wn + rmat[1, j] * we + rmat[2, j] * wd
        for j in range(3):
            x[vo + 3 + j] = rates[j]
        # place the output point (payload mass centre) at the start position
        if rigid:
            th_r = 0.0
            ps_r = 0.0
        else:
            th_r = x[6]
            ps_r = x[7]
        px, py, pz = k[I_RP], k[I_RP + 1], k[I_RP + 2]
        cth, sth = math.cos(th_r), math.sin(th_r)
        cps, sps = math.cos(ps_r), math.sin(ps_r)
        rx = cps * cth * px - sps * py + cps * sth * pz
        ry = sps * cth * px + cps * py + sps * sth * pz
        rz = -sth * px + cth * pz
        dcm_body_to_ned(x[3], x[4], x[5], rmat)
        start = (north, east, -h0)
        for j in range(3):
            x[j] = start[j] - (rmat[j, 0] * rx + rmat[j, 1] * ry + rmat[j, 2] * rz)


@njit(cache=True, inline="always")
def _rhs(t, x, p, u, atm, gust, dx):  # pragma: no cover - compiled
    rho, g, wn, we, wd = env_at(atm, gust, t, -x[2])
    parafoil_rhs(p, x, rho, g, wn + p[I_WN], we + p[I_WE], wd, u[0], u[1], False, dx, p[NPROP:])


@njit(cache=True)
def _observe(t, x, p, u, atm, gust, y):  # pragma: no cover - compiled
    rho, g, wn, we, wd = env_at(atm, gust, t, -x[2])
    parafoil_observe(p, x, wn + p[I_WN], we + p[I_WE], wd, False, y, p[NPROP:])


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


_CANOPY_CHANNELS = (
    Channel("canopy_phi", "rad", "canopy roll angle (3-2-1 Euler)"),
    Channel("canopy_theta", "rad", "canopy pitch angle (3-2-1 Euler)"),
    Channel("canopy_psi", "rad", "canopy yaw angle (3-2-1 Euler), not wrapped"),
    Channel("canopy_p", "rad/s", "canopy body roll rate"),
    Channel("canopy_q", "rad/s", "canopy body pitch rate"),
    Channel("canopy_r", "rad/s", "canopy body yaw rate"),
)
_OPTIONS = {
    "geometry": "mass and geometry: a ParafoilGeometry or a table of its fields",
    "coefficients": "reference (nominal) coefficients replacing Set 0, by name",
    "extra_parameters": f"parameters after the 33 gains, any of {', '.join(EXTRA_PARAMETERS)}",
    "attitude": '"canopy" (default) or "payload": whose attitude the euler/rates channels give',
    "aerodynamics": "false switches aerodynamic forces off (energy tests)",
    "munk_in_static_data": "whether the static Cm, Cn data contain the steady Munk moment",
    "joint_stiffness": "[pitch, yaw] payload joint stiffness, N m/rad",
    "joint_damping": "[pitch, yaw] payload joint damping, N m s/rad",
}


def _number_option(where: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise ParafoilOptionError(
            f"model option {where}: expected a number, got {value!r}; write a plain number"
        )
    if not math.isfinite(float(value)):
        raise ParafoilOptionError(f"model option {where}: expected a finite number, got {value!r}")
    return float(value)


def option_names() -> dict[str, str]:
    """The parafoil models' constructor options (name -> meaning), for error messages."""
    return dict(_OPTIONS)


class ParafoilModelBase(Model):
    """Shared configuration and bookkeeping of the parafoil models (8-DoF and rigid 6-DoF).

    Every option can be given from a study file as ``[identification] model_options = {...}``
    (tables and arrays for the structured ones); invalid values raise
    :class:`~vectorid.models.parafoil_aero.ParafoilOptionError` with a one-line message.

    Parameters
    ----------
    geometry : ParafoilGeometry or mapping, optional
        Mass, inertia, geometry and rigging; default: the reference 2,200-lb-class system (see
        :class:`~vectorid.models.parafoil_aero.ParafoilGeometry`). A mapping gives the fields
        to change from that default (``{"area": 1.5, "span": 1.88, ...}``).
    coefficients : mapping of str to float, optional
        The nominal coefficient set of another canopy: reference values (in each coefficient's
        unit, see :data:`~vectorid.models.parafoil_aero.GAINS`) replacing Set 0, so that the
        gains c1..c33 multiply (or are added to) them; plus ``Cmalpha`` (1/deg) and
        ``CDalpha2`` (1/deg^2), two terms Set 0 does not have (default 0).
    extra_parameters : sequence of str, optional
        Parameters appended after the 33 gains: ``payload_mass`` (kg), ``wind_north``,
        ``wind_east`` (m/s, a uniform wind added to the profile); see :data:`EXTRA_PARAMETERS`.
    attitude : {"canopy", "payload"}
        Whose attitude the ``euler`` and ``rates`` output channels give (8-DoF only; the rigid
        model has one attitude). ``"payload"`` matches an IMU on the payload, as in a drop's
        GPS/IMU unit; the canopy's then appear as ``canopy_phi`` ... ``canopy_r``.
    aerodynamics : bool
        ``False`` switches aerodynamic forces and moments off (apparent masses stay): for
        energy-conservation checks.
    munk_in_static_data : bool
        ``True`` (default): the steady apparent-mass (Munk) moment is taken as already contained
        in the static moment coefficients and is not added again (see ``docs/models.md``).
    joint_stiffness, joint_damping : tuple of float, optional
        Relative pitch and yaw stiffness (N m/rad) and damping (N m s/rad) of the payload joint;
        override ``geometry`` (8-DoF only).
    """

    parameters: tuple[Parameter, ...] = _parameters()
    inputs: tuple[Channel, ...] = _INPUTS
    #: Hand count of floating-point operations per RK4 step (trig, sqrt, division counted as
    #: 10): per right-hand side ~100 trig, ~270 canopy momenta and Kirchhoff terms, ~130
    #: aerodynamics, ~200 payload kinematics and forces, ~80 payload mass and force terms
    #: (written out, see ``system_matrices``), ~70 canopy mass block, ~420 LDL^T 8x8 with both
    #: substitutions, ~80 kinematics, wind and table look-up: ~1,350; 4 evaluations, 192 for
    #: the stage combinations, ~40 controls.
    flops_per_step: ClassVar[int] = 4 * 1350 + 192 + 40
    presets: ClassVar[dict[str, NDArray[np.float64]]] = {"set0": nominal_gains()}
    rigid: ClassVar[bool] = False

    def __init__(
        self,
        *,
        geometry: ParafoilGeometry | Mapping[str, Any] | None = None,
        coefficients: Mapping[str, Any] | None = None,
        extra_parameters: Sequence[str] = (),
        attitude: str = "canopy",
        aerodynamics: bool = True,
        munk_in_static_data: bool = True,
        joint_stiffness: tuple[float, float] | None = None,
        joint_damping: tuple[float, float] | None = None,
    ) -> None:
        if geometry is None:
            geometry = ParafoilGeometry()
        elif isinstance(geometry, Mapping):
            geometry = ParafoilGeometry.from_options(geometry)
        elif not isinstance(geometry, ParafoilGeometry):
            raise ParafoilOptionError(
                f"model option geometry: expected a ParafoilGeometry or a table of its fields, "
                f"got {type(geometry).__name__}"
            )
        changes: dict[str, Any] = {}
        for name, value in (("joint_stiffness", joint_stiffness), ("joint_damping", joint_damping)):
            if value is not None:
                changes[name] = value
        if changes:
            geometry = ParafoilGeometry.from_options(changes, base=geometry)
        geometry.validate()
        self.geometry = geometry
        if coefficients is not None and not isinstance(coefficients, Mapping):
            raise ParafoilOptionError(
                f"model option coefficients: expected a table name -> value, got "
                f"{coefficients!r}; write coefficients = {{ CD0 = 0.12, Cnr = -0.27 }}"
            )
        coefficients = dict(coefficients or {})
        self.extra_coefficients = {
            k: float(_number_option(f"coefficients.{k}", coefficients.pop(k)))
            for k in list(coefficients)
            if k in EXTRA_COEFFICIENTS
        }
        self.reference = reference_coefficients(coefficients)
        self.coefficients = dict(zip(GAIN_NAMES, self.reference.tolist()))
        self.coefficients.update(self.extra_coefficients)
        if isinstance(extra_parameters, str) or not isinstance(extra_parameters, Sequence):
            raise ParafoilOptionError(
                f"model option extra_parameters: expected a list of names, got "
                f'{extra_parameters!r}; write extra_parameters = ["payload_mass"]'
            )
        extra = tuple(str(e) for e in extra_parameters)
        for e in extra:
            if e not in EXTRA_PARAMETERS:
                raise ParafoilOptionError(
                    f"model option extra_parameters: unknown parameter {e!r}; "
                    f"{suggest(e, EXTRA_PARAMETERS)}"
                )
            if extra.count(e) > 1:
                raise ParafoilOptionError(
                    f"model option extra_parameters: {e!r} is listed twice; list it once"
                )
        self.extra_parameters = extra
        if attitude not in ("canopy", "payload"):
            raise ParafoilOptionError(
                f'model option attitude: expected "canopy" or "payload", got {attitude!r}'
            )
        if attitude == "payload" and self.rigid:
            attitude = "canopy"  # one rigid body: the payload's attitude is the canopy's
        self.attitude = attitude
        self.aerodynamics = bool(aerodynamics)
        self.munk_in_static_data = bool(munk_in_static_data)
        self.parameters = _parameters(self.reference, extra, geometry)
        self.presets = {"set0": self.nominal}
        if attitude == "payload":
            self.outputs = BASE_CHANNELS + _CANOPY_CHANNELS + _PAYLOAD_CHANNELS[6:]

    def _split(
        self, X: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64] | None, NDArray[np.float64] | None]:
        """Gains (n, 33), payload masses (n,) or None, wind offsets (n, 2) or None."""
        gains = X[:, :NGAIN]
        mass = wind = None
        names = self.extra_parameters
        if "payload_mass" in names:
            mass = X[:, NGAIN + names.index("payload_mass")]
        if "wind_north" in names or "wind_east" in names:
            wind = np.zeros((X.shape[0], 2))
            for j, key in enumerate(("wind_north", "wind_east")):
                if key in names:
                    wind[:, j] = X[:, NGAIN + names.index(key)]
        return gains, mass, wind

    def _properties(self, X: NDArray[np.float64]) -> NDArray[np.float64]:
        gains, mass, wind = self._split(X)
        return build_properties(
            gains,
            self.geometry,
            aero=self.aerodynamics,
            munk_in_static_data=self.munk_in_static_data,
            reference=self.reference,
            extra_coefficients=self.extra_coefficients,
            payload_mass=mass,
            wind_offset=wind,
        )

    # ---- model quantities -------------------------------------------------------------------
    def constants(self, X: ArrayLike) -> NDArray[np.float64]:
        """Per-trial property rows (see :func:`~vectorid.models.parafoil_aero.build_properties`).

        Returns
        -------
        ndarray, shape (n, NPROP)
        """
        X = self._validate_params(X)
        return self._properties(X)

    def apparent_mass(self, X: ArrayLike, rho: float = 1.225) -> NDArray[np.float64]:
        """Apparent-mass matrix about the joint J in canopy axes, (n, 6, 6), at density ``rho``."""
        k = self.constants(X)
        return rho * k[:, I_MAM : I_MAM + 36].reshape(-1, 6, 6)

    def mass_matrix(
        self,
        X: ArrayLike,
        rho: float = 1.225,
        rel_pitch: float = 0.0,
        rel_yaw: float = 0.0,
    ) -> NDArray[np.float64]:
        """Generalised mass-inertia matrix ``A`` of eq. (1), (n, N, N); N = 8 (6 if rigid).

        Parameters
        ----------
        X : array_like, shape (n, 33)
            Gain vectors.
        rho : float
            Air density, kg/m^3.
        rel_pitch, rel_yaw : float
            Payload joint angles, rad (8-DoF only).
        """
        k = self.constants(X)
        n = 6 if self.rigid else 8
        out = np.empty((k.shape[0], n, n))

        x = np.zeros(NX6 if self.rigid else NX8)
        if not self.rigid:
            x[6], x[7] = rel_pitch, rel_yaw
        for i in range(k.shape[0]):
            a, _, _ = reference_matrices(k[i], rho, 9.80665, x, np.zeros(3), 0.0, 0.0, self.rigid)
            out[i] = a[:n, :n]
        return out

    def mechanical_energy(
        self, X: ArrayLike, states: ArrayLike, rho: float = 1.225, g: float = 9.80665
    ) -> NDArray[np.float64]:
        """Kinetic (with apparent mass, calm air) + potential + joint-spring energy, J.

        Parameters
        ----------
        X : array_like, shape (n, 33)
            Gain vectors.
        states : array_like, shape (n, n_state)
            Full states (16 for 8-DoF, 12 for 6-DoF; layout in ``_parafoil_core``).
        rho, g : float
            Uniform air density (kg/m^3) and gravity (m/s^2).
        """
        k = self.constants(X)
        s = np.atleast_2d(np.asarray(states, dtype=float))
        return np.array(
            [mechanical_energy(k[i], rho, g, s[i], self.rigid) for i in range(k.shape[0])]
        )

    def reference_rhs(
        self,
        x_row: ArrayLike,
        *,
        t_final: float,
        inputs: ControlSchedule | None = None,
        wind: Wind | WindProfile | None = None,
        initial: InitialState | None = None,
        atmosphere: ISA | UniformAtmosphere | None = None,
    ) -> tuple[Callable[[float, NDArray[np.float64]], NDArray[np.float64]], NDArray[np.float64]]:
        """Plain-numpy right-hand side ``f(t, x)`` and initial state ``x0`` of ONE trial.

        The equations of the compiled kernel written independently in matrix form (numpy
        vectors, explicit Jacobians, ``np.linalg.solve``;
        :func:`~vectorid.models._parafoil_core.rhs_reference`), reading density, gravity, wind
        and gusts from the same tables as the kernel: the "what a user would write" baseline
        for ``scipy.integrate.solve_ivp`` and a cross-check of the kernel.
        """
        X, controls, env, initial = self._prepare_reference(
            x_row, t_final, inputs, wind, initial, atmosphere
        )
        pc = self._pack(X)
        x0 = self._initial(pc, initial, controls, env)[0][0]
        k = pc[0, :NPROP].copy()
        atm, gust = env.atm, env.gust
        h_grid = atm[0, 0] + atm[0, 1] * np.arange(int(atm[0, 2]))
        n_g = int(gust[0, 2])
        t_grid = gust[0, 0] + gust[0, 1] * np.arange(n_g)
        rigid = self.rigid

        def f(t: float, x: NDArray[np.float64]) -> NDArray[np.float64]:
            h = -x[2]
            rho = np.interp(h, h_grid, atm[1:, 0])
            g = np.interp(h, h_grid, atm[1:, 1])
            w = np.array([np.interp(h, h_grid, atm[1:, c]) for c in (2, 3, 4)])
            w[0] += k[I_WN]
            w[1] += k[I_WE]
            if n_g > 1:
                w += [np.interp(t, t_grid, gust[1:, c]) for c in range(3)]
            dl, dr = controls(t)
            return rhs_reference(t, x, k, rho, g, w, dl, dr, rigid)

        return f, x0

    def initial_state(
        self,
        params: ArrayLike,
        initial: InitialState | None = None,
        *,
        inputs: ControlSchedule | None = None,
        wind: Wind | WindProfile | None = None,
        atmosphere: ISA | UniformAtmosphere | None = None,
    ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """Initial states used by :meth:`simulate` and whether each trim converged.

        Returns
        -------
        x0 : ndarray, shape (n, n_state)
        trimmed : ndarray of bool, shape (n,)
        """
        X = self._validate_params(params)
        initial = InitialState() if initial is None else initial
        controls = self._validate_inputs(inputs)
        env = Environment.build(
            atmosphere=atmosphere,
            wind=wind,
            h_min=initial.altitude - 10.0,
            h_max=initial.altitude + 10.0,
        )
        pc = self._pack(X)
        return self._initial(pc, initial, controls, env)

    # ---- hooks --------------------------------------------------------------------------------
    def _pack(self, X: NDArray[np.float64]) -> NDArray[np.float64]:
        pc = np.zeros((X.shape[0], NPROP + NWORK))
        pc[:, :NPROP] = self._properties(X)
        return pc

    def _initial(
        self, pc: NDArray[np.float64], initial: InitialState, controls: ControlSchedule, env: Any
    ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        n = pc.shape[0]
        x0 = np.zeros((n, NX6 if self.rigid else NX8))
        trimmed = np.zeros(n, dtype=np.bool_)
        u0 = controls(0.0)
        vel = np.zeros(3) if initial.velocity is None else np.asarray(initial.velocity, float)
        _initial_states(
            pc,
            self.rigid,
            float(initial.altitude),
            float(initial.north),
            float(initial.east),
            initial.velocity is not None,
            vel,
            np.asarray(initial.euler, float),
            np.asarray(initial.rates, float),
            float(u0[0]),
            float(u0[1]),
            env.atm,
            env.gust,
            x0,
            trimmed,
        )
        return x0, trimmed

    def _x_max(self) -> NDArray[np.float64]:
        big = 1e7
        if self.rigid:
            return np.array(
                [big, big, big, math.pi, 1.45, np.inf, 200.0, 200.0, 200.0, 20.0, 20.0, 20.0]
            )
        return np.array(
            [
                big,
                big,
                big,
                math.pi,
                1.45,
                np.inf,
                math.pi,
                4.0 * math.pi,
                200.0,
                200.0,
                200.0,
                20.0,
                20.0,
                20.0,
                50.0,
                50.0,
            ]
        )

    def _check_parameters(self, X: NDArray[np.float64]) -> NDArray[np.int64]:
        """Reject (status 4) gain vectors whose canopy mass matrix is not positive definite,
        and payload masses that are not > 0."""
        k = self._properties(np.where(np.isfinite(X), X, 1.0))
        m = k[:, I_MRB : I_MRB + 36].reshape(-1, 6, 6) + RHO_MAX * k[:, I_MAM : I_MAM + 36].reshape(
            -1, 6, 6
        )
        lam = np.linalg.eigvalsh(0.5 * (m + np.transpose(m, (0, 2, 1))))
        bad = ~(lam[:, 0] > 1e-9 * np.maximum(1.0, lam[:, -1]))
        bad |= ~(k[:, I_MP] > 0.0)
        return np.where(bad, STATUS_REJECTED, 0).astype(np.int64)

    def _simulate(self, X, status, t_fail, *, dt, n_steps, stride, controls, env, initial):
        pc = self._pack(X)
        x0, _ = self._initial(pc, initial, controls, env)
        y = allocate_outputs(X.shape[0], n_steps, stride, len(self.outputs))
        self._run_kernel(
            np.ascontiguousarray(x0),
            pc,
            controls.times,
            controls.values,
            int(controls.mode),
            env.atm,
            env.gust,
            float(dt),
            int(n_steps),
            int(stride),
            self._x_max(),
            y,
            status,
            t_fail,
        )
        if self.attitude == "payload":  # base euler/rates <- payload's, canopy's after the base
            nb = len(BASE_CHANNELS)
            canopy = y[:, :, 6:12].copy()
            y[:, :, 6:12] = y[:, :, nb : nb + 6]
            y[:, :, nb : nb + 6] = canopy
        return y

    def _run_kernel(self, *args: Any) -> None:
        raise NotImplementedError("subclasses bind their own compiled kernel")


class Parafoil8DoF(ParafoilModelBase):
    """8-DoF parafoil-payload model (seed 000 eq. 1-3): canopy 6-DoF + payload relative pitch/yaw.

    See :class:`ParafoilModelBase` for the options and ``docs/models.md`` for the
    equations, frames, constants and sources.
    """

    name: ClassVar[str] = "parafoil8dof"
    #: First compilation in an empty numba cache, s (benchmarks/startup.py --compile: 52 CPU s
    #: with imports; 151 s wall at load 8-11).
    compile_seconds = 50.0
    outputs: tuple[Channel, ...] = BASE_CHANNELS + _PAYLOAD_CHANNELS
    rigid: ClassVar[bool] = False

    def _run_kernel(self, *args: Any) -> None:
        _kernel(*args)
