"""Logs the tool has not seen, as a new user would bring them: made at test time from a shared
log (Bella Lui's) written the ways other loggers and spreadsheets write theirs — another column
order, a semicolon delimiter, decimal commas, a time in ms or as ISO 8601 dates, text lines
before the header, feet in an ``ALT(ft)`` header, a log that ends in the air, rows of NaN.
Each gives the clean log's data (so the clean log's answer) or a one-line error with exit
status 2 — never a traceback, never a silently wrong number.

Skipped when ``../shared/data`` is absent.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from vectorid.cli import main
from vectorid.descent import Canopy, DescentPlan
from vectorid.descent.study import _load

ROOT = Path(__file__).resolve().parents[2]
BELLA = (
    ROOT.parent / "shared" / "data" / "rocketpy-descents" / "EPFL_Bella_Lui"
    / "bella_lui_flight_data_filtered.csv"
)  # fmt: skip
FT = 0.3048
STATED = ["--mass", "18.227", "--drogue-cds", "0.7854", "--pad-altitude", "407"]


def _bella() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    if not BELLA.exists():
        pytest.skip(f"shared data not found at {BELLA}")
    import pandas as pd

    df = pd.read_csv(BELLA)
    return (df["time aprox (s)"].to_numpy(), df["z (m)"].to_numpy(), df["v (m/s)"].to_numpy())


def _lines(t, h, fmt="{:.2f},{:.3f}") -> str:
    return "".join(fmt.format(a, b) + "\n" for a, b in zip(t, h))


def _variants(d: Path) -> dict[str, tuple[Path, list[str], np.ndarray]]:
    """name -> (file, the options its documentation would give, the rows of the clean log it
    holds)."""
    t, h, v = _bella()
    every = np.ones(t.size, dtype=bool)
    out: dict[str, tuple[Path, list[str], np.ndarray]] = {}

    def put(name: str, text: str, opts=(), rows=every) -> None:
        p = d / f"{name}.csv"
        p.write_text(text, encoding="utf-8")
        out[name] = (p, list(opts), rows)

    put("column order", "v (m/s),z (m),temp,time aprox (s)\n"
        + "".join(f"{c:.3f},{b:.3f},20.1,{a:.2f}\n" for a, b, c in zip(t, h, v)))  # fmt: skip
    put("semicolons", "time (s);alt (m)\n" + _lines(t, h, "{:.2f};{:.3f}"))
    put("decimal commas", "time (s);alt (m)\n" + _lines(t, h, "{:.2f};{:.3f}").replace(".", ","))
    put("time in ms", "time_ms,altitude_m\n"
        + "".join(f"{round(a * 1000)},{b:.3f}\n" for a, b in zip(t, h)))  # fmt: skip
    base = np.datetime64("2020-02-22T13:00:00.000")
    iso = [str(base + np.timedelta64(round((a - t[0]) * 1000), "ms")) for a in t]
    put("ISO dates", "timestamp,alt (m)\n" + "".join(f"{a},{b:.3f}\n" for a, b in zip(iso, h)))
    put("text before the header", "Altimeter export v2.1\nFlight 7, 2020-02-22\n\n"
        "time (s),alt (m)\n" + _lines(t, h))  # fmt: skip
    put("ALT(ft)", "TIME(s),ALT(ft)\n" + _lines(t, h / FT, "{:.2f},{:.3f}"))
    air = t <= 30.0
    put("ends in the air", "time (s),alt (m)\n" + _lines(t[air], h[air]), rows=air)
    rows = _lines(t, h).splitlines(keepends=True)
    nan_alt = [100, 300, 301, 500]
    for k in nan_alt:
        rows[k] = f"{t[k]:.2f},nan\n"
    rows[400], rows[600] = ",\n", "NaN,NaN\n"
    keep = every.copy()
    keep[[*nan_alt, 400, 600]] = False
    put("NaN rows", "time (s),alt (m)\n" + "".join(rows), rows=keep)
    # a unit only the flight's documentation states: given as it says
    put("no unit in the header", "time,ALT\n" + _lines(t, h / FT),
        ["--time-unit", "s", "--altitude-unit", "ft"])  # fmt: skip
    return out


@pytest.fixture(scope="module")
def variants(tmp_path_factory):
    return _variants(tmp_path_factory.mktemp("unseen"))


NAMES = [
    "column order", "semicolons", "decimal commas", "time in ms", "ISO dates",
    "text before the header", "ALT(ft)", "ends in the air", "NaN rows", "no unit in the header",
]  # fmt: skip


def _plan(path: Path, opts: list[str]) -> DescentPlan:
    kw = dict(zip(opts[::2], opts[1::2]))
    return DescentPlan(
        file=path, mass=18.227, drogue=Canopy(cds=0.7854), pad_altitude=407.0,
        time_unit=kw.get("--time-unit"), altitude_unit=kw.get("--altitude-unit"),
    )  # fmt: skip


@pytest.mark.parametrize("name", NAMES)
def test_an_unseen_log_is_read_as_the_clean_one(variants, name):
    t, h, _ = _bella()
    path, opts, rows = variants[name]
    _, flight, _, _, notes, _ = _load(_plan(path, opts))
    a = flight["altitude"]
    # the clean log's samples (the loader leaves out its corrupt pad sample alike)
    _, clean, _, _, _, _ = _load(_plan(BELLA, []))
    c = clean["altitude"]
    sel = np.isin(np.round(c.t, 2), np.round(t[rows], 2))
    ct, ch = c.t[sel], c.values[sel, 0]
    assert a.t.size == ct.size, (name, a.t.size, ct.size, notes)
    np.testing.assert_allclose(a.t - a.t[0], ct - ct[0], atol=1e-6)
    tol = 0.002 * FT if "ft" in name.lower() or "unit" in name else 1e-6
    np.testing.assert_allclose(a.values[:, 0], ch, atol=tol)


def _cli(args, capsys) -> tuple[int, str, str]:
    code = main(["descent", *map(str, args)])
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.mark.slow
def test_unseen_logs_give_the_clean_answer_end_to_end(variants, tmp_path, capsys):
    """Two of them through the verb, against the clean log: the same drag area."""

    def cds(path, opts):
        code, out, err = _cli([path, *STATED, *opts, "--trials", "32", "--json", "--out",
                               tmp_path / "o"], capsys)  # fmt: skip
        assert code == 0, err
        assert "Traceback" not in err
        return json.loads(out)["phases"][0]["cds_feasible"]

    clean = cds(BELLA, [])
    for name in ("decimal commas", "text before the header"):
        path, opts, _ = variants[name]
        assert cds(path, opts) == pytest.approx(clean, rel=1e-6), name


@pytest.mark.parametrize(
    ("text", "opts", "says"),
    [
        ("time,ALT\n0,1\n", [], "no unit"),  # the unit only the documentation states
        ("time (s),alt (m)\n", [], "no data rows"),  # a header alone
        ("timestamp,alt (m)\n2020-02-22T13:00:00,5\nnot a date,6\n" * 3, [], "timestamp"),
        ("time (s),alt (m)\n0,1\n0.1,abc\n0.2,3\n", [], "'abc'"),  # text among the numbers
        ("\x00\x01\x02binary", [], ""),  # not a text file
    ],
)
def test_what_cannot_be_read_is_one_line_and_exit_2(tmp_path, capsys, text, opts, says):
    path = tmp_path / "log.csv"
    path.write_text(text, encoding="utf-8")
    code, _, err = _cli([path, *STATED, *opts, "--out", tmp_path / "o"], capsys)
    assert code == 2, err
    assert "Traceback" not in err
    lines = [ln for ln in err.splitlines() if ln.startswith("error:")]
    assert len(lines) == 1 and says in lines[0], err


def test_an_altitude_above_sea_level_is_not_taken_for_one_above_the_pad(tmp_path, capsys):
    t, h, _ = _bella()
    path = tmp_path / "msl.csv"
    path.write_text("time (s),Altitude (m MSL)\n" + _lines(t, h + 407.0))
    code, _, err = _cli([path, *STATED, "--out", tmp_path / "o"], capsys)
    lines = [ln for ln in err.splitlines() if ln.startswith("error:")]
    assert code == 2 and len(lines) == 1 and "--altitude-reference msl" in lines[0], err
    assert "Traceback" not in err
    # said so, it is the clean log's descent (the same drag areas)
    _, flight, _, _, _, _ = _load(_plan(path, []))
    _, clean, _, _, _, _ = _load(_plan(BELLA, []))
    np.testing.assert_allclose(flight["altitude"].values[:, 0] - 407.0,
                               clean["altitude"].values[:, 0], atol=1e-6)  # fmt: skip
