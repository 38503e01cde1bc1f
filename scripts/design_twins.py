"""The worth of a planned drop against flying it (issue 34, item 3): a measurement, run from
the repository root (about 25 s a twin on a 2-core machine)::

    .venv/bin/python scripts/design_twins.py --twins 10

parachute6dof twins, three gains (x6, x8, x11) identified from one drop on a Sobol table of
2,048 trials (GPS, GPS velocity, IMU; noise-grounded limits); two plans for a second drop of
60 s from another height, heading and wind, carrying different sensors:

- ``gps``: the GPS position alone, 1 Hz;
- ``imu``: the GPS velocity, a barometric altitude (σ 3 m) and the IMU (attitude, rates), no
  GPS position;
- ``short``: the GPS position and velocity and the IMU, but 20 s instead of 60 s.

All at 4 Hz. Whether 60 s of the IMU without the GPS position tells D's members apart better
than 20 s of every sensor is not known in advance; the GPS alone leaves the attitude and rates
of the start unfitted (the study takes them as 0), which the estimate should see as a plan
that would reject the truth (flying it would empty D).

:func:`vectorid.workflows.design.design` estimates each plan's share of D kept (300 members
of D). Then each plan is **flown** with the truth: its data are generated with the stated noise
for the plan's sensors only, at the plan's rates, and the study is identified again with both
drops on the same trials — drop 1's criteria on drop 1, and on drop 2 the study's criteria
that read the plan's sensors (the criteria the estimate judged it by), every limit the noise
floor at the study's joint 95 % coverage, the initial state of drop 2 fitted to its own noisy
first seconds. The share of D kept is |D₁ ∩ D₁₂| / |D₁|.

Flying tells two plans apart when their kept shares differ by more than twice the binomial
standard error of that difference over D₁'s members and by more than 0.02; a twin agrees when
the estimate orders every pair that flying tells apart as flying does (by the share kept).
Twins where flying tells no pair apart are counted separately (they cannot disagree).
"""

from __future__ import annotations

import argparse
import math
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
from vectorid.identify.flight import FlightChannel, FlightData  # noqa: E402
from vectorid.identify.twins import twin_drop, write_twin, write_wind_csv  # noqa: E402
from vectorid.models import InitialState  # noqa: E402
from vectorid.spec import StudySpec  # noqa: E402
from vectorid.study import Study  # noqa: E402
from vectorid.workflows.design import design  # noqa: E402

#: The plans' sensors (Hz) and the noise of the barometric altitude (m).
PLANS = {
    "gps": {"position": 4.0, "velocity": 4.0},
    "imu": {"velocity": 4.0, "altitude": 4.0, "euler": 4.0, "rates": 4.0},
    "short": {"position": 4.0, "velocity": 4.0, "euler": 4.0, "rates": 4.0},
}
#: Each plan's duration, s.
DURATIONS = {"gps": 60.0, "imu": 60.0, "short": 20.0}
ALTITUDE_NOISE = 3.0
RATES = {"position": 4.0, "velocity": 4.0, "euler": 4.0, "rates": 4.0}
DURATION = 60.0
TRIALS = 2048
MEMBERS = 300


def _spec(folder, i, drops, second: list[str] | None = None) -> StudySpec:
    """The study on drop 1 (the twins' criteria); with ``second`` (library criteria) drop 2
    too, those criteria on drop 2 alone and the first ones on drop 1 alone."""
    crit = [{"name": c} for c in PURE] + [{"name": c, "role": "pseudo"} for c in PSEUDO]
    table = {}
    if second is not None:
        table = {c: {"use": c, "drops": ["drop1"]} for c in (*PURE, *PSEUDO)}
        for c in second:
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


def _flown_data(flight: FlightData, plan: str) -> FlightData:
    """The plan's sensors only, from the twin's record: the GPS position, or an altitude
    (the GPS height's noise is the barometer's, σ 3 m) and the attitude."""
    chans = {}
    for ch in PLANS[plan]:
        if ch == "altitude":
            p = flight["position"]
            chans[ch] = FlightChannel(ch, p.t, -p.values[:, 2:3], ("altitude",), "m")
        else:
            chans[ch] = flight[ch]
    return FlightData(f"{flight.name}-{plan}", chans, dict(flight.events), flight.origin)


def _files(flight: FlightData, folder: Path, stem: str) -> list[dict]:
    files = write_twin(flight, folder, stem)
    for f in files:  # a twin has no spikes (at 1 Hz a fast first sample can look like one)
        f["mapping"]["spikes"] = "keep"
        if "altitude" in f["mapping"]:  # the altitude is above the origin
            f["mapping"]["altitude"]["reference"] = "origin"
    return files


def fly_twin(folder: Path, i: int) -> dict:
    """Per plan: estimated share kept (with its interval) and the share kept when flown,
    and the size of D₁."""
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
    noise2 = {**NOISE, "altitude": ALTITUDE_NOISE}
    files = []
    for name, channels in PLANS.items():
        files.append(drop_file(folder / f"{name}.toml", [{
            "name": "drop2", "initial": {"altitude": ini2.altitude, "velocity": list(ini2.velocity),
                                         "euler": list(ini2.euler), "rates": list(ini2.rates)},
            "origin_altitude": ORIGIN, "duration": DURATIONS[name], "channels": channels,
            "wind": "wind2.csv", **SONDE, "noise": noise2}]))  # fmt: skip
    t0 = time.time()
    est = design(folder / "one.db", files, members=MEMBERS, seed=i)
    t_design = time.time() - t0
    # flying: drop 2's data, the study identified again with both drops on the same trials
    f2 = twin_drop(m, truth, initial=ini2, duration=DURATION + 4.0, noise=NOISE,
                   seed=1000 * i + 1, wind=wind2, origin_altitude=ORIGIN, rates=RATES)  # fmt: skip
    out = {"n_d1": int(D1.sum()), "design_s": t_design, "plans": {}}
    for c in est.candidates:
        data = _flown_data(f2, c.name)
        drop2 = {"name": "drop2", "files": _files(data, folder, f"drop2-{c.name}"),
                 "wind": "wind2.csv", **SONDE, "window": [0.0, DURATIONS[c.name]],
                 "origin_altitude": ORIGIN,
                 "noise": {"altitude": ALTITUDE_NOISE}}  # fmt: skip
        second = [k.rsplit("@", 1)[0] for k in c.criteria]
        X2, D2 = _feasible(_spec(folder, i, [drop1, drop2], second), folder / f"two-{c.name}.db")
        assert np.array_equal(X1, X2)
        kept = float((D1 & D2).sum() / max(D1.sum(), 1))
        out["plans"][c.name] = {
            "estimate": c.expected_fraction_kept,
            "interval": c.interval,
            "flown": kept,
            "criteria": second,
            "truth_kept": c.truth_kept,
            "rejects_truth": c.rejects_truth,
        }
    return out


def _apart(a: dict, b: dict, n: int) -> bool:
    """Whether flying tells two plans apart: their kept shares differ by more than twice the
    binomial standard error of the difference over D₁'s ``n`` members, and by more than 0.02."""
    se = math.sqrt((a["flown"] * (1 - a["flown"]) + b["flown"] * (1 - b["flown"])) / max(n, 1))
    return abs(a["flown"] - b["flown"]) > max(2 * se, 0.02)


def judge(r: dict) -> str:
    """'tie' (flying tells no two plans apart), 'agree' (the estimate orders every pair that
    flying tells apart as flying does) or 'disagree'."""
    p = list(r["plans"].values())
    pairs = [(a, b) for k, a in enumerate(p) for b in p[k + 1 :] if _apart(a, b, r["n_d1"])]
    if not pairs:
        return "tie"
    same = all((a["estimate"] < b["estimate"]) == (a["flown"] < b["flown"]) for a, b in pairs)
    return "agree" if same else "disagree"


def run(twins: int, folder: Path, out=None) -> list[dict]:
    """Fly ``twins`` twins under ``folder``; print a line each; return their results."""
    out = out or (lambda line: print(line, flush=True))
    results = []
    for i in range(twins):
        t0 = time.time()
        r = fly_twin(folder / f"t{i}", i)
        r["verdict"] = judge(r)
        results.append(r)
        p = r["plans"]
        out(
            f"twin {i}: |D1| {r['n_d1']}; "
            + "; ".join(
                f"{k} est {v['estimate']:.3f} [{v['interval'][0]:.3f}, {v['interval'][1]:.3f}] "
                f"flown {v['flown']:.3f}"
                for k, v in p.items()
            )
            + f" -> {r['verdict']}"
            + "".join(f"; {k} rejects the truth" for k, v in p.items() if v["rejects_truth"])
            + f" (design {r['design_s']:.0f} s, twin {time.time() - t0:.0f} s)"
        )
    return results


def summary(res: list[dict]) -> dict:
    """Counts over the twins: how many flying told apart, how many of those the estimate
    ordered as flying did; how often a plan the estimate says would reject the truth emptied
    D when flown (kept 0), and how often a plan it calls sound did; the pairs of sound plans
    flying told apart, and how many of them the estimate ordered as flying did."""
    apart = [r for r in res if r["verdict"] != "tie"]
    plans = [v for r in res for v in r["plans"].values()]
    # the pairs of sound plans (neither said to reject the truth) that flying told apart
    sound_pairs = []
    for r in res:
        p = [v for v in r["plans"].values() if not v["rejects_truth"]]
        sound_pairs += [(a, b) for k, a in enumerate(p) for b in p[k + 1 :]
                        if _apart(a, b, r["n_d1"])]  # fmt: skip
    rej = [v for v in plans if v["rejects_truth"]]
    sound = [v for v in plans if not v["rejects_truth"]]
    return {
        "twins": len(res),
        "apart": len(apart),
        "agree": sum(r["verdict"] == "agree" for r in apart),
        "rejects": len(rej),
        "rejects_emptied": sum(v["flown"] == 0.0 for v in rej),
        "sound": len(sound),
        "sound_emptied": sum(v["flown"] == 0.0 for v in sound),
        "sound_pairs_apart": len(sound_pairs),
        "sound_pairs_agree": sum(
            (a["estimate"] < b["estimate"]) == (a["flown"] < b["flown"]) for a, b in sound_pairs
        ),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--twins", type=int, default=10, help="how many twins (default 10)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        s = summary(run(args.twins, Path(tmp)))
    print(
        f"flying told the plans apart in {s['apart']} of {s['twins']} twins; the estimate "
        f"ordered them as flying did in {s['agree']} of those {s['apart']}; plans said to reject "
        f"the truth: {s['rejects']}, of which flying emptied D in {s['rejects_emptied']}; sound "
        f"plans: {s['sound']}, of which flying emptied D in {s['sound_emptied']}; pairs of "
        f"sound plans flying told apart: {s['sound_pairs_apart']}, ordered as flying did: "
        f"{s['sound_pairs_agree']}"
    )


if __name__ == "__main__":
    main()
