"""Edgeworth–Pareto filter: the non-dominated rows of a criteria matrix.

The public functions are :func:`pareto_mask` and :func:`pareto_indices`.

Algorithm
---------
All work is done in float64 on "signed" values ``v = s_j * F[i, j]`` with ``s_j = +1`` for a
minimised and ``-1`` for a maximised criterion, so that every column is minimised.

1. A strided sample of about 1024 rows gives per-column offsets and scales (the min and
   spread of its finite values) for the key below; any positive scales are correct.
2. One streaming pass drops the rows with a NaN and every row strictly dominated by one of up
   to 64 *pivots* (the lowest-key rows seen so far). Rows are read 64 at a time and first tried
   against two of them at once, column by column (the pivot of lowest key and the latest
   dominator; vectorised, no branch, comparison flags kept 64-bit wide, which AVX2 handles
   without packing); the rows left are checked against all pivots. Each surviving row gets a
   monotone key, the sum over columns of ``clamp((v - offset) * scale, -1e300, 1e300)``
   (non-decreasing in every ``v`` under rounding, NaN only for a NaN row), so that a dominating
   row never has a larger key. Any row may serve as a pivot (dominance is transitive), so this
   only removes dominated rows. The survivors are checked once more against the final pivots.
   Large matrices on an idle machine are scanned in contiguous parts by several threads, each
   with its own pivots, then every survivor is checked against all of them (see
   :func:`_choose_threads` for when).
3. The survivors (usually a small fraction of the rows) go to an exact kernel chosen by ``k``:

   * ``k = 1``: the rows equal to the column minimum (no pass 2).
   * ``k = 2``: sort by the first column, sweep groups of equal values keeping a running minimum of
     the second column, ``O(n log n)``.
   * ``k = 3``: sort by the first column, sweep with a Fenwick tree (prefix minimum of the third
     column over the ranks of the second), ``O(n log n)``.
   * ``k >= 4``: sort by the key (ties broken lexicographically) so that no row precedes a row
     that dominates it, then sort–filter–skyline: a row is kept iff no row already kept dominates
     it. The kept rows sit in a grid of up to 1024 cells (quantile buckets of the leading
     columns); a row is compared only with the cells that are no higher than its own in every
     bucketed column, 64 rows at a time stored column-wise (the compiler vectorises the
     comparisons), stopping at the first dominator. Worst case ``O(n * front * k)``.

Exact duplicates never dominate each other (every copy of a non-dominated row is kept); rows with a
NaN are "failed trials": never in the mask, never dominating; ``±inf`` are ordinary ordered values.
"""

from __future__ import annotations

import contextlib
import os
import sys
import threading
from collections.abc import Iterator, Sequence

import numpy as np
import numpy.typing as npt

__all__ = ["pareto_indices", "pareto_mask"]

#: The k >= 4 kernel keeps its front in a grid of at most this many cells ...
_MAX_CELLS = 1024
#: ... and about one cell per this many rows it has to filter.
_ROWS_PER_CELL = 64
#: Rows sampled to place the grid thresholds (quantiles of each column).
_GRID_SAMPLE = 4096
#: Number of pivots used by the streaming pre-filter (one block: checking fewer costs the same).
_N_PIVOTS = 64
#: Rows sampled (strided) for the per-column offsets and scales of the key.
_KEY_SAMPLE = 1024
#: Matrices with fewer values are pre-filtered in one thread (see :func:`_choose_threads`):
#: below this the serial pass takes a few ms, and on a shared machine waking a second thread
#: can take as long (a 2-core VM with other jobs: median 20 us, 90th percentile 4 ms).
_PARALLEL_MIN_VALUES = 4_000_000
#: Held while a call runs the parallel pre-filter (see :func:`_mask_signed`).
_PARALLEL_LOCK = threading.Lock()
#: The numpy engine is used for matrices of at most this many values when numba is not loaded
#: yet: loading numba and the cached kernels (0.5-1 s) costs more than its passes there.
_NUMPY_MAX_VALUES = 2_000_000
#: ... for the first this many calls of a process: one that keeps filtering (the UI, a report)
#: then loads the compiled kernels once, which are ~10x faster per call.
_NUMPY_CALLS = 4
_numpy_calls = 0
#: Set by :func:`prefer_numpy`: the numpy engine for every call while numba is not loaded.
_prefer_numpy = False
#: ... and hands its survivors to the compiled exact kernels once its sort-filter-skyline
#: has compared more than this many pairs of rows (a large front; ~0.1-0.3 s of numpy).
_NUMPY_MAX_PAIRS = 2e7
#: Rows per block of the numpy sort-filter-skyline ...
_NUMPY_BLOCK = 256
#: ... and row pairs per comparison (booleans held at once).
_NUMPY_CHUNK = 1_000_000


# --------------------------------------------------------------------------------------------
# validation
# --------------------------------------------------------------------------------------------


def _as_matrix(F: npt.ArrayLike) -> np.ndarray:
    """Return ``F`` as a C-contiguous float64 matrix or raise a helpful ValueError."""
    try:
        A = np.asarray(F)
    except ValueError as exc:  # ragged nested sequences
        raise ValueError(
            "F must be a 2-D numeric array of shape (n_trials, n_criteria); it could not be "
            f"converted to an array ({exc}). Make every row the same length."
        ) from exc
    if A.ndim != 2:
        raise ValueError(
            "F must be a 2-D numeric array of shape (n_trials, n_criteria); got an array with "
            f"ndim={A.ndim} and shape {A.shape}. Reshape it, e.g. F.reshape(-1, 1) for a single "
            "criterion or F[None, :] for a single trial."
        )
    if A.dtype.kind not in "biuf":
        raise ValueError(
            "F must be numeric (bool, integer or float); got dtype "
            f"{A.dtype}. Convert it first, e.g. np.asarray(F, dtype=float)."
        )
    if A.shape[1] == 0:
        raise ValueError(
            f"F must have at least one criterion column; got shape {A.shape}. Pass the matrix of "
            "criterion values with one column per criterion."
        )
    return np.ascontiguousarray(A, dtype=np.float64)


def _signs(senses: Sequence[str] | None, k: int) -> np.ndarray:
    """Return +1 (min) / -1 (max) per column or raise a helpful ValueError."""
    if senses is None:
        return np.ones(k)
    if isinstance(senses, str | bytes):
        raise ValueError(
            f"senses must be a sequence of {k} strings, one 'min' or 'max' per column of F; got "
            f"the single string {senses!r}. Pass e.g. [{senses!r}] * {k}."
        )
    try:
        seq = list(senses)
    except TypeError as exc:
        raise ValueError(
            f"senses must be a sequence of {k} strings, one 'min' or 'max' per column of F; got "
            f"{type(senses).__name__} {senses!r}. Pass e.g. ['min'] * {k}, or None to minimise all."
        ) from exc
    if len(seq) != k:
        raise ValueError(
            f"senses must have one entry per column of F: expected {k} entries, got {len(seq)} "
            f"({seq!r}). Pass a list of {k} strings 'min'/'max', or None to minimise all."
        )
    sgn = np.empty(k)
    for j, s in enumerate(seq):
        if isinstance(s, str) and s == "min":
            sgn[j] = 1.0
        elif isinstance(s, str) and s == "max":
            sgn[j] = -1.0
        else:
            raise ValueError(
                f"senses[{j}] must be 'min' or 'max' (lower case); got {s!r}. Use 'min' for a "
                "criterion to minimise and 'max' for one to maximise."
            )
    return sgn


# --------------------------------------------------------------------------------------------
# driver
# --------------------------------------------------------------------------------------------


def _normalisation(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Parameters of the monotone per-column map ``t = (c * v - c * lo) / den``, shape (3, k).

    ``c`` is 1, or 0.5 where ``hi - lo`` overflows; ``den = c * hi - c * lo > 0``, or 1 for a column
    with no spread (then every finite value equals ``lo`` and maps to 0). The map sends the finite
    values into [0, 1] without overflow and is non-decreasing in ``v`` under rounding.
    """
    k = lo.shape[0]
    nrm = np.empty((3, k))
    nrm[0] = 1.0
    with np.errstate(over="ignore", invalid="ignore"):
        spread = hi - lo
    has = hi > lo
    nrm[0, has & ~np.isfinite(spread)] = 0.5
    c = nrm[0]
    nrm[1] = np.where(np.isfinite(lo), c * lo, 0.0)  # lo = +inf: the column has no finite value
    nrm[2] = np.where(has, c * hi - c * lo, 1.0)
    return nrm


def _grid(X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Bucket counts and thresholds of the cell grid used by :func:`_sfs`.

    About one cell per ``_ROWS_PER_CELL`` rows, at most ``_MAX_CELLS``; buckets are added to the
    columns in turn while the number of cells stays within budget. Thresholds are quantiles of a
    strided sample of each column (actual values, so never NaN); any thresholds are correct, they
    only affect the speed.
    """
    m, k = X.shape
    cells = min(_MAX_CELLS, max(1, m // _ROWS_PER_CELL))
    buckets = [1] * k
    total = 1
    grown = True
    while grown:
        grown = False
        for j in range(k):
            if total // buckets[j] * (buckets[j] + 1) <= cells:
                total = total // buckets[j] * (buckets[j] + 1)
                buckets[j] += 1
                grown = True
    d = sum(1 for b in buckets if b > 1)  # the grown columns are a prefix (round robin)
    B = np.array(buckets[:d], dtype=np.int64)
    thr = np.full((d, max(int(B.max()) - 1, 1) if d else 1), np.inf)
    sample = X[:: max(1, m // _GRID_SAMPLE)]
    for j in range(d):  # order statistics of the sample (np.quantile costs ~20 us a call)
        col = np.sort(sample[:, j])
        thr[j, : B[j] - 1] = col[(np.arange(1, B[j]) * col.size) // B[j]]
    return thr, B


def _exact(G: np.ndarray, sgn: np.ndarray, rows: np.ndarray, keys: np.ndarray) -> np.ndarray:
    """Positions in ``rows`` of the non-dominated ones, by the compiled exact kernels.

    ``rows`` are feasible rows of ``G`` (k >= 2) and ``keys`` their monotone keys."""
    from . import _pareto_kernels as K

    k = G.shape[1]
    if k == 2:
        x = sgn[0] * G[rows, 0]
        return K._front2(x, sgn[1] * G[rows, 1], np.argsort(x))
    if k == 3:
        x, y = sgn[0] * G[rows, 0], sgn[1] * G[rows, 1]
        return K._front3(x, y, sgn[2] * G[rows, 2], np.argsort(x), np.argsort(y))
    X = G[rows] * sgn
    order = np.argsort(keys)
    ks = keys[order]
    if np.any(ks[1:] == ks[:-1]):
        # equal keys: break ties lexicographically so no row precedes its dominator
        order = np.lexsort((*(X[:, j] for j in range(k - 1, -1, -1)), keys))
    X = np.ascontiguousarray(X[order])
    return order[K._sfs(X, *_grid(X))]


def _runnable_others() -> float | None:
    """Other runnable tasks right now (Linux: ``/proc/loadavg``, minus this thread), or None."""
    try:
        with open("/proc/loadavg", encoding="ascii") as fh:
            running = fh.read().split()[3].split("/")[0]
        return max(int(running) - 1, 0)
    except (OSError, IndexError, ValueError):
        return None


def _usable_cpus() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # not on Linux
        return os.cpu_count() or 1


def _choose_threads(
    n_values: int, max_threads: int, cpus: int, load1: float, others: float | None
) -> int:
    """Threads for the pre-filter of an ``n_values``-value matrix (pure: testable).

    The rule: one thread when ``n_values < _PARALLEL_MIN_VALUES`` (starting the threads costs
    more than they save) or when ``max_threads`` (numba's thread count) or ``cpus`` (CPUs this
    process may use) is 1. Otherwise as many threads as CPUs are free, at most ``max_threads``:
    ``round(cpus - busy)``, where ``busy`` is the larger of ``others``, the number of *other*
    tasks runnable right now (``/proc/loadavg``; None where unknown), and ``load1 - 1``, the
    1-minute load average less this process (which may itself have kept a CPU busy). A 2-core
    machine with one other CPU-bound process thus gets one thread: a two-thread kernel there
    waits for its descheduled half (measured: +25-30 ms a call) and loses to the serial one.
    A call that finds another thread of this process in the parallel kernel runs serially.
    """
    if max_threads <= 1 or cpus <= 1 or n_values < _PARALLEL_MIN_VALUES:
        return 1
    busy = max(float(others) if others is not None else 0.0, float(load1) - 1.0)
    free = int(np.floor(cpus - busy + 0.5))
    return max(1, min(max_threads, cpus, free))


@contextlib.contextmanager
def _numba_threads(n: int) -> Iterator[None]:
    """Run numba's parallel kernels with ``n`` threads, restoring the previous count after."""
    import numba

    old = numba.get_num_threads()
    numba.set_num_threads(max(1, min(n, numba.config.NUMBA_NUM_THREADS)))
    try:
        yield
    finally:
        numba.set_num_threads(old)


def _threads_for(n_values: int, threads: int | None) -> int:
    """The thread count of a call: ``threads`` if given, else :func:`_choose_threads`."""
    import numba

    if threads is not None:
        return max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS))
    if n_values < _PARALLEL_MIN_VALUES:
        return 1
    return _choose_threads(
        n_values, numba.get_num_threads(), _usable_cpus(), os.getloadavg()[0], _runnable_others()
    )


def _mask_signed(
    G: np.ndarray, sgn: np.ndarray, n_pivots: int, threads: int | None = 1, chunks: int = 0
) -> np.ndarray:
    """Pareto mask of a validated float64 C-contiguous matrix; ``sgn`` = ±1 per column.

    The compiled engine: every pass in numba kernels; ``threads`` as in :func:`pareto_mask`.
    ``chunks``: parts of the parallel pre-filter, 0 (default) for one per thread (one thread:
    the serial kernel); the tests set it to run the parallel kernel on any machine."""
    from . import _pareto_kernels as K

    n, k = G.shape
    mask = np.zeros(n, dtype=bool)
    if n == 0:
        return mask
    if k == 1:
        v = sgn[0] * G[:, 0]
        feas = ~np.isnan(v)
        if feas.any():
            mask[feas] = v[feas] == v[feas].min()
        return mask
    nrm = K._key_scales(G, sgn, max(1, n // _KEY_SAMPLE))
    nt = _threads_for(n * k, threads)
    parts = chunks or nt
    # one parallel launch at a time per process (numba's workqueue layer, the fallback where
    # neither OpenMP nor TBB is installed, aborts on concurrent launches; and a second one
    # would only compete for the same CPUs): a call that finds it taken runs serially
    if parts > 1 and _PARALLEL_LOCK.acquire(blocking=False):
        try:
            with _numba_threads(nt):
                rows, keys = K._prefilter_parallel(G, sgn, nrm, n_pivots, parts)
        finally:
            _PARALLEL_LOCK.release()
    else:
        rows, keys = K._prefilter(G, sgn, nrm, n_pivots)
    if rows.size:
        mask[rows[_exact(G, sgn, rows, keys)]] = True
    return mask


def _dominated_by(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Rows of ``A`` (a, k) strictly dominated by some row of ``B`` (b, k) (minimised)."""
    le = np.ones((A.shape[0], B.shape[0]), dtype=bool)
    for j in range(A.shape[1]):
        le &= B[None, :, j] <= A[:, None, j]
    if not le.any():
        return np.zeros(A.shape[0], dtype=bool)
    eq = np.ones_like(le)
    for j in range(A.shape[1]):
        eq &= B[None, :, j] == A[:, None, j]
    return (le & ~eq).any(axis=1)


def _mask_numpy(
    G: np.ndarray, sgn: np.ndarray, n_pivots: int, max_pairs: float = _NUMPY_MAX_PAIRS
) -> np.ndarray:
    """The same mask as :func:`_mask_signed` by whole-array numpy passes (no numba).

    The feasible rows' monotone keys are computed as in the compiled engine. Then pivots:
    the remaining row of lowest key removes every row it strictly dominates (any row may do
    that: dominance is transitive), up to ``n_pivots`` of them, stopping earlier when they
    no longer remove much. The survivors, sorted by key with ties broken lexicographically
    (no row after one it dominates), go through a block sort-filter-skyline: a block of
    rows is kept where no kept row before it and no row of the block dominates it. When
    that step has made more than ``max_pairs`` row-against-row comparisons (a large front),
    the survivors are handed to the compiled exact kernels (:func:`_exact`) instead.
    """
    n, k = G.shape
    mask = np.zeros(n, dtype=bool)
    if n == 0:
        return mask
    C = np.empty((k, n))  # the signed columns, each contiguous
    nan = np.zeros(n, dtype=bool)
    for j in range(k):
        np.multiply(G[:, j], sgn[j], out=C[j])
        nan |= np.isnan(C[j])
    rows = np.arange(n)
    if nan.any():
        rows = np.flatnonzero(~nan)
        C = C[:, rows]
    if rows.size == 0:
        return mask
    if k == 1:
        mask[rows[C[0] == C[0].min()]] = True
        return mask
    keys = np.zeros(rows.size)
    t = np.empty(rows.size)
    for j in range(k):  # sum of (c - lo) / (hi - lo) over the finite values, as _key_scales
        c = C[j]
        lo, hi = c.min(), c.max()
        if np.isfinite(lo) and np.isfinite(hi):
            nrm = _normalisation(np.array([lo]), np.array([hi]))[:, 0]
            np.multiply(c, nrm[0], out=t)
            t -= nrm[1]
            t /= nrm[2]
            keys += t
            continue
        fin = np.isfinite(c)
        lo = c[fin].min() if fin.any() else np.inf
        hi = c[fin].max() if fin.any() else -np.inf
        nrm = _normalisation(np.array([lo]), np.array([hi]))[:, 0]
        with np.errstate(invalid="ignore", over="ignore"):
            u = (nrm[0] * np.where(fin, c, 0.0) - nrm[1]) / nrm[2]
        keys += np.where(c == np.inf, 2.0, np.where(c == -np.inf, -1.0, u))
    work = keys.copy()  # the keys of the rows not yet used as pivots
    weak = 0
    for _ in range(n_pivots):
        m = rows.size
        if m <= 64:
            break
        i = int(np.argmin(work))
        if work[i] == np.inf:
            break
        work[i] = np.inf
        p = C[:, i]
        dom = C[0] >= p[0]
        for j in range(1, k):
            dom &= C[j] >= p[j]
        cand = np.flatnonzero(dom)
        if cand.size:  # not the rows equal to the pivot (the pivot among them)
            eq = np.ones(cand.size, dtype=bool)
            for j in range(k):
                eq &= C[j, cand] == p[j]
            cand = cand[~eq]
        if cand.size:
            alive = np.ones(m, dtype=bool)
            alive[cand] = False
            C, rows, keys, work = C[:, alive], rows[alive], keys[alive], work[alive]
        weak = weak + 1 if cand.size * 256 < m else 0
        if weak >= 4:  # the pivots no longer pay for their pass
            break
    m = rows.size
    order = np.argsort(keys, kind="stable")
    ks = keys[order]
    if np.any(ks[1:] == ks[:-1]):
        order = np.lexsort((*(C[j] for j in range(k - 1, -1, -1)), keys))
    X = np.ascontiguousarray(C[:, order].T)
    keep = np.zeros(m, dtype=bool)
    front = X[:0]
    done = 0.0
    step = _NUMPY_BLOCK
    for s in range(0, m, step):
        blk = X[s : s + step]
        done += float(blk.shape[0]) * (front.shape[0] + blk.shape[0])
        if done > max_pairs:
            mask[rows[_exact(G, sgn, rows, keys)]] = True
            return mask
        out = np.zeros(blk.shape[0], dtype=bool)
        per = max(1, _NUMPY_CHUNK // step)
        for f in range(0, front.shape[0], per):  # against the rows kept before the block
            live = ~out
            if not live.any():
                break
            out[live] |= _dominated_by(blk[live], front[f : f + per])
        live = ~out
        if live.any():  # and against the block itself
            out[live] |= _dominated_by(blk[live], blk)
        keep[s : s + step] = ~out
        front = np.concatenate([front, blk[~out]]) if (~out).any() else front
    mask[rows[order[keep]]] = True
    return mask


def prefer_numpy(on: bool = True) -> None:
    """Filter with the numpy engine in this process for as long as numba is not loaded.

    For a long-running process that filters often and wants to stay small, such as
    ``vectorid ui``: numba and the cached compiled kernels cost about 120 MB of code once
    loaded, and on the fronts such a process meets (tens to thousands of rows) the numpy
    engine takes milliseconds to tens of milliseconds at 1e5-1e6 rows. The masks are the
    same. A front large enough that the numpy sort-filter-skyline would compare more than
    ``_NUMPY_MAX_PAIRS`` pairs of rows still goes to the compiled kernels (which loads them:
    from then on every call uses them).

    Parameters
    ----------
    on : bool
        True (default) to prefer the numpy engine, False for the default rule (see
        :func:`pareto_mask`).
    """
    global _prefer_numpy
    _prefer_numpy = bool(on)


def pareto_mask(
    F: npt.ArrayLike, senses: Sequence[str] | None = None, *, threads: int | None = None
) -> np.ndarray:
    """Boolean mask of the non-dominated (Edgeworth–Pareto optimal) rows of a criteria matrix.

    Parameters
    ----------
    F : array_like, shape (n, k)
        Criterion values, one row per trial and one column per criterion, in the criteria's own
        units. Any numeric dtype (bool, integer, float) is accepted and compared as float64, so
        integers beyond 2**53 in magnitude may tie after rounding. A row containing a NaN is a
        failed trial: it is never in the mask and never dominates another row. ``+inf`` and
        ``-inf`` are ordinary values (worse / better than every finite value when minimising).
    senses : sequence of str, optional
        ``k`` strings, ``"min"`` or ``"max"``: whether each criterion is minimised or maximised.
        ``None`` (default) minimises every criterion.
    threads : int, optional
        Threads of the streaming pre-filter (compiled engine). ``None`` (default): chosen at call
        time: one thread for fewer than 4e6 values or when the machine is busy, else as many as
        CPUs are free, at most ``numba.get_num_threads()`` (see :func:`_choose_threads`); an
        ``int`` forces that many (at most ``NUMBA_NUM_THREADS``). The numpy engine (below) is
        single-threaded. The mask does not depend on it.

    Returns
    -------
    numpy.ndarray of bool, shape (n,)
        ``True`` for the rows that no other row dominates. Row ``a`` dominates row ``b`` iff
        ``a`` is no worse than ``b`` in every criterion and strictly better in at least one.
        Exact duplicates do not dominate each other, so every copy of a non-dominated row is
        kept. ``n = 0`` gives an empty mask; for ``k = 1`` the mask marks all rows equal to the
        best value.

    Raises
    ------
    ValueError
        If ``F`` is not a 2-D numeric array with at least one column, or ``senses`` does not hold
        exactly ``k`` entries each equal to ``"min"`` or ``"max"``.

    Notes
    -----
    Two engines give the same mask. In a process that has not loaded numba, the first four
    calls on matrices of at most 2e6 values (every call after :func:`prefer_numpy`) go
    through whole-array numpy passes (the lowest-key rows as pivots, then a block
    sort-filter-skyline of the survivors), which for 1e5 rows take a few milliseconds
    against 0.5-1 s for loading numba and the compiled kernels: a command that filters once
    starts fast; a process that keeps filtering moves to the compiled kernels, faster per
    call, unless it asked for the numpy engine (``vectorid ui`` does, to stay ~120 MB
    smaller). Otherwise the kernels are compiled with numba
    (cached on disk; the first call in a fresh environment compiles them, which takes a few
    seconds, the parallel pre-filter a few more on its first use). Rows are first screened
    against a few low-key pivot rows in one streaming pass (in parallel for large inputs on an
    idle machine, see ``threads``), then the survivors go to an ``O(n log n)`` sweep for
    ``k = 2`` and ``k = 3`` or to a sort–filter–skyline pass (``O(n * front)``) for ``k >= 4``.
    See the module docstring for details. Indicative speed (one thread, AVX-512 or AVX2): 1e6
    rows, k = 2, about 2.5 ms; k = 4, uniform data, about 0.012 s; k = 8 (front of about 31,000
    rows) about 0.25 s. The cost grows with the front: when nearly every row is non-dominated
    (strongly conflicting criteria) and ``k >= 4`` it is quadratic, e.g. about 7-12 s for 1e6
    mutually non-dominated rows with k = 4 (moocore is faster there).

    Examples
    --------
    >>> import numpy as np
    >>> F = np.array([[1.0, 4.0], [2.0, 2.0], [3.0, 3.0], [2.0, 2.0], [np.nan, 0.0]])
    >>> pareto_mask(F)
    array([ True,  True, False,  True, False])
    >>> pareto_mask(F, senses=["min", "max"])
    array([ True, False, False, False, False])
    """
    G = _as_matrix(F)
    sgn = _signs(senses, G.shape[1])
    global _numpy_calls
    if "numba" not in sys.modules and _prefer_numpy:
        return _mask_numpy(G, sgn, _N_PIVOTS)
    if "numba" in sys.modules or G.size > _NUMPY_MAX_VALUES or _numpy_calls >= _NUMPY_CALLS:
        return _mask_signed(G, sgn, _N_PIVOTS, threads)
    _numpy_calls += 1
    return _mask_numpy(G, sgn, _N_PIVOTS)


def pareto_indices(F: npt.ArrayLike, senses: Sequence[str] | None = None) -> np.ndarray:
    """Row indices of the non-dominated rows of ``F``, in increasing order.

    Parameters
    ----------
    F : array_like, shape (n, k)
        Criterion values, as in :func:`pareto_mask`.
    senses : sequence of str, optional
        ``"min"`` or ``"max"`` per column, as in :func:`pareto_mask`.

    Returns
    -------
    numpy.ndarray of int64, shape (n_front,)
        ``numpy.flatnonzero(pareto_mask(F, senses))``.

    Examples
    --------
    >>> pareto_indices([[1, 4], [2, 2], [3, 3]])
    array([0, 1])
    """
    return np.flatnonzero(pareto_mask(F, senses)).astype(np.int64, copy=False)
