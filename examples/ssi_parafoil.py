"""What two real parafoil drops of unknown mass and canopy can tell: wing loading and glide.

Usage::

    python examples/ssi_parafoil.py [PATH/TO/shared/data/ssi-parafoil] [--trials 2048]
        [--budget 20000] [--out ssi-parafoil]

The drops: Stanford SSI's balloon payload under a parafoil, 2018-05-19 (data README in
``../shared/data/ssi-parafoil/``): barometric pressure altitude at 14 Hz and GPS latitude /
longitude (a new fix about once a second), from 78 m and 247 m above the ground at 6-7 m/s;
no mass, canopy size, airspeed, wind or control record, and the payload turns continuously.

The model is ``parafoil6dof`` with a small canopy of the ETH test vehicle's class (1.5 m²,
the stated set of ``examples/eth_parafoil.py``, the library's
:data:`vectorid.models.stated_parafoil.ETH_PARAFOIL`) standing in for the unknown one.
Design variables, with both drops at once (criteria averaged over them):

* ``payload_mass`` (kg): with the canopy area fixed it is the wing loading
  W/S = (m_c + m_p) g / S (printed in N/m²);
* the ``CD0`` gain: the glide (zero-lift drag of canopy and lines);
* per drop, the unknown uniform wind (north, east).

Criteria (pure): the altitude residual ∫|Δh| dt and the horizontal position residual
∫|ΔP_H| dt. Their constraints are noise-grounded as in ``examples/eth_parafoil.py``: each
drop's barometer and GPS noise estimated from its data (``noise = "estimate"``), the noise
floors of a perfect model under it, and a discrepancy allowance for the wind the model flies
as uniform — from the ETH authors' low-level gust model (no wind model is stated for these
drops; it is a stand-in, named as such: :data:`vectorid.identify.gusts.ETH_GUSTS`), over the
height each drop descends. Both drops are one batch model, the library's several-flights
identification (:class:`vectorid.identify.multiflight.MultiFlight`). The study runs
through the library's stage driver (``vectorid.workflows.stages.run_stage``) on the sequential
sampler: ``trials`` Sobol points, then generations that move into D at these limits until it
holds 200 members or ``budget`` evaluations are spent. Where D is not reached, the sampler
says how far it got and a local search from the best trials says by how much the model misses
(or that the box is too narrow, when it ends on the box's edge); only then are the limits
relaxed, as the named last resort, and the factor is printed. It prints the identifiability verdicts
(``vectorid.analysis.identifiability``) and which quantities the data determine and which
they do not: the sink rate fixes only a combination of wing loading and drag (a ridge in the
feasible set), and without airspeed or wind the glide ratio is not separable from the wind.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from vectorid.analysis.weights import trial_weights, weighted_pearson
from vectorid.identify import FlightChannel, FlightData
from vectorid.identify.gusts import ETH_GUSTS, gust_allowance
from vectorid.identify.multiflight import MultiFlight
from vectorid.identify.noise import estimate_noise
from vectorid.models.stated_parafoil import ETH_PARAFOIL
from vectorid.problem import Criterion
from vectorid.space import Continuous, Space
from vectorid.spec import StudySpec

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_DATA = ROOT.parent / "shared" / "data" / "ssi-parafoil"
DROPS = (1, 2)
BOXES = {"payload_mass": (0.5, 30.0), "CD0": (0.3, 10.0)}
WIND_BOX = (-15.0, 15.0)


def load(path: Path, drop: int) -> FlightData:
    """One drop: pressure altitude, and the GPS track (new fixes only) in a local frame."""
    import pymap3d

    d = np.genfromtxt(path, delimiter=",", names=True)
    s = d[d["drop"] == drop]
    t = s["t_s"]
    alt = FlightChannel("altitude", t, s["alt_m"][:, None], ("altitude",), "m")
    fix = np.isfinite(s["lat_deg"]) & np.isfinite(s["lon_deg"])
    lat, lon, tf, h = s["lat_deg"][fix], s["lon_deg"][fix], t[fix], s["alt_m"][fix]
    new = np.concatenate([[True], (np.diff(lat) != 0) | (np.diff(lon) != 0)])
    lat, lon, tf, h = lat[new], lon[new], tf[new], h[new]
    n, e, _ = pymap3d.geodetic2ned(lat, lon, 0.0 * lat, lat[0], lon[0], 0.0)
    pos = FlightChannel("position", tf, np.column_stack([n, e, -h]), ("north", "east", "down"), "m")
    return FlightData(f"drop{drop}", {"altitude": alt, "position": pos}, {}, None)


def two_drops(flights: dict[str, FlightData]) -> MultiFlight:
    """Batch model: (payload_mass, CD0 gain, wind per drop) -> criteria averaged over the drops,
    each drop compared where its altitude and GPS records overlap."""
    options = ETH_PARAFOIL.model_options(
        extra_parameters=("payload_mass", "wind_north", "wind_east")
    )
    table = {"model": "parafoil6dof", "model_options": options, "dt": 0.02, "output_dt": 0.2,
             "init_span": 1.0}  # fmt: skip
    return MultiFlight.from_flights(
        flights, table, ("payload_mass", "CD0"), ["alt_abs", "pos_h_abs"],
        window_channels=("position", "altitude"), drop={"origin_altitude": 0.0},
    )  # fmt: skip


#: The model of the study being run: the study file names ``ssi_parafoil:evaluate`` (a module-level
#: function, so the store can name it), which evaluates this object.
_CURRENT: MultiFlight | None = None


def evaluate(X: np.ndarray) -> np.ndarray:
    """The study's batch model: criteria (n, 2) averaged over the flights of ``_CURRENT``."""
    if _CURRENT is None:
        raise RuntimeError("no model is being identified; call identify() first")
    return _CURRENT(X)


MEANINGS = {
    "payload_mass": "payload mass = wing loading on the stand-in canopy",
    "CD0": "zero-lift drag gain (x the stand-in's c_D0)",
}
UNITS = {"payload_mass": "kg", "CD0": "-"}


def run(
    model: MultiFlight,
    store: Path,
    trials: int,
    limits: dict | None,
    name: str = "ssi",
    budget: int = 20_000,
):
    """One PSI study of the two drops under ``limits`` (criterion -> (limit, note) from the
    noise floors), through the library's stage driver on the sequential sampler (``trials``
    Sobol points first, at most ``budget`` evaluations)."""
    from vectorid.workflows.stages import run_stage

    global _CURRENT
    _CURRENT = model
    boxes = {**BOXES, **{v: WIND_BOX for v in model.variables if v.startswith("wind_")}}
    space = Space([Continuous(v, *boxes[v], unit=UNITS.get(v, "m/s")) for v in model.variables])
    crit = []
    for c in ("alt", "pos_h"):
        lim, note = (limits or {}).get(c, (None, ""))
        src = "noise" if lim is not None else ""
        crit.append(Criterion(c, unit="m·s", limit=lim, limit_source=src, limit_note=note))
    spec = StudySpec(
        name=name, model=evaluate, space=space, criteria=tuple(crit),
        trials=trials, seed=1, executor="inline",
    )  # fmt: skip
    meanings = {**MEANINGS, **{v: "uniform wind of the drop, m/s" for v in model.variables
                               if v.startswith("wind_")}}  # fmt: skip
    return run_stage(spec, store, trials=trials, name=name, meanings=meanings, hints={},
                     sampler="sequential", budget=budget)  # fmt: skip


#: Study criterion name of each library criterion.
STUDY_NAMES = {"alt_abs": "alt", "pos_h_abs": "pos_h"}


def _errors(model: MultiFlight, x: np.ndarray) -> dict[str, tuple[float, float, float]]:
    """Per drop: RMS altitude error (m), RMS horizontal error (m), duration (s)."""
    return {
        n: (e["altitude"], e["horizontal"], e["duration"]) for n, e in model.rms_errors(x).items()
    }


def identify(
    folder: str | Path, out: str | Path, trials: int = 2048, budget: int = 20_000
) -> dict:
    """Both drops at once; ``trials``: the first generation (Sobol points), ``budget``: the
    sequential sampler's evaluations at most."""
    folder, out = Path(folder), Path(out)
    out.mkdir(parents=True, exist_ok=True)
    path = folder / "parafoildata_clean.csv"
    flights = {f"drop{k}": load(path, k) for k in DROPS}
    model = two_drops(flights)
    durations, sink = {}, {}
    for n, ident in model.idents.items():
        d = ident.drops[0]
        durations[n] = float(d.grid[-1] - d.grid[0])
        h = d.measured("altitude")[:, 0]
        sink[n] = float((h[0] - h[-1]) / durations[n])
    gust = gust_allowance(durations, ETH_GUSTS, sink=sink)
    allowance = {
        n: {"position_h": g["position_h"], "altitude": g["position_v"]} for n, g in gust.items()
    }
    chans = ("altitude", "position")
    # drop 1 has 12 GPS fixes, too few for the estimator: its receiver's white noise is
    # estimated on drop 2 (the same receiver, 41 fixes)
    est = {n: estimate_noise(i.drops[0].flight, list(chans)) for n, i in model.idents.items()}
    borrowed = {}
    for n, nm in est.items():
        for m, other in est.items():
            missing = [c for c in chans if nm.component(c, 0) is None]
            if m != n and missing and all(other.component(c, 0) is not None for c in missing):
                est[n] = other.merged(nm)
                borrowed[n] = (m, missing)
    lim, noise = model.noise_limits(allowance, channels=chans, noise=est)
    limits = {STUDY_NAMES[n]: v for n, v in lim.items()}
    st = run(model, out / "ssi-drops.db", trials, limits, budget=budget)
    best = st.result
    a = best.analysis
    x = np.array([best.chosen[v] for v in model.variables]) if best.chosen else None
    Xd = a.trials.X[a.feasible]
    m_c = model.idents["drop1"].model.geometry.canopy_mass
    area = model.idents["drop1"].model.geometry.area
    load_ws = (m_c + Xd[:, 0]) * 9.80665 / area
    ridge = len(Xd) > 2
    # the sequential sampler's trials are not uniform in the box: D's line and correlation
    # use the importance weights (None: a plain table, every trial counts once)
    w = trial_weights(a, a.feasible)
    lx, ly = np.log(Xd[:, 1]), np.log(m_c + Xd[:, 0])
    ww = None if w is None else np.sqrt(w)
    slope = np.polyfit(lx, ly, 1, w=ww)[0] if ridge else np.nan
    corr = float(weighted_pearson(lx[:, None], ly[:, None], w)[0, 0]) if ridge else np.nan
    return {
        "step": best,
        "stage": st,
        "model": model,
        "noise": noise,
        "borrowed": borrowed,
        "allowance": allowance,
        "sink": sink,
        "errors": _errors(model, x) if x is not None else {},
        "wing_loading": (float(load_ws.min()), float(load_ws.max())) if len(Xd) else (np.nan,) * 2,
        "ridge_slope": float(slope),
        "ridge_corr": corr,
        "area": area,
        "canopy_mass": m_c,
        "weighted": w is not None,
    }


def main(argv: list[str] | None = None) -> int:
    from vectorid.workflows.stages import print_stage_limits, print_verdicts

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", nargs="?", default=str(DEFAULT_DATA), help="the ssi-parafoil folder")
    ap.add_argument("--trials", type=int, default=2048,
                    help="the first generation (Sobol points)")  # fmt: skip
    ap.add_argument("--budget", type=int, default=20_000,
                    help="most model evaluations of the sequential sampler")  # fmt: skip
    ap.add_argument("--out", default="ssi-parafoil", help="folder of the store")
    args = ap.parse_args(argv)
    if not (Path(args.data) / "parafoildata_clean.csv").exists():
        print(
            f"error: {args.data} holds no parafoildata_clean.csv. The data are the Stanford "
            "Student Space Initiative's parafoil log of 2018-05-19 (github.com/stanford-ssi/"
            "balloons-Parafoil, parafoildata.xlsx at commit 7611732d; no licence is stated for "
            "it, so vectorid does not ship it). Fetch and convert it with `python "
            "scripts/fetch_data.py ssi-parafoil` (writes ../shared/data/ssi-parafoil; needs "
            "pandas), or pass the folder that holds it",
            file=sys.stderr,
        )
        return 2
    res = identify(args.data, args.out, args.trials, args.budget)
    st = res["stage"]
    r = st.result
    a = r.analysis
    print("Stanford SSI parafoil payload, two drops (data README: ssi-parafoil)")
    print(
        f"  stand-in canopy {res['area']} m² (the ETH class), canopy mass {res['canopy_mass']} kg; "
        "payload mass, CD0 gain and each drop's wind are design variables"
    )
    for n, (m, chans) in res["borrowed"].items():
        print(
            f"  {n}: too few evenly timed samples of {', '.join(chans)} to estimate its noise: "
            f"taken from {m} (the same sensor)"
        )
    for n in res["noise"]:
        al = res["allowance"][n]
        print(
            f"  {n}: sink {res['sink'][n]:.1f} m/s; noise (estimated): {res['noise'][n]}; gust "
            f"allowance (the ETH authors' model, a stand-in) {al['position_h']:.2f} m horizontal, "
            f"{al['altitude']:.2f} m altitude"
        )
    print()
    print(f"  N = {a.n}   ND = {a.n_feasible}   NP = {a.n_pareto} ({r.elapsed:.0f} s)")
    print_stage_limits(st)
    best = r
    print()
    print("Identifiability (a value only where the data identify the variable; else its range):")
    print_verdicts(best.verdicts, best.chosen)
    if res["errors"]:
        print()
        print("Chosen vector against the drops (RMS over each drop):")
        for n, (eh, ep, dur) in res["errors"].items():
            print(f"  {n}: {dur:5.1f} s   altitude {eh:5.1f} m   horizontal {ep:6.1f} m")
    lo, hi = res["wing_loading"]
    print()
    print("What the data determine and what they do not:")
    by = {v.name: v for v in best.verdicts}
    mass, cd0 = by["payload_mass"], by["CD0"]
    if mass.verdict != "not identified" and mass.feasible is not None:
        print(
            f"  - for the stand-in canopy's lift and drag, the sink rate narrows the wing loading "
            f"to {lo:.0f}-{hi:.0f} N/m²\n    (payload {mass.feasible[0]:.1f}-"
            f"{mass.feasible[1]:.1f} kg on {res['area']} m², {mass.verdict}). That is a statement "
            "about the stand-in's\n    polar, not the real canopy: another canopy (area, lift, "
            "drag) gives another wing loading"
            + (f" (CD0: {cd0.verdict})" if cd0.verdict != "identified" else "")
        )
    else:
        print(
            "  - the wing loading is not identified even for the stand-in canopy: "
            f"{lo:.0f}-{hi:.0f} N/m² over D (mass and drag: r = {res['ridge_corr']:+.2f}"
            " in log-log" + (", importance-weighted" if res["weighted"] else "") + ")"
        )
    print(
        "  - the payload mass and the canopy area separately: only W/S enters the glide, and "
        "neither is stated"
    )
    winds = [v for v in best.verdicts if v.name.startswith("wind_")]
    n_id = sum(v.identified for v in winds)
    print(
        "  - the glide ratio: the horizontal track is airspeed plus an unknown wind, and each "
        f"drop flies\n    one way, so the winds absorb it ({n_id} of {len(winds)} wind "
        "components identified)"
    )
    print(
        "  - turn parameters: no control record, and the payload turns continuously (the "
        "orientation sensor\n    sweeps 360 deg every few seconds), which a gliding model "
        "without inputs does not reproduce"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
