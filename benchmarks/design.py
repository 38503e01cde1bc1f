"""Design benchmark: ``vectorid design`` on a parafoil D of 5,000 members and 4 planned drops.

Goal (issue 34): ``vectorid.workflows.design.design`` of 4 plans of the ``parafoil8dof`` model
(33 gains; the demo's drop conditions: 120-s drops from 1,000 m with symmetric brake steps,
asymmetric steps at two amplitudes and a spiral, seen by GPS, velocity, attitude and rates) on
a store whose D holds about 5,000 members (8,192 trials, about 60 % of which fly), in at most
2 minutes on 2 cores after compilation, with its default 400 members flown. Baseline measured
in the same run: the model alone flying the same 400 parameter vectors over the same 4 drops
(one ``Predictor.simulate`` call per drop), so the ratio says what the worth estimate costs
beside the simulation.

The store built by default is the demo's stage 2 with every gain in its full box and no
criteria constraint (every successful trial is a member of D: ``benchmarks/parafoil_study.py``'s
study); building it is not timed. Such a study states no limits, so the plans are judged by
limits that keep almost no member and most members fail the first criterion judged: a lower
bound of the cost. ``--store`` times the case that matters instead: a D at noise-grounded
limits, e.g. the parafoil demo's stage 2 (``vectorid demo parafoil --out DIR`` writes
``DIR/parafoil-stage2.db``, 5,499 members; its ``data/wind.csv`` is the plans' wind).

Usage::

    .venv/bin/python benchmarks/design.py [--trials 8192] [--members 400] [--store DB]
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import time
from pathlib import Path

import _machine
from parafoil_study import write_study
from vectorid._toml import toml_value
from vectorid.identify.predictor import Predictor
from vectorid.spec import load_study
from vectorid.study import Study
from vectorid.workflows.design import design
from vectorid.workflows.predict import members_of

GOAL_S = 120.0
#: The plans: (name, control times s, left flap, right flap), 120 s from 1,000 m.
PLANS = (
    ("brakes", [0.0, 20.0, 20.1, 35.0, 35.1, 60.0, 60.1, 75.0, 75.1],
     [0, 0, 0.6, 0.6, 0, 0, 0.6, 0.6, 0], [0, 0, 0.6, 0.6, 0, 0, 0.6, 0.6, 0]),
    ("asym-small", [0.0, 20.0, 20.1, 40.0, 40.1, 60.0, 60.1, 80.0, 80.1],
     [0, 0, 0.25, 0.25, 0, 0, 0, 0, 0], [0, 0, 0, 0, 0, 0, 0.25, 0.25, 0]),
    ("asym-large", [0.0, 20.0, 20.1, 40.0, 40.1, 60.0, 60.1, 80.0, 80.1],
     [0, 0, 0.7, 0.7, 0, 0, 0, 0, 0], [0, 0, 0, 0, 0, 0, 0.7, 0.7, 0]),
    ("spiral", [0.0, 20.0, 20.1, 100.0, 100.1], [0, 0, 0.8, 0.8, 0], [0, 0, 0, 0, 0]),
)  # fmt: skip


def write_plans(folder: Path) -> list[Path]:
    """The four plan files (their wind: the demo's sonde, ``data/wind.csv``)."""
    out = []
    for name, t, left, right in PLANS:
        plan = {
            "name": name,
            "initial": {"altitude": 2200.0, "euler": [0.0, 0.0, 0.0]},
            "origin": [32.85, -114.39, 1200.0],
            "duration": 120.0,
            "channels": {"position": 4.0, "velocity": 4.0, "euler": 10.0, "rates": 10.0},
            "wind": "data/wind.csv",
            "wind_format": "dropsonde",
            "wind_options": {"altitude": "altitude_m", "u": "u_ms", "v": "v_ms"},
            "controls": {"time": t, "flap_left": left, "flap_right": right},
        }
        lines = ["[[identification.drops]]"] + [f"{k} = {toml_value(v)}" for k, v in plan.items()]
        path = folder / f"{name}.toml"
        path.write_text("\n".join(lines) + "\n", encoding="utf-8")
        out.append(path)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=8192, help="trials (about 60 % succeed)")
    ap.add_argument("--members", type=int, default=400, help="members flown")
    ap.add_argument(
        "--store", type=Path, default=None,
        help="an existing store whose D lies at noise-grounded limits (the parafoil demo's "
        "parafoil-stage2.db; its folder's data/wind.csv is the plans' wind) instead of one built "
        "without limits",
    )  # fmt: skip
    args = ap.parse_args()
    print(_machine.describe())
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        if args.store is None:
            study = write_study(folder, args.trials)
            store = folder / "stage2.db"
            with Study.create(load_study(study), store) as st:
                st.run(executor="serial", progress=False)
        else:
            store = args.store.resolve()
            wind = store.parent / "data" / "wind.csv"
            if not store.exists() or not wind.exists():
                raise SystemExit(
                    f"--store: expected a store beside data/wind.csv (the parafoil demo's "
                    f"folder), got {store}; run vectorid demo parafoil --out DIR first"
                )
            (folder / "data").mkdir()
            shutil.copy(wind, folder / "data" / "wind.csv")
        with Study.open(store) as st:
            nd = st.analysis().n_feasible
            limited = any(c.limit is not None for c in st.spec.criteria)
        plans = write_plans(folder)
        t0 = time.perf_counter()
        d = design(store, plans, members=args.members, seed=0)
        wall = time.perf_counter() - t0
        # baseline: the model alone, the same members over the same drops
        with Study.open(store) as st:
            pred = Predictor.from_spec(st.spec)
            mem = members_of(st, args.members, 0)
        drops = [pred.read_drops(p)[0] for p in plans]
        t0 = time.perf_counter()
        for dr in drops:
            pred.simulate(pred.parameters(mem.X, dr), dr)
        sim = time.perf_counter() - t0
    print()
    print(f"D: {nd} members; {len(mem)} flown over {len(plans)} plans of 120 s")
    if not limited:
        print(
            "(the study states no criteria limits: the plans' limits keep almost no member, so "
            "this is a lower bound of the cost; --store DB times a D at noise-grounded limits)"
        )
    print("| what | wall (s) | ratio |")
    print("|---|---|---|")
    print(f"| model only (the members over the plans) | {sim:.1f} | 1.00 |")
    print(
        f"| design (fly, limits, each member as truth, verdicts) | {wall:.1f} | {wall / sim:.1f}x |"
    )
    print()
    verdict = "met" if wall <= GOAL_S else "NOT met"
    print(f"goal <= {GOAL_S:g} s: {verdict} ({wall:.1f} s, {wall / GOAL_S:.2f} of the goal)")
    for c in sorted(d.candidates, key=lambda c: c.rank):
        print(f"  {c.rank}. {c.name}: keeps {c.expected_fraction_kept:.1%} of D")


if __name__ == "__main__":
    main()
