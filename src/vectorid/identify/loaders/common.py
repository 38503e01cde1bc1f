"""What every loader shares: the table read from a file, unit factors and checks, the valid
samples of a channel (see :mod:`vectorid.identify.loaders` for the common rules)."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vectorid.errors import suggest
from vectorid.identify.flight import STANDARD_CHANNELS, FlightData, FlightDataError

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
    "header_line",
    "decimal",
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


# --------------------------------------------------------------------------- valid samples


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


# --------------------------------------------------------------------------- encodings

#: Signatures of files that are not plain text, and what to do with each.
_SIGNATURES = (
    (b"\x1f\x8b", "gzip-compressed (it begins with the gzip signature 1f 8b)",
     "decompress it first (gunzip -k FILE) and give the .csv"),
    (b"BZh", "bzip2-compressed", "decompress it first (bunzip2 -k FILE)"),
    (b"\xfd7zXZ\x00", "xz-compressed", "decompress it first (unxz -k FILE)"),
    (b"\x28\xb5\x2f\xfd", "zstd-compressed", "decompress it first (unzstd FILE)"),
    (b"PK\x03\x04", "a ZIP archive (a spreadsheet workbook such as .xlsx is one)",
     "extract the CSV, or save the sheet as CSV (UTF-8)"),
    (b"PAR1", "a Parquet file", "give it the extension .parquet (or --format parquet)"),
    (b"\xff\xfe\x00\x00", "UTF-32 text (little-endian byte-order mark ff fe 00 00)",
     "save it as UTF-8, e.g. iconv -f UTF-32 -t UTF-8 FILE > FILE-utf8.csv"),
    (b"\x00\x00\xfe\xff", "UTF-32 text (big-endian byte-order mark 00 00 fe ff)",
     "save it as UTF-8, e.g. iconv -f UTF-32 -t UTF-8 FILE > FILE-utf8.csv"),
    (b"\xff\xfe", "UTF-16 text (little-endian byte-order mark ff fe)",
     "save it as UTF-8, e.g. iconv -f UTF-16 -t UTF-8 FILE > FILE-utf8.csv"),
    (b"\xfe\xff", "UTF-16 text (big-endian byte-order mark fe ff)",
     "save it as UTF-8, e.g. iconv -f UTF-16 -t UTF-8 FILE > FILE-utf8.csv"),
)  # fmt: skip


def text_encoding_problem(path: Any) -> str | None:
    """Why a file is not UTF-8 text, in one sentence with the fix; None if it is.

    Names what the file is instead: compressed (gzip, bzip2, xz, zstd), an archive or a
    spreadsheet (ZIP), Parquet, UTF-16/UTF-32 text (with a byte-order mark, or UTF-16 without
    one: every other byte 0), another 8-bit encoding (the first byte that is not UTF-8, with
    its line and the text as Windows-1252 would read it), or binary data. Reads the first
    64 kB (and decodes the whole file only when those are valid UTF-8, to find a later bad
    byte).
    """
    from pathlib import Path

    p = Path(path)
    name = p.name
    utf8 = f"{p.stem}-utf8{p.suffix or '.csv'}"
    try:
        with p.open("rb") as fh:
            head = fh.read(65536)
    except OSError:
        return None
    for sig, what, fix in _SIGNATURES:
        if head.startswith(sig):
            fix = fix.replace("FILE > FILE-utf8.csv", f"{name} > {utf8}").replace("FILE", name)
            return f"{name} is {what}, not UTF-8 text — {fix}"
    if head.startswith(b"\xef\xbb\xbf"):
        head = head[3:]
    sample = head[:4096]
    if len(sample) >= 8 and sample.count(0) >= len(sample) // 4:
        even, odd = sample[0::2], sample[1::2]
        for zeros, other, order in ((odd, even, "little"), (even, odd, "big")):
            printable = sum(32 <= b < 127 or b in (9, 10, 13) for b in other)
            if zeros.count(0) >= 0.9 * len(zeros) and printable >= 0.9 * len(other):
                enc = "UTF-16LE" if order == "little" else "UTF-16BE"
                return (
                    f"{name} is UTF-16 text ({order}-endian, without a byte-order mark: every "
                    f"other byte is 0), not UTF-8 — save it as UTF-8, e.g. iconv -f {enc} -t "
                    f"UTF-8 {name} > {utf8}"
                )
        return f"{name} holds binary data (NUL bytes), not UTF-8 text: is it a CSV?"
    try:
        data = p.read_bytes()
        data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raw = data
        pos = exc.start
        line = raw.count(b"\n", 0, pos) + 1
        start = raw.rfind(b"\n", 0, pos) + 1
        end = raw.find(b"\n", pos)
        text = raw[start : end if end >= 0 else len(raw)].decode("cp1252", errors="replace")
        return (
            f"{name} is not UTF-8 text: byte 0x{raw[pos]:02x} at line {line} is not UTF-8 "
            f"(read as Windows-1252 / Latin-1 the line is {text.strip()[:80]!r}) — save it as "
            f"UTF-8, e.g. iconv -f WINDOWS-1252 -t UTF-8 {name} > {utf8}"
        )
    except OSError:
        return None
    return None
