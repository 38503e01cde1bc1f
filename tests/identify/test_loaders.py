"""Flight-log loaders: a good file, every kind of bad input, the real TeleMega log, ULog."""

from __future__ import annotations

import math
import struct
from pathlib import Path

import numpy as np
import pytest

from vectorid.identify import (
    FlightDataError,
    load_csv,
    load_flight,
    load_parquet,
    load_telemega,
    load_ulog,
)

DATA = Path(__file__).parents[2] / ".." / "shared" / "data"
TELEMEGA = DATA / "prometheus-2022" / "2022-06-24-serial-6583-flight-0003-TeleMega.csv"

LAT0, LON0, ALT0 = 33.0, -106.9, 1500.0
COLS = ["t", "lat", "lon", "alt", "vn", "ve", "vd", "roll", "pitch", "yaw", "p", "q", "r", "h",
        "left", "right", "state"]  # fmt: skip
MAPPING = {
    "time": "t",
    "time_unit": "s",
    "position": {"lat": "lat", "lon": "lon", "alt": "alt", "angle_unit": "deg", "alt_unit": "m"},
    "velocity": {"north": "vn", "east": "ve", "down": "vd", "unit": "m/s"},
    "euler": {"columns": ["roll", "pitch", "yaw"], "unit": "deg"},
    "rates": {"p": "p", "q": "q", "r": "r", "unit": "deg/s"},
    "altitude": {"column": "h", "unit": "m"},
    "controls": {"columns": ["left", "right"], "unit": "1"},
    "event_column": "state",
    "events": {"canopy_deployed": 1.0},
}


def table(n: int = 201, dt: float = 0.1) -> dict[str, list]:
    """A 20-s descent: 5 m/s down, drifting 2 m/s north, turning at 10 deg/s."""
    import pymap3d

    t = np.arange(n) * dt
    north, east, down = 2.0 * t, 0.5 * t, 5.0 * t
    lat, lon, alt = pymap3d.ned2geodetic(north, east, down, LAT0, LON0, ALT0)
    cols = {
        "t": t, "lat": lat, "lon": lon, "alt": alt,
        "vn": np.full(n, 2.0), "ve": np.full(n, 0.5), "vd": np.full(n, 5.0),
        "roll": 5 * np.sin(t), "pitch": 3 * np.cos(t), "yaw": (10 * t) % 360 - 180,
        "p": 5 * np.cos(t), "q": -3 * np.sin(t), "r": np.full(n, 10.0),
        "h": -down, "left": np.clip(t / 10, 0, 1), "right": np.zeros(n),
    }  # fmt: skip
    out = {k: [f"{x:.9f}" for x in v] for k, v in cols.items()}
    out["state"] = ["drogue" if x < 5 else "main" for x in t]
    return out


def write(path: Path, cols: dict[str, list], names: list[str] | None = None) -> Path:
    names = names or list(cols)
    n = len(cols[names[0]])
    lines = [",".join(names)] + [",".join(str(cols[c][i]) for c in names) for i in range(n)]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_good_csv(tmp_path):
    fd = load_csv(write(tmp_path / "drop.csv", table()), MAPPING)
    assert fd.name == "drop"
    assert set(fd.channels) == {"position", "velocity", "euler", "rates", "altitude", "controls"}
    assert fd.origin == pytest.approx((LAT0, LON0, ALT0))
    p = fd["position"]
    assert p.components == ("north", "east", "down") and p.unit == "m"
    assert p.at([10.0])[0] == pytest.approx([20.0, 5.0, 50.0], abs=1e-3)
    assert fd["euler"].values[:, 0].max() == pytest.approx(math.radians(5), rel=1e-3)
    assert fd["rates"].values[0, 2] == pytest.approx(math.radians(10))
    assert fd["altitude"].at([4.0])[0, 0] == pytest.approx(-20.0)
    assert fd["controls"].components == ("left", "right")
    assert fd.events == {"drogue": 0.0, "main": 5.0, "canopy_deployed": 1.0}
    w = fd.window("main", 15.0)
    assert w.time_range() == (5.0, 15.0)


def test_geodetic_to_ned_by_hand(tmp_path):
    # 0.001 deg of latitude at 33 deg N is 110.9 m (WGS-84 meridian arc); 0.001 deg of
    # longitude is 93.5 m; 10 m higher is 10 m less "down"
    cols = {
        "t": ["0", "1", "2"],
        "lat": ["33.000", "33.001", "33.000"],
        "lon": ["-106.900", "-106.900", "-106.899"],
        "alt": ["1500", "1500", "1510"],
    }
    geo = {"time": "t", "time_unit": "s",
           "position": {"lat": "lat", "lon": "lon", "alt": "alt", "angle_unit": "deg",
                        "alt_unit": "m"}}  # fmt: skip
    fd = load_csv(write(tmp_path / "g.csv", cols), geo)
    v = fd["position"].values
    assert v[1] == pytest.approx([110.9, 0.0, 0.0], abs=0.2)
    assert v[2] == pytest.approx([0.0, 93.5, -10.0], abs=0.2)


def test_misspelled_column_lists_columns_and_suggests(tmp_path):
    path = write(tmp_path / "d.csv", table())
    bad = {**MAPPING, "euler": {"columns": ["rol", "pitch", "yaw"], "unit": "deg"}}
    with pytest.raises(FlightDataError, match=r"column 'rol'.*did you mean 'roll'") as e:
        load_csv(path, bad)
    assert "valid" in str(e.value) and "pitch" in str(e.value)
    with pytest.raises(FlightDataError, match="'time'"):
        load_csv(path, {k: v for k, v in MAPPING.items() if k != "time"})


def test_time_going_backwards_says_where(tmp_path):
    cols = table()
    cols["t"][50], cols["t"][51] = cols["t"][51], cols["t"][50]
    with pytest.raises(FlightDataError, match=r"time goes backwards at line 53"):
        load_csv(write(tmp_path / "d.csv", cols), MAPPING)


def test_duplicated_timestamps(tmp_path):
    cols = table()
    dup = {k: [*v[:31], v[30], *v[31:]] for k, v in cols.items()}  # exact repeat of a row
    fd = load_csv(write(tmp_path / "ok.csv", dup), MAPPING)
    assert fd["euler"].t.size == 201  # dropped
    cols["t"][31] = cols["t"][30]  # same time, different values
    path = write(tmp_path / "bad.csv", cols)
    with pytest.raises(FlightDataError, match=r"duplicated timestamp t=3 s at line 32 and line 33"):
        load_csv(path, MAPPING)
    fd = load_csv(path, {**MAPPING, "duplicates": "keep_first"})
    assert fd["euler"].t.size == 200


def test_nan_gaps(tmp_path):
    cols = table()
    for i in range(40, 70):  # 3 s of NaN in yaw
        cols["yaw"][i] = "NaN"
    path = write(tmp_path / "d.csv", cols)
    with pytest.raises(FlightDataError) as e:
        load_csv(path, MAPPING)
    msg = str(e.value)
    assert "channel 'euler'" in msg and "t=3.9 s to t=7 s" in msg and "line 42" in msg
    assert "max_gap=2" in msg
    fd = load_csv(path, {**MAPPING, "euler": {**MAPPING["euler"], "max_gap": 5.0}})
    assert fd["euler"].t.size == 201 - 30
    # a short gap is dropped and interpolated across; leading NaNs are trimmed
    cols = table()
    for i in (0, 1, 2, 100, 101):
        cols["roll"][i] = ""
    fd = load_csv(write(tmp_path / "s.csv", cols), MAPPING)
    e = fd["euler"]
    assert e.t[0] == pytest.approx(0.3) and e.t.size == 196
    assert e.at([10.0])[0, 0] == pytest.approx(math.radians(5 * math.sin(10.0)), abs=0.02)
    assert fd["position"].t[0] == 0.0  # other channels keep their rows


def test_hole_in_time_column(tmp_path):
    cols = {k: v[:50] + v[100:] for k, v in table().items()}  # 5 s missing
    with pytest.raises(FlightDataError, match="no samples at all"):
        load_csv(write(tmp_path / "d.csv", cols), MAPPING)


def test_degrees_given_as_radians(tmp_path):
    path = write(tmp_path / "d.csv", table())
    with pytest.raises(FlightDataError, match="look like degrees given as radians.*'deg'"):
        load_csv(path, {**MAPPING, "euler": {"columns": ["roll", "pitch", "yaw"], "unit": "rad"}})
    cols = table()
    cols["r"] = ["100"] * 201  # 100 deg/s labelled rad/s: 16 rev/s
    with pytest.raises(FlightDataError, match="deg/s given as rad/s"):
        load_csv(write(tmp_path / "r.csv", cols),
                 {**MAPPING, "rates": {"columns": ["p", "q", "r"], "unit": "rad/s"}})  # fmt: skip
    as_rad = {"columns": ["roll", "pitch", "yaw"], "unit": "rad"}
    fd = load_csv(path, {**MAPPING, "check_units": False, "euler": as_rad})
    assert np.abs(fd["euler"].values).max() > 100


def test_knots_given_as_metres_per_second(tmp_path):
    cols = table()
    kn = 1 / (1852 / 3600)
    for c in ("vn", "ve", "vd"):
        cols[c] = [f"{float(x) * kn:.6f}" for x in cols[c]]
    path = write(tmp_path / "d.csv", cols)
    with pytest.raises(FlightDataError, match=r"1\.94 times.*knots"):
        load_csv(path, MAPPING)
    fd = load_csv(path, {**MAPPING, "velocity": {**MAPPING["velocity"], "unit": "knot"}})
    assert fd["velocity"].values[0] == pytest.approx([2.0, 0.5, 5.0])


def test_feet_and_sign_mistakes(tmp_path):
    cols = table()
    cols["h"] = [f"{float(x) / 0.3048:.6f}" for x in cols["h"]]
    path = write(tmp_path / "ft.csv", cols)
    with pytest.raises(FlightDataError, match=r"altitude is 3\.28 times.*ft"):
        load_csv(path, MAPPING)
    assert load_csv(path, {**MAPPING, "altitude": {"column": "h", "unit": "ft"}})
    path = write(tmp_path / "up.csv", table())
    up = {**MAPPING, "velocity": {"north": "vn", "east": "ve", "up": "vd", "unit": "m/s"}}
    with pytest.raises(FlightDataError, match="'up' given as 'down'"):
        load_csv(path, up)


def _without(mapping: dict, key: str, sub: str | None) -> dict:
    """``mapping`` with ``key`` (or ``mapping[key][sub]``) left out."""
    out = {k: (dict(v) if isinstance(v, dict) else v) for k, v in mapping.items()}
    if sub is None:
        del out[key]
    else:
        del out[key][sub]
    return out


@pytest.mark.parametrize(
    ("key", "sub", "cols", "valid", "fix"),
    [
        ("time_unit", None, "'t'", "s | ms", 'time_unit = "s"'),
        ("position", "angle_unit", "'lat', 'lon'", "rad | deg", 'angle_unit = "deg"'),
        ("position", "alt_unit", "'alt'", "m | ft | km", 'alt_unit = "m"'),
        ("velocity", "unit", "'vn', 've', 'vd'", "m/s | ft/s", 'unit = "m/s"'),
        ("euler", "unit", "'roll', 'pitch', 'yaw'", "rad | deg", 'unit = "rad"'),
        ("rates", "unit", "'p', 'q', 'r'", "rad/s | deg/s", 'unit = "rad/s"'),
        ("altitude", "unit", "'h'", "m | ft | km", 'altitude = { column = "h", unit = "m" }'),
        ("controls", "unit", "'left', 'right'", "'1' if dimensionless", 'unit = "1"'),
    ],
)
def test_a_missing_unit_is_a_one_line_error_naming_key_column_units_and_fix(
    tmp_path, key, sub, cols, valid, fix
):
    # units are never guessed: each physical quantity's unit is said in the mapping
    path = write(tmp_path / "d.csv", table())
    with pytest.raises(FlightDataError) as err:
        load_csv(path, _without(MAPPING, key, sub))
    msg = str(err.value)
    assert "\n" not in msg
    where = "time" if key == "time_unit" else key
    need = "time_unit" if sub is None else sub
    assert f"mapping['{where}'] (column(s) {cols}) has no '{need}'" in msg
    assert valid in msg and fix in msg and "never guessed" in msg


def test_an_other_channel_needs_its_unit_and_a_shorthand_gets_no_default(tmp_path):
    path = write(tmp_path / "d.csv", table())
    with pytest.raises(FlightDataError, match=r"mapping\['channels.brake'\].*has no 'unit'"):
        load_csv(path, {"time": "t", "time_unit": "s", "channels": {"brake": ["left"]}})
    fd = load_csv(
        path, {"time": "t", "time_unit": "s", "channels": {"brake": {"column": "left",
                                                                     "unit": "1"}}}
    )  # fmt: skip
    assert fd["brake"].unit == "1"
    # a bare column name (the short form) states no unit: an error, not metres
    with pytest.raises(FlightDataError, match=r"altitude = \{ column = \"h\", unit = \"m\" \}"):
        load_csv(path, {"time": "t", "time_unit": "s", "altitude": "h"})


def test_stated_units_give_the_numbers_the_old_defaults_gave(tmp_path):
    # the defaults that were dropped (s, m, m/s, deg for lat/lon, 1 for controls) stated
    # explicitly give the SI values of the file, unconverted
    cols = table()
    fd = load_csv(write(tmp_path / "d.csv", cols), MAPPING)
    assert fd["altitude"].values[:, 0] == pytest.approx([float(x) for x in cols["h"]])
    assert fd["velocity"].values[:, 2] == pytest.approx([float(x) for x in cols["vd"]])
    assert fd["altitude"].t == pytest.approx([float(x) for x in cols["t"]])
    assert fd["controls"].values[:, 0] == pytest.approx([float(x) for x in cols["left"]])
    assert fd["controls"].unit == "1"
    # and a stated non-SI unit is converted
    ft = load_csv(
        write(tmp_path / "d.csv", cols),
        {**MAPPING, "check_units": False, "altitude": {"column": "h", "unit": "ft"}},
    )
    assert ft["altitude"].values[:, 0] == pytest.approx(fd["altitude"].values[:, 0] * 0.3048)


def test_time_in_milliseconds(tmp_path):
    cols = table()
    cols["t"] = [f"{float(x) * 1000:.3f}" for x in cols["t"]]
    path = write(tmp_path / "d.csv", cols)
    with pytest.raises(FlightDataError, match="milliseconds.*'ms'"):
        load_csv(path, MAPPING)
    fd = load_csv(path, {**MAPPING, "time_unit": "ms", "events": {}})
    assert fd.time_range() == pytest.approx((0.0, 20.0))


def test_mapping_mistakes(tmp_path):
    path = write(tmp_path / "d.csv", table())
    with pytest.raises(FlightDataError, match="unknown mapping key 'eulr'.*did you mean 'euler'"):
        load_csv(path, {"time": "t", "time_unit": "s", "eulr": ["roll", "pitch", "yaw"]})
    with pytest.raises(FlightDataError, match="has no 'unit'"):
        load_csv(path, {"time": "t", "time_unit": "s", "euler": ["roll", "pitch", "yaw"]})
    with pytest.raises(FlightDataError, match="unknown angle unit 'degs'.*'deg'"):
        load_csv(path, {"time": "t", "time_unit": "s",
                        "euler": {"columns": ["roll", "pitch", "yaw"],
                                  "unit": "degs"}})  # fmt: skip
    with pytest.raises(FlightDataError, match="exactly one of 'down' or 'up'"):
        load_csv(path, {"time": "t", "time_unit": "s", "velocity": {"north": "vn", "east": "ve"}})
    with pytest.raises(FlightDataError, match="names no channel"):
        load_csv(path, {"time": "t"})
    with pytest.raises(FlightDataError, match="event 'late'.*outside the data"):
        load_csv(path, {**MAPPING, "events": {"late": 99.0}})


def test_bad_number_and_ragged_line(tmp_path):
    cols = table()
    cols["h"][7] = "12,5"  # becomes an extra field
    with pytest.raises(FlightDataError, match="line 9 has 18 fields"):
        load_csv(write(tmp_path / "r.csv", cols), MAPPING)
    cols = table()
    cols["h"][7] = "twelve"
    with pytest.raises(FlightDataError, match="'twelve' at line 9"):
        load_csv(write(tmp_path / "n.csv", cols), MAPPING)


def test_nothing_half_loaded_on_missing_file(tmp_path):
    with pytest.raises(FlightDataError, match="no such file"):
        load_csv(tmp_path / "none.csv", MAPPING)


def test_parquet_matches_csv(tmp_path):
    pa = pytest.importorskip("pyarrow")
    pq = pytest.importorskip("pyarrow.parquet")
    cols = table()
    arrays = {k: (v if k == "state" else [float(x) for x in v]) for k, v in cols.items()}
    pq.write_table(pa.table(arrays), tmp_path / "d.parquet")
    a = load_parquet(tmp_path / "d.parquet", MAPPING)
    b = load_csv(write(tmp_path / "d.csv", cols), MAPPING)
    for k in b.channels:
        assert np.allclose(a[k].values, b[k].values) and np.array_equal(a[k].t, b[k].t)
    assert a.events == b.events
    c = load_flight(tmp_path / "d.parquet", MAPPING)
    assert set(c.channels) == set(b.channels)


def test_load_flight_dispatch(tmp_path):
    path = write(tmp_path / "d.csv", table())
    assert "euler" in load_flight(path, MAPPING)
    with pytest.raises(FlightDataError, match="needs a mapping"):
        load_flight(path)
    with pytest.raises(FlightDataError, match="cannot tell the format"):
        load_flight(tmp_path / "d.bin", MAPPING)
    with pytest.raises(FlightDataError, match="did you mean 'ulog'"):
        load_flight(path, MAPPING, format="ulg")


# --------------------------------------------------------------------------- TeleMega


needs_data = pytest.mark.skipif(
    not TELEMEGA.exists(), reason=f"real flight data not found at {TELEMEGA}"
)


@needs_data
def test_real_telemega_flight():
    fd = load_telemega(TELEMEGA)
    ev = fd.events
    for state in ("boost", "coast", "drogue", "main", "landed"):
        assert state in ev
    assert ev["boost"] < ev["coast"] < ev["drogue"] < ev["main"] < ev["landed"]
    # apogee: the barometric height above the pad reaches 3898 m (12 790 ft) at ~28.8 s
    h = fd["altitude"]
    assert h.values.max() == pytest.approx(3898.4, abs=1.0)
    assert ev["apogee"] == pytest.approx(ev["drogue"], abs=1.0)
    # GPS -> NED about the pad: starts at 0, climbs to about the barometric apogee, lands near
    p = fd["position"]
    assert fd.origin is not None and fd.origin[0] == pytest.approx(32.94, abs=0.01)
    assert p.values[0] == pytest.approx([0, 0, 0], abs=1e-6)
    assert -p.values[:, 2].min() == pytest.approx(h.values.max(), rel=0.1)
    landing = p.values[-1]  # last fix, 0.6 s before "landed"
    assert math.hypot(landing[0], landing[1]) < 2000.0
    assert abs(landing[2]) < 30.0
    # main deployed at about 1500 ft above ground (just before the event: the ejection charge
    # spikes the barometer at the event itself)
    assert h.at([ev["main"] - 0.3])[0, 0] == pytest.approx(1500 * 0.3048, abs=30)
    assert fd["rates"].unit == "rad/s" and np.abs(fd["rates"].values).max() < 35
    # the barometer's own samples only (10 Hz in the descent): rows of other packets, which
    # repeat the last pressure and height 0.01-0.09 s later, are not new samples
    steps = np.diff(h.t[(h.t > 35.0) & (h.t < 150.0)])
    assert steps.min() > 0.095 and np.median(steps) == pytest.approx(0.1, abs=1e-6)
    assert np.array_equal(fd["pressure"].t, h.t)
    d = fd.window("drogue", "main")
    assert d.time_range() == (ev["drogue"], ev["main"])
    assert load_flight(TELEMEGA).events == ev


def test_not_a_telemega_file(tmp_path):
    path = write(tmp_path / "x.csv", table())
    with pytest.raises(FlightDataError, match="not a TeleMega or other AltusMetrum CSV"):
        load_telemega(path)


# --------------------------------------------------------------------------- ULog


def _ulog_bytes() -> bytes:
    """A minimal ULog (format version 1): local position and attitude for 5 s at 10 Hz."""

    def msg(kind: str, payload: bytes) -> bytes:
        return struct.pack("<HB", len(payload), ord(kind)) + payload

    out = b"ULog\x01\x12\x35" + bytes([1]) + struct.pack("<Q", 0)
    out += msg("B", bytes(8) + bytes(8) + bytes(24))
    out += msg(
        "F",
        b"vehicle_local_position:uint64_t timestamp;float x;float y;float z;"
        b"float vx;float vy;float vz;double ref_lat;double ref_lon;float ref_alt;",
    )
    out += msg("F", b"vehicle_attitude:uint64_t timestamp;float[4] q;")
    out += msg("A", struct.pack("<BH", 0, 1) + b"vehicle_local_position")
    out += msg("A", struct.pack("<BH", 0, 2) + b"vehicle_attitude")
    for k in range(50):
        ts = 1_000_000 + 100_000 * k
        t = 0.1 * k
        out += msg("D", struct.pack("<HQffffffddf", 1, ts, 2 * t, 0.0, 5 * t, 2.0, 0.0, 5.0,
                                    33.0, -106.9, 1500.0))  # fmt: skip
        yaw = 0.2 * t
        q = (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))
        out += msg("D", struct.pack("<HQ4f", 2, ts + 5000, *q))
    return out


def test_ulog(tmp_path):
    pytest.importorskip("pyulog")
    path = tmp_path / "log.ulg"
    path.write_bytes(_ulog_bytes())
    fd = load_flight(path)
    assert fd.origin == pytest.approx((33.0, -106.9, 1500.0))
    assert fd["position"].t[0] == pytest.approx(1.0)
    assert fd["position"].at([3.0])[0] == pytest.approx([4.0, 0.0, 10.0], abs=1e-5)
    assert fd["velocity"].values[0] == pytest.approx([2.0, 0.0, 5.0])
    e = fd["euler"]
    assert e.at([3.005])[0] == pytest.approx([0.0, 0.0, 0.4], abs=1e-5)
    bad = tmp_path / "bad.ulg"
    bad.write_bytes(b"not a ulog at all")
    with pytest.raises(FlightDataError, match="cannot read as a PX4 ULog"):
        load_ulog(bad)


def test_vertical_sign_checked_when_horizontal_motion_dominates(tmp_path):
    t = np.arange(21.0)
    cols = {
        "t": list(t), "n": list(15 * t), "e": [0.0] * 21, "d": list(4 * t),
        "vn": [15.0] * 21, "ve": [0.0] * 21, "vd": [4.0] * 21,
    }  # fmt: skip
    path = write(tmp_path / "v.csv", cols)
    base = {"time": "t", "time_unit": "s",
            "position": {"north": "n", "east": "e", "down": "d", "unit": "m"}}  # fmt: skip
    ok = load_csv(
        path, {**base, "velocity": {"north": "vn", "east": "ve", "down": "vd", "unit": "m/s"}}
    )
    assert ok["velocity"].values[0] == pytest.approx([15.0, 0.0, 4.0])
    with pytest.raises(FlightDataError, match="'up' given as 'down'"):
        load_csv(
            path, {**base, "velocity": {"north": "vn", "east": "ve", "up": "vd", "unit": "m/s"}}
        )


def test_iso_time_column(tmp_path):
    cols = {
        "when": ["2022-06-24T15:17:16.00", "2022-06-24T15:17:16.50", "2022-06-24T15:17:17.25"],
        "h": ["10", "9", "8"],
    }
    mapping = {"time": "when", "time_unit": "iso", "altitude": {"column": "h", "unit": "m"}}
    fd = load_csv(write(tmp_path / "i.csv", cols), mapping)
    assert fd["altitude"].t == pytest.approx([0.0, 0.5, 1.25])


def _gps_descent(tmp_path: Path, seed: int, *, correlated: bool, factor: float = 1.0) -> Path:
    """A 120-s parachute descent logged by a 4-Hz GPS: 5 m/s down, a drift of 2-4 m/s turning
    with the wind; positions with 1.5 m white noise (plus, if ``correlated``, a Gauss-Markov
    error of 2.5 m with a 60-s correlation time, as receivers have), velocities with 0.15 m/s
    noise, written ``factor`` times the m/s value (1.94: knots)."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 120.0, 0.25)
    speed, heading = 3.0 + np.sin(t / 20.0), 0.3 + t / 60.0
    v = np.stack([speed * np.cos(heading), speed * np.sin(heading), np.full(t.size, 5.0)], 1)
    pos = np.vstack([np.zeros(3), np.cumsum(0.5 * (v[1:] + v[:-1]) * 0.25, axis=0)])
    err = rng.normal(0.0, 1.5, pos.shape)
    if correlated:
        a = np.exp(-0.25 / 60.0)
        gm = np.empty_like(pos)
        gm[0] = rng.normal(0.0, 2.5, 3)
        for i in range(1, t.size):
            gm[i] = a * gm[i - 1] + rng.normal(0.0, 2.5 * math.sqrt(1 - a * a), 3)
        err += gm
    meas_v = (v + rng.normal(0.0, 0.15, v.shape)) * factor
    cols = {"t": t, "n": pos[:, 0] + err[:, 0], "e": pos[:, 1] + err[:, 1],
            "d": pos[:, 2] + err[:, 2], "vn": meas_v[:, 0], "ve": meas_v[:, 1],
            "vd": meas_v[:, 2]}  # fmt: skip
    return write(tmp_path / f"gps{seed}.csv", {k: [f"{x:.6f}" for x in c] for k, c in cols.items()})


GPS_MAPPING = {
    "time": "t",
    "time_unit": "s",
    "position": {"north": "n", "east": "e", "down": "d", "unit": "m"},
    "velocity": {"north": "vn", "east": "ve", "down": "vd", "unit": "m/s"},
}


@pytest.mark.parametrize("correlated", [False, True], ids=["white", "white+gauss-markov"])
def test_unit_check_accepts_noisy_4hz_gps_with_a_right_mapping(tmp_path, correlated):
    # 1.5 m of white noise on 4-Hz positions makes the per-sample derivative noisier (±4 m/s)
    # than the motion; over windows of a few seconds the check sees the motion.
    for seed in range(8):
        fd = load_csv(_gps_descent(tmp_path, seed, correlated=correlated), GPS_MAPPING)
        assert fd["velocity"].values[:, 2].mean() == pytest.approx(5.0, abs=0.05)
        kn = {**GPS_MAPPING, "velocity": {**GPS_MAPPING["velocity"], "unit": "knot"}}
        knots = _gps_descent(tmp_path, seed, correlated=correlated, factor=1 / (1852 / 3600))
        assert load_csv(knots, kn)["velocity"].values[:, 2].mean() == pytest.approx(5.0, abs=0.05)


@pytest.mark.parametrize("correlated", [False, True], ids=["white", "white+gauss-markov"])
def test_unit_check_catches_knots_and_metres_per_second_mixed_up_in_noisy_gps(tmp_path, correlated):
    kn = 1 / (1852 / 3600)
    for seed in range(4):
        knots = _gps_descent(tmp_path, seed, correlated=correlated, factor=kn)
        with pytest.raises(FlightDataError, match=r"velocity is 1\.9\d+ times .*unit 'm/s' of "
                           r"the mapping: the column looks like knots; set the velocity unit to "
                           r"'knot'"):  # fmt: skip
            load_csv(knots, GPS_MAPPING)
        si = _gps_descent(tmp_path, seed, correlated=correlated)
        as_knots = {**GPS_MAPPING, "velocity": {**GPS_MAPPING["velocity"], "unit": "knot"}}
        with pytest.raises(FlightDataError, match=r"velocity is 0\.5\d+ times .*unit 'knot' of "
                           r"the mapping: the column looks like m/s; set the velocity unit to "
                           r"'m/s'"):  # fmt: skip
            load_csv(si, as_knots)
        kmh = {**GPS_MAPPING, "velocity": {**GPS_MAPPING["velocity"], "unit": "km/h"}}
        with pytest.raises(
            FlightDataError, match=r"looks like m/s; set the velocity unit to 'm/s'"
        ):
            load_csv(si, kmh)
