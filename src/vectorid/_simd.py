"""The vector width numba compiles vectorid's kernels for.

LLVM's models of several AVX-512 CPUs (Intel Skylake-SP to Rocket Lake and Ice Lake among them)
carry the tuning flag ``prefer-256-bit``: code on them uses 256-bit (``ymm``) vectors, 4
doubles per instruction, although the CPU has 512-bit ones. The lockstep kernels
(:func:`vectorid.models.integrate.rk4_lanes`) are written to fill 512-bit vectors: measured on
an Intel Xeon (family 6, model 167, LLVM ``rocketlake``), the parachute batch of
``benchmarks/models.py`` took 0.46 s with 512-bit vectors against 0.59 s with 256-bit ones
(550x against 404x the solve_ivp baseline).

:func:`configure` switches that flag off for the process before numba compiles anything,
through ``NUMBA_CPU_FEATURES`` (the host's own feature list, plus ``-prefer-256-bit``), which
numba reads when it creates its compiler and which worker processes inherit. It changes nothing
when the CPU has no AVX-512, when the user has set ``NUMBA_CPU_NAME`` or
``NUMBA_CPU_FEATURES`` (their choice wins), or when ``VECTORID_VECTOR_WIDTH=256`` asks for the
LLVM default. numba compiles for the whole process at once, so other numba code of the same
process gets the same preference. The numba cache is keyed by these features: a change
compiles once, then is cached.
"""

from __future__ import annotations

import os
import sys

__all__ = ["configure"]

#: Set to ``256`` to keep LLVM's default vector width on AVX-512 CPUs.
ENV = "VECTORID_VECTOR_WIDTH"

_done = False


def configure() -> str | None:
    """Let numba use 512-bit vectors on AVX-512 CPUs; returns the feature string set, or None.

    Call before numba compiles anything (vectorid's numba modules call it on import).
    """
    global _done
    if _done:
        return None
    _done = True
    if os.environ.get(ENV, "").strip() == "256":
        return None
    if "NUMBA_CPU_NAME" in os.environ or "NUMBA_CPU_FEATURES" in os.environ:
        return None
    try:
        import llvmlite.binding as ll

        features = ll.get_host_cpu_features()
    except Exception:  # no feature query on this platform: leave numba's defaults
        return None
    if not features.get("avx512f"):
        return None
    spec = features.flatten() + ",-prefer-256-bit"
    os.environ["NUMBA_CPU_FEATURES"] = spec
    config = sys.modules.get("numba.core.config")
    if config is not None:  # numba already imported: it reads config when it first compiles
        config.CPU_FEATURES = spec
    return spec
