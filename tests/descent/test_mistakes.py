"""The mistakes users make with ``vectorid descent``: each is a one-line error with exit status 2
(no traceback) or a result that says what happened — never a silently wrong answer.

Logs are made here from the shared ones (skipped when ``../shared/data`` is absent) or
synthesised.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from vectorid.cli import main
from vectorid.descent import Canopy, DescentPlan, parse_length
from vectorid.descent.checks import check_trigger
from vectorid.descent.formats import column_unit, detect_format
from vectorid.errors import StudyDefinitionError
from vectorid.identify import FlightDataError, load_csv, load_flight

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data"
TELEMEGA = DATA / "prometheus-2022" / "2022-06-24-serial-6583-flight-0003-TeleMega.csv"
RP = DATA / "rocketpy-descents"


def _need(p: Path) -> Path:
    if not p.exists():
        pytest.skip(f"shared data not found at {p}")
    return p


#: the units of the synthetic logs' columns ("t", "alt"), which their names do not state
UNITS = ["--time-unit", "s", "--altitude-unit", "m"]


def _cli(args, capsys) -> tuple[int, str]:
    code = main(["descent", *map(str, args), "--trials", "16"])
    err = capsys.readouterr().err
    return code, err


def _one_line_error(code: int, err: str) -> str:
    assert code == 2, err
    assert "Traceback" not in err
    lines = [ln for ln in err.splitlines() if ln.startswith("error:")]
    assert len(lines) == 1, err
    return lines[0]


def _descent_csv(path: Path, *, header=("t", "alt"), scale=1.0, spike=None, flat=False) -> Path:
    """A drogue descent of 20.846 kg under 0.4378 m² (NDRT-like), 10 Hz, in metres × scale."""
    t = np.arange(-1.0, 90.0, 0.1)
    up = np.clip(t, 0, 20)
    h = np.where(t < 20, 1300 * (1 - (1 - up / 20) ** 2), 1300 - 27.0 * (t - 20))
    h = np.maximum(h, 0.0)
    h = h + np.random.default_rng(3).normal(0, 0.3, t.size)
    if flat:
        h = np.full_like(t, 12.0)
    if spike is not None:
        h[spike[0]] = spike[1]
    rows = [",".join(header)] + [f"{a:.2f},{b * scale:.3f}" for a, b in zip(t, h)]
    path.write_text("\n".join(rows) + "\n")
    return path


# -- lengths and triggers always carry a unit ----------------------------------------------------


def test_a_length_without_a_unit_is_an_error(tmp_path, capsys):
    log = _descent_csv(tmp_path / "d.csv")
    code, err = _cli([log, "--mass", 20.8, "--drogue-diameter", "24", "--pad-altitude", 200,
                      *UNITS, "--out", tmp_path / "o"], capsys)  # fmt: skip
    line = _one_line_error(code, err)
    assert "24 — inches, or metres?" in line and "24in" in line


def test_parse_length_units():
    assert parse_length("24in", "d") == pytest.approx(0.6096)
    assert parse_length("550 ft", "d") == pytest.approx(167.64)
    assert parse_length("0.61m", "d") == pytest.approx(0.61)
    assert parse_length(0.61, "d", "m") == pytest.approx(0.61)  # Python API: SI
    for bad in ("0.61", "24", "24 parsec", "in"):
        with pytest.raises(StudyDefinitionError):
            parse_length(bad, "d")


def test_a_bare_number_trigger_is_an_error(tmp_path, capsys):
    log = _descent_csv(tmp_path / "d.csv")
    code, err = _cli([log, "--mass", 20.8, "--drogue-cds", 0.44, "--main-cds", 16,
                      "--convention", "replaces", "--main-at", "550", "--pad-altitude", 200,
                      *UNITS, "--out", tmp_path / "o"], capsys)  # fmt: skip
    line = _one_line_error(code, err)
    assert "a height or a time" in line and "550m" in line and "550s" in line


def test_a_trigger_above_the_apogee_was_never_reached():
    assert "never reached" in check_trigger(30_479.7, (40.0, 1300.0), None)
    assert check_trigger(500.0, (40.0, 1300.0), None) == ""
    # the altitude in ft where it was metres: the message says so
    assert "metres (not feet)" in check_trigger(1000.0, (40.0, 400.0), "ft")


# -- units: read from the header, never contradicted, never guessed silently ----------------------


def test_units_read_from_column_names():
    assert column_unit("Altitude (Ft-AGL)", "length") == "ft"
    assert column_unit("alt(m)", "length") == "m"
    assert column_unit("height_ft", "length") == "ft"
    assert column_unit("Height [feet]", "length") == "ft"
    assert column_unit("filtered_altitude_AGL", "length") is None
    assert column_unit("time aprox (s)", "time") == "s"
    assert column_unit("t [ms]", "time") == "ms"


def test_ndrt_feet_header_is_read_as_feet():
    log = _need(RP / "NDRT_2020" / "ndrt_2020_flight_data.csv")
    lf = detect_format(log)
    assert lf.mapping["altitude"] == {"column": "Altitude (Ft-AGL)", "unit": "ft"}
    assert lf.mapping["time"] == "Time (s)"
    with pytest.raises(StudyDefinitionError, match="states ft, --altitude-unit says m"):
        detect_format(log, altitude_unit="m")
    # the Python API's mapping is checked against the header too
    from vectorid.descent.study import _load

    plan = DescentPlan(
        file=log, mass=20.846, drogue=Canopy(cds=0.4378), pad_altitude=206,
        mapping={"time": "Time (s)", "time_unit": "s",
                 "altitude": {"column": "Altitude (Ft-AGL)", "unit": "m"}},
    )  # fmt: skip
    with pytest.raises(StudyDefinitionError, match="states ft"):
        _load(plan)


@pytest.mark.parametrize(
    ("unit", "option"), [("parsec", "--altitude-unit"), ("fortnight", "--time-unit")]
)
def test_invalid_units_are_errors(tmp_path, capsys, unit, option):
    log = _descent_csv(tmp_path / "d.csv")
    code, err = _cli([log, "--mass", 20.8, "--drogue-cds", 0.44, option, unit,
                      "--pad-altitude", 200, "--out", tmp_path / "o"], capsys)  # fmt: skip
    assert unit in _one_line_error(code, err)


def test_feet_read_as_metres_stops_with_the_likely_mistake(tmp_path, capsys):
    # a log in feet whose column name states no unit: not read at all without a unit ...
    log = _descent_csv(tmp_path / "d.csv", scale=1 / 0.3048)
    code, err = _cli([log, "--mass", 20.846, "--drogue-cds", 0.4378, "--pad-altitude", 206,
                      "--time-unit", "s", "--out", tmp_path / "o"], capsys)  # fmt: skip
    line = _one_line_error(code, err)
    assert "'alt'" in line and "no unit" in line and "--altitude-unit m or ft" in line
    # ... and read in metres by the user's mistake, the descent check stops
    code, err = _cli([log, "--mass", 20.846, "--drogue-cds", 0.4378, "--pad-altitude", 206,
                      *UNITS, "--out", tmp_path / "o"], capsys)  # fmt: skip
    line = _one_line_error(code, err)
    assert "feet read as metres" in line and "--altitude-unit ft" in line


def test_metres_read_as_feet_stops_with_the_likely_mistake(tmp_path, capsys):
    log = _descent_csv(tmp_path / "d.csv")
    code, err = _cli([log, "--mass", 20.846, "--drogue-cds", 0.4378, "--altitude-unit", "ft",
                      "--time-unit", "s", "--pad-altitude", 206, "--out", tmp_path / "o"],
                     capsys)  # fmt: skip
    assert "metres read as feet" in _one_line_error(code, err)


def test_a_flat_log_is_a_clear_error(tmp_path, capsys):
    log = _descent_csv(tmp_path / "d.csv", flat=True)
    code, err = _cli([log, "--mass", 20.8, "--drogue-cds", 0.44, "--pad-altitude", 200,
                      *UNITS, "--out", tmp_path / "o"], capsys)  # fmt: skip
    assert "no descent" in _one_line_error(code, err)


def test_a_flat_altitude_beside_a_moving_position_is_not_a_zero_division(tmp_path):
    t = np.arange(0, 60, 0.5)
    rows = ["t,n,e,d,alt"] + [f"{a},{a},{0},{-20 * a},{5.0}" for a in t]
    (tmp_path / "f.csv").write_text("\n".join(rows) + "\n")
    m = {
        "time": "t",
        "time_unit": "s",
        "position": {"north": "n", "east": "e", "down": "d", "unit": "m"},
        "altitude": {"column": "alt", "unit": "m"},
    }
    with pytest.raises(FlightDataError, match="holds no height"):
        load_csv(tmp_path / "f.csv", m)


# -- outliers: found, named with their times, left out (or an error when asked) -------------------


def test_a_huge_height_sample_is_left_out_and_named(tmp_path):
    from vectorid.descent import detect_apogee

    log = _descent_csv(tmp_path / "d.csv", spike=(500, 1e6))
    with pytest.warns(UserWarning, match="single-sample spike at 49.00 s"):
        fd = load_csv(
            log, {"time": "t", "time_unit": "s", "altitude": {"column": "alt", "unit": "m"}}
        )
    assert any("49.00 s" in n for n in fd.notes)
    a = fd["altitude"]
    assert a.values.max() < 1400
    t_ap, h_ap = detect_apogee(a.t, a.values[:, 0])
    assert abs(h_ap - 1300) < 5 and abs(t_ap - 20) < 1.5


def test_strict_data_stops_at_a_spike(tmp_path, capsys):
    log = _descent_csv(tmp_path / "d.csv", spike=(500, 1e6))
    code, err = _cli([log, "--mass", 20.8, "--drogue-cds", 0.44, "--pad-altitude", 200,
                      "--strict-data", *UNITS, "--out", tmp_path / "o"], capsys)  # fmt: skip
    line = _one_line_error(code, err)
    assert "49.00 s" in line and "strict" in line


def test_a_1e300_position_in_an_identification_file_is_left_out(tmp_path):
    t = np.arange(0, 60, 0.25)
    down = -1000 + 5.0 * t
    down[100] = 1e300
    rows = ["t,n,e,d"] + [f"{a},{0.5 * a},{0.2 * a},{float(b)!r}" for a, b in zip(t, down)]
    (tmp_path / "gps.csv").write_text("\n".join(rows) + "\n")
    m = {"time": "t", "time_unit": "s",
         "position": {"north": "n", "east": "e", "down": "d", "unit": "m"}}  # fmt: skip
    with pytest.warns(UserWarning, match="25.00 s"):
        fd = load_csv(tmp_path / "gps.csv", m)
    p = fd["position"].values
    assert np.all(np.abs(p) < 1e4) and p.shape[0] == t.size - 1
    with pytest.raises(FlightDataError, match="25.00 s"):
        load_csv(tmp_path / "gps.csv", {**m, "spikes": "strict"})


# -- formats from the content ---------------------------------------------------------------------


def _altus_variant(src: Path, dst: Path, *, drop=(), rename=None, bom=False) -> Path:
    lines = src.read_text().splitlines()
    head = lines[0].lstrip("#").split(",")
    keep = [i for i, c in enumerate(head) if c not in drop]
    # the GPS altitude is the second 'altitude' column: drop both GPS altitude columns together
    out = []
    for k, ln in enumerate(lines):
        cells = (ln.lstrip("#") if k == 0 else ln).split(",")
        cells = [cells[i] for i in keep]
        if k == 0:
            cells = [(rename or {}).get(c, c) for c in cells]
            out.append("#" + ",".join(cells))
        else:
            out.append(",".join(cells))
    dst.write_text(("\ufeff" if bom else "") + "\n".join(out) + "\n", encoding="utf-8")
    return dst


def _gps_cols(src: Path) -> tuple[str, ...]:
    head = src.read_text().splitlines()[0].lstrip("#").split(",")
    i = head.index("latitude")
    return tuple(head[i - 3 : i + 13])  # connected .. pad_el (GPS group)


@pytest.mark.parametrize("variant", ["telemega-bom", "telemetrum", "easymega", "easymini"])
def test_altusmetrum_variants_are_recognised(tmp_path, variant):
    src = _need(TELEMEGA)
    gyro = ("gyro_roll", "gyro_pitch", "gyro_yaw")
    if variant == "telemega-bom":
        log = _altus_variant(src, tmp_path / "a.csv", bom=True)
    elif variant == "telemetrum":  # no gyro, no magnetometer
        log = _altus_variant(
            src, tmp_path / "a.csv", drop=(*gyro, "mag_x", "mag_y", "mag_z", "accel_x", "accel_y")
        )
    elif variant == "easymega":  # IMU, no GPS; gyro_x/y/z names
        log = _altus_variant(
            src,
            tmp_path / "a.csv",
            drop=_gps_cols(src),
            rename=dict(zip(gyro, ("gyro_x", "gyro_y", "gyro_z"))),
        )
    else:  # easymini: barometer only
        log = _altus_variant(
            src, tmp_path / "a.csv",
            drop=(*_gps_cols(src), *gyro, "accel_x", "accel_y", "accel_z", "mag_x", "mag_y",
                  "mag_z", "tilt", "acceleration"),
        )  # fmt: skip
    assert detect_format(log).format == "altusmetrum"
    fd = load_flight(log)
    assert "altitude" in fd.channels and "drogue" in fd.events
    assert ("position" in fd.channels) == (variant in ("telemega-bom", "telemetrum"))
    assert ("rates" in fd.channels) == (variant in ("telemega-bom", "easymega"))
    assert fd["altitude"].values.max() > 3000


@pytest.mark.parametrize(
    "opts",
    [["--altitude-unit", "ft"], ["--time-unit", "ms"], ["--columns", "time=time,altitude=height"]],
)
def test_options_that_do_not_apply_to_a_telemega_log_are_errors(tmp_path, capsys, opts):
    log = _need(TELEMEGA)
    code, err = _cli([log, "--mass", 16.881, "--drogue-cds", 0.47, *opts, "--out",
                      tmp_path / "o"], capsys)  # fmt: skip
    line = _one_line_error(code, err)
    assert "does not apply" in line and opts[0] in line


def test_columns_from_the_header_or_a_clear_error(tmp_path):
    log = _need(RP / "andromeda" / "flight_data.csv")
    # alt(ft) and alt(m) agree: one altitude, read in metres (two that differ: test_content.py)
    lf = detect_format(log)
    assert lf.mapping["altitude"] == {"column": "alt(m)", "unit": "m"}
    assert any("alt(ft)" in n and "same altitude" in n for n in lf.notes)
    lf = detect_format(log, columns={"time": "t(s)", "time_unit": "s", "altitude": "alt(m)"})
    assert lf.mapping["altitude"]["unit"] == "m" and lf.mapping["time_unit"] == "s"
    assert math.isfinite(len(lf.notes))


def test_format_only_overrules_what_the_content_says(tmp_path, capsys):
    """``--format altusmetrum`` on a file that is not one is an error, not a guess."""
    log = _descent_csv(tmp_path / "d.csv")
    code, err = _cli([log, "--mass", 20.8, "--drogue-cds", 0.44, "--pad-altitude", 200,
                      "--format", "telemega", "--out", tmp_path / "o"], capsys)  # fmt: skip
    line = _one_line_error(code, err)
    assert "is not an AltusMetrum CSV" in line and "leave --format out" in line


def test_the_settling_time_moves_the_window_start(tmp_path, capsys):
    """The drogue phase starts --drogue-settle s after the start (default 5 s)."""
    import json

    log = _need(RP / "EPFL_Bella_Lui" / "bella_lui_flight_data_filtered.csv")
    starts = []
    for settle in ("5", "8"):
        code = main(["descent", str(log), "--mass", "18.227", "--drogue-cds", "0.7854",
                     "--pad-altitude", "407", "--drogue-settle", settle, "--trials", "16",
                     "--json", "--out", str(tmp_path / settle)])  # fmt: skip
        out = capsys.readouterr().out
        assert code == 0
        starts.append(json.loads(out)["phases"][0]["window_s"][0])
    assert starts[1] - starts[0] == pytest.approx(3.0)
