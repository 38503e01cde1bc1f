"""Logs that cannot be talked past (issue 35): a column whose values cannot be what its header
says, a time or an altitude in the wrong unit, a selection that leaves nothing, a drag area the
stated rocket cannot give. Each stops with one line and exit status 2, naming the column or the
inputs to check and the fix — and the fix, where it names one, gives the clean log's answer.

Logs are made at test time from the shared ones (skipped when ``../shared/data`` is absent);
the checks' own thresholds are tested on synthetic series.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from vectorid.cli import main
from vectorid.descent import Canopy, DescentPlan
from vectorid.descent.checks import (
    TOO_LARGE,
    TOO_SMALL,
    ReadAs,
    check_drag_magnitude,
    check_time_scale,
)
from vectorid.errors import StudyDefinitionError

ROOT = Path(__file__).resolve().parents[2]
RP = ROOT.parent / "shared" / "data" / "rocketpy-descents"
BELLA = RP / "EPFL_Bella_Lui" / "bella_lui_flight_data_filtered.csv"
GENESIS = RP / "genesis" / "flight_data_faraday.csv"
VALKYRIE = RP / "valkyrie" / "flightInfo_merged.csv"
BELLA_STATED = ["--mass", "18.227", "--drogue-cds", "0.7854", "--pad-altitude", "407"]
GENESIS_STATED = ["--pad-altitude", "160", "--mass", "9.214", "--drogue-cds", "0.285",
                  "--main-cds", "1.1", "--main-at", "870m", "--main-lag", "1",
                  "--convention", "replaces"]  # fmt: skip


def _need(p: Path) -> Path:
    if not p.exists():
        pytest.skip(f"shared data not found at {p}")
    return p


def _run(args, capsys, out: Path, trials: int = 16) -> tuple[int, str, str]:
    code = main(["descent", *map(str, args), "--trials", str(trials), "--out", str(out)])
    cap = capsys.readouterr()
    return code, cap.out, cap.err


def _error(code: int, err: str) -> str:
    """The one error line of a run that must stop with exit status 2."""
    assert code == 2, err
    assert "Traceback" not in err
    lines = [ln for ln in err.splitlines() if ln.startswith("error:")]
    assert len(lines) == 1, err
    return lines[0]


def _with_header(src: Path, dst: Path, header: str) -> Path:
    lines = src.read_text().splitlines(keepends=True)
    dst.write_text(header + "\n" + "".join(lines[1:]))
    return dst


# -- columns whose values are not what their headers say -----------------------------------------


def test_bella_altitude_and_speed_names_swapped(tmp_path, capsys):
    """'z (m)' on the vertical speed, 'v (m/s)' on the altitude: 873 m² and exit 0 before."""
    log = _with_header(_need(BELLA), tmp_path / "swapped.csv",
                       "useless,time(not s),time aprox (s),v (m/s),z (m)")  # fmt: skip
    code, _, err = _run([log, *BELLA_STATED], capsys, tmp_path / "o")
    line = _error(code, err)
    assert "the altitude column 'z (m)' hardly descends" in line
    assert "which no stated canopy can give" in line
    # the likely mistake, from the physics of the other columns
    assert "'v (m/s)' does come down as the stated rocket would" in line
    assert "'z (m)' is its rate of change" in line and "a vertical speed" in line
    fix = "--columns time='time aprox (s)',altitude='v (m/s)' --altitude-unit m"
    assert fix in line
    # following the fix gives the clean log's answer
    code, out, err = _run([log, *BELLA_STATED, "--columns", "time=time aprox (s),altitude=v (m/s)",
                           "--altitude-unit", "m", "--json"], capsys, tmp_path / "a")  # fmt: skip
    assert code == 0, err
    fixed = json.loads(out)["phases"][0]
    code, out, err = _run([BELLA, *BELLA_STATED, "--json"], capsys, tmp_path / "b")
    assert code == 0, err
    clean = json.loads(out)["phases"][0]
    assert fixed["best_fit"]["cds"] == pytest.approx(clean["best_fit"]["cds"], rel=1e-9)
    assert fixed["cds_feasible"] == pytest.approx(clean["cds_feasible"], rel=1e-9)


def test_genesis_altitude_and_acceleration_names_swapped(tmp_path, capsys):
    """A CATS export whose altitude and acceleration names are swapped (its header is still
    the CATS one): 867 m² and exit 0 before."""
    log = _with_header(_need(GENESIS), tmp_path / "swapped.csv",
                       "ts,filtered_acceleration,filtered_altitude_AGL")  # fmt: skip
    code, _, err = _run([log, *GENESIS_STATED], capsys, tmp_path / "o")
    line = _error(code, err)
    assert "'filtered_altitude_AGL' does not descend" in line
    assert "'filtered_acceleration' does come down as the stated rocket would" in line
    assert "--columns time='ts',altitude='filtered_acceleration' --altitude-unit m" in line


def test_a_column_that_does_not_come_down_names_the_one_that_does(tmp_path, capsys):
    """The altitude column chosen by hand is the time counter: no descent, and the message
    names the column that has one."""
    log = _need(BELLA)
    code, _, err = _run([log, *BELLA_STATED, "--columns", "time=time aprox (s),altitude=useless",
                         "--altitude-unit", "m"], capsys, tmp_path / "o")  # fmt: skip
    line = _error(code, err)
    assert "'z (m)' does come down as the stated rocket would" in line


# -- times and altitudes in the wrong unit -------------------------------------------------------


def _bella_rows(t_factor: float = 1.0) -> str:
    import csv

    rows = list(csv.reader(_need(BELLA).open()))[1:]
    return "".join(f"{float(r[2]) * t_factor:.6g},{r[3]}\n" for r in rows)


def test_a_ms_header_on_a_seconds_log(tmp_path, capsys):
    """A flight of 0.05 s: exit 0 with no result before."""
    log = tmp_path / "ms.csv"
    log.write_text("t (ms),alt (m)\n" + _bella_rows())
    code, _, err = _run([log, *BELLA_STATED], capsys, tmp_path / "o")
    line = _error(code, err)
    assert "where a free fall from rest takes 9.85 s (no descent is faster" in line
    assert "'t (ms)' (read in ms from its name)" in line
    assert "the time looks like s (a descent of 476.1 m in 25.1 s" in line
    assert "correct the unit in the column's name" in line


def test_a_seconds_header_on_a_ms_log(tmp_path, capsys):
    log = tmp_path / "s.csv"
    log.write_text("t (s),alt (m)\n" + _bella_rows(1000.0))
    line = _error(*_run([log, *BELLA_STATED], capsys, tmp_path / "o")[::2])
    assert "'t (s)' of s.csv, read in s (from its name), has a sample every 60 s" in line
    assert "the times look like ms (a sample every 0.06 s)" in line


@pytest.mark.parametrize(
    ("units", "says"),
    [
        (["--time-unit", "ms", "--altitude-unit", "m"], "the times look like s"),
        (["--time-unit", "s", "--altitude-unit", "km"],
         "the altitude looks like m (a descent of 2057 m in 103 s, 19.9 m/s): give "
         "--altitude-unit m"),
        (["--time-unit", "min", "--altitude-unit", "m"],
         "'time' read in s instead of min would give 0.131 m²"),
    ],
    ids=["ms for s", "km for m", "min for s"],
)  # fmt: skip
def test_a_unit_option_off_by_orders_of_magnitude(tmp_path, capsys, units, says):
    log = _need(VALKYRIE)
    args = [log, *units, "--mass", "6.295", "--drogue-cds", "0.2589", "--pad-altitude", "592"]
    line = _error(*_run(args, capsys, tmp_path / "o")[::2])
    assert says in line, line


def test_time_scale_check_is_free_fall():
    """A descent as fast as a free fall passes (the fastest there is); one 1000 × faster than
    the log's stops, naming the unit that makes it a descent."""
    t = np.linspace(0.0, 40.0, 801)
    h = np.where(t < 10.0, 500.0 - 4.9 * (t - 10.0) ** 2, 500.0 - 4.9 * (t - 10.0) ** 2)
    h = np.maximum(h, 0.0)
    read = ReadAs("t", "s", "option", "h", "m", "option")
    check_time_scale(t, h, read)  # free fall: allowed
    with pytest.raises(StudyDefinitionError, match=r"the time looks like s .*give --time-unit s"):
        check_time_scale(t * 1e-3, h, ReadAs("t", "ms", "option", "h", "m", "option"))


# -- drag areas the stated rocket cannot give ----------------------------------------------------


def test_a_mass_off_by_orders_of_magnitude(tmp_path, capsys):
    """--mass 1e9 gave 3.9e7 m², exit 0, though the docs promised a stop."""
    log = _need(BELLA)
    stated = [a if a != "18.227" else "1e9" for a in BELLA_STATED]
    line = _error(*_run([log, *stated], capsys, tmp_path / "o")[::2])
    assert "a drag area of 4.03e+07 m²" in line and "5.13e+07 × the largest stated" in line
    assert "check the mass (--mass, kg)" in line
    assert "at this rate the stated 0.7854 m² needs a mass of 19.5 kg" in line
    stated = [a if a != "18.227" else "1e-6" for a in BELLA_STATED]
    line = _error(*_run([log, *stated], capsys, tmp_path / "o")[::2])
    assert "× the smallest stated drag area" in line


def _plan(**kw) -> DescentPlan:
    base = {"file": "x.csv", "mass": 20.846, "drogue": Canopy(cds=0.4378),
            "main": Canopy(cds=16.05), "convention": "replaces"}  # fmt: skip
    base.update(kw)
    return DescentPlan(**base)


def test_drag_magnitude_stops_only_orders_of_magnitude_off():
    """Where the check stops: beyond TOO_LARGE × the largest stated total and below the
    smallest / TOO_SMALL; a main-sized canopy open under a stated drogue (NDRT: 37 ×) or a
    rocket falling with no canopy open is a result, not an error."""
    read = ReadAs("t", "s", "option", "h", "m", "option")
    ok = [("drogue phase", 0, 30, 5.0, 16.05 * 0.9), ("main phase", 30, 60, 60.0, 0.002)]
    check_drag_magnitude(_plan(), ok, read)
    check_drag_magnitude(_plan(main=None, convention=None), [ok[0]], read)  # 33 × the drogue
    big = ("drogue phase", 0, 30, 0.3, 16.05 * TOO_LARGE * 1.01)
    with pytest.raises(StudyDefinitionError, match=r"^drag area: in the drogue phase"):
        check_drag_magnitude(_plan(), [big], read)
    small = ("drogue phase", 0, 30, 300.0, 0.4378 / TOO_SMALL / 1.01)
    with pytest.raises(StudyDefinitionError, match="× the smallest stated drag area"):
        check_drag_magnitude(_plan(), [small], read)
    # adds: the main phase's total is the drogue's plus the main's
    adds = _plan(convention="adds")
    check_drag_magnitude(adds, [("main phase", 0, 30, 5.0, (0.4378 + 16.05) * 90)], read)
    # nothing stated: only what no parachute and no rocket has
    flown = _plan(drogue=Canopy(), main=None, convention=None)
    check_drag_magnitude(flown, [("drogue phase", 0, 30, 2.0, 4e3)], read)
    with pytest.raises(StudyDefinitionError, match="more than the largest parachutes have"):
        check_drag_magnitude(flown, [("drogue phase", 0, 30, 0.1, 1e4)], read)
    assert math.isclose(TOO_LARGE, 100.0) and math.isclose(TOO_SMALL, 1000.0)


# -- selections that leave nothing ---------------------------------------------------------------


@pytest.mark.parametrize(
    ("opts", "says"),
    [
        (["--start", "1e9"], "start: 1e+09 s is at or after the end of the descent"),
        (["--start", "40"], "at or after the end of the descent the phases can use (34.19 s"),
        (["--drogue-window", "30", "20"], "it ends before it starts"),
        (["--drogue-window", "100", "200"], "outside the altitude data (0.00-46.23 s)"),
        (["--end", "5"], "ends 0.0 s after the apogee"),
        (["--end", "-100"], "end: -100 s keeps 0 samples of the log"),
    ],
    ids=["start past the end", "start after touchdown", "window reversed", "window outside",
         "end before apogee", "end before the log"],
)  # fmt: skip
def test_an_empty_selection_is_an_error(tmp_path, capsys, opts, says):
    line = _error(*_run([_need(BELLA), *BELLA_STATED, *opts], capsys, tmp_path / "o")[::2])
    assert says in line, line


def test_no_phase_with_data_is_an_error(tmp_path, capsys):
    """A window of 3 s for the only phase: exit 2, never exit 0 with nothing."""
    line = _error(*_run([_need(BELLA), *BELLA_STATED, "--drogue-window", "20", "23"], capsys,
                        tmp_path / "o")[::2])  # fmt: skip
    assert "nothing to identify: the drogue phase's window 20.00-23.00 s is only 3.00 s" in line


# -- columns that are not there, files that are not UTF-8 text ----------------------------------


def test_a_column_that_is_not_there(tmp_path, capsys):
    log = _need(BELLA)
    line = _error(*_run([log, *BELLA_STATED, "--columns", "time=nope,altitude=z (m)"], capsys,
                        tmp_path / "o")[::2])  # fmt: skip
    assert "has no column 'nope' (given as time=nope)" in line
    assert "the time-like ones: 'time(not s)', 'time aprox (s)'" in line
    line = _error(*_run([log, *BELLA_STATED, "--columns", "time=time aprox (s),altitude=Z (M)"],
                        capsys, tmp_path / "o")[::2])  # fmt: skip
    assert "has no column 'Z (M)'" in line and "the nearest: 'z (m)'" in line
    assert "states no unit" not in line


@pytest.mark.parametrize(
    ("encode", "says"),
    [
        (lambda t: t.encode("utf-16"), r"is UTF-16 text \(little-endian byte-order mark ff fe\)"),
        (lambda t: t.encode("utf-16-be"), r"UTF-16 text \(big-endian, without a byte-order mark"),
        (lambda t: __import__("gzip").compress(t.encode()), r"is gzip-compressed.*gunzip -k"),
        (lambda t: t.replace("z (m)", "Höhe (m)").encode("latin-1"),
         r"byte 0xf6 at line 1 is not UTF-8 \(read as Windows-1252 / Latin-1 the line is"),
    ],
    ids=["utf-16", "utf-16be no bom", "gzip", "latin-1"],
)  # fmt: skip
def test_a_file_that_is_not_utf8_text_names_its_encoding(tmp_path, capsys, encode, says):
    import re

    log = tmp_path / "log.csv"
    log.write_bytes(encode(_need(BELLA).read_text()))
    line = _error(*_run([log, *BELLA_STATED], capsys, tmp_path / "o")[::2])
    assert re.search(says, line), line


# -- a big log is read once ----------------------------------------------------------------------


def test_a_big_log_is_read_once_with_the_same_answer(tmp_path, capsys, monkeypatch):
    """Above BIG_LOG samples, the phases' stores read the altitude as read (from a two-column
    file beside them) instead of the whole log again: the same data, so the same answer."""
    import vectorid.descent.study as study

    log = _need(BELLA)
    code, out, err = _run([log, *BELLA_STATED, "--json"], capsys, tmp_path / "a")
    assert code == 0, err
    whole = json.loads(out)
    monkeypatch.setattr(study, "BIG_LOG", 100)  # Bella Lui's 768 samples count as big
    code, out, err = _run([log, *BELLA_STATED, "--json"], capsys, tmp_path / "b")
    assert code == 0, err
    once = json.loads(out)
    assert any("read once" in n for n in once["notes"])
    assert (tmp_path / "b" / "bella_lui_flight_data_filtered-altitude.csv").exists()
    a, b = whole["phases"][0], once["phases"][0]
    for key in ("cds_feasible", "box", "noise_sigma_m", "window_s"):
        assert b[key] == pytest.approx(a[key], rel=1e-12), key
    assert b["best_fit"]["cds"] == pytest.approx(a["best_fit"]["cds"], rel=1e-12)
