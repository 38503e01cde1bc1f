"""Where a lockstep kernel's time goes, by instruction mix: AVX-512 build against AVX2 build.

Usage::

    .venv/bin/python scripts/kernel_asm.py [--model parachute6dof] [--targets native avx2]

For each target, a fresh process compiles the model's kernel in an empty numba cache
(``benchmarks/_machine.emulation_env`` for ``avx2``: znver3 with every AVX-512 feature off) and
counts the instructions of the generated machine code by kind: double-precision vector
arithmetic by register width (xmm 2, ymm 4, zmm 8 doubles), scalar double arithmetic, stack
loads and stores (register spills), and float/integer conversions. The counts are static (each
instruction once, as written in the code), not executed instructions: a machine without
hardware counters (a VM) cannot count those, and valgrind does not decode AVX-512. Read them
beside the measured time per right-hand-side evaluation (``benchmarks/models.py``: batch wall
x threads / (trials x steps x 4)).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import _machine

PROBE = """
import re, sys
from vectorid import models
m = models.get(sys.argv[1])
m.simulate(m.nominal[None, :], t_final=0.1, dt=0.05)
kernel = sys.modules[type(m).__module__]._kernel
asm = "\\n".join(kernel.inspect_asm().values())
arith = r"v?(add|sub|mul|div|fmadd\\d*|fmsub\\d*|fnmadd\\d*|fnmsub\\d*|sqrt|max|min)"
counts = {
    "zmm": len(re.findall(arith + r"pd\\s+[^\\n]*%zmm", asm)),
    "ymm": len(re.findall(arith + r"pd\\s+[^\\n]*%ymm", asm)),
    "xmm": len(re.findall(arith + r"pd\\s+[^\\n]*%xmm", asm)),
    "scalar": len(re.findall(arith + r"sd\\s", asm)),
    "spill": len(re.findall(r"\\(%rsp\\)", asm)),
    "convert": len(re.findall(r"\\bv?cvtt?(sd2si|pd2qq|pd2dq|si2sd|qq2pd)", asm)),
    "all": len(re.findall(r"^\\s+[a-z]", asm, re.M)),
}
print(" ".join(f"{k}={v}" for k, v in counts.items()))
"""


def measure(model: str, target: str) -> dict[str, int]:
    env = dict(os.environ)
    env.update(_machine.emulation_env(target))
    with tempfile.TemporaryDirectory(prefix="numba-asm-") as cache:
        env["NUMBA_CACHE_DIR"] = cache
        out = subprocess.run(
            [sys.executable, "-c", PROBE, model], env=env, capture_output=True, text=True
        )
    if out.returncode != 0:
        raise SystemExit(f"compiling {model} for {target} failed:\n{out.stderr[-2000:]}")
    line = out.stdout.strip().splitlines()[-1]
    return {k: int(v) for k, v in (item.split("=") for item in line.split())}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--model", default="parachute6dof")
    ap.add_argument("--targets", nargs="+", default=["native", "avx2"])
    args = ap.parse_args()
    print(_machine.describe())
    print(
        f"{'target':<8} {'zmm':>6} {'ymm':>6} {'xmm':>6} {'scalar':>7} {'spills':>7} {'cvt':>5} "
        f"{'all instr':>10}"
    )
    for target in args.targets:
        c = measure(args.model, target)
        print(
            f"{target:<8} {c['zmm']:>6} {c['ymm']:>6} {c['xmm']:>6} {c['scalar']:>7} "
            f"{c['spill']:>7} {c['convert']:>5} {c['all']:>10}"
        )
    print("(static counts of double-precision arithmetic instructions in the compiled kernel)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
