"""Model base class, parameter and channel metadata, simulation results.

A model is configured once (constructor options such as ``aerodynamics=False``) and then
simulates whole batches: ``model.simulate(X, t_final=..., dt=...)`` with ``X`` of shape (n, p).
Validation, the time grid, controls, environment tables and result bookkeeping live here, once;
a concrete model implements only the hook :meth:`Model._simulate` (and usually
:meth:`Model._check_parameters`). How the compiled kernel of a model is written is described in
:mod:`vectorid.models.integrate`.
"""

from __future__ import annotations

import abc
import contextlib
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from vectorid._hints import waiting
from vectorid.models.atmosphere import ISA, UniformAtmosphere
from vectorid.models.controls import ControlSchedule
from vectorid.models.integrate import (
    STATUS_BAD_PARAMETER,
    STATUS_MESSAGES,
    STATUS_OK,
    Environment,
)
from vectorid.models.wind import Wind, WindProfile

#: Trials per chunk of the parallel kernels' work queue (see :meth:`Model.simulate`).
PARALLEL_CHUNK = 4
#: Model classes whose compilation this process has checked (and announced if cold).
_ANNOUNCED: set[type] = set()

__all__ = [
    "BASE_CHANNELS",
    "Channel",
    "InitialState",
    "Model",
    "Parameter",
    "SimulationResult",
]


@dataclass(frozen=True)
class Parameter:
    """One model parameter (design variable).

    Parameters
    ----------
    name : str
        Identifier, e.g. ``"x6"`` or ``"kCD0"``.
    nominal : float
        Nominal value (``model.nominal``).
    low, high : float
        Bounds of the parameter box Π used for sampling. ``simulate`` accepts values outside
        the box (identification may widen it); only NaN/inf are rejected (status 3).
    unit : str
        Unit, ``"-"`` if dimensionless.
    meaning : str
        What the parameter multiplies or sets, with the equation it enters.
    """

    name: str
    nominal: float
    low: float
    high: float
    unit: str = "-"
    meaning: str = ""

    def __post_init__(self) -> None:
        if not self.low <= self.high:
            raise ValueError(f"parameter {self.name}: low={self.low} > high={self.high}")


@dataclass(frozen=True)
class Channel:
    """An input or output channel: name, unit, meaning and (for inputs) the no-control value."""

    name: str
    unit: str
    meaning: str = ""
    default: float = 0.0


#: Output channels every model provides first, in this order (see ``integrate``).
BASE_CHANNELS: tuple[Channel, ...] = (
    Channel("north", "m", "position north of the origin (NED)"),
    Channel("east", "m", "position east of the origin (NED)"),
    Channel("down", "m", "position down (NED); altitude = -down"),
    Channel("v_north", "m/s", "inertial velocity, north"),
    Channel("v_east", "m/s", "inertial velocity, east"),
    Channel("v_down", "m/s", "inertial velocity, down"),
    Channel("phi", "rad", "roll angle (3-2-1 Euler)"),
    Channel("theta", "rad", "pitch angle (3-2-1 Euler)"),
    Channel("psi", "rad", "yaw angle (3-2-1 Euler), not wrapped"),
    Channel("p", "rad/s", "body roll rate"),
    Channel("q", "rad/s", "body pitch rate"),
    Channel("r", "rad/s", "body yaw rate"),
    Channel("airspeed", "m/s", "airspeed (model-specific reference point)"),
    Channel("alpha", "rad", "angle of attack (model-specific definition)"),
    Channel("beta", "rad", "sideslip angle (model-specific definition)"),
)
_N_BASE = len(BASE_CHANNELS)


@dataclass(frozen=True)
class InitialState:
    """Initial conditions shared by all trials of a batch.

    Parameters
    ----------
    altitude : float
        Initial altitude above mean sea level, m (the NED origin is at altitude 0 below the
        start point: position starts at (north, east, -altitude)).
    north, east : float
        Initial horizontal position, m.
    velocity : array_like (3,) or None
        Initial inertial velocity (north, east, down), m/s. ``None``: the model's steady flight
        estimate for each trial (steady descent for a parachute, trim glide for a parafoil).
    euler : array_like (3,)
        Initial roll, pitch, yaw, rad.
    rates : array_like (3,)
        Initial body rates p, q, r, rad/s.
    """

    altitude: float = 1_000.0
    north: float = 0.0
    east: float = 0.0
    velocity: tuple[float, float, float] | None = None
    euler: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rates: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        for name in ("altitude", "north", "east"):
            v = getattr(self, name)
            if not np.isfinite(v):
                raise ValueError(f"initial {name} must be finite, got {v!r}")
        for name in ("velocity", "euler", "rates"):
            v = getattr(self, name)
            if v is None:
                continue
            a = np.asarray(v, dtype=float)
            if a.shape != (3,) or not np.all(np.isfinite(a)):
                raise ValueError(f"initial {name} must be 3 finite numbers, got {v!r}")
            object.__setattr__(self, name, tuple(float(z) for z in a))


class ChannelResult:
    """What every batch simulation result offers: channels by name, the trials that finished
    and one message per trial (a base of :class:`SimulationResult` and of
    :class:`vectorid.models.system.SystemResult`, which hold ``outputs``, ``channels``,
    ``status`` and ``t_fail``)."""

    outputs: NDArray[np.float64]
    channels: tuple[str, ...]
    status: NDArray[np.int64]
    t_fail: NDArray[np.float64]

    def __getitem__(self, channel: str) -> NDArray[np.float64]:
        """Output channel by name, shape (n, T)."""
        try:
            return self.outputs[:, :, self.channels.index(channel)]
        except ValueError:
            raise KeyError(
                f"no output channel {channel!r}; available: {', '.join(self.channels)}"
            ) from None

    @property
    def ok(self) -> NDArray[np.bool_]:
        """Mask of trials that finished (status 0)."""
        return self.status == STATUS_OK

    @property
    def messages(self) -> list[str]:
        """One message per trial explaining its status."""
        out = []
        for s, tf in zip(self.status.tolist(), self.t_fail.tolist()):
            msg = STATUS_MESSAGES.get(s, f"unknown status {s}")
            out.append(msg if s == STATUS_OK or not np.isfinite(tf) else f"{msg} (t = {tf:g} s)")
        return out


@dataclass
class SimulationResult(ChannelResult):
    """Outputs of a batch simulation on the output grid.

    Attributes
    ----------
    t : ndarray (T,)
        Output times, s.
    outputs : ndarray (n, T, C)
        All output channels; ``channels`` names them. The arrays below are views into it.
    position, velocity, euler, rates : ndarray (n, T, 3)
        NED position (m), inertial velocity (m/s), 3-2-1 Euler angles (rad), body rates (rad/s).
    airspeed, alpha, beta : ndarray (n, T)
        Airspeed (m/s), angle of attack and sideslip (rad), definitions in ``model.outputs``.
    status : ndarray (n,) int
        0 = ok; other codes in ``STATUS_MESSAGES`` (``messages`` gives one line per trial).
    t_fail : ndarray (n,)
        Time of failure, s (NaN for trials that finished).
    origin_altitude : float
        Altitude above mean sea level of the origin that ``position`` (its ``down``) is
        measured from, m: 0 for a model's own simulation (down = -altitude above sea level);
        a drop's origin altitude where an identification returns positions relative to the
        drop's origin (:meth:`vectorid.identify.Identification.simulate`).
    """

    t: NDArray[np.float64]
    outputs: NDArray[np.float64]
    channels: tuple[str, ...]
    status: NDArray[np.int64]
    t_fail: NDArray[np.float64]
    params: NDArray[np.float64]
    model: str
    origin_altitude: float = 0.0
    position: NDArray[np.float64] = field(init=False, repr=False)
    velocity: NDArray[np.float64] = field(init=False, repr=False)
    euler: NDArray[np.float64] = field(init=False, repr=False)
    rates: NDArray[np.float64] = field(init=False, repr=False)
    airspeed: NDArray[np.float64] = field(init=False, repr=False)
    alpha: NDArray[np.float64] = field(init=False, repr=False)
    beta: NDArray[np.float64] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        y = self.outputs
        self.position = y[:, :, 0:3]
        self.velocity = y[:, :, 3:6]
        self.euler = y[:, :, 6:9]
        self.rates = y[:, :, 9:12]
        self.airspeed = y[:, :, 12]
        self.alpha = y[:, :, 13]
        self.beta = y[:, :, 14]


class Model(abc.ABC):
    """Base class of the batch flight-dynamics models.

    Notes
    -----
    Contract for subclasses:

    - Class attributes: ``name`` (registry name), ``parameters`` (tuple of :class:`Parameter`,
      in the column order of ``params``), ``inputs`` (tuple of :class:`Channel`, with the
      no-control value in ``default``), ``outputs`` (tuple of :class:`Channel`, starting with
      :data:`BASE_CHANNELS`), ``presets`` (name -> (p,) vector).
    - Implement :meth:`_simulate`: it receives validated float64 arrays, must integrate every
      trial whose ``status`` is 0, must not touch other rows of ``status`` except to set a
      non-zero code, and must return an (n, T, len(outputs)) array. It must be batch-first
      (no Python loop over trials) and must give each trial a result that does not depend on
      the other trials of the batch (so a good trial is bit-identical alone and in a batch).
    - Optionally override :meth:`_check_parameters` to reject non-physical parameter vectors
      (status 4) before integration, and :meth:`altitude_range` if the tables must cover more.
    - ``simulate`` itself is not overridden.
    - Compilation: the module-level numba dispatcher ``_kernel`` of the model's module is what
      :meth:`kernel_cached` checks (override :meth:`_kernels` otherwise); set
      ``compile_seconds`` to the measured first compile (``benchmarks/startup.py --compile``)
      so that the "compiling ..." message says how long to wait.
    """

    name: ClassVar[str] = ""
    parameters: tuple[Parameter, ...] = ()
    inputs: tuple[Channel, ...] = ()
    outputs: tuple[Channel, ...] = BASE_CHANNELS
    presets: Mapping[str, NDArray[np.float64]] = {}
    #: Seconds the first compilation of the model's kernel takes (numba, empty cache, 2 cores),
    #: measured and quoted in the "compiling ..." message; None: not measured.
    compile_seconds: ClassVar[float | None] = None

    # ---- compilation ----------------------------------------------------------------------
    def _kernels(self) -> list[Any]:
        """The numba dispatchers ``_simulate`` calls: by default the ``_kernel`` of the model's
        module. Override when a model's kernel lives elsewhere."""
        kernel = getattr(sys.modules[type(self).__module__], "_kernel", None)
        return [kernel] if hasattr(kernel, "signatures") else []

    def kernel_cached(self) -> bool | None:
        """Whether the compiled kernel is ready without compiling: loaded in this process, or
        in numba's on-disk cache for this machine and this source. ``None``: cannot tell."""
        kernels = self._kernels()
        if not kernels:
            return None
        try:
            for k in kernels:
                if k.signatures:
                    continue
                cache = k._cache  # numba internals, read only: FunctionCache
                codegen = k.targetctx.codegen()
                index = cache._cache_file._load_index()  # {} when missing or stale
                if not any(cache._index_key(key[0], codegen) == key for key in index):
                    return False
        except Exception:  # numba's private API moved: say nothing rather than guess
            return None
        return True

    def _compiling(self) -> contextlib.AbstractContextManager[None]:
        """Signs of life around the first call, once per process and model, when the kernel
        is about to be compiled: what is compiled and the seconds waited so far
        (:func:`vectorid._hints.waiting`), then how long it took."""
        if type(self) in _ANNOUNCED:
            return contextlib.nullcontext()
        _ANNOUNCED.add(type(self))
        if self.kernel_cached() is not False:
            return contextlib.nullcontext()
        kernels = ", ".join(
            f"{getattr(k, '__module__', '?')}.{getattr(k, '__name__', '?')}"
            for k in self._kernels()
        )
        about = (
            f"about {self.compile_seconds:.0f} s on 2 quiet cores"
            if self.compile_seconds
            else "up to a minute on 2 quiet cores"
        )
        return waiting(
            f"compiling the {self.name} model's kernel ({kernels})",
            note=f"numba, first use only, cached on disk afterwards; {about}",
        )

    def compile(self) -> bool:
        """Compile the model's kernel now unless it is cached, saying so on stderr.

        Call it before a run whose progress should not sit still while the kernel compiles
        (``vectorid demo`` does). Returns whether it compiled.
        """
        if self.kernel_cached() is not False:
            return False
        self.simulate(self.nominal[None, :], t_final=0.1, dt=0.05)
        return True

    # ---- metadata -----------------------------------------------------------------------
    @property
    def parameter_names(self) -> tuple[str, ...]:
        """Parameter names in column order."""
        return tuple(p.name for p in self.parameters)

    @property
    def nominal(self) -> NDArray[np.float64]:
        """Nominal parameter vector, shape (p,)."""
        return np.array([p.nominal for p in self.parameters], dtype=float)

    @property
    def bounds(self) -> NDArray[np.float64]:
        """Parameter box Π, shape (p, 2): columns low, high."""
        return np.array([[p.low, p.high] for p in self.parameters], dtype=float)

    @property
    def input_names(self) -> tuple[str, ...]:
        """Control input channel names, in the column order of a control schedule."""
        return tuple(c.name for c in self.inputs)

    @property
    def output_names(self) -> tuple[str, ...]:
        """Output channel names."""
        return tuple(c.name for c in self.outputs)

    def describe(self) -> str:
        """A plain-text table of the parameters."""
        lines = [f"{self.name}: {len(self.parameters)} parameters"]
        for p in self.parameters:
            lines.append(
                f"  {p.name:<8} nominal={p.nominal:<10.4g} [{p.low:.4g}, {p.high:.4g}] "
                f"{p.unit:<8} {p.meaning}"
            )
        return "\n".join(lines)

    # ---- simulation ---------------------------------------------------------------------
    def simulate(
        self,
        params: ArrayLike,
        *,
        t_final: float,
        dt: float,
        inputs: ControlSchedule | None = None,
        wind: Wind | WindProfile | None = None,
        output_dt: float | None = None,
        initial: InitialState | None = None,
        atmosphere: ISA | UniformAtmosphere | None = None,
    ) -> SimulationResult:
        """Simulate a batch of parameter vectors with fixed-step RK4.

        Parameters
        ----------
        params : array_like, shape (n, p) or (p,)
            Parameter vectors, columns in the order of ``parameters`` (a 1-D vector is one
            trial). Rows with NaN/inf get status 3 and NaN outputs; the others are integrated.
        t_final : float
            Duration, s; a multiple of ``dt``.
        dt : float
            Integration step, s.
        inputs : ControlSchedule or None
            Control commands versus time (channels named in ``inputs``; missing channels take
            their no-control value). ``None``: no control.
        wind : Wind, WindProfile or None
            Wind field; ``None``: calm air.
        output_dt : float or None
            Output interval, s; a multiple of ``dt`` dividing ``t_final``. ``None``: every step.
        initial : InitialState or None
            Initial conditions; ``None``: ``InitialState()`` (1000 m, steady flight).
        atmosphere : ISA, UniformAtmosphere or None
            Atmosphere; ``None``: ISA.

        Returns
        -------
        SimulationResult
        """
        X = self._validate_params(params)
        dt, n_steps, stride = validate_time(t_final, dt, output_dt)
        controls = self._validate_inputs(inputs)
        initial = InitialState() if initial is None else initial
        if not isinstance(initial, InitialState):
            raise TypeError(f"initial must be an InitialState, got {type(initial).__name__}")
        h_min, h_max = self.altitude_range(initial, n_steps * dt)
        env = Environment.build(
            atmosphere=atmosphere,
            wind=wind,
            h_min=h_min,
            h_max=h_max,
            t_final=n_steps * dt,
            h0=initial.altitude,
        )
        n = X.shape[0]
        status = np.zeros(n, dtype=np.int64)
        finite = np.all(np.isfinite(X), axis=1)
        status[~finite] = STATUS_BAD_PARAMETER
        Xc = np.where(finite[:, None], X, self.nominal[None, :])
        status |= np.where(status == 0, self._check_parameters(Xc), 0).astype(np.int64)
        t_fail = np.full(n, np.nan)
        # Trials that diverge stop early, so equal static shares of the batch leave threads
        # idle; small chunks handed out on demand keep every core busy (measured: 6 % faster
        # on the parafoil box, where half the trials stop early), and on a shared machine a
        # thread that gets less of its core takes fewer chunks (benchmarks/models.py --busy 1:
        # 63-69 % of the quiet throughput with one CPU-bound process beside it on 2 cores).
        with self._compiling(), numba.parallel_chunksize(PARALLEL_CHUNK):
            y = self._simulate(
                np.ascontiguousarray(Xc),
                status,
                t_fail,
                dt=dt,
                n_steps=n_steps,
                stride=stride,
                controls=controls,
                env=env,
                initial=initial,
            )
        expected = (n, n_steps // stride + 1, len(self.outputs))
        if y.shape != expected:  # a model bug, not a user error
            raise RuntimeError(f"{self.name}: _simulate returned {y.shape}, expected {expected}")
        return SimulationResult(
            t=np.arange(expected[1]) * stride * dt,
            outputs=y,
            channels=self.output_names,
            status=status,
            t_fail=t_fail,
            params=X,
            model=self.name,
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

        Optional: a model that provides it can be checked against its compiled kernel and
        benchmarked against ``scipy.integrate.solve_ivp`` (benchmarks/models.py). It must use the
        same state layout and equations as the compiled right-hand side.

        Parameters
        ----------
        x_row : (p,) or (1, p) array of float
            One parameter vector, in the parameters' units.
        t_final : float
            Flight time, s.
        inputs, wind, initial, atmosphere : optional
            As for :meth:`simulate`.

        Returns
        -------
        f : callable
            ``f(t, x) -> dx/dt`` with ``t`` in s and the model's state layout.
        x0 : ndarray
            The initial state.
        """
        raise NotImplementedError(f"{self.name} has no plain-numpy reference right-hand side")

    def _prepare_reference(
        self, x_row: ArrayLike, t_final: float, inputs, wind, initial, atmosphere
    ) -> tuple[NDArray[np.float64], ControlSchedule, Environment, InitialState]:
        """Shared validation for :meth:`reference_rhs` implementations."""
        X = self._validate_params(x_row)
        if X.shape[0] != 1:
            raise ValueError(f"reference_rhs takes one parameter vector, got {X.shape[0]}")
        controls = self._validate_inputs(inputs)
        initial = InitialState() if initial is None else initial
        h_min, h_max = self.altitude_range(initial, t_final)
        env = Environment.build(
            atmosphere=atmosphere,
            wind=wind,
            h_min=h_min,
            h_max=h_max,
            t_final=t_final,
            h0=initial.altitude,
        )
        return X, controls, env, initial

    def altitude_range(self, initial: InitialState, t_final: float) -> tuple[float, float]:
        """Altitudes the environment tables must cover; default: ground-500 m to h0+2 km.

        Parameters
        ----------
        initial : InitialState
            The initial state (its altitude, m).
        t_final : float
            Flight time, s.

        Returns
        -------
        (float, float)
            Lowest and highest altitude, m.
        """
        return min(-500.0, initial.altitude - 5_000.0), initial.altitude + 2_000.0

    def _check_parameters(self, X: NDArray[np.float64]) -> NDArray[np.int64]:
        """Status per row before integration (0 = accept). Override to reject with code 4."""
        return np.zeros(X.shape[0], dtype=np.int64)

    @abc.abstractmethod
    def _simulate(
        self,
        X: NDArray[np.float64],
        status: NDArray[np.int64],
        t_fail: NDArray[np.float64],
        *,
        dt: float,
        n_steps: int,
        stride: int,
        controls: ControlSchedule,
        env: Environment,
        initial: InitialState,
    ) -> NDArray[np.float64]:
        """Integrate the batch; fill ``status`` and ``t_fail`` in place; return (n, T, C)."""

    # ---- validation helpers -----------------------------------------------------------------
    def _validate_params(self, params: ArrayLike) -> NDArray[np.float64]:
        try:
            X = np.array(params, dtype=float)
        except (TypeError, ValueError) as exc:
            raise TypeError(
                f"params must be a numeric array of shape (n, {len(self.parameters)}); "
                f"could not convert it to float: {exc}"
            ) from None
        p = len(self.parameters)
        if X.ndim == 1:
            X = X[None, :]
        if X.ndim != 2 or X.shape[1] != p:
            raise ValueError(
                f"{self.name}: params must have shape (n, {p}) with columns "
                f"{', '.join(self.parameter_names)}; got shape {np.shape(params)}. "
                f"Use model.nominal[None, :] for one nominal trial."
            )
        if X.shape[0] == 0:
            raise ValueError(f"{self.name}: params has no rows; pass at least one trial")
        return X

    def _validate_inputs(self, inputs: ControlSchedule | None) -> ControlSchedule:
        names = self.input_names
        defaults = [c.default for c in self.inputs]
        if inputs is None:
            return (
                ControlSchedule.constant(names, defaults)
                if names
                else ControlSchedule(np.zeros(1), np.zeros((1, 1)), ("none",))
            )
        if not isinstance(inputs, ControlSchedule):
            raise TypeError(
                f"inputs must be a ControlSchedule (see vectorid.models.controls) or None, got "
                f"{type(inputs).__name__}"
            )
        return inputs.reorder(names, defaults)


def validate_time(t_final: float, dt: float, output_dt: float | None) -> tuple[float, int, int]:
    for name, v in (("t_final", t_final), ("dt", dt)):
        if not isinstance(v, int | float | np.floating | np.integer) or not np.isfinite(v):
            raise ValueError(f"{name} must be a finite number of seconds, got {v!r}")
    if dt <= 0:
        raise ValueError(f"dt must be > 0 s, got dt={dt}")
    if t_final <= 0:
        raise ValueError(f"t_final must be > 0 s, got t_final={t_final}")
    n_steps = round(t_final / dt)
    if n_steps < 1 or abs(n_steps * dt - t_final) > 1e-9 * max(1.0, t_final):
        raise ValueError(
            f"t_final must be a whole number of steps dt: t_final={t_final} s, dt={dt} s gives "
            f"{t_final / dt:.6g} steps; choose t_final = k*dt"
        )
    if output_dt is None:
        return float(dt), int(n_steps), 1
    if not np.isfinite(output_dt) or output_dt <= 0:
        raise ValueError(f"output_dt must be > 0 s, got {output_dt!r}")
    stride = round(output_dt / dt)
    if stride < 1 or abs(stride * dt - output_dt) > 1e-9 * max(1.0, output_dt):
        raise ValueError(
            f"output_dt must be a whole multiple of dt: output_dt={output_dt} s, dt={dt} s "
            f"(ratio {output_dt / dt:.6g}); choose output_dt = k*dt"
        )
    if n_steps % stride:
        raise ValueError(
            f"t_final must be a multiple of output_dt: t_final={t_final} s, output_dt={output_dt} s"
        )
    return float(dt), int(n_steps), int(stride)
