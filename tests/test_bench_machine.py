"""benchmarks/_machine.py: the machine line and the AVX2 emulation environment."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCH))
import _machine  # noqa: E402  (benchmarks/ is not a package)


def test_describe_names_cpu_isa_threads_and_load():
    text = _machine.describe()
    lines = text.splitlines()
    assert len(lines) == 2
    assert lines[0].startswith("CPU: ") and "numba target: " in lines[0]
    assert "avx512f " in lines[0] and "avx2 " in lines[0]
    assert "numba threads: " in lines[1] and "load average: " in lines[1]


def test_avx2_env_switches_avx512_off_explicitly():
    env = _machine.emulation_env("avx2")
    assert env["NUMBA_CPU_NAME"] == "znver3"
    feats = _machine._parse_features(env["NUMBA_CPU_FEATURES"])
    assert feats  # the host's full list, so nothing is left to numba's host default
    assert not any(on for name, on in feats.items() if name.startswith(("avx512", "amx")))
    assert "avx512f" in feats and feats["avx512f"] is False
    assert env["NUMBA_CACHE_DIR"].endswith("vectorid-numba-avx2")
    assert "AVX512F" in env["NPY_DISABLE_CPU_FEATURES"]
    assert _machine.emulation_env("native") == {}
    with pytest.raises(ValueError, match="unknown target"):
        _machine.emulation_env("sse9")


@pytest.mark.skipif(
    not _machine.isa_flags()[1].get("avx512f", False), reason="the host has no AVX-512"
)
def test_avx2_env_compiles_without_avx512_registers(tmp_path):
    # numba with NUMBA_CPU_NAME alone keeps the host's AVX-512 features; with the emulation
    # environment a vectorisable loop must use no zmm and no mask (k) register.
    code = (
        "import re, numba, numpy as np\n"
        "@numba.njit\n"
        "def f(a, b):\n"
        "    s = 0\n"
        "    for i in range(a.size):\n"
        "        s += a[i] <= b[i]\n"
        "    return s\n"
        "f(np.ones(64), np.ones(64))\n"
        "asm = ''.join(f.inspect_asm().values())\n"
        "print('ymm' in asm, 'zmm' in asm, bool(re.search(r'%k[1-7]', asm)))\n"
    )
    env = dict(os.environ)
    env.update(_machine.emulation_env("avx2"))
    env["NUMBA_CACHE_DIR"] = str(tmp_path)
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    )
    assert out.stdout.split() == ["True", "False", "False"]
