"""Identify the drag areas of every real rocket descent in the shared data, and tabulate them.

Usage::

    python examples/descent_gallery.py [DATA_DIR] [--trials 512] [--out descent-gallery]
                                        [--json] [--only NAME ...]

``DATA_DIR`` is the shared data folder (default ``../shared/data`` beside the checkout): the
Prometheus TeleMega log (``prometheus-2022/``) and the nine flights of ``rocketpy-descents/``.
Each flight is identified by :func:`vectorid.descent.identify_descent` with the
mass, drag areas, triggers and pad elevations its README states (RocketPy's values; the
TeleMega flight's from the data README). Where a flight's README shows that the log needs
something the stated parameters do not say (a corrupt last row, an ejection disturbance that
lasts longer than the default settling time), the setting and its reason are in ``FLIGHTS``
below and in the table's notes.

The main's drag area follows RocketPy's convention (``replaces``: the stated ``cd_s`` of a main
is the whole drag area under it) for the RocketPy flights, and ``adds`` for Prometheus (the
drogue stays attached; the stated C_D refer to each canopy's own diameter).

Prints a Markdown table (flight, phase, stated C_D S, identified C_D S with its feasible range,
altitude RMS, verdict), the one in README.md and docs/identify.md; ``--json`` prints every
result instead. A flight whose files are missing is listed as such.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from vectorid.descent import INCH, Canopy, DescentPlan, identify_descent
from vectorid.errors import VectoridError

HERE = Path(__file__).resolve().parent
DEFAULT_DATA = HERE.parent.parent / "shared" / "data"
RP = "rocketpy-descents"

#: flight name -> (file relative to the data folder, plan keywords, note on the settings)
FLIGHTS: dict[str, tuple[str, dict[str, Any], str]] = {
    "Prometheus (TeleMega)": (
        "prometheus-2022/2022-06-24-serial-6583-flight-0003-TeleMega.csv",
        {
            "mass": 13.9 + 2.981,
            "drogue": Canopy(diameter=24 * INCH, cd=1.6),
            "main": Canopy(diameter=72 * INCH, cd=2.2),
            "convention": "adds",
            "drogue_settle": 17.0,
        },
        "drogue and main events from the log; pad altitude from the pad pressure; the drag "
        "area the GPS descent rate implies is 14 % low for 17 s after the drogue event (the "
        "deployment transient, examples/telemega_drogue.py): drogue window from drogue + 17 s",
    ),
    "Bella Lui": (
        f"{RP}/EPFL_Bella_Lui/bella_lui_flight_data_filtered.csv",
        {
            "mapping": {"time": "time aprox (s)", "altitude": {"column": "z (m)", "unit": "m"}},
            "mass": 18.227,
            "drogue": Canopy(cds=0.7854),
            "pad_altitude": 407.0,
            "drogue_settle": 6.0,
        },
        "drogue opens 4 s after apogee (README): window from apogee + 6 s",
    ),
    "NDRT 2020": (
        f"{RP}/NDRT_2020/ndrt_2020_flight_data.csv",
        {
            "mapping": {
                "time": "Time (s)",
                "altitude": {"column": "Altitude (Ft-AGL)", "unit": "ft"},
            },
            "mass": 20.846,
            "drogue": Canopy(cds=0.4378),
            "main": Canopy(cds=16.05),
            "convention": "replaces",
            "main_at": "550ft",
            "main_lag": 3.0,
            "pad_altitude": 206.0,
        },
        "altitude in feet; main at the stated 550 ft trigger; it opens about 3 s after its "
        "ejection (README), not the stated 1 s: main_lag 3 s",
    ),
    "Andromeda": (
        f"{RP}/andromeda/flight_data.csv",
        {
            "mapping": {"time": "t(s)", "altitude": {"column": "alt(m)", "unit": "m"}},
            "mass": 20.9767,
            "drogue": Canopy(cds=0.84665922014),
            "main": Canopy(cds=8.362919643856031),
            "convention": "replaces",
            "main_at": "500m",
            "pad_altitude": 160.0,
            "end": 321.85,
            "windows": {"drogue": [40.0, 321.85]},
        },
        "last two rows corrupt (README): log cut at 321.85 s; the descent rate steps at 36.1 s "
        "(README): drogue-phase window from 40 s",
    ),
    "Camões": (
        f"{RP}/camoes/flight_data.csv",
        {
            "mapping": {
                "time": "ts",
                "altitude": {"column": "filtered_altitude_AGL", "unit": "m"},
            },
            "mass": 22.8,
            "drogue": Canopy(cds=0.33),
            "pad_altitude": 107.0,
            "windows": {"drogue": [40.0, "touchdown-1"]},
        },
        "deployment disturbances to 39.2 s (README): window from 40 s",
    ),
    "Genesis": (
        f"{RP}/genesis/flight_data_faraday.csv",
        {
            "mapping": {
                "time": "ts",
                "altitude": {"column": "filtered_altitude_AGL", "unit": "m"},
            },
            "mass": 9.214,
            "drogue": Canopy(cds=0.285005285533666),
            "main": Canopy(cds=1.1),
            "convention": "replaces",
            "main_at": "870m",
            "main_lag": 1.0,
            "pad_altitude": 160.0,
            "windows": {"drogue": [30.0, 99.5]},
        },
        "main at the stated 870 m trigger + 1 s lag; disturbances 25.3-29.3 s and from 100.0 s "
        "(README): drogue window 30-99.5 s",
    ),
    "Hedy": (
        f"{RP}/hedy/cats_tust/filteredDataInfo.csv",
        {
            "mapping": {
                "time": "ts",
                "altitude": {"column": "filteredAltitudeAGL", "unit": "m"},
            },
            "mass": 17.2,
            "drogue": Canopy(cds=0.5336875),
            "main": Canopy(cds=6.911503837897546),
            "convention": "replaces",
            "main_at": 204.0,
            "main_settle": 4.0,
            "pad_altitude": 160.0,
            "windows": {"drogue": [42.0, 203.0]},
        },
        "disturbances to 41.5 s (README); nothing happens at the stated 450 m trigger, the one "
        "change of descent rate is at 204 s (README): main from it",
    ),
    "Juno III": (
        f"{RP}/juno3/cots_GNSS.csv",
        {
            "mapping": {
                "time": "time",
                "altitude": {"column": "ALT", "unit": "ft"},
                "first_line": 46,
                "max_gap": 4.0,
            },
            "mass": 24.05,
            "drogue": Canopy(cds=0.885),
            "altitude_reference": "msl",
        },
        "GNSS altitude above sea level in feet, about 1 Hz with holes of 3 s (max_gap 4 s); "
        "the file repeats a pre-launch buffer six times (README): read from line 46",
    ),
    "Lince": (
        f"{RP}/lince/main_data.csv",
        {
            "mapping": {
                "time": "ts",
                "altitude": {"column": "filtered_altitude_AGL", "unit": "m"},
            },
            "mass": 10.3521352,
            "main": Canopy(cds=3.9),
            "pad_altitude": 158.0,
            "main_settle": 10.0,
        },
        "one canopy (the main) from apogee; mass after payload separation; ejection "
        "disturbance to 29.7 s (README) and the descent rate settles at 35 s: window from "
        "apogee + 10 s",
    ),
    "Valkyrie": (
        f"{RP}/valkyrie/flightInfo_merged.csv",
        {
            "mapping": {"time": "time", "altitude": {"column": "altitude", "unit": "m"}},
            "mass": 5.65 + 0.6449,
            "drogue": Canopy(cds=0.258940616),
            "main": Canopy(cds=5.786483801),
            "convention": "replaces",
            "main_at": "500m",
            "main_lag": 1.73,
            "pad_altitude": 592.0,
        },
        "main at the stated 500 m trigger + 1.73 s lag",
    ),
}


def run_flight(name: str, data: Path, out: Path, trials: int, seed: int = 1):
    """Identify one flight of :data:`FLIGHTS`; None when its file is not in ``data``."""
    rel, kw, _ = FLIGHTS[name]
    path = data / rel
    if not path.exists():
        return None
    plan = DescentPlan(file=path, trials=trials, seed=seed, name=_slug(name), **kw)
    return identify_descent(plan, out)


def _slug(name: str) -> str:
    return "".join(c if c.isalnum() else "-" for c in name.lower()).strip("-")


def table(results: dict[str, Any]) -> str:
    """The gallery as a Markdown table."""
    rows = [
        "| flight | phase | stated C_D S (m²) | identified C_D S (m²) | feasible range (m²) "
        "| altitude RMS (m) | verdict |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    for name, r in results.items():
        if r is None:
            rows.append(f"| {name} | | | | | | shared data not found |")
            continue
        for p in r.phases:
            stated = "-" if p.stated_cds is None else f"{p.stated_cds:.4g}"
            if p.cds is not None:
                ident = f"{p.cds:.4g}"
                if p.cds_corrected is not None:
                    ident += f" (hot-day corrected {p.cds_corrected:.4g})"
                rng = f"{p.cds_feasible[0]:.4g}-{p.cds_feasible[1]:.4g}"
                rms = f"{p.alt_rms_m:.1f}"
            elif p.best_cds is not None and p.cds_feasible is None:
                ident = f"none (best fit {p.best_cds:.4g})"
                rng = "D empty"
                rms = f"{p.best_alt_rms_m:.1f} (best fit)"
            elif p.cds_feasible is not None:
                ident = p.status
                rng = f"{p.cds_feasible[0]:.4g}-{p.cds_feasible[1]:.4g}"
                rms = "-"
            else:
                ident, rng, rms = "none", "-", "-"
            verdict = p.summary.replace("|", "/")
            rows.append(f"| {name} | {p.name} | {stated} | {ident} | {rng} | {rms} | {verdict} |")
    return "\n".join(rows)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", nargs="?", default=str(DEFAULT_DATA), help="shared data folder")
    ap.add_argument("--trials", type=int, default=512, help="trials per phase (default 512)")
    ap.add_argument("--out", default="descent-gallery", help="folder of the stores")
    ap.add_argument("--json", action="store_true", help="print every result as JSON")
    ap.add_argument("--only", nargs="*", help="flights to run (names of the table)")
    args = ap.parse_args(argv)
    data = Path(args.data)
    if not data.is_dir():
        print(f"error: no shared data folder at {data}; give its path", file=sys.stderr)
        return 2
    names = args.only or list(FLIGHTS)
    for n in names:
        if n not in FLIGHTS:
            print(f"error: unknown flight {n!r}; flights: {', '.join(FLIGHTS)}", file=sys.stderr)
            return 2
    results = {}
    try:
        for n in names:
            results[n] = run_flight(n, data, Path(args.out), args.trials)
    except VectoridError as exc:
        print(f"error: {n}: {exc}", file=sys.stderr)
        return 2
    if args.json:
        json.dump(
            {n: None if r is None else r.to_dict() for n, r in results.items()},
            sys.stdout,
            indent=2,
            default=float,
        )
        print()
        return 0
    print(table(results))
    print()
    for n in names:
        print(f"- {n}: {FLIGHTS[n][2]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
