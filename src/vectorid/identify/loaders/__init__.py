"""Loaders of flight logs into :class:`~vectorid.identify.flight.FlightData`.

- :func:`load_csv` and :func:`load_parquet`: any table, described by a *mapping* (from the study
  file) of columns and units to the standard channels (see ``docs/identify.md`` for the keys).
- :func:`load_telemega`: the CSV written by Altus Metrum's TeleMega flight computer.
- :func:`load_ulog`: PX4 ULog (needs the ``ulog`` extra, ``pip install pyulog``).
- :func:`load_flight`: dispatch on ``format`` or the file extension.

One module per format: :mod:`~vectorid.identify.loaders.tables` (CSV and Parquet described by a
mapping), :mod:`~vectorid.identify.loaders.altusmetrum`, :mod:`~vectorid.identify.loaders.ulog`;
what they share (the table read from a file, units and their checks, valid samples) is in
:mod:`~vectorid.identify.loaders.common`. This package re-exports the public names.

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
  dropped — :meth:`~vectorid.identify.flight.FlightChannel.at` interpolates linearly across
  them — as long as no stretch between two valid samples is longer than ``max_gap`` (default
  2 s); a longer stretch is an error naming the channel, the times and the lines.
- Units are converted to SI (see :data:`UNITS`) and checked against magnitude heuristics
  (:func:`check_units`); ``"check_units": false`` in the mapping turns the checks off.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from vectorid.errors import suggest
from vectorid.identify.flight import FlightData, FlightDataError
from vectorid.identify.loaders.altusmetrum import _is_telemega, altusmetrum_header, load_telemega
from vectorid.identify.loaders.common import DEFAULT_MAX_GAP, UNITS, check_units, geodetic_to_ned
from vectorid.identify.loaders.tables import load_csv, load_parquet
from vectorid.identify.loaders.ulog import load_ulog

__all__ = [
    "DEFAULT_MAX_GAP",
    "UNITS",
    "altusmetrum_header",
    "check_units",
    "geodetic_to_ned",
    "load_csv",
    "load_flight",
    "load_parquet",
    "load_telemega",
    "load_ulog",
]

_FORMATS = ("csv", "parquet", "telemega", "altusmetrum", "ulog")


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
            "e.g. {'time': 't', 'time_unit': 's', 'altitude': {'column': 'h', 'unit': 'm'}}"
        )
    return load_csv(p, mapping) if fmt == "csv" else load_parquet(p, mapping)
