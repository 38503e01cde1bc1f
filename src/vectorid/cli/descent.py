"""The ``vectorid descent`` verb (loaded by :mod:`vectorid.cli`)::

    vectorid descent LOG --mass KG [--columns time=COL,altitude=COL[,event=COL]]
                     [--time-unit s|ms|iso] [--altitude-unit m|ft] [--altitude-reference pad|msl]
                     [--strict-data]
                     [--pad-altitude M] [--first-line N] [--last-line N] [--max-gap S]
                     [--drogue-cds M2 | --drogue-diameter LEN [--drogue-cd CD] | --drogue]
                     [--main-cds M2 | --main-diameter LEN [--main-cd CD] | --main]
                     [--convention adds|replaces] [--main-at EVENT|TIME|HEIGHT|detect]
                     [--main-lag S] [--start TIME|EVENT] [--end S]
                     [--drogue-window START END] [--main-window START END]
                     [--drogue-settle S] [--main-settle S] [--allowance M]
                     [--allowance-fraction F] [--vz-allowance M/S] [--vz-allowance-fraction F]
                     [--noise M|estimate] [--initial-speed steady|data] [--box-factor F]
                     [--trials N] [--seed N] [--out DIR] [--json]

Identifies the drag area C_D S of each parachute of a rocket's recovery descent from an
altimeter log (and C_D where a canopy's diameter is given), phase by phase, with a verdict per
phase; see :mod:`vectorid.descent` and docs/descent.md. The log's format is read from its
content; units are read from its header or stated with a unit, never guessed.
"""

from __future__ import annotations

import argparse
import math
import sys
from typing import Any

from .main import add_json_option, positive_int

__all__ = ["COMMANDS", "add_parsers"]


def _number(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return v


def _positive(text: str) -> float:
    v = _number(text)
    if v <= 0:
        raise argparse.ArgumentTypeError(f"expected a number > 0, got {text!r}")
    return v


def _time_or_event(text: str) -> float | str:
    try:
        return float(text)
    except ValueError:
        return text


def add_parsers(sub: Any) -> None:
    """Add ``descent`` to the ``vectorid`` sub-parsers."""
    d = sub.add_parser(
        "descent",
        help="identify the parachutes' drag areas of a rocket descent from an altimeter log",
        description="Identify the drag area C_D S (m²) of each parachute of a rocket's recovery "
        "descent from an altimeter log, phase by phase (drogue, main), with the feasible and "
        "Pareto ranges and a verdict against the stated values. Touchdown is read from the "
        "data. Each phase is a study store in --out.",
    )
    d.add_argument(
        "log", help="the altimeter log (CSV, AltusMetrum CSV, Parquet, ULog: read from its content)"
    )
    d.add_argument(
        "--format",
        choices=["csv", "parquet", "altusmetrum", "telemega", "ulog"],
        help="only to overrule what the content says (telemega = altusmetrum)",
    )
    d.add_argument(
        "--columns",
        metavar="time=COL,altitude=COL[,event=COL]",
        help="column names of the time, the altitude and (optional) a flight-state column "
        "whose changes are events (a generic CSV; default: from its header when it has one "
        "time-like and one altitude-like column; an AltusMetrum log states its own)",
    )
    d.add_argument(
        "--time-unit",
        help="unit of a generic CSV's time column when its name states none (required then: "
        "units are never guessed): s, ms, us, ns, min, or iso (ISO 8601 dates)",
    )
    d.add_argument(
        "--altitude-unit",
        help="unit of a generic CSV's altitude column when its name states none (required "
        "then: units are never guessed): m, ft, km (an error where the header or a recognised "
        "format states the unit)",
    )
    d.add_argument(
        "--strict-data",
        action="store_true",
        help="stop at a single-sample spike in the log instead of leaving it out",
    )
    d.add_argument(
        "--altitude-reference",
        choices=["pad", "msl"],
        default="pad",
        help="the altitude is above the pad (default) or above mean sea level",
    )
    d.add_argument(
        "--pad-altitude",
        type=_number,
        metavar="M",
        help="pad altitude above sea level, m (the air density depends on it; a TeleMega "
        "log's comes from its pad pressure)",
    )
    d.add_argument("--first-line", type=positive_int, help="first line of the file to read")
    d.add_argument("--last-line", type=positive_int, help="last line of the file to read")
    d.add_argument("--max-gap", type=_positive, metavar="S", help="longest gap in the altitude, s")
    d.add_argument("--mass", type=_positive, required=True, help="descending mass, kg")
    for c in ("drogue", "main"):
        g = d.add_argument_group(f"{c} parachute")
        g.add_argument(f"--{c}-cds", type=_positive, metavar="M2", help="stated drag area, m²")
        g.add_argument(
            f"--{c}-diameter",
            metavar="LEN",
            help="nominal diameter, with a unit: 24in, 0.61m, 2ft (C_D is then reported)",
        )
        g.add_argument(f"--{c}-cd", type=_positive, metavar="CD", help="stated C_D on π D²/4")
        g.add_argument(
            f"--{c}", action="store_true", help=f"a {c} was flown, its drag area not stated"
        )
    d.add_argument(
        "--convention",
        choices=["adds", "replaces"],
        help="with two parachutes (required then): the main's drag adds to the drogue's (the "
        "drogue stays attached) or replaces it (the stated main C_D S is the whole drag area "
        "under it, as RocketPy states it)",
    )
    d.add_argument(
        "--main-at",
        metavar="EVENT|HEIGHT|TIMEs|detect",
        help="when the main is triggered: an event of the log (default 'main'), a height "
        "above the pad with its unit (870m, 550ft), a time with its unit (204s), or 'detect' "
        "(the change of descent rate); never a bare number",
    )
    d.add_argument("--main-lag", type=_number, default=0.0, metavar="S", help="trigger to open, s")
    d.add_argument(
        "--start",
        type=_time_or_event,
        metavar="TIME|EVENT",
        help="start of the descent (default: the log's drogue event, else the apogee)",
    )
    d.add_argument("--end", type=_number, metavar="S", help="ignore the log after this time, s")
    for c in ("drogue", "main"):
        d.add_argument(
            f"--{c}-window",
            nargs=2,
            metavar=("START", "END"),
            help=f"the {c} phase's window: times in s or events (apogee, touchdown, main, "
            "main_trigger, the log's) with +/- offsets, e.g. 40 touchdown-1",
        )
    for c, settle, after in (
        ("drogue", 5.0, "the descent's start"),
        ("main", 6.0, "the main opens"),
    ):
        d.add_argument(
            f"--{c}-settle", type=_number, default=settle, metavar="S",
            help=f"seconds left out after {after}: deployment transients (default {settle:g})",
        )  # fmt: skip
    d.add_argument(
        "--allowance",
        type=_number,
        default=3.0,
        metavar="M",
        help="model-discrepancy allowance on the altitude, m (default 3)",
    )
    d.add_argument(
        "--allowance-fraction",
        type=_number,
        default=0.005,
        metavar="F",
        help="plus this fraction of the phase's altitude loss (default 0.005)",
    )
    d.add_argument(
        "--vz-allowance",
        type=_number,
        default=1.0,
        metavar="M/S",
        help="model-discrepancy allowance on the mean vertical-speed residual, m/s (default 1)",
    )
    d.add_argument(
        "--vz-allowance-fraction",
        type=_number,
        default=0.1,
        metavar="F",
        help="plus this fraction of the phase's mean descent rate (default 0.1)",
    )
    d.add_argument(
        "--noise",
        metavar="M|estimate",
        default="estimate",
        help="the altitude's measurement noise: a σ in m, or 'estimate' (default: white plus "
        "correlated noise estimated from each phase's data)",
    )
    d.add_argument(
        "--initial-speed",
        choices=["steady", "data"],
        default="steady",
        help="each phase starts at every trial's steady descent rate (default) or at the "
        "slope of the data at the window's start",
    )
    d.add_argument(
        "--box-factor",
        type=_number,
        default=1.5,
        metavar="F",
        help="each phase's box of the drag area: this factor either way of what its mean "
        "descent rate implies (default 1.5)",
    )
    d.add_argument("--trials", type=positive_int, default=1024, help="trials per phase")
    d.add_argument("--seed", type=int, default=1, help="seed of the Sobol trials (default 1)")
    d.add_argument("--out", default="vectorid-descent", help="folder of the phases' stores")
    add_json_option(d)


def _canopy(args: argparse.Namespace, c: str):
    from ..descent import Canopy, parse_length

    cds = getattr(args, f"{c}_cds")
    diam = getattr(args, f"{c}_diameter")
    cd = getattr(args, f"{c}_cd")
    flown = getattr(args, c)
    if cds is None and diam is None and cd is None and not flown:
        return None
    d = None if diam is None else parse_length(diam, f"--{c}-diameter")
    if cd is not None and d is None:
        from ..errors import StudyDefinitionError

        raise StudyDefinitionError(
            f"--{c}-cd", "a drag coefficient needs the canopy's diameter", f"add --{c}-diameter"
        )
    return Canopy(cds=cds, diameter=d, cd=cd)


def _columns(args: argparse.Namespace) -> dict[str, str] | None:
    from ..errors import StudyDefinitionError

    if args.columns is None:
        return None
    cols: dict[str, str] = {}
    for part in args.columns.split(","):
        key, sep, col = part.partition("=")
        key = key.strip()
        if not sep or key not in ("time", "altitude", "event") or not col.strip():
            raise StudyDefinitionError(
                "--columns",
                f"cannot read {part!r}",
                "write time=COL,altitude=COL (and event=COL for a flight-state column)",
            )
        cols[key] = col.strip()
    for key in ("time", "altitude"):
        if key not in cols:
            raise StudyDefinitionError(
                "--columns", f"no {key} column given", f"add {key}=COLUMN to --columns"
            )
    return cols


def _noise(text: str) -> float | str:
    from ..errors import StudyDefinitionError

    if text.strip() == "estimate":
        return "estimate"
    try:
        v = float(text)
    except ValueError:
        v = math.nan
    if not (math.isfinite(v) and v > 0):
        raise StudyDefinitionError(
            "--noise", f"expected a σ in m (> 0) or 'estimate', got {text!r}", "e.g. --noise 1.5"
        )
    return v


def plan_from_args(args: argparse.Namespace):
    """The :class:`~vectorid.descent.DescentPlan` of a parsed ``vectorid descent`` command."""
    from ..descent import DescentPlan

    windows = {}
    for c in ("drogue", "main"):
        w = getattr(args, f"{c}_window")
        if w is not None:
            windows[c] = [_time_or_event(x) for x in w]
    plan = DescentPlan(
        file=args.log,
        mass=args.mass,
        drogue=_canopy(args, "drogue"),
        main=_canopy(args, "main"),
        convention=args.convention,
        format=args.format,
        columns=_columns(args),
        time_unit=args.time_unit,
        altitude_unit=args.altitude_unit,
        read={
            k: v
            for k, v in (
                ("first_line", args.first_line),
                ("last_line", args.last_line),
                ("max_gap", args.max_gap),
            )
            if v is not None
        },
        strict_data=args.strict_data,
        pad_altitude=args.pad_altitude,
        altitude_reference=args.altitude_reference,
        main_at=args.main_at,
        main_lag=args.main_lag,
        start=args.start,
        end=args.end,
        windows=windows,
        drogue_settle=args.drogue_settle,
        main_settle=args.main_settle,
        allowance=args.allowance,
        allowance_fraction=args.allowance_fraction,
        vz_allowance=args.vz_allowance,
        vz_allowance_fraction=args.vz_allowance_fraction,
        noise=_noise(args.noise),
        initial_speed=args.initial_speed,
        box_factor=args.box_factor,
        trials=args.trials,
        seed=args.seed,
    )
    return plan


def _cmd_descent(args: argparse.Namespace) -> int:
    from ..descent import identify_descent
    from ..errors import StudyDefinitionError, VectoridError
    from .main import print_json

    plan = plan_from_args(args)
    try:
        result = identify_descent(plan, args.out)
    except VectoridError:
        raise
    except ValueError as exc:  # a log too short or too odd for the detectors
        raise StudyDefinitionError("log", str(exc), "check the log and the columns") from None
    if args.json:
        print_json(result.to_dict())
    else:
        sys.stdout.write(result.format_text() + "\n")
    return 0


COMMANDS = {"descent": _cmd_descent}
