"""The sequential PSI sampler: generations of trials that move into the feasible set D.

A study asks for it with ``[study] sampler = "sequential"``, ``budget`` (model evaluations
at most) and ``population`` (members of D wanted, default 200). Each generation is evaluated
as batches through the study's executor (in-process, processes or Dask) and stored like any
trial; the parts that only compute live in :mod:`vectorid.sequential`.

1. Generation 0 is the plain Sobol table of the study's ``trials`` first points (so a
   sequential store starts exactly like a plain one).
2. After each generation the driver computes D at the stated limits: its members, their
   importance weights (:mod:`vectorid.sequential.weights`) and Kish's effective sample size
   (ESS). It stops when D holds at least ``population`` members with an ESS of at least
   ``population`` (:data:`ESS_SHARE`), or when the budget is spent.
3. Otherwise generation ``g + 1`` tightens each constrained criterion's limit toward its
   Φ** (:mod:`vectorid.sequential.tolerance`; functional constraints are always hard), fits
   a Gaussian-mixture kernel on the trials of every generation that meet the new limits
   (:mod:`vectorid.sequential.kernel`) and draws points inside the box from it, in one of
   two schedules. *Searching* (D at the stated limits holds no member yet): the limits that
   :data:`SEARCH_KEEP` of the trials within the last ones meet, every axis Gaussian with
   covariance factor :data:`SEARCH_SCALE`, ``SEARCH_GENERATION_FACTOR x population`` points.
   *D found*: the limits that :data:`KEEP` of those trials meet (but at least
   :data:`MIN_KEEP_SHARE` x ``population`` trials), the free axes uniform and the tied ones
   with factor :data:`SCALE`, ``GENERATION_FACTOR x population`` points; a generation that
   aims at the stated limits draws only what the ESS still wanted needs at the last
   generation's rate. The generation (its points, kernel and schedule) is recorded *before*
   it is evaluated.
4. With :data:`~vectorid.sequential.moves.MOVE_FROM` or more variables the importance
   weights degenerate, so generations 1, 2, ... instead move ``PARTICLES_FACTOR x
   population`` equally weighted particles by random-walk Metropolis steps inside the
   current limits (:mod:`vectorid.sequential.moves`); the run has converged when the limits
   are the stated ones, the particles have made ``MIN_FINAL_MOVES`` moves there or more, and
   the chains' ESS from their autocorrelation over the moves kept after the warm-up reaches
   ``population`` (the ESS printed); D's densities weigh each member by its holding time.

Resume: generation ``g``'s points are a deterministic function of the seed, ``g``, the study's
limits and the stored trials of generations ``< g``; they are stored before evaluation, so a
run killed at any point (``kill -9``) continues with exactly the trials an uninterrupted run
computes, none lost or repeated.

When the budget is spent before D holds the population, the summary says how far it got
(the limits the last generation met, as a factor on Φ**). Only if a local search from the
best trials (a pattern search from several starts, evaluated in batches, stored as an
auxiliary stage of kind ``"search"``) also fails to meet every limit, with its best vector
inside the box, does it say that the model or the limits may not fit the data, with the best
vector found; a best vector on the box's edge means the box may be too narrow there (the
variables and edges are named).
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any, TextIO

import numpy as np
from scipy.special import logsumexp

from ..errors import StudyDefinitionError
from ..problem import FAILED, OK, EvalResult
from ..sequential.kernel import MASS_DRAWS, Proposal, _cholesky, fit_proposal
from ..sequential.moves import (
    DIVERSE,
    MIN_FINAL_MOVES,
    MOVE_FROM,
    adapt_scale,
    chains_ess,
    copy_evenly,
    in_box_mass,
    initial_scale,
    kept_moves,
    move_draws,
    particle_cov,
)
from ..sequential.tolerance import next_tolerance, oriented
from ..sequential.weights import kish_ess, log_weights
from ..store.sqlite import Generation, Store, Trials
from .executors import make_executor
from .loop import FIRST_LOOK, RunInterrupted, RunSummary, _stop_loudly

__all__ = [
    "COLLAPSE_SHARE",
    "ESS_SHARE",
    "GENERATION_FACTOR",
    "LocalSearch",
    "SequentialState",
    "SequentialSummary",
    "assess",
    "run_sequential",
    "sample_note",
    "trial_log_weights",
]

#: Until D at the stated limits holds a member ("searching"), generations follow a careful
#: schedule (SEARCH_*): where D is hard to reach, the population must not narrow onto the first
#: region that looks good. Measured on the ETH flights (12 variables, D not reached, 50,000
#: evaluations; ``examples/eth_parafoil.py``): keeping half the trials and drawing 4 x population
#: per generation, the nearest generation meets the limits x1.02 with Cnr against its physical
#: floor; 0.3 and 2 x population stalled at x1.11 inside the box, and the faster settings below
#: at x1.33 (docs/sequential.md). Once a member of D is known, the population knows where D is,
#: and the faster settings reach a faithful sample in a third of the evaluations (parachute15
#: twins seeds 0-5: 1,894 evaluations on average against 5,957).
#: Members of D at the stated limits that end the search.
FOUND = 1
#: Searching: share of the trials within the last limits that meet the next ones ...
SEARCH_KEEP = 0.5
#: ... this many times ``population`` points per generation ...
SEARCH_GENERATION_FACTOR = 4
#: ... and the kernel's covariance factor (Beaumont et al. 2009), every axis Gaussian.
SEARCH_SCALE = 2.0
#: D found: later generations propose this many times ``population`` points (2 was tried:
#: the run stops a whole generation later than it needs; parachute15 twin 2,224 against 1,824).
GENERATION_FACTOR = 1
#: A generation that aims at the stated limits is sized to the ESS still wanted at the last
#: generation's rate, with this margin ...
SIZE_MARGIN = 1.15
#: ... and at least this share of ``population`` trials.
MIN_GENERATION = 0.25
#: D found: share of the trials within the last limits that meet the next generation's
#: limits ...
KEEP = 0.05
#: ... but at least this share of ``population`` (and ``2 (p + 1)``) trials: the limits drop
#: as fast as enough centres allow (0.3 of the trials took four generations to the stated
#: limits on the parachute15 twin where this takes two).
MIN_KEEP_SHARE = 0.25
#: The run has converged when D's ESS reaches this share of ``population``.
ESS_SHARE = 1.0
#: Below this share of ``population``, D's ESS means the population has collapsed.
COLLAPSE_SHARE = 0.1
#: D found: the kernel's covariance factor on the tied axes (the free ones are uniform).
#: Beaumont et al.'s 2 (2009) was the factor while every axis was Gaussian; with the free axes
#: drawn uniformly the tied block has few axes, and a narrower kernel wastes fewer draws outside
#: D. Measured (parachute15 twins seeds 0-3, mean evaluations to ESS 200): 0.5: 1,684;
#: 0.75: 1,864; 1: 1,877 (KEEP 0.1); 2: more. 0.5 made the 8-axis slab's weighted
#: marginals deviate from uniform more than their ESS allows (16 runs: Kolmogorov p 0.03 on
#: the tied axes, 0.2 at 0.75). A factor from the centres' spacing (12 n^(-2/t), t tied
#: axes) was tried: 2,145 on parachute15, 10,536 against 6,224 on the quiet twin.
SCALE = 0.75
#: D found: axes along which the accepted members spread at least this share of the box's
#: spread, unpredicted by the others, are drawn uniformly
#: (:func:`~vectorid.sequential.kernel.free_axes`).
FREE_FROM = 0.8
#: With moves (:data:`~vectorid.sequential.moves.MOVE_FROM` or more variables): particles
#: per ``population``.
PARTICLES_FACTOR = 2
#: With moves: share of the particles that meet the next generation's limits.
MOVE_KEEP = 0.7
#: Most evaluations of the local search made when the budget is spent before D is reached ...
SEARCH_EVALUATIONS = 4000
#: ... and no more than the sampler's budget, but at least this many.
SEARCH_FLOOR = 500
#: A start of the local search ends when its step (share of each variable's width) falls below
#: this; the next start is the best trial farther than :data:`SEARCH_SEPARATION` (max over the
#: variables, share of the width) from every earlier start and end.
SEARCH_MIN_STEP = 1e-4
SEARCH_SEPARATION = 0.05
#: A search's best vector within this share of a variable's width from the box's side is
#: "against the edge": the search was held there (on the ETH flights it stopped 0.06 % of
#: the width from a side, its steps toward it no better).
EDGE_SHARE = 0.01


@dataclass
class LocalSearch:
    """A local search from the best trials (run when D was not reached).

    Attributes
    ----------
    start : int
        Trial id it started from.
    start_factor, factor : float
        ``max_l Φ_l / Φ**_l`` (how far the limits must be relaxed; ``<= 1`` meets them) at
        the start and at the best vector found.
    x : (p,) float array
        The best vector found.
    evaluations : int
        Model evaluations it made (stored in an auxiliary stage).
    stage : int
        The auxiliary stage (kind ``"search"``) holding them.
    edges : list of (str, str, float)
        Variables of ``x`` against the box's edge (within :data:`EDGE_SHARE` of its width):
        ``(name, "low" or "high", the edge's value)``. A search that ends pressed against the
        box says the box may be too narrow, not that the model misses.
    starts : int
        Trials it started from (the best first, then the best not near an earlier start).
    """

    start: int
    start_factor: float
    factor: float
    x: np.ndarray
    evaluations: int
    stage: int
    edges: list[tuple[str, str, float]] = field(default_factory=list)
    starts: int = 1

    @property
    def met(self) -> bool:
        return self.factor <= 1.0


@dataclass
class SequentialSummary(RunSummary):
    """What a sequential run did and where it stands (see :class:`RunSummary`).

    Attributes
    ----------
    budget, population : int
        The run's budget (evaluations) and the members of D wanted.
    generations : int
        Generations stored.
    evaluations : int
        Model evaluations stored (every generation; the local search not included).
    members : int
        Members of D at the stated limits.
    ess : float
        Kish effective sample size of D's importance weights.
    converged : bool
        D holds ``population`` members with an ESS of at least ``ESS_SHARE x population``.
    relaxed : float or None
        Factor on the stated limits that the last generation's limits amount to (1.0 when
        they are the stated ones; None when no limit is positive).
    tolerance : dict
        The last generation's limit per constrained criterion.
    search : LocalSearch or None
        The local search made when D was not reached.
    names : list of str
        Variable names (to show the search's vector).
    moves : bool
        The run moved particles (many variables): ``ess`` is the chains' ESS from their
        autocorrelation at the stated limits; D's members weigh their holding times.
    """

    budget: int = 0
    population: int = 0
    generations: int = 0
    evaluations: int = 0
    members: int = 0
    ess: float = 0.0
    converged: bool = False
    relaxed: float | None = None
    tolerance: dict[str, float] = field(default_factory=dict)
    search: LocalSearch | None = None
    names: list[str] = field(default_factory=list)
    moves: bool = False

    @property
    def collapsed(self) -> bool:
        """D holds members but their ESS is far below the population wanted."""
        return not self.moves and self.members > 0 and self.ess < COLLAPSE_SHARE * self.population

    def verdict(self) -> str:
        """One plain sentence: converged, collapsed, or how far it got."""
        head = (
            f"{self.evaluations} evaluations, {self.generations} generations, "
            f"{self.members} members of D at the stated limits, ESS {self.ess:.0f}"
        )
        if self.converged and self.moves:
            return (
                f"D reached: {head} (target {self.population} members; ESS from the "
                "autocorrelation of the particles' chains over their last moves at the stated "
                "limits, each chain sampling D uniformly; densities of D weigh each member by "
                "the number of those moves it held a particle, members never so held weigh 0)"
            )
        if self.converged:
            return (
                f"D reached: {head} (target {self.population} members, ESS >= "
                f"{ESS_SHARE * self.population:.0f}); histograms and densities of D use the "
                "importance weights"
            )
        if self.members >= self.population or (self.members and self.collapsed):
            state = (
                "not yet moved enough at the stated limits to be a faithful sample"
                if self.moves
                else "collapsed"
                if self.collapsed
                else "not yet a faithful sample"
            )
            need = (
                f"at least {MIN_FINAL_MOVES} moves there and an ESS of "
                f"{ESS_SHARE * self.population:.0f} are needed; ESS so far {self.ess:.0f}"
                if self.moves
                else f"ESS {self.ess:.0f} against {ESS_SHARE * self.population:.0f} wanted"
            )
            return (
                f"D not reached after {self.evaluations} evaluations: {head}; the population "
                f"is {state} ({need}), so it is not presented as D: raise --budget to go on"
            )
        factor = (
            f"; the nearest generation meets the limits relaxed ×{self.relaxed:.3g}"
            if self.relaxed is not None
            else ""
        )
        text = f"D not reached after {self.evaluations} evaluations ({head}){factor}"
        s = self.search
        if s is None:
            return text + "; raise --budget to go on"
        best = ", ".join(f"{n}={v:.6g}" for n, v in zip(self.names, s.x))
        if s.met:
            return (
                f"{text}; a local search from the best {_starts(s)} found a vector that "
                f"meets every limit (×{s.factor:.3g}, {s.evaluations} evaluations, stage "
                f"{s.stage}): D is not empty, the sampler did not reach it within the budget — "
                f"raise --budget. Vector: {best}"
            )
        missed = (
            f"{text}; a local search from the best {_starts(s)} also misses: its best "
            f"vector meets the limits only relaxed ×{s.factor:.3g} ({s.evaluations} "
            f"evaluations, stage {s.stage})"
        )
        if s.edges:
            value = dict(zip(self.names, s.x))
            at = ", ".join(
                f"{n}={value.get(n, v):.6g} against its {side} edge {v:.6g}"
                for n, side, v in s.edges
            )
            return (
                f"{missed}, pressed against the box ({at}): the box may be too narrow there — "
                f"widen it where the physics allows and run again; nothing yet says the model "
                f"misses. Best vector: {best}"
            )
        return (
            f"{missed}, inside the box, so the model or the limits may not fit the data (or D "
            f"is smaller than both searches found). Best vector: {best}"
        )

    def describe(self) -> str:
        head, *rest = RunSummary.describe(self).split("\n")
        head = head.replace(
            f"the study holds {self.total_stored} of {self.target}",
            f"the study holds {self.total_stored} (budget {self.budget})",
        )
        lines = [head, *rest, self.verdict()]
        if self.tolerance:
            shown = ", ".join(f"{k} {v:.4g}" for k, v in self.tolerance.items())
            lines.append(f"last generation's limits: {shown}")
        return "\n".join(lines)


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
        (:func:`~vectorid.sequential.moves.chain_ess`, min over the variables, over the moves
        kept after the warm-up at the stated limits; 0 before four are kept).
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


def _unit(space, X: np.ndarray) -> np.ndarray:
    return (np.asarray(X, dtype=float) - space.lows) / (space.highs - space.lows)


def proposals_of(gens: Sequence[Generation], p: int) -> list[Proposal]:
    """The stored generations' proposal densities."""
    return [Proposal.stored(g.proposal, g.centres, g.log_mix, g.chol) for g in gens]


def _generation_of(gens: Sequence[Generation], trials: Trials) -> np.ndarray:
    out = np.full(len(trials), -1, dtype=np.int64)
    for g in gens:
        m = (trials.stage == 0) & (trials.seq >= g.seq_start) & (trials.seq < g.seq_start + g.n)
        out[m] = g.gen
    return out


def _bounds(spec, limits=None):
    from ..analysis.results import Analysis

    return Analysis(spec, _empty_trials(spec), limits)


def _empty_trials(spec) -> Trials:
    p, k, q = len(spec.space), len(spec.criteria), len(spec.constraints)
    e = np.empty(0, dtype=np.int64)
    return Trials(e, e, e, np.empty(0, np.int8), np.empty((0, p)), np.empty((0, k)),
                  np.empty((0, q)), np.empty(0))  # fmt: skip


def constrained_limits(spec, limits=None) -> tuple[list[int], np.ndarray]:
    """Indices of the criteria with a finite limit and their oriented limits."""
    a = _bounds(spec, limits)
    idx, floor = [], []
    for j, c in enumerate(spec.criteria):
        lo, hi = a.bounds[c.name]
        bound = hi if c.sense == "min" else -lo
        if math.isfinite(bound):
            idx.append(j)
            floor.append(bound)
    return idx, np.array(floor, dtype=float)


def assess(
    store: Store, trials: Trials | None = None, limits=None, *, weights: bool = True
) -> SequentialState:
    """D at the stated limits (or at ``limits``), its importance weights and ESS.

    Parameters
    ----------
    store : Store
        A sequential store.
    trials : Trials, optional
        Stage-0 trials (loaded when not given).
    limits : optional
        Bounds overriding the study's (as for :class:`~vectorid.analysis.Analysis`): D is
        taken at these, e.g. a limit loosened after the run.
    weights : bool
        Compute the members' importance weights (the moves' driver needs none; with many
        generations they cost most of the time).
    """
    from ..analysis.results import Analysis

    spec = store.spec
    if trials is None:
        trials = store.load(stages=[0])
    gens = store.generations()
    p = len(spec.space)
    proposals = proposals_of(gens, p)
    generation = _generation_of(gens, trials)
    counts = [int(np.sum(generation == g.gen)) for g in gens]
    a = Analysis(spec, trials, limits)
    constrained, floor = constrained_limits(spec, limits)
    senses = [spec.criteria[j].sense for j in constrained]
    phi = oriented(trials.F[:, constrained], senses)
    usable = a.functional_ok & (generation >= 0)
    members = a.feasible & (generation >= 0)
    stated = limits is None or _bounds(spec, limits).bounds == _bounds(spec).bounds
    moved = bool(gens) and gens[-1].proposal.get("move") is not None and stated
    weights = weights and not moved
    log_w = np.full(len(trials), np.nan)
    if members.any() and weights:
        log_w[members] = _cached_log_weights(store, spec, trials, generation, proposals,
                                             counts, members)  # fmt: skip
    ess = kish_ess(log_w[members]) if weights else 0.0
    state = SequentialState(
        proposals, counts, generation, constrained, phi, floor, usable, members, log_w, ess
    )
    if moved:  # D's sample: the chains' states over the kept moves at the stated limits
        state.particles, _, _ = _moved_particles(spec, state, trials, gens[-1])
        state.chains = final_chains(spec, state, trials, gens)
        kept = state.chains[len(state.chains) - kept_moves(len(state.chains)) :]
        counts = np.bincount(kept.ravel(), minlength=len(trials)) if kept.size else None
        with np.errstate(divide="ignore"):
            log_w[members] = -np.inf if counts is None else np.log(counts[members])
        state.ess = _chain_ess(spec, trials, kept)
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
        P, _, eps = _moved_particles(spec, state, trials, gen)
        if not np.all(eps <= state.floor):
            break
        hist.append(P)
    if not hist:
        return np.empty((0, 0), dtype=np.int64)
    return np.array(hist[::-1], dtype=np.int64)


def _chain_ess(spec, trials: Trials, kept: np.ndarray) -> float:
    """The chains' ESS over the kept moves (min over the variables; 0 for fewer than four
    moves): :func:`~vectorid.sequential.moves.chain_ess` in unit coordinates."""
    if kept.ndim != 2 or kept.shape[0] < 4:
        return 0.0
    return float(np.min(chains_ess(_unit(spec.space, trials.X[kept]))))


def holding_log_weights(spec, trials: Trials, gens) -> np.ndarray | None:
    """Log weights of a moved store's trials as D's sample (None when the chains have not
    made four kept moves at the stated limits): each member of D weighs the number of kept
    moves (after :data:`~vectorid.sequential.moves.WARMUP`) at the stated limits for which it
    was a particle's state — its holding time, summed over the chains. Members never so weigh
    0 (``-inf``); trials outside D at the stated limits have no weight (NaN)."""
    state = assess(_StoreView(spec, gens), trials, weights=False)
    if state.chains is None or kept_moves(state.chains.shape[0]) < 4:
        return None
    out = np.full(len(trials), np.nan)
    out[state.members] = state.log_w[state.members]
    return out


class _StoreView:
    """What :func:`assess` reads of a store: its spec and generations."""

    def __init__(self, spec, gens) -> None:
        self.spec = spec
        self._gens = gens

    def generations(self):
        return self._gens


#: Log proposal densities of stored trials, one block per (proposal, generation of trials);
#: kept for the last store only. Trials and proposals never change once stored, so a block
#: is computed once instead of once per generation (the weights are recomputed every
#: generation over every earlier proposal).
_DENSITY_BLOCKS: dict[str, Any] = {"store": None, "blocks": {}}


def _cached_log_weights(
    store: Store,
    spec,
    trials: Trials,
    generation: np.ndarray,
    proposals: Sequence[Proposal],
    counts: Sequence[int],
    mask: np.ndarray,
) -> np.ndarray:
    """:func:`~vectorid.sequential.weights.log_weights` of ``trials[mask]``, each proposal's
    density evaluated once per block of one generation's trials.

    A block always holds the same rows (all stored trials of that generation), so an
    interrupted and resumed run computes the same numbers, bit for bit, as an uninterrupted
    one.
    """
    ident = (str(store.path), store.meta().get("created"))
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
                dens = prop.logpdf(_unit(spec.space, trials.X[block_rows]))
                blocks[key] = dens
            sel = gen_rows == h
            col[sel] = dens[where[sel]]
        terms.append(col + math.log(n / total))
    return -logsumexp(np.vstack(terms), axis=0)


def trial_log_weights(store: Store, trials: Trials, mask: np.ndarray) -> np.ndarray:
    """Log importance weights of ``trials[mask]`` of a sequential store (they make any
    subset selected by limits a weighted sample of the box's uniform density)."""
    spec = store.spec
    gens = store.generations()
    generation = _generation_of(gens, trials)
    counts = [int(np.sum(generation == g.gen)) for g in gens]
    return log_weights(
        _unit(spec.space, trials.X[mask]), proposals_of(gens, len(spec.space)), counts
    )


def _tolerance_json(spec, constrained, eps) -> dict[str, float | None]:
    out: dict[str, float | None] = {}
    for j, e in zip(constrained, eps):
        c = spec.criteria[j]
        v = float(e if c.sense == "min" else -e)
        out[c.name] = v if math.isfinite(v) else None
    return out


def _tolerance_of(gen: Generation, spec, constrained) -> np.ndarray:
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


def _relaxed(eps: np.ndarray, floor: np.ndarray) -> float | None:
    pos = floor > 0
    if not pos.any() or not np.all(np.isfinite(eps[pos])):
        return None
    return float(np.max(eps[pos] / floor[pos]))


def _score(phi: np.ndarray, floor: np.ndarray) -> np.ndarray:
    """``max_l Φ_l / Φ**_l`` for positive limits (``1 + Φ_l - Φ**_l`` otherwise): <= 1 meets
    every limit."""
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.where(floor > 0, phi / np.where(floor > 0, floor, 1.0), 1.0 + phi - floor)
    s = np.max(ratio, axis=1) if ratio.shape[1] else np.zeros(len(phi))
    return np.where(np.isfinite(s), s, np.inf)


def _propose(store: Store, spec, state: SequentialState, gens, n: int, trials: Trials,
             population: int):  # fmt: skip
    """Generation ``len(gens)``'s points and record (a function of the seed, the generation
    number, the limits and the stored trials of earlier generations only)."""
    g = len(gens)
    rng = np.random.default_rng([int(spec.seed), g, 0x5E0])
    eps_prev = _tolerance_of(gens[-1], spec, state.constrained)
    phi = state.phi
    with np.errstate(invalid="ignore"):
        in_prev = state.usable & np.all(phi <= eps_prev, axis=1)
    searching = _searching(state)
    least = max((0 if searching else MIN_KEEP_SHARE) * population, 2 * (len(spec.space) + 1))
    keep = min(1.0, max(SEARCH_KEEP if searching else KEEP, least / max(int(in_prev.sum()), 1)))
    eps = next_tolerance(phi[in_prev], eps_prev, state.floor, keep)
    with np.errstate(invalid="ignore"):
        centres = state.usable & np.all(phi <= eps, axis=1)
    if np.all(eps <= state.floor):
        n = _final_size(state, gens, n, population)
    scale = SEARCH_SCALE if searching else SCALE
    U = _unit(spec.space, trials.X[centres])
    log_w = _cached_log_weights(store, spec, trials, state.generation, state.proposals,
                                state.counts, centres)  # fmt: skip
    kernel = fit_proposal(U, log_w, rng, scale=scale,
                          free_from=None if searching else FREE_FROM)  # fmt: skip
    try:
        Unew, kernel = kernel.sample(n, rng)
    except RuntimeError:
        return None
    X = spec.space.scale(Unew)
    record = {
        "kind": "mixture",
        "tolerance": _tolerance_json(spec, state.constrained, eps),
        "log_mass": kernel.log_mass,
        "draws": kernel.draws,
        "centres_from": int(centres.sum()),
        "keep": keep,
        "scale": scale,
        "search": searching,
        "free": [int(j) for j in kernel.free],
    }
    return X, record, kernel


def _rows_of(trials: Trials, seqs) -> np.ndarray:
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


def _moved_particles(spec, state: SequentialState, trials: Trials, gen: Generation):
    """The particles after generation ``gen``'s moves: each draw that meets the generation's
    limits replaces its particle. Returns (rows, share of moves accepted, limits)."""
    mv = gen.proposal["move"]
    P = _rows_of(trials, mv["particles"])
    eps = _tolerance_of(gen, spec, state.constrained)
    parents = np.asarray(mv["parents"], dtype=np.int64)[: gen.n]
    draws = _rows_of(trials, gen.seq_start + np.arange(len(parents)))
    ok = draws >= 0
    with np.errstate(invalid="ignore"):
        ok[ok] = state.usable[draws[ok]] & np.all(state.phi[draws[ok]] <= eps, axis=1)
    P = P.copy()
    P[parents[ok]] = draws[ok]
    return P, float(ok.sum()) / max(len(P), 1), eps


def _move_status(spec, state: SequentialState, trials: Trials, gen: Generation, population: int):
    """(converged, ESS) after a generation of moves: converged when the limits are the stated
    ones, the chains have made at least :data:`~vectorid.sequential.moves.MIN_FINAL_MOVES`
    moves there and their ESS (from the autocorrelation of the kept moves) reaches
    ``population``."""
    _, _, eps = _moved_particles(spec, state, trials, gen)
    at_floor = bool(np.all(eps <= state.floor))
    m = 0 if state.chains is None else int(state.chains.shape[0])
    done = at_floor and m >= MIN_FINAL_MOVES and state.ess >= ESS_SHARE * population
    return done, state.ess


def _propose_move(store: Store, spec, state: SequentialState, gens, n: int, trials: Trials,
                  left: int):  # fmt: skip
    """Generation ``len(gens)`` with moves (:mod:`vectorid.sequential.moves`): ``n``
    particles, each moved once; at most ``left`` draws evaluated. A function of the seed, the
    generation number, the limits and the stored trials of earlier generations only."""
    g = len(gens)
    rng = np.random.default_rng([int(spec.seed), g, 0x5E1])
    p = len(spec.space)
    last = gens[-1]
    mv = last.proposal.get("move")
    if mv is None:  # the first moves start from the Sobol table (generation 0)
        eps_prev = _tolerance_of(last, spec, state.constrained)
        P = np.flatnonzero(state.usable & (state.generation == 0))
        scale, level_moves, tighten = initial_scale(p), 0, True
    else:
        P, accepted, eps_prev = _moved_particles(spec, state, trials, last)
        scale = adapt_scale(float(mv["scale"]), accepted)
        level_moves = int(mv["level_moves"])
        tighten = len(np.unique(P)) >= DIVERSE * len(P)
    if not len(P):
        return None
    eps = eps_prev
    if tighten and not np.all(eps_prev <= state.floor):
        eps = next_tolerance(state.phi[P], eps_prev, state.floor, MOVE_KEEP)
        with np.errstate(invalid="ignore"):
            alive = np.unique(P[np.all(state.phi[P] <= eps, axis=1)])
        P = copy_evenly(alive, n, rng)
        level_moves = 0
    elif len(P) != n:
        P = copy_evenly(np.unique(P), n, rng)
    level_moves += 1
    U = _unit(spec.space, trials.X[P])
    cov = particle_cov(U)
    for _ in range(12):
        L = _cholesky(cov * scale)
        draws, parents = move_draws(U, L, rng)
        if len(draws):
            break
        scale *= 0.5
    else:
        return None
    draws, parents = draws[:left], parents[:left]
    rows, copies = np.unique(P, return_counts=True)
    mass = in_box_mass(U, L, rng, MASS_DRAWS)
    kernel = Proposal("mixture", _unit(spec.space, trials.X[rows]),
                      np.log(copies / copies.sum()), L, math.log(mass), MASS_DRAWS)  # fmt: skip
    record = {
        "kind": "mixture",
        "tolerance": _tolerance_json(spec, state.constrained, eps),
        "log_mass": kernel.log_mass,
        "draws": kernel.draws,
        "centres_from": len(rows),
        "keep": KEEP,
        "scale": scale,
        "move": {
            "particles": [int(v) for v in trials.seq[P]],
            "parents": [int(v) for v in parents],
            "scale": scale,
            "level_moves": level_moves,
        },
    }
    return spec.space.scale(draws), record, kernel


def run_sequential(
    store: Store,
    *,
    budget: int | None = None,
    population: int | None = None,
    executor: str | None = None,
    workers: int | None = None,
    batch_size: int | None = None,
    progress: bool | TextIO = True,
    keep_going: bool = False,
    ranges: Sequence[tuple[int, int, int]] | None = None,
    timeout: float | None = None,
    search: bool = True,
) -> SequentialSummary:
    """Run (or resume) a sequential study held by a writable store.

    Parameters
    ----------
    store : Store
        Opened with ``write=True``; its study has ``sampler = "sequential"``.
    budget : int, optional
        Most model evaluations (default: the study's ``budget``, else ``trials``); a new
        value is saved in the study.
    population : int, optional
        Members of D wanted (default: the study's, else 200); a new value is saved.
    executor, workers, batch_size, timeout, keep_going
        As for :func:`vectorid.run.run_store`.
    progress : bool or file
        Print one line per generation (on stderr, or on the given file).
    ranges : sequence of (stage, start, end), optional
        Only evaluate the missing trials of these stored ranges (a repair): every generation's
        points are stored, so they are evaluated again exactly.
    search : bool
        Run the local search when the budget is spent before D is reached.

    Returns
    -------
    SequentialSummary
    """
    spec = store.spec
    if budget is not None or population is not None:
        store.set_sequential(budget=budget, population=population)
        spec = store.spec
    budget = spec.sequential_budget
    population = spec.sequential_population
    constrained, floor = constrained_limits(spec)
    if not constrained:
        raise StudyDefinitionError(
            "study.sampler",
            "sampler 'sequential' moves trials toward the criteria constraints Φ**, and this "
            "study states none",
            'give at least one [[criteria]] a limit (or use sampler = "sobol")',
        )
    extra = [s for s in store.stages() if s.kind == "sample" and s.stage != 0]
    if extra:
        raise StudyDefinitionError(
            "study.sampler",
            f"a sequential study samples its one box; this store holds {len(extra) + 1} "
            "sample stages (a refined box?)",
            'run the refined box as a new study, or use sampler = "sobol"',
        )
    out = progress if not isinstance(progress, bool) else sys.stderr
    say = (lambda text: print(text, file=out, flush=True)) if progress else (lambda text: None)
    stored_before = store.count_sample()
    summary = SequentialSummary(
        target=budget, total_stored=stored_before, budget=budget, population=population,
        names=list(spec.space.names),
    )  # fmt: skip
    executor_name = executor or spec.executor or "processes"
    pool = make_executor(
        executor_name, spec, workers if workers is not None else spec.workers, timeout=timeout
    )
    run_id = store.begin_run(executor_name, pool.workers, budget)
    t0 = time.perf_counter()
    outcome = "completed"
    held_state = {"held": [] if not keep_going and stored_before == 0 else None, "seen": 0}

    def size_for(n: int) -> int:
        if batch_size or spec.batch_size:
            return int(batch_size or spec.batch_size)
        return int(min(1024, max(16, math.ceil(n / (2 * pool.workers)))))

    def evaluate(gen: Generation, only: Sequence[tuple[int, int]] | None = None) -> None:
        spans = only if only is not None else [(gen.seq_start, gen.seq_start + gen.n)]
        todo = [m for a, b in spans for m in store.missing(0, a, b)]
        if not todo:
            return
        bs = size_for(sum(b - a for a, b in todo))

        def batches() -> Iterator[tuple[int, np.ndarray]]:
            for a, b in todo:
                for s in range(a, b, bs):
                    e = min(b, s + bs)
                    yield s, gen.X[s - gen.seq_start : e - gen.seq_start]

        for start, res in pool.map_unordered(batches()):
            X = gen.X[start - gen.seq_start : start - gen.seq_start + res.n]
            held = held_state["held"]
            if held is not None:
                held.append((0, start, X, res))
                held_state["seen"] += res.n
                if not np.all(res.status == FAILED):
                    release()
                elif held_state["seen"] >= min(FIRST_LOOK, gen.n):
                    _stop_loudly(spec, held, held_state["seen"])
                continue
            put(start, X, res)
        release()

    def put(start: int, X: np.ndarray, res: EvalResult) -> None:
        wrote = store.write_batch(
            0, start, X, res.criteria, res.functionals, res.status, res.wall, res.messages
        )
        if wrote == 0:
            summary.duplicates += res.n
            return
        summary.stored += wrote
        summary.add_failures(start + 1, res)

    def release() -> None:
        held = held_state["held"]
        if held is None:
            return
        held_state["held"] = None
        for _, start, X, res in held:
            put(start, X, res)

    try:
        with pool:
            pool.start()
            gens = store.generations()
            if ranges is not None:  # a repair: the stored generations' missing trials only
                for gen in gens:
                    spans = [
                        (max(a, gen.seq_start), min(b, gen.seq_start + gen.n))
                        for st, a, b in ranges
                        if st == 0 and a < gen.seq_start + gen.n and b > gen.seq_start
                    ]
                    if spans:
                        evaluate(gen, spans)
            else:
                state = _drive(store, spec, gens, budget, population, evaluate, say, summary)
                if search and state is not None and not summary.converged and summary.members == 0:
                    summary.search = _local_search(store, spec, state, pool, say, budget)
    except KeyboardInterrupt:
        outcome = "interrupted"
        raise RunInterrupted(summary) from None
    except BaseException as exc:
        outcome = f"stopped: {str(exc)[:200]}"
        raise
    finally:
        summary.elapsed = time.perf_counter() - t0
        summary.total_stored = store.count_sample()
        store.end_run(run_id, outcome)
    return summary


def _drive(store, spec, gens, budget, population, evaluate, say, summary):
    """The generations loop; returns the last state (None when nothing succeeded)."""
    p = len(spec.space)
    moves = p >= MOVE_FROM
    summary.moves = moves
    while True:
        if not gens:
            n0 = min(spec.trials, budget)
            X = spec.space.scale(spec.sampler_for().points(0, n0))
            record = {"kind": "sobol", "tolerance": {}, "log_mass": 0.0, "draws": n0}
            store.add_generation(0, 0, X, record, np.empty((0, p)), np.empty(0), np.eye(p))
            gens = store.generations()
        for gen in gens:  # a resumed run first completes the generation it was in
            evaluate(gen)
        trials = store.load(stages=[0])
        state = assess(store, trials, weights=not moves)
        moved = gens[-1].proposal.get("move") is not None
        if moved:
            done, state.ess = _move_status(spec, state, trials, gens[-1], population)
        elif moves:  # the Sobol table alone: its members weigh the same
            state.ess = float(state.members.sum())
        evaluations = int(np.sum(state.generation >= 0))
        members = int(state.members.sum())
        eps = _tolerance_of(gens[-1], spec, state.constrained)
        summary.generations = len(gens)
        summary.evaluations = evaluations
        summary.members = members
        summary.ess = float(state.ess)
        summary.tolerance = {
            k: v for k, v in _tolerance_json(spec, state.constrained, eps).items() if v is not None
        }
        with np.errstate(invalid="ignore"):
            at_tol = int(np.sum(state.usable & np.all(state.phi <= eps, axis=1)))
        rel = _relaxed(eps, state.floor)
        summary.relaxed = rel if len(gens) > 1 else _relaxed_of_best(state, population)
        say(
            f"generation {len(gens) - 1}: {gens[-1].n} trials, {evaluations} evaluations; "
            + (f"limits ×{rel:.3g} of Φ**, " if rel is not None else "")
            + f"{at_tol} trials within them; D: {members} members, ESS {state.ess:.0f}"
        )
        if moved:
            summary.converged = done and members >= population
        else:
            summary.converged = members >= population and state.ess >= ESS_SHARE * population
        if summary.converged or evaluations >= budget:
            return state if state.usable.any() else None
        if not state.usable.any():
            say("no trial succeeded and met the functional constraints: nothing to move toward")
            return None
        if moves:
            made = _propose_move(store, spec, state, gens, PARTICLES_FACTOR * population,
                                 trials, budget - evaluations)  # fmt: skip
        else:
            gf = SEARCH_GENERATION_FACTOR if _searching(state) else GENERATION_FACTOR
            n = min(int(gf * population), budget - evaluations)
            made = _propose(store, spec, state, gens, n, trials, population)
        if made is None:
            say("the proposal puts almost no mass inside the box: stopped")
            return state
        X, record, kernel = made
        start = gens[-1].seq_start + gens[-1].n
        store.add_generation(
            len(gens), start, X, record, kernel.centres, kernel.log_mix, kernel.chol
        )
        gens = store.generations()


def _searching(state: SequentialState) -> bool:
    """True while D at the stated limits holds fewer than :data:`FOUND` members: the next
    generation follows the careful schedule (``SEARCH_*``)."""
    return int(state.members.sum()) < FOUND


def _final_size(state: SequentialState, gens, full: int, population: int) -> int:
    """Trials of a generation that aims at the stated limits: as many as the ESS still wanted
    needs at the rate of the last generation (members of D it added per trial x D's ESS per
    member; a generation aiming at the stated limits does at least as well as one aiming
    wider), with :data:`SIZE_MARGIN` to spare; ``full`` when the last generation added none."""
    if len(gens) < 2:
        return full
    last = gens[-1].gen
    added = int(np.sum(state.members & (state.generation == last)))
    members = int(state.members.sum())
    if not added or not members:
        return full
    rate = added / max(state.counts[last], 1) * state.ess / members
    need = (population * ESS_SHARE - state.ess) / max(rate, 1e-12) * SIZE_MARGIN
    return int(min(full, max(MIN_GENERATION * population, math.ceil(need))))


def _relaxed_of_best(state: SequentialState, population: int) -> float | None:
    """Generation 0 only: the factor on the limits that ``population`` trials meet."""
    s = _score(state.phi[state.usable], state.floor)
    if not len(s) or not np.all(state.floor > 0):
        return None
    s = np.sort(s)
    return float(max(1.0, s[min(population, len(s)) - 1]))


def _local_search(store, spec, state: SequentialState, pool, say,
                  budget: int) -> LocalSearch | None:  # fmt: skip
    """Pattern search in unit coordinates from the best trials, 2p points per batch.

    Each poll tries the 2p coordinate steps; where none improves, it tries once more along a
    random orthonormal basis (the criteria's max-ratio score has kinks, at which no coordinate
    step may improve although a slanted one does) before halving the step. A start ends when
    its step falls below :data:`SEARCH_MIN_STEP`; the next starts from the best trial not yet
    near a start or an end (:data:`SEARCH_SEPARATION`), until a vector meets every limit or
    :data:`SEARCH_EVALUATIONS` are spent, but no more than the sampler's ``budget`` (at least
    :data:`SEARCH_FLOOR`). Seeded by the study's seed: a function of the stored
    trials only.
    """
    trials = store.load(stages=[0])
    score = np.where(state.usable, _score(state.phi, state.floor), np.inf)
    if not np.isfinite(score).any():
        return None
    order = [int(i) for i in np.argsort(score, kind="stable") if np.isfinite(score[i])]
    U0 = _unit(spec.space, trials.X)
    p = U0.shape[1]
    rng = np.random.default_rng([int(spec.seed), 0x5EA])
    first = order[0]
    start_id = int(trials.id[first])
    stage = store.add_stage(spec.space, kind="search", note=f"local search from trial {start_id}")
    senses = [spec.criteria[j].sense for j in state.constrained]
    seq = used = starts = 0
    best_u, best_s = U0[first], float(score[first])
    visited: list[np.ndarray] = []

    def poll(u: np.ndarray, E: np.ndarray) -> tuple[np.ndarray, float]:
        nonlocal seq, used
        Ub = np.clip(u + E, 0.0, 1.0)
        X = spec.space.scale(Ub)
        res = None
        for _, r in pool.map_unordered([(seq, X)]):
            res = r
        store.write_batch(
            stage.stage, seq, X, res.criteria, res.functionals, res.status, res.wall, res.messages
        )
        seq += len(X)
        used += len(X)
        ok = res.status == OK
        for c in spec.constraints:
            j = spec.constraint_names.index(c.name)
            col = res.functionals[:, j]
            with np.errstate(invalid="ignore"):
                ok &= (col >= (-np.inf if c.low is None else c.low)) & (
                    col <= (np.inf if c.high is None else c.high)
                )
        sc = np.where(ok, _score(oriented(res.criteria[:, state.constrained], senses),
                                 state.floor), np.inf)  # fmt: skip
        i = int(np.argmin(sc))
        return Ub[i], float(sc[i])

    cap = min(SEARCH_EVALUATIONS, max(int(budget), SEARCH_FLOOR))
    say(f"local search from trial {start_id} (limits ×{best_s:.3g})")
    for i in order:
        if used >= cap or best_s <= 1.0:
            break
        if any(np.max(np.abs(U0[i] - v)) < SEARCH_SEPARATION for v in visited):
            continue
        u, s = U0[i], float(score[i])
        visited.append(u)
        starts += 1
        step = 0.05
        while used < cap and step > SEARCH_MIN_STEP and s > 1.0:
            eye = np.eye(p)
            un, sn = poll(u, np.vstack([eye, -eye]) * step)
            if sn >= s and used < cap:
                Q, _ = np.linalg.qr(rng.standard_normal((p, p)))
                un, sn = poll(u, np.vstack([Q.T, -Q.T]) * step)
            if sn < s:
                u, s = un, sn
            else:
                step *= 0.5
        visited.append(u)
        if s < best_s:
            best_u, best_s = u, s
    say(f"local search: {used} evaluations from {starts} start(s), best limits ×{best_s:.3g}")
    edges = search_edges(spec, best_u)
    return LocalSearch(start_id, float(score[first]), best_s, spec.space.scale(best_u[None])[0],
                       used, stage.stage, edges, starts)  # fmt: skip


def _starts(s: LocalSearch) -> str:
    """"trial (id)" or "trials (id and k more)" for the search's message."""
    return f"trial ({s.start})" if s.starts <= 1 else f"trials ({s.start} and {s.starts - 1} more)"


def search_edges(
    spec, u: np.ndarray, tol: float = EDGE_SHARE
) -> list[tuple[str, str, float]]:
    """Variables of the unit-coordinate vector ``u`` against the box's edge (within ``tol`` of
    the width from a side): ``(name, "low" or "high", the edge in the study's unit)``."""
    out = []
    for j, var in enumerate(spec.space):
        if u[j] <= tol:
            out.append((var.name, "low", float(var.low)))
        elif u[j] >= 1.0 - tol:
            out.append((var.name, "high", float(var.high)))
    return out


def sample_note(store: Store, analysis) -> str | None:
    """One line for analyses of a sequential store: D's members and ESS under the limits in
    force, and whether the population is collapsed (then its ranges are not D's); None for a
    plain store."""
    if store.spec.sampler != "sequential" or not store.generations():
        return None
    limits = {b.name: b.value for b in analysis.active_bounds() if b.name in analysis.crit_names}
    state = assess(store, analysis.trials, limits or None)
    m = int(state.members.sum())
    wanted = store.spec.sequential_population
    head = (
        f"sequential sampler: {sum(state.counts)} evaluations in {len(state.counts)} "
        f"generations; D holds {m} members, ESS {state.ess:.0f} "
        + (_chains_note(state) if state.particles is not None else "(importance weights)")
    )
    if m and state.ess < COLLAPSE_SHARE * wanted and state.particles is None:
        return (
            f"{head}: the population has COLLAPSED (ESS far below the {wanted} wanted), so "
            "these trials are not a sample of D; run with a larger --budget"
        )
    if m < wanted or state.ess < ESS_SHARE * wanted:
        return f"{head}: not yet the {wanted} wanted (ranges are those of the trials so far)"
    return head


def _chains_note(state: SequentialState) -> str:
    """How a moved population's ESS and weights were made (for the sampler line)."""
    m = 0 if state.chains is None else int(state.chains.shape[0])
    k = kept_moves(m)
    if k < 4:
        return (
            f"(particles' chains; {m} moves at the stated limits, too few to weigh D's "
            "members: densities count every member once)"
        )
    held = np.isfinite(state.log_w) & state.members
    return (
        f"(from the autocorrelation of the particles' chains over their last {k} of {m} moves "
        f"at the stated limits; densities weigh each member by the moves it held a particle: "
        f"{int(state.members.sum() - held.sum())} members never held one weigh 0)"
    )


def describe_state(state: SequentialState) -> dict[str, Any]:
    """Counts for reports: generations, evaluations, members, ESS."""
    return {
        "generations": len(state.counts),
        "evaluations": int(sum(state.counts)),
        "members": int(state.members.sum()),
        "ess": float(state.ess),
    }
