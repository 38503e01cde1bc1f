"""``vectorid step``: the integration step an identification study needs (loaded by the CLI).

::

    vectorid step STUDY.toml [--tolerance M] [--trials N] [--seed S] [--json]

For each drop of the study's ``[identification]``, the trajectories of the study's nominal
vector and ``--trials`` Sobol vectors of its box, over the drop's window with its controls,
wind and initial state, are integrated at each candidate step and compared with a reference
(see :mod:`vectorid.models.steps`). It prints the largest position error of each step (m), the
largest step within ``--tolerance`` for every drop, and what the study's own ``dt`` gives. It
changes nothing: the study file keeps an explicit ``dt``.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from .main import add_json_option, positive_int

__all__ = ["COMMANDS", "add_parsers"]


def add_parsers(sub: Any) -> None:
    """Add the ``step`` verb to the ``vectorid`` sub-parsers."""
    s = sub.add_parser(
        "step", help="the largest integration step within a position tolerance, per drop"
    )
    s.add_argument("study", help="study file (.toml) with an [identification] table")
    s.add_argument(
        "--tolerance", type=float, default=0.1, help="largest position error allowed, m (0.1)"
    )
    s.add_argument("--trials", type=positive_int, default=16, help="Sobol vectors of the box (16)")
    s.add_argument("--seed", type=int, default=0, help="seed of the Sobol sample (0)")
    add_json_option(s)


def _cmd_step(args: argparse.Namespace) -> int:
    import numpy as np
    from scipy.stats import qmc

    from ..errors import StudyDefinitionError
    from ..identify.identification import Identification
    from ..models.steps import DEFAULT_CANDIDATES, choose_step
    from ..spec import load_study

    if not (args.tolerance > 0):
        raise StudyDefinitionError(
            "--tolerance",
            f"expected a positive number of metres, got {args.tolerance!r}",
            "e.g. --tolerance 0.1",
        )
    spec = load_study(Path(args.study))
    ident = Identification.from_spec(spec)
    space = spec.space
    u = qmc.Sobol(len(space), seed=args.seed).random(args.trials)
    X = np.vstack([space.nominal, space.scale(u)])
    candidates = sorted({*DEFAULT_CANDIDATES, float(ident.dt)}, reverse=True)
    rows = []
    for d in ident.drops:
        t_final = ident.output_dt * int(d.duration / ident.output_dt + 1e-9)
        choice = choose_step(
            ident.model,
            ident.parameters(X),
            t_final=t_final,
            tolerance=args.tolerance,
            candidates=candidates,
            output_dt=ident.output_dt,
            inputs=d.inputs,
            wind=d.wind,
            initial=d.initial,
            atmosphere=ident.atmosphere,
        )
        rows.append((d.name, choice))
    chosen = [c.dt for _, c in rows]
    overall = None if any(dt is None for dt in chosen) else min(chosen)
    if args.json:
        out = {
            "tolerance_m": args.tolerance,
            "study_dt_s": ident.dt,
            "recommended_dt_s": overall,
            "drops": [
                {
                    "drop": name,
                    "dt_s": c.dt,
                    "reference_dt_s": c.reference_dt,
                    "trials": c.trials,
                    "failed_in_reference": c.failed_in_reference,
                    "errors_m": {f"{dt:g}": err for dt, err in c.errors.items()},
                }
                for name, c in rows
            ],
        }
        json.dump(out, sys.stdout, indent=2)
        sys.stdout.write("\n")
        return 0
    for name, c in rows:
        print(f"drop {name!r} ({c.t_final:g} s):")
        print("  " + c.summary().replace("\n", "\n  "))
    mine = [c.errors.get(float(ident.dt)) for _, c in rows]
    if any(e is None for e in mine):  # load_study refuses such a dt; said, never a KeyError
        print(f"the study's dt = {ident.dt:g} s does not divide output_dt: not compared")
    else:
        own = max(e for e in mine if e is not None)
        print(
            f"the study's dt = {ident.dt:g} s: largest position error {own:.3g} m over every drop"
        )
    if overall is None:
        print(f"no candidate step is within {args.tolerance:g} m for every drop")
    else:
        ratio = overall / ident.dt
        change = (
            f"{ratio:.3g}x fewer model evaluations than dt = {ident.dt:g} s"
            if ratio > 1
            else f"{1 / ratio:.3g}x more model evaluations than dt = {ident.dt:g} s"
            if ratio < 1
            else "the study's own step"
        )
        print(
            f"recommended: dt = {overall:g} s (the largest within {args.tolerance:g} m for "
            f"every drop; {change}); write it as dt in [identification]"
        )
    return 0


COMMANDS = {"step": _cmd_step}
