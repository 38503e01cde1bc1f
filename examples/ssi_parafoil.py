"""What two real parafoil drops of unknown mass and canopy can tell: wing loading and glide.

Usage::

    python examples/ssi_parafoil.py [PATH/TO/shared/data/ssi-parafoil] [--trials 2048]
        [--out ssi-parafoil]

The drops: Stanford SSI's balloon payload under a parafoil, 2018-05-19 (data README in
``../shared/data/ssi-parafoil/``): barometric pressure altitude at 14 Hz and GPS latitude /
longitude (a new fix about once a second), from 78 m and 247 m above the ground at 6-7 m/s;
no mass, canopy size, airspeed, wind or control record, and the payload turns continuously.

The model is ``parafoil6dof`` with a small canopy of the ETH test vehicle's class (1.5 m²,
the stated aerodynamic set of ``examples/eth_parafoil.py``) standing in for the unknown one.
Design variables, with both drops at once (criteria averaged over them):

* ``payload_mass`` (kg): with the canopy area fixed it is the wing loading
  W/S = (m_c + m_p) g / S (printed in N/m²);
* the ``CD0`` gain: the glide (zero-lift drag of canopy and lines);
* per drop, the unknown uniform wind (north, east).

Criteria (pure): the altitude residual ∫|Δh| dt and the horizontal position residual
∫|ΔP_H| dt. The script prints what the fit gives, and which quantities the data determine and
which they do not: the sink rate fixes only a combination of wing loading and drag (a ridge in
the feasible set), and without airspeed or wind the glide ratio is not separable from the wind.
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
from pathlib import Path

import numpy as np

from vectorid.identify import Channel, FlightData, Identification
from vectorid.problem import Criterion
from vectorid.space import Continuous, Space
from vectorid.spec import StudySpec

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_DATA = ROOT.parent / "shared" / "data" / "ssi-parafoil"
DROPS = (1, 2)
BOXES = {"payload_mass": (0.5, 30.0), "CD0": (0.3, 10.0)}
WIND_BOX = (-15.0, 15.0)


def _eth():
    spec = importlib.util.spec_from_file_location(
        "eth_parafoil", ROOT / "examples" / "eth_parafoil.py"
    )
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def load(path: Path, drop: int) -> FlightData:
    """One drop: pressure altitude, and the GPS track (new fixes only) in a local frame."""
    import pymap3d

    d = np.genfromtxt(path, delimiter=",", names=True)
    s = d[d["drop"] == drop]
    t = s["t_s"]
    alt = Channel("altitude", t, s["alt_m"][:, None], ("altitude",), "m")
    fix = np.isfinite(s["lat_deg"]) & np.isfinite(s["lon_deg"])
    lat, lon, tf, h = s["lat_deg"][fix], s["lon_deg"][fix], t[fix], s["alt_m"][fix]
    new = np.concatenate([[True], (np.diff(lat) != 0) | (np.diff(lon) != 0)])
    lat, lon, tf, h = lat[new], lon[new], tf[new], h[new]
    n, e, _ = pymap3d.geodetic2ned(lat, lon, 0.0 * lat, lat[0], lon[0], 0.0)
    pos = Channel("position", tf, np.column_stack([n, e, -h]), ("north", "east", "down"), "m")
    return FlightData(f"drop{drop}", {"altitude": alt, "position": pos}, {}, None)


class TwoDrops:
    """Batch model: (payload_mass, CD0 gain, wind per drop) -> criteria averaged over drops."""

    def __init__(self, flights: dict[str, FlightData]):
        eth = _eth()
        options = eth.model_options()
        options["extra_parameters"] = ["payload_mass", "wind_north", "wind_east"]
        self.names = list(flights)
        self.idents = {}
        for name, fl in flights.items():
            p = fl["position"]
            t0, t1 = max(p.t[0], fl["altitude"].t[0]), min(p.t[-1], fl["altitude"].t[-1])
            table = {
                "model": "parafoil6dof", "model_options": options, "dt": 0.02, "output_dt": 0.2,
                "init_span": 1.0,
                "drops": [{"name": name, "window": [float(t0), float(t1)], "origin_altitude": 0.0}],
            }  # fmt: skip
            self.idents[name] = Identification.from_table(
                table, variables=["payload_mass", "CD0", "wind_north", "wind_east"],
                criteria=["alt_abs", "pos_h_abs"], flights={name: fl},
            )  # fmt: skip

    @property
    def variables(self) -> list[str]:
        return ["payload_mass", "CD0", *(f"{c}.{n}" for n in self.names
                                         for c in ("wind_north", "wind_east"))]  # fmt: skip

    def columns(self, X: np.ndarray, k: int) -> np.ndarray:
        return np.column_stack([X[:, 0], X[:, 1], X[:, 2 + 2 * k], X[:, 3 + 2 * k]])

    def __call__(self, X: np.ndarray) -> np.ndarray:
        X = np.atleast_2d(np.asarray(X, dtype=float))
        parts = [self.idents[n].evaluate(self.columns(X, k))[0] for k, n in enumerate(self.names)]
        return np.mean(parts, axis=0)

    def errors(self, x: np.ndarray) -> dict[str, tuple[float, float, float]]:
        """Per drop: RMS altitude error (m), RMS horizontal error (m), duration (s)."""
        out = {}
        for k, n in enumerate(self.names):
            ident = self.idents[n]
            d = ident.drops[0]
            res = ident.simulate(self.columns(np.atleast_2d(x), k), d)
            h = -res.position[0, :, 2] - d.origin_altitude
            eh = h - d.measured("altitude")[:, 0]
            ep = res.position[0, :, :2] - d.measured("position")[:, :2]
            out[n] = (
                float(np.sqrt(np.mean(eh**2))),
                float(np.sqrt(np.mean((ep**2).sum(axis=1)))),
                d.duration,
            )
        return out


#: The model of the study being run: the study file names ``ssi_parafoil:evaluate`` (a module-level
#: function, so the store can name it), which evaluates this object.
_CURRENT: TwoDrops | None = None


def evaluate(X: np.ndarray) -> np.ndarray:
    """The study's batch model: criteria (n, 2) averaged over the flights of ``_CURRENT``."""
    if _CURRENT is None:
        raise RuntimeError("no model is being identified; call identify() first")
    return _CURRENT(X)


def identify(folder: str | Path, out: str | Path, trials: int = 2048) -> dict:
    from vectorid.identify.twostep import run_step

    folder, out = Path(folder), Path(out)
    out.mkdir(parents=True, exist_ok=True)
    path = folder / "parafoildata_clean.csv"
    flights = {f"drop{k}": load(path, k) for k in DROPS}
    model = TwoDrops(flights)
    global _CURRENT
    _CURRENT = model
    boxes = {**BOXES, **{v: WIND_BOX for v in model.variables if v.startswith("wind_")}}
    space = Space([Continuous(v, *boxes[v]) for v in model.variables])
    spec = StudySpec(
        name="ssi-drops", model=evaluate, space=space,
        criteria=(Criterion("alt", unit="m·s"), Criterion("pos_h", unit="m·s")),
        trials=trials, seed=1, executor="serial",
    )  # fmt: skip
    store = out / "ssi-drops.db"
    if store.exists():
        store.unlink()
    r = run_step(spec, store, trials=trials, coarse=max(16, trials // 4), auto_quantile=0.1,
                 min_feasible=20, name="ssi")  # fmt: skip
    a = r.analysis
    x = np.array([r.chosen[v] for v in model.variables])
    Xd = a.trials.X[a.feasible]
    m_c = model.idents["drop1"].model.geometry.canopy_mass
    area = model.idents["drop1"].model.geometry.area
    load_ws = (m_c + Xd[:, 0]) * 9.80665 / area
    slope = np.polyfit(np.log(Xd[:, 1]), np.log(m_c + Xd[:, 0]), 1)[0] if len(Xd) > 2 else np.nan
    corr = (
        float(np.corrcoef(np.log(Xd[:, 1]), np.log(m_c + Xd[:, 0]))[0, 1])
        if len(Xd) > 2
        else np.nan
    )
    return {
        "step": r,
        "model": model,
        "errors": model.errors(x),
        "wing_loading": (float(load_ws.min()), float(load_ws.max())),
        "ridge_slope": float(slope),
        "ridge_corr": corr,
        "area": area,
        "canopy_mass": m_c,
    }


def main(argv: list[str] | None = None) -> int:
    from vectorid.demo_parafoil import print_chosen_values

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", nargs="?", default=str(DEFAULT_DATA), help="the ssi-parafoil folder")
    ap.add_argument("--trials", type=int, default=2048)
    ap.add_argument("--out", default="ssi-parafoil", help="folder of the store")
    args = ap.parse_args(argv)
    if not (Path(args.data) / "parafoildata_clean.csv").exists():
        print(f"error: {args.data} holds no parafoildata_clean.csv", file=sys.stderr)
        return 2
    res = identify(args.data, args.out, args.trials)
    r = res["step"]
    a = r.analysis
    print("Stanford SSI parafoil payload, two drops (data README: ssi-parafoil)")
    print(
        f"  stand-in canopy {res['area']} m² (the ETH class), canopy mass {res['canopy_mass']} kg; "
        "payload mass, CD0 gain and each drop's wind are design variables"
    )
    print(
        f"  N = {a.n}   ND = {a.n_feasible}   NP = {a.n_pareto} ({r.elapsed:.0f} s); criteria "
        "constraints (10 % quantile): "
        + ", ".join(f"{k} <= {v:.3g} m·s" for k, v in r.limits.items())
    )
    print()
    rows = print_chosen_values(a, r.chosen)
    print()
    print("Chosen vector against the drops (RMS over each drop):")
    for n, (eh, ep, dur) in res["errors"].items():
        print(f"  {n}: {dur:5.1f} s   altitude {eh:5.1f} m   horizontal {ep:6.1f} m")
    lo, hi = res["wing_loading"]
    print()
    print("What the data determine and what they do not:")
    mass = next(rr for rr in rows if rr.name == "payload_mass")
    cd0 = next(rr for rr in rows if rr.name == "CD0")
    if mass.verdict != "wide":
        print(
            f"  - for the stand-in canopy's lift and drag, the sink rate pins the wing loading at "
            f"{lo:.0f}-{hi:.0f} N/m²\n    (payload "
            f"{mass.feasible[0]:.1f}-{mass.feasible[1]:.1f} kg on {res['area']} m²). That is a "
            "statement about the stand-in's polar, not the real canopy:\n    another canopy "
            "(area, lift, drag) gives another wing loading"
            + (" (CD0 stays wide here)" if cd0.verdict == "wide" else "")
        )
    else:
        print(
            f"  - the wing loading is not pinned even for the stand-in canopy: {lo:.0f}-{hi:.0f} "
            f"N/m² over D (mass and drag: r = {res['ridge_corr']:+.2f} in log-log)"
        )
    print(
        "  - the payload mass and the canopy area separately: only W/S enters the glide, and "
        "neither is stated"
    )
    print(
        "  - the glide ratio: the horizontal track is airspeed plus an unknown wind, and each "
        "drop flies\n    one way, so the winds absorb it (see their ranges)"
    )
    print(
        "  - turn parameters: no control record, and the payload turns continuously (the "
        "orientation sensor\n    sweeps 360 deg every few seconds), which a gliding model "
        "without inputs does not reproduce"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
