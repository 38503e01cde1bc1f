"""Benchmark: vectorid.analysis.pareto_mask against moocore and paretoset.

Usage::

    .venv/bin/python benchmarks/pareto.py [--quick] [--repeats R] [--target {native,avx2}]
                                          [--threads 1 2] [--force-threads] [--busy N]

For every case (N trials, k criteria, data kind) the script builds seeded data with 1 % failed
trials (a NaN in one criterion), then times "feasible + Pareto" for

* ours: ``pareto_mask(F)`` (handles NaN rows itself);
* moocore: ``moocore.is_nondominated(F[ok], keep_weakly=True)`` on the feasible rows;
* paretoset: ``paretoset.paretoset(F[ok], distinct=False, use_numba=True)`` on the feasible rows.

``keep_weakly=True`` / ``distinct=False`` keep every copy of a non-dominated row, the convention of
``pareto_mask``; the NaN filtering and the scatter back to all N rows are part of the competitors'
time. Each time is the best of a few calls after a warm-up (numba compilation is not counted; the
time to the first call is printed separately). A competitor whose single call is predicted to
exceed ~60 s (from the previous N of the same case, assuming cost ~ N * front size, as for their
window / block-nested-loop algorithms) is skipped with a note. The three masks must agree.
``ratio`` = fastest competitor time / our time (> 1: we are faster).

The machine is printed first (``benchmarks/_machine.py``: CPU model, the CPU name and vector ISA
numba compiles for, numba's threads, load average). ``--target avx2`` measures AVX2 code on an
AVX-512 machine: the script re-executes itself with ``NUMBA_CPU_NAME=znver3``, the host's
features minus AVX-512 (``NUMBA_CPU_FEATURES``), its own ``NUMBA_CACHE_DIR`` and numpy's AVX-512
dispatch off (``NPY_DISABLE_CPU_FEATURES``); ours and paretoset (numba) are then compiled for
AVX2, moocore (a compiled C library) is not affected. ``--threads 1 2`` gives one column of ours
per thread count ``t``: ``numba.set_num_threads(t)`` and ``pareto_mask``'s own choice within it
(one thread for small inputs or a busy machine; the ``thr`` column says what it chose), or
exactly ``t`` threads with ``--force-threads``; the competitors are single-threaded. ``--busy N``
runs N busy-loop processes during the measurements (a loaded machine).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable

import numpy as np

from vectorid.analysis import pareto as _pareto
from vectorid.analysis.pareto import pareto_mask

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _machine

try:
    import moocore
except ImportError:  # pragma: no cover - optional
    moocore = None
try:
    import paretoset
except ImportError:  # pragma: no cover - optional
    paretoset = None

SKIP_ABOVE_S = 60.0
FAILED_FRACTION = 0.01


def make_data(n: int, k: int, kind: str, seed: int) -> np.ndarray:
    """Seeded criteria matrix (n, k); ``FAILED_FRACTION`` of the rows get one NaN."""
    rng = np.random.default_rng(seed)
    if kind == "uniform":
        F = rng.random((n, k))
    elif kind == "correlated":  # each criterion = x + 0.05 * noise, x shared per row
        F = rng.random((n, 1)) + 0.05 * rng.standard_normal((n, k))
    else:
        raise ValueError(f"unknown data kind {kind!r}; expected 'uniform' or 'correlated'")
    bad = rng.choice(n, size=int(FAILED_FRACTION * n), replace=False)
    F[bad, rng.integers(0, k, size=bad.size)] = np.nan
    return F


def with_feasible(fn: Callable[[np.ndarray], np.ndarray]) -> Callable[[np.ndarray], np.ndarray]:
    """Wrap a competitor that cannot take NaN: filter the rows, scatter the mask back."""

    def run(F: np.ndarray) -> np.ndarray:
        ok = ~np.isnan(F).any(axis=1)
        out = np.zeros(F.shape[0], dtype=bool)
        out[ok] = fn(F[ok])
        return out

    return run


def competitors() -> dict[str, Callable[[np.ndarray], np.ndarray] | None]:
    comp: dict[str, Callable[[np.ndarray], np.ndarray] | None] = {}
    comp["moocore"] = (
        with_feasible(lambda A: moocore.is_nondominated(A, keep_weakly=True))
        if moocore is not None
        else None
    )
    comp["paretoset"] = (
        with_feasible(lambda A: paretoset.paretoset(A, distinct=False, use_numba=True))
        if paretoset is not None
        else None
    )
    return comp


def best_time(fn: Callable[[np.ndarray], np.ndarray], F: np.ndarray, repeats: int):
    """Best wall time of ``repeats`` calls (at least one) and the last result."""
    best = np.inf
    out = None
    for _ in range(max(repeats, 1)):
        t0 = time.perf_counter()
        out = fn(F)
        best = min(best, time.perf_counter() - t0)
    return best, out


def first_call_times() -> tuple[float, float, float]:
    """Seconds for import + first calls in a fresh process.

    (numpy engine: the first calls of a process without numba loaded; compiled kernels with
    the numba cache; compiled kernels with an empty cache, i.e. compilation included.)"""
    code = (
        "import time; t=time.perf_counter(); import numpy as np{numba};"
        "from vectorid.analysis.pareto import pareto_mask;"
        "[pareto_mask(np.random.default_rng(0).random((50, k))) for k in (1, 2, 3, 5)];"
        "print(time.perf_counter()-t)"
    )
    times = []
    with tempfile.TemporaryDirectory(prefix="numba-cold-") as empty_cache:
        for numba, cold in ((False, False), (True, False), (True, True)):
            env = dict(os.environ)
            if cold:
                env["NUMBA_CACHE_DIR"] = empty_cache
            res = subprocess.run(
                [sys.executable, "-c", code.format(numba="; import numba" if numba else "")],
                env=env,
                capture_output=True,
                text=True,
                check=True,
            )
            times.append(float(res.stdout.strip().splitlines()[-1]))
    return times[0], times[1], times[2]


def fmt(t: float | None) -> str:
    """Seconds as milliseconds, 3 decimals."""
    return f"{1e3 * t:.3f}" if t is not None else "skipped"


def ours_fn(t: int, force: bool) -> Callable[[np.ndarray], np.ndarray]:
    """pareto_mask with numba limited to ``t`` threads (its own choice within), or exactly t."""
    import numba

    def run(F: np.ndarray) -> np.ndarray:
        old = numba.get_num_threads()
        numba.set_num_threads(min(t, numba.config.NUMBA_NUM_THREADS))
        try:
            return pareto_mask(F, threads=t if force else None)
        finally:
            numba.set_num_threads(old)

    return run


def chosen_threads(F: np.ndarray, t: int, force: bool) -> int:
    """The thread count ``ours_fn(t, force)`` uses on ``F`` now."""
    import numba

    if force:
        return min(t, numba.config.NUMBA_NUM_THREADS)
    old = numba.get_num_threads()
    numba.set_num_threads(min(t, numba.config.NUMBA_NUM_THREADS))
    try:
        return _pareto._threads_for(F.size, None)
    finally:
        numba.set_num_threads(old)


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="only N <= 1e5 (well under a minute)")
    ap.add_argument("--repeats", type=int, default=3, help="calls per timing (best is kept)")
    ap.add_argument(
        "--target",
        choices=["native", *_machine.TARGETS],
        default="native",
        help="ISA numba compiles for: native, or avx2 emulated on an AVX-512 machine",
    )
    ap.add_argument(
        "--threads",
        type=int,
        nargs="+",
        default=[1],
        help="numba thread counts to measure ours with (one column each), e.g. --threads 1 2",
    )
    ap.add_argument(
        "--force-threads",
        action="store_true",
        help="use exactly that many threads (default: pareto_mask's choice, at most that many)",
    )
    ap.add_argument("--busy", type=int, default=0, help="busy-loop processes running meanwhile")
    args = ap.parse_args(argv)
    rc = _machine.reexec_for_target(__file__, args.target, sys.argv[1:] if argv is None else argv)
    if rc is not None:
        return rc

    sizes = [10**4, 10**5] if args.quick else [10**4, 10**5, 10**6]
    ks = [2, 4, 8]
    kinds = ["uniform", "correlated"]
    comp = competitors()
    for name, fn in comp.items():
        if fn is None:
            print(f"note: {name} is not installed; its column is skipped")

    target = _machine.measured_target()
    print(f"target measured: {target + ' (emulated)' if target != 'native' else 'native'}")
    print(_machine.describe())
    npy, cached, cold = first_call_times()
    print(
        f"time to first calls (import + 4 small calls, fresh process): {npy:.2f} s by the numpy "
        f"engine (numba not loaded); compiled kernels (numba loaded first): {cached:.2f} s with "
        f"the numba cache, {cold:.2f} s with an empty cache (compilation)"
    )
    ours = {t: ours_fn(t, args.force_threads) for t in args.threads}
    # warm-up: compile/load every kernel (the parallel one too) and the competitors' numba code
    warm = np.random.default_rng(0).random((2000, 8))
    for k in (1, 2, 3, 4, 8):
        pareto_mask(warm[:, :k])
        for fn in comp.values():
            if fn is not None:
                fn(warm[:, :k])
    if max(args.threads) > 1:
        pareto_mask(warm[:, :2], threads=2)

    busy = _machine.Busy(args.busy).start()
    try:
        if busy.procs:
            print(f"{len(busy.procs)} busy-loop process(es) running")
        cols = " ".join(f"{f'ours t={t}[ms]':>14} {'thr':>3}" for t in args.threads)
        rcols = " ".join(f"{f'ratio t={t}':>9}" for t in args.threads)
        header = (
            f"{'N':>9} {'k':>2} {'data':>10} {'front':>7} {cols} {'moocore[ms]':>11} "
            f"{'paretoset[ms]':>13} {rcols}"
        )
        print(header)
        print("-" * len(header))
        history: dict[tuple[str, int, str], tuple[int, int, float]] = {}
        notes: list[str] = []
        all_agree = True
        worst = {t: np.inf for t in args.threads}
        for k in ks:
            for kind in kinds:
                for n in sizes:
                    F = make_data(n, k, kind, seed=1000 * k + n % 997 + len(kind))
                    reps = args.repeats if n < 10**6 else max(1, min(args.repeats, 3))
                    t_ours: dict[int, float] = {}
                    used: dict[int, int] = {}
                    mask = None
                    for t, fn in ours.items():
                        used[t] = chosen_threads(F, t, args.force_threads)
                        t_ours[t], m = best_time(fn, F, reps)
                        if mask is None:
                            mask = m
                        elif not np.array_equal(m, mask):
                            all_agree = False
                            notes.append(f"MISMATCH between thread counts at N={n}, k={k}, {kind}")
                    front = int(mask.sum())
                    times = measure_competitors(
                        comp, F, mask, n, k, kind, front, reps, history, notes
                    )
                    if times is None:
                        all_agree = False
                        times = {}
                    measured = [x for x in times.values() if x is not None]
                    best_comp = min(measured) if measured else float("nan")
                    for t in args.threads:
                        if measured:
                            worst[t] = min(worst[t], best_comp / t_ours[t])
                    cells = " ".join(f"{fmt(t_ours[t]):>14} {used[t]:>3}" for t in args.threads)
                    rcells = " ".join(f"{best_comp / t_ours[t]:>9.2f}" for t in args.threads)
                    print(
                        f"{n:>9} {k:>2} {kind:>10} {front:>7} {cells} "
                        f"{fmt(times.get('moocore')):>11} {fmt(times.get('paretoset')):>13} "
                        f"{rcells}",
                        flush=True,
                    )
    finally:
        busy.stop()
    print(f"load average at end: {', '.join(f'{x:.2f}' for x in os.getloadavg())}")
    for note in notes:
        print("note:", note)
    print(f"masks agree in every measured case: {all_agree}")
    for t in args.threads:
        print(f"smallest ratio (fastest competitor / ours), t={t}: {worst[t]:.2f}")
    return 0 if all_agree else 1


def measure_competitors(comp, F, ours, n, k, kind, front, reps, history, notes):
    """Time each competitor on ``F`` (skipping predicted > SKIP_ABOVE_S); None on a mismatch."""
    times: dict[str, float | None] = {}
    agree = True
    for name, fn in comp.items():
        if fn is None:
            times[name] = None
            continue
        prev = history.get((name, k, kind))
        est = None
        if prev is not None:
            n0, f0, t0 = prev
            est = t0 * (n / n0) * max(front / max(f0, 1), 1.0)
        if est is not None and est > SKIP_ABOVE_S:
            notes.append(
                f"{name} skipped at N={n}, k={k}, {kind}: one call estimated at "
                f"~{est:.0f} s (> {SKIP_ABOVE_S:.0f} s) from {t0:.2f} s at N={n0}"
            )
            times[name] = None
            continue
        r = 1 if (est is not None and est > 5.0) else reps
        t, m = best_time(fn, F, r)
        history[(name, k, kind)] = (n, front, t)
        times[name] = t
        if not np.array_equal(m, ours):
            agree = False
            notes.append(
                f"MISMATCH with {name} at N={n}, k={k}, {kind}: "
                f"{int((m != ours).sum())} rows differ"
            )
    return times if agree else None


if __name__ == "__main__":
    raise SystemExit(main())
