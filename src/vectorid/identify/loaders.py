"""Loaders of flight logs into :class:`~vectorid.identify.flight.FlightData`.

- :func:`load_csv` and :func:`load_parquet`: any table, described by a *mapping* (from the study
  file) of columns and units to the standard channels (see ``docs/identify.md`` for the keys).
- :func:`load_telemega`: the CSV written by Altus Metrum's TeleMega flight computer.
- :func:`load_ulog`: PX4 ULog (needs the ``ulog`` extra, ``pip install pyulog``).
- :func:`load_flight`: dispatch on ``format`` or the file extension.

Every loader checks everything before it builds anything: a file is loaded whole or not at all,
and bad input raises :class:`~vectorid.identify.flight.FlightDataError` saying what was expected,
what came and how to fix it.

Common rules
------------
- Rows that are exact duplicates (same time and same values in every used column) are dropped
  (loggers repeat rows); a repeated time with different values, or a time going backwards, is an
  error that names the lines.
- A sample is valid for a channel when all its columns are finite. Leading and trailing invalid
  samples are trimmed (the channel's time range is where it has data). Inside, invalid samples are
  dropped — :meth:`Channel.at` interpolates linearly across them — as long as no stretch between
  two valid samples is longer than ``max_gap`` (default 2 s); a longer stretch is an error naming
  the channel, the times and the lines.
- Units are converted to SI (see :data:`UNITS`) and checked against magnitude heuristics
  (:func:`check_units`); ``"check_units": false`` in the mapping turns the checks off.
"""

from __future__ import annotations

import csv
import math
import os
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vectorid.errors import suggest
from vectorid.identify.flight import STANDARD_CHANNELS, Channel, FlightData, FlightDataError
from vectorid.identify.outliers import drop_spikes

__all__ = [
    "DEFAULT_MAX_GAP",
    "UNITS",
    "check_units",
    "geodetic_to_ned",
    "load_csv",
    "load_flight",
    "load_parquet",
    "load_telemega",
    "load_ulog",
]

Array = NDArray[np.float64]

#: Longest stretch without valid data inside a channel, s (see the module docstring).
DEFAULT_MAX_GAP = 2.0

#: Unit name -> factor to SI, by kind.
UNITS: dict[str, dict[str, float]] = {
    "length": {"m": 1.0, "ft": 0.3048, "km": 1000.0},
    "speed": {
        "m/s": 1.0,
        "ft/s": 0.3048,
        "knot": 1852.0 / 3600.0,
        "kn": 1852.0 / 3600.0,
        "kt": 1852.0 / 3600.0,
        "km/h": 1.0 / 3.6,
        "mph": 0.44704,
    },
    "angle": {"rad": 1.0, "deg": math.pi / 180.0},
    "rate": {"rad/s": 1.0, "deg/s": math.pi / 180.0},
    "time": {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9, "min": 60.0},
}
_KIND = {
    "position": "length",
    "velocity": "speed",
    "euler": "angle",
    "rates": "rate",
    "altitude": "length",
}
_TOP_KEYS = {
    "name",
    "time",
    "time_unit",
    "delimiter",
    "comment",
    "max_gap",
    "origin",
    "events",
    "event_column",
    "event_names",
    "duplicates",
    "check_units",
    "spikes",
    "channels",
    "first_line",
    "last_line",
    *STANDARD_CHANNELS,
}


def _fix(msg: str) -> FlightDataError:
    return FlightDataError(msg)


# --------------------------------------------------------------------------- tables


class _Table:
    """Columns of a file by name, with row labels for error messages."""

    #: File line number of each row (CSV only; ``first_line`` / ``last_line`` cut on it).
    lines: NDArray[Any] | None = None

    def __init__(
        self,
        source: str,
        names: list[str],
        get: Callable[[int], NDArray[Any]],
        n_rows: int,
        row_label: Callable[[int], str],
    ) -> None:
        self.source = source
        self.names = names
        self._get = get
        self.n_rows = n_rows
        self.row_label = row_label
        self._num: dict[str, Array] = {}

    def index(self, name: str, what: str) -> int:
        if name in self.names:
            return self.names.index(name)
        raise FlightDataError(
            f"{self.source}: {what} asks for column {name!r}, which is not in the file; "
            f"{suggest(name, self.names)}"
        )

    def raw(self, name: str, what: str) -> NDArray[Any]:
        return self._get(self.index(name, what))

    def numeric(self, name: str, what: str) -> Array:
        if name in self._num:
            return self._num[name]
        col = self.raw(name, what)
        if col.dtype.kind in "fiub":
            out = col.astype(np.float64)
        else:
            out = np.empty(col.size)
            for i, s in enumerate(col):
                if s is None:
                    out[i] = np.nan
                    continue
                txt = str(s).strip()
                if txt == "" or txt.lower() in ("nan", "na", "null", "none", "-"):
                    out[i] = np.nan
                    continue
                try:
                    out[i] = float(txt)
                except ValueError:
                    raise FlightDataError(
                        f"{self.source}: column {self.index(name, what) + 1} ({name!r}, {what}) "
                        f"should hold numbers, got {txt!r} at {self.row_label(i)}; fix the value "
                        "or map another column"
                    ) from None
        self._num[name] = out
        return out

    def strings(self, name: str, what: str) -> list[str]:
        return [("" if s is None else str(s).strip()) for s in self.raw(name, what)]


def _dedupe_names(names: Sequence[str]) -> list[str]:
    seen: dict[str, int] = {}
    out = []
    for n in names:
        n = n.strip()
        k = seen.get(n, 0)
        out.append(n if k == 0 else f"{n}.{k}")
        seen[n] = k + 1
    return out


def _read_csv(
    path: Path, delimiter: str | None = None, comment: str | None = None, skip: int = 0
) -> _Table:
    source = str(path)
    try:
        text = path.read_text(encoding="utf-8-sig", errors="strict")
    except FileNotFoundError:
        raise FlightDataError(f"no such file: {source}") from None
    except UnicodeDecodeError as exc:
        raise FlightDataError(f"{source}: not a UTF-8 text file ({exc}); is it a CSV?") from None
    lines = text.splitlines()
    # header: first non-empty line (after `skip` lines); a leading '#' on it is stripped
    # (AltusMetrum style)
    k = skip
    while k < len(lines) and (
        not lines[k].strip()
        or (comment and lines[k].lstrip().startswith(comment) and "," not in lines[k])
    ):
        k += 1
    if k >= len(lines):
        raise FlightDataError(f"{source}: the file is empty; expected a header line of columns")
    head = lines[k].lstrip()
    if head.startswith("#"):
        head = head[1:]
    if delimiter is None:
        try:
            delimiter = csv.Sniffer().sniff(head, delimiters=",;\t ").delimiter
        except csv.Error:
            delimiter = ","
    names = _dedupe_names(next(csv.reader([head], delimiter=delimiter, skipinitialspace=True)))
    rows: list[list[str]] = []
    linenos: list[int] = []
    for j in range(k + 1, len(lines)):
        line = lines[j]
        if not line.strip() or (comment and line.lstrip().startswith(comment)):
            continue
        row = next(csv.reader([line], delimiter=delimiter, skipinitialspace=True))
        if delimiter == " ":
            row = [c for c in row if c != ""]
        if len(row) != len(names):
            last = all(not ln.strip() for ln in lines[j + 1 :])
            cut = (
                "; it is the file's last line: the file looks cut short"
                if last and len(row) < len(names)
                else ""
            )
            raise FlightDataError(
                f"{source}: line {j + 1} has {len(row)} fields but the header has "
                f"{len(names)}; fix the line or the delimiter (got {delimiter!r}){cut}"
            )
        rows.append(row)
        linenos.append(j + 1)
    if not rows:
        raise FlightDataError(f"{source}: no data rows after the header")
    arr = np.array(rows, dtype=object)

    def get(i: int) -> NDArray[Any]:
        return arr[:, i]

    table = _Table(source, names, get, len(rows), lambda i: f"line {linenos[i]}")
    table.lines = np.asarray(linenos)  # file line number of each row (first_line/last_line)
    return table


def _cut_lines(table: _Table, mapping: Mapping[str, Any]) -> _Table:
    """The rows of a CSV table between ``first_line`` and ``last_line`` (file line numbers,
    inclusive): a log whose file holds more than the flight (a repeated pre-launch buffer,
    corrupt last rows) is read from the lines that hold it."""
    first, last = mapping.get("first_line"), mapping.get("last_line")
    if first is None and last is None:
        return table
    bounds = []
    for key, v in (("first_line", first), ("last_line", last)):
        if v is not None and (isinstance(v, bool) or not isinstance(v, int) or v < 1):
            raise FlightDataError(
                f"mapping[{key!r}] must be a line number of the file (an integer >= 1), got {v!r}"
            )
        bounds.append(v)
    lines = table.lines
    if lines is None:
        raise FlightDataError("first_line / last_line apply to CSV files only")
    lo = 1 if bounds[0] is None else bounds[0]
    hi = int(lines[-1]) if bounds[1] is None else bounds[1]
    keep = np.flatnonzero((lines >= lo) & (lines <= hi))
    if keep.size == 0:
        raise FlightDataError(
            f"{table.source}: no data rows between line {lo} and line {hi} (data rows are on "
            f"lines {int(lines[0])} to {int(lines[-1])}); fix first_line / last_line"
        )
    base = table

    def get(i: int) -> NDArray[Any]:
        return base._get(i)[keep]

    out = _Table(base.source, base.names, get, keep.size, lambda i: base.row_label(keep[i]))
    out.lines = lines[keep]
    return out


def _read_parquet(path: Path) -> _Table:
    try:
        import pyarrow.parquet as pq
    except ImportError:  # pragma: no cover - depends on the environment
        raise FlightDataError(
            "reading Parquet needs pyarrow: pip install 'vectorid[parquet]' (or pip install "
            "pyarrow)"
        ) from None
    source = str(path)
    if not path.exists():
        raise FlightDataError(f"no such file: {source}")
    try:
        table = pq.read_table(path)
    except Exception as exc:
        raise FlightDataError(f"{source}: cannot read as Parquet ({exc})") from None
    names = list(table.column_names)

    def get(i: int) -> NDArray[Any]:
        col = table.column(i)
        import pyarrow as pa

        if pa.types.is_timestamp(col.type) or pa.types.is_date(col.type):
            ns = col.cast(pa.timestamp("ns")).to_numpy(zero_copy_only=False)
            return ns.astype("datetime64[ns]")
        if pa.types.is_integer(col.type) or pa.types.is_floating(col.type):
            return np.asarray(col.to_numpy(zero_copy_only=False), dtype=np.float64)
        if pa.types.is_boolean(col.type):
            return np.asarray(col.to_numpy(zero_copy_only=False), dtype=np.float64)
        return np.asarray(col.to_pylist(), dtype=object)

    if len(set(names)) != len(names):
        names = _dedupe_names(names)
    return _Table(source, names, get, table.num_rows, lambda i: f"row {i}")


# --------------------------------------------------------------------------- geodesy


def geodetic_to_ned(
    lat: Array, lon: Array, alt: Array, origin: tuple[float, float, float]
) -> Array:
    """Latitude/longitude (deg) and altitude (m) -> NED (m) relative to ``origin``, WGS-84.

    Uses :func:`pymap3d.geodetic2ned`. Altitudes are taken as heights above the ellipsoid; when
    they are above mean sea level (GPS receivers usually report MSL) the constant geoid offset
    cancels in the difference to the origin to well under a metre over a drop.
    """
    try:
        import pymap3d
    except ImportError:  # pragma: no cover - core dependency
        raise FlightDataError(
            "converting latitude/longitude to a local frame needs pymap3d: pip install pymap3d"
        ) from None
    n, e, d = pymap3d.geodetic2ned(lat, lon, alt, origin[0], origin[1], origin[2])
    return np.stack([np.asarray(n), np.asarray(e), np.asarray(d)], axis=-1).astype(float)


# --------------------------------------------------------------------------- unit checks


def _factor(kind: str, unit: str, where: str) -> float:
    table = UNITS[kind]
    if unit not in table:
        raise FlightDataError(f"{where}: unknown {kind} unit {unit!r}; {suggest(unit, table)}")
    return table[unit]


#: Window lengths tried, shortest first, when comparing a rate with a position's change, s.
_WINDOWS = (1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0)
#: A window is long enough when the rms change of position over it is at least this many
#: times the standard deviation of that change due to white measurement noise (so the noise
#: makes up at most 1/100 of the variance: GPS positions at 4 Hz with 1.5 m of noise would
#: otherwise bias a per-sample derivative by half).
_SIGNAL_TO_NOISE = 10.0


def _noise_sd(t: Array, x: Array) -> float:
    """Robust standard deviation of the white noise of samples ``x`` (T, m), combined over the
    columns, from their second differences (a smooth motion contributes ~a dt², negligible)."""
    if x.shape[0] < 5:
        return 0.0
    d2 = x[2:] - 2.0 * x[1:-1] + x[:-2]
    mad = np.median(np.abs(d2 - np.median(d2, axis=0)), axis=0)
    return float(np.sqrt(np.sum((1.4826 * mad) ** 2 / 6.0)))


def _changes(t: Array, x: Array, starts: Array, T: float, rate: bool) -> Array:
    """Change of ``x`` over ``[s, s + T]`` for each start ``s``; a rate is integrated first."""
    if rate:
        steps = 0.5 * (x[1:] + x[:-1]) * np.diff(t)[:, None]
        x = np.vstack([np.zeros((1, x.shape[1])), np.cumsum(steps, axis=0)])
    cols = range(x.shape[1])
    return np.stack([np.interp(starts + T, t, x[:, j]) - np.interp(starts, t, x[:, j])
                     for j in cols], axis=1)  # fmt: skip


def _compare_changes(
    t_a: Array, a: Array, t_b: Array, b: Array, *, a_is_rate: bool, noise: float
) -> tuple[float, float, float] | None:
    """Factor ``k`` with ``a ≈ k b``, comparing their changes over windows of length ``T``.

    ``b`` is a position (m); ``a`` a velocity (integrated over each window) or another
    position. ``T`` is the shortest of :data:`_WINDOWS` over which the change of ``b`` stands
    out of the white noise (``noise``: the noise of one change of ``b - a``); at least 5
    non-overlapping windows are needed. For a velocity, the regression is of the (noisy)
    position change on the (smooth) integrated velocity, ``k = Σa² / Σab``, so position
    noise does not bias ``k`` towards 0; two positions use ``k = Σab / Σb²``.
    Returns ``(k, T, rms change of b / T in m/s)`` or None when the data cannot tell.
    """
    lo, hi = max(t_a[0], t_b[0]), min(t_a[-1], t_b[-1])
    for T in _WINDOWS:
        nw = int((hi - lo) // T)
        if nw < 5:
            return None
        starts = lo + T * np.arange(nw)
        db = _changes(t_b, b, starts, T, rate=False)
        rms = math.sqrt(float(np.mean(np.sum(db * db, axis=1))))
        if rms < _SIGNAL_TO_NOISE * noise:
            continue
        da = _changes(t_a, a, starts, T, rate=a_is_rate)
        num, den = (np.sum(da * da), np.sum(da * db)) if a_is_rate else (
            np.sum(da * db), np.sum(db * db))  # fmt: skip
        if den == 0:
            return None
        return float(num / den), T, rms / T
    return None


def _unit_named(kind: str, factor: float) -> str | None:
    """The unit of ``kind`` whose factor to SI is within 15 % of ``factor``."""
    for unit, f in UNITS[kind].items():
        if abs(factor / f - 1) < 0.15:
            return unit
    return None


_UNIT_WORDS = {"knot": "knots", "m/s": "m/s", "ft/s": "ft/s", "km/h": "km/h", "mph": "mph",
               "m": "metres", "ft": "ft (feet)", "km": "km"}  # fmt: skip


def check_units(fd: FlightData, source: str = "", units: Mapping[str, str] | None = None) -> None:
    """Magnitude heuristics that catch unit mistakes; raise :class:`FlightDataError`.

    - ``euler`` in rad: |roll| > π, |pitch| > π/2, or a wrapped yaw (jumps > π between samples)
      beyond 2π are degrees labelled as radians.
    - ``rates`` in rad/s: any |rate| > 35 rad/s (2000 deg/s, a common gyro full scale) is deg/s.
    - ``velocity`` against the change of ``position`` (when both are present and the motion
      is > 1 m/s), compared over windows long enough for the position noise not to matter
      (the shortest of 1, 2, 4, ... s over which the change of position is 10 times the
      change due to its white noise, estimated from its second differences): the velocity
      integrated over each window against the position's change, ``k = Σv² / Σv·Δp``. A
      factor ``k`` far from 1 whose unit ``f_mapped / k`` is a known speed unit (knot, ft/s,
      km/h, mph, m/s) names that unit and the unit the mapping gave; a negative factor on the
      vertical component means "up" given as "down".
    - ``altitude`` against ``-position.down`` likewise (e.g. ft given as m).

    Parameters
    ----------
    fd : FlightData
    source : str
        Prefix of the messages (the file).
    units : mapping, optional
        The unit each channel was mapped with (``{"velocity": "knot"}``), to name it and the
        unit the data look like; default SI.
    - time: a median sample interval > 50 s looks like milliseconds, < 10 µs like nanoseconds.
    """
    pre = f"{source}: " if source else ""
    off = " (or set 'check_units': false in the mapping if the data really are so)"
    if "euler" in fd.channels:
        e = fd.channels["euler"].values
        tol = 0.05
        if e.shape[1] >= 1 and np.max(np.abs(e[:, 0])) > math.pi + tol:
            v = float(np.max(np.abs(e[:, 0])))
            raise FlightDataError(
                f"{pre}euler roll reaches {v:.4g} rad, beyond ±π: the angles look like degrees "
                f"given as radians; set the euler unit to 'deg'{off}"
            )
        if e.shape[1] >= 2 and np.max(np.abs(e[:, 1])) > math.pi / 2 + tol:
            v = float(np.max(np.abs(e[:, 1])))
            raise FlightDataError(
                f"{pre}euler pitch reaches {v:.4g} rad, beyond ±π/2: the angles look like degrees "
                f"given as radians; set the euler unit to 'deg'{off}"
            )
        if e.shape[1] >= 3 and e.shape[0] > 1:
            y = e[:, 2]
            if np.max(np.abs(y)) > 2 * math.pi + tol and np.max(np.abs(np.diff(y))) > math.pi:
                raise FlightDataError(
                    f"{pre}euler yaw is wrapped (jumps of {np.max(np.abs(np.diff(y))):.4g}) but "
                    f"reaches {np.max(np.abs(y)):.4g} rad, beyond 2π: it looks like degrees "
                    f"given as radians; set the euler unit to 'deg'{off}"
                )
    if "rates" in fd.channels:
        r = fd.channels["rates"].values
        if np.max(np.abs(r)) > 35.0:
            raise FlightDataError(
                f"{pre}angular rates reach {np.max(np.abs(r)):.4g} rad/s "
                f"({np.max(np.abs(r)) / (2 * math.pi):.3g} rev/s): they look like deg/s given "
                f"as rad/s; set the rates unit to 'deg/s'{off}"
            )
    units = dict(units or {})
    if "position" in fd.channels and fd.channels["position"].t.size >= 5:
        p = fd.channels["position"]
        p_noise = _noise_sd(p.t, p.values)
        for key in ("velocity", "altitude"):
            if key not in fd.channels or fd.channels[key].t.size < 5:
                continue
            ch = fd.channels[key]
            kind = "speed" if key == "velocity" else "length"
            mapped = units.get(key, "m/s" if key == "velocity" else "m")
            if key == "velocity":
                if ch.values.shape[1] != 3:
                    continue
                a, b, noise = ch.values, p.values, math.sqrt(2) * p_noise
                vert = _compare_changes(
                    ch.t, a[:, 2:3], p.t, b[:, 2:3], a_is_rate=True, noise=noise
                )
                if vert is not None and vert[2] >= 1.0 and vert[0] < -0.5:
                    raise FlightDataError(
                        f"{pre}the vertical velocity has the opposite sign of the change of "
                        f"position.down (over {vert[1]:g}-s windows): it looks like 'up' given "
                        f"as 'down'; map the column with the key 'up' instead of 'down'{off}"
                    )
                what = "the change of the position"
            else:
                a, b = ch.values[:, :1], -p.values[:, 2:3]
                noise = math.sqrt(2) * math.hypot(p_noise, _noise_sd(ch.t, ch.values[:, :1]))
                what = "the change of -position.down"
            fit = _compare_changes(ch.t, a, p.t, b, a_is_rate=key == "velocity", noise=noise)
            if fit is None or fit[2] < 1.0:
                continue  # too little motion, or too short, to tell
            k, T, _ = fit
            if abs(k - 1) < 0.25:
                continue
            if k == 0 or not math.isfinite(k):
                raise FlightDataError(
                    f"{pre}{key} does not change over {T:g}-s windows while {what} does: the "
                    f"{key} column holds no {'speed' if key == 'velocity' else 'height'}; "
                    f"check the column mapped to {key}{off}"
                )
            f_map = UNITS[kind].get(mapped, 1.0)
            actual = _unit_named(kind, f_map / abs(k))
            if actual is not None and actual != mapped:
                raise FlightDataError(
                    f"{pre}{key} is {abs(k):.3g} times {what} over {T:g}-s windows, with the "
                    f"unit {mapped!r} of the mapping: the column looks like "
                    f"{_UNIT_WORDS.get(actual, actual)}; set the {key} unit to {actual!r} (or "
                    f"check the position's unit){off}"
                )
            if k < 0 and key == "altitude":
                raise FlightDataError(
                    f"{pre}altitude decreases when the position rises: it looks like depth "
                    f"(positive down), but 'altitude' is positive up{off}"
                )
    for ch in fd.channels.values():
        _check_time_scale(ch.t, f"{pre}channel {ch.name!r}", off)


def _check_time_scale(t: Array, where: str, off: str) -> None:
    if t.size < 3:
        return
    dt = float(np.median(np.diff(t)))
    if dt > 50.0:
        raise FlightDataError(
            f"{where} has a median sample interval of {dt:.4g} s, implausible for flight data: "
            f"is the time column in milliseconds? set 'time_unit': 'ms'{off}"
        )
    if 0 < dt < 1e-5:
        raise FlightDataError(
            f"{where} has a median sample interval of {dt:.3g} s, implausible for flight data: "
            f"is the time column in micro- or nanoseconds? set 'time_unit' to 'us' or 'ns'{off}"
        )


# --------------------------------------------------------------------------- channel building


@dataclass
class _Spec:
    name: str
    columns: list[str]
    components: tuple[str, ...]
    unit_out: str
    convert: Callable[[Array], Array]
    max_gap: float
    kind: str = ""
    geodetic: bool = False


def _as_dict(name: str, spec: Any) -> dict[str, Any]:
    if isinstance(spec, str):
        return {"columns": [spec]}
    if isinstance(spec, list | tuple):
        return {"columns": list(spec)}
    if isinstance(spec, Mapping):
        return dict(spec)
    raise FlightDataError(
        f"mapping[{name!r}] must be a column name, a list of columns or a table of keys, got "
        f"{type(spec).__name__}"
    )


def _check_keys(where: str, spec: Mapping[str, Any], allowed: set[str]) -> None:
    for key in spec:
        if key not in allowed:
            raise FlightDataError(
                f"mapping[{where!r}] has an unknown key {key!r}; {suggest(key, allowed)}"
            )


def _ned_spec(name: str, spec: dict[str, Any], kind: str, max_gap: float) -> _Spec:
    """position/velocity: north/east/down|up, lat/lon/alt, or columns."""
    where = name
    default_unit = "m" if kind == "length" else "m/s"
    if name == "position" and "lat" in spec:
        _check_keys(where, spec, {"lat", "lon", "alt", "angle_unit", "alt_unit", "max_gap"})
        for k in ("lat", "lon", "alt"):
            if k not in spec:
                raise FlightDataError(
                    f"mapping['position'] with 'lat' also needs {k!r} (columns lat, lon, alt)"
                )
        af = _factor("angle", spec.get("angle_unit", "deg"), "position.angle_unit")
        hf = _factor("length", spec.get("alt_unit", "m"), "position.alt_unit")
        deg = af * 180.0 / math.pi

        def conv_geo(v: Array) -> Array:
            return np.stack([v[:, 0] * deg, v[:, 1] * deg, v[:, 2] * hf], axis=1)

        return _Spec(
            name,
            [spec["lat"], spec["lon"], spec["alt"]],
            ("north", "east", "down"),
            "m",
            conv_geo,
            float(spec.get("max_gap", max_gap)),
            kind,
            geodetic=True,
        )
    if "columns" in spec:
        _check_keys(where, spec, {"columns", "unit", "max_gap"})
        cols = list(spec["columns"])
        if len(cols) != 3:
            raise FlightDataError(
                f"mapping[{name!r}].columns needs 3 columns (north, east, down), got {cols}"
            )
        sign = np.array([1.0, 1.0, 1.0])
    else:
        _check_keys(where, spec, {"north", "east", "down", "up", "unit", "max_gap"})
        missing = [k for k in ("north", "east") if k not in spec]
        if missing or ("down" in spec) == ("up" in spec):
            raise FlightDataError(
                f"mapping[{name!r}] needs columns 'north', 'east' and exactly one of 'down' or "
                f"'up' (or 'columns': [north, east, down]"
                + (", or 'lat', 'lon', 'alt'" if name == "position" else "")
                + f"), got keys {sorted(spec)}"
            )
        cols = [spec["north"], spec["east"], spec.get("down", spec.get("up"))]
        sign = np.array([1.0, 1.0, 1.0 if "down" in spec else -1.0])
    f = _factor(kind, spec.get("unit", default_unit), f"{name}.unit")
    return _Spec(
        name,
        [str(c) for c in cols],
        ("north", "east", "down"),
        default_unit,
        lambda v: v * (f * sign)[None, :],
        float(spec.get("max_gap", max_gap)),
        kind,
    )


def _named_spec(
    name: str, spec: dict[str, Any], keys: tuple[str, ...], kind: str, max_gap: float
) -> _Spec:
    """euler/rates: columns or one key per component; unit required."""
    if "columns" in spec:
        _check_keys(name, spec, {"columns", "unit", "max_gap"})
        cols = list(spec["columns"])
    else:
        _check_keys(name, spec, {*keys, "unit", "max_gap"})
        missing = [k for k in keys if k not in spec]
        if missing:
            raise FlightDataError(
                f"mapping[{name!r}] needs 'columns': [{', '.join(keys)}] or the keys "
                f"{list(keys)}; missing {missing}"
            )
        cols = [spec[k] for k in keys]
    if len(cols) != len(keys):
        raise FlightDataError(
            f"mapping[{name!r}].columns needs {len(keys)} columns ({', '.join(keys)}), got {cols}"
        )
    if "unit" not in spec:
        raise FlightDataError(
            f"mapping[{name!r}] needs a 'unit' ({' or '.join(UNITS[kind])}); angles are logged "
            "in both, so there is no default"
        )
    f = _factor(kind, spec["unit"], f"{name}.unit")
    return _Spec(
        name,
        [str(c) for c in cols],
        STANDARD_CHANNELS[name][0],
        STANDARD_CHANNELS[name][1],
        lambda v: v * f,
        float(spec.get("max_gap", max_gap)),
        kind,
    )


def _specs(mapping: Mapping[str, Any], max_gap: float) -> list[_Spec]:
    out: list[_Spec] = []
    for name in ("position", "velocity"):
        if name in mapping:
            out.append(_ned_spec(name, _as_dict(name, mapping[name]), _KIND[name], max_gap))
    if "euler" in mapping:
        out.append(
            _named_spec("euler", _as_dict("euler", mapping["euler"]),
                        ("roll", "pitch", "yaw"), "angle", max_gap)
        )  # fmt: skip
    if "rates" in mapping:
        out.append(
            _named_spec("rates", _as_dict("rates", mapping["rates"]), ("p", "q", "r"), "rate",
                        max_gap)
        )  # fmt: skip
    if "altitude" in mapping:
        spec = _as_dict("altitude", mapping["altitude"])
        if "column" in spec:
            spec["columns"] = [spec.pop("column")]
        _check_keys("altitude", spec, {"columns", "unit", "reference", "max_gap"})
        if len(spec.get("columns", [])) != 1:
            raise FlightDataError(
                f"mapping['altitude'] needs one column ('column': name), got {spec.get('columns')}"
            )
        f = _factor("length", spec.get("unit", "m"), "altitude.unit")
        ref = spec.get("reference", "origin")
        if ref not in ("origin", "msl"):
            raise FlightDataError(
                f"mapping['altitude'].reference must be 'origin' (values are heights above the "
                f"NED origin) or 'msl' (the origin altitude is subtracted), got {ref!r}"
            )
        s = _Spec("altitude", [str(spec["columns"][0])], ("altitude",), "m",
                  lambda v: v * f, float(spec.get("max_gap", max_gap)), "length")  # fmt: skip
        s.geodetic = ref == "msl"  # reuse the flag: needs the origin
        out.append(s)
    if "controls" in mapping:
        spec = _as_dict("controls", mapping["controls"])
        _check_keys("controls", spec, {"columns", "components", "unit", "max_gap"})
        cols = [str(c) for c in spec.get("columns", [])]
        if not cols:
            raise FlightDataError("mapping['controls'] needs 'columns': [one per control]")
        comps = tuple(spec.get("components", cols))
        if len(comps) != len(cols):
            raise FlightDataError(
                f"mapping['controls'].components needs one name per column: {cols} vs {comps}"
            )
        out.append(_Spec("controls", cols, comps, str(spec.get("unit", "1")), lambda v: v,
                         float(spec.get("max_gap", max_gap))))  # fmt: skip
    extra = mapping.get("channels", {}) or {}
    if not isinstance(extra, Mapping):
        raise FlightDataError("mapping['channels'] must be a table {name: {columns, unit}}")
    for name, raw in extra.items():
        if name in STANDARD_CHANNELS:
            raise FlightDataError(
                f"mapping['channels'][{name!r}]: {name!r} is a standard channel; map it at the "
                "top level of the mapping, where its units are converted"
            )
        spec = _as_dict(name, raw)
        if "column" in spec:
            spec["columns"] = [spec.pop("column")]
        _check_keys(name, spec, {"columns", "components", "unit", "max_gap"})
        cols = [str(c) for c in spec.get("columns", [])]
        if not cols:
            raise FlightDataError(f"mapping['channels'][{name!r}] needs 'columns'")
        comps = tuple(spec.get("components", cols))
        out.append(_Spec(str(name), cols, comps, str(spec.get("unit", "")), lambda v: v,
                         float(spec.get("max_gap", max_gap))))  # fmt: skip
    for s in out:
        if not (math.isfinite(s.max_gap) and s.max_gap > 0):
            raise FlightDataError(f"max_gap of {s.name!r} must be > 0 s, got {s.max_gap}")
    return out


def _valid_samples(
    name: str, t: Array, v: Array, max_gap: float, table: _Table, rows: NDArray[np.int64]
) -> tuple[Array, Array]:
    ok = np.all(np.isfinite(v), axis=1)
    idx = np.flatnonzero(ok)
    if idx.size < 2:
        raise FlightDataError(
            f"{table.source}: channel {name!r} has {idx.size} valid sample(s) (rows where all its "
            "columns are numbers); it needs at least 2 — check the columns mapped to it"
        )
    tv = t[idx]
    gaps = np.diff(tv)
    bad = np.flatnonzero(gaps > max_gap)
    if bad.size:
        k = int(bad[np.argmax(gaps[bad])])
        a, b = idx[k], idx[k + 1]
        n_nan = int(b - a - 1)
        what = (
            f"{n_nan} invalid (NaN) sample(s) from {table.row_label(int(rows[a + 1]))} to "
            f"{table.row_label(int(rows[b - 1]))}"
            if n_nan
            else "no samples at all (a hole in the time column)"
        )
        raise FlightDataError(
            f"{table.source}: channel {name!r} has no valid data for {gaps[k]:.4g} s, from "
            f"t={tv[k]:.6g} s to t={tv[k + 1]:.6g} s ({what}); the longest gap allowed is "
            f"max_gap={max_gap:g} s ({bad.size} such gap(s)). Fill the gap, cut the flight "
            "around it, or raise max_gap for this channel if interpolating over it is acceptable"
        )
    return tv, v[idx]


def _time_axis(table: _Table, mapping: Mapping[str, Any]) -> Array:
    if "time" not in mapping:
        raise FlightDataError(
            f"the mapping needs 'time': the name of the time column; columns in "
            f"{table.source}: {', '.join(table.names)}"
        )
    col = str(mapping["time"])
    unit = mapping.get("time_unit", "s")
    raw = table.raw(col, "time")
    if unit == "iso" or raw.dtype.kind == "M":
        if raw.dtype.kind == "M":
            dt64 = raw.astype("datetime64[ns]")
        else:
            try:
                dt64 = np.array([np.datetime64(s.strip().rstrip("Z")) for s in raw]).astype(
                    "datetime64[ns]"
                )
            except ValueError as exc:
                raise FlightDataError(
                    f"{table.source}: time column {col!r} with time_unit 'iso' should hold ISO "
                    f"8601 times like 2022-06-24T15:17:16.25 ({exc})"
                ) from None
        nat = np.isnat(dt64)
        if nat.any():
            k = int(np.flatnonzero(nat)[0])
            raise FlightDataError(
                f"{table.source}: time column {col!r} is empty at {table.row_label(k)}; every row "
                "needs a time"
            )
        return (dt64 - dt64[0]).astype(np.int64) * 1e-9
    f = _factor("time", str(unit), "time_unit")
    t = table.numeric(col, "time") * f
    if not np.all(np.isfinite(t)):
        k = int(np.flatnonzero(~np.isfinite(t))[0])
        raise FlightDataError(
            f"{table.source}: time column {col!r} is not a number at {table.row_label(k)}; every "
            "row needs a time (drop rows without one)"
        )
    return t


def _order_rows(table: _Table, t: Array, used: list[str], policy: str) -> NDArray[np.int64]:
    """Indices of the rows to keep after the duplicate/monotonicity rules."""
    if policy not in ("drop_identical", "keep_first", "error"):
        raise FlightDataError(
            f"mapping['duplicates'] must be 'drop_identical', 'keep_first' or 'error', got "
            f"{policy!r}"
        )
    vals = np.stack([table.numeric(c, "a channel") for c in used], axis=1) if used else None
    keep = np.ones(t.size, dtype=bool)
    dt = np.diff(t)
    back = np.flatnonzero(dt < 0)
    if back.size:
        k = int(back[0])
        raise FlightDataError(
            f"{table.source}: time goes backwards at {table.row_label(k + 1)} (t={t[k + 1]:.6g} s "
            f"after t={t[k]:.6g} s at {table.row_label(k)}; {back.size} such place(s)); sort "
            "the rows by time, or split the log if it holds several flights"
        )
    same = np.flatnonzero(dt == 0)
    conflicts = []
    for k in same:
        identical = vals is None or bool(
            np.all((vals[k] == vals[k + 1]) | (np.isnan(vals[k]) & np.isnan(vals[k + 1])))
        )
        if identical and policy != "error":
            keep[k + 1] = False
        elif policy == "keep_first":
            keep[k + 1] = False
        else:
            conflicts.append(int(k))
    if conflicts:
        k = conflicts[0]
        kind = "with different values" if policy != "error" else ""
        raise FlightDataError(
            f"{table.source}: duplicated timestamp t={t[k]:.6g} s at {table.row_label(k)} and "
            f"{table.row_label(k + 1)} {kind} ({len(conflicts)} such place(s)); remove the "
            "duplicates, or set 'duplicates': 'keep_first' to keep the first row of each time"
        )
    return np.flatnonzero(keep)


def _events(table: _Table, mapping: Mapping[str, Any], t_all: Array) -> dict[str, float]:
    """Events of ``event_column`` (each new value at the time of its first row) and ``events``.

    ``t_all`` is the time of every row of the file, before duplicate rows are dropped: a row
    dropped as a repeated timestamp can still carry a change of the event column, and its time
    is the time of the row it repeats.
    """
    events: dict[str, float] = {}
    col = mapping.get("event_column")
    if col is not None:
        names_map = {str(k): str(v) for k, v in (mapping.get("event_names") or {}).items()}
        vals = table.strings(str(col), "event_column")
        prev = None
        for r, v in enumerate(vals):
            if v != prev and v != "":
                label = names_map.get(v, v)
                events.setdefault(label, float(t_all[r]))
            prev = v
    given = mapping.get("events") or {}
    if not isinstance(given, Mapping):
        raise FlightDataError("mapping['events'] must be a table {event name: time in s}")
    for k, v in given.items():
        try:
            events[str(k)] = float(v)
        except (TypeError, ValueError):
            raise FlightDataError(
                f"mapping['events'][{k!r}] must be a time in s, got {v!r}"
            ) from None
    return events


def _build(table: _Table, mapping: Mapping[str, Any], name: str | None) -> FlightData:
    if not isinstance(mapping, Mapping):
        raise FlightDataError(f"the mapping must be a table of keys, got {type(mapping).__name__}")
    for key in mapping:
        if key not in _TOP_KEYS:
            raise FlightDataError(f"unknown mapping key {key!r}; {suggest(key, _TOP_KEYS)}")
    max_gap = float(mapping.get("max_gap", DEFAULT_MAX_GAP))
    specs = _specs(mapping, max_gap)
    if not specs:
        raise FlightDataError(
            "the mapping names no channel; add at least one of "
            f"{', '.join(STANDARD_CHANNELS)} (or 'channels' for others)"
        )
    # resolve every column first so that all misspellings are reported before any work
    for s in specs:
        for c in s.columns:
            table.index(c, f"channel {s.name!r}")
    t_all = _time_axis(table, mapping)
    used = sorted({c for s in specs for c in s.columns})
    rows = _order_rows(table, t_all, used, str(mapping.get("duplicates", "drop_identical")))
    t = t_all[rows]
    if mapping.get("check_units", True):
        _check_time_scale(t, f"{table.source}: the time column", " (or set 'check_units': false)")

    origin = mapping.get("origin")
    if origin is not None:
        try:
            origin = tuple(float(x) for x in origin)
        except (TypeError, ValueError):
            origin = None
        if origin is None or len(origin) != 3 or not all(map(math.isfinite, origin)):
            raise FlightDataError(
                f"mapping['origin'] must be [lat_deg, lon_deg, alt_m], got {mapping['origin']!r}"
            )
    channels: dict[str, Channel] = {}
    geo: tuple[Array, Array] | None = None
    for s in specs:
        v = np.stack([table.numeric(c, f"channel {s.name!r}")[rows] for c in s.columns], axis=1)
        v = s.convert(v)
        tv, vv = _valid_samples(s.name, t, v, s.max_gap, table, rows)
        if s.name == "position" and s.geodetic:
            geo = (tv, vv)
            continue
        channels[s.name] = Channel(s.name, tv, vv, s.components, s.unit_out)
    if geo is not None:
        tv, vv = geo
        if origin is None:
            origin = (float(vv[0, 0]), float(vv[0, 1]), float(vv[0, 2]))
        if np.any(np.abs(vv[:, 0]) > 90) or np.any(np.abs(vv[:, 1]) > 360):
            raise FlightDataError(
                f"{table.source}: latitude/longitude out of range (|lat| <= 90°, |lon| <= 360°), "
                f"got lat up to {np.max(np.abs(vv[:, 0])):.4g}, lon up to "
                f"{np.max(np.abs(vv[:, 1])):.4g}; check 'angle_unit' and the column order"
            )
        channels["position"] = Channel(
            "position", tv, geodetic_to_ned(vv[:, 0], vv[:, 1], vv[:, 2], origin),
            ("north", "east", "down"), "m",
        )  # fmt: skip
    alt_spec = next((s for s in specs if s.name == "altitude"), None)
    if alt_spec is not None and alt_spec.geodetic:
        if origin is None:
            raise FlightDataError(
                "mapping['altitude'].reference = 'msl' needs the origin: give 'origin' or a "
                "geodetic 'position' (lat, lon, alt)"
            )
        a = channels["altitude"]
        channels["altitude"] = Channel(a.name, a.t, a.values - origin[2], a.components, a.unit)
    events = _events(table, mapping, t_all)
    lo = min(float(c.t[0]) for c in channels.values())
    hi = max(float(c.t[-1]) for c in channels.values())
    for k, v in events.items():
        if not lo <= v <= hi:
            raise FlightDataError(
                f"{table.source}: event {k!r} at t={v:.6g} s is outside the data [{lo:.6g}, "
                f"{hi:.6g}] s; events are times on the loaded time axis (after time_unit)"
            )
    fd = FlightData(
        str(mapping.get("name") or name or Path(table.source).stem), channels, events, origin
    )
    fd = drop_spikes(fd, table.source, str(mapping.get("spikes", "drop")))
    if mapping.get("check_units", True):
        units = {
            key: str(_as_dict(key, mapping[key]).get("unit", default))
            for key, default in (("velocity", "m/s"), ("altitude", "m"))
            if key in mapping
        }
        check_units(fd, table.source, units)
    return fd


# --------------------------------------------------------------------------- public loaders


def load_csv(path: str | os.PathLike[str], mapping: Mapping[str, Any]) -> FlightData:
    """Load a flight from a CSV file described by a column/unit mapping.

    Parameters
    ----------
    path : path-like
        CSV file with one header line (a leading ``#`` on it is ignored); the delimiter is
        detected (``,``, ``;``, tab, space) unless ``mapping["delimiter"]`` says.
    mapping : mapping
        Which column holds what, in which unit; see ``docs/identify.md``. Example::

            {"time": "t", "time_unit": "s",
             "position": {"lat": "lat_deg", "lon": "lon_deg", "alt": "alt_m"},
             "velocity": {"north": "vn", "east": "ve", "down": "vd", "unit": "m/s"},
             "euler": {"columns": ["roll", "pitch", "yaw"], "unit": "deg"},
             "controls": {"columns": ["left", "right"]},
             "events": {"canopy_deployed": 3.2}}

    Returns
    -------
    FlightData

    Raises
    ------
    FlightDataError
        Missing or misspelled columns, bad numbers, time going backwards or duplicated,
        gaps longer than ``max_gap``, unit mistakes; nothing is returned half-loaded.
    """
    p = Path(path)
    table = _read_csv(p, mapping.get("delimiter"), mapping.get("comment"))
    return _build(_cut_lines(table, mapping), mapping, p.stem)


def load_parquet(path: str | os.PathLike[str], mapping: Mapping[str, Any]) -> FlightData:
    """Load a flight from a Parquet file (needs the ``parquet`` extra, pyarrow).

    The mapping is the one of :func:`load_csv` (``delimiter`` and ``comment`` are ignored); a
    timestamp-typed time column is converted to seconds from its first row.
    """
    p = Path(path)
    return _build(_cut_lines(_read_parquet(p), mapping), mapping, p.stem)


_TELEMEGA_STATES = ("boost", "fast", "coast", "drogue", "main", "landed")


def load_telemega(
    path: str | os.PathLike[str], *, max_gap: float = 3.0, spikes: str = "drop"
) -> FlightData:
    """Load the CSV written by an Altus Metrum flight computer (TeleMega, TeleMetrum, EasyMega,
    EasyMini, ...: AltosUI's CSV export), with or without a UTF-8 byte-order mark and comment
    lines before the header.

    The columns present depend on the device (AltosUI writes the groups it has data for): the
    barometric ``height`` is always there; GPS columns (``latitude``, ``longitude``, the
    second ``altitude``) only for a device with GPS (TeleMega, TeleMetrum), gyro columns
    (``gyro_roll``/``gyro_pitch``/``gyro_yaw`` or ``gyro_x``/``gyro_y``/``gyro_z``) only for one
    with an IMU, the speed as ``speed`` or ``baro_speed``; ``state_name`` when the device kept
    a flight state.

    Channels: ``position`` (GPS latitude/longitude/altitude -> NED about the first valid fix,
    the pad; one sample per new fix, ~1 Hz), ``altitude`` (barometric height above the pad, m,
    column ``height``), ``rates`` (gyro roll/pitch/yaw, deg/s -> rad/s), ``vertical_speed``
    (the logger's speed estimate, m/s positive up; starts where the log has it), ``acceleration``
    (along the axis, m/s²), ``pressure`` (Pa), ``temperature`` (°C), ``gps_altitude``
    (GPS altitude above mean sea level, m).

    Events: the first time of each flight state in ``state_name`` (``boost``, ``fast``, ``coast``,
    ``drogue``, ``main``, ``landed`` as present) plus ``apogee``, the time of the highest
    barometric height (derived, not a logger state).

    Exact duplicate rows (the logger repeats some) are dropped. The barometric channels
    (``altitude``, ``pressure``) keep the rows where the barometer gave a new sample: rows of
    other packets repeat the last pressure and height at a later time. GPS rows are fixes where
    ``locked`` is 1, ``nsat`` >= 4 and the fix (position or GPS clock) changed from the previous
    row: the file repeats the last fix between updates.

    Parameters
    ----------
    path : path-like
        The TeleMega CSV.
    max_gap : float
        Longest stretch without valid data inside a channel, s (GPS fixes come at ~1 Hz).
    spikes : {"drop", "note", "keep", "strict"}
        Single-sample spikes of every channel (:func:`vectorid.identify.outliers.drop_spikes`):
        left out and named in ``notes`` (default), kept, or an error.
    """
    p = Path(path)
    head = altusmetrum_header(p)
    table = _read_csv(p, skip=0 if head is None else head)
    need = ["time", "height"]
    for c in need:
        if c not in table.names:
            raise FlightDataError(
                f"{p}: not a TeleMega or other AltusMetrum CSV: column {c!r} is missing; "
                f"{suggest(c, table.names)}. Use load_csv with a mapping for other formats"
            )
    has_gps = all(c in table.names for c in ("latitude", "longitude", "altitude.1"))
    t_all = table.numeric("time", "time")
    # exact duplicates of whole rows
    raw = [table.raw(c, "") for c in table.names]
    keep = np.ones(table.n_rows, dtype=bool)
    for k in range(1, table.n_rows):
        if t_all[k] == t_all[k - 1] and all(col[k] == col[k - 1] for col in raw):
            keep[k] = False
    rows = np.flatnonzero(keep)
    t = t_all[rows]
    dt = np.diff(t)
    if np.any(dt <= 0):
        k = int(np.flatnonzero(dt <= 0)[0])
        raise FlightDataError(
            f"{p}: time does not increase at {table.row_label(int(rows[k + 1]))} (t={t[k + 1]:.6g}"
            f" s after t={t[k]:.6g} s, rows not identical); the file may hold several flights or "
            "be edited — fix or cut it"
        )

    def num(c: str) -> Array:
        return table.numeric(c, "TeleMega")[rows]

    def chan(name: str, cols: list[str], comps: tuple[str, ...], unit: str, f: float = 1.0,
             gap: float = max_gap) -> Channel:  # fmt: skip
        v = np.stack([num(c) for c in cols], axis=1) * f
        tv, vv = _valid_samples(name, t, v, gap, table, rows)
        return Channel(name, tv, vv, comps, unit)

    channels: dict[str, Channel] = {}
    # The logger writes a row for every packet; rows of other packets carry the last
    # barometer sample over (same pressure and height, a later time). They are not new
    # measurements: a copy 0.07 s after its sample, interpolated as if measured then, is off
    # by the distance flown meanwhile (up to 8 m in the drogue phase of the shared log).
    baro = ["height"] + (["pressure"] if "pressure" in table.names else [])
    bv = np.stack([num(c) for c in baro], axis=1)
    fresh = np.ones(t.size, dtype=bool)
    fresh[1:] = np.any(bv[1:] != bv[:-1], axis=1)

    def baro_chan(name: str, col: str, comps: tuple[str, ...], unit: str) -> Channel:
        v = num(col)[fresh][:, None]
        tv, vv = _valid_samples(name, t[fresh], v, max_gap, table, rows[fresh])
        return Channel(name, tv, vv, comps, unit)

    channels["altitude"] = baro_chan("altitude", "height", ("altitude",), "m")
    origin = None
    if has_gps:
        origin = _altusmetrum_gps(p, table, t, num, channels, max_gap)
    for gyro in (("gyro_roll", "gyro_pitch", "gyro_yaw"), ("gyro_x", "gyro_y", "gyro_z")):
        if all(c in table.names for c in gyro):
            channels["rates"] = chan("rates", list(gyro), ("p", "q", "r"), "rad/s", math.pi / 180.0)
            break
    speed = next((c for c in ("speed", "baro_speed") if c in table.names), "speed")
    extras = [
        ("vertical_speed", speed, "m/s"),
        ("acceleration", "acceleration", "m/s^2"),
        ("pressure", "pressure", "Pa"),
        ("temperature", "temperature", "degC"),
    ]
    for name, col, unit in extras:
        if col in table.names and np.sum(np.isfinite(num(col))) >= 2:
            if name == "pressure":
                channels[name] = baro_chan(name, col, (name,), unit)
            else:
                channels[name] = chan(name, [col], (name,), unit)
    events: dict[str, float] = {}
    if "state_name" in table.names:
        states = table.strings("state_name", "events")
        prev = None
        for r, tr in zip(rows, t):
            st = states[r]
            if st != prev and st:
                events.setdefault(st, float(tr))
            prev = st
    unknown = [e for e in events if e not in _TELEMEGA_STATES and e not in ("pad", "idle")]
    if unknown:
        warnings.warn(f"{p}: unexpected flight states {unknown}; kept as events", stacklevel=2)
    h = channels["altitude"]
    # the apogee of the heights' running median: a single corrupt sample is not the apogee
    from scipy.ndimage import median_filter

    hm = median_filter(h.values[:, 0], size=min(5, h.t.size) | 1, mode="nearest")
    events["apogee"] = float(h.t[int(np.argmax(hm))])
    fd = drop_spikes(FlightData(p.stem, channels, events, origin), str(p), spikes)
    if "pressure" in fd.channels:  # one barometer: a spike of either is left out of both
        a, b = fd.channels["altitude"], fd.channels["pressure"]
        both = np.intersect1d(a.t, b.t)
        for c in (a, b):
            if c.t.size != both.size:
                k = np.isin(c.t, both)
                fd.channels[c.name] = Channel(c.name, c.t[k], c.values[k], c.components, c.unit)
    check_units(fd, str(p))
    return fd


def _altusmetrum_gps(p, table, t, num, channels, max_gap):
    """The GPS channels of an AltusMetrum CSV (``position``, ``gps_altitude``); the origin."""
    lat, lon, alt = num("latitude"), num("longitude"), num("altitude.1")
    ok = np.isfinite(lat) & np.isfinite(lon) & np.isfinite(alt) & ~((lat == 0) & (lon == 0))
    if "locked" in table.names:
        ok &= num("locked") == 1
    if "nsat" in table.names:
        ok &= num("nsat") >= 4
    clock = [c for c in ("year", "month", "day", "hour", "minute", "second") if c in table.names]
    key = np.stack([lat, lon, alt] + [num(c) for c in clock], axis=1)
    new = np.ones(t.size, dtype=bool)
    new[1:] = np.any(key[1:] != key[:-1], axis=1)
    fix = np.flatnonzero(ok & new)
    if fix.size < 2:
        raise FlightDataError(
            f"{p}: fewer than 2 valid GPS fixes (locked, >= 4 satellites) in the GPS columns; "
            "delete the GPS columns (latitude, longitude, the second altitude) to read the log "
            "without them"
        )
    gaps = np.diff(t[fix])
    if np.any(gaps > max_gap):
        k = int(np.argmax(gaps))
        raise FlightDataError(
            f"{p}: no new GPS fix for {gaps[k]:.4g} s, from t={t[fix[k]]:.6g} s to "
            f"t={t[fix[k + 1]]:.6g} s (max_gap={max_gap:g} s); raise max_gap or cut the flight"
        )
    origin = (float(lat[fix[0]]), float(lon[fix[0]]), float(alt[fix[0]]))
    channels["position"] = Channel(
        "position", t[fix], geodetic_to_ned(lat[fix], lon[fix], alt[fix], origin),
        ("north", "east", "down"), "m",
    )  # fmt: skip
    channels["gps_altitude"] = Channel("gps_altitude", t[fix], alt[fix], ("altitude",), "m")
    return origin


def _quat_to_euler(q: Array) -> Array:
    """Quaternion (w, x, y, z), body to NED -> roll, pitch, yaw (rad), ZYX convention."""
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1.0, 1.0))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.stack([roll, pitch, yaw], axis=1)


def load_ulog(path: str | os.PathLike[str], *, max_gap: float = DEFAULT_MAX_GAP) -> FlightData:
    """Load a PX4 ULog (needs the ``ulog`` extra: ``pip install pyulog``).

    Topics read (first instance of each, when present):

    - ``vehicle_local_position``: ``x, y, z`` -> ``position`` (NED, m), ``vx, vy, vz`` ->
      ``velocity`` (m/s); ``ref_lat, ref_lon, ref_alt`` -> ``origin``.
    - ``vehicle_global_position`` (``lat, lon, alt``) -> ``position`` by pymap3d when there is no
      local position.
    - ``vehicle_attitude``: quaternion ``q[0..3]`` -> ``euler`` (ZYX roll, pitch, yaw, rad).
    - ``vehicle_angular_velocity`` (``xyz[0..2]``) or ``sensor_combined`` (``gyro_rad[0..2]``)
      -> ``rates`` (rad/s).
    - ``vehicle_air_data``: ``baro_alt_meter`` -> ``altitude`` (above the origin when known).
    - ``actuator_outputs`` (``output[0..7]``) -> ``controls`` (raw outputs, no scaling).

    Times are ``timestamp`` (µs since boot) in s. Events: ``armed`` and ``disarmed`` from
    ``vehicle_status.arming_state`` changes, ``landed``/``takeoff`` from
    ``vehicle_land_detected.landed``.
    """
    try:
        from pyulog import ULog
    except ImportError:
        raise FlightDataError(
            "reading PX4 ULog files needs pyulog: pip install 'vectorid[ulog]' (or pip install "
            "pyulog)"
        ) from None
    p = Path(path)
    if not p.exists():
        raise FlightDataError(f"no such file: {p}")
    try:
        ulog = ULog(str(p))
    except Exception as exc:
        raise FlightDataError(f"{p}: cannot read as a PX4 ULog ({exc})") from None
    topics: dict[str, dict[str, Array]] = {}
    for d in ulog.data_list:
        if d.multi_id == 0 and d.name not in topics:
            topics[d.name] = {k: np.asarray(v) for k, v in d.data.items()}
    if not topics:
        raise FlightDataError(f"{p}: the ULog holds no logged topics")

    table = _Table(str(p), [], lambda i: np.empty(0), 0, lambda i: f"sample {i}")

    def build(topic: str, fields: list[str], name: str, comps: tuple[str, ...], unit: str,
              f: float = 1.0) -> Channel | None:  # fmt: skip
        d = topics.get(topic)
        if d is None or not all(k in d for k in fields):
            return None
        t = d["timestamp"].astype(np.float64) * 1e-6
        v = np.stack([d[k].astype(np.float64) for k in fields], axis=1) * f
        order = np.argsort(t, kind="stable")
        t, v = t[order], v[order]
        keep = np.concatenate([[True], np.diff(t) > 0])
        t, v = t[keep], v[keep]
        tv, vv = _valid_samples(
            f"{name} ({topic})", t, v, max_gap, table, np.arange(t.size, dtype=np.int64)
        )
        return Channel(name, tv, vv, comps, unit)

    channels: dict[str, Channel] = {}
    origin: tuple[float, float, float] | None = None
    lp = topics.get("vehicle_local_position")
    if lp is not None and all(k in lp for k in ("ref_lat", "ref_lon", "ref_alt")):
        ref = (float(lp["ref_lat"][-1]), float(lp["ref_lon"][-1]), float(lp["ref_alt"][-1]))
        if all(map(math.isfinite, ref)) and not (ref[0] == 0 and ref[1] == 0):
            origin = ref
    pos = build("vehicle_local_position", ["x", "y", "z"], "position",
                ("north", "east", "down"), "m")  # fmt: skip
    if pos is None:
        gp = build("vehicle_global_position", ["lat", "lon", "alt"], "position",
                   ("north", "east", "down"), "m")  # fmt: skip
        if gp is not None:
            v = gp.values
            if origin is None:
                origin = (float(v[0, 0]), float(v[0, 1]), float(v[0, 2]))
            pos = Channel("position", gp.t, geodetic_to_ned(v[:, 0], v[:, 1], v[:, 2], origin),
                          ("north", "east", "down"), "m")  # fmt: skip
    if pos is not None:
        channels["position"] = pos
    vel = build("vehicle_local_position", ["vx", "vy", "vz"], "velocity",
                ("north", "east", "down"), "m/s")  # fmt: skip
    if vel is not None:
        channels["velocity"] = vel
    att = build("vehicle_attitude", ["q[0]", "q[1]", "q[2]", "q[3]"], "euler",
                ("w", "x", "y", "z"), "1")  # fmt: skip
    if att is not None:
        channels["euler"] = Channel("euler", att.t, _quat_to_euler(att.values),
                                    ("roll", "pitch", "yaw"), "rad")  # fmt: skip
    rates = build("vehicle_angular_velocity", ["xyz[0]", "xyz[1]", "xyz[2]"], "rates",
                  ("p", "q", "r"), "rad/s")  # fmt: skip
    if rates is None:
        rates = build("sensor_combined", ["gyro_rad[0]", "gyro_rad[1]", "gyro_rad[2]"], "rates",
                      ("p", "q", "r"), "rad/s")  # fmt: skip
    if rates is not None:
        channels["rates"] = rates
    alt = build("vehicle_air_data", ["baro_alt_meter"], "altitude", ("altitude",), "m")
    if alt is not None:
        off = origin[2] if origin is not None else 0.0
        channels["altitude"] = Channel("altitude", alt.t, alt.values - off, ("altitude",), "m")
    ao = topics.get("actuator_outputs")
    if ao is not None:
        cols = [f"output[{i}]" for i in range(16) if f"output[{i}]" in ao]
        if cols:
            c = build("actuator_outputs", cols, "controls", tuple(cols), "1")
            if c is not None:
                channels["controls"] = c
    if not channels:
        raise FlightDataError(
            f"{p}: none of the topics vectorid reads is in the log (found {sorted(topics)}); "
            "convert the topics you need to CSV and use load_csv with a mapping"
        )
    events: dict[str, float] = {}
    st = topics.get("vehicle_status")
    if st is not None and "arming_state" in st:
        ts = st["timestamp"] * 1e-6
        a = st["arming_state"]
        for k in range(1, a.size):
            if a[k] != a[k - 1]:
                events.setdefault("armed" if a[k] == 2 else "disarmed", float(ts[k]))
    ld = topics.get("vehicle_land_detected")
    if ld is not None and "landed" in ld:
        ts = ld["timestamp"] * 1e-6
        a = ld["landed"]
        for k in range(1, a.size):
            if a[k] != a[k - 1]:
                events.setdefault("landed" if a[k] else "takeoff", float(ts[k]))
    lo = min(float(c.t[0]) for c in channels.values())
    hi = max(float(c.t[-1]) for c in channels.values())
    events = {k: v for k, v in events.items() if lo <= v <= hi}
    fd = FlightData(p.stem, channels, events, origin)
    check_units(fd, str(p))
    return fd


_FORMATS = ("csv", "parquet", "telemega", "altusmetrum", "ulog")


def altusmetrum_header(path: str | os.PathLike[str]) -> int | None:
    """Line index (0-based) of the header of an AltusMetrum CSV, None if the file is not one.

    Recognised from the content, not the name: a header line (after an optional UTF-8 BOM,
    blank lines and ``#`` comment lines) whose columns begin ``version,serial,flight,call,time``
    (with or without a leading ``#``) and include ``height``: every AltusMetrum device's CSV
    export (TeleMega, TeleMetrum, EasyMega, EasyMini, TeleMini, ...).
    """
    try:
        with Path(path).open(encoding="utf-8-sig", errors="replace") as fh:
            lines = [fh.readline() for _ in range(64)]
    except OSError:
        return None
    for k, line in enumerate(lines):
        text = line.strip().lstrip("\ufeff")
        if not text:
            continue
        cols = [c.strip().lower() for c in text.lstrip("#").split(",")]
        if cols[:5] == ["version", "serial", "flight", "call", "time"] and "height" in cols:
            return k
        if not text.startswith("#"):
            return None
    return None


def _is_telemega(path: Path) -> bool:
    return altusmetrum_header(path) is not None


def load_flight(
    path: str | os.PathLike[str],
    mapping: Mapping[str, Any] | None = None,
    format: str | None = None,
) -> FlightData:
    """Load a flight, choosing the loader from ``format`` or the file.

    Parameters
    ----------
    path : path-like
    mapping : mapping, optional
        Column/unit mapping for CSV and Parquet (required for them, unless the CSV is a TeleMega
        log, recognised by its header).
    format : {"csv", "parquet", "telemega", "ulog"}, optional
        Default: from the extension (``.csv``, ``.parquet``/``.pq``, ``.ulg``) and, for a CSV
        without a mapping, the TeleMega header.
    """
    p = Path(path)
    fmt = format
    if fmt is None:
        ext = p.suffix.lower()
        if ext in (".ulg", ".ulog"):
            fmt = "ulog"
        elif ext in (".parquet", ".pq"):
            fmt = "parquet"
        elif ext in (".csv", ".txt", ".tsv"):
            fmt = "telemega" if mapping is None and _is_telemega(p) else "csv"
        else:
            raise FlightDataError(
                f"{p}: cannot tell the format from the extension {ext!r}; pass format= one of "
                f"{', '.join(_FORMATS)}"
            )
    if fmt not in _FORMATS:
        raise FlightDataError(f"unknown format {fmt!r}; {suggest(fmt, _FORMATS)}")
    if fmt in ("telemega", "altusmetrum"):
        return load_telemega(p, spikes=str((mapping or {}).get("spikes", "drop")))
    if fmt == "ulog":
        return load_ulog(p)
    if mapping is None:
        raise FlightDataError(
            f"{p}: a {fmt} file needs a mapping of columns to channels (see docs/identify.md), "
            "e.g. {'time': 't', 'altitude': {'column': 'h', 'unit': 'm'}}"
        )
    return load_csv(p, mapping) if fmt == "csv" else load_parquet(p, mapping)
