"""``vectorid predict``: what the identified set predicts for new drops (loaded by
:mod:`vectorid.cli`).

::

    vectorid predict STORE DROP.toml [DROP.toml ...] [--members N] [--seed S]
                     [--limit 'NAME<=VALUE' ...] [--nearest-generation] [--json] [--out DIR]

The store is opened read-only: nothing is written to it. ``--out DIR`` writes
``prediction.json`` and ``prediction.html`` (the bands per channel, the landing scatter) there.
Errors in input exit with status 2 and one line that says what was expected, what came and
how to fix it. See :mod:`vectorid.workflows.predict`.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from .main import (
    add_json_option,
    add_limit_options,
    add_store_argument,
    open_study,
    positive_int,
    print_json,
)

__all__ = ["COMMANDS", "add_parsers"]


def add_parsers(sub: Any) -> None:
    """Add the ``predict`` verb to the ``vectorid`` sub-parsers."""
    p = sub.add_parser(
        "predict",
        help="what the identified set D predicts for new drops: bands, landing, checks",
        description="Fly the members of D over drops copied from a study (with their data: a "
        "predictive check) or planned (no data), and print per channel the median, the "
        "credible 5-95 %% band (D's spread) and the with-noise band (where a measured sample "
        "is expected), the landing R50/R90/R95 and, where there are data, whether they lie "
        "within what D predicts. The store is only read (--save writes the limits, nothing else).",
    )
    add_store_argument(p)
    p.add_argument("drops", nargs="+", metavar="DROP.toml", help="drop file(s)")
    p.add_argument(
        "--members",
        type=positive_int,
        help="members of D to fly (default: all; fewer are drawn keeping their weights)",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the draws (default 0)")
    add_limit_options(p, role=False)
    p.add_argument(
        "--nearest-generation",
        action="store_true",
        help="where D is empty on a sequential store, fly the sampler's nearest generation "
        "(named as not D in every output)",
    )
    add_json_option(p)
    p.add_argument("--out", help="folder for prediction.json and prediction.html")


def _cmd_predict(args: argparse.Namespace) -> int:
    from ..workflows.predict import as_limits, predict

    with open_study(args.store) as study:
        limits = as_limits(study.spec, args.limit)
        pred = predict(
            study,
            args.drops,
            members=args.members,
            seed=args.seed,
            limits=limits,
            nearest_generation=args.nearest_generation,
        )
    if args.out:
        from ..views.predict import write_prediction

        for f in write_prediction(pred, args.out):
            print(f"written {f}", file=sys.stderr)
    if args.json:
        print_json(pred.to_dict())
    else:
        print(pred.describe())
    return 0


COMMANDS = {"predict": _cmd_predict}
