"""Drops to predict: a drop copied from a study (with its data) or a planned drop (none).

A *drop file* is a TOML file of one or more ``[[identification.drops]]`` tables::

    [identification]
    model = "parachute6dof"      # optional: the model these drops are for (checked)

    [[identification.drops]]     # a drop copied from a study: the same keys, its data files
    name = "drop2"
    file = "drop2.csv"
    mapping = { ... }
    wind = "wind2.csv"
    window = [2.0, 62.0]
    noise = { position_h = 1.5 }          # optional: its noise (over the study's, key by key)

    [[identification.drops]]     # a planned drop: no data files
    name = "next"
    initial = { altitude = 2200.0, velocity = [0.0, 0.0, 6.5], euler = [0.0, 0.0, 1.2],
                rates = [0.0, 0.0, 0.0] }   # m above sea level, m/s (NED), rad, rad/s
    origin = [32.85, -114.39, 1200.0]      # lat, lon (deg), altitude (m): positions local to it
    duration = 120.0                        # s simulated
    channels = { position = 4.0, velocity = 4.0 }   # the outputs predicted, Hz
    wind = "wind.csv"                       # as in a study (none: calm air)
    controls = { time = [0.0, 30.0, 31.0], flap_left = [0.0, 0.0, 0.5] }  # optional schedule
    noise = { position_h = 1.5, position_v = 3.0 }  # optional: the noise of its sensors

Paths are relative to the drop file's folder. A planned drop's ``initial`` holds the state
where the prediction starts, in the models' conventions (:class:`vectorid.models.InitialState`:
``altitude`` above mean sea level, m; ``north``/``east`` relative to the origin, m, default
0; ``velocity`` north, east, down, m/s, default the model's steady flight; ``euler`` roll,
pitch, yaw, rad; ``rates`` p, q, r, rad/s). The ground is at the origin's altitude unless
``ground_altitude`` (m above sea level) says otherwise; a drop that starts at or below it is
refused. ``inputs`` hold constant model inputs, ``controls`` a schedule (``time`` in s from
the start, one list per model input, ``interpolation`` ``"linear"`` or ``"previous"``).

A drop with data may say which of its channels are predicted and checked (``check =
["position"]``; default: every one the model gives — a channel the study only fits the initial
state to, such as a course read as a yaw, is better left out).

``parameters`` (either kind of drop) holds values of model parameters that are no design
variable of the study (e.g. a heavier payload), and, for a study whose design variables
include per-drop ones (``"wind_north.flight1"``: the several-flights identification), how a
new drop gets them: a number (e.g. 0.0, calm air), ``"drawn"`` (each member takes its value
on one of the study's drops, drawn at random, seeded) or ``"mean"`` (the member's mean over
the study's drops).

:func:`read_drop_file` parses a drop file into :class:`DropToPredict` objects (a data drop
through the study's own :func:`~vectorid.identify.drops.build_drop`, so it is windowed and its
initial state fitted exactly as in a study). Nothing here simulates: see
:mod:`vectorid.identify.predictor`.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from vectorid.errors import StudyDefinitionError, suggest
from vectorid.identify.drops import _DROP_KEYS, Drop, _load_wind, build_drop, fit_initial_state
from vectorid.identify.flight import FlightData, FlightDataError
from vectorid.identify.noise.estimate import estimate_noise
from vectorid.identify.noise.statements import NoiseModel, parse_noise
from vectorid.models.base import InitialState, Model
from vectorid.models.controls import ControlSchedule
from vectorid.models.wind import WindProfile

__all__ = [
    "DATA_DROP_KEYS",
    "PLANNED_KEYS",
    "POSITION_SPAN",
    "PREDICTED_CHANNELS",
    "DropToPredict",
    "fit_prediction_state",
    "parse_drops",
    "read_drop_file",
]

#: Channels a prediction can give (besides a model's own output channels), with their
#: components and units: the data's conventions (positions NED relative to the origin).
PREDICTED_CHANNELS: dict[str, tuple[tuple[str, ...], str]] = {
    "position": (("north", "east", "down"), "m"),
    "velocity": (("north", "east", "down"), "m/s"),
    "euler": (("roll", "pitch", "yaw"), "rad"),
    "rates": (("p", "q", "r"), "rad/s"),
    "altitude": (("altitude",), "m"),
}
#: Keys of a planned drop (no data files).
PLANNED_KEYS: dict[str, str] = {
    "name": "drop name",
    "initial": "{ altitude (m above sea level), north, east (m), velocity = [n, e, d] (m/s), "
    "euler = [roll, pitch, yaw] (rad), rates = [p, q, r] (rad/s) }",
    "duration": "simulated time, s",
    "channels": "{ channel = rate in Hz, ... }: the outputs predicted",
    "origin": "[latitude deg, longitude deg, altitude m] of the local NED origin",
    "origin_altitude": "altitude of the NED origin above sea level, m",
    "ground_altitude": "altitude of the ground above sea level, m (default: the origin's)",
    "wind": "wind profile file (Wyoming sounding .txt or dropsonde .csv)",
    "wind_format": "wyoming | dropsonde",
    "wind_options": "options of the dropsonde reader",
    "inputs": "constant model inputs { name = value }",
    "controls": "{ time = [s, ...], <input> = [...] }: a control schedule",
    "interpolation": "control interpolation: linear | previous",
    "noise": "the noise of its sensors (noise keys, as in a study)",
    "parameters": "model parameters that are no design variable, or per-drop ones",
}
#: Keys of a drop copied from a study: the study's, plus ``parameters`` and ``check``.
DATA_DROP_KEYS: dict[str, str] = {
    **_DROP_KEYS,
    "parameters": PLANNED_KEYS["parameters"],
    "check": "the channels predicted and checked (default: every one the model gives)",
}
_INITIAL_KEYS = ("altitude", "north", "east", "velocity", "euler", "rates")
_FILE_KEYS = {"identification"}
_TABLE_KEYS = {"model", "drops"}
#: How a per-drop design variable of the study is set for a new drop (besides a number).
PER_DROP_RULES = ("drawn", "mean")


def _err(field_: str, problem: str, fix: str = "") -> StudyDefinitionError:
    return StudyDefinitionError(field_, problem, fix)


def _number(where: str, value: Any, *, positive: bool = False) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    if isinstance(value, bool) or not math.isfinite(v) or (positive and v <= 0):
        want = "a number > 0" if positive else "a finite number"
        raise _err(where, f"expected {want}, got {value!r}", "e.g. 120.0")
    return v


def _triple(where: str, value: Any, unit: str) -> tuple[float, float, float]:
    if isinstance(value, str) or not isinstance(value, Sequence) or len(value) != 3:
        raise _err(where, f"expected three numbers ({unit}), got {value!r}", "e.g. [0.0, 0.0, 6.0]")
    return tuple(_number(f"{where}[{i}]", v) for i, v in enumerate(value))  # type: ignore[return-value]


@dataclass
class DropToPredict:
    """One drop to predict, copied from a study (with data) or planned (without).

    Attributes
    ----------
    name : str
    kind : {"data", "planned"}
    initial : InitialState
        The state the prediction starts from (altitude above sea level, m); for a data drop,
        fitted to the data at the window start (:func:`fit_prediction_state`).
    duration : float
        Simulated time, s.
    inputs : ControlSchedule or None
        Control schedule, s from the start.
    wind : WindProfile or None
        None: calm air.
    wind_text : str
        Where the wind comes from, for people.
    origin_altitude : float
        Altitude of the NED origin above sea level, m: positions are relative to it.
    ground_altitude : float or None
        Altitude of the ground above sea level, m (planned drops: where the load lands);
        None for a data drop (its dispersion is read at the end of its window).
    channels : dict
        Channel name -> rate, Hz (planned drops; None for a data drop: its samples' times).
    noise : NoiseModel or None
        The measurement noise of its channels (None: none stated).
    noise_text : str
        Where the noise comes from, for people.
    parameters : dict
        Model parameter -> value (float) or per-drop rule (``"drawn"``, ``"mean"``).
    drop : Drop or None
        A data drop as the study builds it (windowed flight, fitted initial state, grid).
    """

    name: str
    kind: str
    initial: InitialState
    duration: float
    inputs: ControlSchedule | None
    wind: WindProfile | None
    wind_text: str
    origin_altitude: float
    ground_altitude: float | None
    channels: dict[str, float | None]
    noise: NoiseModel | None
    noise_text: str
    parameters: dict[str, float | str] = field(default_factory=dict)
    drop: Drop | None = None

    @property
    def t0(self) -> float:
        """Absolute start time, s (the data's clock; 0 for a planned drop)."""
        return 0.0 if self.drop is None else float(self.drop.t0)

    @property
    def flight(self) -> FlightData | None:
        """The windowed measured data (None for a planned drop)."""
        return None if self.drop is None else self.drop.flight


def read_drop_file(
    path: str | Path,
    model: Model,
    *,
    study_noise: Any = None,
    output_dt: float = 0.5,
    init_span: float = 1.0,
    dt: float = 0.05,
) -> list[DropToPredict]:
    """The drops of a drop file (see the module docstring).

    Parameters
    ----------
    path : path
        The drop file (TOML).
    model : Model
        The model the store identifies (checks inputs and channels; a data drop is built for it).
    study_noise : optional
        The study's ``[identification] noise`` statement (a table, ``"estimate"`` or None):
        the noise of a drop that states none of its own, key by key.
    output_dt : float
        The study's comparison grid step, s (a data drop's grid).
    init_span : float
        The study's initial-state fit span, s (a data drop's initial state).
    dt : float
        The study's integration step, s (a planned drop's channel rates must be multiples).

    Returns
    -------
    list of DropToPredict

    Raises
    ------
    StudyDefinitionError
        One line naming the field: an unknown key, a missing file, a channel the model lacks,
        a planned drop that starts below the ground, ...
    """
    p = Path(path)
    if not p.is_file():
        raise _err(str(p), "no such drop file", "give the path of a TOML file of drops")
    try:
        doc = tomllib.loads(p.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise _err(str(p), f"not a TOML file ({exc})", "write the drops as TOML tables") from None
    return parse_drops(
        doc, model, base_dir=p.parent, where=p.name, study_noise=study_noise,
        output_dt=output_dt, init_span=init_span, dt=dt,
    )  # fmt: skip


def parse_drops(
    doc: Mapping[str, Any],
    model: Model,
    *,
    base_dir: str | Path,
    where: str = "drops",
    study_noise: Any = None,
    output_dt: float = 0.5,
    init_span: float = 1.0,
    dt: float = 0.05,
) -> list[DropToPredict]:
    """The drops of a parsed drop file ``doc`` (see :func:`read_drop_file`)."""
    for key in doc:
        if key not in _FILE_KEYS:
            raise _err(
                f"{where}: {key}",
                f"unknown top-level key {key!r}",
                suggest(key, sorted(_FILE_KEYS))
                + " (a drop file holds [[identification.drops]] tables)",
            )
    table = doc.get("identification")
    if not isinstance(table, Mapping):
        raise _err(where, "no [[identification.drops]] table", "add one drop table per drop")
    for key in table:
        if key not in _TABLE_KEYS:
            raise _err(
                f"{where}: identification.{key}",
                f"unknown key {key!r}",
                suggest(key, sorted(_TABLE_KEYS))
                + " (the study's other settings come from the store)",
            )
    named = table.get("model")
    if named is not None and named != model.name:
        raise _err(
            f"{where}: identification.model",
            f"the drops are for model {named!r}, but the store identifies {model.name!r}",
            "predict them from a store of that model, or remove model = ...",
        )
    drops = table.get("drops")
    if isinstance(drops, Mapping):
        drops = [drops]
    if not isinstance(drops, list) or not drops:
        raise _err(
            f"{where}: identification.drops",
            f"expected one or more [[identification.drops]] tables, got {drops!r}",
            "add [[identification.drops]] with name = ... and either file = ... or initial = ...",
        )
    base = Path(base_dir)
    out: list[DropToPredict] = []
    for i, t in enumerate(drops):
        w = f"{where}: drops[{i}]"
        if not isinstance(t, Mapping):
            raise _err(w, f"expected a table, got {t!r}", "write [[identification.drops]]")
        if "file" in t or "files" in t:
            out.append(_data_drop(t, i, w, base, model, study_noise, output_dt, init_span))
        else:
            out.append(_planned_drop(t, i, w, base, model, study_noise, dt))
    names = [d.name for d in out]
    for n in names:
        if names.count(n) > 1:
            raise _err(f"{where}: drops", f"drop name {n!r} is used twice", "give each a name")
    return out


def _check_keys(where: str, got: Mapping[str, Any], valid: Mapping[str, str], kind: str) -> None:
    for key in got:
        if key not in valid:
            raise _err(
                f"{where}.{key}",
                f"unknown key {key!r} for a {kind}",
                suggest(key, list(valid))
                + (
                    " (a planned drop has no data files; a drop with file = ... has the "
                    "keys of a study's drop)"
                ),
            )


def _parameters(where: str, value: Any, model: Model) -> dict[str, float | str]:
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise _err(where, f"expected a table, got {value!r}", "write parameters = { x13 = 0.6 }")
    names = list(model.parameter_names)
    out: dict[str, float | str] = {}
    for k, v in value.items():
        if k not in names:
            raise _err(
                f"{where}.{k}", f"not a parameter of model {model.name!r}", suggest(k, names)
            )
        if isinstance(v, str):
            if v not in PER_DROP_RULES:
                raise _err(
                    f"{where}.{k}",
                    f"expected a number or one of {', '.join(map(repr, PER_DROP_RULES))}, "
                    f"got {v!r}",
                    '"drawn": each member takes its value on one of the study\'s drops',
                )
            out[k] = v
        else:
            out[k] = _number(f"{where}.{k}", v)
    return out


def _noise(where: str, own: Any, study: Any, flight: FlightData | None, channels) -> tuple:
    """(NoiseModel or None, where it comes from): the drop's own over the study's, key by key;
    "estimate" estimates the white part from the drop's data (a planned drop has none)."""
    base = None if study is None else parse_noise(study, "study noise")
    mine = None if own is None else parse_noise(own, f"{where}.noise")
    if isinstance(mine, str) or (mine is None and isinstance(base, str)):
        if flight is None:
            return None, (
                "none stated (the study estimates its noise from its data, and a planned "
                "drop has none: state noise = { ... } in the drop)"
            )
        est = estimate_noise(flight, [c for c in channels if c in flight.channels])
        return est, "estimated from the drop's data (white part), as the study does"
    if mine is None and base is None:
        return None, "none stated (the study states none: state noise = { ... } in the drop)"
    if mine is None:
        return base, "the study's"
    if base is None or isinstance(base, str):
        return mine, "the drop's own"
    return base.merged(mine), "the drop's own over the study's"


#: Seconds of position fixes (moved back along the measured velocity) that a drop with data
#: fits its initial position to, where it has a velocity channel (see
#: :func:`fit_prediction_state`).
POSITION_SPAN = 10.0


def fit_prediction_state(
    flight: FlightData,
    t0: float,
    span: float,
    origin_alt: float,
    wind: Any,
    where: str,
    end: float | None = None,
) -> InitialState:
    """The initial state a prediction of a drop with data starts from.

    The study's fit (:func:`~vectorid.identify.drops.fit_initial_state`: least-squares lines
    through the first ``span`` s of every channel), except the position where the drop has
    both position and velocity: each fix of the first :data:`POSITION_SPAN` s (at most half
    the record up to ``end``, s; default the data's end) is moved back to ``t0`` along the
    measured velocity (trapezoidal integral) and the mean is taken. A line through one second
    of fixes leaves an offset of about 0.8 σ of the position noise that persists over the
    whole prediction; the moved-back mean leaves σ/√n plus the integrated velocity noise, with
    no bias from a curved start.
    """
    state = fit_initial_state(flight, t0, span, origin_alt, wind, where)
    chans = flight.channels
    if "position" not in chans or "velocity" not in chans:
        return state
    p, v = chans["position"], chans["velocity"]
    last = float(p.t[-1]) if end is None else float(end)
    t1 = min(float(p.t[-1]), float(v.t[-1]), t0 + POSITION_SPAN, t0 + 0.5 * (last - t0))
    sel = (p.t >= t0 - 1e-9) & (p.t <= t1 + 1e-9)
    if sel.sum() < 3 or float(v.t[0]) > t0 + 1e-9:
        return state
    tv = np.concatenate([[t0], v.t[(v.t > t0) & (v.t < t1)], [t1]])
    vv = np.column_stack([np.interp(tv, v.t, v.values[:, j]) for j in range(3)])
    cum = np.concatenate(
        [np.zeros((1, 3)), np.cumsum(0.5 * (vv[1:] + vv[:-1]) * np.diff(tv)[:, None], axis=0)]
    )
    moved = p.values[sel] - np.column_stack([np.interp(p.t[sel], tv, cum[:, j]) for j in range(3)])
    n0, e0, d0 = moved.mean(axis=0)
    return replace(state, north=float(n0), east=float(e0), altitude=float(origin_alt - d0))


def _data_drop(
    t: Mapping[str, Any],
    i: int,
    where: str,
    base: Path,
    model: Model,
    study_noise: Any,
    output_dt: float,
    init_span: float,
) -> DropToPredict:
    _check_keys(where, t, DATA_DROP_KEYS, "drop with data")
    params = _parameters(f"{where}.parameters", t.get("parameters"), model)
    table = {k: v for k, v in t.items() if k not in ("parameters", "check")}
    try:
        drop = build_drop(table, i, base, model, output_dt=output_dt, init_span=init_span)
    except StudyDefinitionError as exc:  # name the drop file, not a study
        raise _err(f"{where}: {exc.field}", exc.problem, exc.fix) from None
    except FlightDataError as exc:
        raise _err(where, str(exc), "fix the drop's window or its data") from None
    initial = fit_prediction_state(
        drop.flight, drop.t0, drop.init_span, drop.origin_altitude, drop.wind, where,
        end=drop.t0 + drop.duration,
    )  # fmt: skip
    chans = {c: None for c in drop.flight.channels if c != "controls"}
    check = t.get("check")
    if check is not None:
        if isinstance(check, str) or not isinstance(check, Sequence) or not check:
            raise _err(f"{where}.check", f"expected a list of channels, got {check!r}",
                       'e.g. check = ["position"]')  # fmt: skip
        for c in check:
            if c not in chans:
                raise _err(f"{where}.check", f"the drop has no channel {c!r} to check",
                           suggest(str(c), list(chans)))  # fmt: skip
        chans = {c: None for c in chans if c in check}
    noise, text = _noise(where, t.get("noise"), study_noise, drop.flight, list(chans))
    wind_text = f"the profile {t['wind']}" if drop.wind is not None else "calm air (no wind file)"
    return DropToPredict(
        drop.name, "data", initial, float(drop.duration), drop.inputs, drop.wind, wind_text,
        float(drop.origin_altitude), None, chans, noise, text, params, drop,
    )  # fmt: skip


def _planned_drop(
    t: Mapping[str, Any],
    i: int,
    where: str,
    base: Path,
    model: Model,
    study_noise: Any,
    dt: float,
) -> DropToPredict:
    _check_keys(where, t, PLANNED_KEYS, "planned drop")
    name = str(t.get("name", f"drop{i + 1}"))
    for key in ("initial", "duration", "channels"):
        if key not in t:
            raise _err(
                f"{where}.{key}",
                f"a planned drop (no data files) needs {key} ({PLANNED_KEYS[key]})",
                "add it, or give file = ... for a drop with data",
            )
    # the origin and the ground: never guessed
    origin = t.get("origin")
    origin_alt = None
    if origin is not None:
        if isinstance(origin, str) or not isinstance(origin, Sequence) or len(origin) != 3:
            raise _err(
                f"{where}.origin",
                f"expected [latitude deg, longitude deg, altitude m], got {origin!r}",
                "e.g. origin = [32.85, -114.39, 1200.0]",
            )
        origin_alt = _number(f"{where}.origin[2]", origin[2])
    if t.get("origin_altitude") is not None:
        if origin_alt is not None:
            raise _err(
                f"{where}.origin_altitude", "given twice (origin holds an altitude too)",
                "keep one of origin and origin_altitude",
            )  # fmt: skip
        origin_alt = _number(f"{where}.origin_altitude", t["origin_altitude"])
    ground = t.get("ground_altitude")
    ground = None if ground is None else _number(f"{where}.ground_altitude", ground)
    if origin_alt is None and ground is None:
        raise _err(
            f"{where}.origin",
            "a planned drop needs its origin or its ground (positions are relative to the "
            "origin; the load lands on the ground)",
            "add origin = [latitude, longitude, altitude m] (e.g. the landing zone) or "
            "ground_altitude = m above sea level",
        )
    origin_alt = ground if origin_alt is None else origin_alt
    ground = origin_alt if ground is None else ground
    # the initial state, in the models' conventions
    ini = t["initial"]
    if not isinstance(ini, Mapping):
        raise _err(f"{where}.initial", f"expected a table, got {ini!r}", PLANNED_KEYS["initial"])
    for key in ini:
        if key not in _INITIAL_KEYS:
            raise _err(
                f"{where}.initial.{key}", f"unknown key {key!r}", suggest(key, _INITIAL_KEYS)
            )
    if "altitude" not in ini:
        raise _err(
            f"{where}.initial.altitude",
            "missing: the altitude the drop starts from, m above sea level",
            "add altitude = ... (above sea level, as in the models' initial state)",
        )
    alt = _number(f"{where}.initial.altitude", ini["altitude"])
    if alt <= ground:
        raise _err(
            f"{where}.initial.altitude",
            f"{alt:g} m is at or below the ground ({ground:g} m above sea level): the drop "
            "would start underground",
            "give the altitude above sea level (the origin's altitude plus the height of the "
            f"release, e.g. {ground + 1000.0:g})",
        )
    vel = ini.get("velocity")
    initial = InitialState(
        altitude=alt,
        north=_number(f"{where}.initial.north", ini.get("north", 0.0)),
        east=_number(f"{where}.initial.east", ini.get("east", 0.0)),
        velocity=None if vel is None else _triple(f"{where}.initial.velocity", vel, "m/s"),
        euler=_triple(f"{where}.initial.euler", ini.get("euler", (0.0, 0.0, 0.0)), "rad"),
        rates=_triple(f"{where}.initial.rates", ini.get("rates", (0.0, 0.0, 0.0)), "rad/s"),
    )
    duration = _number(f"{where}.duration", t["duration"], positive=True)
    # channels and their rates
    chans = t["channels"]
    if not isinstance(chans, Mapping) or not chans:
        raise _err(
            f"{where}.channels",
            f"expected a table of channel = rate in Hz, got {chans!r}",
            "e.g. channels = { position = 4.0, velocity = 4.0 }",
        )
    valid = [*PREDICTED_CHANNELS, *(c for c in model.output_names if c not in _BASE_NAMES)]
    rates: dict[str, float | None] = {}
    for c, hz in chans.items():
        if c not in valid:
            raise _err(
                f"{where}.channels.{c}",
                f"model {model.name!r} has no channel {c!r}",
                suggest(c, valid) + f" (channels: {', '.join(valid)})",
            )
        hz = _number(f"{where}.channels.{c}", hz, positive=True)
        k = round(1.0 / (hz * dt))
        if k < 1 or abs(k * dt * hz - 1.0) > 1e-6:
            raise _err(
                f"{where}.channels.{c}",
                f"{hz:g} Hz: its period {1.0 / hz:.6g} s is not a whole number of the study's "
                f"integration steps (dt = {dt:g} s)",
                f"choose a rate that divides {1.0 / dt:g} Hz (e.g. {1.0 / (dt * 5):g})",
            )
        rates[c] = hz
    # wind
    wind, wind_text = None, "calm air (no wind file)"
    if t.get("wind") is not None:
        wpath = Path(t["wind"])
        wpath = wpath if wpath.is_absolute() else base / wpath
        if not wpath.exists():
            raise _err(f"{where}.wind", f"wind file {str(wpath)!r} not found", "check the path")
        wind = _load_wind(wpath, t.get("wind_format"), t.get("wind_options", {}))
        wind_text = f"the profile {t['wind']}"
    inputs = _planned_inputs(where, t, model, duration)
    noise, text = _noise(where, t.get("noise"), study_noise, None, list(rates))
    params = _parameters(f"{where}.parameters", t.get("parameters"), model)
    return DropToPredict(
        name, "planned", initial, duration, inputs, wind, wind_text, origin_alt, ground, rates,
        noise, text, params, None,
    )  # fmt: skip


_BASE_NAMES = {
    "north", "east", "down", "v_north", "v_east", "v_down", "phi", "theta", "psi", "p", "q", "r",
}  # fmt: skip


def _planned_inputs(
    where: str, t: Mapping[str, Any], model: Model, duration: float
) -> ControlSchedule | None:
    names = model.input_names
    cols: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for key, v in dict(t.get("inputs") or {}).items():
        if key not in names:
            raise _err(
                f"{where}.inputs.{key}",
                f"{key!r} is not an input of model {model.name!r}",
                suggest(key, names) if names else f"model {model.name!r} takes no inputs",
            )
        cols[key] = (np.array([0.0]), np.array([_number(f"{where}.inputs.{key}", v)]))
    ctl = t.get("controls")
    if ctl is not None:
        if not isinstance(ctl, Mapping) or "time" not in ctl:
            raise _err(
                f"{where}.controls",
                f"expected {{ time = [s, ...], <input> = [...] }}, got {ctl!r}",
                "e.g. controls = { time = [0.0, 30.0, 31.0], flap_left = [0.0, 0.0, 0.5] }",
            )
        tt = np.array([_number(f"{where}.controls.time", v) for v in _list(where, ctl["time"])])
        if tt.size > 1 and np.any(np.diff(tt) <= 0):
            raise _err(
                f"{where}.controls.time", "times must increase strictly",
                "sort them and remove repeated times",
            )  # fmt: skip
        for key, v in ctl.items():
            if key == "time":
                continue
            if key not in names:
                raise _err(
                    f"{where}.controls.{key}",
                    f"{key!r} is not an input of model {model.name!r}",
                    suggest(key, names) if names else f"model {model.name!r} takes no inputs",
                )
            if key in cols:
                raise _err(f"{where}.controls.{key}", "given in inputs too", "keep one of the two")
            vals = np.array([_number(f"{where}.controls.{key}", x) for x in _list(where, v)])
            if vals.size != tt.size:
                raise _err(
                    f"{where}.controls.{key}",
                    f"{vals.size} values for {tt.size} times",
                    "give one value per time",
                )
            cols[key] = (tt, vals)
    if not cols:
        return None
    interp = t.get("interpolation", "linear")
    if interp not in ("linear", "previous"):
        raise _err(
            f"{where}.interpolation",
            f"expected 'linear' or 'previous', got {interp!r}",
            suggest(str(interp), ["linear", "previous"]),
        )
    times = np.unique(np.concatenate([c[0] for c in cols.values()]))
    values = np.empty((times.size, len(cols)))
    for j, (tk, vk) in enumerate(cols.values()):
        if tk.size == 1:
            values[:, j] = vk[0]
        elif interp == "previous":
            idx = np.clip(np.searchsorted(tk, times, side="right") - 1, 0, tk.size - 1)
            values[:, j] = vk[idx]
        else:
            values[:, j] = np.interp(times, tk, vk)
    return ControlSchedule(times, values, tuple(cols), interp)


def _list(where: str, v: Any) -> list[Any]:
    if isinstance(v, str) or not isinstance(v, Sequence):
        raise _err(f"{where}.controls", f"expected a list, got {v!r}", "e.g. [0.0, 30.0]")
    return list(v)
