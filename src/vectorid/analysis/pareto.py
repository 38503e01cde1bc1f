"""Edgeworth–Pareto filter: the non-dominated rows of a criteria matrix.

The public functions are :func:`pareto_mask` and :func:`pareto_indices`.

Algorithm
---------
All work is done in float64 on "signed" values ``v = s_j * F[i, j]`` with ``s_j = +1`` for a
minimised and ``-1`` for a maximised criterion, so that every column is minimised.

1. One pass finds the feasible rows (no NaN) and the range of the finite values per column.
2. A streaming pass discards every row strictly dominated by one of up to 64 *pivots* (the
   lowest-key rows seen so far; the pivot that dropped the previous row is tried first) and gives
   each surviving row a monotone key: the sum of its min–max normalised columns, with ``-1`` for
   ``-inf`` and ``2`` for ``+inf``, so that a dominating row never has a larger key. Any row may
   serve as a pivot (dominance is transitive), so this only removes dominated rows. The survivors
   are checked once more against the final pivots.
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

from collections.abc import Sequence

import numba as nb
import numpy as np
import numpy.typing as npt

__all__ = ["pareto_indices", "pareto_mask"]

#: Front members compared per vectorised block in the k >= 4 kernel.
_BLOCK = 64
#: The k >= 4 kernel keeps its front in a grid of at most this many cells ...
_MAX_CELLS = 1024
#: ... and about one cell per this many rows it has to filter.
_ROWS_PER_CELL = 64
#: Rows sampled to place the grid thresholds (quantiles of each column).
_GRID_SAMPLE = 4096
#: Number of pivots used by the streaming pre-filter (one block: checking fewer costs the same).
_N_PIVOTS = 64


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
# compiled kernels
# --------------------------------------------------------------------------------------------


@nb.njit(cache=True)
def _feasible_bounds(G, sgn):  # pragma: no cover - compiled
    """Feasible rows (no NaN) and min/max of the finite signed values per column."""
    n, k = G.shape
    feas = np.ones(n, dtype=np.bool_)
    lo = np.full(k, np.inf)
    hi = np.full(k, -np.inf)
    for i in range(n):
        ok = True
        for j in range(k):
            if np.isnan(G[i, j]):
                ok = False
                break
        if not ok:
            feas[i] = False
            continue
        for j in range(k):
            v = sgn[j] * G[i, j]
            if v != np.inf and v != -np.inf:
                if v < lo[j]:
                    lo[j] = v
                if v > hi[j]:
                    hi[j] = v
    return feas, lo, hi


@nb.njit(cache=True)
def _prefilter(G, sgn, feas, nrm, n_pivots):  # pragma: no cover - compiled
    """Monotone keys and pivot pre-filter; returns (survivor rows, their keys).

    Phase 0 streams over the feasible rows; a row strictly dominated by the last successful
    pivot ("hot") or by one of the pivots is dropped, otherwise it survives, gets its key and may
    replace the pivot with the largest key. Phase 1 checks the survivors against the final pivots.
    Pivots are stored like the skyline front: shape (n_blocks, k, _BLOCK), NaN-padded.
    """
    n, k = G.shape
    npb = max(-(-n_pivots // _BLOCK), 1)
    P = np.full((npb, k, _BLOCK), np.nan)
    pkey = np.empty(max(n_pivots, 1))
    npiv = 0
    worst = 0  # position of the pivot with the largest key
    hot = np.empty(k)  # the pivot that dominated the previous dropped row
    have_hot = False
    surv = np.empty(n, dtype=np.int64)
    keys = np.empty(n)
    ns = 0
    p = np.empty(k)
    acc = np.empty(_BLOCK, dtype=np.uint8)
    for phase in range(2):
        if phase == 1 and npiv == 0:
            break
        count = n if phase == 0 else ns
        w = 0
        for it in range(count):
            if phase == 0:
                i = it
                if not feas[i]:
                    continue
            else:
                i = surv[it]
            for j in range(k):
                p[j] = sgn[j] * G[i, j]
            if have_hot:  # strict dominance by the hot pivot, scalar with early exit
                le = True
                lt = False
                for j in range(k):
                    if hot[j] > p[j]:
                        le = False
                        break
                    if hot[j] < p[j]:
                        lt = True
                if le and lt:
                    continue
            # block-wise check against the pivots (inlined by hand, as in _sfs: a helper taking
            # arrays costs atomic reference counting on every call)
            dom = -1
            for b in range(-(-npiv // _BLOCK)):
                for t in range(_BLOCK):
                    acc[t] = 1
                s = 1
                for j in range(k):
                    pj = p[j]
                    for t in range(_BLOCK):
                        acc[t] &= P[b, j, t] <= pj
                    if j == 1 or j == 3 or j + 1 == k:
                        s = 0
                        for t in range(_BLOCK):
                            s |= acc[t]
                        if s == 0:
                            break
                if s != 0:
                    for t in range(_BLOCK):
                        if acc[t]:
                            for j in range(k):
                                if P[b, j, t] < p[j]:
                                    dom = t
                                    break
                            if dom >= 0:
                                break
                if dom >= 0:
                    for j in range(k):
                        hot[j] = P[b, j, dom]
                    have_hot = True
                    break
            if dom >= 0:
                continue
            if phase == 1:
                surv[w] = i
                keys[w] = keys[it]
                w += 1
                continue
            key = 0.0
            for j in range(k):
                v = p[j]
                if v == np.inf:
                    key += 2.0
                elif v == -np.inf:
                    key -= 1.0
                else:
                    key += (nrm[0, j] * v - nrm[1, j]) / nrm[2, j]
            surv[ns] = i
            keys[ns] = key
            ns += 1
            if n_pivots == 0:
                continue
            if npiv < n_pivots:
                slot = npiv
                npiv += 1
            elif key < pkey[worst]:
                slot = worst
            else:
                continue
            for j in range(k):
                P[slot // _BLOCK, j, slot % _BLOCK] = p[j]
            pkey[slot] = key
            worst = 0
            for t in range(1, npiv):
                if pkey[t] > pkey[worst]:
                    worst = t
        if phase == 1:
            ns = w
    return surv[:ns], keys[:ns]


@nb.njit(cache=True)
def _front2(x, y, order):  # pragma: no cover - compiled
    """Non-dominated mask of the points (x[i], y[i]), both minimised, no NaN.

    ``order`` sorts ``x`` ascending (ties in any order).
    """
    n = x.shape[0]
    out = np.zeros(n, dtype=np.bool_)
    have = False
    best = np.inf  # minimum y over groups with a strictly smaller x
    i = 0
    while i < n:
        gx = x[order[i]]
        gmin = y[order[i]]
        j = i
        while j + 1 < n and x[order[j + 1]] == gx:
            j += 1
            if y[order[j]] < gmin:
                gmin = y[order[j]]
        if not have or gmin < best:
            for t in range(i, j + 1):
                if y[order[t]] == gmin:
                    out[order[t]] = True
            best = gmin
            have = True
        i = j + 1
    return out


@nb.njit(cache=True)
def _front3(x, y, z, order, oy):  # pragma: no cover - compiled
    """Non-dominated mask of the points (x, y, z), all minimised, no NaN.

    ``order`` sorts ``x`` and ``oy`` sorts ``y`` ascending (ties in any order).
    """
    n = x.shape[0]
    out = np.zeros(n, dtype=np.bool_)
    if n == 0:
        return out
    rank = np.empty(n, dtype=np.int64)
    r = 1
    rank[oy[0]] = 1
    for t in range(1, n):
        if y[oy[t]] != y[oy[t - 1]]:
            r += 1
        rank[oy[t]] = r
    R = r
    tval = np.full(R + 1, np.inf)
    thas = np.zeros(R + 1, dtype=np.bool_)
    i = 0
    while i < n:
        gx = x[order[i]]
        j = i
        while j + 1 < n and x[order[j + 1]] == gx:
            j += 1
        # dominated by a point with a strictly smaller x?
        for t in range(i, j + 1):
            q = order[t]
            a = rank[q]
            found = False
            best = np.inf
            while a > 0:
                if thas[a] and (not found or tval[a] < best):
                    best = tval[a]
                    found = True
                a -= a & (-a)
            out[q] = not (found and best <= z[q])
        # dominated within the group of equal x?
        if j > i:
            g = order[i : j + 1]
            yg = y[g]
            inner = _front2(yg, z[g], np.argsort(yg))
            for t in range(j + 1 - i):
                if not inner[t]:
                    out[g[t]] = False
        for t in range(i, j + 1):
            q = order[t]
            a = rank[q]
            v = z[q]
            while a <= R:
                if not thas[a] or v < tval[a]:
                    tval[a] = v
                    thas[a] = True
                a += a & (-a)
        i = j + 1
    return out


@nb.njit(cache=True)
def _sfs(X, thr, B):  # pragma: no cover - compiled
    """Sort-filter-skyline: non-dominated mask of the rows of X (all columns minimised).

    The rows must be sorted so that a row never precedes a row that dominates it (by a monotone
    key, ties broken lexicographically); then a row is non-dominated iff no earlier
    non-dominated row dominates it. The front found so far is kept in a grid of cells: column
    ``j < d`` is cut into ``B[j]`` buckets by the thresholds ``thr[j, :B[j] - 1]``, and a row can
    only be dominated by rows in cells that are, bucket by bucket, no higher than its own. Each
    cell is a linked list of blocks of ``_BLOCK`` members stored column-wise (NaN-padded).
    """
    m, k = X.shape
    out = np.zeros(m, dtype=np.bool_)
    if m == 0:
        return out
    d = B.shape[0]
    stride = np.empty(d, dtype=np.int64)
    R = 1
    for j in range(d):
        stride[j] = R
        R *= B[j]
    maxblk = m // _BLOCK + R + 1
    Bk = np.full((maxblk, k, _BLOCK), np.nan)
    nxt = np.full(maxblk, -1, dtype=np.int64)
    head = np.full(R, -1, dtype=np.int64)
    tail = np.full(R, -1, dtype=np.int64)
    fill = np.zeros(R, dtype=np.int64)
    nblk = 0
    acc = np.empty(_BLOCK, dtype=np.uint8)
    p = np.empty(k)
    c = np.empty(d, dtype=np.int64)
    r = np.empty(d, dtype=np.int64)
    for i in range(m):
        for j in range(k):
            p[j] = X[i, j]
        M = 0  # own cell
        for j in range(d):
            cj = 0
            for t in range(B[j] - 1):
                if thr[j, t] <= p[j]:
                    cj += 1
            c[j] = cj
            r[j] = 0
            M += cj * stride[j]
        dom = False
        cell = 0
        while True:
            b = head[cell]
            while b >= 0:
                # block check, inlined by hand (see _prefilter)
                for t in range(_BLOCK):
                    acc[t] = 1
                s = 1
                for j in range(k):
                    pj = p[j]
                    for t in range(_BLOCK):
                        acc[t] &= Bk[b, j, t] <= pj
                    if j == 1 or j == 3 or j + 1 == k:
                        s = 0
                        for t in range(_BLOCK):
                            s |= acc[t]
                        if s == 0:
                            break
                if s != 0:
                    for t in range(_BLOCK):
                        if acc[t]:
                            for j in range(k):
                                if Bk[b, j, t] < p[j]:
                                    dom = True
                                    break
                            if dom:
                                break
                if dom:
                    break
                b = nxt[b]
            if dom:
                break
            # next cell r <= c, lowest buckets first (odometer over the d columns)
            j = 0
            while j < d:
                if r[j] < c[j]:
                    r[j] += 1
                    cell += stride[j]
                    break
                cell -= r[j] * stride[j]
                r[j] = 0
                j += 1
            if j == d:
                break
        if dom:
            continue
        out[i] = True
        b = tail[M]
        if b < 0 or fill[M] == _BLOCK:
            nb_ = nblk
            nblk += 1
            if b < 0:
                head[M] = nb_
            else:
                nxt[b] = nb_
            tail[M] = nb_
            fill[M] = 0
            b = nb_
        f = fill[M]
        for j in range(k):
            Bk[b, j, f] = p[j]
        fill[M] = f + 1
    return out


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
    for j in range(d):
        q = np.arange(1, B[j]) / B[j]
        thr[j, : B[j] - 1] = np.quantile(sample[:, j], q, method="inverted_cdf")
    return thr, B


def _mask_signed(G: np.ndarray, sgn: np.ndarray, n_pivots: int) -> np.ndarray:
    """Pareto mask of a validated float64 C-contiguous matrix; ``sgn`` = ±1 per column."""
    n, k = G.shape
    mask = np.zeros(n, dtype=bool)
    if n == 0:
        return mask
    feas, lo, hi = _feasible_bounds(G, sgn)
    if k == 1:
        v = sgn[0] * G[:, 0]
        if feas.any():
            mask[feas] = v[feas] == v[feas].min()
        return mask
    nrm = _normalisation(lo, hi)
    rows, keys = _prefilter(G, sgn, feas, nrm, n_pivots)
    if rows.size == 0:
        return mask
    if k == 2:
        x = sgn[0] * G[rows, 0]
        sub = _front2(x, sgn[1] * G[rows, 1], np.argsort(x))
        mask[rows[sub]] = True
    elif k == 3:
        x, y = sgn[0] * G[rows, 0], sgn[1] * G[rows, 1]
        sub = _front3(x, y, sgn[2] * G[rows, 2], np.argsort(x), np.argsort(y))
        mask[rows[sub]] = True
    else:
        X = G[rows] * sgn
        order = np.argsort(keys)
        ks = keys[order]
        if np.any(ks[1:] == ks[:-1]):
            # equal keys: break ties lexicographically so no row precedes its dominator
            order = np.lexsort((*(X[:, j] for j in range(k - 1, -1, -1)), keys))
        rows = rows[order]
        X = np.ascontiguousarray(X[order])
        sub = _sfs(X, *_grid(X))
        mask[rows[sub]] = True
    return mask


def pareto_mask(F: npt.ArrayLike, senses: Sequence[str] | None = None) -> np.ndarray:
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
    Compiled with numba (cached on disk); the first call in a fresh environment compiles the
    kernels, which takes a few seconds. Rows are first screened against a few low-key pivot rows
    in one streaming pass, then the survivors go to an ``O(n log n)`` sweep for ``k = 2`` and
    ``k = 3`` or to a sort–filter–skyline pass (``O(n * front)``) for ``k >= 4``. See the module
    docstring for details. Indicative speed (one core): 1e6 rows, k = 4, uniform data, about
    0.03 s; k = 8 (front of about 31,000 rows) about 0.3 s. The cost grows with the front: when
    nearly every row is non-dominated (strongly conflicting criteria) and ``k >= 4`` it is
    quadratic, e.g. about 7 s for 1e6 mutually non-dominated rows with k = 4.

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
    return _mask_signed(G, sgn, _N_PIVOTS)


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
