"""Scaling benchmark: the Dask executor (LocalCluster, 2 workers) against the local process
executor (2 workers), for trials of 5 ms, 50 ms and 500 ms.

Goal (issue 7): Dask throughput >= 97 % of the process executor's for 50-ms trials; and a
paper estimate, from the measured per-task overhead, of the efficiency on 64 workers.

The model is a *busy loop*: a fixed number of floating-point iterations per trial, calibrated
in this process to the nominal duration before the runs; ``--model compiled`` runs the same
loop compiled by numba with ``nogil=True`` (how vectorid's own models run), which does not
compete with the Dask worker's threads for the GIL. That is the honest CPU-bound case —
both executors must share the same cores with their own machinery (Dask's scheduler, nanny and
client threads; the run loop), which a ``sleep`` model would hide. ``--model sleep`` measures
the pure overhead instead.

Both executors are measured the same way: the executor is started and warmed up (workers
spawned, model built), then a fixed set of batches goes through ``map_unordered`` and the wall
time is taken; the start-up time is reported separately. Each configuration runs ``--reps``
times, alternating executors, and the best wall time counts (noise on a shared machine only
ever slows a run down).

Usage::

    .venv/bin/python benchmarks/scaling.py --quick     # about a minute
    .venv/bin/python benchmarks/scaling.py             # a few minutes, 3 repetitions
"""

from __future__ import annotations

import argparse
import math
import tempfile
import textwrap
import time
from pathlib import Path

import numpy as np

import _machine
from vectorid import Continuous, Criterion, Space, StudySpec
from vectorid.run.executors import make_executor

MODEL = """
import time

import numba
import numpy as np

ITER_PER_S = {rate!r}
ITER_PER_S_COMPILED = {rate_c!r}


@numba.njit(nogil=True, cache=True)
def _busy_compiled(n):
    x = 1.0
    for _ in range(n):
        x = x * 1.0000001 + 1e-9
    return x


def compiled(X):
    out = np.empty((len(X), 1))
    for i, row in enumerate(X):
        out[i, 0] = _busy_compiled(int(row[1] * ITER_PER_S_COMPILED)) * 0.0 + row[0]
    return out


def _busy(seconds):
    x = 1.0
    for _ in range(int(seconds * ITER_PER_S)):
        x = x * 1.0000001 + 1e-9
    return x


def busy(X):
    out = np.empty((len(X), 1))
    for i, row in enumerate(X):
        out[i, 0] = _busy(row[1]) * 0.0 + row[0]
    return out


def sleep(X):
    for row in X:
        time.sleep(row[1])
    return X[:, :1].copy()
"""


def calibrate(seconds: float = 0.3) -> float:
    """Iterations per second of the busy loop, in this process."""
    n, x = 200_000, 1.0
    best = math.inf
    for _ in range(5):
        t0 = time.perf_counter()
        for _ in range(n):
            x = x * 1.0000001 + 1e-9
        best = min(best, time.perf_counter() - t0)
    return n / best


def calibrate_compiled() -> float:
    """Iterations per second of the compiled (numba, nogil) busy loop, in this process."""
    import numba

    @numba.njit(nogil=True)
    def loop(n):
        x = 1.0
        for _ in range(n):
            x = x * 1.0000001 + 1e-9
        return x

    loop(10)
    n, best = 20_000_000, math.inf
    for _ in range(5):
        t0 = time.perf_counter()
        loop(n)
        best = min(best, time.perf_counter() - t0)
    return n / best


def make_spec(folder: Path, model: str, duration: float) -> StudySpec:
    # x0 in [0, 1] is the trial's identity; "d" is the trial's duration in seconds (a tiny
    # range around the nominal value: bounds must differ).
    return StudySpec(
        name="scaling",
        model=f"scalingmodel:{model}",
        space=Space([Continuous("x0", 0.0, 1.0), Continuous("d", duration, duration * (1 + 1e-9))]),
        criteria=(Criterion("f"),),
        base_dir=str(folder),
    )


def batches(spec: StudySpec, n_trials: int, batch: int):
    X = spec.space.scale(spec.point_sequence().points(0, n_trials))
    return [(s, X[s : s + batch]) for s in range(0, n_trials, batch)]


def measure(name: str, spec: StudySpec, work, workers: int) -> tuple[float, float, list]:
    """(start-up s, wall s of the timed work, results)."""
    t0 = time.perf_counter()
    ex = make_executor(name, spec, workers)
    with ex:
        warm = batches(spec, 2 * workers, 1)
        list(ex.map_unordered(warm))
        startup = time.perf_counter() - t0
        t1 = time.perf_counter()
        out = list(ex.map_unordered(work))
        wall = time.perf_counter() - t1
    assert sorted(k for k, _ in out) == sorted(k for k, _ in work), "lost or repeated batch"
    return startup, wall, out


def overhead(name: str, folder: Path, workers: int, tasks: int, reps: int) -> tuple[float, float]:
    """Per-task overhead with a zero-work model and one trial per task:
    (wall per task in s = central cost c, per-slot overhead o = wall × workers / tasks)."""
    spec = make_spec(folder, "sleep", 1e-9)
    work = batches(spec, tasks, 1)
    best = math.inf
    for _ in range(reps):
        best = min(best, measure(name, spec, work, workers)[1])
    return best / tasks, best * workers / tasks


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="about a minute")
    ap.add_argument("--reps", type=int, help="repetitions per configuration (default 2/3)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument(
        "--model",
        choices=["busy", "compiled", "sleep"],
        default="busy",
        help="busy: pure-Python loop (holds the GIL); compiled: the same loop in numba with "
        "nogil, like vectorid's compiled models; sleep: overhead only",
    )
    ap.add_argument("--batch", type=int, default=16, help="trials per task (default 16)")
    ap.add_argument(
        "--durations",
        default="5,50,500",
        help="trial durations in ms, comma-separated (default 5,50,500; the goal needs 50)",
    )
    args = ap.parse_args()
    print(_machine.describe())
    reps = args.reps or (2 if args.quick else 3)
    durations = [float(v) / 1e3 for v in args.durations.split(",")]
    workers = args.workers
    # seconds of trial work per worker, per configuration
    budget = 2.0 if args.quick else 8.0
    rate = calibrate()
    print(f"busy loop: {rate / 1e6:.1f} M iterations/s in this process; {workers} workers")
    print(f"model: {args.model}; best of {reps}; trials per task (batch): see table")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        (folder / "scalingmodel.py").write_text(
            textwrap.dedent(MODEL.format(rate=rate, rate_c=calibrate_compiled())),
            encoding="utf-8",
        )
        for duration in durations:
            batch = max(1, min(args.batch, round(budget / duration / 4)))
            n_tasks = max(2 * workers, round(budget * workers / (duration * batch)))
            n_tasks += (-n_tasks) % workers  # whole rounds: no tail imbalance
            n_trials = n_tasks * batch
            spec = make_spec(folder, args.model, duration)
            work = batches(spec, n_trials, batch)
            best = {"processes": (math.inf, math.inf), "dask": (math.inf, math.inf)}
            per_trial = []
            for _ in range(reps):
                for name in ("processes", "dask"):
                    startup, wall, out = measure(name, spec, work, workers)
                    per_trial.append(np.mean(np.concatenate([r.wall for _, r in out])))
                    if wall < best[name][1]:
                        best[name] = (startup, wall)
            tp = {k: n_trials / v[1] for k, v in best.items()}
            ideal = workers / duration
            rows.append(
                (
                    duration,
                    batch,
                    n_trials,
                    float(np.mean(per_trial)),
                    tp["processes"],
                    tp["dask"],
                    tp["dask"] / tp["processes"],
                    tp["processes"] / ideal,
                    tp["dask"] / ideal,
                    best["processes"][0],
                    best["dask"][0],
                )
            )
        o_tasks = 200 if args.quick else 1000
        c_p, o_p = overhead("processes", folder, workers, o_tasks, reps)
        c_d, o_d = overhead("dask", folder, workers, o_tasks, reps)

    print()
    print(
        "| trial | batch | trials | measured s/trial | processes trials/s | dask trials/s "
        "| dask / processes | processes eff. | dask eff. | start-up p / d (s) |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for d, b, n, m, tpp, tpd, ratio, ep, ed, sp, sd in rows:
        print(
            f"| {d * 1e3:g} ms | {b} | {n} | {m * 1e3:.1f} ms | {tpp:.1f} | {tpd:.1f} "
            f"| {ratio:.1%} | {ep:.1%} | {ed:.1%} | {sp:.1f} / {sd:.1f} |"
        )
    goal = next((r[6] for r in rows if r[0] == 0.05), None)
    if goal is not None:
        print(
            f"\ngoal: dask >= 97 % of processes for 50-ms trials: {goal:.1%} "
            f"({'met' if goal >= 0.97 else 'NOT met'})"
        )
    print(
        f"\nper-task overhead ({o_tasks} one-trial tasks of no work, {workers} workers): "
        f"processes {c_p * 1e3:.2f} ms/task central, {o_p * 1e3:.2f} ms per worker slot; "
        f"dask {c_d * 1e3:.2f} ms/task central, {o_d * 1e3:.2f} ms per worker slot"
    )
    print(
        "\npaper estimate for 64 Dask workers (one thread each), tasks of 16 trials:\n"
        "  efficiency = T / (T + o) × min(1, T / (64 c)), T = task duration, o = per-slot\n"
        "  overhead, c = central (client + scheduler) cost per task, both measured above;\n"
        "  on a real cluster c is paid on the scheduler and client machines, o on each worker."
    )
    print("| trial | task T | efficiency on 64 workers | central load 64 c / T |")
    print("|---|---|---|---|")
    for d in (0.005, 0.05, 0.5):
        T = 16 * d
        eff = T / (T + o_d) * min(1.0, T / (64 * c_d))
        print(f"| {d * 1e3:g} ms | {T:.2f} s | {eff:.1%} | {64 * c_d / T:.2f} |")


if __name__ == "__main__":
    main()
