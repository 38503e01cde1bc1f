"""Tables described by a mapping: :func:`load_csv` and :func:`load_parquet` (see
:mod:`vectorid.identify.loaders` and ``docs/identify.md`` for the mapping's keys)."""

from __future__ import annotations

import csv
import math
import os
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vectorid.errors import suggest
from vectorid.identify.flight import STANDARD_CHANNELS, FlightChannel, FlightData, FlightDataError
from vectorid.identify.loaders.common import (
    _KIND,
    _TOP_KEYS,
    DEFAULT_MAX_GAP,
    UNITS,
    Array,
    _check_time_scale,
    _dedupe_names,
    _factor,
    _Table,
    _valid_samples,
    check_units,
    geodetic_to_ned,
    text_encoding_problem,
)
from vectorid.identify.outliers import drop_spikes


def _read_csv(
    path: Path,
    delimiter: str | None = None,
    comment: str | None = None,
    skip: int = 0,
    decimal: str = ".",
    header_line: int | None = None,
    keep: set[str] | None = None,
) -> _Table:
    """The table of a CSV file; ``keep``: the only columns whose values are kept (the others
    are checked for their count of fields only: a wide log is read without holding every
    field of every row)."""
    source = str(path)
    try:
        text = path.read_text(encoding="utf-8-sig", errors="strict")
    except FileNotFoundError:
        raise FlightDataError(f"no such file: {source}") from None
    except UnicodeDecodeError as exc:
        why = text_encoding_problem(path) or f"not a UTF-8 text file ({exc}); is it a CSV?"
        raise FlightDataError(f"{source}: {why}") from None
    if "\x00" in text[:4096]:  # UTF-16 ASCII text decodes as UTF-8 with NULs between
        raise FlightDataError(f"{source}: {text_encoding_problem(path) or 'binary data'}")
    lines = text.splitlines()
    # header: first non-empty line (after `skip` lines); a leading '#' on it is stripped
    # (AltusMetrum style)
    if header_line is not None:
        if isinstance(header_line, bool) or not isinstance(header_line, int) or header_line < 1:
            raise FlightDataError(
                f"mapping['header_line'] must be a line number of the file (an integer >= 1), "
                f"got {header_line!r}"
            )
        skip = header_line - 1
    if decimal not in (".", ","):
        raise FlightDataError(f"mapping['decimal'] must be '.' or ',', got {decimal!r}")
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
    if decimal == "," and delimiter == ",":
        raise FlightDataError(
            f"{source}: decimal commas need another delimiter than ',' (the header's is ',')"
        )
    rows: list[list[str]] = []
    linenos: list[int] = []
    empty: list[int] = []  # rows without any value: left out, said in a note
    cols = None if keep is None else [i for i, n in enumerate(names) if n in keep]
    for j in range(k + 1, len(lines)):
        line = lines[j]
        if not line.strip() or (comment and line.lstrip().startswith(comment)):
            continue
        row = next(csv.reader([line], delimiter=delimiter, skipinitialspace=True))
        if delimiter == " ":
            row = [c for c in row if c != ""]
        if decimal == ",":
            row = [c.replace(",", ".") for c in row]
        if _DIGIT.search(line) is None and all(c.strip().lower() in _NO_VALUE for c in row):
            empty.append(j + 1)
            continue
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
        rows.append(row if cols is None else [row[i] for i in cols])
        linenos.append(j + 1)
    if not rows:
        raise FlightDataError(f"{source}: no data rows after the header")
    arr = np.array(rows, dtype=object)
    kept = range(len(names)) if cols is None else cols
    where = {c: n for n, c in enumerate(kept)}

    def get(i: int) -> NDArray[Any]:
        if i not in where:
            raise FlightDataError(f"{source}: column {names[i]!r} was not read (internal)")
        return arr[:, where[i]]

    table = _Table(source, names, get, len(rows), lambda i: f"line {linenos[i]}")
    table.lines = np.asarray(linenos)  # file line number of each row (first_line/last_line)
    table.empty_lines = empty
    return table


#: Field contents that hold no value (a row of only these is left out, with a note).
_NO_VALUE = {"", "nan", "na", "null", "none", "-"}
_DIGIT = re.compile(r"\d")


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
    out.empty_lines = [n for n in getattr(base, "empty_lines", []) if lo <= n <= hi]
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


def _required_unit(
    where: str, spec: Mapping[str, Any], key: str, kind: str, columns: list[str], example: str
) -> str:
    """The unit ``spec[key]`` of mapping entry ``where``; a missing one is an error (units are
    never guessed: a column of heights in feet read as metres is silently wrong)."""
    if key in spec and spec[key] is not None and str(spec[key]).strip() != "":
        return str(spec[key])
    valid = " | ".join(UNITS[kind]) if kind in UNITS else "any unit name, '1' if dimensionless"
    cols = ", ".join(repr(c) for c in columns)
    raise FlightDataError(
        f"mapping[{where!r}] (column(s) {cols}) has no {key!r}: units are never guessed; "
        f"say the unit the column(s) hold ({valid}), e.g. {example}"
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
        geo_cols = [str(spec[k]) for k in ("lat", "lon", "alt")]
        geo_ex = (f'position = {{ lat = "{geo_cols[0]}", lon = "{geo_cols[1]}", alt = '
                  f'"{geo_cols[2]}", angle_unit = "deg", alt_unit = "m" }}')  # fmt: skip
        af = _factor(
            "angle", _required_unit(name, spec, "angle_unit", "angle", geo_cols[:2], geo_ex),
            "position.angle_unit",
        )  # fmt: skip
        hf = _factor(
            "length", _required_unit(name, spec, "alt_unit", "length", geo_cols[2:], geo_ex),
            "position.alt_unit",
        )  # fmt: skip
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
    if "columns" in spec:
        ex = f'{name} = {{ columns = {[str(c) for c in cols]}, unit = "{default_unit}" }}'
    else:
        vert = "down" if "down" in spec else "up"
        ex = (f'{name} = {{ north = "{cols[0]}", east = "{cols[1]}", {vert} = "{cols[2]}", '
              f'unit = "{default_unit}" }}')  # fmt: skip
    ex = ex.replace("'", '"')
    f = _factor(kind, _required_unit(name, spec, "unit", kind, [str(c) for c in cols], ex),
                f"{name}.unit")  # fmt: skip
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
    si = "rad" if kind == "angle" else "rad/s"
    ex = f'{name} = {{ columns = {[str(c) for c in cols]}, unit = "{si}" }}'.replace("'", '"')
    f = _factor(kind, _required_unit(name, spec, "unit", kind, [str(c) for c in cols], ex),
                f"{name}.unit")  # fmt: skip
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
        acol = str(spec["columns"][0])
        f = _factor(
            "length",
            _required_unit("altitude", spec, "unit", "length", [acol],
                           f'altitude = {{ column = "{acol}", unit = "m" }}'),
            "altitude.unit",
        )  # fmt: skip
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
        cunit = _required_unit(
            "controls", spec, "unit", "", cols,
            f'controls = {{ columns = {cols}, unit = "1" }} for fractions of full travel, or '
            '"deg"/"rad" for deflections'.replace("'", '"'),
        )  # fmt: skip
        out.append(_Spec("controls", cols, comps, cunit, lambda v: v,
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
        xunit = _required_unit(
            f"channels.{name}", spec, "unit", "", cols,
            f'[...mapping.channels] {name} = {{ columns = {cols}, unit = "Pa" }} (the unit the '
            'column holds, "1" if dimensionless; not converted)'.replace("'", '"'),
        )  # fmt: skip
        out.append(_Spec(str(name), cols, comps, xunit, lambda v: v,
                         float(spec.get("max_gap", max_gap))))  # fmt: skip
    for s in out:
        if not (math.isfinite(s.max_gap) and s.max_gap > 0):
            raise FlightDataError(f"max_gap of {s.name!r} must be > 0 s, got {s.max_gap}")
    return out


def _time_axis(table: _Table, mapping: Mapping[str, Any]) -> Array:
    if "time" not in mapping:
        raise FlightDataError(
            f"the mapping needs 'time': the name of the time column; columns in "
            f"{table.source}: {', '.join(table.names)}"
        )
    col = str(mapping["time"])
    raw = table.raw(col, "time")
    if raw.dtype.kind == "M":
        unit = "iso"  # a timestamp column (Parquet): the format fixes the unit
    else:
        unit = _required_unit(
            "time",
            {"time_unit": mapping.get("time_unit")},
            "time_unit",
            "time",
            [col],
            f'time = "{col}" with time_unit = "s" (or ms, us, ns, min; "iso" for ISO 8601 text)',
        )
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
    channels: dict[str, FlightChannel] = {}
    geo: tuple[Array, Array] | None = None
    for s in specs:
        v = np.stack([table.numeric(c, f"channel {s.name!r}")[rows] for c in s.columns], axis=1)
        v = s.convert(v)
        tv, vv = _valid_samples(s.name, t, v, s.max_gap, table, rows)
        if s.name == "position" and s.geodetic:
            geo = (tv, vv)
            continue
        channels[s.name] = FlightChannel(s.name, tv, vv, s.components, s.unit_out)
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
        channels["position"] = FlightChannel(
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
        channels["altitude"] = FlightChannel(
            a.name, a.t, a.values - origin[2], a.components, a.unit
        )
    events = _events(table, mapping, t_all)
    lo = min(float(c.t[0]) for c in channels.values())
    hi = max(float(c.t[-1]) for c in channels.values())
    for k, v in events.items():
        if not lo <= v <= hi:
            raise FlightDataError(
                f"{table.source}: event {k!r} at t={v:.6g} s is outside the data [{lo:.6g}, "
                f"{hi:.6g}] s; events are times on the loaded time axis (after time_unit)"
            )
    notes = []
    empty = getattr(table, "empty_lines", [])
    if empty:
        where = ", ".join(map(str, empty[:8])) + (f" and {len(empty) - 8} more" if len(empty) > 8
                                                   else "")  # fmt: skip
        notes.append(f"{len(empty)} row(s) without any value (line(s) {where}): left out")
    fd = FlightData(
        str(mapping.get("name") or name or Path(table.source).stem),
        channels,
        events,
        origin,
        notes,
    )
    fd = drop_spikes(fd, table.source, str(mapping.get("spikes", "drop")))
    if mapping.get("check_units", True):
        units = {
            key: str(_as_dict(key, mapping[key])["unit"])
            for key in ("velocity", "altitude")
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
        CSV file with one header line (a leading ``#`` on it is ignored; the first non-empty
        line, or line ``mapping["header_line"]``); the delimiter is detected (``,``, ``;``,
        tab, space) unless ``mapping["delimiter"]`` says; ``mapping["decimal"] = ","`` reads
        decimal commas (``12,5``). Rows without any value are left out, with a note.
    mapping : mapping
        Which column holds what, in which unit; see ``docs/identify.md``. Example::

            {"time": "t", "time_unit": "s",
             "position": {"lat": "lat_deg", "lon": "lon_deg", "alt": "alt_m",
                          "angle_unit": "deg", "alt_unit": "m"},
             "velocity": {"north": "vn", "east": "ve", "down": "vd", "unit": "m/s"},
             "euler": {"columns": ["roll", "pitch", "yaw"], "unit": "deg"},
             "controls": {"columns": ["left", "right"], "unit": "1"},
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
    table = _read_csv(
        p, mapping.get("delimiter"), mapping.get("comment"),
        decimal=str(mapping.get("decimal", ".")), header_line=mapping.get("header_line"),
        keep=_used_columns(mapping),
    )  # fmt: skip
    return _build(_cut_lines(table, mapping), mapping, p.stem)


def _used_columns(mapping: Mapping[str, Any]) -> set[str] | None:
    """The columns a mapping reads (None where it cannot be told: then every column is kept,
    and :func:`_build` reports what is wrong with the mapping)."""
    if not isinstance(mapping, Mapping):
        return None
    try:
        specs = _specs(mapping, float(mapping.get("max_gap", DEFAULT_MAX_GAP)))
    except (FlightDataError, TypeError, ValueError):
        return None
    used = {str(c) for sp in specs for c in sp.columns}
    for key in ("time", "event_column"):
        if mapping.get(key) is not None:
            used.add(str(mapping[key]))
    return used


def load_parquet(path: str | os.PathLike[str], mapping: Mapping[str, Any]) -> FlightData:
    """Load a flight from a Parquet file (needs the ``parquet`` extra, pyarrow).

    The mapping is the one of :func:`load_csv` (``delimiter`` and ``comment`` are ignored); a
    timestamp-typed time column is converted to seconds from its first row.
    """
    p = Path(path)
    return _build(_cut_lines(_read_parquet(p), mapping), mapping, p.stem)
