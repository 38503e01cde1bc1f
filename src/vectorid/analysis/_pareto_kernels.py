"""Compiled kernels of :mod:`vectorid.analysis.pareto` (numba, cached on disk).

Kept apart so that importing :mod:`vectorid.analysis` does not import numba: loading numba and
these kernels from the cache takes 0.5-1 s, more than the whole analysis of a 1e5-trial store
by the numpy engine of :mod:`~vectorid.analysis.pareto`. The algorithm is described there.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from .pareto import _BLOCK


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
