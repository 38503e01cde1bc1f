"""A generic CSV is read from its content: a repeated pre-launch buffer (the time restarts), a
logging pause, two altitude columns in different units; a unit the file does not state is not
guessed (the descent check stops on feet read as metres).

Synthetic logs are built here; the real flights are read from ``../shared/data`` (skipped when
absent).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from vectorid.descent import Canopy, DescentPlan, identify_descent
from vectorid.descent.formats import detect_format
from vectorid.errors import StudyDefinitionError
from vectorid.identify import FlightDataError, load_flight

ROOT = Path(__file__).resolve().parents[2]
RP = ROOT.parent / "shared" / "data" / "rocketpy-descents"
FT = 0.3048


def _need(p: Path) -> Path:
    if not p.exists():
        pytest.skip(f"shared data not found at {p}")
    return p


def _descent(step: float = 0.5, t_end: float = 90.0) -> tuple[np.ndarray, np.ndarray]:
    """A drogue descent (20.846 kg under 0.4378 m², about 27 m/s) from a 1300-m apogee at 20 s."""
    t = np.arange(0.0, t_end, step)
    up = np.clip(t, 0, 20)
    h = np.where(t < 20, 1300 * (1 - (1 - up / 20) ** 2), 1300 - 27.0 * (t - 20))
    return t, np.maximum(h, 0.0) + np.random.default_rng(5).normal(0, 0.3, t.size)


def _write(path: Path, header: str, rows: list[tuple[float, ...]]) -> Path:
    path.write_text(header + "\n" + "\n".join(",".join(f"{v:.3f}" for v in r) for r in rows)
                    + "\n", encoding="utf-8")  # fmt: skip
    return path


def _buffer_log(tmp_path: Path, repeats: int = 4) -> tuple[Path, int]:
    """A log whose first rows repeat a pre-launch buffer (time -0.7 ... 0.2) ``repeats`` times;
    returns the file and the line of the flight's first row."""
    buf = [(round(-0.7 + 0.1 * k, 1), 0.0) for k in range(10)]
    t, h = _descent()
    rows = buf * repeats + list(zip(t + 0.3, h))
    return _write(tmp_path / "buffer.csv", "time (s),alt (m)", rows), 2 + 10 * (repeats - 1) + 10


def test_a_repeated_buffer_is_cut_to_the_monotonic_flight_part(tmp_path):
    path, _ = _buffer_log(tmp_path)
    lf = detect_format(path)
    # the longest part where the time never goes back: the last copy of the buffer + the flight
    assert lf.mapping["first_line"] == 2 + 10 * 3
    assert "last_line" not in lf.mapping
    note = next(n for n in lf.notes if "time goes back" in n)
    assert "3 time(s)" in note and "30 left out" in note
    fd = load_flight(path, mapping=lf.mapping, format="csv")
    assert np.all(np.diff(fd["altitude"].t) > 0)
    # without the cut the loader stops on the time going back (nothing is silently reordered)
    with pytest.raises(FlightDataError, match="time goes backwards"):
        load_flight(path, mapping={k: v for k, v in lf.mapping.items() if k != "first_line"},
                    format="csv")  # fmt: skip


def test_a_user_line_choice_wins_and_a_file_that_is_not_one_flight_is_not_cut(tmp_path):
    path, _ = _buffer_log(tmp_path)
    lf = detect_format(path, extra={"first_line": 45})
    assert lf.mapping["first_line"] == 45
    assert not any("time goes back" in n for n in lf.notes)
    # two halves of equal length: no part holds 80 % of the rows, nothing is cut
    t, h = _descent()
    half = t.size // 2
    rows = list(zip(t[half:], h[half:])) + list(zip(t[:half], h[:half]))
    lf = detect_format(_write(tmp_path / "halves.csv", "time (s),alt (m)", rows))
    assert "first_line" not in lf.mapping and "last_line" not in lf.mapping


def test_a_logging_pause_is_accepted_with_a_note_and_a_long_hole_is_not(tmp_path):
    t, h = _descent(step=1.0)
    keep = ~((t > 50) & (t < 54)) & ~((t > 70) & (t < 73))  # pauses of 4 s and 3 s at 1 Hz
    path = _write(tmp_path / "pause.csv", "time,alt", list(zip(t[keep], h[keep])))
    with pytest.raises(StudyDefinitionError, match="'time' and the altitude column 'alt'.*no unit"):
        detect_format(path)  # units are never guessed
    units = {"time_unit": "s", "altitude_unit": "m"}
    lf = detect_format(path, **units)
    assert lf.mapping["max_gap"] == pytest.approx(4.0)
    note = next(n for n in lf.notes if "logging pause" in n)
    assert "2 logging pause(s)" in note and "50-54 s" in note
    load_flight(path, mapping=lf.mapping, format="csv")  # loads
    # a 40-s hole in a 1-Hz log is not a pause: the loader's gap rule stands
    keep = ~((t > 30) & (t < 70))
    path = _write(tmp_path / "hole.csv", "time,alt", list(zip(t[keep], h[keep])))
    lf = detect_format(path, **units)
    assert "max_gap" not in lf.mapping
    with pytest.raises(FlightDataError, match="max_gap"):
        load_flight(path, mapping=lf.mapping, format="csv")
    # the user's --max-gap wins
    assert detect_format(path, extra={"max_gap": 50.0}, **units).mapping["max_gap"] == 50.0


def test_two_altitude_columns_that_agree_are_one_and_that_differ_are_an_error(tmp_path):
    t, h = _descent()
    path = _write(tmp_path / "two.csv", "t(s),alt(ft),alt(m)", list(zip(t, h / FT, h)))
    lf = detect_format(path)
    assert lf.mapping["altitude"] == {"column": "alt(m)", "unit": "m"}
    assert any("same altitude" in n for n in lf.notes)
    # two different altitudes (baro and GNSS, say) are not chosen between
    path = _write(tmp_path / "diff.csv", "t(s),alt(ft),alt(m)", list(zip(t, h / FT, h + 200.0)))
    with pytest.raises(StudyDefinitionError, match="cannot tell the altitude column"):
        detect_format(path)
    # nor columns that state no unit
    path = _write(tmp_path / "nounit.csv", "t,alt1,alt2", list(zip(t, h, h)))
    with pytest.raises(StudyDefinitionError, match="cannot tell the altitude column"):
        detect_format(path)


@pytest.mark.slow
def test_feet_without_a_unit_in_the_header_are_not_read_as_metres(tmp_path):
    t, h = _descent()
    path = _write(tmp_path / "feet.csv", "time,ALT", list(zip(t, h / FT)))
    plan = dict(mass=20.846, drogue=Canopy(cds=0.4378), pad_altitude=206.0, trials=16, seed=1)
    # no unit in the header, none given: not guessed, a one-line error naming the column
    with pytest.raises(StudyDefinitionError, match="'ALT' of feet.csv state.? no unit"):
        identify_descent(DescentPlan(file=path, name="feet", time_unit="s", **plan),
                         tmp_path / "out")  # fmt: skip
    # metres given by mistake: the descent check stops with the likely mistake
    with pytest.raises(StudyDefinitionError, match="feet read as metres"):
        identify_descent(DescentPlan(file=path, name="feet", time_unit="s", altitude_unit="m",
                                     **plan), tmp_path / "out")  # fmt: skip
    r = identify_descent(DescentPlan(file=path, name="feet", time_unit="s", altitude_unit="ft",
                                     **plan), tmp_path / "out")  # fmt: skip
    assert 1000.0 < r.phases[0].altitude_loss < 1300.0  # metres: the feet were converted


def test_juno_iii_is_read_from_its_content():
    path = _need(RP / "juno3" / "cots_GNSS.csv")
    # its README states s and feet, its header nothing: the units must be given
    with pytest.raises(StudyDefinitionError, match="'time' and the altitude column 'ALT'"):
        detect_format(path)
    lf = detect_format(path, time_unit="s", altitude_unit="ft")
    assert lf.mapping["time"] == "time" and lf.mapping["altitude"] == {
        "column": "ALT",
        "unit": "ft",
    }
    assert lf.mapping["first_line"] == 46  # the last copy of the repeated buffer
    assert 3.0 <= lf.mapping["max_gap"] < 3.01  # its 3-s holes, as logging pauses
    # metres given by mistake: the descent check stops
    plan = dict(mass=24.05, drogue=Canopy(cds=0.885), altitude_reference="msl", trials=16, seed=1)
    with pytest.raises(StudyDefinitionError, match="feet read as metres"):
        identify_descent(DescentPlan(file=path, name="juno", time_unit="s", altitude_unit="m",
                                     **plan), Path("/tmp") / "vid-juno")  # fmt: skip


@pytest.mark.parametrize(
    ("folder", "file", "column"),
    [("camoes", "flight_data.csv", "filtered_altitude_AGL"),
     ("genesis", "flight_data_faraday.csv", "filtered_altitude_AGL"),
     ("lince", "main_data.csv", "filtered_altitude_AGL"),
     ("hedy", "cats_tust/filteredDataInfo.csv", "filteredAltitudeAGL")],
)  # fmt: skip
def test_cats_exports_are_a_named_format_with_documented_units(folder, file, column):
    path = _need(RP / folder / file)
    lf = detect_format(path)
    assert lf.named is not None and "CATS" in lf.named
    assert lf.mapping["time"] == "ts" and lf.mapping["time_unit"] == "s"
    assert lf.mapping["altitude"] == {"column": column, "unit": "m"}
    assert any("recognised from its header" in n and "CATS documentation" in n for n in lf.notes)
    # its units are documented: a unit option does not apply
    with pytest.raises(StudyDefinitionError, match="does not apply"):
        detect_format(path, altitude_unit="ft")
    # the same columns in a generic file (another column added) are not the CATS format
    with pytest.raises(StudyDefinitionError, match="no unit"):
        detect_format(path, format="csv")
