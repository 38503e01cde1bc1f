"""Speed of the parafoil demo's stage-2 study run through ``vectorid run`` (issue: seed 000 end to
end).

    .venv/bin/python benchmarks/parafoil_study.py [--trials 16384] [--keep DIR]

What is timed
-------------
* **wall**: ``vectorid run STUDY.toml --trials N`` in a fresh process — the 8-DoF model's 33
  gains over the demo's drop (150 s at dt = 0.05 s, compared every 0.2 s), every criterion of
  the demo (trajectory, course, speed, turn-rate and the three spectral ones), Sobol sampling,
  the SQLite store, start-up and imports included. The study is the demo's stage 2 with every
  gain in its full box ([0.2, 2]; the additive ones in theirs), executor ``serial`` (the
  compiled model runs on every core), the run loop's own batch size.
* **model only** (the baseline, measured in the same run): the same N parameter vectors,
  read back from the store, simulated by the model over the same drop in batches of 1024
  (``Identification.simulate``: the same integration, inputs, wind and initial state), without
  criteria, sampling or store.

The ratio wall / model-only is the overhead of everything that is not the flight simulation
(goal: ≤ 1.3×); the wall time is the absolute goal (≤ 60 s on 2 cores). The numba kernel is
compiled (or loaded from its on-disk cache) before anything is timed. The machine is described
by its CPU model, the vector instruction sets LLVM sees, the core count and the load average
before and after (a loaded machine inflates both times; the ratio less so).
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import _machine

ROOT = Path(__file__).resolve().parents[1]


def write_study(folder: Path, trials: int) -> Path:
    from vectorid import models
    from vectorid.demos.parafoil import DEMO_DATA, MODEL_OPTIONS, stage_toml

    data = folder / "data"
    data.mkdir(parents=True, exist_ok=True)
    for f in DEMO_DATA.glob("*"):
        shutil.copyfile(f, data / f.name)
    import json

    truth = json.loads((DEMO_DATA / "truth.json").read_text(encoding="utf-8"))
    m = models.get("parafoil8dof", **MODEL_OPTIONS)
    variables = [(p.name, p.low, p.high) for p in m.parameters]
    path = folder / "stage2.toml"
    path.write_text(
        stage_toml("bench-stage2", variables, truth=truth, trials=trials, limits=False,
                   comment="benchmark: the demo's stage 2, every gain in its full box (the "
                           "noise floors, computed once at creation, are left out)"),
        encoding="utf-8",
    )  # fmt: skip
    return path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--trials", type=int, default=16_384)
    ap.add_argument("--batch", type=int, default=1024, help="model-only batch size")
    ap.add_argument("--keep", help="folder to keep the study and store in (default: a temp dir)")
    args = ap.parse_args(argv)

    from vectorid.identify import Identification
    from vectorid.spec import load_study
    from vectorid.store import Store

    folder = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="vectorid-bench-"))
    folder.mkdir(parents=True, exist_ok=True)
    study = write_study(folder, args.trials)
    store = folder / "stage2.db"
    if store.exists():
        store.unlink()
    ident = Identification.from_spec(load_study(study))
    drop = ident.drops[0]
    ident.evaluate(np.tile(ident.model.nominal, (4, 1)))  # compile or load the cached kernel

    print(_machine.describe())
    load0 = os.getloadavg()
    print(f"load average before: {load0[0]:.2f} {load0[1]:.2f} {load0[2]:.2f}")
    print(
        f"study: {args.trials} trials of parafoil8dof (33 gains) over {drop.duration:g} s of the "
        f"demo's drop, dt {ident.dt:g} s, comparison every {ident.output_dt:g} s, "
        f"{len(ident.criteria)} criteria"
    )
    sys.stdout.flush()

    exe = Path(sys.executable).with_name("vectorid")
    cmd = [str(exe), "run", str(study), "--trials", str(args.trials), "--store", str(store)]
    ru0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    ru1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu_run = (ru1.ru_utime - ru0.ru_utime) + (ru1.ru_stime - ru0.ru_stime)
    if proc.returncode != 0:
        print(proc.stdout, proc.stderr, sep="\n")
        return proc.returncode

    with Store.open(store) as st:
        trials = st.load()
    order = np.argsort(trials.seq)
    X = trials.X[order]
    c0 = time.process_time()
    t0 = time.perf_counter()
    n_ok = 0
    for s in range(0, len(X), args.batch):
        res = ident.simulate(X[s : s + args.batch], drop)
        n_ok += int(res.ok.sum())
    model_only = time.perf_counter() - t0
    cpu_sim = time.process_time() - c0
    load1 = os.getloadavg()

    n = len(X)
    n_failed = int((trials.status != 0).sum())
    print()
    print("| what | wall (s) | CPU (s, all threads) | trials/s (wall) |")
    print("|---|---|---|---|")
    print(f"| `vectorid run` (fresh process) | {wall:.1f} | {cpu_run:.1f} | {n / wall:.0f} |")
    print(f"| model only, same vectors, batches of {args.batch} | {model_only:.1f} | "
          f"{cpu_sim:.1f} | {n / model_only:.0f} |")  # fmt: skip
    print()
    print(
        f"overhead ratio wall / model-only: {wall / model_only:.2f}x  (goal <= 1.3x); in CPU "
        f"time {cpu_run / cpu_sim:.2f}x (less sensitive to other jobs on the machine)"
    )
    print(f"wall: {wall:.1f} s for {n} trials  (goal <= 60 s on 2 cores)")
    print(
        f"trials: {n} stored, {n_failed} failed (canopy tucked or diverged, stored with their "
        f"reason); model-only ok {n_ok}"
    )
    print(f"load average after: {load1[0]:.2f} {load1[1]:.2f} {load1[2]:.2f}")
    if not args.keep:
        shutil.rmtree(folder, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
