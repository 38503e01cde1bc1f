"""PX4 ULog files: :func:`load_ulog` (needs the ``ulog`` extra, ``pip install pyulog``)."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from vectorid.identify.flight import FlightChannel, FlightData, FlightDataError
from vectorid.identify.loaders.common import (
    DEFAULT_MAX_GAP,
    Array,
    _Table,
    _valid_samples,
    check_units,
    geodetic_to_ned,
)


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
              f: float = 1.0) -> FlightChannel | None:  # fmt: skip
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
        return FlightChannel(name, tv, vv, comps, unit)

    channels: dict[str, FlightChannel] = {}
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
            ned = geodetic_to_ned(v[:, 0], v[:, 1], v[:, 2], origin)
            pos = FlightChannel("position", gp.t, ned, ("north", "east", "down"), "m")
    if pos is not None:
        channels["position"] = pos
    vel = build("vehicle_local_position", ["vx", "vy", "vz"], "velocity",
                ("north", "east", "down"), "m/s")  # fmt: skip
    if vel is not None:
        channels["velocity"] = vel
    att = build("vehicle_attitude", ["q[0]", "q[1]", "q[2]", "q[3]"], "euler",
                ("w", "x", "y", "z"), "1")  # fmt: skip
    if att is not None:
        channels["euler"] = FlightChannel("euler", att.t, _quat_to_euler(att.values),
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
        channels["altitude"] = FlightChannel(
            "altitude", alt.t, alt.values - off, ("altitude",), "m"
        )
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
