"""Your own dynamic model: a batch ODE with named states, outputs and parameters.

A :class:`SystemModel` is the form a model of your own takes to be identified from measured
data with the ``[identification]`` table of a study file (noise statements, noise-grounded
limits, the residual criteria, verdicts), like the built-in flight-dynamics models. It has
the same batch interface: ``parameters`` (names, nominal values, the box Π, units),
``states`` and ``outputs`` (named channels with units), and
``simulate(params, t_final=..., dt=..., output_dt=...)`` for a whole batch of parameter
vectors at once.

Write it in plain numpy (the right-hand side ``rhs(t, x, p)`` of a whole batch: the base
class integrates it with fixed-step RK4), or, faster, override :meth:`SystemModel._simulate`
with a compiled kernel (numba) that integrates the batch itself. ``docs/own-model.md`` shows
both.

>>> import numpy as np
>>> from vectorid.models import Channel, Parameter, SystemModel
>>> class Decay(SystemModel):
...     name = "decay"
...     parameters = (Parameter("k", 1.0, 0.1, 5.0, "1/s", "decay rate"),)
...     states = (Channel("y", "m", "level", default=1.0),)
...     outputs = states
...     def rhs(self, t, x, p):
...         return -p[:, :1] * x
>>> res = Decay().simulate([[1.0], [2.0]], t_final=1.0, dt=0.01, output_dt=0.5)
>>> res["y"].round(3)
array([[1.   , 0.607, 0.368],
       [1.   , 0.368, 0.135]])

Such a model is named in a study by import path (``model = "mypkg.dynamics:Oscillator"``,
the study file's folder is on the import path), by a name given to
:func:`vectorid.models.register`, or by a name an installed package declares in the
``vectorid.models`` entry-point group (see :func:`vectorid.models.get`).
"""

from __future__ import annotations

import abc
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vectorid.errors import suggest
from vectorid.models.base import Channel, ChannelResult, Parameter, validate_time
from vectorid.models.integrate import (
    STATUS_BAD_PARAMETER,
    STATUS_NONFINITE,
    STATUS_OK,
)
from vectorid.problem import checked_output

__all__ = ["SystemModel", "SystemResult"]


@dataclass
class SystemResult(ChannelResult):
    """Outputs of a batch simulation of a :class:`SystemModel` on the output grid.

    Attributes
    ----------
    t : ndarray (T,)
        Output times, s (0 at the start of the simulation).
    outputs : ndarray (n, T, C)
        Output channels, in the units of ``model.outputs``; ``channels`` names them.
    channels : tuple of str
    status : ndarray (n,) int
        0 = ok; other codes in :data:`vectorid.models.STATUS_MESSAGES`.
    t_fail : ndarray (n,)
        Time of failure, s (NaN for trials that finished).
    params : ndarray (n, p)
    model : str
    """

    t: NDArray[np.float64]
    outputs: NDArray[np.float64]
    channels: tuple[str, ...]
    status: NDArray[np.int64]
    t_fail: NDArray[np.float64]
    params: NDArray[np.float64]
    model: str


class SystemModel(abc.ABC):  # noqa: B024 - either hook (rhs or _simulate) is the one to write
    """Base class of a user's batch ODE model (see the module docstring).

    Notes
    -----
    Contract for subclasses:

    - Class attributes: ``name`` (shown in messages and stores), ``parameters`` (tuple of
      :class:`~vectorid.models.Parameter`: name, nominal, low, high, unit, meaning; in the
      column order of ``params``), ``states`` (tuple of :class:`~vectorid.models.Channel`
      whose ``default`` is the initial value), ``outputs`` (tuple of ``Channel``: what data
      are compared with; default: the states).
    - Either implement :meth:`rhs` (and :meth:`output` when the outputs are not the states),
      in numpy over the whole batch, or override :meth:`_simulate` with a kernel that
      integrates the batch itself (e.g. numba). Each trial's result must not depend on the
      other trials of the batch.
    - A trial whose state becomes NaN/inf gets status 1 and NaN outputs from that time on;
      it is stored as a failed trial with that reason and the study goes on.
    - What :meth:`rhs`, :meth:`output` and :meth:`_simulate` return is checked before it is
      used: real numbers of exactly the documented shape, (n, states), (n, outputs) and
      (n, output times, outputs). Anything else (an (n, 1) column or a scalar that numpy
      would broadcast, a transposed array, a list of columns) raises
      :class:`~vectorid.problem.ModelOutputError` naming the function, the expected and the
      returned shape.
    - The class must be importable by name (a module-level class), so that process and Dask
      workers can rebuild it; constructor options must be plain values (TOML
      ``model_options``).
    """

    name: ClassVar[str] = ""
    parameters: tuple[Parameter, ...] = ()
    states: tuple[Channel, ...] = ()
    outputs: tuple[Channel, ...] = ()
    #: Not a flight model: no inputs, wind or atmosphere (the identification checks this).
    inputs: tuple[Channel, ...] = ()

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if not cls.outputs and cls.states:
            cls.outputs = cls.states
        if not cls.name:
            cls.name = cls.__name__

    # ---- metadata -----------------------------------------------------------------------
    @property
    def parameter_names(self) -> tuple[str, ...]:
        """Parameter names in column order."""
        return tuple(p.name for p in self.parameters)

    @property
    def state_names(self) -> tuple[str, ...]:
        """State names in the order of the state vector."""
        return tuple(c.name for c in self.states)

    @property
    def output_names(self) -> tuple[str, ...]:
        """Output channel names."""
        return tuple(c.name for c in self.outputs)

    @property
    def input_names(self) -> tuple[str, ...]:
        """Control inputs: none (a SystemModel takes its known inputs as model options)."""
        return ()

    @property
    def nominal(self) -> NDArray[np.float64]:
        """Nominal parameter vector, shape (p,)."""
        return np.array([p.nominal for p in self.parameters], dtype=float)

    @property
    def bounds(self) -> NDArray[np.float64]:
        """Parameter box Π, shape (p, 2): columns low, high."""
        return np.array([[p.low, p.high] for p in self.parameters], dtype=float)

    def unit_of(self, channel: str) -> str:
        """Unit of an output channel.

        Parameters
        ----------
        channel : str
            Output channel name.
        """
        for c in self.outputs:
            if c.name == channel:
                return c.unit
        raise KeyError(f"no output channel {channel!r}; available: {', '.join(self.output_names)}")

    def describe(self) -> str:
        """A plain-text table of the parameters, states and outputs."""
        lines = [f"{self.name}: {len(self.parameters)} parameters"]
        for p in self.parameters:
            lines.append(
                f"  {p.name:<8} nominal={p.nominal:<10.4g} [{p.low:.4g}, {p.high:.4g}] "
                f"{p.unit:<8} {p.meaning}"
            )
        lines.append("states: " + ", ".join(f"{c.name} ({c.unit})" for c in self.states))
        lines.append("outputs: " + ", ".join(f"{c.name} ({c.unit})" for c in self.outputs))
        return "\n".join(lines)

    # ---- hooks --------------------------------------------------------------------------
    def rhs(self, t: float, x: NDArray[np.float64], p: NDArray[np.float64]) -> NDArray[np.float64]:
        """Time derivative of the states of a batch.

        Implement it (numpy over the batch), or override :meth:`_simulate` instead.

        Parameters
        ----------
        t : float
            Time since the start of the simulation, s.
        x : ndarray (n, s)
            States of the trials, in the units of ``states``.
        p : ndarray (n, p)
            Parameters of the trials, in the units of ``parameters``.

        Returns
        -------
        ndarray (n, s)
            d x / d t, in the states' units per second.
        """
        raise NotImplementedError(
            f"{type(self).__name__} must implement rhs(t, x, p) or override _simulate"
        )

    def output(
        self, t: float, x: NDArray[np.float64], p: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Output channels of a batch at time ``t``.

        Default: the states (override when the outputs are not the states, e.g. an
        acceleration).

        Parameters
        ----------
        t : float
            Time since the start of the simulation, s.
        x : ndarray (n, s)
            States of the trials.
        p : ndarray (n, p)
            Parameters of the trials.

        Returns
        -------
        ndarray (n, len(outputs))
            The outputs, in the units of ``outputs``.
        """
        if self.output_names != self.state_names:
            raise NotImplementedError(
                f"{type(self).__name__}: outputs {self.output_names} are not the states "
                f"{self.state_names}; implement output(t, x, p)"
            )
        return x

    def _simulate(
        self,
        X: NDArray[np.float64],
        x0: NDArray[np.float64],
        status: NDArray[np.int64],
        t_fail: NDArray[np.float64],
        *,
        dt: float,
        n_steps: int,
        stride: int,
    ) -> NDArray[np.float64]:
        """Integrate the batch (fixed-step RK4 over :meth:`rhs`); fill ``status`` and
        ``t_fail`` of trials that fail; return the outputs (n, n_steps // stride + 1, C).

        ``X`` (n, p) parameters, ``x0`` (n, s) initial states. Override with a compiled
        kernel for speed; keep the same arguments and result."""
        n = X.shape[0]
        T = n_steps // stride + 1
        y = np.full((n, T, len(self.outputs)), np.nan)
        x = x0.copy()
        live = status == STATUS_OK
        rhs, output = self._checked_rhs, self._checked_output
        with np.errstate(all="ignore"):
            self._probe(x[live][:1], X[live][:1], int(live.sum()))
            y[live, 0] = output(0.0, x[live], X[live])
            for k in range(n_steps):
                t = k * dt
                idx = np.flatnonzero(live)
                if not idx.size:
                    break
                xs, ps = x[idx], X[idx]
                k1 = rhs(t, xs, ps)
                k2 = rhs(t + dt / 2, xs + dt / 2 * k1, ps)
                k3 = rhs(t + dt / 2, xs + dt / 2 * k2, ps)
                k4 = rhs(t + dt, xs + dt * k3, ps)
                xs = xs + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
                bad = ~np.all(np.isfinite(xs), axis=1)
                if bad.any():
                    status[idx[bad]] = STATUS_NONFINITE
                    t_fail[idx[bad]] = t + dt
                    live[idx[bad]] = False
                x[idx] = xs
                if (k + 1) % stride == 0:
                    good = idx[~bad]
                    y[good, (k + 1) // stride] = output(t + dt, x[good], X[good])
        return y

    # ---- the contract of rhs and output, checked ----------------------------------------
    def _where(self, hook: str) -> str:
        cls = type(self)
        return f"{cls.__module__}.{cls.__qualname__}.{hook}"

    def _checked_rhs(
        self, t: float, x: NDArray[np.float64], p: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """:meth:`rhs`, its result checked: (n, states) real numbers."""
        names = ", ".join(self.state_names)
        return checked_output(
            self._where("rhs"),
            self.rhs(t, x, p),
            x.shape,
            f"one row per trial, one column per state: {names}",
        )

    def _checked_output(
        self, t: float, x: NDArray[np.float64], p: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """:meth:`output`, its result checked: (n, outputs) real numbers."""
        names = ", ".join(self.output_names)
        return checked_output(
            self._where("output"),
            self.output(t, x, p),
            (x.shape[0], len(self.outputs)),
            f"one row per trial, one column per output: {names}",
        )

    def _probe(self, x1: NDArray[np.float64], p1: NDArray[np.float64], n: int) -> None:
        """With as many trials as states (or outputs), a transposed result has the right
        shape: one trial alone tells it (``(1, s)`` against ``(s, 1)``)."""
        if not len(x1):
            return
        if n == len(self.states) > 1:
            self._checked_rhs(0.0, x1, p1)
        if n == len(self.outputs) > 1:
            self._checked_output(0.0, x1, p1)

    # ---- simulation ---------------------------------------------------------------------
    def simulate(
        self,
        params: ArrayLike,
        *,
        t_final: float,
        dt: float,
        output_dt: float | None = None,
        initial: Mapping[str, float] | None = None,
    ) -> SystemResult:
        """Simulate a batch of parameter vectors.

        Parameters
        ----------
        params : array_like, shape (n, p) or (p,)
            Parameter vectors, columns in the order of ``parameters``. Rows with NaN/inf get
            status 3 and NaN outputs.
        t_final : float
            Duration, s; a multiple of ``dt``.
        dt : float
            Integration step, s.
        output_dt : float or None
            Output interval, s; a multiple of ``dt`` dividing ``t_final``. ``None``: every step.
        initial : mapping or None
            Initial values of states by name (in the states' units); the others start at
            their ``default``.

        Returns
        -------
        SystemResult
        """
        X = self._validate_params(params)
        dt, n_steps, stride = validate_time(t_final, dt, output_dt)
        x0 = self.initial_state(initial)
        n = X.shape[0]
        status = np.zeros(n, dtype=np.int64)
        finite = np.all(np.isfinite(X), axis=1)
        status[~finite] = STATUS_BAD_PARAMETER
        Xc = np.where(finite[:, None], X, self.nominal[None, :])
        t_fail = np.full(n, np.nan)
        y = self._simulate(
            np.ascontiguousarray(Xc),
            np.ascontiguousarray(np.tile(x0, (n, 1))),
            status,
            t_fail,
            dt=dt,
            n_steps=n_steps,
            stride=stride,
        )
        expected = (n, n_steps // stride + 1, len(self.outputs))
        y = checked_output(
            self._where("_simulate"),
            y,
            expected,
            "trials, output times, outputs " + ", ".join(self.output_names),
        )
        y[status != STATUS_OK] = np.nan
        return SystemResult(
            t=np.arange(expected[1]) * stride * dt,
            outputs=y,
            channels=self.output_names,
            status=status,
            t_fail=t_fail,
            params=X,
            model=self.name,
        )

    def initial_state(self, initial: Mapping[str, float] | None = None) -> NDArray[np.float64]:
        """The initial state vector (s,): the states' defaults, overridden by ``initial``.

        Parameters
        ----------
        initial : mapping, optional
            State name -> initial value, in the state's unit.
        """
        x0 = np.array([c.default for c in self.states], dtype=float)
        for key, value in dict(initial or {}).items():
            if key not in self.state_names:
                raise ValueError(
                    f"{self.name}: {key!r} is not a state (states: "
                    f"{', '.join(self.state_names)}); {suggest(key, self.state_names)}"
                )
            v = float(value)
            if not np.isfinite(v):
                raise ValueError(f"{self.name}: initial {key} must be finite, got {value!r}")
            x0[self.state_names.index(key)] = v
        return x0

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
        if X.ndim != 2 or X.shape[1] != p or X.shape[0] == 0:
            raise ValueError(
                f"{self.name}: params must have shape (n, {p}) with n >= 1 and columns "
                f"{', '.join(self.parameter_names)}; got shape {np.shape(params)}"
            )
        return X
