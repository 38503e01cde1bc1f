"""The sampler seam: what a sampler must do, and what the run driver does for every sampler.

A sampler decides which trials a study evaluates. The run driver (:func:`vectorid.run.run_store`)
owns everything else — the executor, batching, the first look at the first trials, the input
check, retries, every write to the store, progress and the run report — so a sampler only
*plans* (which parameter vectors, at which sequence indices, in which stage) and *reads*
(the trials stored so far, through the store's read methods). It never writes: what it must
keep to replay its decisions goes into :class:`Round.record`, which the driver writes before
the round's trials are evaluated.

Contract of :meth:`Sampler._rounds` (a generator):

* it yields :class:`Round` objects; after each, the driver has evaluated and stored every trial
  of the round that the store did not hold, and sends back a :class:`RoundResult`;
* the points of a round are a function of the study (its seed) and of what the store held
  when the round was planned, never of timing or of how the work was batched: a run killed at
  any moment and resumed plans the same rounds and computes only what is missing, so no trial
  is lost or repeated;
* it may fill the fields of its own summary (``ctx.summary``) and say one line per step
  (``ctx.say``), and returns when the study needs nothing more from this run.

On the reading side, :meth:`Sampler.weighting` says how the stored sample weighs as a sample of
the box's uniform density (None: every trial counts once), and :meth:`Sampler.describe` gives
one line for analyses of its stores.
"""

from __future__ import annotations

import abc
from collections.abc import Callable, Generator
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import StudyDefinitionError
from ..problem import EvalResult
from ..sampler_kinds import SAMPLER_OPTIONS, sampler_kind, sampler_names
from ..spec import StudySpec
from ..store import Store, Trials
from ..summary import RunSummary
from .weighting import Weighting

__all__ = [
    "Round",
    "RoundResult",
    "RunContext",
    "RunSettings",
    "Sampler",
    "StageRequest",
    "Weighting",
    "sampler_for",
]


@dataclass(frozen=True)
class StageRequest:
    """An auxiliary stage a round's trials go to, created by the driver.

    Attributes
    ----------
    kind : str
        Stage kind (e.g. ``"search"``); never ``"sample"``.
    note : str
        Why it was added (shown by ``vectorid info``).
    """

    kind: str
    note: str


@dataclass
class Round:
    """Trials the driver evaluates and stores before the sampler plans the next ones.

    Attributes
    ----------
    stage : int or StageRequest
        The stage the trials belong to (0: the study's box), or a new auxiliary stage to add.
    start, end : int
        The round's sequence indices ``start .. end - 1`` in that stage; the driver computes
        those the store does not hold.
    points : callable
        ``points(start, n) -> X`` (n, p): the parameter vectors of sequence indices
        ``start .. start + n - 1``, in the study's units.
    record : dict, optional
        A sampler record the driver writes before evaluating: ``{"index", "seq_start",
        "n", "info", "arrays"}`` (see :meth:`vectorid.store.Store.add_sampler_record`).
    batch : int, optional
        Trials per batch; None: chosen by the driver from the work and the workers
        (``parts_per_worker`` batches per worker at least, 16 to 1,024 trials each).
    parts_per_worker : int
        See ``batch``.
    results : bool
        Send the evaluated trials back in the :class:`RoundResult` (for a sampler that
        decides from them at once, such as a local search).
    bar : bool
        Count the round's trials on the run's progress bar (a sampler that says its own
        lines per step sets False).
    """

    stage: int | StageRequest
    start: int
    end: int
    points: Callable[[int, int], np.ndarray]
    record: dict[str, Any] | None = None
    batch: int | None = None
    parts_per_worker: int = 8
    results: bool = False
    bar: bool = True


@dataclass
class RoundResult:
    """What the driver sends back after a round.

    Attributes
    ----------
    stage : int
        The stage the trials went to (a new one's number, when the round asked for one).
    computed : int
        Trials evaluated in this round (those already stored are not).
    X : (m, p) float array or None
        With ``Round.results``: the evaluated vectors, in sequence order.
    result : EvalResult or None
        With ``Round.results``: their evaluation (criteria, functionals, status).
    """

    stage: int
    computed: int
    X: np.ndarray | None = None
    result: EvalResult | None = None


@dataclass
class RunSettings:
    """A run's settings, as the sampler read them from the options and the study.

    Attributes
    ----------
    spec : StudySpec
        The study with the run's options applied (not yet saved).
    save : dict
        ``[study]`` keys the run changes; the driver saves them in the store at its first
        write (after the input check), so a refused run changes nothing.
    target : int
        What the run log records as the run's target (trials, or a budget of evaluations).
    work : int or None
        Trials the run will evaluate, when known beforehand (for the progress bar).
    notes : list of str
        Things the user must know (a target below what is stored, ...).
    """

    spec: StudySpec
    save: dict[str, Any] = field(default_factory=dict)
    target: int = 0
    work: int | None = None
    notes: list[str] = field(default_factory=list)


@dataclass
class RunContext:
    """What the driver gives a sampler's rounds.

    Attributes
    ----------
    settings : RunSettings
    summary : RunSummary
        The run's summary (the sampler's own type): the sampler fills its own fields.
    workers : int
        Workers of the executor.
    say : callable
        ``say(text)``: one line of progress (a no-op when the run is quiet).
    search : bool
        Whether a sampler may run an extra search (the sequential sampler's local search)
        when it did not reach what it aims at.
    """

    settings: RunSettings
    summary: RunSummary
    workers: int
    say: Callable[[str], None]
    search: bool = True


class Sampler(abc.ABC):
    """A strategy that decides which trials a study evaluates (see the module docstring).

    Subclasses implement :meth:`_rounds`; they may override :meth:`configure`,
    :meth:`planned`, :meth:`points`, :meth:`weighting`, :meth:`describe` and
    :meth:`new_summary`. One sampler object is made per run or analysis, by
    :func:`sampler_for`, from the study's ``sampler`` key.

    Parameters
    ----------
    spec : StudySpec
        The study.
    """

    def __init__(self, spec: StudySpec) -> None:
        self.spec = spec

    # -- running ---------------------------------------------------------------------------

    def configure(
        self,
        store: Store,
        *,
        trials: int | None = None,
        budget: int | None = None,
        population: int | None = None,
    ) -> RunSettings:
        """Read the run's options against the study (nothing is written).

        Parameters
        ----------
        store : Store
            The study's store.
        trials, budget, population : int, optional
            The run's options (``--trials``, ``--budget``, ``--population``).

        Returns
        -------
        RunSettings

        Raises
        ------
        StudyDefinitionError
            An option this sampler does not take, or a value it cannot run.
        """
        for key, value in (("budget", budget), ("population", population)):
            if value is not None and key not in sampler_kind(self.spec.sampler).options:
                takes = [n for n in sampler_names() if key in sampler_kind(n).options]
                their = [
                    o for o in SAMPLER_OPTIONS if takes and o in sampler_kind(takes[0]).options
                ]
                raise StudyDefinitionError(
                    f"--{key}",
                    f"{' and '.join(their or [key])} apply to sampler "
                    f"{' or '.join(repr(n) for n in takes)}, this study's sampler is "
                    f"{self.spec.sampler!r}",
                    "use --trials for a plain study, or set sampler = "
                    f'"{takes[0] if takes else "NAME"}" in a new study',
                )
        return self._configure(store, trials=trials, budget=budget, population=population)

    def _configure(
        self, store: Store, *, trials: int | None, budget: int | None, population: int | None
    ) -> RunSettings:
        return RunSettings(self.spec, target=self.spec.trials)

    def rounds(self, store: Store, ctx: RunContext) -> Generator[Round, RoundResult, None]:
        """The run's rounds (see the module docstring); each is checked before the driver
        evaluates it.

        Parameters
        ----------
        store : Store
            The study's store, open for writing (the sampler only reads it).
        ctx : RunContext

        Yields
        ------
        Round
        """
        gen = self._rounds(store, ctx)
        try:
            rnd = next(gen)
            while True:
                self._check_round(rnd)
                rnd = gen.send((yield rnd))
        except StopIteration:
            return

    def _check_round(self, rnd: Round) -> None:
        if rnd.end < rnd.start or rnd.start < 0:
            raise ValueError(
                f"sampler {self.spec.sampler!r}: a round from {rnd.start} to {rnd.end}"
            )
        if isinstance(rnd.stage, StageRequest) and rnd.stage.kind == "sample":
            raise ValueError("a sampler's extra stage cannot be of kind 'sample'")

    @abc.abstractmethod
    def _rounds(self, store: Store, ctx: RunContext) -> Generator[Round, RoundResult, None]:
        """The hook: yield the run's rounds (see the module docstring)."""

    def new_summary(self, settings: RunSettings, stored: int) -> RunSummary:
        """The summary this sampler's runs fill (the driver counts trials and failures).

        Parameters
        ----------
        settings : RunSettings
        stored : int
            Trials the study's sample holds before the run.
        """
        return RunSummary(target=settings.target, total_stored=stored, notes=list(settings.notes))

    # -- reading ---------------------------------------------------------------------------

    def planned(self, store: Store) -> list[tuple[int, int, int]]:
        """The sample's sequence ranges this sampler planned: what the store should hold once
        every run finished (``verify`` counts what is missing).

        Parameters
        ----------
        store : Store
            The study's store.

        Returns
        -------
        list of (stage, start, end)
        """
        return []

    def points(self, store: Store, stage: int, start: int, n: int) -> np.ndarray:
        """The planned parameter vectors of stored or planned sample trials (a repair
        recomputes them).

        Parameters
        ----------
        store : Store
            The study's store.
        stage : int
            A sample stage.
        start, n : int
            The sequence indices ``start .. start + n - 1``.

        Returns
        -------
        (n, p) float array
            In the study's units.
        """
        raise NotImplementedError(f"sampler {self.spec.sampler!r} cannot give planned points")

    def status_lines(self, store: Store, held: int, failed: int) -> list[str]:
        """``vectorid info``'s lines on where the sample stands.

        Parameters
        ----------
        store : Store
        held : int
            Trials the sample holds (damaged batches included).
        failed : int
            Trials of the sample that failed.
        """
        return [f"trials     {held} stored of {self.spec.trials} wanted; {failed} failed"]

    def weighting(self, store: Store, trials: Trials) -> Weighting | None:
        """How the stored sample weighs as a sample of the box's uniform density.

        Parameters
        ----------
        store : Store
            The study's store.
        trials : Trials
            Its sample, as loaded.

        Returns
        -------
        Weighting or None
            None: every trial counts once (a plain table).
        """
        return None

    def describe(
        self, store: Store, limits: Any = None, trials: Trials | None = None
    ) -> str | None:
        """One line for analyses of this sampler's stores (None: nothing to say).

        Parameters
        ----------
        store : Store
        limits : Limits, optional
            The limits in force in the analysis.
        trials : Trials, optional
            The sample, when already loaded.
        """
        return None


def sampler_for(spec: StudySpec) -> Sampler:
    """The sampler the study names (``[study] sampler``), resolved once through the registry
    (:mod:`vectorid.sampler_kinds`).

    Parameters
    ----------
    spec : StudySpec

    Returns
    -------
    Sampler
    """
    cls = sampler_kind(spec.sampler).resolve()
    return cls(spec)
