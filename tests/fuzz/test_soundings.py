"""Fuzz table: wind profiles (Wyoming soundings and dropsonde CSV). A bad cell is refused with
its line and column, a file cut short is refused, a good file is read exactly; a parser never
stops early and returns part of a profile."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vectorid.identify import FlightDataError, load_dropsonde_csv, load_wyoming

from ._harness import TALLY, expect, write

KIND = "soundings"
KN = 1852 / 3600

HEADER = """\
-----------------------------------------------------------------------------
   PRES   HGHT   TEMP   DWPT   RELH   MIXR   DRCT   SKNT   THTA   THTE   THTV
    hPa     m      C      C      %    g/kg    deg   knot     K      K      K
-----------------------------------------------------------------------------
"""


def level(i: int) -> str:
    p, h = 1000.0 - 10 * i, 100 + 300 * i
    return (
        f"{p:7.1f}{h:7d}{20.0 - i:7.1f}{10.0 - i:7.1f}{50:7d}{7.0:7.2f}"
        f"{(10 * i) % 360:7d}{5 + i:7d}{293.0 + i:7.1f}{313.0:7.1f}{294.0:7.1f}"
    )


LEVELS = [level(i) for i in range(30)]
GOOD = HEADER + "\n".join(LEVELS) + "\n"


def with_line(k: int, text: str) -> str:
    lines = list(LEVELS)
    lines[k] = text
    return HEADER + "\n".join(lines) + "\n"


def cell(k: int, col: int, value: str) -> str:
    line = LEVELS[k]
    return with_line(k, line[: 7 * col] + f"{value:>7}" + line[7 * (col + 1) :])


# (id, text, regex of the error; None: must read the 30 levels exactly)
WYOMING = [
    ("good", GOOD, None),
    ("good html", "<HTML><PRE>\n" + GOOD + "</PRE><H3>Station information</H3>\n", None),
    ("good crlf", GOOD.replace("\n", "\r\n"), None),
    ("good bom", "\ufeff" + GOOD, None),
    ("good no final newline", GOOD.rstrip("\n"), None),
    ("bad height", cell(3, 1, "1x0"), r"line 8, column HGHT.*'1x0'"),
    ("bad direction", cell(12, 6, "27O"), r"line 17, column DRCT.*'27O'"),
    ("bad speed", cell(20, 7, "1,5"), r"line 25, column SKNT.*'1,5'"),
    ("bad unused cell", cell(5, 2, "abc"), r"line 10, column TEMP.*'abc'"),
    ("direction 400", cell(7, 6, "400"), r"line 12, column DRCT: wind direction 400 deg"),
    ("direction -5", cell(7, 6, "-5"), r"line 12, column DRCT: wind direction -5 deg"),
    ("speed negative", cell(9, 7, "-3"), r"line 14, column SKNT: wind speed -3"),
    ("cut mid-line", GOOD[: GOOD.index(LEVELS[17]) + 30], r"cut short.*line 22"),
    ("cut mid-line, newline", GOOD[: GOOD.index(LEVELS[17]) + 30] + "\n", r"cut short"),
    ("html never closed", "<HTML><PRE>\n" + GOOD, r"cut short.*<PRE>"),
    ("text after columns", with_line(4, LEVELS[4] + "   999"), r"line 9 has text after"),
    ("letter line inside", with_line(10, "garbage" + LEVELS[10][7:]), r"line 15.*PRES.*garb"),
    ("no header", "\n".join(LEVELS), "not a University of Wyoming sounding"),
    ("header only", HEADER, "holds no level"),
    ("no DRCT column", GOOD.replace("DRCT", "DRXT"), "no DRCT column"),
    ("no speed column", GOOD.replace("SKNT", "SKXT"), "no wind speed column"),
    ("empty", "", "not a University of Wyoming sounding"),
    ("binary", "\x00\x01\x02" * 50, "not a University of Wyoming sounding"),
    ("all winds blank", HEADER + "\n".join(ln[:42] for ln in LEVELS) + "\n", "no level"),
]


@pytest.mark.parametrize(("case", "text", "match"), WYOMING, ids=[c[0] for c in WYOMING])
def test_wyoming(tmp_path, case, text, match):
    path = write(tmp_path / "s.txt", text.encode("utf-8") if isinstance(text, str) else text)
    if match is None:
        w = load_wyoming(path)
        h = np.array([100 + 300 * i for i in range(30)], float)
        speed, direction = w.speed_direction(h)
        ok = (
            np.array_equal(w.altitude, h)
            and np.allclose(speed, (5 + np.arange(30)) * KN)
            and np.allclose(np.mod(direction, 360), (10 * np.arange(30)) % 360, atol=1e-9)
        )
        expect(KIND, bool(ok), f"{case}: read {w.altitude.size} levels")
        return
    with pytest.raises(FlightDataError) as err:
        load_wyoming(path)
    import re

    ok = re.search(match, str(err.value)) is not None and "\n" not in str(err.value)
    TALLY[KIND]["clear" if ok else "silent"] += 1
    assert ok, str(err.value)


DROPSONDE_GOOD = "altitude,speed,direction\n" + "".join(
    f"{100 * i},{2 + i},{(15 * i) % 360}\n" for i in range(20)
)


def drop_line(k: int, text: str) -> str:
    lines = DROPSONDE_GOOD.splitlines()
    lines[k] = text
    return "\n".join(lines) + "\n"


DROPSONDE = [
    ("good", DROPSONDE_GOOD, None),
    ("good semicolons", DROPSONDE_GOOD.replace(",", ";"), None),
    ("good blank lines", DROPSONDE_GOOD.replace("\n", "\n\n"), None),
    ("bad cell", drop_line(5, "400,x7,60"), r"line 6, column 2 \('speed'\).*'x7'"),
    ("bad cell after blanks", "\n\n" + drop_line(5, "400,x7,60"), r"line 8, column 2"),
    ("short row", drop_line(8, "700,9"), r"line 9 has 2 fields"),
    ("cut short", DROPSONDE_GOOD[:-5], r"cut short|line 21"),
    ("direction 370", drop_line(3, "200,5,370"), r"line 4, column 'direction': direction 370"),
    ("speed negative", drop_line(3, "200,-5,30"), r"line 4, column 'speed': wind speed -5"),
    ("missing column", DROPSONDE_GOOD.replace("speed", "sped"), "column 'speed' is not"),
    ("header only", "altitude,speed,direction\n", "at least one level"),
    (
        "radians as degrees",
        "altitude,speed,direction\n"
        + "".join(f"{100 * i},{2 + i},{0.3 * i % 6}\n" for i in range(20)),
        "radians",
    ),
]


@pytest.mark.parametrize(("case", "text", "match"), DROPSONDE, ids=[c[0] for c in DROPSONDE])
def test_dropsonde(tmp_path, case, text, match):
    path = write(tmp_path / "d.csv", text)
    if match is None:
        w = load_dropsonde_csv(path)
        speed, direction = w.speed_direction(w.altitude)
        ok = (
            np.array_equal(w.altitude, 100.0 * np.arange(20))
            and np.allclose(speed, 2 + np.arange(20))
            and all(
                math.isclose((d - e + 180) % 360 - 180, 0, abs_tol=1e-9)
                for d, e in zip(direction[speed > 0], ((15 * np.arange(20)) % 360)[speed > 0])
            )
        )
        expect(KIND, bool(ok), case)
        return
    with pytest.raises(FlightDataError) as err:
        load_dropsonde_csv(path)
    import re

    ok = re.search(match, str(err.value)) is not None
    TALLY[KIND]["clear" if ok else "silent"] += 1
    assert ok, str(err.value)
