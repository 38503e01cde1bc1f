"""Vectorisable elementary functions against numpy: accuracy, special values, vectorisation."""

import re

import numpy as np
import pytest
from numba import njit

from vectorid.models import vecmath as vm


@njit(error_model="numpy", fastmath={"contract"})  # the flags of the lockstep kernels
def _apply(x, y, out):
    for i in range(x.shape[0]):
        s, c = vm.sincos(x[i])
        out[0, i] = s
        out[1, i] = c
        out[2, i] = vm.atan2(y[i], x[i])
        out[3, i] = vm.exp(x[i])
        out[4, i] = vm.sin(x[i])
        out[5, i] = vm.cos(x[i])
        out[6, i] = vm.sincos_hot(x[i])[0]
        out[7, i] = vm.sincos_hot(x[i])[1]
        out[8, i] = vm.atan2_hot(y[i], x[i])
        out[9, i] = vm.sin_hot(x[i])


def _run(x, y):
    out = np.empty((10, x.size))
    _apply(np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(y, dtype=float), out)
    return out


def _ulp(got, want):
    ok = np.isfinite(want) & (want != 0)
    return np.max(np.abs(got[ok] - want[ok]) / np.spacing(np.abs(want[ok])))


@pytest.fixture(scope="module")
def samples():
    rng = np.random.default_rng(0)
    x = np.concatenate(
        [
            rng.uniform(-10, 10, 200_000),
            rng.uniform(-1e5, 1e5, 50_000),
            rng.uniform(-745, 709, 50_000),
            np.pi / 4 * np.arange(-40, 41),  # quadrant boundaries
            [1e-300, -1e-310, 5e-324],
        ]
    )
    y = np.concatenate(
        [
            rng.uniform(-10, 10, 200_000),
            rng.uniform(-1e-3, 1e-3, 50_000),  # |y| << |x|
            rng.uniform(-1e6, 1e6, 50_000),  # |y| >> |x|
            rng.uniform(-1, 1, 81),
            [1.0, 0.0, -2.0],
        ]
    )
    return x, y, _run(x, y)


def test_sin_cos_within_two_ulp(samples):
    x, _, out = samples
    assert _ulp(out[0], np.sin(x)) <= 2
    assert _ulp(out[1], np.cos(x)) <= 2
    np.testing.assert_array_equal(out[4], out[0])
    np.testing.assert_array_equal(out[5], out[1])
    # identities hold to rounding, and the quadrant logic never flips a sign
    np.testing.assert_allclose(out[0] ** 2 + out[1] ** 2, 1.0, rtol=0, atol=1e-15)
    clear = np.abs(np.sin(x)) > 1e-12
    np.testing.assert_array_equal(np.sign(out[0][clear]), np.sign(np.sin(x)[clear]))


def test_atan2_within_three_ulp_in_every_octant(samples):
    x, y, out = samples
    want = np.arctan2(y, x)
    assert _ulp(out[2], want) <= 3
    for sx in (1, -1):
        for sy in (1, -1):
            for big in (0.5, 2.0):  # |y| < |x| and |y| > |x|
                xs, ys = sx * np.ones(7), sy * big * np.linspace(0.1, 1, 7)
                np.testing.assert_allclose(_run(xs, ys)[2], np.arctan2(ys, xs), rtol=1e-15)


def test_exp_within_one_ulp_over_its_range(samples):
    x, _, out = samples
    with np.errstate(over="ignore"):
        want = np.exp(x)
    assert _ulp(out[3], want) <= 1
    got = _run(np.array([-745.2, -740.0, 709.7, 710.0, -np.inf, np.inf]), np.zeros(6))[3]
    with np.errstate(over="ignore"):
        np.testing.assert_allclose(got, np.exp([-745.2, -740.0, 709.7, 710.0, -np.inf, np.inf]))


def test_special_values_follow_numpy():
    x = np.array([0.0, -0.0, 1.0, -1.0, 0.0, np.nan, 1.0, np.inf, -np.inf, 3.0])
    y = np.array([0.0, 0.0, 0.0, 0.0, -2.0, 1.0, np.nan, 1.0, 1.0, np.inf])
    out = _run(x, y)
    np.testing.assert_array_equal(out[2], np.arctan2(y, x))
    with np.errstate(invalid="ignore"):
        np.testing.assert_array_equal(np.isnan(out[0]), np.isnan(np.sin(x)))
        np.testing.assert_array_equal(np.isnan(out[1]), np.isnan(np.cos(x)))
    assert np.isnan(_run(np.array([np.nan]), np.array([0.0]))[3][0])


def test_hot_loop_twins_give_the_same_bits(samples):
    """Inlined by numba, the twins take the caller's flags: the kernels' (contract) here."""
    _, _, out = samples
    np.testing.assert_array_equal(out[6], out[0])
    np.testing.assert_array_equal(out[7], out[1])
    np.testing.assert_array_equal(out[8], out[2])
    np.testing.assert_array_equal(out[9], out[0])


def test_a_loop_over_them_is_vectorised():
    """The point of the module: LLVM turns such a loop into SIMD code (8 doubles per op)."""
    asm = next(iter(_apply.inspect_asm().values()))
    simd = len(re.findall(r"\b(vfmadd\d+pd|vmulpd|vaddpd)\s+%[yz]mm", asm))
    assert simd > 20, "the loop over vecmath calls was not vectorised"


# The loop of _apply compiled for an AVX2 machine (no AVX-512), in a fresh process and cache.
_AVX2_PROBE = """
import re
import numpy as np
from numba import njit
from vectorid.models import vecmath as vm

@njit(error_model="numpy", fastmath={"contract"})
def apply(x, y, out):
    for i in range(x.shape[0]):
        s, c = vm.sincos(x[i])
        out[0, i] = s + c
        out[1, i] = vm.atan2(y[i], x[i])
        out[2, i] = vm.exp(x[i])

x = np.linspace(-5.0, 5.0, 64)
apply(x, x, np.empty((3, 64)))
asm = next(iter(apply.inspect_asm().values()))
print(len(re.findall(r"%zmm", asm)),
      len(re.findall(r"\\b(vfmadd\\d+pd|vmulpd|vaddpd)\\s+%ymm", asm)),
      len(re.findall(r"\\bv?cvtt?sd2si", asm)))
"""


def test_no_float_to_integer_conversion_in_the_vector_loop():
    """Quadrant and exponent are found in floating point: AVX2 has no vector double -> int64
    conversion, so one would make LLVM convert lane by lane inside the loop."""
    asm = next(iter(_apply.inspect_asm().values()))
    assert not re.search(r"\bv?cvtt?(sd2si|pd2qq|pd2dq)", asm)


def test_the_loop_vectorises_for_avx2_as_well(tmp_path):
    """Compiled for Haswell (AVX2 + FMA, 4 doubles per instruction) in a fresh process: ymm
    arithmetic, no AVX-512 register, no scalar conversion."""
    import os
    import subprocess
    import sys

    env = dict(os.environ, NUMBA_CPU_NAME="haswell", NUMBA_CPU_FEATURES="")
    env["NUMBA_CACHE_DIR"] = str(tmp_path)
    out = subprocess.run(
        [sys.executable, "-c", _AVX2_PROBE], env=env, capture_output=True, text=True, check=True
    )
    zmm, ymm_ops, scalar_cvt = (int(v) for v in out.stdout.split())
    assert zmm == 0
    assert ymm_ops > 15
    assert scalar_cvt == 0
