"""Describe the machine a benchmark runs on, and compile for another vector ISA.

Shared by the scripts in ``benchmarks/``; needs only the standard library, numba and llvmlite.

* :func:`describe` gives one or two lines: CPU model, the CPU name and vector ISA that numba
  compiles for (``NUMBA_CPU_NAME`` / ``NUMBA_CPU_FEATURES`` when set, else the LLVM host CPU),
  numba's thread count, the CPUs this process may use and the load average.
* :func:`emulation_env` gives the environment variables under which numba compiles for another
  ISA on this machine, e.g. AVX2 code on an AVX-512 machine. A benchmark re-executes itself in a
  subprocess with them (numba reads them when it is imported).

Why features as well as a CPU name: numba's ``CPUCodegen._get_host_cpu_features`` returns
``NUMBA_CPU_FEATURES`` when set and otherwise the *host's* features, even when ``NUMBA_CPU_NAME``
names another CPU; ``NUMBA_CPU_NAME=znver3`` alone on an AVX-512 host therefore still emits
AVX-512 (zmm) code. :func:`emulation_env` passes the host's features with every AVX-512, AVX10
and AMX feature switched off explicitly, and a separate ``NUMBA_CACHE_DIR`` (the cache index is
keyed on CPU name and features, but a separate directory keeps the native cache untouched and
makes a cold compile easy to measure).
"""

from __future__ import annotations

import os
import platform

__all__ = [
    "TARGETS",
    "Busy",
    "describe",
    "emulation_env",
    "isa_flags",
    "measured_target",
    "reexec_for_target",
]

#: Targets :func:`emulation_env` knows: name -> (LLVM CPU name, feature prefixes switched off).
TARGETS: dict[str, tuple[str, tuple[str, ...]]] = {
    "avx2": ("znver3", ("avx512", "avx10", "amx", "evex512", "avxvnni")),
}
#: numpy's own run-time dispatch (sorts, reductions) switched off for the same target; numpy
#: ignores the names it was not built with.
_NPY_OFF: dict[str, str] = {
    "avx2": "X86_V4 AVX512F AVX512CD AVX512_SKX AVX512_CLX AVX512_CNL AVX512_ICL AVX512_SPR",
}


def cpu_model() -> str:
    """The CPU model as the OS reports it, with family/model numbers where known (Linux)."""
    info: dict[str, str] = {}
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if not line.strip():
                    break  # the first CPU is enough
                key, _, value = line.partition(":")
                info[key.strip()] = value.strip()
    except OSError:
        pass
    name = info.get("model name") or platform.processor() or platform.machine() or "unknown CPU"
    if "cpu family" in info and "model" in info:
        name += f" (family {info['cpu family']}, model {info['model']})"
    return name


def _host_features() -> dict[str, bool]:
    import llvmlite.binding as ll

    return {name: bool(on) for name, on in ll.get_host_cpu_features().items()}


def _parse_features(spec: str) -> dict[str, bool]:
    out: dict[str, bool] = {}
    for item in spec.split(","):
        item = item.strip()
        if item[:1] in "+-" and len(item) > 1:
            out[item[1:]] = item[0] == "+"
    return out


def isa_flags() -> tuple[str, dict[str, bool]]:
    """(CPU name, features) numba compiles for in this process's environment."""
    import llvmlite.binding as ll

    name = os.environ.get("NUMBA_CPU_NAME") or ll.get_host_cpu_name()
    spec = os.environ.get("NUMBA_CPU_FEATURES")
    feats = _parse_features(spec) if spec else _host_features()
    return name, feats


def describe() -> str:
    """Two lines: CPU model and the ISA numba targets; threads, usable CPUs and load average."""
    try:  # what vectorid does before numba compiles (full-width vectors on AVX-512)
        from vectorid._simd import configure

        configure()
    except ImportError:
        pass
    import numba

    name, feats = isa_flags()
    source = "NUMBA_CPU_NAME" if os.environ.get("NUMBA_CPU_NAME") else "LLVM host"
    if os.environ.get("NUMBA_CPU_FEATURES"):
        source += " + NUMBA_CPU_FEATURES"
    isa = ", ".join(f"{f} {'on' if feats.get(f, False) else 'off'}" for f in ("avx512f", "avx2"))
    if feats.get("avx512f", False):
        # vectorid._simd switches LLVM's 256-bit preference off (VECTORID_VECTOR_WIDTH=256 keeps it)
        pref = feats.get("prefer-256-bit")
        isa += ", vectors: " + ("512-bit" if pref is False else "LLVM's default width")
    try:
        cpus = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cpus = os.cpu_count() or 1
    load = ", ".join(f"{x:.2f}" for x in os.getloadavg())
    return (
        f"CPU: {cpu_model()}; numba target: {name} ({source}), {isa}\n"
        f"numba threads: {numba.get_num_threads()} (layer {numba.config.THREADING_LAYER}), "
        f"usable CPUs: {cpus}, load average: {load}"
    )


def emulation_env(target: str) -> dict[str, str]:
    """Environment variables under which numba compiles for ``target`` on this machine.

    ``"avx2"``: ``NUMBA_CPU_NAME=znver3`` (AMD Zen 3: AVX2 + FMA, no AVX-512), the host's
    features with every AVX-512 / AVX10 / AMX feature off (``NUMBA_CPU_FEATURES``),
    ``NUMBA_CACHE_DIR=~/.cache/vectorid-numba-avx2``, and ``NPY_DISABLE_CPU_FEATURES`` naming
    numpy's AVX-512 dispatch targets (numpy's sorts use AVX-512 when the CPU has it). Merge
    into ``os.environ`` of a *new* process (numba and numpy read them at import).
    ``"native"`` gives ``{}``.
    """
    if target == "native":
        return {}
    if target not in TARGETS:
        raise ValueError(f"unknown target {target!r}; expected 'native' or one of {list(TARGETS)}")
    cpu, off = TARGETS[target]
    feats = _host_features()
    spec = ",".join(
        ("-" if name.startswith(off) else "+" if on else "-") + name
        for name, on in sorted(feats.items())
    )
    cache = os.path.join(os.path.expanduser("~"), ".cache", f"vectorid-numba-{target}")
    return {
        "NUMBA_CPU_NAME": cpu,
        "NUMBA_CPU_FEATURES": spec,
        "NUMBA_CACHE_DIR": cache,
        "NPY_DISABLE_CPU_FEATURES": _NPY_OFF[target],
    }


#: Set in the re-executed process so that it does not re-execute again.
_TARGET_ENV = "VECTORID_BENCH_TARGET"


def measured_target() -> str:
    """``"native"``, or the emulated target this process was re-executed for."""
    return os.environ.get(_TARGET_ENV, "native")


def reexec_for_target(script: str, target: str, argv: list[str]) -> int | None:
    """Run ``script`` again under :func:`emulation_env` (numba reads it at import).

    Returns the child's exit status, or ``None`` when this process already measures ``target``
    (it is native, or this is the re-executed child)."""
    import subprocess
    import sys

    if target == "native" or measured_target() == target:
        return None
    env = dict(os.environ)
    env.update(emulation_env(target))
    env[_TARGET_ENV] = target
    print(
        f"re-executing for target {target}: NUMBA_CPU_NAME={env['NUMBA_CPU_NAME']}, AVX-512 "
        f"features off, cache {env['NUMBA_CACHE_DIR']} (first run compiles)",
        flush=True,
    )
    return subprocess.run([sys.executable, os.path.abspath(script), *argv], env=env).returncode


class Busy:
    """``with Busy(n):`` runs ``n`` CPU-bound busy-loop processes (a loaded machine); or call
    :meth:`start` and :meth:`stop`."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.procs: list = []

    def start(self) -> Busy:
        import subprocess
        import sys
        import time

        self.procs = [
            subprocess.Popen([sys.executable, "-c", "while True: pass"], stdin=subprocess.DEVNULL)
            for _ in range(self.n)
        ]
        if self.procs:
            time.sleep(1.0)  # let them start spinning
        return self

    def stop(self) -> None:
        for p in self.procs:
            p.kill()
        for p in self.procs:
            p.wait()
        self.procs = []

    def __enter__(self) -> Busy:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
