"""The sequential PSI sampler: generations of trials that move into the feasible set D.

A study asks for it with ``[study] sampler = "sequential"``, ``budget`` (model evaluations
at most) and ``population`` (members of D wanted, default 200). Each generation is a round of
the run driver (:mod:`vectorid.run`), evaluated as batches through the study's executor
(in-process, processes or Dask) and stored like any trial.

1. Generation 0 is the plain Sobol table of the study's ``trials`` first points (so a
   sequential store starts exactly like a plain one); a study that does not state ``trials``
   gets :func:`vectorid.spec.first_generation_size` of its population (256 for 200).
2. After each generation the sampler computes D at the stated limits: its members, their
   importance weights (:mod:`.weights`) and Kish's effective sample size (ESS). It stops when
   D holds at least ``population`` members with an ESS of at least ``population``
   (:data:`~.schedule.ESS_SHARE`), or when the budget is spent.
3. Otherwise generation ``g + 1`` tightens each constrained criterion's limit toward its
   Φ** (:mod:`.tolerance`; functional constraints are always hard), fits a Gaussian-mixture
   kernel on the trials of every generation that meet the new limits (:mod:`.kernel`) and
   draws points inside the box from it, in one of two schedules (:mod:`.schedule`):
   *searching* while D at the stated limits holds no member, *D found* afterwards. The
   generation (its points, kernel and schedule) is recorded in the store *before* it is
   evaluated.
4. With :data:`~.moves.MOVE_FROM` or more variables the importance weights degenerate, so
   generations 1, 2, ... instead move equally weighted particles by random-walk Metropolis
   steps inside the current limits (:mod:`.moves`); D's densities then weigh each member by
   its holding time in the chains.

Resume: generation ``g``'s points are a deterministic function of the seed, ``g``, the study's
limits and the stored trials of generations ``< g``; they are stored before evaluation, so a
run killed at any point (``kill -9``) continues with exactly the trials an uninterrupted run
computes, none lost or repeated.

When the budget is spent before D holds the population, the summary says how far it got, and
a local search from the best trials (:mod:`.search`) tells whether D is empty.
"""

from __future__ import annotations

from collections.abc import Generator
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...errors import StudyDefinitionError, plural
from ...limits import Limits
from ...spec import StudySpec
from ...store import Store, Trials
from ...summary import RunSummary
from ..base import Round, RoundResult, RunContext, RunSettings, Sampler
from ..weighting import Weighting
from .moves import MIN_FINAL_MOVES, MOVE_FROM, kept_moves
from .schedule import (
    COLLAPSE_SHARE,
    ESS_SHARE,
    GENERATION_FACTOR,
    PARTICLES_FACTOR,
    SEARCH_GENERATION_FACTOR,
    move_status,
    propose,
    propose_move,
    relaxed_of_best,
    searching,
)
from .search import LocalSearch, local_search, starts_text
from .state import (
    Generation,
    SequentialState,
    assess,
    assess_generations,
    generations,
    relaxed,
    tolerance_json,
    tolerance_of,
    weighting_of,
)

__all__ = ["SequentialSampler", "SequentialSummary", "describe_state", "sample_note"]


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
            f"{plural(self.evaluations, 'evaluation')}, {plural(self.generations, 'generation')}, "
            f"{plural(self.members, 'member')} of D at the stated limits, ESS {self.ess:.0f}"
        )
        if self.converged and self.moves:
            return (
                f"D reached: {head} (target {plural(self.population, 'member')}; ESS from the "
                "autocorrelation of the particles' chains over their last moves at the stated "
                "limits, each chain sampling D uniformly; densities of D weigh each member by "
                "the number of those moves it held a particle, members never so held weigh 0)"
            )
        if self.converged:
            return (
                f"D reached: {head} (target {plural(self.population, 'member')}, ESS >= "
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
                f"D not reached after {plural(self.evaluations, 'evaluation')}: {head}; the "
                f"population is {state} ({need}), so it is not presented as D: raise --budget "
                "to go on"
            )
        factor = (
            f"; the nearest generation meets the limits relaxed ×{self.relaxed:.3g}"
            if self.relaxed is not None
            else ""
        )
        text = f"D not reached after {plural(self.evaluations, 'evaluation')} ({head}){factor}"
        s = self.search
        if s is None:
            return text + "; raise --budget to go on"
        best = ", ".join(f"{n}={v:.6g}" for n, v in zip(self.names, s.x))
        if s.met:
            return (
                f"{text}; a local search from the best {starts_text(s)} found a vector that "
                f"meets every limit (×{s.factor:.3g}, {s.evaluations} evaluations, stage "
                f"{s.stage}): D is not empty, the sampler did not reach it within the budget — "
                f"raise --budget. Vector: {best}"
            )
        missed = (
            f"{text}; a local search from the best {starts_text(s)} also misses: its best "
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

    def to_dict(self) -> dict[str, Any]:
        """The summary as JSON-ready values: :meth:`RunSummary.to_dict`'s, and the
        sequential run's (budget, population, generations, evaluations, members, ess,
        converged, relaxed, tolerance per criterion, the verdict sentence)."""
        out = RunSummary.to_dict(self)
        out.update(
            budget=self.budget, population=self.population, generations=self.generations,
            evaluations=self.evaluations, members=self.members, ess=self.ess,
            converged=self.converged, relaxed=self.relaxed, tolerance=dict(self.tolerance),
            moves=self.moves, verdict=self.verdict(),
        )  # fmt: skip
        return out

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


class SequentialSampler(Sampler):
    """The sequential sampler (see the module docstring)."""

    def _configure(
        self, store: Store, *, trials: int | None, budget: int | None, population: int | None
    ) -> RunSettings:
        spec = self.spec
        notes: list[str] = []
        save: dict[str, int] = {}
        if trials is not None and int(trials) != spec.trials:
            if store.count_sample():
                notes.append(
                    f"--trials sets the size of generation 0, which the store holds already "
                    f"({spec.trials} trials): {int(trials)} is not used; --budget and "
                    "--population carry a sequential study further"
                )
            else:
                save["trials"] = int(trials)  # generation 0's size, before anything is stored
        for key, value in (("budget", budget), ("population", population)):
            if value is not None and int(value) != getattr(spec, key):
                save[key] = int(value)
        if save:
            spec = spec.with_study_keys(**save)
        constrained, _ = Limits(spec).constrained()
        if not constrained:
            raise StudyDefinitionError(
                "study.sampler",
                "sampler 'sequential' moves trials toward the criteria constraints Φ**, and "
                "this study states none",
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
        return RunSettings(spec, save, spec.sequential_budget, None, notes)

    def new_summary(self, settings: RunSettings, stored: int) -> SequentialSummary:
        spec = settings.spec
        return SequentialSummary(
            target=spec.sequential_budget, total_stored=stored, notes=list(settings.notes),
            budget=spec.sequential_budget, population=spec.sequential_population,
            names=list(spec.space.names),
        )  # fmt: skip

    def _rounds(self, store: Store, ctx: RunContext) -> Generator[Round, RoundResult, None]:
        spec = ctx.settings.spec
        summary = ctx.summary
        assert isinstance(summary, SequentialSummary)
        budget, population = spec.sequential_budget, spec.sequential_population
        state = yield from self._generations(store, spec, budget, population, ctx)
        if ctx.search and state is not None and not summary.converged and summary.members == 0:
            summary.search = yield from local_search(store, spec, state, ctx.say, budget)

    def _evaluate(self, gen: Generation, record: bool = False) -> Round:
        """The round that evaluates generation ``gen`` (and records it first if asked)."""
        return Round(0, gen.seq_start, gen.seq_start + gen.n,
                     lambda s, n: gen.X[s - gen.seq_start : s - gen.seq_start + n],
                     record=gen.record() if record else None, parts_per_worker=2,
                     bar=False)  # fmt: skip

    def _generations(
        self, store: Store, spec: StudySpec, budget: int, population: int, ctx: RunContext
    ) -> Generator[Round, RoundResult, SequentialState | None]:
        """The generations loop; returns the last state (None when nothing succeeded)."""
        summary = ctx.summary
        say = ctx.say
        p = len(spec.space)
        moves = p >= MOVE_FROM
        summary.moves = moves
        gens = generations(store)
        cache = (str(store.path), store.meta().get("created"))
        if not gens:
            n0 = min(spec.trials, budget)
            X = spec.space.scale(spec.point_sequence().points(0, n0))
            record = {"kind": "sobol", "tolerance": {}, "log_mass": 0.0, "draws": n0}
            gen0 = Generation(0, 0, n0, 0.0, record, X, np.empty((0, p)), np.empty(0), np.eye(p))
            yield self._evaluate(gen0, record=True)
            gens = generations(store)
        while True:
            for gen in gens:  # a resumed run first completes the generation it was in
                yield self._evaluate(gen)
            trials = store.load(stages=[0])
            state = assess_generations(spec, gens, trials, weights=not moves, cache=cache)
            moved = gens[-1].proposal.get("move") is not None
            if moved:
                done, state.ess = move_status(spec, state, trials, gens[-1], population)
            elif moves:  # the Sobol table alone: its members weigh the same
                state.ess = float(state.members.sum())
            evaluations = int(np.sum(state.generation >= 0))
            members = int(state.members.sum())
            eps = tolerance_of(gens[-1], spec, state.constrained)
            summary.generations = len(gens)
            summary.evaluations = evaluations
            summary.members = members
            summary.ess = float(state.ess)
            summary.tolerance = {
                k: v
                for k, v in tolerance_json(spec, state.constrained, eps).items()
                if v is not None
            }
            with np.errstate(invalid="ignore"):
                at_tol = int(np.sum(state.usable & np.all(state.phi <= eps, axis=1)))
            rel = relaxed(eps, state.floor)
            summary.relaxed = rel if len(gens) > 1 else relaxed_of_best(state, population)
            say(
                f"generation {len(gens) - 1}: {plural(gens[-1].n, 'trial')}, "
                f"{plural(evaluations, 'evaluation')}; "
                + (f"limits ×{rel:.3g} of Φ**, " if rel is not None else "")
                + f"{plural(at_tol, 'trial')} within them; D: {plural(members, 'member')}, "
                f"ESS {state.ess:.0f}"
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
                made = propose_move(cache, spec, state, gens, PARTICLES_FACTOR * population,
                                    trials, budget - evaluations)  # fmt: skip
            else:
                gf = SEARCH_GENERATION_FACTOR if searching(state) else GENERATION_FACTOR
                n = min(int(gf * population), budget - evaluations)
                made = propose(cache, spec, state, gens, n, trials, population)
            if made is None:
                say("the proposal puts almost no mass inside the box: stopped")
                return state
            X, record, kernel = made
            start = gens[-1].seq_start + gens[-1].n
            new = Generation(len(gens), start, len(X), 0.0, record, X, kernel.centres,
                             kernel.log_mix, kernel.chol)  # fmt: skip
            yield self._evaluate(new, record=True)
            gens = generations(store)

    # -- reading ---------------------------------------------------------------------------

    def planned(self, store: Store) -> list[tuple[int, int, int]]:
        return [(0, g.seq_start, g.seq_start + g.n) for g in generations(store)]

    def points(self, store: Store, stage: int, start: int, n: int) -> np.ndarray:
        if stage != 0:
            raise ValueError(f"a sequential study samples stage 0 only, not stage {stage}")
        out = np.empty((n, len(self.spec.space)))
        done = 0
        for g in generations(store):
            a, b = max(start, g.seq_start), min(start + n, g.seq_start + g.n)
            if a < b:
                out[a - start : b - start] = g.X[a - g.seq_start : b - g.seq_start]
                done += b - a
        if done != n:
            raise ValueError(
                f"sequence indices {start}..{start + n - 1} are not all planned by a stored "
                "generation"
            )
        return out

    def status_lines(self, store: Store, held: int, failed: int) -> list[str]:
        spec = self.spec
        sq = assess(store)
        return [
            f"trials     {held} evaluated of a budget of {spec.sequential_budget}; {failed} failed",
            f"sequential {plural(len(sq.counts), 'generation')}; D: "
            f"{plural(int(sq.members.sum()), 'member')} "
            f"(wanted {spec.sequential_population}), ESS {sq.ess:.0f} "
            + ("(particles' chains)" if sq.particles is not None else "(importance weights)"),
        ]

    def weighting(self, store: Store, trials: Trials) -> Weighting | None:
        return weighting_of(store.spec, generations(store), trials)

    def describe(
        self, store: Store, limits: Any = None, trials: Trials | None = None
    ) -> str | None:
        return sample_note(store, limits, trials)


def sample_note(store: Store, limits: Any = None, trials: Trials | None = None) -> str | None:
    """One line for analyses of a sequential store: D's members and ESS under the limits in
    force, and whether the population is collapsed (then its ranges are not D's); None for a
    store without generations.

    Parameters
    ----------
    store : Store
    limits : Limits or mapping, optional
        The limits in force (default: the stated ones).
    trials : Trials, optional
        The store's sample, when loaded already.
    """
    if not store.sampler_records():
        return None
    if isinstance(limits, Limits):
        limits = {n: limits.worse_side(n) for n in limits.crit_names}
    state = assess(store, trials, limits or None)
    m = int(state.members.sum())
    wanted = store.spec.sequential_population
    head = (
        f"sequential sampler: {plural(sum(state.counts), 'evaluation')} in "
        f"{plural(len(state.counts), 'generation')}; D holds {plural(m, 'member')}, ESS "
        f"{state.ess:.0f} "
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
