"""Speed of the compiled batch models against a per-trial ``solve_ivp`` baseline.

Run::

    .venv/bin/python benchmarks/models.py                       # parachute6dof and parafoil8dof
    .venv/bin/python benchmarks/models.py --models parachute6dof --baseline-trials 2
    .venv/bin/python benchmarks/models.py --target avx2 --busy 1   # AVX2 code; a shared machine

For each model: a batch of ``--n`` Sobol parameter vectors over the model's box, ``--t-final``
seconds at ``--dt`` with outputs every second, on all cores; against the baseline "what a user
would write": the model's plain-numpy right-hand side (``model.reference_rhs``: numpy vectors,
the full 6x6 mass matrix and ``np.linalg.solve``) integrated trial by trial with
``scipy.integrate.solve_ivp`` (default RK45, rtol=1e-3, atol=1e-6) in a Python loop, timed on
``--baseline-trials`` trials and scaled to the batch. Both are measured in the same run, each
as the best of ``--repeat`` runs (noise on a shared machine only ever adds time); the ratio is
what matters.

Also printed: trials per second; an estimate of the GFLOP/s achieved (``model.flops_per_step``,
a hand count documented in the model, divided by the wall time) against the numpy matmul
GFLOP/s measured in the same run; the time to the first trial in a fresh process (compile cache
warm); the peak resident memory of a 16,384-trial batch with 1-s outputs; with ``--busy N``,
the batch's wall time with N CPU-bound processes running and its throughput as a fraction of
the quiet one. The first lines name the machine: CPU, the ISA numba compiles for, threads, load
(``benchmarks/_machine.py``); ``--target avx2`` measures AVX2 code on an AVX-512 machine.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time

import numpy as np
from scipy.integrate import solve_ivp
from scipy.stats import qmc

import _machine
from vectorid import models


def matmul_gflops(n: int = 1024, reps: int = 3) -> float:
    a = np.random.default_rng(0).standard_normal((n, n))
    b = np.random.default_rng(1).standard_normal((n, n))
    a @ b
    best = np.inf
    for _ in range(reps):
        t0 = time.perf_counter()
        a @ b
        best = min(best, time.perf_counter() - t0)
    return 2.0 * n**3 / best / 1e9


def sobol_batch(model: models.Model, n: int, seed: int = 0) -> np.ndarray:
    lo, hi = model.bounds.T
    u = qmc.Sobol(len(lo), seed=seed).random(n)
    return qmc.scale(u, lo, hi + (hi == lo) * 1e-12)


def flight_equivalents(res: models.SimulationResult, t_final: float) -> float:
    """The batch in full-flight equivalents: trials that diverge stop early (``t_fail``)."""
    flown = np.where(np.isnan(res.t_fail), t_final, np.minimum(res.t_fail, t_final))
    return float(flown.sum() / t_final)


def time_baseline(
    model: models.Model, x: np.ndarray, t_final: float, repeat: int, env: dict
) -> tuple[float, object]:
    """Best wall time (s) of ``repeat`` ``solve_ivp`` runs (defaults: RK45, rtol 1e-3) of the
    model's numpy reference right-hand side for the vector ``x``, and the last solution.

    Raises NotImplementedError where the model has no reference right-hand side."""
    f, x0 = model.reference_rhs(x, t_final=t_final, **env)
    best = np.inf
    for _ in range(repeat):  # the same best-of rule as the batch
        t0 = time.perf_counter()
        sol = solve_ivp(f, (0.0, t_final), x0)
        best = min(best, time.perf_counter() - t0)
    return best, sol


def _subprocess_seconds(code: str) -> float:
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return float(out.stdout.strip().splitlines()[-1])


def first_trial_seconds(name: str) -> float:
    code = (
        "import time; t0 = time.perf_counter()\n"
        "from vectorid import models\n"
        f"m = models.get({name!r})\n"
        "m.simulate(m.nominal, t_final=1.0, dt=0.02)\n"
        "print(time.perf_counter() - t0)\n"
    )
    return _subprocess_seconds(code)


def peak_memory_mb(name: str, n: int, t_final: float) -> tuple[float, float, float]:
    """Peak RSS (MB), output array size (MB) and wall time (s) of an n-trial batch.

    dt = 0.2 s keeps this short: memory depends on the output grid (1 s), not on dt.
    """
    code = (
        "import resource, time, numpy as np\n"
        "from scipy.stats import qmc\n"
        "from vectorid import models\n"
        f"m = models.get({name!r})\n"
        "lo, hi = m.bounds.T\n"
        f"X = qmc.scale(qmc.Sobol(len(lo), seed=0).random({n}), lo, hi + (hi == lo) * 1e-12)\n"
        "t0 = time.perf_counter()\n"
        f"r = m.simulate(X, t_final={t_final}, dt=0.2, output_dt=1.0)\n"
        "el = time.perf_counter() - t0\n"
        "print(r.outputs.nbytes / 2**20)\n"
        "print(el)\n"
        "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    nbytes, el, rss = (float(v) for v in out.stdout.strip().splitlines()[-3:])
    return rss, nbytes, el


def scenario(model: models.Model, name: str) -> dict:
    """Control inputs and wind of a benchmark scenario (keyword arguments of ``simulate``).

    ``calm``: no control, calm air (the issue's benchmark). ``controlled``: a flight as the
    identification studies fly it, a steady wind profile (no turbulence) and control steps
    (parachute: riser 1 pulled from 40 to 80 s, riser 2 from 120 to 160 s; parafoils: a left
    then a right turn with 50 % flap, 5-s ramps), so ``solve_ivp`` must resolve the actuator
    transients as real studies make it do.
    """
    if name == "calm":
        return {}
    wind = models.WindProfile(
        [0.0, 500.0, 1000.0, 1500.0, 3000.0], [2.0, 5.0, 8.0, 10.0, 12.0], [0.0, 2.0, 4.0, 3.0, 2.0]
    )
    names = tuple(model.input_names)
    if names == ("riser1", "riser2", "riser3", "riser4"):
        lengths = np.ones((5, 4))
        lengths[1, 0] = 0.0
        lengths[3, 1] = 0.0
        inputs = models.riser_commands([0.0, 40.0, 80.0, 120.0, 160.0], lengths)
    elif names == ("flap_left", "flap_right"):
        t = [0.0, 40.0, 45.0, 75.0, 80.0, 120.0, 125.0, 155.0, 160.0]
        left = [0.0, 0.0, 0.5, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0]
        right = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0]
        inputs = models.flap_deflections(t, left, right)
    else:
        raise SystemExit(f"no controlled scenario for {model.name} (inputs {names})")
    return {"inputs": inputs, "wind": wind}


def bench_model(name: str, args: argparse.Namespace, gflops_peak: float) -> dict | None:
    try:
        model = models.get(name)
    except ImportError as exc:
        print(f"[skip] {name}: {exc}")
        return None
    X = sobol_batch(model, args.n)
    env = scenario(model, args.scenario)
    model.simulate(X[:2], t_final=1.0, dt=args.dt, **env)  # compile or load the cache
    wall = np.inf
    for _ in range(args.repeat):  # best of --repeat: the machine's noise only ever adds time
        t0 = time.perf_counter()
        res = model.simulate(X, t_final=args.t_final, dt=args.dt, output_dt=1.0, **env)
        wall = min(wall, time.perf_counter() - t0)
    busy_wall = None
    if args.busy:  # the same batch with --busy CPU-bound processes running alongside
        busy_wall = np.inf
        with _machine.Busy(args.busy):
            for _ in range(args.repeat):
                t0 = time.perf_counter()
                model.simulate(X, t_final=args.t_final, dt=args.dt, output_dt=1.0, **env)
                busy_wall = min(busy_wall, time.perf_counter() - t0)
    # Trials that diverge stop early: count the batch in full-flight equivalents, and time the
    # baseline on full-length (status 0) trials only, so early stops flatter neither side.
    equivalent = flight_equivalents(res, args.t_final)
    per_trial = wall / equivalent
    row = {
        "model": name,
        "n": args.n,
        "wall_s": wall,
        "trials_per_s": args.n / wall,
        "ok": int(res.ok.sum()),
        "full_flight_equivalents": equivalent,
    }
    if busy_wall is not None:
        row["busy_wall_s"] = busy_wall
        row["busy_fraction"] = wall / busy_wall
    n_steps = round(args.t_final / args.dt)
    flops = getattr(model, "flops_per_step", None)
    if flops:
        row["gflops"] = equivalent * n_steps * flops / wall / 1e9
        row["gflops_frac"] = row["gflops"] / gflops_peak
    base = []
    nfev = []
    full = np.flatnonzero(res.status == 0)
    for i in full[: args.baseline_trials]:
        try:
            best, sol = time_baseline(model, X[i], args.t_final, args.repeat, env)
        except NotImplementedError as exc:
            print(f"[note] {name}: no baseline ({exc})")
            break
        base.append(best)
        nfev.append(sol.nfev)
        if i == full[0]:  # the baseline solves the same problem: compare the end states
            x_end = res.outputs[i, -1, 2]
            print(
                f"  {name}: trial 0 final down position compiled {x_end:.2f} m; "
                f"baseline reached t = {sol.t[-1]:.1f} s (status {sol.status})"
            )
    if base:
        row["baseline_per_trial_s"] = float(np.mean(base))
        row["baseline_nfev"] = float(np.mean(nfev))
        row["speedup"] = row["baseline_per_trial_s"] / per_trial
    row["first_trial_s"] = first_trial_seconds(name)
    if not args.skip_memory:
        rss, nbytes, el = peak_memory_mb(name, args.memory_trials, args.t_final)
        row.update(mem_peak_mb=rss, mem_outputs_mb=nbytes, mem_wall_s=el)
    return row


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--models", nargs="+", default=["parachute6dof", "parafoil8dof"])
    ap.add_argument("--n", type=int, default=1024)
    ap.add_argument("--t-final", type=float, default=200.0)
    ap.add_argument("--dt", type=float, default=0.02)
    ap.add_argument("--baseline-trials", type=int, default=3)
    ap.add_argument(
        "--repeat",
        type=int,
        default=3,
        help="time the batch and each baseline trial this many times and keep the best",
    )
    ap.add_argument("--memory-trials", type=int, default=16_384)
    ap.add_argument("--skip-memory", action="store_true")
    ap.add_argument(
        "--scenario",
        choices=["calm", "controlled"],
        default="calm",
        help="calm: no control, calm air (the goal's benchmark); controlled: control steps "
        "and a wind profile, as identification flights are flown",
    )
    ap.add_argument(
        "--target",
        choices=["native", *_machine.TARGETS],
        default="native",
        help="compile for this vector ISA (avx2: emulated on an AVX-512 machine, in its own "
        "numba cache; see benchmarks/_machine.py)",
    )
    ap.add_argument(
        "--busy",
        type=int,
        default=0,
        help="also time the batch with this many CPU-bound processes running (a shared machine)",
    )
    args = ap.parse_args(argv)
    rc = _machine.reexec_for_target(__file__, args.target, sys.argv[1:] if argv is None else argv)
    if rc is not None:
        raise SystemExit(rc)
    gpk = matmul_gflops()
    print(_machine.describe())
    print(
        f"target measured: {_machine.measured_target()}; numpy matmul: {gpk:.1f} GFLOP/s; "
        f"scenario: {args.scenario}"
    )
    rows = [r for name in args.models if (r := bench_model(name, args, gpk)) is not None]
    print()
    print(
        "| model | trials | batch wall (s) | trials/s | baseline s/trial (nfev) | speed-up "
        "| est. GFLOP/s (% of matmul) | first trial, fresh process (s) | 16k-trial peak RSS "
        f"(MB) / outputs (MB) | with {args.busy} busy: wall (s), % of quiet throughput |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        base = (
            f"{r['baseline_per_trial_s']:.3f} ({r['baseline_nfev']:.0f})"
            if "baseline_per_trial_s" in r
            else "n/a"
        )
        sp = f"{r['speedup']:.0f}x" if "speedup" in r else "n/a"
        gf = f"{r['gflops']:.2f} ({100 * r['gflops_frac']:.1f}%)" if "gflops" in r else "n/a"
        busy = (
            f"{r['busy_wall_s']:.2f}, {100 * r['busy_fraction']:.0f}%"
            if "busy_wall_s" in r
            else "not measured"
        )
        mem = (
            f"{r['mem_peak_mb']:.0f} / {r['mem_outputs_mb']:.0f}"
            if "mem_peak_mb" in r
            else "skipped"
        )
        print(
            f"| {r['model']} | {r['n']} ({r['ok']} ok, {r['full_flight_equivalents']:.0f} full) | "
            f"{r['wall_s']:.2f} | "
            f"{r['trials_per_s']:.0f} | {base} | {sp} | {gf} | {r['first_trial_s']:.2f} | "
            f"{mem} | {busy} |"
        )


if __name__ == "__main__":
    main()
