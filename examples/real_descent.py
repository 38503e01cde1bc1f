"""Identify the drogue and main parachute drag coefficients of a real rocket descent.

Usage::

    python examples/real_descent.py PATH/TO/2022-06-24-serial-6583-flight-0003-TeleMega.csv \
        [--trials 1024] [--out real-descent]

The flight: the Prometheus sounding rocket (Spaceport America, 2022-06-24), TeleMega log of
the shared data (``../shared/data/prometheus-2022/``). After burn-out the rocket (13.9 kg dry
without motor + 2.981 kg motor casing = 16.881 kg) descends under a 24-in drogue from apogee,
then under the 72-in main (deployed at 1500 ft above ground) with the drogue still attached.

The model is :class:`vectorid.identify.descent.RocketDescent` (``"rocket-descent"``): a point
mass with drag area C_D,d S_d (+ C_D,m S_m once the main is out), in ISA air, with the wind
ignored horizontally (only the barometric altitude is compared). Each descent phase is a
"drop" of its own (a window of the log) with its own design variable and box:

- ``drogue``: from 5 s after the drogue event to 1 s before the main event, main stowed;
- ``main``: from 6 s after the main event (inflated) to 2 s before landing.

Criteria (pure): altitude residual ∫|h - ĥ| dt and vertical-speed residual ∫|h' - ĥ'| dt, per
phase (four criteria). The barometric heights are pressure-altitude differences; on a hot day
they under-read geometric heights by T_ISA / T (the GPS heights show it), so the coefficients
identified in ISA air are too large by about that ratio: the script reports them as identified
and corrected by the GPS/baro height ratio.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from vectorid.identify import load_telemega
from vectorid.identify.descent import INCH
from vectorid.spec import StudySpec
from vectorid.study import Study

NOMINAL = {"cd_drogue": 1.6, "cd_main": 2.2}
MASS = 13.9 + 2.981  # kg after burn-out (data README)
BOXES = {"cd_drogue": (0.5, 3.5), "cd_main": (0.8, 4.5)}
CRITERIA = {
    "alt_drogue": ("alt_abs", "drogue"),
    "vz_drogue": ("vz_abs", "drogue"),
    "alt_main": ("alt_abs", "main"),
    "vz_main": ("vz_abs", "main"),
}


def pad_pressure_altitude(flight) -> float:
    """ISA pressure altitude of the pad (m) from the first pressure samples."""
    p = float(np.median(flight["pressure"].values[:20, 0]))
    return 44_330.8 * (1.0 - (p / 101_325.0) ** 0.190263)


def baro_scale(flight) -> float:
    """Ratio of GPS to barometric height gains over the descent (≈ T / T_ISA)."""
    t0, t1 = flight.events["drogue"] + 5.0, flight.events["landed"] - 2.0
    g = flight["gps_altitude"]
    sel = (g.t >= t0) & (g.t <= t1)
    t = g.t[sel]
    gps = g.values[sel, 0]
    baro = flight["altitude"].at(t)[:, 0]
    A = np.stack([baro, np.ones_like(baro)], axis=1)
    coef, *_ = np.linalg.lstsq(A, gps, rcond=None)
    return float(coef[0])


def study(path: str | Path, trials: int = 1024, seed: int = 1) -> StudySpec:
    """The identification study of the real descent (a StudySpec with [identification])."""
    path = Path(path).resolve()
    flight = load_telemega(path)
    origin = pad_pressure_altitude(flight)
    drops = []
    for name, window, main in (
        ("drogue", ["drogue+5", "main-1"], 0.0),
        ("main", ["main+6", "landed-2"], 1.0),
    ):
        drops.append(
            {
                "name": name,
                "file": str(path),
                "format": "telemega",
                "window": window,
                "inputs": {"main": main},
                "origin_altitude": origin,
            }
        )
    data = {
        "study": {
            "name": "prometheus-descent",
            "model": "rocket-descent",
            "trials": trials,
            "seed": seed,
            "executor": "serial",
        },
        "variables": [
            {"name": k, "low": lo, "high": hi, "nominal": NOMINAL[k]}
            for k, (lo, hi) in BOXES.items()
        ],
        "criteria": [{"name": k, "role": "pure"} for k in CRITERIA],
        "identification": {
            "dt": 0.05,
            "output_dt": 0.5,
            "init_span": 2.0,
            "model_options": {
                "mass": MASS,
                "drogue_diameter": 24 * INCH,
                "main_diameter": 72 * INCH,
            },
            "drops": drops,
            "criteria": {k: {"use": use, "drops": [d]} for k, (use, d) in CRITERIA.items()},
        },
    }
    return StudySpec.from_dict(data, base_dir=path.parent)


def identify(path: str | Path, store: str | Path, trials: int = 1024) -> dict:
    """Run the study and summarise: Pareto spread, chosen vector, residuals."""
    from vectorid.analysis.choice import suggest_choice
    from vectorid.identify import Identification
    from vectorid.identify.twostep import auto_limits

    spec = study(path, trials)
    store = Path(store)
    if store.exists():
        store.unlink()
    with Study.create(spec, store) as st:
        st.run(trials=trials, executor="serial")
        limits = auto_limits(st.analysis(), quantile=0.1, min_feasible=10)
        a = st.analysis(limits)
        X = a.trials.X[a.pareto]
        cid = suggest_choice(a)
        i = int(np.flatnonzero(a.trials.id == cid)[0])
        chosen = dict(zip(spec.space.names, a.trials.X[i].tolist()))
        out = {
            "n": a.n,
            "n_feasible": a.n_feasible,
            "n_pareto": a.n_pareto,
            "limits": limits,
            "chosen_id": cid,
            "chosen": chosen,
            "pareto_min": dict(zip(spec.space.names, X.min(axis=0).tolist())),
            "pareto_max": dict(zip(spec.space.names, X.max(axis=0).tolist())),
            "criteria": dict(zip(a.crit_names, a.trials.F[i].tolist())),
        }
    ident = Identification.from_spec(spec)
    x = np.array([chosen[n] for n in spec.space.names])
    resid = {}
    for d in ident.drops:
        res = ident.simulate(x[None, :], d)
        h = -res.position[0, :, 2] - d.origin_altitude
        e = h - d.measured("altitude")[:, 0]
        resid[d.name] = {
            "rms": float(np.sqrt(np.mean(e**2))),
            "max": float(np.abs(e).max()),
            "end": float(e[-1]),
            "duration": d.duration,
        }
    out["residuals"] = resid
    out["baro_scale"] = baro_scale(load_telemega(path))
    out["origin_pressure_altitude"] = ident.drops[0].origin_altitude
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("path", help="the TeleMega CSV of the Prometheus flight")
    ap.add_argument("--trials", type=int, default=1024)
    ap.add_argument("--out", default="real-descent", help="folder of the store")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    r = identify(args.path, out / "prometheus-descent.db", args.trials)
    print(
        f"N = {r['n']}   ND = {r['n_feasible']}   NP = {r['n_pareto']}   "
        f"(pad pressure altitude {r['origin_pressure_altitude']:.0f} m)"
    )
    print(
        "criteria constraints (10 % quantile of each criterion): "
        + ", ".join(f"{n} <= {v:.4g}" for n, v in r["limits"].items())
    )
    k = r["baro_scale"]
    print(f"GPS/baro height ratio {k:.4f} (T/T_ISA): ISA-identified C_D are high by about it")
    print(
        f"{'':<10} {'chosen':>8} {'Pareto min':>11} {'Pareto max':>11} {'corrected':>10} "
        f"{'nominal':>8}  drag area (m²)"
    )
    areas = {"cd_drogue": np.pi * (24 * INCH) ** 2 / 4, "cd_main": np.pi * (72 * INCH) ** 2 / 4}
    for n in ("cd_drogue", "cd_main"):
        c = r["chosen"][n]
        print(
            f"{n:<10} {c:>8.3f} {r['pareto_min'][n]:>11.3f} {r['pareto_max'][n]:>11.3f} "
            f"{c / k:>10.3f} {NOMINAL[n]:>8.2f}  {c * areas[n]:.3f}"
        )
    print("altitude residuals of the chosen vector (model - baro height):")
    for name, e in r["residuals"].items():
        print(
            f"  {name:<7} RMS {e['rms']:6.2f} m   max {e['max']:6.2f} m   at the end "
            f"{e['end']:+7.2f} m   over {e['duration']:.0f} s"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
