"""Tests for vectorid.analysis.pareto (Edgeworth–Pareto filter)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from vectorid.analysis import pareto
from vectorid.analysis.pareto import pareto_indices, pareto_mask

# --------------------------------------------------------------------------------------------
# independent references
# --------------------------------------------------------------------------------------------


def _signed(F, senses):
    F = np.asarray(F, dtype=float)
    if senses is None:
        return F.copy()
    sgn = np.array([-1.0 if s == "max" else 1.0 for s in senses])
    return F * sgn


def brute_mask(F, senses=None):
    """O(n^2 k) reference written directly from the definition, one row at a time."""
    S = _signed(F, senses)
    n = S.shape[0]
    feasible = ~np.isnan(S).any(axis=1)
    out = np.zeros(n, dtype=bool)
    for i in range(n):
        if not feasible[i]:
            continue
        dominated = False
        for j in range(n):
            if j == i or not feasible[j]:
                continue
            if np.all(S[j] <= S[i]) and np.any(S[j] < S[i]):
                dominated = True
                break
        out[i] = not dominated
    return out


def lexsort_mask(F, senses=None):
    """Vectorised reference: lexicographic presort, then each row against the front so far.

    In lexicographic order a row never precedes a row that dominates it, so a row is
    non-dominated iff no earlier non-dominated row dominates it. Pure numpy, one row at a time.
    """
    S = _signed(F, senses)
    feasible = np.flatnonzero(~np.isnan(S).any(axis=1))
    T = S[feasible]
    order = np.lexsort(T.T[::-1])
    front = np.empty_like(T)
    members = []
    for i in order:
        p = T[i]
        cur = front[: len(members)]
        if ((cur <= p).all(axis=1) & (cur < p).any(axis=1)).any():
            continue
        front[len(members)] = p
        members.append(i)
    out = np.zeros(S.shape[0], dtype=bool)
    out[feasible[members]] = True
    return out


# --------------------------------------------------------------------------------------------
# property-based tests
# --------------------------------------------------------------------------------------------

#: Few distinct values -> many ties and exact duplicates; includes ±inf, ±0, subnormal, huge.
TRICKY = [-np.inf, -1e308, -1.0, -0.0, 0.0, 5e-324, 1.0, 2.0, 1e308, np.inf]


SMALL_INTS = st.integers(0, 3).map(float)


@st.composite
def problems(draw, values=SMALL_INTS, max_k=6, max_n=40, nan_rows=True):
    n = draw(st.integers(0, max_n))
    k = draw(st.integers(1, max_k))
    F = draw(hnp.arrays(np.float64, (n, k), elements=values))
    if nan_rows and n > 0:
        bad = draw(st.lists(st.integers(0, n - 1), max_size=3))
        cols = draw(st.lists(st.integers(0, k - 1), min_size=len(bad), max_size=len(bad)))
        F[bad, cols] = np.nan
    senses = draw(st.none() | st.lists(st.sampled_from(["min", "max"]), min_size=k, max_size=k))
    return F, senses


@pytest.mark.slow
@settings(max_examples=400, deadline=None)
@given(problems())
def test_matches_brute_force_on_small_integer_grids(problem):
    F, senses = problem
    expected = brute_mask(F, senses)
    got = pareto_mask(F, senses)
    assert got.dtype == bool
    assert got.shape == (F.shape[0],)
    np.testing.assert_array_equal(got, expected)


@settings(max_examples=300, deadline=None)
@given(problems(values=st.sampled_from(TRICKY)))
def test_matches_brute_force_with_infinities_and_extreme_values(problem):
    F, senses = problem
    np.testing.assert_array_equal(pareto_mask(F, senses), brute_mask(F, senses))


@settings(max_examples=300, deadline=None)
@given(problems(values=st.integers(0, 4).map(float), max_n=120), st.sampled_from([0, 1, 2, 5]))
def test_kernels_exact_with_few_or_no_pivots(problem, n_pivots):
    # With few pivots the pre-filter passes dominated rows on, so the exact kernels (k = 2 sweep,
    # k = 3 Fenwick sweep, k >= 4 skyline with tie-breaking) do the real work; with 0 pivots
    # they see every feasible row.
    F, senses = problem
    sgn = np.array([-1.0 if s == "max" else 1.0 for s in senses]) if senses else np.ones(F.shape[1])
    got = pareto._mask_signed(np.ascontiguousarray(F), sgn, n_pivots)
    np.testing.assert_array_equal(got, brute_mask(F, senses))


@settings(max_examples=200, deadline=None)
@given(problems(values=st.sampled_from(TRICKY), max_n=30))
def test_lexsort_reference_agrees_with_brute_force(problem):
    F, senses = problem
    np.testing.assert_array_equal(lexsort_mask(F, senses), brute_mask(F, senses))


@settings(max_examples=300, deadline=None)
@given(problems(values=st.sampled_from(TRICKY), max_n=60), st.sampled_from([0, 1, 3]))
def test_kernels_exact_with_few_pivots_and_extreme_values(problem, n_pivots):
    F, senses = problem
    sgn = np.array([-1.0 if s == "max" else 1.0 for s in senses]) if senses else np.ones(F.shape[1])
    got = pareto._mask_signed(np.ascontiguousarray(F), sgn, n_pivots)
    np.testing.assert_array_equal(got, brute_mask(F, senses))


@pytest.mark.parametrize("k", [2, 3, 4, 5])
@pytest.mark.parametrize("first", ["dominated", "dominator"])
def test_dominator_with_an_equal_rounded_key(k, first):
    # Column 0 spans (-1e308, 1e308), so 0 and 5e-324 normalise to the same value and rows A and
    # B get equal sort keys although A dominates B: the skyline must break the tie correctly.
    A = [0.0] * k
    B = [5e-324] + [0.0] * (k - 1)
    others = [[-1e308] + [2.0] * (k - 1), [1e308] + [-1.0] * (k - 1)]
    rows = [B, A] if first == "dominated" else [A, B]
    F = np.array(rows + others)
    expected = np.array([first == "dominator", first == "dominated", True, True])
    for n_pivots in (0, 64):
        got = pareto._mask_signed(F, np.ones(k), n_pivots)
        np.testing.assert_array_equal(got, expected)
    np.testing.assert_array_equal(pareto_mask(F), expected)
    np.testing.assert_array_equal(pareto_mask(F), brute_mask(F))


@settings(max_examples=100, deadline=None)
@given(problems(values=st.floats(-10, 10, allow_nan=False), max_k=5, max_n=60))
def test_matches_brute_force_on_continuous_values(problem):
    F, senses = problem
    np.testing.assert_array_equal(pareto_mask(F, senses), brute_mask(F, senses))


@settings(max_examples=100, deadline=None)
@given(problems(max_n=30))
def test_invariant_under_row_permutation_and_flipping_senses(problem):
    F, senses = problem
    k = F.shape[1]
    senses = senses or ["min"] * k
    perm = np.random.default_rng(F.shape[0]).permutation(F.shape[0])
    base = pareto_mask(F, senses)
    np.testing.assert_array_equal(pareto_mask(F[perm], senses), base[perm])
    flipped = ["max" if s == "min" else "min" for s in senses]
    np.testing.assert_array_equal(pareto_mask(-F, flipped), base)


# --------------------------------------------------------------------------------------------
# unit cases
# --------------------------------------------------------------------------------------------


def test_empty_input_gives_empty_mask():
    got = pareto_mask(np.empty((0, 3)))
    assert got.shape == (0,)
    assert got.dtype == bool
    assert pareto_indices(np.empty((0, 2))).shape == (0,)


def test_single_criterion_keeps_all_copies_of_the_best():
    F = np.array([[3.0], [1.0], [2.0], [1.0], [np.nan], [5.0]])
    np.testing.assert_array_equal(pareto_mask(F), [False, True, False, True, False, False])
    np.testing.assert_array_equal(
        pareto_mask(F, senses=["max"]), [False, False, False, False, False, True]
    )


def test_single_criterion_with_only_failed_trials():
    np.testing.assert_array_equal(pareto_mask([[np.nan], [np.nan]]), [False, False])


def test_all_equal_rows_are_all_kept():
    F = np.full((7, 4), 2.5)
    assert pareto_mask(F).all()


def test_one_dominating_row_is_the_only_front():
    rng = np.random.default_rng(0)
    F = rng.random((500, 4)) + 1.0
    F[123] = 0.5
    expected = np.zeros(500, dtype=bool)
    expected[123] = True
    np.testing.assert_array_equal(pareto_mask(F), expected)
    np.testing.assert_array_equal(pareto_indices(F), [123])


def test_hand_example_front():
    # (cost, error): rows 0, 1, 3 trade off; 2 is dominated by 1; 4 duplicates 1; 5 is failed;
    # 6 is dominated by 3 only through the second criterion (equal first criterion).
    F = np.array(
        [
            [1.0, 9.0],
            [2.0, 4.0],
            [3.0, 5.0],
            [5.0, 1.0],
            [2.0, 4.0],
            [np.nan, 0.0],
            [5.0, 2.0],
        ]
    )
    np.testing.assert_array_equal(pareto_mask(F), [True, True, False, True, True, False, False])
    np.testing.assert_array_equal(pareto_indices(F), [0, 1, 3, 4])
    # maximise the second criterion instead: (1, 9) dominates all with cost >= 1 and value <= 9
    np.testing.assert_array_equal(
        pareto_mask(F, senses=["min", "max"]), [True, False, False, False, False, False, False]
    )


def test_failed_trial_never_dominates():
    F = np.array([[0.0, 0.0, np.nan], [1.0, 1.0, 1.0], [2.0, 2.0, 2.0]])
    np.testing.assert_array_equal(pareto_mask(F), [False, True, False])


def test_infinities_are_ordinary_values():
    F = np.array([[-np.inf, 5.0], [0.0, 0.0], [np.inf, -1.0], [np.inf, -1.0], [-np.inf, 6.0]])
    np.testing.assert_array_equal(pareto_mask(F), [True, True, True, True, False])
    # maximising both: (0, 0) is not beaten by (inf, -1) nor by (-inf, 6)
    np.testing.assert_array_equal(pareto_mask(F, ["max", "max"]), [False, True, True, True, True])


def test_accepts_lists_ints_bools_float32_and_strided_input_without_modifying_it():
    F = np.array([[1, 4], [2, 2], [3, 3], [4, 1]], dtype=np.int64)
    expected = [True, True, False, True]
    np.testing.assert_array_equal(pareto_mask(F.tolist()), expected)
    np.testing.assert_array_equal(pareto_mask(F), expected)
    np.testing.assert_array_equal(pareto_mask(F.astype(np.float32)), expected)
    np.testing.assert_array_equal(pareto_mask(np.asfortranarray(F)), expected)
    wide = np.repeat(F, 2, axis=1)  # strided view below
    np.testing.assert_array_equal(pareto_mask(wide[:, ::2]), expected)
    np.testing.assert_array_equal(
        pareto_mask(np.array([[True, False], [False, True], [True, True]])), [True, True, False]
    )
    G = np.array([[1.0, 4.0], [2.0, 2.0]])
    before = G.copy()
    pareto_mask(G, ["max", "min"])
    np.testing.assert_array_equal(G, before)


# --------------------------------------------------------------------------------------------
# validation
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("senses", "pattern"),
    [
        (["min"], r"expected 3 entries, got 1"),
        (["min", "max", "min", "max"], r"expected 3 entries, got 4"),
        (["min", "MAX", "min"], r"senses\[1\] must be 'min' or 'max'.*got 'MAX'"),
        (["min", "min", 1], r"senses\[2\] must be 'min' or 'max'.*got 1"),
        ("min", r"single string 'min'.*\['min'\] \* 3"),
        (5, r"sequence of 3 strings.*got int 5"),
    ],
)
def test_senses_validation_messages(senses, pattern):
    with pytest.raises(ValueError, match=pattern):
        pareto_mask(np.zeros((4, 3)), senses)


@pytest.mark.parametrize(
    ("F", "pattern"),
    [
        (np.zeros(5), r"2-D numeric array.*ndim=1.*reshape"),
        (np.zeros((2, 2, 2)), r"2-D numeric array.*ndim=3"),
        (np.array([["a", "b"]]), r"must be numeric.*dtype <U1.*dtype=float"),
        (np.array([[1 + 1j, 2]]), r"must be numeric.*complex"),
        (np.zeros((3, 0)), r"at least one criterion column.*\(3, 0\)"),
        ([[1.0, 2.0], [3.0]], r"could not be converted.*same length"),
    ],
)
def test_matrix_validation_messages(F, pattern):
    with pytest.raises(ValueError, match=pattern):
        pareto_mask(F)


# --------------------------------------------------------------------------------------------
# large inputs through the fast paths
# --------------------------------------------------------------------------------------------


def _large(kind, n, k, seed):
    rng = np.random.default_rng(seed)
    if kind == "uniform":
        return rng.random((n, k))
    if kind == "correlated":
        return rng.random((n, 1)) + 0.05 * rng.standard_normal((n, k))
    if kind == "ties":  # coarse grid: many equal keys and exact duplicates
        return rng.integers(0, 12, size=(n, k)).astype(float)
    if kind == "anti":  # near a simplex: large fronts
        X = rng.random((n, k))
        return X / X.sum(axis=1, keepdims=True) + 1e-3 * rng.random((n, k))
    raise AssertionError(kind)


@pytest.mark.long
@pytest.mark.slow
@pytest.mark.parametrize("k", [2, 3, 4, 6])
@pytest.mark.parametrize("kind", ["uniform", "correlated", "ties", "anti"])
def test_large_inputs_match_lexsort_reference(kind, k):
    n = 6_000 if kind == "anti" else 20_000  # the reference is O(n * front); anti's front ~ n
    F = _large(kind, n, k, seed=10 * k + len(kind))
    F[::997] = np.nan  # some failed trials
    senses = ["min", "max"] * (k // 2) + ["min"] * (k % 2)
    F = F * np.array([1.0 if s == "min" else -1.0 for s in senses])  # same front as all-min
    expected = lexsort_mask(F, senses)
    assert 0 < expected.sum() < n - n // 997  # non-trivial front
    got = pareto_mask(F, senses)
    np.testing.assert_array_equal(got, expected)


# --------------------------------------------------------------------------------------------
# the numpy engine (used without numba loaded): same mask as the compiled one
# --------------------------------------------------------------------------------------------


def _sgn(F, senses):
    return (
        np.array([-1.0 if s == "max" else 1.0 for s in senses]) if senses else np.ones(F.shape[1])
    )


@settings(max_examples=150, deadline=None)
@given(
    problems(values=st.sampled_from(TRICKY), max_n=60),
    st.sampled_from([0, 1, 3, 64]),
    st.sampled_from([np.inf, 0.0]),
)
def test_numpy_engine_exact_with_extreme_values(problem, n_pivots, max_pairs):
    # max_pairs = 0 hands the survivors to the compiled exact kernels; inf compares them
    # pairwise in numpy.
    F, senses = problem
    got = pareto._mask_numpy(np.ascontiguousarray(F), _sgn(F, senses), n_pivots, max_pairs)
    np.testing.assert_array_equal(got, brute_mask(F, senses))


@settings(max_examples=150, deadline=None)
@given(problems(values=st.integers(0, 4).map(float), max_n=60), st.sampled_from([0, 2, 64]))
def test_numpy_engine_exact_with_ties(problem, n_pivots):
    F, senses = problem
    got = pareto._mask_numpy(np.ascontiguousarray(F), _sgn(F, senses), n_pivots)
    np.testing.assert_array_equal(got, brute_mask(F, senses))


@pytest.mark.parametrize("k", [2, 3, 4, 6])
@pytest.mark.parametrize("kind", ["uniform", "correlated", "ties"])
def test_numpy_engine_matches_the_compiled_one_on_large_inputs(kind, k):
    F = _large(kind, 30_000, k, seed=k + len(kind))
    F[::991] = np.nan
    sgn = np.ones(k)
    compiled = pareto._mask_signed(F, sgn, pareto._N_PIVOTS)
    assert 0 < compiled.sum()
    np.testing.assert_array_equal(pareto._mask_numpy(F, sgn, pareto._N_PIVOTS), compiled)
    small = pareto._mask_numpy(F, sgn, pareto._N_PIVOTS, max_pairs=0.0)  # compiled exact step
    np.testing.assert_array_equal(small, compiled)


@settings(max_examples=30, deadline=None)
@given(
    problems(values=st.integers(0, 5).map(float), max_k=5, max_n=700, nan_rows=True),
    st.sampled_from([0, 1, 8, 64]),
)
def test_numpy_engine_exact_over_several_blocks_with_ties(problem, n_pivots):
    # Hundreds of rows on a coarse grid: the pivots run (more than 64 rows), equal keys are
    # broken lexicographically, and the sort-filter-skyline spans several blocks.
    F, senses = problem
    got = pareto._mask_numpy(np.ascontiguousarray(F), _sgn(F, senses), n_pivots, np.inf)
    np.testing.assert_array_equal(got, lexsort_mask(F, senses))


@pytest.mark.parametrize("k", [2, 3, 4, 6])
def test_numpy_engine_on_a_large_front_same_with_or_without_the_compiled_step(k):
    # 'anti': thousands of mutually non-dominated rows. With no budget the numpy
    # sort-filter-skyline does it all; with the default budget it hands over to the compiled
    # exact kernels; a budget of 0 hands over at once. All three give the compiled mask.
    F = _large("anti", 4_000, k, seed=7 * k)
    F[::97, 0] = np.nan
    F[5::211] = F[3::211][: len(F[5::211])]  # exact duplicates
    sgn = np.where(np.arange(k) % 2, -1.0, 1.0)
    F = F * sgn
    compiled = pareto._mask_signed(F, sgn, pareto._N_PIVOTS)
    assert compiled.sum() > 100
    for budget in (np.inf, pareto._NUMPY_MAX_PAIRS, 0.0):
        np.testing.assert_array_equal(
            pareto._mask_numpy(F, sgn, pareto._N_PIVOTS, budget), compiled
        )


def test_prefer_numpy_keeps_numba_unloaded_with_the_same_masks(tmp_path):
    # A process that asked for the numpy engine (the UI server) filters large matrices, many
    # times, without loading numba; its masks are the compiled engine's. (A front of
    # thousands of rows, e.g. uniform data in 6 criteria, would go to the compiled kernels.)
    import subprocess
    import sys

    code = f"""
import sys
import numpy as np
from vectorid.analysis import pareto
pareto.prefer_numpy()
rng = np.random.default_rng(5)
out = {{}}
for i, (n, k) in enumerate([(700_000, 4), (200_000, 6), (50_000, 2), (50_000, 3), (9, 1)] * 2):
    F = rng.random((n, 1)) + 0.05 * rng.standard_normal((n, k))  # fronts of tens to hundreds
    F[:: 101 + i] = np.nan
    F[1::7] = np.round(F[1::7], 1)  # ties
    senses = ["min", "max"] * (k // 2) + ["min"] * (k % 2)
    F *= [1.0 if s == "min" else -1.0 for s in senses]  # correlated once signed
    out[f"F{{i}}"] = F
    out[f"m{{i}}"] = pareto.pareto_mask(F, senses)
assert "numba" not in sys.modules, "numba was loaded"
np.savez({str(tmp_path / "m.npz")!r}, **out)
"""
    subprocess.run([sys.executable, "-c", code], check=True)
    got = np.load(tmp_path / "m.npz")
    for i in range(10):
        F = got[f"F{i}"]
        k = F.shape[1]
        senses = ["min", "max"] * (k // 2) + ["min"] * (k % 2)
        sgn = _sgn(F, senses)
        np.testing.assert_array_equal(
            got[f"m{i}"], pareto._mask_signed(np.ascontiguousarray(F), sgn, pareto._N_PIVOTS)
        )


@pytest.mark.slow
@settings(max_examples=200, deadline=None)
@given(
    problems(values=st.integers(0, 4).map(float), max_n=200),
    st.sampled_from([0, 1, 3, 64]),
    st.sampled_from([2, 3, 7]),
)
def test_parallel_prefilter_exact(problem, n_pivots, chunks):
    # The parallel pre-filter (contiguous parts, each with its own pivots, then every survivor
    # against all pivots) run in as many parts as asked, whatever the machine's threads.
    F, senses = problem
    got = pareto._mask_signed(np.ascontiguousarray(F), _sgn(F, senses), n_pivots, 1, chunks)
    np.testing.assert_array_equal(got, brute_mask(F, senses))


@pytest.mark.parametrize("kind", ["uniform", "correlated", "ties"])
@pytest.mark.parametrize("k", [2, 4, 5])
def test_parallel_prefilter_matches_serial_on_large_inputs(kind, k):
    F = _large(kind, 20_000, k, seed=3 * k + len(kind))
    F[::331, k - 1] = np.nan
    sgn = np.where(np.arange(k) % 2, -1.0, 1.0)
    serial = pareto._mask_signed(F, sgn, pareto._N_PIVOTS)
    for chunks in (2, 5):
        np.testing.assert_array_equal(
            pareto._mask_signed(F, sgn, pareto._N_PIVOTS, 1, chunks), serial
        )
    np.testing.assert_array_equal(pareto_mask(F * sgn, threads=2), serial)


def test_key_scales_are_positive_and_finite_for_any_sample():
    big, tiny = 1.7e308, 5e-324
    lo = np.array([0.0, -big, np.inf, 3.0, tiny, -np.inf])
    hi = np.array([1.0, big, -np.inf, 3.0, 2 * tiny, np.inf])
    from vectorid.analysis import _pareto_kernels as K

    nrm = K._scales_of(lo, hi)
    assert np.all(np.isfinite(nrm)) and np.all(nrm[1] > 0)
    np.testing.assert_array_equal(nrm[:, 0], [0.0, 1.0])
    assert nrm[1, 1] > 0 and nrm[0, 1] == -big  # spread overflows: halved, still positive


@pytest.mark.parametrize(
    ("n_values", "max_threads", "cpus", "load1", "others", "expected"),
    [
        (10**8, 2, 2, 0.0, 0, 2),  # idle 2-core machine, large input: both threads
        (10**8, 2, 2, 1.0, 0, 2),  # load 1: this process's own work, nothing else runnable
        (10**8, 2, 2, 0.1, 1, 1),  # one other runnable task now: serial
        (10**8, 2, 2, 2.0, 0, 1),  # none runnable this instant, but load 2 (a sleeping job)
        (10**8, 2, 2, 0.0, 2, 1),  # two others: serial
        (10**8, 2, 2, 1.4, None, 2),  # no /proc/loadavg: the load average decides
        (10**8, 2, 2, 1.6, None, 1),  # ... rounded: 1.4 CPUs free -> one thread
        (10**8, 8, 8, 0.0, 3, 5),  # 8 CPUs, 3 others: 5 threads
        (10**8, 4, 8, 0.0, 0, 4),  # never more than numba's thread count
        (10**8, 8, 4, 0.0, 0, 4),  # nor than the usable CPUs
        (10**5, 2, 2, 0.0, 0, 1),  # small input: one thread
        (10**8, 1, 2, 0.0, 0, 1),  # NUMBA_NUM_THREADS=1
        (10**8, 2, 1, 0.0, 0, 1),  # one usable CPU
    ],
)
def test_thread_choice_rule(n_values, max_threads, cpus, load1, others, expected):
    assert pareto._choose_threads(n_values, max_threads, cpus, load1, others) == expected


def test_thread_choice_threshold_and_context_restore():
    import numba

    t = pareto._PARALLEL_MIN_VALUES
    assert pareto._choose_threads(t - 1, 2, 2, 0.0, 0) == 1
    assert pareto._choose_threads(t, 2, 2, 0.0, 0) == 2
    assert pareto._threads_for(10, None) == 1
    assert pareto._threads_for(10, 1) == 1
    before = numba.get_num_threads()
    with pareto._numba_threads(1):
        assert numba.get_num_threads() == 1
    assert numba.get_num_threads() == before
    others = pareto._runnable_others()
    assert others is None or others >= 0


def test_pareto_mask_in_a_fresh_process_does_not_load_numba():
    # The analysis verbs of the CLI start without numba (0.5-1 s to load); see pareto_mask.
    import subprocess
    import sys

    # A process that keeps filtering moves to the compiled kernels after a few calls.
    code = (
        "import sys, numpy as np\n"
        "from vectorid.analysis import Analysis, pareto_mask\n"
        "F = np.random.default_rng(0).random((20000, 4))\n"
        "masks = []\n"
        "for i in range(6):\n"
        "    masks.append(pareto_mask(F))\n"
        "    print(int(masks[-1].sum()), 'numba' in sys.modules)\n"
        "assert all((m == masks[0]).all() for m in masks)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    rows = [line.split() for line in out.stdout.splitlines()]
    assert int(rows[0][0]) > 0
    assert [loaded for _, loaded in rows] == ["False"] * 4 + ["True"] * 2


def test_concurrent_calls_agree_and_only_one_runs_in_parallel():
    # Request threads (the UI) may filter at once: one parallel launch at a time, the others
    # serial, every mask the same.
    from concurrent.futures import ThreadPoolExecutor

    F = _large("correlated", 20_000, 4, seed=5)
    F[::97, 1] = np.nan
    expected = pareto._mask_signed(F, np.ones(4), pareto._N_PIVOTS)
    with ThreadPoolExecutor(4) as ex:
        masks = list(
            ex.map(lambda _: pareto._mask_signed(F, np.ones(4), pareto._N_PIVOTS, 1, 3), range(8))
        )
    for m in masks:
        np.testing.assert_array_equal(m, expected)
    assert not pareto._PARALLEL_LOCK.locked()
