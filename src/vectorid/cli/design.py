"""``vectorid design``: which planned drop would cut D the most (loaded by :mod:`vectorid.cli`).

::

    vectorid design STORE PLAN.toml [PLAN.toml ...] [--members N] [--seed S]
                    [--limit 'NAME<=VALUE' ...] [--json]

Each plan is a drop file of planned drops (``vectorid predict``'s format, with the noise of
its sensors). The store is only read. Errors in input exit with status 2 and one line that
says what was expected, what came and how to fix it. See :mod:`vectorid.workflows.design`.
"""

from __future__ import annotations

import argparse
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
    """Add the ``design`` verb to the ``vectorid`` sub-parsers."""
    p = sub.add_parser(
        "design",
        help="rank planned drops by how much of D their data would keep",
        description="Fly D's members over each planned drop; let each member play the truth, "
        "its outputs plus the stated noise being the data; count the members that would still "
        "meet the study's own criteria (those that read the plan's sensors) within the "
        "noise-floor limits the study would set for them. Prints, per plan, the expected "
        "share of D kept with a bootstrap interval, the criteria and limits it is judged by, "
        "how often the truth itself meets them, and the gains and combinations it would newly "
        "identify, ranked (1: the most informative; a plan that would reject the truth last), "
        "and says plainly when no plan would shrink D. The store "
        "is only read.",
    )
    add_store_argument(p)
    p.add_argument("plans", nargs="+", metavar="PLAN.toml", help="drop file(s) of planned drops")
    p.add_argument(
        "--members",
        type=positive_int,
        default=400,
        help="members of D flown, drawn keeping their weights (default 400; the cost grows "
        "with its square)",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the draws (default 0)")
    add_limit_options(p, role=False)
    add_json_option(p)


def _cmd_design(args: argparse.Namespace) -> int:
    from ..workflows.design import design
    from ..workflows.predict import as_limits

    with open_study(args.store) as study:
        limits = as_limits(study.spec, args.limit)
        d = design(study, args.plans, members=args.members, seed=args.seed, limits=limits)
    if args.json:
        print_json(d.to_dict())
    else:
        print(d.describe())
    return 0


COMMANDS = {"design": _cmd_design}
