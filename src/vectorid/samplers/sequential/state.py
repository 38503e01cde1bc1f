"""The sequential sampler's state, replayed from the store: its generations, D at the stated
limits, the members' importance weights or holding times, and the ESS.

Everything here only reads: the store's sampler records become :class:`Generation` objects,
and the stored trials of every generation give :class:`SequentialState`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.special import logsumexp

from ...limits import Limits, oriented
from ...spec import StudySpec
from ...store import SamplerRecord, Store, Trials
from ..weighting import Weighting, kish_ess
from .kernel import Proposal
from .moves import chains_ess, kept_moves
from .weights import log_weights

__all__ = [
    "Generation",
    "SequentialState",
    "assess",
    "assess_generations",
    "final_chains",
    "generation_of",
    "generations",
    "holding_log_weights",
    "moved_particles",
    "proposals_of",
    "relaxed",
    "rows_of",
    "score",
    "tolerance_json",
    "tolerance_of",
    "trial_log_weights",
    "unit",
    "weighting_of",
]


@dataclass(frozen=True)
class Generation:
    """One generation of a sequential study, replayed from its record in the store.

    Attributes
    ----------
    gen, seq_start, n : int
        Generation number; its trials are the stage-0 sequence indices
        ``seq_start .. seq_start + n - 1``.
    created : float
        Unix time it was recorded.
    proposal : dict
        ``kind`` (``"sobol"`` or ``"mixture"``), ``tolerance`` (criterion -> limit aimed
        at), ``log_mass`` and ``draws`` of the kernel, ...; with moves, ``move``.
    X : (n, p) float array
        The proposed vectors, in the study's units.
    centres, log_mix, chol : float arrays
        The kernel's parameters in unit coordinates.
    """

    gen: int
    seq_start: int
    n: int
    created: float
    proposal: dict[str, Any]
    X: np.ndarray
    centres: np.ndarray
    log_mix: np.ndarray
    chol: np.ndarray

    @classmethod
    def from_record(cls, rec: SamplerRecord, p: int) -> Generation:
        """The generation a store's sampler record holds (``p`` variables)."""
        x, centres, log_mix, chol = rec.arrays
        return cls(
            rec.index, rec.seq_start, rec.n, rec.created, rec.info,
            x.reshape(rec.n, p), centres.reshape(-1, p), log_mix, chol.reshape(p, p),
        )  # fmt: skip

    def record(self) -> dict[str, Any]:
        """The sampler record that keeps this generation (see :class:`vectorid.samplers.Round`)."""
        return {
            "index": self.gen,
            "seq_start": self.seq_start,
            "n": self.n,
            "info": self.proposal,
            "arrays": (self.X, self.centres, self.log_mix, self.chol),
        }


def generations(store: Store) -> list[Generation]:
    """The sequential sampler's generations a store keeps, in order (empty for a plain store)."""
    p = len(store.spec.space)
    return [Generation.from_record(r, p) for r in store.sampler_records()]


@dataclass
class SequentialState:
    """D and the weights of a sequential store's trials under the stated limits.

    Attributes
    ----------
    proposals : list of Proposal
        Every generation's proposal.
    counts : list of int
        Trials evaluated per generation.
    generation : (n,) int array
        Generation of each trial (-1 for trials outside every generation).
    constrained : list of int
        Indices of the criteria with a limit.
    phi : (n, k_c) float array
        Oriented constrained criteria (smaller is better).
    floor : (k_c,) float array
        Oriented stated limits.
    usable : (n,) bool array
        Trials that succeeded and meet the functional constraints.
    members : (n,) bool array
        Members of D at the stated limits.
    log_w : (n,) float array
        Log importance weights of the members (NaN elsewhere; all NaN when not computed).
    ess : float
        Kish's effective sample size of the members' importance weights; with moves (many
        variables, at the stated limits) the chains' ESS from their autocorrelation instead
        (:func:`~vectorid.samplers.sequential.moves.chain_ess`, min over the variables, over
        the moves kept after the warm-up at the stated limits; 0 before four are kept).
    particles : (N,) int array or None
        With moves: rows of the current particles (after the last generation's moves).
    chains : (m, N) int array or None
        With moves: the particles after each move at the stated limits
        (:func:`final_chains`).
    """

    proposals: list[Proposal]
    counts: list[int]
    generation: np.ndarray
    constrained: list[int]
    phi: np.ndarray
    floor: np.ndarray
    usable: np.ndarray
    members: np.ndarray
    log_w: np.ndarray
    ess: float
    particles: np.ndarray | None = None
    chains: np.ndarray | None = None


def unit(space, X: np.ndarray) -> np.ndarray:
    return (np.asarray(X, dtype=float) - space.lows) / (space.highs - space.lows)


def proposals_of(gens: Sequence[Generation], p: int) -> list[Proposal]:
    """The stored generations' proposal densities."""
    return [Proposal.stored(g.proposal, g.centres, g.log_mix, g.chol) for g in gens]


def generation_of(gens: Sequence[Generation], trials: Trials) -> np.ndarray:
    out = np.full(len(trials), -1, dtype=np.int64)
    for g in gens:
        m = (trials.stage == 0) & (trials.seq >= g.seq_start) & (trials.seq < g.seq_start + g.n)
        out[m] = g.gen
    return out


def assess(
    store: Store, trials: Trials | None = None, limits: Any = None, *, weights: bool = True
) -> SequentialState:
    """D at the stated limits (or at ``limits``), its importance weights and ESS.

    Parameters
    ----------
    store : Store
        A sequential store.
    trials : Trials, optional
        Stage-0 trials (loaded when not given).
    limits : optional
        Bounds overriding the study's (as :class:`~vectorid.limits.Limits` takes them): D is
        taken at these, e.g. a limit loosened after the run.
    weights : bool
        Compute the members' importance weights (the moves' driver needs none; with many
        generations they cost most of the time).
    """
    if trials is None:
        trials = store.load(stages=[0])
    cache = (str(store.path), store.meta().get("created"))
    return assess_generations(store.spec, generations(store), trials, limits, weights=weights,
                              cache=cache)  # fmt: skip


def assess_generations(
    spec: StudySpec,
    gens: Sequence[Generation],
    trials: Trials,
    limits: Any = None,
    *,
    weights: bool = True,
    cache: Any = None,
) -> SequentialState:
    """:func:`assess` from the generations and trials themselves.

    Parameters
    ----------
    spec : StudySpec
    gens : sequence of Generation
    trials : Trials
        Stage-0 trials.
    limits, weights
        As for :func:`assess`.
    cache : hashable, optional
        Identifies the store, so that proposal densities of its trials are computed once
        (None: not cached).
    """
    p = len(spec.space)
    proposals = proposals_of(gens, p)
    generation = generation_of(gens, trials)
    counts = [int(np.sum(generation == g.gen)) for g in gens]
    lim = Limits(spec, limits)
    constrained, floor = lim.constrained()
    senses = [spec.criteria[j].sense for j in constrained]
    phi = oriented(trials.F[:, constrained], senses)
    functional = lim.functional_mask(trials.status, trials.G)
    feasible = lim.feasible_mask(trials.status, trials.F, trials.G)
    usable = functional & (generation >= 0)
    members = feasible & (generation >= 0)
    stated = limits is None or lim.same_as_stated()
    moved = bool(gens) and gens[-1].proposal.get("move") is not None and stated
    weights = weights and not moved
    log_w = np.full(len(trials), np.nan)
    if members.any() and weights:
        log_w[members] = cached_log_weights(cache, spec, trials, generation, proposals, counts,
                                            members)  # fmt: skip
    ess = kish_ess(log_w[members]) if weights else 0.0
    state = SequentialState(
        proposals, counts, generation, constrained, phi, floor, usable, members, log_w, ess
    )
    if moved:  # D's sample: the chains' states over the kept moves at the stated limits
        state.particles, _, _ = moved_particles(spec, state, trials, gens[-1])
        state.chains = final_chains(spec, state, trials, gens)
        kept = state.chains[len(state.chains) - kept_moves(len(state.chains)) :]
        counts = np.bincount(kept.ravel(), minlength=len(trials)) if kept.size else None
        with np.errstate(divide="ignore"):
            log_w[members] = -np.inf if counts is None else np.log(counts[members])
        state.ess = chain_ess_of(spec, trials, kept)
    return state


def final_chains(spec, state: SequentialState, trials: Trials, gens) -> np.ndarray:
    """With moves: the particles (rows of ``trials``) after each move made at the stated
    limits, oldest first — ``(m, N)``; ``(0, 0)`` when the last generation's limits are not
    the stated ones. Row ``i`` of every move is the same chain (no copies are made at the
    stated limits)."""
    hist = []
    for gen in reversed(gens):
        if gen.proposal.get("move") is None:
            break
        P, _, eps = moved_particles(spec, state, trials, gen)
        if not np.all(eps <= state.floor):
            break
        hist.append(P)
    if not hist:
        return np.empty((0, 0), dtype=np.int64)
    return np.array(hist[::-1], dtype=np.int64)


def chain_ess_of(spec, trials: Trials, kept: np.ndarray) -> float:
    """The chains' ESS over the kept moves (min over the variables; 0 for fewer than four
    moves): :func:`~vectorid.samplers.sequential.moves.chain_ess` in unit coordinates."""
    if kept.ndim != 2 or kept.shape[0] < 4:
        return 0.0
    return float(np.min(chains_ess(unit(spec.space, trials.X[kept]))))


def holding_log_weights(
    spec: StudySpec, trials: Trials, gens: Sequence[Generation]
) -> np.ndarray | None:
    """Log weights of a moved store's trials as D's sample (None when the chains have not
    made four kept moves at the stated limits): each member of D weighs the number of kept
    moves (after :data:`~vectorid.samplers.sequential.moves.WARMUP`) at the stated limits for
    which it was a particle's state — its holding time, summed over the chains. Members never
    so weigh 0 (``-inf``); trials outside D at the stated limits have no weight (NaN)."""
    state = assess_generations(spec, gens, trials, weights=False)
    if state.chains is None or kept_moves(state.chains.shape[0]) < 4:
        return None
    out = np.full(len(trials), np.nan)
    out[state.members] = state.log_w[state.members]
    return out


#: Log proposal densities of stored trials, one block per (proposal, generation of trials);
#: kept for the last store only. Trials and proposals never change once stored, so a block
#: is computed once instead of once per generation (the weights are recomputed every
#: generation over every earlier proposal).
_DENSITY_BLOCKS: dict[str, Any] = {"store": None, "blocks": {}}


def cached_log_weights(
    cache: Any,
    spec,
    trials: Trials,
    generation: np.ndarray,
    proposals: Sequence[Proposal],
    counts: Sequence[int],
    mask: np.ndarray,
) -> np.ndarray:
    """:func:`~vectorid.samplers.sequential.weights.log_weights` of ``trials[mask]``, each
    proposal's density evaluated once per block of one generation's trials.

    A block always holds the same rows (all stored trials of that generation), so an
    interrupted and resumed run computes the same numbers, bit for bit, as an uninterrupted
    one.
    """
    ident = cache if cache is not None else object()
    if _DENSITY_BLOCKS["store"] != ident:
        _DENSITY_BLOCKS["store"] = ident
        _DENSITY_BLOCKS["blocks"] = {}
    blocks: dict[tuple, np.ndarray] = _DENSITY_BLOCKS["blocks"]
    rows = np.flatnonzero(mask)
    total = float(sum(counts))
    if not len(rows) or total <= 0:
        return np.zeros(len(rows))
    gen_rows = generation[rows]
    hs = np.unique(gen_rows)
    members_of = {int(h): np.flatnonzero(generation == h) for h in hs}
    # position of each selected row inside its generation's block
    where = np.empty(len(rows), dtype=np.int64)
    for h, block_rows in members_of.items():
        sel = gen_rows == h
        where[sel] = np.searchsorted(block_rows, rows[sel])
    terms = []
    for g, (prop, n) in enumerate(zip(proposals, counts)):
        if n <= 0:
            continue
        col = np.empty(len(rows))
        for h, block_rows in members_of.items():
            key = (g, prop.log_mass, h, len(block_rows), hash(trials.seq[block_rows].tobytes()))
            dens = blocks.get(key)
            if dens is None:
                dens = prop.logpdf(unit(spec.space, trials.X[block_rows]))
                blocks[key] = dens
            sel = gen_rows == h
            col[sel] = dens[where[sel]]
        terms.append(col + math.log(n / total))
    return -logsumexp(np.vstack(terms), axis=0)


def trial_log_weights(store: Store, trials: Trials, mask: np.ndarray) -> np.ndarray:
    """Log importance weights of ``trials[mask]`` of a sequential store (they make any
    subset selected by limits a weighted sample of the box's uniform density)."""
    spec = store.spec
    gens = generations(store)
    generation = generation_of(gens, trials)
    counts = [int(np.sum(generation == g.gen)) for g in gens]
    return log_weights(
        unit(spec.space, trials.X[mask]), proposals_of(gens, len(spec.space)), counts
    )


def weighting_of(spec: StudySpec, gens: Sequence[Generation], trials: Trials) -> Weighting | None:
    """How a sequential store's sample ``trials`` weighs (None for a store without
    generations): importance weights against the box over every generation's proposal, or,
    for a store whose particles moved (many variables), the members' holding times in the
    particles' chains at the stated limits (computed on first use; a vector that is no member
    of D, or no trial, has none: NaN)."""
    if not gens:
        return None
    if gens[-1].proposal.get("move") is None:
        lows, widths = spec.space.lows, spec.space.highs - spec.space.lows
        props = proposals_of(gens, len(spec.space))
        counts = [g.n for g in gens]

        def importance(X: np.ndarray) -> np.ndarray:
            return log_weights((np.asarray(X, dtype=float) - lows) / widths, props, counts)

        return Weighting("importance", importance)
    memo: dict[bytes, float] = {}
    done: list[bool] = []

    def holding(X: np.ndarray) -> np.ndarray:
        if not done:
            lw = holding_log_weights(spec, trials, gens)
            if lw is not None:
                rows = np.flatnonzero(~np.isnan(lw))
                memo.update({trials.X[i].tobytes(): float(lw[i]) for i in rows})
            done.append(True)
        X = np.ascontiguousarray(np.asarray(X, dtype=float).reshape(-1, trials.X.shape[1]))
        return np.array([memo.get(x.tobytes(), np.nan) for x in X])

    return Weighting("holding", holding)


def tolerance_json(spec, constrained, eps) -> dict[str, float | None]:
    out: dict[str, float | None] = {}
    for j, e in zip(constrained, eps):
        c = spec.criteria[j]
        v = float(e if c.sense == "min" else -e)
        out[c.name] = v if math.isfinite(v) else None
    return out


def tolerance_of(gen: Generation, spec, constrained) -> np.ndarray:
    tol = gen.proposal.get("tolerance") or {}
    out = []
    for j in constrained:
        c = spec.criteria[j]
        v = tol.get(c.name)
        if v is None:
            out.append(math.inf)
        else:
            out.append(float(v) if c.sense == "min" else -float(v))
    return np.array(out, dtype=float)


def relaxed(eps: np.ndarray, floor: np.ndarray) -> float | None:
    pos = floor > 0
    if not pos.any() or not np.all(np.isfinite(eps[pos])):
        return None
    return float(np.max(eps[pos] / floor[pos]))


def score(phi: np.ndarray, floor: np.ndarray) -> np.ndarray:
    """``max_l Φ_l / Φ**_l`` for positive limits (``1 + Φ_l - Φ**_l`` otherwise): <= 1 meets
    every limit."""
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.where(floor > 0, phi / np.where(floor > 0, floor, 1.0), 1.0 + phi - floor)
    s = np.max(ratio, axis=1) if ratio.shape[1] else np.zeros(len(phi))
    return np.where(np.isfinite(s), s, np.inf)


def rows_of(trials: Trials, seqs) -> np.ndarray:
    """Rows of stage-0 trials with sequence indices ``seqs`` (-1 where none is stored)."""
    seqs = np.asarray(seqs, dtype=np.int64)
    out = np.full(len(seqs), -1, dtype=np.int64)
    if not len(trials):
        return out
    pos = np.full(int(trials.seq.max()) + 1, -1, dtype=np.int64)
    pos[trials.seq] = np.arange(len(trials))
    inr = (seqs >= 0) & (seqs < len(pos))
    out[inr] = pos[seqs[inr]]
    return out


def moved_particles(spec, state: SequentialState, trials: Trials, gen: Generation):
    """The particles after generation ``gen``'s moves: each draw that meets the generation's
    limits replaces its particle. Returns (rows, share of moves accepted, limits)."""
    mv = gen.proposal["move"]
    P = rows_of(trials, mv["particles"])
    eps = tolerance_of(gen, spec, state.constrained)
    parents = np.asarray(mv["parents"], dtype=np.int64)[: gen.n]
    draws = rows_of(trials, gen.seq_start + np.arange(len(parents)))
    ok = draws >= 0
    with np.errstate(invalid="ignore"):
        ok[ok] = state.usable[draws[ok]] & np.all(state.phi[draws[ok]] <= eps, axis=1)
    P = P.copy()
    P[parents[ok]] = draws[ok]
    return P, float(ok.sum()) / max(len(P), 1), eps
