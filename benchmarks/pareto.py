"""Benchmark: vectorid.analysis.pareto_mask against moocore and paretoset.

Usage::

    .venv/bin/python benchmarks/pareto.py [--quick] [--repeats R]

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

from vectorid.analysis.pareto import pareto_mask

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


def first_call_times() -> tuple[float, float]:
    """Seconds for import + first call in a fresh process: with the numba cache, and cold."""
    code = (
        "import time; t=time.perf_counter(); import numpy as np;"
        "from vectorid.analysis.pareto import pareto_mask;"
        "[pareto_mask(np.random.default_rng(0).random((50, k))) for k in (1, 2, 3, 5)];"
        "print(time.perf_counter()-t)"
    )
    times = []
    with tempfile.TemporaryDirectory(prefix="numba-cold-") as empty_cache:
        for cold in (False, True):
            env = dict(os.environ)
            if cold:
                env["NUMBA_CACHE_DIR"] = empty_cache
            res = subprocess.run(
                [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
            )
            times.append(float(res.stdout.strip().splitlines()[-1]))
    return times[0], times[1]


def fmt(t: float | None) -> str:
    return f"{t:.4f}" if t is not None else "skipped"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="only N <= 1e5 (well under a minute)")
    ap.add_argument("--repeats", type=int, default=3, help="calls per timing (best is kept)")
    args = ap.parse_args(argv)

    sizes = [10**4, 10**5] if args.quick else [10**4, 10**5, 10**6]
    ks = [2, 4, 8]
    kinds = ["uniform", "correlated"]
    comp = competitors()
    for name, fn in comp.items():
        if fn is None:
            print(f"note: {name} is not installed; its column is skipped")

    print(f"cpus: {os.cpu_count()}, load average at start: {os.getloadavg()}")
    cached, cold = first_call_times()
    print(
        f"time to first call (import + 4 small calls, fresh process): {cached:.2f} s with the "
        f"numba cache, {cold:.2f} s with an empty cache (compilation)"
    )
    # warm-up: compile/load every kernel and the competitors' numba code
    warm = np.random.default_rng(0).random((2000, 8))
    for k in (1, 2, 3, 4, 8):
        pareto_mask(warm[:, :k])
        for fn in comp.values():
            if fn is not None:
                fn(warm[:, :k])

    header = (
        f"{'N':>9} {'k':>2} {'data':>10} {'front':>7} {'ours[s]':>9} {'moocore[s]':>10} "
        f"{'paretoset[s]':>12} {'ratio':>7}"
    )
    print(header)
    print("-" * len(header))
    history: dict[tuple[str, int, str], tuple[int, int, float]] = {}
    notes: list[str] = []
    all_agree = True
    worst_ratio = np.inf
    for k in ks:
        for kind in kinds:
            for n in sizes:
                F = make_data(n, k, kind, seed=1000 * k + n % 997 + len(kind))
                reps = args.repeats if n < 10**6 else max(1, min(args.repeats, 3))
                t_ours, ours = best_time(pareto_mask, F, reps)
                front = int(ours.sum())
                times: dict[str, float | None] = {}
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
                        all_agree = False
                        notes.append(
                            f"MISMATCH with {name} at N={n}, k={k}, {kind}: "
                            f"{int((m != ours).sum())} rows differ"
                        )
                measured = [t for t in times.values() if t is not None]
                ratio = min(measured) / t_ours if measured else float("nan")
                worst_ratio = min(worst_ratio, ratio) if measured else worst_ratio

                print(
                    f"{n:>9} {k:>2} {kind:>10} {front:>7} {t_ours:>9.4f} "
                    f"{fmt(times['moocore']):>10} {fmt(times['paretoset']):>12} {ratio:>7.1f}",
                    flush=True,
                )
    print(f"load average at end: {os.getloadavg()}")
    for note in notes:
        print("note:", note)
    print(f"masks agree in every measured case: {all_agree}")
    print(f"smallest ratio (fastest competitor / ours): {worst_ratio:.2f}")
    return 0 if all_agree else 1


if __name__ == "__main__":
    raise SystemExit(main())
