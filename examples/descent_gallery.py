"""Identify the drag areas of every real rocket descent in the shared data, and tabulate them.

Usage::

    python examples/descent_gallery.py [DATA_DIR] [--trials 512] [--out descent-gallery]
                                        [--json] [--only NAME ...]

``DATA_DIR`` is the shared data folder (default ``../shared/data`` beside the checkout): the
Prometheus TeleMega log (``prometheus-2022/``) and the nine flights of ``rocketpy-descents/``.
Each flight is identified by :func:`vectorid.descent.identify_descent` with the
mass, drag areas, triggers and pad elevations its README states (RocketPy's values; the
TeleMega flight's from the data README), and nothing else: no window, settling time or end
picked by hand (the phases, the touchdown, the spikes left out come from the data).

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

#: flight name -> (file relative to the data folder, plan keywords, note on the settings).
#: Only what each flight's README states: the mass, the canopies, the triggers (with their lag),
#: the pad elevation, and the units a file does not state where its README does (Juno III's
#: s and feet, Valkyrie's s and m; the CATS exports' units are documented by CATS). Columns,
#: repeated buffers and logging pauses are read from the content. No window, settling time or
#: end is picked by hand: the phases come from the data.
FLIGHTS: dict[str, tuple[str, dict[str, Any], str]] = {
    "Prometheus (TeleMega)": (
        "prometheus-2022/2022-06-24-serial-6583-flight-0003-TeleMega.csv",
        {
            "mass": 13.9 + 2.981,
            "drogue": Canopy(diameter=24 * INCH, cd=1.6),
            "main": Canopy(diameter=72 * INCH, cd=2.2),
            "convention": "adds",
        },
        "AltusMetrum CSV: format, drogue and main events, pad altitude (pad pressure) from the log",
    ),
    "Bella Lui": (
        f"{RP}/EPFL_Bella_Lui/bella_lui_flight_data_filtered.csv",
        {"mass": 18.227, "drogue": Canopy(cds=0.7854), "pad_altitude": 407.0},
        "columns and units read from the header",
    ),
    "NDRT 2020": (
        f"{RP}/NDRT_2020/ndrt_2020_flight_data.csv",
        {
            "mass": 20.846,
            "drogue": Canopy(cds=0.4378),
            "main": Canopy(cds=16.05),
            "convention": "replaces",
            "main_at": "550ft",
            "main_lag": 1.0,
            "pad_altitude": 206.0,
        },
        "altitude in feet, read from the header 'Altitude (Ft-AGL)'; main at the stated 550 ft",
    ),
    "Andromeda": (
        f"{RP}/andromeda/flight_data.csv",
        {
            "mass": 20.9767,
            "drogue": Canopy(cds=0.84665922014),
            "main": Canopy(cds=8.362919643856031),
            "convention": "replaces",
            "main_at": "500m",
            "pad_altitude": 160.0,
        },
        "the header has alt(ft) and alt(m), which agree: alt(m) is used; the corrupt last two "
        "rows are left out as spikes",
    ),
    "Camões": (
        f"{RP}/camoes/flight_data.csv",
        {"mass": 22.8, "drogue": Canopy(cds=0.33), "pad_altitude": 107.0},
        "CATS Vega export, recognised from its header: units m and s as CATS documents them",
    ),
    "Genesis": (
        f"{RP}/genesis/flight_data_faraday.csv",
        {
            "mass": 9.214,
            "drogue": Canopy(cds=0.285005285533666),
            "main": Canopy(cds=1.1),
            "convention": "replaces",
            "main_at": "870m",
            "main_lag": 1.0,
            "pad_altitude": 160.0,
        },
        "main at the stated 870 m trigger + 1 s lag",
    ),
    "Hedy": (
        f"{RP}/hedy/cats_tust/filteredDataInfo.csv",
        {
            "mass": 17.2,
            "drogue": Canopy(cds=0.5336875),
            "main": Canopy(cds=6.911503837897546),
            "convention": "replaces",
            "main_at": "450m",
            "main_lag": 4.0,
            "pad_altitude": 160.0,
        },
        "main at the stated 450 m trigger + 4 s lag",
    ),
    "Juno III": (
        f"{RP}/juno3/cots_GNSS.csv",
        {
            # the units, beyond mass, canopy and trigger: the file does not state them (its
            # README does: time in s, ALT in feet); without them the run stops (units are never
            # guessed), and read as metres the descent check stops (2.5-3.3 × too fast)
            "time_unit": "s",
            "altitude_unit": "ft",
            "mass": 24.05,
            "drogue": Canopy(cds=0.885),
            "altitude_reference": "msl",
        },
        "GNSS altitude above sea level in feet (README; the header states no unit, so "
        "--time-unit s --altitude-unit ft are needed); the repeated pre-launch buffer and "
        "the 3-s logging pauses are found from the time column",
    ),
    "Lince": (
        f"{RP}/lince/main_data.csv",
        {"mass": 10.3521352, "main": Canopy(cds=3.9), "pad_altitude": 158.0},
        "one canopy (the main) from apogee; mass after payload separation",
    ),
    "Valkyrie": (
        f"{RP}/valkyrie/flightInfo_merged.csv",
        {
            # the file's header states no units; its README does: time s, altitude m
            "time_unit": "s",
            "altitude_unit": "m",
            "mass": 5.65 + 0.6449,
            "drogue": Canopy(cds=0.258940616),
            "main": Canopy(cds=5.786483801),
            "convention": "replaces",
            "main_at": "500m",
            "main_lag": 1.73,
            "pad_altitude": 592.0,
        },
        "time and altitude units from the README (s, m; the header states none); main at "
        "the stated 500 m trigger + 1.73 s lag",
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


def command(name: str, data: str = "../shared/data") -> str:
    """The ``vectorid descent`` command of a flight of :data:`FLIGHTS`: the same plan, from
    the command line (``--commands`` prints them all; docs/descent.md lists them)."""
    rel, kw, _ = FLIGHTS[name]

    def num(v: float) -> str:
        return format(float(v), ".10g")

    args = [".venv/bin/vectorid", "descent", f"{data}/{rel}"]
    for key, value in kw.items():
        if isinstance(value, Canopy):
            if value.cds is not None:
                args += [f"--{key}-cds", num(value.cds)]
            else:
                args += [f"--{key}-diameter", f"{num(value.diameter / INCH)}in"]
                if value.cd is not None:
                    args += [f"--{key}-cd", num(value.cd)]
        elif isinstance(value, float | int):
            args += [f"--{key.replace('_', '-')}", num(value)]
        else:
            args += [f"--{key.replace('_', '-')}", str(value)]
    return " ".join(args) + f" --out {_slug(name)}"


def _slug(name: str) -> str:
    import re
    import unicodedata

    plain = unicodedata.normalize("NFKD", name).encode("ascii", "ignore").decode()
    return re.sub(r"[^a-z0-9]+", "-", plain.lower()).strip("-")


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
            elif p.cds_range is not None:  # the drag area changes along the descent
                ident = "varies"
                rng = f"{p.cds_range[0]:.4g}-{p.cds_range[1]:.4g}"
                rms = "-"
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
    ap.add_argument(
        "--commands", action="store_true",
        help="print each flight's `vectorid descent` command instead of running them",
    )  # fmt: skip
    args = ap.parse_args(argv)
    if args.commands:
        for n in args.only or list(FLIGHTS):
            print(f"# {n}\n{command(n)}")
        return 0
    data = Path(args.data)
    if not data.is_dir():
        print(
            f"error: no shared data folder at {data}. The flights are RocketPy's "
            "(github.com/RocketPy-Team/RocketPy, data/rockets/, MIT): fetch them with `python "
            "scripts/fetch_data.py rocketpy-descents prometheus-2022` (writes ../shared/data), or "
            "give the folder's path",
            file=sys.stderr,
        )
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
