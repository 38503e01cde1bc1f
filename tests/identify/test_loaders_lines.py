"""``first_line`` / ``last_line`` of the generic CSV loader: read a log from the lines that hold
the flight (a repeated pre-launch buffer before it, corrupt rows after it)."""

from __future__ import annotations

import pytest

from vectorid.identify import FlightDataError, load_csv, load_parquet

MAPPING = {"time": "t", "time_unit": "s", "altitude": {"column": "h", "unit": "m"}}


def _log(tmp_path):
    # lines 2-4: a buffer whose time runs backwards into the flight; lines 5-9: the flight;
    # line 10: a corrupt row
    rows = ["0.0,1", "0.5,1", "-0.5,1", "-0.5,0", "0.0,0", "0.5,5", "1.0,9", "1.5,12", "9e9,-7"]
    path = tmp_path / "log.csv"
    path.write_text("t,h\n" + "\n".join(rows) + "\n")
    return path


def test_the_whole_file_is_refused(tmp_path):
    with pytest.raises(FlightDataError, match="time goes backwards at line 4"):
        load_csv(_log(tmp_path), MAPPING)


def test_first_and_last_line_keep_the_flight(tmp_path):
    fd = load_csv(_log(tmp_path), {**MAPPING, "first_line": 5, "last_line": 9})
    a = fd["altitude"]
    assert a.t.tolist() == [-0.5, 0.0, 0.5, 1.0, 1.5]
    assert a.values[:, 0].tolist() == [0.0, 0.0, 5.0, 9.0, 12.0]


def test_errors_inside_the_kept_lines_name_the_file_line(tmp_path):
    path = tmp_path / "log.csv"
    path.write_text("t,h\n0,1\n1,x\n2,3\n3,4\n")
    load_csv(path, {**MAPPING, "first_line": 4})  # the bad cell is outside: fine
    with pytest.raises(FlightDataError, match="'x' at line 3"):
        load_csv(path, {**MAPPING, "first_line": 2, "last_line": 4})


@pytest.mark.parametrize(
    ("keys", "match"),
    [
        ({"first_line": 0}, "integer >= 1"),
        ({"last_line": "ten"}, "integer >= 1"),
        ({"first_line": 50}, "no data rows between line 50"),
    ],
)
def test_bad_line_numbers(tmp_path, keys, match):
    with pytest.raises(FlightDataError, match=match):
        load_csv(_log(tmp_path), {**MAPPING, **keys})


def test_parquet_has_no_lines(tmp_path):
    pa = pytest.importorskip("pyarrow")
    import pyarrow.parquet as pq

    path = tmp_path / "log.parquet"
    pq.write_table(pa.table({"t": [0.0, 1.0, 2.0], "h": [1.0, 2.0, 3.0]}), path)
    with pytest.raises(FlightDataError, match="CSV files only"):
        load_parquet(path, {**MAPPING, "first_line": 2})


# -- header_line, decimal commas, rows without any value ---------------------------------------


def test_header_line_decimal_commas_and_empty_rows(tmp_path):
    path = tmp_path / "log.csv"
    body = ["0,0;1,5", "0,5;2,5", ";", "nan;NaN", "1,0;3,5", "1,5;4,5", "2,0;5,5", "2,5;6,5",
            "3,0;7,5", "3,5;8,5"]  # fmt: skip
    path.write_text("Logger v2\nflight 3\nt;h\n" + "\n".join(body) + "\n")
    fd = load_csv(path, {**MAPPING, "header_line": 3, "decimal": ",", "spikes": "keep"})
    a = fd["altitude"]
    assert a.t.tolist() == [0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5]
    assert a.values[:, 0].tolist() == [1.5, 2.5, 3.5, 4.5, 5.5, 6.5, 7.5, 8.5]
    assert any("2 row(s) without any value (line(s) 6, 7)" in n for n in fd.notes)
    # without them: the title is taken for the header, a clear error, nothing half-read
    with pytest.raises(FlightDataError, match="fields but the header has"):
        load_csv(path, MAPPING)
    with pytest.raises(FlightDataError, match="integer >= 1"):
        load_csv(path, {**MAPPING, "header_line": 0})
    with pytest.raises(FlightDataError, match="'.' or ','"):
        load_csv(path, {**MAPPING, "header_line": 3, "decimal": ";"})
