"""Which column of a log is its altitude, when the one read as such cannot be: the log's other
columns, read as altitudes, tested against the physics of the stated rocket's descent.

A log whose header names are swapped (the altitude's name on the vertical speed, the speed's on
the altitude) gives a "descent" the stated canopies cannot give; before the run stops, this
module looks at the file's other numeric columns: one that comes down from an apogee at a rate
whose drag area is within a factor 3 of a stated canopy's, and no faster than a free fall, is
named, with the option that reads it; where the column read as the altitude is that column's
rate of change (correlation of at least 0.9), it is called a vertical speed.

Only generic CSV and Parquet logs have columns to choose from; a format that names its own
(AltusMetrum, ULog) gets no suggestion.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vectorid.descent.checks import _TIME_FACTORS, FT, ReadAs
from vectorid.descent.events import _running_median
from vectorid.descent.formats import _data_rows, _header, _layout, column_unit
from vectorid.descent.phases import _cds_estimate
from vectorid.descent.plan import G0

__all__ = ["Candidate", "altitude_candidates", "suggest_altitude"]

#: A column "descends as the stated rocket would" when its drag area is within this factor of
#: a stated one.
WITHIN = 3.0
_LENGTHS = {"m": 1.0, "ft": FT, "km": 1000.0}
#: At most this many rows are read for the diagnosis (every k-th row beyond it).
_MAX_ROWS = 200_000


@dataclass(frozen=True)
class Candidate:
    """A column that comes down like the stated rocket's altitude.

    Attributes
    ----------
    column, unit : str
        The column and the length unit it was read in.
    apogee_s, apogee_m : float
        Its top (s, m).
    rate : float
        Its mean descent rate after the top, m/s.
    cds : float
        The drag area that rate implies, m².
    speed_corr : float or None
        Correlation of its rate of change with the column read as the altitude (near ±1: that
        column is its vertical speed); None if not computed.
    """

    column: str
    unit: str
    apogee_s: float
    apogee_m: float
    rate: float
    cds: float
    speed_corr: float | None = None


def _columns(path: Path, mapping: Mapping[str, Any]) -> tuple[list[str], np.ndarray] | None:
    """The names and numbers (rows × columns, NaN where not a number) of a generic CSV's rows
    (within ``first_line``/``last_line``), or of a Parquet file; None if unreadable."""
    if path.suffix.lower() in (".parquet", ".pq"):
        try:
            import pyarrow.parquet as pq

            tab = pq.read_table(path)
        except Exception:
            return None
        names = list(tab.column_names)
        cols = []
        for c in names:
            try:
                cols.append(np.asarray(tab.column(c).to_numpy(zero_copy_only=False), dtype=float))
            except (TypeError, ValueError):
                cols.append(np.full(tab.num_rows, np.nan))
        return names, np.stack(cols, axis=1)[:: max(1, tab.num_rows // _MAX_ROWS)]

    try:
        lay = _layout(path)
        names = lay.names if lay is not None else _header(path)
        first = int(mapping.get("first_line") or 0)
        last = int(mapping.get("last_line") or 0) or None
        # every k-th row of a big file: k from its size over the first rows' length
        with path.open("rb") as fh:
            head = fh.read(65536)
        per_row = max(len(head) / max(head.count(b"\n"), 1), 1.0)
        k = max(1, int(path.stat().st_size / per_row / _MAX_ROWS))
        rows: list[list[float]] = []
        for n, (lineno, row) in enumerate(_data_rows(path, lay)):
            if n % k or lineno < first or (last is not None and lineno > last):
                continue
            vals = []
            for c in row[: len(names)]:
                try:
                    vals.append(float(c))
                except ValueError:
                    vals.append(math.nan)
            vals += [math.nan] * (len(names) - len(vals))
            rows.append(vals)
    except (OSError, UnicodeError):
        return None
    if not rows:
        return None
    arr = np.asarray(rows, dtype=float)
    return names, arr[:: max(1, arr.shape[0] // _MAX_ROWS)]  # (where the estimate was short)


def _descends_like(t, y, mass: float, origin: float) -> tuple[float, float, float, float] | None:
    """(apogee time, apogee, mean rate, drag area) of a series read as an altitude in m, when
    it comes down at least 50 m from its top over at least 5 s and no faster than a free fall;
    else None."""

    if t.size < 20:
        return None
    s = _running_median(y, 5)
    i = int(np.argmax(s))
    if i >= s.size - 5:
        return None
    k = i + 1 + int(np.argmin(s[i + 1 :]))
    drop = float(s[i] - s[k])
    if drop < 50.0 or t[k] - t[i] < math.sqrt(2 * drop / G0):
        return None
    # the steady part: from 5 s after the top to where 90 % of the drop is done
    lvl = s[i] - 0.9 * drop
    j = i + int(np.argmax(s[i:] <= lvl))
    sel = (t >= t[i] + 5.0) & (t <= t[j])
    if sel.sum() < 5 or t[j] - t[i] - 5.0 < 5.0:
        return None
    rate = -float(np.polyfit(t[sel], s[sel], 1)[0])
    if rate <= 0.5:
        return None
    mid = float(np.mean(s[sel]))
    return float(t[i]), float(s[i]), rate, _cds_estimate(rate, mid, mass, origin)


def altitude_candidates(
    path: str | Path,
    mapping: Mapping[str, Any],
    read: ReadAs,
    *,
    mass: float,
    origin: float,
    totals: list[float],
    table: tuple[list[str], np.ndarray] | None = None,
) -> list[Candidate]:
    """The log's other columns that come down like the stated rocket's altitude, closest
    first (see the module docstring). ``table``: the file's columns as read already."""

    if read.time is None or read.time_unit not in _TIME_FACTORS or not totals:
        return []
    got = _columns(Path(path), mapping) if table is None else table
    if got is None:
        return []
    names, arr = got
    if read.time not in names:
        return []
    t_all = arr[:, names.index(read.time)] * _TIME_FACTORS[str(read.time_unit)]
    out: list[Candidate] = []
    skip = {read.time, read.altitude, mapping.get("event_column")}
    for j, name in enumerate(names):
        if name in skip:
            continue
        y = arr[:, j]
        ok = np.isfinite(y) & np.isfinite(t_all)
        if ok.sum() < max(20, 0.5 * y.size):
            continue
        t, y = t_all[ok], y[ok]
        keep = np.concatenate([[True], np.diff(t) > 0])
        t, y = t[keep], y[keep]
        try:
            stated = column_unit(name, "length")
        except ValueError:
            stated = None
        for unit in [stated] if stated else ["m", "ft"]:
            got_d = _descends_like(t, y * _LENGTHS[unit], mass, origin)
            if got_d is None:
                continue
            ta, ha, rate, cds = got_d
            if any(1 / WITHIN <= cds / c <= WITHIN for c in totals):
                out.append(Candidate(name, unit, ta, ha, rate, cds))
    out.sort(key=lambda c: min(abs(math.log(c.cds / v)) for v in totals))
    return out


def _rate_of(c: Candidate, t_alt, h_alt, t, y) -> float | None:
    """Correlation of the rate of change of ``y`` (the candidate) with the series read as the
    altitude, on a common 0.1-s grid over the overlap."""
    lo, hi = max(t[0], t_alt[0]), min(t[-1], t_alt[-1])
    if hi - lo < 5.0:
        return None
    g = np.arange(lo, hi, 0.1)
    dy = np.gradient(np.interp(g, t, y), g)
    ha = np.interp(g, t_alt, h_alt)
    if np.std(dy) == 0 or np.std(ha) == 0:
        return None
    return float(np.corrcoef(dy, ha)[0, 1])


def suggest_altitude(
    path: str | Path,
    mapping: Mapping[str, Any] | None,
    read: ReadAs,
    t_alt: np.ndarray,
    h_alt: np.ndarray,
    *,
    mass: float,
    origin: float,
    totals: list[float],
    api: bool = False,
) -> str:
    """The likely mistake when the altitude read cannot be the stated rocket's: another column
    that comes down as it would, and the option that reads it ('' if none)."""
    if mapping is None:
        return ""
    if read.time is None or read.time_unit not in _TIME_FACTORS or not totals:
        return ""
    try:
        got = _columns(Path(path), mapping)
        cands = altitude_candidates(
            path, mapping, read, mass=mass, origin=origin, totals=totals, table=got
        )
    except (ValueError, OSError):  # a diagnosis never hides the error it explains
        return ""
    if not cands:
        return ""
    c = cands[0]
    text = (
        f"the column {c.column!r} does come down as the stated rocket would (read in "
        f"{c.unit}: from {c.apogee_m:.0f} m at {c.apogee_s:.1f} s at {c.rate:.1f} m/s, a drag "
        f"area of {c.cds:.3g} m²)"
    )
    if got is not None and read.time in got[0]:
        names, arr = got
        t = arr[:, names.index(read.time)] * _TIME_FACTORS[str(read.time_unit)]
        y = arr[:, names.index(c.column)] * _LENGTHS[c.unit]
        ok = np.isfinite(t) & np.isfinite(y)
        t, y = t[ok], y[ok]
        keep = np.concatenate([[True], np.diff(t) > 0])
        r = _rate_of(c, t_alt, h_alt, t[keep], y[keep])
        if r is not None and abs(r) >= 0.9:
            text += (
                f", and {read.altitude!r} is its rate of change (correlation {r:+.2f}): a "
                "vertical speed; the two names look swapped"
            )

    try:
        states = column_unit(c.column, "length") is not None
    except ValueError:
        states = False
    if api:
        how = f"map the altitude to {c.column!r} (unit {c.unit!r})"
    else:
        how = f"give --columns time={read.time!r},altitude={c.column!r}" + (
            "" if states else f" --altitude-unit {c.unit}"
        )
    return f"{text}: {how}"
