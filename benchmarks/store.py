"""Store benchmark: batched writes and loading a million trials into arrays.

Goals (issue 2): batched write >= 1e5 trials/s; 1e6 trials x 50 columns loaded into arrays in
under 2 s. Baselines measured in the same run, on the same data:

* write baseline: the straightforward SQLite layout, one row per trial with one REAL column per
  quantity, inserted with ``executemany`` in the same batches;
* load baseline: reading that per-trial table back with ``SELECT *`` into a numpy array, and
  ``numpy.load`` of the same arrays from an ``.npy`` file (the disk/memory floor).

Usage::

    .venv/bin/python benchmarks/store.py [--n 1000000] [--batch 10000]
"""

from __future__ import annotations

import argparse
import sqlite3
import tempfile
import time
from pathlib import Path

import numpy as np

import _machine
from vectorid import Continuous, Criterion, FunctionalConstraint, Space, StudySpec
from vectorid.store import Store


def make_spec(p: int, k: int, q: int) -> StudySpec:
    return StudySpec(
        name="bench",
        model="binh-korn",
        space=Space([Continuous(f"x{i}", 0.0, 1.0) for i in range(p)]),
        criteria=tuple(Criterion(f"f{i}") for i in range(k)),
        constraints=tuple(FunctionalConstraint(f"g{i}", high=1.0) for i in range(q)),
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--batch", type=int, default=10_000)
    args = ap.parse_args()
    print(_machine.describe())
    n, b = args.n, args.batch
    p, k, q = 30, 12, 8  # 50 columns
    rng = np.random.default_rng(0)
    X, F, G = rng.random((n, p)), rng.random((n, k)), rng.random((n, q))
    S = (rng.random(n) < 0.01).astype(np.int8)
    W = rng.random(n) * 1e-3
    spec = make_spec(p, k, q)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        # -- vectorid store ------------------------------------------------------------
        t0 = time.perf_counter()
        with Store.create(tmp / "v.db", spec) as st:
            for s in range(0, n, b):
                e = min(n, s + b)
                failed = {int(i): "fail" for i in np.flatnonzero(S[s:e])}
                st.write_batch(0, s, X[s:e], F[s:e], G[s:e], S[s:e], W[s:e], failed)
        t_write = time.perf_counter() - t0
        loads = []
        for _ in range(3):
            t0 = time.perf_counter()
            with Store.open(tmp / "v.db") as st:
                tr = st.load()
            loads.append(time.perf_counter() - t0)
        t_load = loads[0]  # the first load after writing, as a user meets it
        assert np.array_equal(tr.X, X) and np.array_equal(tr.F, F) and len(tr.messages) == S.sum()

        # -- baseline: one row per trial, one column per quantity -------------------------
        cols = p + k + q
        con = sqlite3.connect(tmp / "b.db")
        con.execute("PRAGMA journal_mode=WAL")
        con.execute("PRAGMA synchronous=NORMAL")
        names = ", ".join(f"c{i} REAL" for i in range(cols))
        con.execute(f"CREATE TABLE t (id INTEGER PRIMARY KEY, status INTEGER, wall REAL, {names})")
        marks = ", ".join("?" * (cols + 2))
        insert = f"INSERT INTO t (status, wall, {', '.join(f'c{i}' for i in range(cols))}) "
        insert += f"VALUES ({marks})"
        A = np.hstack([X, F, G])
        t0 = time.perf_counter()
        for s in range(0, n, b):
            e = min(n, s + b)
            rows = [(int(S[i]), float(W[i]), *A[i].tolist()) for i in range(s, e)]
            with con:
                con.executemany(
                    insert,
                    rows,
                )
        t_write_base = time.perf_counter() - t0
        t0 = time.perf_counter()
        B = np.array(con.execute("SELECT * FROM t").fetchall(), dtype=float)
        t_load_base = time.perf_counter() - t0
        con.close()
        assert B.shape == (n, cols + 3)
        np.save(tmp / "a.npy", A)
        t0 = time.perf_counter()
        np.load(tmp / "a.npy")
        t_npy = time.perf_counter() - t0
        size_v = (tmp / "v.db").stat().st_size + sum(f.stat().st_size for f in tmp.glob("v.db-*"))

    print(f"store benchmark: {n:,} trials x {p + k + q} columns, batches of {b:,}")
    print(f"{'operation':<44}{'seconds':>10}{'trials/s':>14}{'ratio':>10}")
    print(
        f"{'write, vectorid store (columnar batches)':<44}{t_write:>10.2f}{n / t_write:>14,.0f}"
        f"{t_write_base / t_write:>9.1f}x"
    )
    print(
        f"{'write, baseline (row per trial)':<44}{t_write_base:>10.2f}{n / t_write_base:>14,.0f}"
        f"{1:>9.1f}x"
    )
    print(
        f"{'load, vectorid store -> arrays':<44}{t_load:>10.2f}{n / t_load:>14,.0f}"
        f"{t_load_base / t_load:>9.1f}x"
    )
    print(
        f"{'load, baseline (SELECT * -> array)':<44}{t_load_base:>10.2f}{n / t_load_base:>14,.0f}"
        f"{1:>9.1f}x"
    )
    print(
        f"{'load, numpy .npy of the same arrays (floor)':<44}{t_npy:>10.2f}{n / t_npy:>14,.0f}"
        f"{t_load_base / t_npy:>9.1f}x"
    )
    print(
        f"store size {size_v / 1e6:.0f} MB; store loads (open + load), 3 runs: "
        + ", ".join(f"{x:.2f} s" for x in loads)
    )
    print(
        f"goal write >= 100,000 trials/s: {'met' if n / t_write >= 1e5 else 'NOT met'}; "
        f"goal load < 2 s: {'met' if t_load < 2 else 'NOT met'}"
    )


if __name__ == "__main__":
    main()
