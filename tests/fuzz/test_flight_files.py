"""Fuzz table: flight-log files (generic CSV with a mapping, the real TeleMega log damaged).
A bad cell is refused with its line and column, a file cut short is refused, a good file is
read exactly; nothing is half-loaded."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from vectorid.identify import FlightDataError, load_csv, load_telemega

from ._harness import TALLY, expect, write

KIND = "flight files"

DATA = Path(__file__).parents[2] / ".." / "shared" / "data"
TELEMEGA = DATA / "prometheus-2022" / "2022-06-24-serial-6583-flight-0003-TeleMega.csv"

MAPPING = {
    "time": "t",
    "time_unit": "s",
    "altitude": {"column": "h", "unit": "m"},
    "velocity": {"north": "vn", "east": "ve", "down": "vd", "unit": "m/s"},
}
N = 101
T = np.arange(N) * 0.1


def csv_text(rows: list[list[str]] | None = None, names: str = "t,h,vn,ve,vd") -> str:
    if rows is None:
        rows = [[f"{t:.3f}", f"{1000 - 5 * t:.3f}", "2.0", "0.5", "5.0"] for t in T]
    return names + "\n" + "\n".join(",".join(r) for r in rows) + "\n"


GOOD = csv_text()


def with_cell(row: int, col: int, value: str) -> str:
    rows = [[f"{t:.3f}", f"{1000 - 5 * t:.3f}", "2.0", "0.5", "5.0"] for t in T]
    rows[row][col] = value
    return csv_text(rows)


def with_row(row: int, text: str) -> str:
    lines = GOOD.splitlines()
    lines[row + 1] = text
    return "\n".join(lines) + "\n"


CASES = [
    ("good", GOOD, None),
    ("good crlf", GOOD.replace("\n", "\r\n"), None),
    ("good bom", "\ufeff" + GOOD, None),
    ("good semicolons", GOOD.replace(",", ";"), None),
    ("bad altitude", with_cell(30, 1, "1O00"), r"column 2 \('h'.*'1O00' at line 32"),
    ("bad time", with_cell(40, 0, "4.0s"), r"column 1 \('t'.*'4.0s' at line 42"),
    ("bad velocity", with_cell(50, 3, "0,5"), r"line 52 has 6 fields"),
    ("short row", with_row(60, "6.0,970.0,2.0"), r"line 62 has 3 fields"),
    ("cut short", GOOD[: GOOD.rindex("\n", 0, -1) + 8], r"last line: the file looks cut short"),
    ("empty", "", "empty"),
    ("header only", "t,h,vn,ve,vd\n", "no data rows"),
    (
        "latin-1",
        (GOOD.replace("t,h", "t,h\xe9")).encode("latin-1"),
        r"byte 0xe9 at line 1 is not UTF-8.*WINDOWS-1252",
    ),
    ("binary", b"\x00\xff" * 300, "binary data"),
    ("missing column", GOOD.replace("vd", "vz"), r"'vd'.*not in the file"),
    ("time backwards", with_cell(20, 0, "0.5"), r"time|monoton|order"),
]


@pytest.mark.parametrize(("case", "text", "match"), CASES, ids=[c[0] for c in CASES])
def test_flight_csv(tmp_path, case, text, match):
    path = write(tmp_path / "f.csv", text)
    if match is None:
        fd = load_csv(path, MAPPING)
        h = fd["altitude"]
        ok = np.allclose(h.t, T) and np.allclose(h.values[:, 0], 1000 - 5 * T, atol=1e-9)
        expect(KIND, bool(ok), case)
        return
    with pytest.raises(FlightDataError) as err:
        load_csv(path, MAPPING)
    ok = re.search(match, str(err.value)) is not None
    TALLY[KIND]["clear" if ok else "silent"] += 1
    assert ok, str(err.value)


@pytest.mark.skipif(not TELEMEGA.exists(), reason=f"real TeleMega log not found at {TELEMEGA}")
@pytest.mark.parametrize("case", ["cut mid-line", "bad cell", "intact"])
def test_real_telemega_damaged(tmp_path, case):
    text = TELEMEGA.read_text(encoding="utf-8")
    lines = text.splitlines(keepends=True)
    if case == "cut mid-line":
        k = len(lines) * 2 // 3
        damaged = "".join(lines[:k]) + lines[k][: len(lines[k]) // 3]
        match = rf"line {k + 1} has \d+ fields.*cut short"
    elif case == "bad cell":
        k = len(lines) // 2
        fields = lines[k].split(",")
        fields[4] = " 12x4"  # the time column
        damaged = "".join(lines[:k]) + ",".join(fields) + "".join(lines[k + 1 :])
        match = rf"got '12x4' at line {k + 1}"
    else:
        damaged, match = text, None
    path = write(tmp_path / "mega.csv", damaged)
    if match is None:
        fd = load_telemega(path)
        expect(KIND, "altitude" in fd.channels and len(fd["altitude"].t) > 100, case)
        return
    with pytest.raises(FlightDataError) as err:
        load_telemega(path)
    ok = re.search(match, str(err.value)) is not None
    TALLY[KIND]["clear" if ok else "silent"] += 1
    assert ok, str(err.value)
