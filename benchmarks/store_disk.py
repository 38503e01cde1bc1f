"""Disk footprint of a store during a run: store + write-ahead log + shared memory file.

Goal (issue 24): the files of a store take at most 2x the final store's size at any moment
of a run. A 1e5-trial study (the Binh–Korn problem, in-process model, so the run is
write-bound) is run while a thread samples the footprint (``STORE``, ``STORE-wal``,
``STORE-shm``) every millisecond; the largest footprint is printed as a ratio to the final
store's size. Baseline in the same run: the same study with the log left to SQLite's own
checkpoints (what a run did before), so the ratio can be compared.

Usage::

    .venv/bin/python benchmarks/store_disk.py [--n 100000] [--batch 64 1024]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import threading
import time
from pathlib import Path

import _machine
from vectorid import Study
from vectorid.spec import StudySpec
from vectorid.store import Store

STUDY = {
    "study": {"name": "disk", "model": "binh-korn", "trials": 0, "seed": 1},
    "variables": [
        {"name": "x", "low": 0.0, "high": 5.0},
        {"name": "y", "low": 0.0, "high": 3.0},
    ],
    "criteria": [{"name": "f1", "sense": "min"}, {"name": "f2", "sense": "min"}],
    "constraints": [{"name": "g1", "high": 0.0}, {"name": "g2", "high": 0.0}],
}


def footprint(path: Path) -> int:
    total = 0
    for suffix in ("", "-wal", "-shm"):
        try:
            total += os.path.getsize(f"{path}{suffix}")
        except OSError:
            pass
    return total


def one_run(folder: Path, n: int, batch: int, trim: bool) -> tuple[float, int, int, float]:
    """Peak footprint / final size, peak bytes, final bytes, seconds."""
    spec = StudySpec.from_dict({**STUDY, "study": {**STUDY["study"], "trials": n}})
    path = folder / f"disk-{batch}-{int(trim)}.db"
    peak = [0]
    stop = threading.Event()

    def sample() -> None:
        while not stop.is_set():
            peak[0] = max(peak[0], footprint(path))
            time.sleep(0.001)

    saved = Store.WAL_FLOOR
    if not trim:  # the baseline: SQLite's automatic checkpoints only
        Store.WAL_FLOOR = 1 << 62
    try:
        t0 = time.perf_counter()
        with Study.create(spec, path) as st:
            th = threading.Thread(target=sample, daemon=True)
            th.start()
            st.run(executor="inline", batch_size=batch)
            stop.set()
            th.join()
        seconds = time.perf_counter() - t0
    finally:
        Store.WAL_FLOOR = saved
    peak[0] = max(peak[0], footprint(path))
    final = os.path.getsize(path)
    return peak[0] / final, peak[0], final, seconds


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=100_000)
    ap.add_argument("--batch", type=int, nargs="+", default=[64, 1024])
    args = ap.parse_args()
    print(_machine.describe())
    print(f"{args.n} trials of binh-korn, in-process model; footprint = store + -wal + -shm")
    print(
        f"{'batch':>6} {'checkpoints':<26} {'peak/final':>10} {'peak MB':>8} {'final MB':>9} "
        f"{'run s':>6}"
    )
    with tempfile.TemporaryDirectory() as tmp:
        for batch in args.batch:
            for trim, label in ((False, "SQLite automatic (before)"), (True, "vectorid (now)")):
                ratio, peak, final, sec = one_run(Path(tmp), args.n, batch, trim)
                print(
                    f"{batch:>6} {label:<26} {ratio:>10.2f} {peak / 1e6:>8.2f} "
                    f"{final / 1e6:>9.2f} {sec:>6.1f}"
                )


if __name__ == "__main__":
    main()
