"""Compiled kernels of :mod:`vectorid.analysis.pareto` (numba, cached on disk).

Kept apart so that importing :mod:`vectorid.analysis` does not import numba: loading numba and
these kernels from the cache takes 0.5-1 s, more than the whole analysis of a 1e5-trial store
by the numpy engine of :mod:`~vectorid.analysis.pareto`. The algorithm is described there.
"""

from __future__ import annotations

from vectorid._simd import configure as _configure_simd

_configure_simd()  # before numba compiles: full-width vectors on AVX-512 CPUs (see _simd)

import numba as nb  # noqa: E402
import numpy as np  # noqa: E402

#: Front members compared per vectorised block in the k >= 4 kernel.
_BLOCK = 64

#: Rows the streaming pre-filter tries first for every row (vectorised over rows).
#: Slot 0: the pivot of lowest key; slot 1: the latest dominator. The unrolled k = 2 and
#: k = 4 passes of :func:`_scan` are written for exactly two.
_HOT = 2
#: Clamp of each normalised column term of the key: keeps the key finite (no inf - inf = NaN).
_BIG = 1e300


@nb.njit(cache=True)
def _key_scales(G, sgn, step):  # pragma: no cover - compiled
    """Offsets and scales of the key's per-column map, shape (2, k), from the rows 0, step, ...

    The key term of column ``j`` is ``clamp((v - nrm[0, j]) * nrm[1, j], -_BIG, _BIG)``: with a
    finite offset and a positive finite scale it is non-decreasing in ``v`` under rounding (and
    NaN only for a NaN ``v``), whatever the sample; the sample's min and spread of the finite
    values only make the columns weigh alike in the key (see :func:`_scales_of`).
    """
    n, k = G.shape
    lo = np.full(k, np.inf)
    hi = np.full(k, -np.inf)
    for i in range(0, n, step):
        for j in range(k):
            v = sgn[j] * G[i, j]
            if v > -np.inf and v < np.inf:  # finite (NaN fails both)
                if v < lo[j]:
                    lo[j] = v
                if v > hi[j]:
                    hi[j] = v
    return _scales_of(lo, hi)


@nb.njit(cache=True)
def _scales_of(lo, hi):  # pragma: no cover - compiled
    """(2, k): offset ``lo`` and scale ``1 / (hi - lo)`` per column where those are finite and
    positive (the spread halved first, so it never overflows), else offset 0 and scale 1."""
    k = lo.shape[0]
    nrm = np.empty((2, k))
    for j in range(k):
        nrm[0, j] = 0.0
        nrm[1, j] = 1.0
        if lo[j] > -np.inf and hi[j] < np.inf and lo[j] <= hi[j]:
            nrm[0, j] = lo[j]
            half = 0.5 * hi[j] - 0.5 * lo[j]
            if half > 0.0:
                sc = 0.5 / half
                if sc > 0.0 and sc < np.inf:
                    nrm[1, j] = sc
    return nrm


@nb.njit(inline="always")
def _block_dominator(P, b, p, k, acc):  # pragma: no cover - compiled
    """Lane of block ``P[b]`` (k x _BLOCK, NaN-padded) that strictly dominates ``p``, or -1.

    Column-wise compare of the whole block (vectorised), with an early exit when no lane is
    still <= ``p`` after columns 2, 4 and k; inlined at the IR level (no call, no reference
    counting per row)."""
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
                return -1
    for t in range(_BLOCK):
        if acc[t]:
            for j in range(k):
                if P[b, j, t] < p[j]:
                    return t
    return -1


@nb.njit(cache=True)
def _scan(G, sgn, nrm, n_pivots, start, stop, surv, keys, P, pkey):  # pragma: no cover
    """Stream over rows ``start:stop``: drop rows with a NaN or strictly dominated by a pivot.

    Rows are copied ``_BLOCK`` at a time, signed and column-wise, into ``T`` and tried against
    the ``_HOT`` "hot" rows (the pivot of lowest key and the latest dominator found; column by
    column, vectorised, no branch, 64-bit flags; the copy and this test are unrolled for k = 2
    and k = 4, whose runtime-k loops LLVM does not vectorise well); the rest one by one
    against all pivots block-wise. A row with a NaN gets a NaN key and is dropped. A
    survivor's index and monotone key go to ``surv[start + w]`` / ``keys[start + w]`` and it
    replaces the pivot of largest key when its key is lower (or fills a free slot).
    Pivots live in ``P`` (n_blocks x k x _BLOCK, NaN-padded) with keys ``pkey``.
    Returns (number of survivors, number of pivots).
    """
    n, k = G.shape
    npiv = 0
    worst = 0  # position of the pivot with the largest key
    # _HOT rows tried first, _BLOCK rows at a time: the pivot of lowest key and the latest
    # dominators found by the full check (NaN: dominates nothing)
    hot = np.full((_HOT, k), np.nan)
    rr = 1  # next slot of hot to replace (1 .. _HOT - 1)
    best = -1  # pivot slot of lowest key
    p = np.empty(k)
    acc = np.empty(_BLOCK, dtype=np.int64)
    le = np.empty(_BLOCK, dtype=np.int64)
    lt = np.empty(_BLOCK, dtype=np.int64)
    drop = np.empty(_BLOCK, dtype=np.int64)
    T = np.empty((k, _BLOCK))  # the block of rows, signed, column-wise
    w = start
    for r0 in range(start, stop, _BLOCK):
        m = min(_BLOCK, stop - r0)
        if k == 2:
            s0 = sgn[0]
            s1 = sgn[1]
            for t in range(m):
                T[0, t] = s0 * G[r0 + t, 0]
                T[1, t] = s1 * G[r0 + t, 1]
        elif k == 4:
            s0 = sgn[0]
            s1 = sgn[1]
            s2 = sgn[2]
            s3 = sgn[3]
            for t in range(m):
                T[0, t] = s0 * G[r0 + t, 0]
                T[1, t] = s1 * G[r0 + t, 1]
                T[2, t] = s2 * G[r0 + t, 2]
                T[3, t] = s3 * G[r0 + t, 3]
        else:
            for j in range(k):
                sj = sgn[j]
                for t in range(m):
                    T[j, t] = sj * G[r0 + t, j]
        for t in range(m, _BLOCK):
            for j in range(k):
                T[j, t] = np.nan
        if k == 2:  # both hot rows in one pass
            a0 = hot[0, 0]
            a1 = hot[0, 1]
            b0 = hot[1, 0]
            b1 = hot[1, 1]
            for t in range(_BLOCK):
                v0 = T[0, t]
                v1 = T[1, t]
                da = (a0 <= v0) & (a1 <= v1) & ((a0 < v0) | (a1 < v1))
                db = (b0 <= v0) & (b1 <= v1) & ((b0 < v0) | (b1 < v1))
                drop[t] = da | db
        elif k == 4:
            a0 = hot[0, 0]
            a1 = hot[0, 1]
            a2 = hot[0, 2]
            a3 = hot[0, 3]
            b0 = hot[1, 0]
            b1 = hot[1, 1]
            b2 = hot[1, 2]
            b3 = hot[1, 3]
            for t in range(_BLOCK):
                v0 = T[0, t]
                v1 = T[1, t]
                v2 = T[2, t]
                v3 = T[3, t]
                da = (a0 <= v0) & (a1 <= v1) & (a2 <= v2) & (a3 <= v3)
                da &= (a0 < v0) | (a1 < v1) | (a2 < v2) | (a3 < v3)
                db = (b0 <= v0) & (b1 <= v1) & (b2 <= v2) & (b3 <= v3)
                db &= (b0 < v0) | (b1 < v1) | (b2 < v2) | (b3 < v3)
                drop[t] = da | db
        else:
            for t in range(_BLOCK):
                drop[t] = 0
            for h in range(_HOT):
                for t in range(_BLOCK):
                    le[t] = 1
                    lt[t] = 0
                for j in range(k):
                    hj = hot[h, j]
                    for t in range(_BLOCK):
                        v = T[j, t]
                        le[t] &= hj <= v
                        lt[t] |= hj < v
                for t in range(_BLOCK):
                    drop[t] |= le[t] & lt[t]
        alldrop = 1
        for t in range(_BLOCK):
            alldrop &= drop[t]
        if alldrop:
            continue
        for t in range(m):
            if drop[t]:
                continue
            i = r0 + t
            for j in range(k):
                p[j] = T[j, t]
            dom = -1
            for b in range(-(-npiv // _BLOCK)):
                dom = _block_dominator(P, b, p, k, acc)
                if dom >= 0:
                    for j in range(k):
                        hot[rr, j] = P[b, j, dom]
                    rr = rr + 1 if rr + 1 < _HOT else 1
                    break
            if dom >= 0:
                continue
            key = 0.0
            for j in range(k):
                u = (p[j] - nrm[0, j]) * nrm[1, j]
                if u > _BIG:
                    u = _BIG
                elif u < -_BIG:
                    u = -_BIG
                key += u
            if key != key:  # a NaN in the row: a failed trial
                continue
            surv[w] = i
            keys[w] = key
            w += 1
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
            for q in range(1, npiv):
                if pkey[q] > pkey[worst]:
                    worst = q
            if best < 0 or key < pkey[best] or best == slot:
                best = slot
                for q in range(npiv):
                    if pkey[q] < pkey[best]:
                        best = q
                for j in range(k):
                    hot[0, j] = P[best // _BLOCK, j, best % _BLOCK]
    return w - start, npiv


@nb.njit(cache=True)
def _recheck(G, sgn, surv, keys, start, count, P, npiv):  # pragma: no cover - compiled
    """Drop from ``surv[start:start + count]`` (and ``keys``) the rows a pivot strictly
    dominates, in place; returns the number kept."""
    k = G.shape[1]
    p = np.empty(k)
    acc = np.empty(_BLOCK, dtype=np.int64)
    nblk = -(-npiv // _BLOCK)
    w = start
    for it in range(start, start + count):
        i = surv[it]
        for j in range(k):
            p[j] = sgn[j] * G[i, j]
        dom = -1
        for b in range(nblk):
            dom = _block_dominator(P, b, p, k, acc)
            if dom >= 0:
                break
        if dom < 0:
            surv[w] = i
            keys[w] = keys[it]
            w += 1
    return w - start


@nb.njit(cache=True)
def _prefilter(G, sgn, nrm, n_pivots):  # pragma: no cover - compiled
    """Pivot pre-filter of all rows in one thread; returns (survivor rows, their keys)."""
    n, k = G.shape
    npb = max(-(-n_pivots // _BLOCK), 1)
    P = np.full((npb, k, _BLOCK), np.nan)
    pkey = np.empty(npb * _BLOCK)
    surv = np.empty(n, dtype=np.int64)
    keys = np.empty(n)
    ns, npiv = _scan(G, sgn, nrm, n_pivots, 0, n, surv, keys, P, pkey)
    if npiv:
        ns = _recheck(G, sgn, surv, keys, 0, ns, P, npiv)
    return surv[:ns], keys[:ns]


@nb.njit(cache=True, parallel=True)
def _prefilter_parallel(G, sgn, nrm, n_pivots, n_chunks):  # pragma: no cover - compiled
    """The pre-filter on ``n_chunks`` contiguous row ranges in parallel (numba threads).

    Each range is scanned with its own pivots; then every survivor is checked against the
    pivots of all ranges (in parallel again) and the survivors are gathered in row order."""
    n, k = G.shape
    npb = max(-(-n_pivots // _BLOCK), 1)
    P = np.full((n_chunks * npb, k, _BLOCK), np.nan)
    pkey = np.empty((n_chunks, npb * _BLOCK))
    surv = np.empty(n, dtype=np.int64)
    keys = np.empty(n)
    counts = np.zeros(n_chunks, dtype=np.int64)
    npivs = np.zeros(n_chunks, dtype=np.int64)
    for c in nb.prange(n_chunks):
        a = c * n // n_chunks
        z = (c + 1) * n // n_chunks
        ns, npiv = _scan(
            G, sgn, nrm, n_pivots, a, z, surv, keys, P[c * npb : (c + 1) * npb], pkey[c]
        )
        counts[c] = ns
        npivs[c] = npiv
    # the pivots of all ranges, packed (each range's last block may be partly NaN: harmless)
    nq = 0
    for c in range(n_chunks):
        if npivs[c]:
            nq = (c + 1) * npb * _BLOCK
    for c in nb.prange(n_chunks):
        a = c * n // n_chunks
        counts[c] = _recheck(G, sgn, surv, keys, a, counts[c], P, nq)
    total = 0
    for c in range(n_chunks):
        total += counts[c]
    rows = np.empty(total, dtype=np.int64)
    rkeys = np.empty(total)
    w = 0
    for c in range(n_chunks):
        a = c * n // n_chunks
        for t in range(a, a + counts[c]):
            rows[w] = surv[t]
            rkeys[w] = keys[t]
            w += 1
    return rows, rkeys


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
    acc = np.empty(_BLOCK, dtype=np.int64)
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
                if _block_dominator(Bk, b, p, k, acc) >= 0:
                    dom = True
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
