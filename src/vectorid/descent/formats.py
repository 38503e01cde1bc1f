"""What kind of log a descent's file is, read from its content, and the units its header states.

- An AltusMetrum CSV (TeleMega, TeleMetrum, EasyMega, EasyMini, ...; with or without a UTF-8
  BOM) is recognised by its header (:func:`vectorid.identify.loaders.altusmetrum_header`): it
  states its own columns and units, so options that map columns or set units do not apply to
  it and are refused.
- A PX4 ULog by its extension (``.ulg``) and a Parquet file by ``.parquet``/``.pq``.
- Any other text file is a generic CSV: its time and altitude columns come from ``--columns``
  or, when the header has exactly one time-like and one altitude-like column, from the header
  (said in a note); a unit in a column's name (``Altitude (Ft-AGL)``, ``alt(m)``,
  ``height_ft``, ``t [ms]``) is read, and an option that contradicts it is an error. Several
  altitude columns that state their units and agree after the conversion are one (the metres
  one is used). A time that goes back (a repeated buffer) and logging pauses are handled from
  the time column (:func:`_flight_part`), each said in a note.
- A logger's CSV export whose documentation fixes its columns' units is recognised from its
  header as a named format (:data:`NAMED_CSV`: the CATS Vega flight computer's filtered-data
  export): its units are the documented ones, not a guess, and a unit option is refused.
- A unit is never guessed: a generic CSV's time or altitude column whose name states no unit
  needs ``--time-unit``/``--altitude-unit`` (the flight's documentation says which); without
  it the run stops with a one-line message naming the column. A time column of ISO 8601 dates
  states its unit by its content.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from vectorid.errors import StudyDefinitionError
from vectorid.identify.loaders import DEFAULT_MAX_GAP, altusmetrum_header
from vectorid.identify.loaders.common import text_encoding_problem

__all__ = ["LENGTH_UNITS", "NAMED_CSV", "TIME_UNITS", "LogFormat", "column_unit", "detect_format"]

#: Length units a column name or an option may state, as the loaders spell them.
LENGTH_UNITS = {
    "m": "m", "meter": "m", "meters": "m", "metre": "m", "metres": "m",
    "ft": "ft", "feet": "ft", "foot": "ft",
    "km": "km",
}  # fmt: skip
#: Time units a column name or an option may state.
TIME_UNITS = {
    "s": "s", "sec": "s", "secs": "s", "second": "s", "seconds": "s",
    "ms": "ms", "millis": "ms", "milliseconds": "ms",
    "us": "us", "µs": "us", "ns": "ns", "min": "min", "minutes": "min",
}  # fmt: skip


@dataclass(frozen=True)
class NamedCsv:
    """A logger's CSV export recognised by its header, with the units its documentation states.

    Attributes
    ----------
    name : str
        The format's name as notes print it.
    header : tuple of str
        The exact column names (in any order; a leading unnamed index column is allowed).
    time, altitude : str
        The time and altitude columns.
    time_unit, altitude_unit : str
        Their documented units.
    source : str
        Where the units are documented.
    """

    name: str
    header: tuple[str, ...]
    time: str
    altitude: str
    time_unit: str
    altitude_unit: str
    source: str


# CATS Vega flight computer (Control and Telemetry Systems, https://github.com/catsystems).
# Its logs are exported to CSV by the cats-logs parser (catsystems/cats-logs,
# catslogs/binary_parser.py: ``filtered_data_info`` rows {ts, filtered_altitude_AGL,
# filtered_acceleration}, ts converted from the logger's ms ticks to s since liftoff,
# ``scale_col(..., 'ts', 1000)``) and by the CATS Configurator (catsystems/cats-configurator,
# ``filteredDataInfo`` {ts, filteredAltitudeAGL, filteredAcceleration}). The CATS team's flight
# data README (catsystems/euroc21-team-data, Aris-Euler/CATS/README.md) states: "The state
# estimation height is in m and the velocity in m/s"; the filtered altitude above ground is that
# estimate, in m. The shared EuRoC 2023 logs (Camões, Genesis, Lince) and Hedy's (EuRoC 2025,
# "CATS Vega Flight Data") are these exports; their READMEs say s and m as well.
_CATS_SOURCE = (
    "the CATS documentation (height in m: catsystems/euroc21-team-data; ts in s since "
    "liftoff: catsystems/cats-logs)"
)
#: Logger exports recognised from their header, whose documentation fixes the units.
NAMED_CSV: tuple[NamedCsv, ...] = (
    NamedCsv(
        "CATS Vega filtered data (cats-logs export)",
        ("ts", "filtered_altitude_AGL", "filtered_acceleration"),
        "ts", "filtered_altitude_AGL", "s", "m", _CATS_SOURCE,
    ),
    NamedCsv(
        "CATS Vega filtered data (CATS Configurator export)",
        ("ts", "filteredAltitudeAGL", "filteredAcceleration"),
        "ts", "filteredAltitudeAGL", "s", "m", _CATS_SOURCE,
    ),
)  # fmt: skip


def named_csv(names: list[str]) -> NamedCsv | None:
    """The named format whose header ``names`` is (None: a generic CSV)."""
    cols = list(names)
    if cols and (cols[0] in ("", "index") or cols[0].lower().startswith("unnamed")):
        cols = cols[1:]  # a pandas index column
    for f in NAMED_CSV:
        if sorted(cols) == sorted(f.header):
            return f
    return None


_TIME_NAME = re.compile(r"^(t|ts|time|timestamp|time_s|elapsed)\b", re.IGNORECASE)
_ALT_NAME = re.compile(r"(alt|height|^z$|^h$|^z\b|^h\b)", re.IGNORECASE)


def _err(where: str, problem: str, fix: str = "") -> StudyDefinitionError:
    return StudyDefinitionError(where, problem, fix)


def _split_name(name: str) -> tuple[str, str | None]:
    """A column name's base and the text of its unit part (in () or [], or a _unit suffix)."""
    m = re.match(r"^\s*(.*?)\s*[\(\[]([^\)\]]*)[\)\]]\s*$", name)
    if m:
        return m.group(1), m.group(2)
    m = re.match(r"^(.*?)[_ ]([A-Za-zµ]+)$", name.strip())
    if m and (m.group(2).lower() in LENGTH_UNITS or m.group(2).lower() in TIME_UNITS):
        return m.group(1), m.group(2)
    return name.strip(), None


def column_unit(name: str, kind: str) -> str | None:
    """The unit a column's name states (``"ft"``, ``"m"``, ``"s"``, ...), None if it states none.

    Parameters
    ----------
    name : str
        Column name, e.g. ``"Altitude (Ft-AGL)"``, ``"alt(m)"``, ``"height_ft"``.
    kind : {"length", "time"}

    Raises
    ------
    StudyDefinitionError
        When the name states a unit of the other kind, or two different ones.
    """
    _, text = _split_name(name)
    if text is None:
        return None
    table = LENGTH_UNITS if kind == "length" else TIME_UNITS
    words = [w for w in re.split(r"[^A-Za-zµ0-9/]+", text.lower()) if w]
    found = {table[w] for w in words if w in table}
    if len(found) > 1:
        raise _err(
            "columns", f"column {name!r} names two units ({', '.join(sorted(found))})",
            "rename the column or say its unit with --altitude-unit/--time-unit",
        )  # fmt: skip
    return found.pop() if found else None


@dataclass
class LogFormat:
    """The format of a log and what its content states.

    Attributes
    ----------
    format : str
        ``"altusmetrum"``, ``"csv"``, ``"parquet"`` or ``"ulog"``.
    mapping : dict or None
        The CSV/Parquet mapping with every unit resolved (None for self-describing formats).
    notes : list of str
        What was read from the content (columns chosen, units read from the header).
    named : str or None
        The name of a recognised logger export (:data:`NAMED_CSV`) whose documentation states
        the altitude's unit; None otherwise.
    """

    format: str
    mapping: dict[str, Any] | None = None
    notes: list[str] = field(default_factory=list)
    named: str | None = None


#: A field that reads as a number (a decimal point or comma), an ISO 8601 date, or no value.
_NUMERIC = re.compile(
    r"^\s*([-+]?(\d+([.,]\d*)?|[.,]\d+)([eE][-+]?\d+)?|\d{4}-\d\d-\d\d[T ][\d:.]+Z?"
    r"|nan|NaN|NAN|)\s*$"
)
_DECIMAL_COMMA = re.compile(r"^\s*[-+]?\d+,\d+\s*$")


@dataclass(frozen=True)
class _Layout:
    """Where a generic CSV's header is and how its fields are written."""

    line: int  # the header's line number (1-based)
    first: int  # the first non-empty, non-comment line (text before the header: line > first)
    delimiter: str
    decimal: str
    names: list[str]


def _split(line: str, delim: str) -> list[str]:
    import csv

    return next(csv.reader([line], delimiter=delim, skipinitialspace=True), [])


def _layout(path: Path) -> _Layout | None:
    """The header of a generic CSV: the first line of at least two fields, not all numbers,
    followed by rows of as many fields, each with a number in it (text lines before it, as
    loggers write a title or a date, are not the header); its delimiter; and whether the
    numbers are written with a decimal comma (``12,5`` in a ``;``- or tab-separated file)."""
    import csv

    lines: list[tuple[int, str]] = []
    with path.open(encoding="utf-8-sig", errors="replace", newline="") as fh:
        for lineno, line in enumerate(fh, start=1):
            if line.strip() and not line.lstrip().startswith("#"):
                lines.append((lineno, line.rstrip("\r\n")))
            if len(lines) >= 40:
                break
    for i, (lineno, line) in enumerate(lines[:30]):
        try:
            delim = csv.Sniffer().sniff(line, delimiters=",;\t").delimiter
        except csv.Error:
            delim = ","
        names = _split(line, delim)
        if len(names) < 2 or all(_NUMERIC.match(f) for f in names):
            continue
        rows = [_split(ln, delim) for _, ln in lines[i + 1 : i + 6]]
        if not rows or any(
            len(r) != len(names) or not any(_NUMERIC.match(f) and f.strip() for f in r)
            for r in rows
        ):
            continue
        comma = delim != "," and any(_DECIMAL_COMMA.match(f) for r in rows for f in r)
        return _Layout(lineno, lines[0][0], delim, "," if comma else ".",
                       [c.strip() for c in names])  # fmt: skip
    return None


def _header(path: Path) -> list[str]:
    lay = _layout(path)
    if lay is not None:
        return lay.names
    import csv

    with path.open(encoding="utf-8-sig", errors="replace") as fh:
        for line in fh:
            if line.strip() and not line.lstrip().startswith("#"):
                try:
                    delim = csv.Sniffer().sniff(line, delimiters=",;\t").delimiter
                except csv.Error:
                    delim = ","
                return [c.strip() for c in next(csv.reader([line], delimiter=delim))]
    return []


def _data_rows(path: Path, lay: _Layout | None):
    """``(line number, fields)`` of the data rows after the header (decimal commas made
    points)."""
    import csv

    with path.open(encoding="utf-8-sig", errors="replace", newline="") as fh:
        header_seen = False
        delim = "," if lay is None else lay.delimiter
        for lineno, line in enumerate(fh, start=1):
            if not line.strip() or line.lstrip().startswith("#"):
                continue
            if not header_seen:
                if lay is None:
                    try:
                        delim = csv.Sniffer().sniff(line, delimiters=",;\t").delimiter
                    except csv.Error:
                        delim = ","
                    header_seen = True
                elif lineno == lay.line:
                    header_seen = True
                continue
            row = next(csv.reader([line], delimiter=delim), [])
            if lay is not None and lay.decimal == ",":
                row = [c.replace(",", ".") for c in row]
            yield lineno, row


def detect_format(
    path: str | Path,
    *,
    format: str | None = None,
    columns: dict[str, str] | None = None,
    time_unit: str | None = None,
    altitude_unit: str | None = None,
    extra: dict[str, Any] | None = None,
) -> LogFormat:
    """The format of a descent log and its resolved mapping (see the module docstring).

    Parameters
    ----------
    path : path
    format : str, optional
        As the user stated it (``telemega`` is taken as ``altusmetrum``); checked against the
        content.
    columns : dict, optional
        ``{"time": COL, "altitude": COL[, "event": COL]}`` as the user gave them.
    time_unit, altitude_unit : str, optional
        As the user gave them (None: not given).
    extra : dict, optional
        Further mapping keys the user gave (``first_line``, ``last_line``, ``max_gap``).

    Raises
    ------
    StudyDefinitionError
        An option that does not apply to the format, a unit that is not one, a unit that
        contradicts the header, columns that cannot be chosen from the header.
    """

    p = Path(path)
    extra = dict(extra or {})
    if altitude_unit is not None and altitude_unit.strip().lower() not in LENGTH_UNITS:
        raise _err(
            "--altitude-unit", f"{altitude_unit!r} is not a unit of length",
            "write m, ft or km",
        )  # fmt: skip
    if time_unit is not None and time_unit.strip().lower() not in (*TIME_UNITS, "iso"):
        raise _err(
            "--time-unit", f"{time_unit!r} is not a unit of time for a descent log",
            "write s, ms, us, ns, min, or iso (a column of ISO 8601 dates)",
        )  # fmt: skip
    fmt = {"telemega": "altusmetrum"}.get(format or "", format)
    ext = p.suffix.lower()
    if fmt is None:
        if ext in (".ulg", ".ulog"):
            fmt = "ulog"
        elif ext in (".parquet", ".pq"):
            fmt = "parquet"
        elif altusmetrum_header(p) is not None:
            fmt = "altusmetrum"
        else:
            fmt = "csv"
    elif fmt == "altusmetrum" and altusmetrum_header(p) is None:
        raise _err(
            "--format",
            f"{p.name} is not an AltusMetrum CSV (its header does not begin "
            "version,serial,flight,call,time)",
            "leave --format out: the format is read from the file",
        )
    if fmt in ("altusmetrum", "ulog"):
        given = [
            name
            for name, v in (
                ("--columns", columns),
                ("--time-unit", time_unit),
                ("--altitude-unit", altitude_unit),
                ("--first-line", extra.get("first_line")),
                ("--last-line", extra.get("last_line")),
                ("--max-gap", extra.get("max_gap")),
            )
            if v is not None
        ]
        if given:
            what = "an AltusMetrum CSV" if fmt == "altusmetrum" else "a PX4 ULog"
            raise _err(
                given[0], f"{p.name} is {what}, which states its own columns and units: "
                f"{', '.join(given)} do{'es' if len(given) == 1 else ''} not apply to it",
                f"leave {' and '.join(given)} out",
            )  # fmt: skip
        return LogFormat(fmt, None, [])
    notes: list[str] = []
    if fmt == "csv":
        why = text_encoding_problem(p)
        if why is not None:
            raise _err("file", why)
    lay = _layout(p) if fmt == "csv" else None
    names = _header(p) if fmt == "csv" else []
    if fmt == "csv":
        for key, col in (columns or {}).items():
            if key in ("time", "altitude", "event") and col not in names:
                raise _err("--columns", *_no_such_column(p.name, key, col, names))
    if lay is not None:
        if lay.line > lay.first:
            extra.setdefault("header_line", lay.line)
            notes.append(
                f"the header is line {lay.line}: the text before it (from line {lay.first}) is "
                "not data"
            )
        if lay.decimal == ",":
            extra.setdefault("decimal", ",")
            extra.setdefault("delimiter", lay.delimiter)
            notes.append(
                f"numbers written with a decimal comma (12,5), fields separated by "
                f"{lay.delimiter!r}: read as such"
            )
    cols = dict(columns or {})
    named = named_csv(names) if fmt == "csv" and format is None else None
    if named is not None:
        cols.setdefault("time", named.time)
        cols.setdefault("altitude", named.altitude)
        notes.append(f"format: {named.name}, recognised from its header")
    if fmt == "csv" and ("time" not in cols or "altitude" not in cols):
        for key, pat in (("time", _TIME_NAME), ("altitude", _ALT_NAME)):
            if key in cols:
                continue
            cand = [n for n in names if pat.search(_split_name(n)[0])]
            if key == "time":
                cand = [n for n in cand if _plain_unit(n, "time")]
            if key == "altitude" and len(cand) > 1:
                same = _same_altitude(p, cand)
                if same is not None:
                    notes.append(
                        f"the header has {len(cand)} altitude columns "
                        f"({', '.join(map(repr, cand))}) holding the same altitude in different "
                        f"units (they agree after the unit conversion): {same!r} is used "
                        "(--columns altitude=COL chooses another)"
                    )
                    cand = [same]
            if len(cand) != 1:
                found = f"candidates: {', '.join(map(repr, cand))}" if cand else "none found"
                raise _err(
                    "--columns", f"cannot tell the {key} column of {p.name} from its header "
                    f"({found}; columns: {', '.join(map(repr, names))})",
                    "give --columns time=COL,altitude=COL",
                )  # fmt: skip
            cols[key] = cand[0]
        notes.append(
            f"columns read from the header: time {cols['time']!r}, altitude {cols['altitude']!r} "
            "(--columns chooses others)"
        )
    if "time" not in cols or "altitude" not in cols:
        raise _err("--columns", f"a {fmt} log needs its time and altitude columns",
                   "give --columns time=COL,altitude=COL")  # fmt: skip
    units: dict[str, str] = {}
    missing: list[tuple[str, str, str]] = []
    for key, kind, given_unit, opt in (
        ("time", "time", time_unit, "--time-unit"),
        ("altitude", "length", altitude_unit, "--altitude-unit"),
    ):
        table = TIME_UNITS if kind == "time" else LENGTH_UNITS
        stated = column_unit(cols[key], kind)
        g = None if given_unit is None else given_unit.strip().lower()
        given_u = None if g is None else ("iso" if g == "iso" else table[g])
        documented = None
        if named is not None and cols[key] == getattr(named, key):
            documented = getattr(named, f"{key}_unit")
        if documented is not None:
            if given_u is not None:
                raise _err(
                    opt, f"{p.name} is a {named.name} (recognised from its header), whose "  # type: ignore[union-attr]
                    f"documentation states its units ({cols[key]!r} in {documented}): {opt} "
                    "does not apply to it",
                    f"leave {opt} out",
                )  # fmt: skip
            units[key] = documented
            continue
        if stated is not None and given_u is not None and stated != given_u:
            raise _err(
                opt, f"the column {cols[key]!r} states {stated}, {opt} says {given_u}",
                f"leave {opt} out (the header's unit is read) or fix the column's name",
            )  # fmt: skip
        if stated is not None:
            units[key] = stated
            notes.append(f"{key} unit {stated}, read from the column name {cols[key]!r}")
        elif given_u is not None:
            units[key] = given_u
            notes.append(f"{key} unit {given_u}, as given by {opt}")
        elif key == "time" and fmt == "csv" and _iso_times(p, cols[key]):
            units[key] = "iso"
            notes.append(f"time read as ISO 8601 dates from the column {cols[key]!r}")
        else:
            missing.append((key, cols[key], opt))
    if missing:
        what = " and ".join(f"the {k} column {c!r}" for k, c, _ in missing)
        fix = " and ".join(
            "--time-unit s or ms" if k == "time" else "--altitude-unit m or ft"
            for k, _, _ in missing
        )
        raise _err(
            missing[0][2], f"{what} of {p.name} state{'s' if len(missing) == 1 else ''} no unit, "
            "and units are never guessed",
            f"give {fix} (the flight's documentation says which)",
        )  # fmt: skip
    if named is not None:
        said = [f"{k} {cols[k]!r} in {units[k]}" for k in ("time", "altitude")
                if cols[k] == getattr(named, k)]  # fmt: skip
        notes[notes.index(f"format: {named.name}, recognised from its header")] = (
            f"format: {named.name}, recognised from its header: {', '.join(said)}, as "
            f"{named.source} states"
        )
    if fmt == "csv":
        extra.update(_flight_part(p, cols["time"], units["time"], extra, notes))
    mapping: dict[str, Any] = {
        "time": cols["time"],
        "time_unit": units["time"],
        "altitude": {"column": cols["altitude"], "unit": units["altitude"]},
        **{k: v for k, v in extra.items() if v is not None},
    }
    if "event" in cols:
        mapping["event_column"] = cols["event"]
    documented = named is not None and cols["altitude"] == named.altitude
    return LogFormat(fmt, mapping, notes, named.name if documented else None)


def _no_such_column(file: str, key: str, col: str, names: list[str]) -> tuple[str, str]:
    """(problem, fix) for a column given with --columns that the header does not have."""
    import difflib

    near = difflib.get_close_matches(col, names, n=3, cutoff=0.3)
    lower = {n.lower(): n for n in names}
    if col.lower() in lower and lower[col.lower()] not in near:
        near.insert(0, lower[col.lower()])
    pat = {"time": _TIME_NAME, "altitude": _ALT_NAME}.get(key)
    like = [n for n in names if pat is not None and pat.search(_split_name(n)[0])]
    if near:
        said = f"the nearest: {', '.join(map(repr, near))}; "
    elif like:
        said = f"the {key}-like ones: {', '.join(map(repr, like))}; "
    else:
        said = ""
    return (
        f"{file} has no column {col!r} (given as {key}={col})",
        f"{said}its columns: {', '.join(map(repr, names))}",
    )


def _iso_times(path: Path, col: str) -> bool:
    """Whether the column ``col`` holds ISO 8601 dates (its first five values parse as such)."""
    import numpy as np

    lay = _layout(path)
    names = lay.names if lay is not None else _header(path)
    if col not in names:
        return False
    k = names.index(col)
    vals: list[str] = []
    for _, row in _data_rows(path, lay):
        if k < len(row):
            vals.append(row[k].strip())
        if len(vals) >= 5:
            break
    if not vals:
        return False
    try:
        return all(re.match(r"^\d{4}-\d\d-\d\d[T ]\d", v) for v in vals) and all(
            not np.isnat(np.datetime64(v.rstrip("Z").replace(" ", "T"))) for v in vals
        )
    except ValueError:
        return False


def _plain_unit(name: str, kind: str) -> bool:
    """A column whose unit part, if any, is a unit of ``kind`` (``time(not s)`` is not)."""
    _, text = _split_name(name)
    if text is None:
        return True
    try:
        return column_unit(name, kind) is not None and not re.search(r"\bnot\b", text.lower())
    except StudyDefinitionError:
        return False


#: A time restart is cut only when the longest part where time never goes back holds at least
#: this share of the rows (else the file is not one flight with a repeated buffer: an error).
_KEEP_SHARE = 0.8
#: A pause longer than the loader's default gap (2 s) is accepted, with a note, up to this
#: many median sample steps and at most this many seconds.
_PAUSE_STEPS, _PAUSE_MAX_S = 20.0, 30.0


def _flight_part(
    path: Path, time_col: str, time_unit: str, extra: dict[str, Any], notes: list[str]
) -> dict[str, Any]:
    """``first_line``/``last_line``/``max_gap`` a generic CSV needs, read from its time column.

    - The time goes back (a logger that repeats a pre-launch buffer, or restarts): the longest
      part where the time never goes back is the flight, kept with a note, when it holds at
      least 80 % of the rows; else nothing is cut (the loader stops on the time going back).
    - Logging pauses longer than the default gap (2 s) but at most 20 sample steps (the median
      step of the 20 around each) and 30 s: accepted with a note naming them (no rows are made
      up for them).

    Options the user gave (``first_line``, ``last_line``, ``max_gap``) are kept as given.
    """

    factor = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9, "min": 60.0}.get(time_unit)
    if factor is None:
        return {}
    lines: list[int] = []
    times: list[float] = []
    lay = _layout(path)
    names = lay.names if lay is not None else _header(path)
    if time_col not in names:
        return {}
    idx = names.index(time_col)
    for lineno, row in _data_rows(path, lay):
        try:
            v = float(row[idx]) * factor
        except (IndexError, ValueError):
            continue
        lines.append(lineno)
        times.append(v)
    if len(times) < 3:
        return {}
    import numpy as np

    t = np.asarray(times)
    _check_step(path.name, time_col, time_unit, t)
    out: dict[str, Any] = {}
    lo, hi = 0, t.size - 1
    back = np.flatnonzero(np.diff(t) < 0)
    if back.size and extra.get("first_line") is None and extra.get("last_line") is None:
        starts = np.concatenate([[0], back + 1])
        ends = np.concatenate([back, [t.size - 1]])
        k = int(np.argmax(ends - starts))
        n_keep = int(ends[k] - starts[k] + 1)
        if n_keep >= _KEEP_SHARE * t.size:
            lo, hi = int(starts[k]), int(ends[k])
            if lo > 0:
                out["first_line"] = lines[lo]
            if hi < t.size - 1:
                out["last_line"] = lines[hi]
            notes.append(
                f"the time goes back {back.size} time(s) (a repeated buffer or a restart): "
                f"the flight is read from lines {lines[lo]}-{lines[hi]}, the longest part where "
                f"the time never goes back ({n_keep} of {t.size} rows; "
                f"{t.size - n_keep} left out); --first-line/--last-line choose others"
            )
    if extra.get("max_gap") is None:
        part = t[lo : hi + 1]
        dt = np.diff(part)
        gaps = np.flatnonzero(dt > DEFAULT_MAX_GAP)
        ok = []
        for g in gaps:  # a pause is judged against the sample step around it
            near = dt[max(0, g - 10) : g + 11]
            near = near[(near > 0) & (near <= DEFAULT_MAX_GAP)]
            step = float(np.median(near)) if near.size else np.inf
            ok.append(dt[g] <= min(_PAUSE_STEPS * step, _PAUSE_MAX_S))
        if gaps.size and all(ok):
            worst = float(dt[gaps].max())
            out["max_gap"] = float(np.nextafter(worst, np.inf))
            where = ", ".join(f"{part[g]:.4g}-{part[g + 1]:.4g} s" for g in gaps[:5])
            more = f" and {gaps.size - 5} more" if gaps.size > 5 else ""
            notes.append(
                f"{gaps.size} logging pause(s) longer than {DEFAULT_MAX_GAP:g} s (up to "
                f"{worst:.3g} s, at most {_PAUSE_STEPS:g} sample steps): {where}{more}; "
                "accepted as logging pauses, no rows are made up for them (--max-gap sets "
                "the limit)"
            )
    return out


#: Median sample steps no flight log has, s: slower than one sample a minute, faster than
#: 100 kHz (the loaders refuse these too, in the words of a mapping).
_STEP_RANGE = (1e-5, 50.0)


def _check_step(file: str, col: str, unit: str, t) -> None:
    """Stop on a time column whose median sample step, read in ``unit``, no flight log has,
    naming the column, where its unit came from, and the unit that gives a logger's step."""
    import numpy as np

    d = np.diff(t)
    d = d[d > 0]
    if d.size < 2:
        return
    step = float(np.median(d))
    if _STEP_RANGE[0] <= step <= _STEP_RANGE[1]:
        return
    factors = {"ns": 1e-9, "us": 1e-6, "ms": 1e-3, "s": 1.0, "min": 60.0}
    f0 = factors[unit]
    fits = [u for u, f in factors.items() if 1e-4 <= step * f / f0 <= 2.0]
    stated = column_unit(col, "time") is not None
    how = "from its name" if stated else "as --time-unit says"
    span = float(t[-1] - t[0])
    said = (
        f"the time column {col!r} of {file}, read in {unit} ({how}), has a sample every "
        f"{step:.3g} s and spans {span:.4g} s: no flight log is sampled so "
        f"{'slowly' if step > _STEP_RANGE[1] else 'fast'}"
    )
    if fits:
        u = fits[-1] if step > _STEP_RANGE[1] else fits[0]  # the nearest to the unit read
        fix = f"the times look like {u} (a sample every {step * factors[u] / f0:.3g} s): " + (
            f"correct the unit in the column's name ({col!r} says {unit}), or choose another "
            "time column with --columns"
            if stated
            else f"give --time-unit {u}"
        )
    else:
        fix = "check the time column and its unit (--columns, --time-unit)"
    raise _err("time unit", said, fix)


def _same_altitude(path: Path, cand: list[str]) -> str | None:
    """The column to use when all of ``cand`` state a unit of length and hold the same altitude
    (after the unit conversion, 99 % of the rows within 0.5 % of the altitude's span): the one
    in metres, else the first; None when they differ or a unit is not stated."""
    import numpy as np
    import pandas as pd

    units = []
    for c in cand:
        try:
            u = column_unit(c, "length")
        except StudyDefinitionError:
            return None
        if u is None:
            return None
        units.append(u)
    try:
        lay = _layout(path)
        if lay is None:
            df = pd.read_csv(path, usecols=cand, sep=None, engine="python",
                             encoding="utf-8-sig", comment="#")  # fmt: skip
        else:
            df = pd.read_csv(path, usecols=cand, sep=lay.delimiter, decimal=lay.decimal,
                             skiprows=range(lay.line - 1), encoding="utf-8-sig",
                             comment="#", skipinitialspace=True)  # fmt: skip
        df.columns = [str(c).strip() for c in df.columns]
        to_m = {"m": 1.0, "ft": 0.3048, "km": 1000.0}
        vals = [pd.to_numeric(df[c], errors="coerce").to_numpy(float) * to_m[u]
                for c, u in zip(cand, units)]  # fmt: skip
    except (ValueError, KeyError, OSError):
        return None
    ref = vals[0]
    span = float(np.nanmax(ref) - np.nanmin(ref)) if np.isfinite(ref).any() else 0.0
    if span <= 0:
        return None
    for v in vals[1:]:
        both = np.isfinite(ref) & np.isfinite(v)
        if both.sum() < 10 or np.mean(np.abs(ref[both] - v[both]) <= 0.005 * span) < 0.99:
            return None
    return cand[units.index("m")] if "m" in units else cand[0]
