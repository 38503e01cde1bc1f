"""AltusMetrum CSV logs (TeleMega, TeleMetrum, EasyMega, EasyMini, ...): recognised from
their header (:func:`altusmetrum_header`) and loaded by :func:`load_telemega`."""

from __future__ import annotations

import math
import os
import warnings
from pathlib import Path

import numpy as np

from vectorid.errors import suggest
from vectorid.identify.flight import FlightChannel, FlightData, FlightDataError
from vectorid.identify.loaders.common import Array, _valid_samples, check_units, geodetic_to_ned
from vectorid.identify.loaders.tables import _read_csv
from vectorid.identify.outliers import drop_spikes

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
             gap: float = max_gap) -> FlightChannel:  # fmt: skip
        v = np.stack([num(c) for c in cols], axis=1) * f
        tv, vv = _valid_samples(name, t, v, gap, table, rows)
        return FlightChannel(name, tv, vv, comps, unit)

    channels: dict[str, FlightChannel] = {}
    # The logger writes a row for every packet; rows of other packets carry the last
    # barometer sample over (same pressure and height, a later time). They are not new
    # measurements: a copy 0.07 s after its sample, interpolated as if measured then, is off
    # by the distance flown meanwhile (up to 8 m in the drogue phase of the shared log).
    baro = ["height"] + (["pressure"] if "pressure" in table.names else [])
    bv = np.stack([num(c) for c in baro], axis=1)
    fresh = np.ones(t.size, dtype=bool)
    fresh[1:] = np.any(bv[1:] != bv[:-1], axis=1)

    def baro_chan(name: str, col: str, comps: tuple[str, ...], unit: str) -> FlightChannel:
        v = num(col)[fresh][:, None]
        tv, vv = _valid_samples(name, t[fresh], v, max_gap, table, rows[fresh])
        return FlightChannel(name, tv, vv, comps, unit)

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
                fd.channels[c.name] = FlightChannel(
                    c.name, c.t[k], c.values[k], c.components, c.unit
                )
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
    channels["position"] = FlightChannel(
        "position", t[fix], geodetic_to_ned(lat[fix], lon[fix], alt[fix], origin),
        ("north", "east", "down"), "m",
    )  # fmt: skip
    channels["gps_altitude"] = FlightChannel("gps_altitude", t[fix], alt[fix], ("altitude",), "m")
    return origin


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
