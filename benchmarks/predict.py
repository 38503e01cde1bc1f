"""Prediction benchmark: 1,000 members of the parachute model over a 120-s planned drop.

Goal (issue 33): ``vectorid.workflows.predict.predict`` of 1,000 members of ``parachute6dof``
over a 120-s drop with 4-Hz outputs (position, velocity, Euler angles and body rates, the
with-noise bands of all four, the landing dispersion with its bootstrap) in at most 10 s on 2
cores after compilation. Baseline measured in the same run: the model alone flying the same
1,000 parameter vectors over the same drop (one ``model.simulate`` call), so the ratio says
what the statistics cost beside the simulation.

The store is a parachute twin identified on a plain Sobol table of 2,048 trials of three
parameters without criteria constraints (every successful trial is a member of D), so that D
holds more than 1,000 members; building it is not timed.

Usage::

    .venv/bin/python benchmarks/predict.py [--members 1000] [--repeat 3]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

import _machine
from vectorid import models
from vectorid._toml import toml_value
from vectorid.identify.twins import twin_drop, write_twin, write_wind_csv
from vectorid.models import InitialState, WindProfile
from vectorid.spec import StudySpec
from vectorid.study import Study
from vectorid.workflows.predict import BOOTSTRAP, predict

ORIGIN = 1200.0
NOISE = {"position_h": 1.5, "position_v": 3.0, "velocity": 0.15, "euler_deg": 0.5, "rates": 0.01}
WIND = WindProfile.from_speed_direction(
    ORIGIN + np.array([0.0, 500.0, 2500.0]), [3.0, 6.0, 9.0], [240.0, 255.0, 270.0]
)
GOAL_S = 10.0


def make_store(folder: Path) -> Path:
    m = models.get("parachute6dof")
    truth = {"x6": 0.5, "x8": 1.2, "x11": 0.08}
    ini = InitialState(altitude=ORIGIN + 800.0, velocity=(2.0, 1.0, 7.0))
    fl = twin_drop(m, truth, initial=ini, duration=34.0, noise=NOISE, seed=1, wind=WIND,
                   origin_altitude=ORIGIN)  # fmt: skip
    files = write_twin(fl, folder, "drop")
    write_wind_csv(WIND, folder / "wind.csv", ORIGIN + np.arange(0.0, 2501.0, 100.0))
    sonde = {"wind_format": "dropsonde",
             "wind_options": {"altitude": "altitude_m", "u": "u_ms", "v": "v_ms"}}  # fmt: skip
    data = {
        "study": {"name": "bench", "model": "parachute6dof", "trials": 2048, "seed": 1},
        "variables": [
            {"name": "x6", "low": 0.3, "high": 0.7},
            {"name": "x8", "low": 0.9, "high": 1.5},
            {"name": "x11", "low": 0.05, "high": 0.11},
        ],
        "criteria": [{"name": "pos_h_abs"}, {"name": "pos_v_abs"}],
        "identification": {
            "dt": 0.05,
            "output_dt": 0.25,
            "noise": NOISE,
            "drops": [
                {
                    "name": "drop",
                    "files": files,
                    "wind": "wind.csv",
                    **sonde,
                    "window": [2.0, 32.0],
                },
            ],
        },
    }
    store = folder / "bench.db"
    with Study.create(StudySpec.from_dict(data, base_dir=folder), store) as st:
        st.run(executor="inline", progress=False)
    planned = {
        "name": "planned", "initial": {"altitude": ORIGIN + 800.0, "euler": [0.0, 0.0, 1.0]},
        "origin_altitude": ORIGIN, "duration": 120.0, "wind": "wind.csv", **sonde,
        "channels": {"position": 4.0, "velocity": 4.0, "euler": 4.0, "rates": 4.0},
        "noise": NOISE,
    }  # fmt: skip
    lines = ["[[identification.drops]]"] + [f"{k} = {toml_value(v)}" for k, v in planned.items()]
    (folder / "planned.toml").write_text("\n".join(lines) + "\n", encoding="utf-8")
    return store


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--members", type=int, default=1000)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    print(_machine.describe())
    m = models.get("parachute6dof")
    m.compile()  # compilation is not timed
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        store = make_store(folder)
        drop = folder / "planned.toml"
        predict(store, drop, members=50)  # warm: imports, the statistics' first calls
        walls = []
        for r in range(args.repeat):
            t0 = time.perf_counter()
            p = predict(store, drop, members=args.members, seed=r)
            walls.append(time.perf_counter() - t0)
        d = p.drops[0]
        # baseline: the model alone, the same vectors over the same drop
        from vectorid.identify.predictor import Predictor

        pred = Predictor.from_spec(Study.open(store).spec)
        (planned,) = pred.read_drops(drop)
        P = pred.parameters(p.members.X, planned)
        sims = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            pred.simulate(P, planned)
            sims.append(time.perf_counter() - t0)
    wall, sim = min(walls), min(sims)
    T = d.channels[0].t.size
    print()
    print(
        f"{len(p.members)} members of D (of {p.members.n_set}), {d.duration:g} s at 4 Hz ({T} "
        f"samples) x 4 channels, with-noise bands, landing with a {BOOTSTRAP}-resample bootstrap"
    )
    print(f"| what | wall (s), best of {args.repeat} | ratio |")
    print("|---|---|---|")
    print(f"| model only (one simulate call) | {sim:.2f} | 1.00 |")
    print(f"| predict (members, flight, bands, checks, landing) | {wall:.2f} | {wall / sim:.1f}x |")
    print()
    verdict = "met" if wall <= GOAL_S else "NOT met"
    print(
        f"goal <= {GOAL_S:g} s: {verdict} ({wall:.2f} s, {wall / GOAL_S:.2f} of the goal); "
        f"landing R50/R90/R95 {d.dispersion.radii['r50']:.1f}/{d.dispersion.radii['r90']:.1f}/"
        f"{d.dispersion.radii['r95']:.1f} m"
    )


if __name__ == "__main__":
    main()
