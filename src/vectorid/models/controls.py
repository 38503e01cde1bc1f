"""Control time histories shared by the whole batch.

A :class:`ControlSchedule` is a table of times (s) against command values, one column per input
channel of a model (``model.inputs`` names the channels, their units and their "no control"
values). Between knots the command is interpolated linearly (``interpolation="linear"``) or held
from the previous knot (``interpolation="previous"``, zero-order hold); before the first knot and
after the last one the end values are held.

Helpers build the two tables the shipped models use:

- :func:`riser_commands` for ``parachute6dof``: relative PMA lengths l̄_k of the four risers
  (1 = lengthened, not actuated; 0 = fully shortened), see docs/models.md;
- :func:`flap_deflections` for the parafoils: left and right trailing-edge flap deflections.

Inside compiled code the table is read by :func:`control_at` (see ``integrate.py``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "INTERP_LINEAR",
    "INTERP_PREVIOUS",
    "ControlSchedule",
    "control_at",
    "flap_deflections",
    "riser_commands",
]

INTERP_LINEAR = 0
INTERP_PREVIOUS = 1
_MODES = {"linear": INTERP_LINEAR, "previous": INTERP_PREVIOUS}


@dataclass(frozen=True)
class ControlSchedule:
    """Piecewise-linear or zero-order-hold table of control commands versus time.

    Parameters
    ----------
    times : array_like, shape (K,)
        Knot times in s, strictly increasing (K >= 1).
    values : array_like, shape (K, m)
        Command of each channel at each knot, in the channel's unit (``model.inputs``).
    channels : sequence of str
        Channel names, length m, in the order of the columns of ``values``.
    interpolation : {"linear", "previous"}
        Linear interpolation or zero-order hold between knots.
    """

    times: NDArray[np.float64]
    values: NDArray[np.float64]
    channels: tuple[str, ...]
    interpolation: str = "linear"
    mode: int = field(init=False, repr=False)

    def __post_init__(self) -> None:
        t = np.asarray(self.times, dtype=float)
        v = np.asarray(self.values, dtype=float)
        ch = tuple(str(c) for c in self.channels)
        if t.ndim != 1 or t.size < 1:
            raise ValueError(
                f"times must be a 1-D array with at least one knot, got shape {t.shape}"
            )
        if v.ndim == 1 and len(ch) == 1:
            v = v[:, None]
        if v.shape != (t.size, len(ch)):
            raise ValueError(
                f"values must have shape (len(times), len(channels)) = ({t.size}, {len(ch)}), "
                f"got {v.shape}"
            )
        if not np.all(np.isfinite(t)) or not np.all(np.isfinite(v)):
            raise ValueError("times and values must be finite; remove NaN/inf knots")
        if t.size > 1 and np.any(np.diff(t) <= 0):
            i = int(np.argmax(np.diff(t) <= 0))
            raise ValueError(
                f"times must be strictly increasing; times[{i}]={t[i]} >= times[{i + 1}]={t[i + 1]}"
            )
        if self.interpolation not in _MODES:
            raise ValueError(
                f"interpolation must be one of {sorted(_MODES)}, got {self.interpolation!r}"
            )
        object.__setattr__(self, "times", np.ascontiguousarray(t))
        object.__setattr__(self, "values", np.ascontiguousarray(v))
        object.__setattr__(self, "channels", ch)
        object.__setattr__(self, "mode", _MODES[self.interpolation])

    @classmethod
    def constant(cls, channels: Sequence[str], values: ArrayLike) -> ControlSchedule:
        """A schedule that holds ``values`` (one per channel) for all times."""
        v = np.atleast_1d(np.asarray(values, dtype=float))
        return cls(np.zeros(1), v[None, :], tuple(channels))

    def __call__(self, t: ArrayLike) -> NDArray[np.float64]:
        """Commands at times ``t`` (s), shape ``t.shape + (m,)``."""
        t = np.asarray(t, dtype=float)
        out = np.empty((*t.shape, len(self.channels)))
        flat = out.reshape(-1, len(self.channels))
        for i, ti in enumerate(t.reshape(-1)):
            control_at(self.times, self.values, self.mode, float(ti), flat[i])
        return out

    def reorder(self, channels: Sequence[str], defaults: Sequence[float]) -> ControlSchedule:
        """The same schedule with columns in the order ``channels``.

        Channels missing from this schedule take the constant value from ``defaults``; a channel
        of this schedule that is not in ``channels`` raises ``ValueError``.
        """
        unknown = [c for c in self.channels if c not in channels]
        if unknown:
            raise ValueError(
                f"control channels {unknown} are not inputs of this model; expected a subset of "
                f"{list(channels)}"
            )
        v = np.empty((self.times.size, len(channels)))
        for j, c in enumerate(channels):
            v[:, j] = self.values[:, self.channels.index(c)] if c in self.channels else defaults[j]
        return ControlSchedule(self.times, v, tuple(channels), self.interpolation)


@njit(cache=True, inline="always")
def control_at(times, values, mode, t, u):  # pragma: no cover - compiled
    """Write the commands at time ``t`` into ``u`` (m,), from a schedule's arrays (compiled)."""
    n = times.shape[0]
    m = values.shape[1]
    if n == 1 or t <= times[0]:
        for j in range(m):
            u[j] = values[0, j]
        return
    if t >= times[n - 1]:
        for j in range(m):
            u[j] = values[n - 1, j]
        return
    lo = 0
    hi = n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if times[mid] <= t:
            lo = mid
        else:
            hi = mid
    if mode == 1:
        for j in range(m):
            u[j] = values[lo, j]
        return
    w = (t - times[lo]) / (times[hi] - times[lo])
    for j in range(m):
        u[j] = values[lo, j] + w * (values[hi, j] - values[lo, j])


def riser_commands(
    times: ArrayLike,
    lengths: ArrayLike,
    *,
    interpolation: str = "previous",
) -> ControlSchedule:
    """Riser (pneumatic muscle actuator) commands for ``parachute6dof``.

    Parameters
    ----------
    times : array_like, shape (K,)
        Times in s at which the commands change.
    lengths : array_like, shape (K, 4)
        Commanded relative PMA length l̄_k of risers 1..4, dimensionless in [0, 1]:
        1 = lengthened (not actuated, the default), 0 = fully shortened. The actuator model in
        the parachute moves the real length towards the command at a finite rate (4.5 s for a
        full stroke, seed 001 §V.B), so a step command is the natural input.
    interpolation : {"previous", "linear"}
        Zero-order hold (default, on/off valve commands) or linear ramps.
    """
    v = np.asarray(lengths, dtype=float)
    if v.ndim != 2 or v.shape[1] != 4:
        raise ValueError(f"lengths must have shape (K, 4) for risers 1..4, got {v.shape}")
    if np.any((v < 0) | (v > 1)):
        raise ValueError("riser relative lengths must lie in [0, 1] (1 = not actuated)")
    return ControlSchedule(times, v, ("riser1", "riser2", "riser3", "riser4"), interpolation)


def flap_deflections(
    times: ArrayLike,
    left: ArrayLike,
    right: ArrayLike,
    *,
    interpolation: str = "linear",
) -> ControlSchedule:
    """Left/right trailing-edge flap deflections for the parafoil models.

    Parameters
    ----------
    times : array_like, shape (K,)
        Knot times in s.
    left, right : array_like, shape (K,)
        Flap deflections; the unit is the one the parafoil model lists in ``model.inputs``
        (channels ``"flap_left"`` and ``"flap_right"``).
    interpolation : {"linear", "previous"}
        Linear ramps (default) or zero-order hold.
    """
    l_ = np.asarray(left, dtype=float)
    r_ = np.asarray(right, dtype=float)
    if l_.shape != r_.shape or l_.ndim != 1:
        raise ValueError(
            f"left and right must be 1-D arrays of the same length, got {l_.shape} and {r_.shape}"
        )
    return ControlSchedule(
        times, np.stack([l_, r_], axis=1), ("flap_left", "flap_right"), interpolation
    )
