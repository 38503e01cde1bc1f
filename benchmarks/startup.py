"""Benchmark: how fast the ``vectorid`` command starts, and how long models take to compile.

Usage::

    .venv/bin/python benchmarks/startup.py [--trials 100000] [--repeat 7]
                                           [--also-src OTHER/src] [--compile]
    .venv/bin/python benchmarks/startup.py --compile-only [--target avx2]

Goals (issue 13): ``vectorid --help`` <= 0.5 s; ``vectorid info``, ``table`` and ``pareto`` on a
1e5-trial store <= 1 s on 2 cores.

A synthetic store of ``--trials`` trials (6 criteria, 15 parameters, one functional; as in
``benchmarks/report.py``) is written to a temporary folder. Each command runs in a fresh
process, once to warm the file cache (and numba's disk cache), then ``--repeat`` times; the
table gives the best and the median wall time and the ratio of the median to the baseline
``python -c "import numpy"`` measured in the same run (``python -c pass`` is the floor).

* ``vectorid`` rows run the console script of this venv (what a user types).
* ``--also-src DIR`` times the same commands with another source tree first on the path
  (``python -c 'from vectorid.cli import main; main()'`` with ``PYTHONPATH=DIR``), e.g. an
  older commit exported by ``git archive COMMIT src | tar -x -C /tmp/old``, for a before/after
  comparison in one run (its numba kernels compile in the warm-up run).
* ``--compile`` also measures each model's first compilation in an empty numba cache
  (``NUMBA_CACHE_DIR`` set to a new folder), then the first simulation of a fresh process with
  that cache filled: the figures quoted by the "compiling ..." message (``compile_seconds``).

It prints the machine (``benchmarks/_machine.py``: CPU, the ISA numba compiles for, threads,
load) and the load average before and after (the machine may be shared: compare rows of one
run). ``--target avx2`` compiles AVX2 code on an AVX-512 machine (issue 17's cold-start goal:
first use of each model <= 60 s on 2 cores, for either ISA).
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import _machine

HERE = Path(__file__).resolve().parent
SRC = HERE.parent / "src"
LAUNCH = "import sys; from vectorid.cli import main; sys.exit(main())"


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def _synthetic_store(path: Path, n: int) -> None:
    spec = importlib.util.spec_from_file_location("bench_report", HERE / "report.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    mod.synthetic_store(path, n, 6, 15)


def _time(cmd: list[str], env: dict[str, str], repeat: int) -> tuple[float, float]:
    times = []
    for i in range(repeat + 1):
        t0 = time.perf_counter()
        out = subprocess.run(cmd, env=env, capture_output=True, text=True)
        dt = time.perf_counter() - t0
        if out.returncode != 0:
            raise SystemExit(f"{' '.join(cmd)} failed ({out.returncode}):\n{out.stderr}")
        if i:  # the first run warms the caches
            times.append(dt)
    return min(times), statistics.median(times)


def startup(args: argparse.Namespace) -> None:
    py = sys.executable
    script = str(Path(py).parent / "vectorid")
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    with tempfile.TemporaryDirectory() as tmp:
        store = str(Path(tmp) / "big.db")
        t0 = time.perf_counter()
        _synthetic_store(Path(store), args.trials)
        print(f"store of {args.trials} trials written in {time.perf_counter() - t0:.1f} s")
        rows: list[tuple[str, list[str], dict[str, str]]] = [
            ('python -c "pass"', [py, "-c", "pass"], env),
            ('python -c "import numpy"', [py, "-c", "import numpy"], env),
        ]
        verbs = [["--help"], ["info", store], ["table", store], ["pareto", store]]
        for v in verbs:
            label = "vectorid " + " ".join(a if a != store else "STORE" for a in v)
            rows.append((label, [script, *v], env))
        if args.also_src:
            other = dict(env, PYTHONPATH=str(Path(args.also_src).resolve()))
            for v in verbs:
                label = "other src: " + " ".join(a if a != store else "STORE" for a in v)
                rows.append((label, [py, "-c", LAUNCH, *v], other))
        print(f"load average before: {load()}")
        results = [(label, *_time(cmd, e, args.repeat)) for label, cmd, e in rows]
        print(f"load average after:  {load()}")
    base = results[1][2]
    print()
    print(f"{'command (STORE: ' + str(args.trials) + ' trials)':<42} {'best s':>8} "
          f"{'median s':>9} {'/ numpy':>8}")  # fmt: skip
    for label, best, med in results:
        print(f"{label:<42} {best:>8.3f} {med:>9.3f} {med / base:>8.1f}")


def compile_times(args: argparse.Namespace) -> None:
    from vectorid import models

    code = (
        "import sys, time; from vectorid import models; m = models.get(sys.argv[1]); "
        "t = time.perf_counter(); compiled = m.compile(); "
        "m.simulate(m.nominal[None, :], t_final=0.1, dt=0.05); "
        "print(compiled, time.perf_counter() - t)"
    )
    print()
    print(f"load average before: {load()}")
    print(f"{'model':<16} {'first compile: wall s':>22} {'CPU s':>7} "
          f"{'cached, fresh process s':>24}")  # fmt: skip
    for name in sorted(models.available()):
        with tempfile.TemporaryDirectory() as cache:
            env = dict(os.environ, NUMBA_CACHE_DIR=cache)
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            cold = subprocess.run([sys.executable, "-c", code, name], env=env,
                                  capture_output=True, text=True, check=True)  # fmt: skip
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            warm = subprocess.run([sys.executable, "-c", code, name], env=env,
                                  capture_output=True, text=True, check=True)  # fmt: skip
        cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
        c_flag, c_s = cold.stdout.split()
        w_flag, w_s = warm.stdout.split()
        assert c_flag == "True" and w_flag == "False", (name, cold.stdout, warm.stdout)
        print(f"{name:<16} {float(c_s):>22.1f} {cpu:>7.1f} {float(w_s):>24.2f}")
    print(f"load average after:  {load()}")
    print("(CPU s: the whole first process, imports included; the compiler is single-threaded,")
    print(" so on an idle machine the first compile takes about its CPU time)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--trials", type=int, default=100_000)
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--also-src", help="another source tree (its src/ folder) to time")
    ap.add_argument("--compile", action="store_true", help="also time model compilation")
    ap.add_argument(
        "--compile-only", action="store_true", help="time model compilation, not the commands"
    )
    ap.add_argument(
        "--target",
        choices=["native", *_machine.TARGETS],
        default="native",
        help="compile for this vector ISA (avx2: emulated; see benchmarks/_machine.py)",
    )
    args = ap.parse_args()
    rc = _machine.reexec_for_target(__file__, args.target, sys.argv[1:])
    if rc is not None:
        raise SystemExit(rc)
    print(_machine.describe())
    print(f"target measured: {_machine.measured_target()}")
    if not args.compile_only:
        startup(args)
    if args.compile or args.compile_only:
        compile_times(args)


if __name__ == "__main__":
    main()
