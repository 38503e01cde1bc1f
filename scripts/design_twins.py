"""The worth of a planned drop against flying it (issue 34, item 3): a measurement, run from
the repository root (about 12 s a twin on a 2-core machine)::

    .venv/bin/python scripts/design_twins.py --twins 10

parachute6dof twins, three gains (x6, x8, x11) identified from one drop on a Sobol table; two
plans for a second drop from another height, heading and wind — GPS alone (position, 1 Hz) and
the IMU's attitude alone (4 Hz), both 62 s from release — ranked by
``vectorid.workflows.design.design``; then each plan is flown with the truth (its data
generated with the stated noise), the study identified again with both drops on the same
trials (drop 2's criteria those of the plan's sensors: pos_h/pos_v, or roll/pitch; the data's
window starts 2 s after release, at its first GPS sample), and the share of D kept counted.
Printed per twin: (estimated, flown) share kept per plan, and how often the estimate ranks the
plans as flying does — counting apart the twins where flying cannot tell the plans apart (kept
shares within 0.02).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # the twins are the test suite's

from tests.workflows.predict_helpers import drop_file  # noqa: E402
from tests.workflows.test_predict_twins import (  # noqa: E402
    LEVELS,
    NOISE,
    ORIGIN,
    PSEUDO,
    PURE,
    SONDE,
    THREE,
)
from tests.workflows.test_predict_twins import _wind as wind_profile  # noqa: E402

from vectorid import models  # noqa: E402
from vectorid.identify.twins import twin_drop, write_twin, write_wind_csv  # noqa: E402
from vectorid.models import InitialState  # noqa: E402
from vectorid.spec import StudySpec  # noqa: E402
from vectorid.study import Study  # noqa: E402
from vectorid.workflows.design import design  # noqa: E402

PLANS = {"gps": {"position": 1.0}, "imu": {"euler": 4.0}}
#: The criteria the study adds for drop 2 when it is flown with each plan's sensors.
SECOND = {"gps": ("pos_h_abs", "pos_v_abs"), "imu": ("roll_abs", "pitch_abs")}
RATES = {"position": 1.0, "velocity": 1.0, "euler": 4.0, "rates": 4.0}
DURATION = 60.0
TRIALS = 2048


def _spec(folder, i, drops, plan: str | None = None) -> StudySpec:
    """The study on drop 1 (the twins' criteria), and with ``plan`` drop 2 too, its criteria
    restricted to the plan's sensors."""
    crit = [{"name": c} for c in PURE] + [{"name": c, "role": "pseudo"} for c in PSEUDO]
    table = {}
    if plan is not None:
        table = {c: {"use": c, "drops": ["drop1"]} for c in (*PURE, *PSEUDO)}
        for c in SECOND[plan]:
            crit.append({"name": f"{c}_2", "role": "pseudo"})
            table[f"{c}_2"] = {"use": c, "drops": ["drop2"]}
    ident = {"dt": 0.05, "output_dt": 0.25, "init_span": 1.0, "noise": NOISE, "limits": "noise",
             "drops": drops}  # fmt: skip
    if table:
        ident["criteria"] = table
    data = {
        "study": {"name": f"twin{i}", "model": "parachute6dof", "trials": TRIALS, "seed": 1},
        "variables": [{"name": n, "low": lo, "high": hi} for n, lo, hi in THREE],
        "criteria": crit,
        "identification": ident,
    }
    return StudySpec.from_dict(data, base_dir=folder)


def _feasible(spec, path) -> tuple[np.ndarray, np.ndarray]:
    with Study.create(spec, path) as st:
        st.run(executor="inline", progress=False)
        a = st.analysis()
        return a.trials.X, a.feasible


def fly_twin(folder, i: int) -> dict[str, tuple[float, float]]:
    """Per plan: (estimated share of D kept, share kept when flown)."""
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(3400 + i)
    m = models.get("parachute6dof")
    truth = {n: float(rng.uniform(lo, hi)) for n, lo, hi in THREE}
    flights = []
    for k, height in enumerate((800.0, float(rng.uniform(1300.0, 1900.0)))):
        wind = wind_profile(rng)
        ini = InitialState(
            altitude=ORIGIN + height,
            velocity=(float(rng.normal(0, 2)), float(rng.normal(0, 2)), 7.0),
            euler=(*rng.normal(0.0, 0.1, 2), float(rng.uniform(-np.pi, np.pi))),
            rates=tuple(rng.normal(0.0, 0.05, 3)),
        )
        write_wind_csv(wind, folder / f"wind{k + 1}.csv", LEVELS)
        flights.append((ini, wind))
    # drop 1 (30 s of data) and the study identified from it
    ini, wind = flights[0]
    f1 = twin_drop(m, truth, initial=ini, duration=34.0, noise=NOISE, seed=1000 * i,
                   wind=wind, origin_altitude=ORIGIN)  # fmt: skip
    drop1 = {"name": "drop1", "files": write_twin(f1, folder, "drop1"), "wind": "wind1.csv",
             **SONDE, "window": [2.0, 32.0]}  # fmt: skip
    X1, D1 = _feasible(_spec(folder, i, [drop1]), folder / "one.db")
    # the plans: the second drop's conditions, two sensor sets
    ini2, wind2 = flights[1]
    plans = []
    for name, channels in PLANS.items():
        plans.append(drop_file(folder / f"{name}.toml", [{
            "name": "drop2", "initial": {"altitude": ini2.altitude, "velocity": list(ini2.velocity),
                                         "euler": list(ini2.euler), "rates": list(ini2.rates)},
            "origin_altitude": ORIGIN, "duration": DURATION + 2.0, "channels": channels,
            "wind": "wind2.csv", **SONDE, "noise": NOISE}]))  # fmt: skip
    est = design(folder / "one.db", plans, members=300, seed=i)
    out = {}
    # flying: drop 2's data, the study identified again with both drops on the same trials
    f2 = twin_drop(m, truth, initial=ini2, duration=DURATION + 4.0, noise=NOISE,
                   seed=1000 * i + 1, wind=wind2, origin_altitude=ORIGIN, rates=RATES)  # fmt: skip
    files2 = write_twin(f2, folder, "drop2")
    for c in est.candidates:
        drop2 = {
            "name": "drop2",
            "files": files2,
            "wind": "wind2.csv",
            **SONDE,
            "window": [2.0, 2.0 + DURATION],
        }  # fmt: skip (its criteria: the plan's sensors only)
        X2, D2 = _feasible(_spec(folder, i, [drop1, drop2], c.name), folder / f"two-{c.name}.db")
        assert np.array_equal(X1, X2)
        kept = float((D1 & D2).sum() / max(D1.sum(), 1))
        out[c.name] = (c.expected_fraction_kept, kept)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--twins", type=int, default=10, help="how many twins (default 10)")
    args = ap.parse_args()
    agree = distinct = 0
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.twins):
            t0 = time.time()
            r = fly_twin(Path(tmp) / f"t{i}", i)
            (eg, fg), (ei, fi) = r["gps"], r["imu"]
            tie = abs(fg - fi) < 0.02
            ok = tie or ((eg < ei) == (fg < fi))
            distinct += not tie
            agree += ok and not tie
            print(f"twin {i}: gps est {eg:.3f} flown {fg:.3f}; imu est {ei:.3f} flown {fi:.3f}"
                  f" -> {'flying ties' if tie else ('agree' if ok else 'DISAGREE')}"
                  f" ({time.time() - t0:.0f} s)", flush=True)  # fmt: skip
    print(f"flying told the plans apart in {distinct} of {args.twins} twins; the estimate "
          f"ranked them as flying did in {agree} of those {distinct}")  # fmt: skip


if __name__ == "__main__":
    main()
