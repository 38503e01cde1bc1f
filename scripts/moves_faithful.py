"""Is a moved population (20 or more variables) a faithful sample of uniform-on-D?

Runs the sequential sampler on two problems whose uniform-on-D marginals are known exactly —
the 24-variable banana of ``tests/samplers/sequential/test_moves.py`` and a 20-variable slab — and
compares, axis by axis, the Kolmogorov–Smirnov distance to the exact marginal of

(i)   the distinct final particles (what the ESS used to count),
(ii)  the chains' states over the kept moves at the stated limits, each weighted by its
      holding time (what densities of D now use), and
(iii) every member of D in the store, counted once each (what histograms used to count),

each at the old stopping point (30 moves at the stated limits) and at the run's end. An axis
fails when ``D sqrt(n) > K`` at the family-wise 1 % level over the axes, with ``n`` the
distinct particles (i), the chains' ESS (ii) or the members (iii).

    nice -n 5 .venv/bin/python scripts/moves_faithful.py [--budget 60000] [--seed 0]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy import stats

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "samplers" / "sequential"))

from test_moves import CENTRES, HALF, K, P, banana_spec

from vectorid.problem import Criterion
from vectorid.run.loop import run_store
from vectorid.samplers.sequential.moves import kept_moves
from vectorid.samplers.sequential.state import (
    assess_generations,
    chain_ess_of,
    final_chains,
    generations,
)
from vectorid.space import Continuous, Space
from vectorid.spec import StudySpec
from vectorid.store import Store

ALPHA = 0.01
VERBOSE = False


def banana_cdfs() -> list:
    """Exact marginal CDFs of uniform on the banana's D (a product set)."""
    out = []
    for j in range(K):
        out.append(stats.uniform(CENTRES[j] - HALF, 2 * HALF).cdf)
    g = np.linspace(0.0, 1.0, 200_001)
    c = 0.2 + 3.0 * (g - 0.5) ** 2
    length = np.clip(c + 0.03, 0, 1) - np.clip(c - 0.03, 0, 1)  # y-length of the band at x
    cx = np.concatenate([[0.0], np.cumsum(0.5 * (length[1:] + length[:-1]) * np.diff(g))])
    cx /= cx[-1]
    out.append(lambda v, cx=cx: np.interp(v, g, cx))
    # y marginal: x-measure of {x : |y - c(x)| <= 0.03}, by a grid over x for each y
    ys = np.linspace(0.0, 1.0, 4001)
    xs = np.linspace(0.0, 1.0, 20001)
    cxs = 0.2 + 3.0 * (xs - 0.5) ** 2
    dens = np.array([np.mean(np.abs(y - cxs) <= 0.03) for y in ys])
    cy = np.concatenate([[0.0], np.cumsum(0.5 * (dens[1:] + dens[:-1]) * np.diff(ys))])
    cy /= cy[-1]
    out.append(lambda v, cy=cy: np.interp(v, ys, cy))
    out += [stats.uniform(0, 1).cdf] * (P - K - 2)
    return out


# the 20-variable slab: the first 6 variables pinned within 0.05 of 0.5, the others free
SLAB_P, SLAB_K, SLAB_HALF = 20, 6, 0.05


def slab(X):
    return np.abs(X[:, :SLAB_K] - 0.5), np.zeros((len(X), 0))


def slab_spec(**kw) -> StudySpec:
    opts = {"trials": 2048, "budget": 60_000, "population": 200, "seed": 0} | kw
    return StudySpec(
        name="slab",
        model=slab,
        space=Space([Continuous(f"x{i}", 0.0, 1.0) for i in range(SLAB_P)]),
        criteria=tuple(Criterion(f"f{i}", limit=SLAB_HALF) for i in range(SLAB_K)),
        sampler="sequential",
        **opts,
    )


def slab_cdfs() -> list:
    pinned = [stats.uniform(0.5 - SLAB_HALF, 2 * SLAB_HALF).cdf] * SLAB_K
    return pinned + [stats.uniform(0, 1).cdf] * (SLAB_P - SLAB_K)


def ks(x: np.ndarray, w: np.ndarray | None, cdf) -> float:
    """One-sample (weighted) KS distance of ``x`` to ``cdf``."""
    w = np.ones(len(x)) if w is None else np.asarray(w, float)
    o = np.argsort(x)
    xs, ws = x[o], w[o] / w.sum()
    hi = np.cumsum(ws)
    lo = hi - ws
    f = cdf(xs)
    return float(max(np.max(hi - f), np.max(f - lo)))


def judge(label: str, X: np.ndarray, w, n: float, cdfs) -> str:
    crit = stats.kstwobign.isf(ALPHA / len(cdfs))
    d = np.array([ks(X[:, j], w, cdfs[j]) for j in range(len(cdfs))])
    z = d * np.sqrt(max(n, 1.0))
    return (
        f"  {label:<44} n={n:7.0f}  fail {int(np.sum(z > crit)):2d}/{len(cdfs)}  "
        f"max D {d.max():.3f}  max D√n {z.max():5.2f} (crit {crit:.2f})"
        + (f"\n      D per axis: {' '.join(f'{v:.2f}' for v in d)}" if VERBOSE else "")
    )


def analyse(st: Store, upto: int, cdfs) -> list[str]:
    """The three samples with the store's first ``upto`` generations."""
    gens = generations(st)[:upto]
    trials = st.load(stages=[0])
    state = assess_generations(st.spec, gens, trials, weights=False)
    hist = final_chains(st.spec, state, trials, gens)
    m = hist.shape[0]
    kept = hist[m - kept_moves(m) :]
    seqs = trials.seq
    mem = state.members & (seqs < gens[-1].seq_start + gens[-1].n)
    lines = [f" after generation {upto - 1}: {m} moves at the stated limits, {mem.sum()} members"]
    part = np.unique(state.particles)
    lines.append(judge("(i) distinct final particles", trials.X[part], None, len(part), cdfs))
    if kept.size:
        cnt = np.bincount(kept.ravel(), minlength=len(trials))
        rows = np.flatnonzero(cnt)
        ess = chain_ess_of(st.spec, trials, kept)
        lines.append(
            judge(
                f"(ii) chain states × holding time (last {len(kept)})",
                trials.X[rows],
                cnt[rows],
                ess,
                cdfs,
            )
        )
    lines.append(judge("(iii) every member of D, once each", trials.X[mem], None, mem.sum(), cdfs))
    return lines


def stops(st: Store, every: int) -> list[tuple[int, int]]:
    """(generations, moves at the stated limits) every ``every`` moves there, and the last."""
    gens = generations(st)
    out = []
    for g in range(len(gens)):
        mv = gens[g].proposal.get("move")
        if mv is None:
            continue
        tol = gens[g].proposal["tolerance"]
        at = all(tol[c.name] is not None and tol[c.name] <= c.limit for c in st.spec.criteria)
        m = int(mv["level_moves"])
        if at and (m % every == 0 or g == len(gens) - 1):
            out.append((g + 1, m))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--budget", type=int, default=60_000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--population", type=int, default=200, help="members of D wanted")
    ap.add_argument("--problems", nargs="*", default=["slab20", "banana24"])
    ap.add_argument("--moves", type=int, default=0, help="least moves at the stated limits")
    ap.add_argument("--every", type=int, default=10, help="analyse every this many moves")
    ap.add_argument(
        "--set", nargs="*", default=[], help="NAME=VALUE: a constant of the sequential sampler"
    )
    ap.add_argument("--verbose", action="store_true", help="KS distance of every axis")
    args = ap.parse_args()
    global VERBOSE
    VERBOSE = args.verbose
    from benchmarks_machine import describe

    print(describe())
    problems = {
        "slab20": (slab_spec, slab_cdfs),
        "banana24": (banana_spec, banana_cdfs),
    }
    from vectorid.samplers.sequential import moves, sampler, schedule, search, state

    modules = (moves, schedule, sampler, search, state)  # each binds the constants it uses

    def set_constant(k: str, v: str) -> None:
        holders = [m for m in modules if hasattr(m, k)]
        if not holders:
            raise SystemExit(f"no constant {k} in vectorid.samplers.sequential")
        value = type(getattr(holders[0], k))(v)
        for m in holders:
            setattr(m, k, value)
        print(f"set {k} = {value}")

    if args.moves:
        set_constant("MIN_FINAL_MOVES", str(args.moves))
    for kv in args.set:
        set_constant(*kv.split("="))
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.problems:
            make, cdfs_of = problems[name]
            cdfs = cdfs_of()
            t0 = time.perf_counter()
            path = Path(tmp) / f"{name}.db"
            kw = {"budget": args.budget, "seed": args.seed, "population": args.population}
            with Store.create(path, make(**kw)) as st:
                summary = run_store(st, executor="inline", progress=False)
            wall = time.perf_counter() - t0
            print(f"{name} (seed {args.seed}): {wall:.0f} s; {summary.verdict()}")
            with Store.open(path) as st:
                for g, _ in stops(st, args.every):
                    print("\n".join(analyse(st, g, cdfs)), flush=True)


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    sys.modules["benchmarks_machine"] = __import__("_machine")
    main()
