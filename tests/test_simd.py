"""vectorid._simd: full-width vectors on AVX-512 CPUs, never over the user's own choice."""

from __future__ import annotations

import os
import subprocess
import sys

import llvmlite.binding as ll
import pytest

PROBE = "import os, vectorid.models; print(os.environ.get('NUMBA_CPU_FEATURES', '<unset>'))"


def _features_after_import(**env: str) -> str:
    clean = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_CPU", "VECTORID_"))}
    clean.update(env)
    out = subprocess.run(
        [sys.executable, "-c", PROBE], env=clean, capture_output=True, text=True, check=True
    )
    return out.stdout.strip()


def test_avx512_hosts_get_512_bit_vectors_others_nothing():
    got = _features_after_import()
    if ll.get_host_cpu_features().get("avx512f"):
        assert got.endswith(",-prefer-256-bit")
        assert "+avx512f" in got  # the host's own features, not a guess
    else:
        assert got == "<unset>"


@pytest.mark.parametrize(
    "env",
    [
        {"VECTORID_VECTOR_WIDTH": "256"},
        {"NUMBA_CPU_NAME": "haswell"},
        {"NUMBA_CPU_FEATURES": "+avx2"},
    ],
)
def test_the_users_choice_wins(env):
    got = _features_after_import(**env)
    assert "prefer-256-bit" not in got
    if "NUMBA_CPU_FEATURES" in env:
        assert got == env["NUMBA_CPU_FEATURES"]
