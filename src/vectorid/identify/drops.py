"""Drops: one flight's data prepared for simulation and comparison.

:func:`build_drop` loads (or takes) the flight data of one ``[[identification.drops]]`` table,
windows it, fits the initial state at the window start (least-squares lines over
``init_span`` seconds), builds the control schedule and reads the wind profile; a
:class:`Drop` holds the result. Split out of :mod:`vectorid.identify.identification`
(a pure move); that module re-exports these names.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vectorid.errors import StudyDefinitionError, suggest
from vectorid.identify.flight import FlightChannel, FlightData, FlightDataError
from vectorid.identify.loaders import load_flight
from vectorid.identify.windprofiles import load_dropsonde_csv, load_wyoming
from vectorid.models.base import InitialState, Model
from vectorid.models.controls import ControlSchedule
from vectorid.models.wind import WindProfile

__all__ = ["Drop", "build_drop", "fit_initial_state", "merge_flights", "resolve_time"]

_DROP_KEYS = {
    "name": "drop name",
    "file": "flight data file, relative to the study file",
    "files": "several files of one drop (one per sensor): [{file, format, mapping}, ...]",
    "events": "extra events, name -> time in s (merged with the loader's)",
    "format": "csv | parquet | telemega | ulog",
    "mapping": "column/unit mapping (csv, parquet)",
    "wind": "wind profile file (Wyoming sounding .txt or dropsonde .csv)",
    "wind_format": "wyoming | dropsonde",
    "wind_options": "options of the dropsonde reader",
    "window": "[start, end]: times in s or event names (optional +/- offset)",
    "weight": "weight in the mean over drops",
    "inputs": "constant or event-step model inputs",
    "origin_altitude": "altitude of the NED origin, m",
    "interpolation": "control interpolation: previous | linear",
    "noise": "this drop's measurement noise (overrides [identification] noise key by key)",
    "channels": "the channels compared with the model (default: every standard channel)",
}
_OFFSET = re.compile(r"^\s*(.+?)\s*([+-])\s*(\d+(?:\.\d*)?|\.\d+)\s*$")


def _err(field_: str, problem: str, fix: str = "") -> StudyDefinitionError:
    return StudyDefinitionError(f"identification.{field_}", problem, fix)


def _check_keys(where: str, got: Mapping[str, Any], valid) -> None:
    if not isinstance(got, Mapping):
        raise _err(where, f"expected a table, got {got!r}", "write it as a TOML table")
    for key in got:
        if key not in valid:
            raise _err(f"{where}.{key}", f"unknown key {key!r}", suggest(key, list(valid)))


def _positive(where: str, value: Any) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    if isinstance(value, bool) or not (v > 0 and math.isfinite(v)):
        raise _err(where, f"expected a number > 0, got {value!r}", "e.g. 0.05")
    return v


# -- drops --------------------------------------------------------------------------------------


def resolve_time(flight, key: float | str) -> float:
    """A window bound: a time in s, an event name, or ``"event+offset"`` / ``"event-offset"``.

    Raises
    ------
    FlightDataError
        Unknown event (the message lists the known ones).
    """
    if isinstance(key, str) and key not in flight.events:
        m = _OFFSET.match(key)
        if m and m.group(1) in flight.events:
            sign = 1.0 if m.group(2) == "+" else -1.0
            return flight.events[m.group(1)] + sign * float(m.group(3))
    return flight.event_time(key)


def _linear_at_start(t: NDArray, v: NDArray, t0: float, span: float) -> NDArray:
    """Value at ``t0`` of a least-squares line through the samples in ``[t0, t0 + span]``."""
    sel = (t >= t0) & (t <= t0 + span)
    if sel.sum() < 3:
        return v[int(np.argmin(np.abs(t - t0)))]
    tt = t[sel] - t0
    A = np.stack([np.ones_like(tt), tt], axis=1)
    coef, *_ = np.linalg.lstsq(A, v[sel], rcond=None)
    return coef[0]


def _slope_at_start(t: NDArray, v: NDArray, t0: float, span: float) -> NDArray:
    sel = (t >= t0) & (t <= t0 + max(span, 1.0))
    if sel.sum() < 2:
        raise ValueError("not enough samples to estimate a rate")
    tt = t[sel] - t0
    A = np.stack([np.ones_like(tt), tt], axis=1)
    coef, *_ = np.linalg.lstsq(A, v[sel], rcond=None)
    return coef[1]


@dataclass
class Drop:
    """One drop prepared for simulation.

    Attributes
    ----------
    name : str
    flight : FlightData
        The windowed flight data (absolute times).
    t0, t1 : float
        Window start and end, s; the simulated span is ``duration`` from ``t0``.
    duration : float
        Simulated time, s: the window length floored to a multiple of ``output_dt``.
    wind : WindProfile or None
    weight : float
    inputs : ControlSchedule or None
        Control schedule in simulation time (0 at ``t0``).
    initial : InitialState
        State at ``t0`` from the data (altitude above mean sea level).
    origin_altitude : float
        Altitude of the NED origin of the data, m.
    """

    name: str
    flight: Any
    t0: float
    t1: float
    duration: float
    wind: WindProfile | None
    weight: float
    inputs: ControlSchedule | None
    initial: InitialState
    origin_altitude: float
    grid: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    span: tuple[float, float] | None = None
    #: s of data fitted (least-squares lines) for the initial state at a window start
    init_span: float = 1.0
    starter: Callable[[float, float], tuple[InitialState, ControlSchedule | None]] | None = field(
        default=None, repr=False
    )

    def data_span(self) -> tuple[float, float]:
        """Times (s) the windowed data cover: where a trial's window may lie."""
        return (self.t0, self.t1) if self.span is None else self.span

    def start(self, t0: float, duration: float) -> tuple[InitialState, ControlSchedule | None]:
        """Initial state and control schedule of a simulation that starts at ``t0`` (s, absolute)
        and lasts ``duration`` s (for window variables; the nominal window's are ``initial``
        and ``inputs``)."""
        if self.starter is None:
            raise _err(
                "variables",
                f"drop {self.name!r} was built without the data around its window, so its "
                "window cannot move",
                "build it with build_drop(..., extend=(min start offset, max end offset))",
            )
        return self.starter(t0, duration)

    def measured(self, channel: str, t: NDArray | None = None) -> NDArray[np.float64]:
        """The measured channel on the absolute times ``t`` (default: the output grid), (T, m)."""
        return self.flight[channel].at(self.grid if t is None else t)


def _load_wind(path: Path, fmt: str | None, options: Mapping[str, Any]) -> WindProfile:
    fmt = fmt or ("wyoming" if path.suffix.lower() == ".txt" else "dropsonde")
    if fmt == "wyoming":
        return load_wyoming(path)
    if fmt == "dropsonde":
        return load_dropsonde_csv(path, **dict(options))
    raise _err(
        "drops.wind_format", f"unknown wind format {fmt!r}", suggest(fmt, ["wyoming", "dropsonde"])
    )


def _event_input(
    name: str, spec: Mapping[str, Any], flight, t0: float, duration: float
) -> tuple[NDArray, NDArray]:
    if "event" not in spec:
        raise _err(
            f"drops.inputs.{name}",
            f"expected a number or a table with event, got {dict(spec)!r}",
            f'write {name} = 1.0 or {name} = {{ event = "main", before = 0, after = 1 }}',
        )
    te = resolve_time(flight, spec["event"]) - t0
    before, after = float(spec.get("before", 0.0)), float(spec.get("after", 1.0))
    ramp = float(spec.get("ramp", 0.0))
    if te + ramp <= 0:
        return np.array([0.0]), np.array([after])
    if te >= duration:
        return np.array([0.0]), np.array([before])
    if ramp > 0:
        ts = np.array([min(0.0, te - 1.0), te, te + ramp])
        return ts, np.array([before, before, after])
    ts = np.array([min(0.0, te - 1.0), te - 1e-9, te])
    return ts, np.array([before, before, after])


def build_drop(
    table: Mapping[str, Any],
    index: int,
    base_dir: Path,
    model: Model,
    *,
    output_dt: float,
    init_span: float,
    flight=None,
    extend: tuple[float, float] = (0.0, 0.0),
) -> Drop:
    """Load and window one drop of the ``[[identification.drops]]`` array.

    ``flight`` (a :class:`FlightData`) replaces ``file`` for the Python API. ``extend`` =
    (smallest start offset, largest end offset), s: the data are kept over
    ``[t0 + min(extend[0], 0), t1 + max(extend[1], 0)]`` so that window variables
    (``window_start``, ``window_end``) can move the window inside it.
    """
    where = f"drops[{index}]"
    _check_keys(where, table, _DROP_KEYS)
    name = str(table.get("name", f"drop{index + 1}"))
    if flight is None:
        sources = table.get("files")
        if sources is None:
            if "file" not in table:
                raise _err(f"{where}.file", "missing flight data file", 'add file = "drop1.csv"')
            sources = [{k: table[k] for k in ("file", "format", "mapping") if k in table}]
        elif "file" in table or not isinstance(sources, Sequence) or not sources:
            raise _err(
                f"{where}.files",
                "expected either file = ... or a non-empty files = [{file = ...}, ...]",
                "keep one of the two",
            )
        parts = []
        for j, src in enumerate(sources):
            _check_keys(f"{where}.files[{j}]", src, {"file", "format", "mapping"})
            if "file" not in src:
                raise _err(f"{where}.files[{j}]", "missing file", 'add file = "gps.csv"')
            path = Path(src["file"])
            path = path if path.is_absolute() else base_dir / path
            if not path.exists():
                raise _err(
                    f"{where}.file",
                    f"file {str(path)!r} not found",
                    "paths are relative to the study file's folder",
                )
            parts.append(load_flight(path, mapping=src.get("mapping"), format=src.get("format")))
        flight = merge_flights(name, parts)
    extra_events = table.get("events")
    if extra_events:
        _check_keys(f"{where}.events", extra_events, set(extra_events))
        events = dict(flight.events)
        events.update({str(k): float(v) for k, v in extra_events.items()})
        flight = type(flight)(flight.name, dict(flight.channels), events, flight.origin)
    window = table.get("window")
    if window is None:
        t_lo, t_hi = flight.time_range()
        window = [t_lo, t_hi]
    if not isinstance(window, Sequence) or isinstance(window, str) or len(window) != 2:
        raise _err(
            f"{where}.window",
            f"expected [start, end] (times in s or event names), got {window!r}",
            'e.g. window = ["canopy", 90.0]',
        )
    t0, t1 = resolve_time(flight, window[0]), resolve_time(flight, window[1])
    std = [c for c in ("position", "velocity", "euler", "rates", "altitude", "controls")]
    chans = [c for c in flight.channels if c in std or c in model.output_names]
    only = table.get("channels")
    if only is not None:
        if isinstance(only, str) or not isinstance(only, Sequence):
            raise _err(f"{where}.channels", f"expected a list of names, got {only!r}")
        for c in only:
            if c not in chans:
                raise _err(f"{where}.channels", f"no channel {c!r}", suggest(str(c), chans))
        chans = [c for c in chans if c in only]
    if not chans:
        raise _err(
            f"{where}",
            f"flight {flight.name!r} has none of the channels a model can be compared with "
            f"(has {sorted(flight.channels)})",
            f"map at least one of {std} in the loader mapping",
        )
    chans = _unwrap_yaw(flight.select(chans))
    ext_lo, ext_hi = min(0.0, float(extend[0])), max(0.0, float(extend[1]))
    if ext_lo == 0.0 and ext_hi == 0.0:
        windowed = chans.window(t0, t1)
    else:
        try:
            windowed = chans.window(t0 + ext_lo, t1 + ext_hi)
        except FlightDataError as exc:
            raise _err(
                f"{where}.window",
                f"the window variables move the window of drop {name!r} over "
                f"[{t0 + ext_lo:g}, {t1 + ext_hi:g}] s, which the data do not cover ({exc})",
                "narrow the low/high of window_start / window_end, or the window",
            ) from None
    n_out = math.floor((t1 - t0) / output_dt + 1e-9)
    if n_out < 2:
        raise _err(
            f"{where}.window",
            f"window [{t0:g}, {t1:g}] s is shorter than two output steps of {output_dt:g} s",
            "widen the window or reduce output_dt",
        )
    duration = n_out * output_dt
    grid = t0 + output_dt * np.arange(n_out + 1)
    origin_alt = table.get("origin_altitude")
    if origin_alt is None:
        origin_alt = flight.origin[2] if flight.origin is not None else 0.0
    origin_alt = float(origin_alt)
    wind = None
    if table.get("wind") is not None:
        wpath = Path(table["wind"])
        wpath = wpath if wpath.is_absolute() else base_dir / wpath
        if not wpath.exists():
            raise _err(f"{where}.wind", f"wind file {str(wpath)!r} not found", "check the path")
        wind = _load_wind(wpath, table.get("wind_format"), table.get("wind_options", {}))
    initial = fit_initial_state(windowed, t0, init_span, origin_alt, wind, where)
    inputs = _inputs(table, windowed, flight, model, t0, duration, where)
    weight = _positive(f"{where}.weight", table.get("weight", 1.0))

    def starter(t_start: float, length: float) -> tuple[InitialState, ControlSchedule | None]:
        return (
            fit_initial_state(windowed, t_start, init_span, origin_alt, wind, where),
            _inputs(table, windowed, flight, model, t_start, length, where),
        )

    return Drop(
        name,
        windowed,
        t0,
        t1,
        duration,
        wind,
        weight,
        inputs,
        initial,
        origin_alt,
        grid,
        span=(t0 + ext_lo, t1 + ext_hi),
        starter=starter,
        init_span=init_span,
    )


def merge_flights(name: str, parts: Sequence[Any]):
    """One flight from several (one file per sensor): the union of channels and events.

    Raises
    ------
    StudyDefinitionError
        When two parts hold the same channel, or their NED origins differ.
    """
    if len(parts) == 1:
        return parts[0]
    chans: dict[str, Any] = {}
    events: dict[str, float] = {}
    origin = None
    for p in parts:
        for k, c in p.channels.items():
            if k in chans:
                raise _err(
                    "drops.files",
                    f"channel {k!r} comes from two files of drop {name!r}",
                    "map each channel in one file only",
                )
            chans[k] = c
        events.update(p.events)
        if p.origin is not None:
            if origin is not None and not np.allclose(origin, p.origin):
                raise _err(
                    "drops.files",
                    f"files of drop {name!r} have different origins {origin} and {p.origin}",
                    "give them one origin in their mappings",
                )
            origin = p.origin
    return FlightData(name, chans, events, origin)


def _unwrap_yaw(flight):
    if "euler" not in flight.channels:
        return flight
    ch = flight.channels["euler"]
    v = np.array(ch.values)
    v[:, -1] = np.unwrap(v[:, -1])
    chans = dict(flight.channels)
    chans["euler"] = FlightChannel(ch.name, ch.t, v, ch.components, ch.unit)
    return type(flight)(flight.name, chans, dict(flight.events), flight.origin)


def fit_initial_state(
    flight: FlightData, t0: float, span: float, origin_alt: float, wind, where: str
) -> InitialState:
    """The state at ``t0`` fitted to the first ``span`` s of the data: least-squares lines
    through position (or altitude), velocity, attitude and rates (the drop's initial state;
    the noise floor applies the same fit to noise alone). ``where`` names the drop in errors."""
    chans = flight.channels
    north = east = 0.0
    altitude = None
    if "position" in chans:
        c = chans["position"]
        p = _linear_at_start(c.t, c.values, t0, span)
        north, east = float(p[0]), float(p[1])
        altitude = origin_alt - float(p[2])
    if "altitude" in chans:
        c = chans["altitude"]
        altitude = origin_alt + float(_linear_at_start(c.t, c.values, t0, span)[0])
    if altitude is None:
        raise _err(
            where,
            "the drop has neither a position nor an altitude channel, so the initial state is "
            "unknown",
            "map a position (north, east, down) or an altitude column",
        )
    velocity = None
    if "velocity" in chans:
        c = chans["velocity"]
        velocity = tuple(float(v) for v in _linear_at_start(c.t, c.values, t0, span))
    else:
        if "altitude" in chans:
            c = chans["altitude"]
            vd = -float(_slope_at_start(c.t, c.values, t0, span)[0])
        else:
            c = chans["position"]
            vd = float(_slope_at_start(c.t, c.values, t0, span)[2])
        vn, ve = (0.0, 0.0) if wind is None else tuple(float(w) for w in wind(altitude))
        if "position" in chans:
            c = chans["position"]
            n_fit = int(((c.t >= t0) & (c.t <= t0 + max(span, 3.0))).sum())
            if n_fit >= 3:
                rate = _slope_at_start(c.t, c.values, t0, max(span, 3.0))
                vn, ve = float(rate[0]), float(rate[1])
        velocity = (vn, ve, vd)
    euler = (0.0, 0.0, 0.0)
    if "euler" in chans:
        c = chans["euler"]
        euler = tuple(float(v) for v in _linear_at_start(c.t, c.values, t0, span))
    rates = (0.0, 0.0, 0.0)
    if "rates" in chans:
        c = chans["rates"]
        rates = tuple(float(v) for v in _linear_at_start(c.t, c.values, t0, span))
    return InitialState(
        altitude=altitude, north=north, east=east, velocity=velocity, euler=euler, rates=rates
    )


def _inputs(table, windowed, flight, model, t0, duration, where) -> ControlSchedule | None:
    names = model.input_names
    if not names:
        return None
    cols: dict[str, tuple[NDArray, NDArray]] = {}
    interp = table.get("interpolation", "previous")
    if "controls" in windowed.channels:
        c = windowed.channels["controls"]
        for j, comp in enumerate(c.components):
            if comp in names:
                cols[comp] = (c.t - t0, c.values[:, j])
    for key, spec in dict(table.get("inputs", {})).items():
        if key not in names:
            raise _err(
                f"{where}.inputs.{key}",
                f"{key!r} is not an input of model {model.name!r}",
                suggest(key, names),
            )
        if isinstance(spec, int | float) and not isinstance(spec, bool):
            cols[key] = (np.array([0.0]), np.array([float(spec)]))
        elif isinstance(spec, Mapping):
            cols[key] = _event_input(key, spec, flight, t0, duration)
            interp = "linear"
        else:
            raise _err(
                f"{where}.inputs.{key}",
                f"expected a number or a table, got {spec!r}",
                f"write {key} = 1.0",
            )
    if not cols:
        return None
    times = np.unique(np.concatenate([t for t, _ in cols.values()]))
    values = np.empty((times.size, len(cols)))
    for j, (t, v) in enumerate(cols.values()):
        if t.size == 1:
            values[:, j] = v[0]
        elif interp == "previous":
            idx = np.clip(np.searchsorted(t, times, side="right") - 1, 0, t.size - 1)
            values[:, j] = v[idx]
        else:
            values[:, j] = np.interp(times, t, v)
    return ControlSchedule(times, values, tuple(cols), interp)
