"""``event_column`` of the generic CSV loader on files with repeated rows (issue 12).

Before the fix the loader indexed the de-duplicated time array with the file's row numbers: a
raw IndexError when a state changed late in a file with repeated rows, or a silently wrong event
time when the row number stayed in range.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from vectorid.identify import FlightDataError, load_csv, load_telemega

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data"
TELEMEGA = DATA / "prometheus-2022" / "2022-06-24-serial-6583-flight-0003-TeleMega.csv"

MAPPING = {
    "time": "t",
    "time_unit": "s",
    "altitude": {"column": "h", "unit": "m"},
    "event_column": "state",
}


def _write(path: Path, rows: list[tuple[float, float, str]]) -> Path:
    path.write_text("t,h,state\n" + "".join(f"{t},{h},{s}\n" for t, h, s in rows))
    return path


def _rows(n: int, changes: dict[int, str], repeat: set[int]) -> list[tuple[float, float, str]]:
    """n distinct times 0, 0.5, ... with the state changing at the given sample numbers; the
    samples in ``repeat`` are written twice (identical rows, as loggers do)."""
    out, state = [], "pad"
    for i in range(n):
        state = changes.get(i, state)
        row = (0.5 * i, 100.0 - i, state)
        out.append(row)
        if i in repeat:
            out.append(row)
    return out


def test_late_event_after_repeated_rows_is_not_an_index_error(tmp_path):
    # 6 repeated rows early: the "landed" change sits on file row 25 of 26, beyond the 20
    # de-duplicated samples the old code indexed (IndexError, exit 1)
    rows = _rows(20, {5: "drogue", 19: "landed"}, repeat={0, 1, 2, 3, 4, 6})
    fd = load_csv(_write(tmp_path / "log.csv", rows), MAPPING)
    assert fd.events == {"pad": 0.0, "drogue": 2.5, "landed": 9.5}
    assert fd["altitude"].t.size == 20  # the repeated rows are dropped


def test_event_times_are_the_times_of_their_rows(tmp_path):
    # the row number of "main" (file row 13) stays in range of the de-duplicated array, where
    # the old code silently read the time of sample 13 (6.5 s) instead of sample 10 (5.0 s)
    rows = _rows(30, {4: "drogue", 10: "main", 25: "landed"}, repeat={1, 2, 3})
    fd = load_csv(_write(tmp_path / "log.csv", rows), MAPPING)
    assert fd.events == {"pad": 0.0, "drogue": 2.0, "main": 5.0, "landed": 12.5}


def test_state_change_on_a_repeated_timestamp_keeps_its_time(tmp_path):
    # a logger writes the same sample twice, the second time with the new state: the row is
    # dropped as a repeat (same mapped values), the state change keeps that time
    rows = [(0.0, 10.0, "pad"), (0.5, 9.0, "pad"), (0.5, 9.0, "drogue"), (1.0, 8.0, "drogue")]
    fd = load_csv(_write(tmp_path / "log.csv", rows), MAPPING)
    assert fd.events == {"pad": 0.0, "drogue": 0.5}


def test_event_names_rename_the_values(tmp_path):
    rows = _rows(10, {3: "2", 7: "3"}, repeat={0, 1})
    fd = load_csv(
        _write(tmp_path / "log.csv", rows), {**MAPPING, "event_names": {"2": "drogue", "3": "main"}}
    )
    assert fd.events == {"pad": 0.0, "drogue": 1.5, "main": 3.5}


def test_conflicting_repeated_rows_are_still_an_error(tmp_path):
    rows = [(0.0, 10.0, "pad"), (0.5, 9.0, "pad"), (0.5, 7.0, "pad"), (1.0, 8.0, "pad")]
    with pytest.raises(FlightDataError, match="line 3 and line 4"):
        load_csv(_write(tmp_path / "log.csv", rows), MAPPING)


@pytest.mark.skipif(not TELEMEGA.exists(), reason=f"shared flight data not found at {TELEMEGA}")
def test_real_telemega_states_through_the_generic_loader():
    # the real log repeats 511 rows; its state names read as events by the generic loader must
    # be the TeleMega loader's (drogue 28.5 s, main 157.97 s, landed 237.94 s)
    fd = load_csv(
        TELEMEGA,
        {
            "time": "time",
            "time_unit": "s",
            "altitude": {"column": "height", "unit": "m"},
            "event_column": "state_name",
        },
    )
    ref = load_telemega(TELEMEGA).events
    for name in ("boost", "coast", "drogue", "main", "landed"):
        assert fd.events[name] == pytest.approx(ref[name], abs=1e-9), name
    assert fd.events["drogue"] == pytest.approx(28.5)
    assert fd.events["main"] == pytest.approx(157.97)
