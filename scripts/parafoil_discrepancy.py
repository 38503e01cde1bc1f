"""Read the parafoil demo's model-discrepancy allowance from twins of its generator.

Run from the repository root::

    python scripts/parafoil_discrepancy.py [--twins 40] [--draws 2000] [--coverage 0.9]

The identified model (``parafoil8dof`` with the demo's options) does not fly what the
generator's truth flies: Dryden gusts, a flap actuator lag, the payload joint's pitch
stiffness, a dropsonde wind with errors. Even at the true gains its criteria therefore exceed
their noise floors (the values a perfect model reaches under the stated sensor noise alone).
The allowance that the demo grants (``vectorid.demos.parafoil.DEMO_DISCREPANCY``) is read here
from twins: the same truth, flight program and sensors as the embedded drop, flown with other
seeds (other gusts, sonde errors and sensor noise; ``scripts/make_parafoil_demo_data.py``'s
``generate(seed)``), never from the embedded drop itself (whose seed is excluded).

For each twin and criterion, the allowance that just puts the true gains inside the limit:
(criterion at the truth - noise-floor limit), divided by the window length for the
criteria that a channel bound limits (``pos_h`` by ``position_h``, ``pos_v`` by
``position_v``, ``speed`` by ``velocity_h``: a bound δ on the model's deviation adds δ·T to
∫|e| dt), in the criterion's own unit for the others (``heading`` in rad·s, ``turn`` in rad,
the spectral peaks in Hz), 0 where the truth is already inside. The allowance printed covers
``--coverage`` (90 %) of the twins on every criterion together: per criterion the largest need
over the twins, after leaving out the 10 % of twins whose exclusion lowers the allowances most
(a common percentile, as the G-12 demo's allowance was read, would be the maximum here: with
eight criteria whose heavy tails fall on different twins, 90 % joint coverage needs each one
near its largest value). Rounded up, it goes into ``DEMO_DISCREPANCY``.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
#: Criterion -> discrepancy key, and whether the key is a channel bound (divide by T).
KEYS = {
    "pos_h": ("position_h", True),
    "pos_v": ("position_v", True),
    "speed": ("velocity_h", True),
    "heading": ("heading", False),
    "turn": ("turn", False),
    "peak_roll": ("peak_roll", False),
    "peak_pitch": ("peak_pitch", False),
    "peak_yaw": ("peak_yaw", False),
}


def _generator():
    spec = importlib.util.spec_from_file_location(
        "make_parafoil_demo_data", ROOT / "scripts" / "make_parafoil_demo_data.py"
    )
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    return gen


def twin_needs(seed: int, folder: Path, draws: int) -> dict[str, float]:
    """The allowance each criterion needs on one twin (0 where the truth is inside)."""
    from vectorid import models
    from vectorid.demos.parafoil import MODEL_OPTIONS, stage_toml
    from vectorid.identify import Identification
    from vectorid.identify.noise import parse_noise
    from vectorid.identify.noise.floor import noise_floor
    from vectorid.spec import load_study

    gen = _generator()
    gen.generate(seed, folder / "data")
    truth = json.loads((folder / "data" / "truth.json").read_text(encoding="utf-8"))
    model = models.get("parafoil8dof", **MODEL_OPTIONS)
    names = list(model.parameter_names)
    variables = [(p.name, float(p.low), float(p.high)) for p in model.parameters]
    f = folder / "twin.toml"
    f.write_text(stage_toml("twin", variables, truth=truth, trials=1, limits=False), "utf-8")
    spec = load_study(f)
    ident = Identification.from_spec(spec)
    x_true = np.array([truth["parameters"][n] for n in names])
    F = ident.evaluate(x_true[None])[0][0]
    floor = noise_floor(
        ident,
        parse_noise(truth["sensor_noise"]),
        draws=draws,
        seed=0,
        params=dict(zip(names, model.nominal)),
    )
    crit = [c.name for c in ident.criteria]
    limits = floor.limits(crit, coverage=0.95)
    T = float(ident.drops[0].grid[-1] - ident.drops[0].grid[0])
    out = {}
    for j, n in enumerate(crit):
        excess = max(0.0, float(F[j]) - limits[n][0])
        out[n] = excess / T if KEYS[n][1] else excess
    out["_values"] = {n: float(F[j]) for j, n in enumerate(crit)}
    out["_floors"] = {n: limits[n][0] for n in crit}
    return out


def allowance(needs: list[dict[str, float]], coverage: float) -> tuple[list[int], dict[str, float]]:
    """The allowance that covers ``coverage`` of the twins: per criterion the largest need
    over the twins kept, after leaving out the (1 - coverage) share of twins whose exclusion
    lowers the allowances most (greedily, each allowance measured against its maximum over
    all twins). Returns the indices left out and the allowance by discrepancy key."""
    crit = list(KEYS)
    A = np.array([[nd[c] for c in crit] for nd in needs])
    scale = np.where(A.max(axis=0) > 0, A.max(axis=0), 1.0)
    keep = np.ones(len(A), dtype=bool)
    out: list[int] = []
    for _ in range(int(np.floor((1.0 - coverage) * len(A) + 1e-9))):
        cost = []
        for i in np.flatnonzero(keep):
            k = keep.copy()
            k[i] = False
            cost.append((float(np.sum(A[k].max(axis=0) / scale)), int(i)))
        _, i = min(cost)
        keep[i] = False
        out.append(i)
    lim = A[keep].max(axis=0)
    return out, {KEYS[c][0]: float(v) for c, v in zip(crit, lim)}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--twins", type=int, default=40)
    ap.add_argument("--draws", type=int, default=2000)
    ap.add_argument("--coverage", type=float, default=0.9)
    ap.add_argument("--first-seed", type=int, default=1)
    ap.add_argument("--json", help="write the per-twin needs to this file")
    ap.add_argument("--from-json", help="summarise the needs written by an earlier --json run")
    args = ap.parse_args(argv)
    gen = _generator()
    if args.from_json:
        doc = json.loads(Path(args.from_json).read_text(encoding="utf-8"))
        seeds, needs = doc["seeds"], doc["needs"]
    else:
        seeds = [s for s in range(args.first_seed, args.first_seed + args.twins + 1)]
        seeds = [s for s in seeds if s != gen.SEED][: args.twins]
        needs = []
        t0 = time.perf_counter()
        with tempfile.TemporaryDirectory() as tmp:
            for seed in seeds:
                nd = twin_needs(seed, Path(tmp) / str(seed), args.draws)
                needs.append(nd)
                shown = "  ".join(f"{c} {nd[c]:.3g}" for c in KEYS)
                print(f"twin {seed:>3}: {shown}   ({time.perf_counter() - t0:.0f} s)", flush=True)
    units = {"position_h": "m", "position_v": "m", "velocity_h": "m/s", "heading": "rad·s",
             "turn": "rad", "peak_roll": "Hz", "peak_pitch": "Hz", "peak_yaw": "Hz"}  # fmt: skip
    print()
    print(f"per criterion over {len(needs)} twins: needed allowance median / 90th pct / max")
    for c, (key, _) in KEYS.items():
        v = np.array([nd[c] for nd in needs])
        floor = np.median([nd["_floors"][c] for nd in needs])
        print(
            f"  {c:<10} {key:<11} {np.median(v):9.4g} {np.percentile(v, 90):9.4g} "
            f"{v.max():9.4g} {units[key]:<6} (median floor limit {floor:.4g}; "
            f"truth inside the bare floor in {np.mean(v == 0):.0%})"
        )
    left, allow = allowance(needs, args.coverage)
    print()
    print(
        f"allowance covering {len(needs) - len(left)} of {len(needs)} twins on every criterion "
        f"(left out: seeds {', '.join(str(seeds[i]) for i in left)}):"
    )
    print("  " + ", ".join(f"{k} = {v:.4g} {units[k]}" for k, v in allow.items()))
    if args.json and not args.from_json:
        Path(args.json).write_text(json.dumps({"seeds": seeds, "needs": needs}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
