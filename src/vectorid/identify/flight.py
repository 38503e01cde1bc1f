"""Flight data: channels with their own time bases, events, window selection.

A drop (or any test flight) is a :class:`FlightData`: a set of :class:`FlightChannel` objects, each
sampled on its own time base (GPS at 1–4 Hz, IMU up to 100 Hz), plus named events (times in s)
and the geodetic origin of the local north-east-down (NED) frame.

Standard channel names and units (loaders convert to these):

============  ====================================  ==========================================
name          components                            unit
============  ====================================  ==========================================
position      north, east, down                     m, NED relative to ``origin``
velocity      north, east, down                     m/s, NED
euler         roll, pitch, yaw                      rad
rates         p, q, r (body)                        rad/s
altitude      altitude                              m above the origin, positive up
controls      one column per control (named)        as given (e.g. riser commands in [0, 1])
============  ====================================  ==========================================

Other channels (pressure, temperature, ...) may be present with their own names and units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vectorid.errors import VectoridError, suggest

__all__ = ["STANDARD_CHANNELS", "FlightChannel", "FlightData", "FlightDataError"]

#: Standard channel names -> (default components, SI unit).
STANDARD_CHANNELS: dict[str, tuple[tuple[str, ...], str]] = {
    "position": (("north", "east", "down"), "m"),
    "velocity": (("north", "east", "down"), "m/s"),
    "euler": (("roll", "pitch", "yaw"), "rad"),
    "rates": (("p", "q", "r"), "rad/s"),
    "altitude": (("altitude",), "m"),
    "controls": ((), "1"),
}


class FlightDataError(VectoridError, ValueError):
    """Flight data, a flight-data file or a window on it is invalid.

    The message says what was expected, what came and how to fix it.
    """


def _fmt_t(x: float) -> str:
    return f"{x:.6g} s"


@dataclass(frozen=True)
class FlightChannel:
    """One measured (or simulated) signal of a :class:`FlightData`, with its own time base.

    (A model declares the channels it reads and writes with :class:`vectorid.models.Channel`:
    a name, unit and meaning, no samples.)

    Parameters
    ----------
    name : str
        Channel name (see the module docstring for the standard names).
    t : ndarray, shape (T,)
        Sample times, s, finite and strictly increasing, T >= 1.
    values : ndarray, shape (T, m)
        Samples, float64, finite (a 1-D array is taken as one column).
    components : tuple of str
        Names of the m columns.
    unit : str
        Unit of the values (SI for the standard channels).
    """

    name: str
    t: NDArray[np.float64]
    values: NDArray[np.float64]
    components: tuple[str, ...]
    unit: str

    def __post_init__(self) -> None:
        t = np.asarray(self.t, dtype=np.float64)
        v = np.asarray(self.values, dtype=np.float64)
        if v.ndim == 1:
            v = v[:, None]
        where = f"channel {self.name!r}"
        if t.ndim != 1 or t.size < 1:
            raise FlightDataError(
                f"{where}: expected a 1-D array of at least one time, got shape {t.shape}"
            )
        if v.ndim != 2 or v.shape[0] != t.size:
            raise FlightDataError(
                f"{where}: expected values of shape ({t.size}, m) to match {t.size} times, "
                f"got shape {v.shape}"
            )
        comps = tuple(str(c) for c in self.components)
        if len(comps) != v.shape[1]:
            raise FlightDataError(
                f"{where}: {v.shape[1]} value columns but {len(comps)} component names "
                f"{comps}; give one name per column"
            )
        if not np.all(np.isfinite(t)):
            k = int(np.flatnonzero(~np.isfinite(t))[0])
            raise FlightDataError(
                f"{where}: time must be finite, got {t[k]} at sample {k}; drop those samples"
            )
        if t.size > 1:
            bad = np.flatnonzero(np.diff(t) <= 0)
            if bad.size:
                k = int(bad[0])
                raise FlightDataError(
                    f"{where}: time must be strictly increasing, but sample {k + 1} "
                    f"(t={_fmt_t(t[k + 1])}) does not come after sample {k} "
                    f"(t={_fmt_t(t[k])}) ({bad.size} such place(s)); sort the samples and "
                    "remove duplicated timestamps"
                )
        if not np.all(np.isfinite(v)):
            k = int(np.flatnonzero(~np.all(np.isfinite(v), axis=1))[0])
            raise FlightDataError(
                f"{where}: values must be finite, got {v[k]} at t={_fmt_t(t[k])}; drop or "
                "fill those samples (the loaders do this for gaps up to max_gap)"
            )
        t.setflags(write=False)
        v.setflags(write=False)
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "values", v)
        object.__setattr__(self, "components", comps)

    @property
    def m(self) -> int:
        """Number of columns."""
        return int(self.values.shape[1])

    def at(self, t: ArrayLike) -> NDArray[np.float64]:
        """Values at times ``t`` by linear interpolation between samples.

        Parameters
        ----------
        t : array_like, shape (K,)
            Times, s, inside ``[self.t[0], self.t[-1]]``.

        Returns
        -------
        ndarray, shape (K, m)

        Raises
        ------
        FlightDataError
            If a time lies outside the channel's time range (no extrapolation).
        """
        tq = np.atleast_1d(np.asarray(t, dtype=np.float64))
        if tq.ndim != 1:
            raise FlightDataError(
                f"channel {self.name!r}: expected a 1-D array of times, got shape {tq.shape}"
            )
        if tq.size == 0:
            return np.empty((0, self.m))
        t0, t1 = float(self.t[0]), float(self.t[-1])
        lo, hi = float(np.min(tq)), float(np.max(tq))
        if not (np.all(np.isfinite(tq)) and lo >= t0 and hi <= t1):
            raise FlightDataError(
                f"channel {self.name!r} covers [{_fmt_t(t0)}, {_fmt_t(t1)}] but values were "
                f"asked for in [{_fmt_t(lo)}, {_fmt_t(hi)}]; there is no extrapolation — "
                "choose times inside the data (see FlightData.window)"
            )
        out = np.empty((tq.size, self.m))
        for j in range(self.m):
            out[:, j] = np.interp(tq, self.t, self.values[:, j])
        return out

    def window(self, start: float, end: float) -> FlightChannel:
        """The samples with ``start <= t <= end``, plus interpolated end points.

        The ends are interpolated so that the window starts and ends exactly at ``start`` and
        ``end`` (both must lie inside the channel's time range).
        """
        inner = (self.t > start) & (self.t < end)
        tt = np.concatenate([[start], self.t[inner], [end]]) if end > start else np.array([start])
        return FlightChannel(self.name, tt, self.at(tt), self.components, self.unit)


@dataclass
class FlightData:
    """A flight: channels with their own time bases, events and the NED origin.

    Parameters
    ----------
    name : str
        Label of the flight (file name, drop number, ...).
    channels : dict of str to FlightChannel
        The channels by name.
    events : dict of str to float
        Event name -> time, s (e.g. ``"canopy_deployed"``, ``"drogue"``, ``"main"``).
    origin : (float, float, float) or None
        Latitude (deg), longitude (deg) and altitude (m) of the NED origin.
    notes : list of str
        What the loader did to the data that a person should know (samples left out as
        spikes, with their times).
    """

    name: str
    channels: dict[str, FlightChannel]
    events: dict[str, float] = field(default_factory=dict)
    origin: tuple[float, float, float] | None = None
    notes: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        for key, ch in self.channels.items():
            if not isinstance(ch, FlightChannel):
                raise FlightDataError(
                    f"flight {self.name!r}: channels[{key!r}] must be a FlightChannel, got "
                    f"{type(ch).__name__}"
                )
        for key, value in self.events.items():
            if not (
                isinstance(value, int | float | np.integer | np.floating) and math.isfinite(value)
            ):
                raise FlightDataError(
                    f"flight {self.name!r}: event {key!r} must be a finite time in s, got {value!r}"
                )
        self.events = {str(k): float(v) for k, v in self.events.items()}

    def __getitem__(self, name: str) -> FlightChannel:
        try:
            return self.channels[name]
        except KeyError:
            raise FlightDataError(
                f"flight {self.name!r} has no channel {name!r}; {suggest(name, self.channels)}"
            ) from None

    def __contains__(self, name: object) -> bool:
        return name in self.channels

    def time_range(self) -> tuple[float, float]:
        """Earliest and latest sample time over all channels, s."""
        if not self.channels:
            raise FlightDataError(f"flight {self.name!r} has no channels")
        return (
            min(float(c.t[0]) for c in self.channels.values()),
            max(float(c.t[-1]) for c in self.channels.values()),
        )

    def common_range(self, names: list[str] | tuple[str, ...] | None = None) -> tuple[float, float]:
        """The time range covered by every one of ``names`` (all channels by default), s."""
        chans = [self[n] for n in (names if names is not None else list(self.channels))]
        if not chans:
            raise FlightDataError(f"flight {self.name!r} has no channels")
        lo = max(float(c.t[0]) for c in chans)
        hi = min(float(c.t[-1]) for c in chans)
        if hi < lo:
            raise FlightDataError(
                f"flight {self.name!r}: channels {[c.name for c in chans]} do not overlap in time "
                f"(latest start {_fmt_t(lo)}, earliest end {_fmt_t(hi)})"
            )
        return lo, hi

    def event_time(self, key: float | str) -> float:
        """A time in s, given either as a number or as an event name."""
        if isinstance(key, str):
            if key not in self.events:
                raise FlightDataError(
                    f"flight {self.name!r} has no event {key!r}; "
                    f"{suggest(key, self.events)} (or give a time in s)"
                )
            return self.events[key]
        value = float(key)
        if not math.isfinite(value):
            raise FlightDataError(f"a window bound must be a finite time in s, got {key!r}")
        return value

    def window(
        self,
        start: float | str,
        end: float | str,
        *,
        require: list[str] | tuple[str, ...] | None = None,
    ) -> FlightData:
        """The flight between two times or events, absolute times kept.

        Channels are cut to ``[start, end]`` with their end points interpolated. The channels in
        ``require`` (by default the standard channels present: position, velocity, euler, rates,
        altitude, controls) must cover the whole window; other channels are cut to the part of
        the window they cover and left out when they have no data in it. Events outside the
        window are dropped.

        Parameters
        ----------
        start, end : float or str
            Times in s or event names (e.g. ``"main"``).
        require : list of str, optional
            Channels that must cover the whole window.

        Raises
        ------
        FlightDataError
            If ``end <= start``, the window is not inside the flight's time range, or a required
            channel does not cover it (the message says what each covers).
        """
        t0 = self.event_time(start)
        t1 = self.event_time(end)
        if not t1 > t0:
            raise FlightDataError(
                f"window end ({end!r} = {_fmt_t(t1)}) must come after its start "
                f"({start!r} = {_fmt_t(t0)})"
            )
        lo, hi = self.time_range()
        if t0 < lo or t1 > hi:
            raise FlightDataError(
                f"window [{_fmt_t(t0)}, {_fmt_t(t1)}] is outside the data of flight "
                f"{self.name!r}, which covers [{_fmt_t(lo)}, {_fmt_t(hi)}]; choose times inside"
            )
        if require is None:
            req = [k for k in self.channels if k in STANDARD_CHANNELS]
        else:
            for k in require:
                self[k]  # raises, naming the channels, on an unknown name
            req = list(require)
        short = [
            f"{k} [{_fmt_t(self.channels[k].t[0])}, {_fmt_t(self.channels[k].t[-1])}]"
            for k in req
            if self.channels[k].t[0] > t0 or self.channels[k].t[-1] < t1
        ]
        if short:
            raise FlightDataError(
                f"window [{_fmt_t(t0)}, {_fmt_t(t1)}] of flight {self.name!r} is outside the data "
                f"of channel(s): {'; '.join(short)}; choose a window inside every channel, or "
                "leave the channel out (FlightData.select, or require=[...])"
            )
        chans = {}
        for k, c in self.channels.items():
            a, b = max(t0, float(c.t[0])), min(t1, float(c.t[-1]))
            if b > a or (b == a and k in req):
                chans[k] = c.window(a, b)
        events = {k: v for k, v in self.events.items() if t0 <= v <= t1}
        return FlightData(self.name, chans, events, self.origin)

    def select(self, names: list[str] | tuple[str, ...]) -> FlightData:
        """A flight with only the named channels (events and origin kept)."""
        return FlightData(self.name, {n: self[n] for n in names}, dict(self.events), self.origin)

    def sample(
        self, names: list[str] | tuple[str, ...], t: ArrayLike
    ) -> dict[str, NDArray[np.float64]]:
        """The named channels interpolated onto one time grid: ``{name: (len(t), m)}``."""
        return {n: self[n].at(t) for n in names}

    def grid(
        self, dt: float, names: list[str] | tuple[str, ...] | None = None
    ) -> NDArray[np.float64]:
        """A uniform time grid of step ``dt`` (s) inside the common range of ``names``."""
        if not (math.isfinite(dt) and dt > 0):
            raise FlightDataError(f"dt must be a time step > 0 s, got {dt!r}")
        lo, hi = self.common_range(names)
        n = int(np.floor((hi - lo) / dt + 1e-9)) + 1
        return lo + dt * np.arange(n)

    def __repr__(self) -> str:
        lo, hi = self.time_range() if self.channels else (math.nan, math.nan)
        chans = ", ".join(f"{k}[{c.m}] {c.unit} @{c.t.size}" for k, c in self.channels.items())
        return (
            f"FlightData({self.name!r}, t=[{lo:.6g}, {hi:.6g}] s, channels: {chans}; "
            f"events: {self.events})"
        )
