"""Where the parachute's right-hand side spends its time, by kind of work.

Usage::

    .venv/bin/python scripts/rhs_breakdown.py [--target native|avx2] [--n 1024] [--repeat 3]

The ``parachute6dof`` batch of ``benchmarks/models.py`` (``--n`` Sobol vectors over the box,
200 s at dt = 0.02 s, 1-s outputs, calm air, both cores) is timed with its kernel compiled from
the model's own source and from copies of it in which one group of elementary functions of the
right-hand side's main loop is replaced by a single cheap operation (the three Euler-angle
``sincos``, the three ``atan2`` of the angles of attack, the three ``sin`` of the aerodynamic
coefficients, or all nine). The copies compute wrong trajectories; what they measure is the time
that group costs: full time minus the copy's time. Each build runs in a fresh process with an
empty numba cache (``--target avx2``: AVX2 code on an AVX-512 machine, as in
``benchmarks/_machine.emulation_env``). Time per right-hand-side evaluation = wall x threads /
(trials x steps x 4).

A substitution that no longer matches the model's source stops the script: it then needs
updating, rather than silently timing the unmodified kernel.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BENCH = str(ROOT / "benchmarks")
sys.path.insert(0, BENCH)
import _machine  # noqa: E402

SOURCE = ROOT / "src" / "vectorid" / "models" / "parachute6dof.py"

_EULER = [
    (f"vm.sincos_hot(X[{k}, i])", f"(X[{k}, i], 1.0 - 0.5 * X[{k}, i] * X[{k}, i])")
    for k in (3, 4, 5)
]
_ATAN2 = [
    ("vm.atan2_hot(uv, wcp)", "(uv / wcp)"),
    ("vm.atan2_hot(ucp, wcp)", "(ucp / wcp)"),
    ("vm.atan2_hot(vcp, wcp)", "(vcp / wcp)"),
]
_SIN = [("vm.sin_hot(", "(0.5 * ")]

#: variant -> (meaning, substitutions (old, new), how many times each old text must occur)
VARIANTS: dict[str, tuple[str, list[tuple[str, str]], list[int]]] = {
    "full": ("the model as shipped", [], []),
    "euler": ("3 Euler-angle sincos -> x, 1 - x²/2", _EULER, [1, 1, 1]),
    "atan2": ("3 atan2 (α, β, spatial α) -> one division", _ATAN2, [1, 1, 1]),
    "sin": ("3 sin of C_D, C_m -> a product", _SIN, [2]),
    "none": ("all 9 of them replaced", _EULER + _ATAN2 + _SIN, [1, 1, 1, 1, 1, 1, 2]),
}

PROBE = """
import importlib.util, sys, time
import numba
import numpy as np
path, n, repeat, n_base, bench_dir = sys.argv[1:6]
n, repeat, n_base = int(n), int(repeat), int(n_base)
sys.path.insert(0, bench_dir)
import models as bench  # benchmarks/models.py: the same batch, baseline and counting
spec = importlib.util.spec_from_file_location("vectorid.models._breakdown", path)
mod = importlib.util.module_from_spec(spec)
sys.modules[spec.name] = mod
spec.loader.exec_module(mod)
m = mod.Parachute6DoF()
X = bench.sobol_batch(m, n)
m.simulate(X[:2], t_final=1.0, dt=0.02)
best = float("inf")
for _ in range(repeat):
    t0 = time.perf_counter()
    res = m.simulate(X, t_final=200.0, dt=0.02, output_dt=1.0)
    best = min(best, time.perf_counter() - t0)
full = np.flatnonzero(res.status == 0)[:n_base]
base = [bench.time_baseline(m, X[i], 200.0, repeat, {})[0] for i in full]
print(best, numba.get_num_threads(), bench.flight_equivalents(res, 200.0),
      np.mean(base) if base else "nan")
"""


def variant_source(name: str) -> str:
    """The parachute module's source with the substitutions of variant ``name``."""
    text = SOURCE.read_text(encoding="utf-8")
    _, subs, counts = VARIANTS[name]
    for (old, new), count in zip(subs, counts, strict=True):
        found = text.count(old)
        if found != count:
            raise SystemExit(
                f"variant {name!r}: expected {count} occurrence(s) of {old!r} in {SOURCE.name}, "
                f"found {found}; update scripts/rhs_breakdown.py to the model's source"
            )
        text = text.replace(old, new)
    return text


def measure(
    name: str, target: str, n: int, repeat: int, n_base: int, workdir: Path
) -> tuple[float, int, float, float]:
    """Variant ``name`` compiled for ``target``: best batch wall time (s), threads, the batch in
    full-flight equivalents, and the solve_ivp baseline's seconds per trial (NaN if not timed).
    """
    path = workdir / f"parachute_{name}.py"
    path.write_text(variant_source(name), encoding="utf-8")
    env = dict(os.environ)
    env.update(_machine.emulation_env(target))
    env["NUMBA_CACHE_DIR"] = str(workdir / f"cache-{target}")
    out = subprocess.run(
        [sys.executable, "-c", PROBE, str(path), str(n), str(repeat), str(n_base), BENCH],
        env=env,
        capture_output=True,
        text=True,
    )
    if out.returncode != 0:
        raise SystemExit(f"variant {name!r} for {target} failed:\n{out.stderr[-2000:]}")
    wall, threads, flown, base = out.stdout.split()
    return float(wall), int(threads), float(flown), float(base)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--target", choices=["native", *_machine.TARGETS], default="native")
    ap.add_argument("--n", type=int, default=1024, help="trials in the batch")
    ap.add_argument("--repeat", type=int, default=3, help="time each build this many times")
    ap.add_argument(
        "--baseline-trials",
        type=int,
        default=3,
        help="solve_ivp baseline trials, timed in the process of the first variant",
    )
    ap.add_argument("--variants", nargs="+", choices=list(VARIANTS), default=list(VARIANTS))
    args = ap.parse_args(argv)
    if args.target != "native":
        os.environ.update(_machine.emulation_env(args.target))
    print(_machine.describe())
    print(f"target measured: {args.target}; {args.n} trials x 200 s at dt 0.02 s, calm air\n")
    evals = args.n * 10_000 * 4
    rows = []
    base = float("nan")
    with tempfile.TemporaryDirectory(prefix="rhs-breakdown-") as tmp:
        for k, name in enumerate(args.variants):
            n_base = args.baseline_trials if k == 0 else 0
            wall, threads, flown, b = measure(
                name, args.target, args.n, args.repeat, n_base, Path(tmp)
            )
            base = b if k == 0 else base
            rows.append((name, wall, wall * threads / evals * 1e9, base * flown / wall))
            print(f"  {name}: {wall:.3f} s", flush=True)
    print(f"\nbaseline (solve_ivp, RK45 rtol 1e-3, numpy right-hand side): {base:.3f} s per trial")
    full = {r[0]: r[2] for r in rows}.get("full")
    print(
        "\n| variant | what is replaced | batch wall (s) | ns per evaluation | its cost (ns) "
        "| speed-up vs solve_ivp |"
    )
    print("|---|---|---|---|---|---|")
    for name, wall, ns, ratio in rows:
        cost = "" if full is None or name == "full" else f"{full - ns:.1f}"
        print(f"| {name} | {VARIANTS[name][0]} | {wall:.3f} | {ns:.1f} | {cost} | {ratio:.0f}x |")


if __name__ == "__main__":
    main()
