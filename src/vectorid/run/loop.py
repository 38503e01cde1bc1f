"""The run loop: which trials are missing, batching, progress, storing, resuming.

The study should hold the sequence indices ``0 .. target - 1`` across its sample stages;
stage ``s`` owns the indices from its ``start_seq`` up to the next sample stage's start.
A run computes exactly the indices that no stored batch holds, so a run interrupted at any
point (Ctrl-C, ``kill -9``) resumes with no trial lost and none stored twice: a batch is
written in one transaction, and a batch that was being computed when the run died was not
stored and is computed again.

The work is planned lazily (one batch at a time), so a target of 10^12 trials costs no more
memory than one of 10^3: the run stores batches as they come until it is stopped.

Loud failures: when every trial of the first batches (at least :data:`FIRST_LOOK` trials)
failed, the study as defined cannot work (the model's output does not fit the study, an
import fails in the model, every trial times out, ...): the run stops with
:class:`~vectorid.errors.RunFailedError` naming the reason and the fix, and stores none of
those trials, so a fixed study or model starts from a clean store. ``keep_going=True``
(``--keep-going``) stores them anyway.
"""

from __future__ import annotations

import collections
import math
import re
import sys
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import TextIO

import numpy as np

from ..errors import RunFailedError
from ..problem import FAILED, EvalResult
from ..store.sqlite import Store
from .executors import make_executor

__all__ = [
    "FIRST_LOOK",
    "FailureGroup",
    "RunInterrupted",
    "RunSummary",
    "group_failures",
    "plan",
    "run_store",
]

#: Trials the run looks at before deciding that a study whose every trial failed cannot work.
FIRST_LOOK = 8


class RunInterrupted(KeyboardInterrupt):
    """The run was stopped by the user; everything finished so far is stored."""

    def __init__(self, summary: RunSummary) -> None:
        super().__init__()
        self.summary = summary

    def __str__(self) -> str:
        s = self.summary
        return (
            f"interrupted: {s.stored} new trials stored in this run; the study holds "
            f"{s.total_stored} of {s.target}; run the same command again to resume"
        )


@dataclass(frozen=True)
class FailureGroup:
    """Failed trials that failed the same way (their messages differ at most in numbers).

    Attributes
    ----------
    count : int
        How many trials.
    message : str
        The full message of the first of them (real numbers and names).
    trial : int
        Its trial id.
    """

    count: int
    message: str
    trial: int


@dataclass
class RunSummary:
    """What a run did.

    Attributes
    ----------
    target : int
        Trials the study should hold.
    stored, failed, duplicates : int
        Trials stored by this run, how many of them failed, and trials computed twice and
        stored once.
    total_stored : int
        Trials the study holds after the run.
    elapsed : float
        Seconds.
    reasons : Counter
        Failed trials by group key (digits masked: a key, not a message).
    examples : dict
        Group key -> ``(trial id, full message)`` of the first trial of the group.
    notes : list of str
        Things the run decided that the user must know (a target below what is stored, ...).
    retried : dict
        Model errors the run recovered from by re-running trials (a batch that raised,
        returned too few rows, lost its worker or ran past its time): group key ->
        ``[batches, trials lost, example text]``; :attr:`model_errors` says them.
    """

    target: int
    stored: int = 0
    failed: int = 0
    duplicates: int = 0
    total_stored: int = 0
    elapsed: float = 0.0
    reasons: collections.Counter = field(default_factory=collections.Counter)
    examples: dict[str, tuple[int, str]] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    retried: dict[str, list] = field(default_factory=dict)

    def add_retried(self, res: EvalResult) -> None:
        """Count the model errors a batch recovered from (once per batch and kind; the run
        loop calls it).

        Parameters
        ----------
        res : EvalResult
            The evaluated batch, with the errors it was re-run after (``res.retried``).
        """
        if not res.retried:
            return
        lost = int(res.retry_lost)
        for text in dict.fromkeys(res.retried):
            key = _reason_key(text)
            entry = self.retried.setdefault(key, [0, 0, text])
            entry[0] += 1
            entry[1] += lost

    @property
    def model_errors(self) -> list[str]:
        """One line per kind of model error the run recovered from, e.g. "3 batches raised
        ValueError: ... ; re-run trial by trial: 0 lost"."""
        out = []
        for batches, lost, text in sorted(self.retried.values(), key=lambda e: -e[0]):
            out.append(
                f"{batches} batch{'es' if batches > 1 else ''} {text}; re-run trial by "
                f"trial: {lost} lost"
            )
        return out

    @property
    def rate(self) -> float:
        """Trials per second."""
        return self.stored / self.elapsed if self.elapsed > 0 else math.nan

    @property
    def failures(self) -> list[FailureGroup]:
        """Failure groups, most frequent first, each with a real example message."""
        return [
            FailureGroup(count, self.examples[key][1], self.examples[key][0])
            for key, count in self.reasons.most_common()
        ]

    def add_failures(self, start_id: int, res: EvalResult) -> None:
        """Count the failed trials of one evaluated batch (the run loop calls it).

        Parameters
        ----------
        start_id : int
            Trial id of the batch's first row.
        res : EvalResult
            The batch's evaluation.
        """
        failed = np.flatnonzero(res.status == FAILED)
        self.failed += len(failed)
        for i in failed:
            msg = res.messages.get(int(i), "unknown failure (no message)")
            key = _reason_key(msg)
            self.reasons[key] += 1
            self.examples.setdefault(key, (int(start_id + i), msg))

    def describe(self) -> str:
        """Human-readable summary, with failure reasons (real example messages)."""
        lines = [
            f"{self.stored} trials computed in {self.elapsed:.1f} s "
            f"({self.rate:.0f} trials/s); the study holds {self.total_stored} of {self.target}"
        ]
        lines += [f"note: {n}" for n in self.notes]
        if self.retried:
            lines.append(
                "model errors (the values were re-computed; failed trials are counted below):"
            )
            lines += [f"  {m}" for m in self.model_errors]
        if self.failed:
            share = 100.0 * self.failed / max(self.stored, 1)
            lines.append(f"{self.failed} of {self.stored} trials failed ({share:.0f} %):")
            for g in self.failures[:10]:
                lines.append(f"  {g.count:>7} × {g.message} (e.g. trial {g.trial})")
            if len(self.reasons) > 10:
                rest = sum(c for _, c in self.reasons.most_common()[10:])
                lines.append(f"  {rest:>7} × other reasons (`vectorid info` lists them)")
            if share > 50:
                lines.append(
                    "warning: most trials failed; check the reasons above before analysing "
                    "the study"
                )
        if self.duplicates:
            lines.append(f"{self.duplicates} trials were computed twice and stored once")
        return "\n".join(lines)


_NUMBER = re.compile(r"(?<![\w.])[-+]?\d+(\.\d+)?([eE][-+]?\d+)?(?![\w.])")


def _reason_key(message: str) -> str:
    """Group key of a failure message: numbers standing alone masked ("shape (#, #)"), names
    such as ``f1`` or ``x12`` kept, the source location dropped. A key, never shown alone."""
    text = re.sub(r" \(at [^)]*\)$", "", message)
    text = _NUMBER.sub("#", text)
    return text[:160]


def group_failures(
    messages: dict[tuple[int, int], str], ids: dict[tuple[int, int], int] | None = None
) -> list[FailureGroup]:
    """Group stored failure messages (``(stage, seq) -> message``) by reason, most frequent
    first, each with the full message of its first trial (``ids`` maps keys to trial ids;
    default ``seq + 1``)."""
    counts: collections.Counter = collections.Counter()
    first: dict[str, tuple[int, str]] = {}
    for (stage, seq), msg in sorted(messages.items()):
        key = _reason_key(msg)
        counts[key] += 1
        if key not in first:
            tid = ids.get((stage, seq), seq + 1) if ids is not None else seq + 1
            first[key] = (tid, msg)
    return [FailureGroup(c, first[k][1], first[k][0]) for k, c in counts.most_common()]


def plan(
    store: Store,
    target: int,
    batch_size: int,
    ranges: Sequence[tuple[int, int, int]] | None = None,
) -> Iterator[tuple[int, int, int]]:
    """Missing work as ``(stage, seq_start, n)`` batches, in sequence order, one at a time.

    Parameters
    ----------
    store : Store
    target : int
        Trials the study should hold.
    batch_size : int
    ranges : sequence of (stage, start, end), optional
        Only these sequence ranges (a repair), instead of everything up to ``target``.
    """
    if ranges is None:
        sample = [s for s in store.stages() if s.kind == "sample"]
        spans = []
        for i, stage in enumerate(sample):
            end = sample[i + 1].start_seq if i + 1 < len(sample) else target
            end = min(end, target)
            if end > stage.start_seq:
                spans.append((stage.stage, stage.start_seq, end))
    else:
        spans = list(ranges)
    for stage, start, end in spans:
        for a, b in store.missing(stage, start, end):
            for s in range(a, b, batch_size):
                yield (stage, s, min(batch_size, b - s))


#: Points scipy's Sobol engine can give (``bits=30``); index i is point i + 1 unscrambled.
SOBOL_POINTS = 2**30


def _check_capacity(spec, target: int) -> None:
    """Refuse a target the point sequence cannot reach (before computing anything)."""
    if spec.sampler != "sobol":
        return
    most = SOBOL_POINTS - (0 if spec.scramble else 1)
    if target > most:
        from ..errors import StudyDefinitionError

        raise StudyDefinitionError(
            "trials",
            f"{target} trials are more than the Sobol sequence can give here: at most {most} "
            f"(scipy's Sobol engine holds 2**30 = {SOBOL_POINTS} points)",
            f'use at most {most} trials, or sampler = "lhs" (Latin hypercube blocks, no such '
            "limit)",
        )


def _missing_count(store: Store, target: int, ranges=None) -> int:
    return sum(n for _, _, n in plan(store, target, 1 << 62, ranges))


def _auto_batch(missing: int, workers: int) -> int:
    if missing <= 0:
        return 1
    per_worker = math.ceil(missing / (workers * 8))
    return int(min(1024, max(16, per_worker)))


def _hint(message: str, spec) -> str:
    """How to fix a study whose every trial failed with ``message``."""
    names = lambda items: ", ".join(c.name for c in items)  # noqa: E731
    p, k, q = len(spec.space), len(spec.criteria), len(spec.constraints)
    if ("model returned" in message and "shape" in message) or "model returned no" in message:
        return (
            f"the model's output does not fit the study, which has {k} criteria "
            f"({names(spec.criteria)}) and {q} functional constraints "
            f"({names(spec.constraints) or 'none'}): make [[criteria]] and [[constraints]] "
            "match the model's output columns, in order"
        )
    if message.startswith("IndexError") or "out of bounds" in message:
        return (
            f"the model reads a column the batch does not have: the study has {p} "
            f"variables ({', '.join(spec.space.names)}) — check [[variables]] against what "
            "the model expects"
        )
    if message.startswith(("ImportError", "ModuleNotFoundError")):
        return "the model needs a module this environment cannot import: install it"
    if message.startswith("non-finite result"):
        return (
            "the model returns NaN or infinity for every trial: check the box of "
            "[[variables]] and the model"
        )
    if message.startswith("timed out"):
        return "every trial ran past the timeout: raise --timeout (or timeout under [study])"
    if "worker process died" in message or "killed by signal" in message:
        return "the model crashes its process on every trial: run one trial by hand to see why"
    if message.startswith("complex"):
        return "the model returns complex numbers: return real criteria and functionals"
    return "the model raises on every trial: fix the model (the message says where)"


def run_store(
    store: Store,
    *,
    trials: int | None = None,
    executor: str | None = None,
    workers: int | None = None,
    batch_size: int | None = None,
    progress: bool | TextIO = True,
    keep_going: bool = False,
    ranges: Sequence[tuple[int, int, int]] | None = None,
    timeout: float | None = None,
    budget: int | None = None,
    population: int | None = None,
    accept_changes: bool = False,
) -> RunSummary:
    """Run (or resume, or extend) the study held by a writable store.

    Parameters
    ----------
    store : Store
        Opened with ``write=True``.
    trials : int, optional
        Total number of trials the study should hold (default: the study's ``trials``); for a
        sequential study (``sampler = "sequential"``, run by
        :func:`vectorid.run.sequential.run_sequential`) the size of generation 0. A
        larger number than before extends the study along the same sequence; a smaller one
        than is stored computes nothing and keeps every stored trial (the summary says so).
    executor : {"serial", "processes", "dask", "inline"}, optional
        Default: the study's executor, else ``"processes"``.
    workers : int, optional
        Worker processes (default: all cores).
    batch_size : int, optional
        Trials per batch (default: the study's, else chosen from the work size).
    progress : bool or file
        Show a progress bar (on stderr, or on the given file).
    keep_going : bool
        Store the first batches even when every one of their trials failed (see the module
        docstring); default False: stop with :class:`~vectorid.errors.RunFailedError`.
    ranges : sequence of (stage, start, end), optional
        Only compute the missing trials of these sequence ranges (used by repairs).
    timeout : float, optional
        Most seconds one trial may take (default: the study's ``timeout``).
    budget, population : int, optional
        Sequential studies only: most model evaluations and members of D wanted (saved in
        the study; default: the study's).
        Most seconds one trial may take (default: the study's ``timeout``; see
        :mod:`vectorid.run.executors` for how a batch that runs over is split).
    accept_changes : bool
        When the data files or the model's code changed since the stored trials were
        computed, take the change and record it in the store's history instead of stopping
        (:func:`vectorid.store.inputs.check_inputs`).

    Returns
    -------
    RunSummary

    Raises
    ------
    RunInterrupted
        On Ctrl-C, after storing everything already finished.
    RunFailedError
        When every trial of the first batches failed (unless ``keep_going``).
    """
    spec = store.spec
    if spec.sampler != "sequential" and (budget is not None or population is not None):
        from ..errors import StudyDefinitionError

        raise StudyDefinitionError(
            "--budget" if budget is not None else "--population",
            f"budget and population apply to sampler 'sequential', this study's sampler is "
            f"{spec.sampler!r}",
            'use --trials for a plain study, or set sampler = "sequential" in a new study',
        )
    if spec.sampler == "sequential":
        from .sequential import run_sequential

        if trials is not None and int(trials) != spec.trials and not store.count_sample():
            store.set_target(int(trials))  # generation 0's size, before anything is stored
        return run_sequential(
            store,
            budget=budget,
            population=population,
            executor=executor,
            workers=workers,
            batch_size=batch_size,
            progress=progress,
            keep_going=keep_going,
            ranges=ranges,
            timeout=timeout,
        )
    if trials is not None:
        _check_capacity(spec, int(trials))
    notes: list[str] = []
    stored_before = store.count_sample()
    if trials is not None and ranges is None:
        trials = int(trials)
        if trials < stored_before:
            notes.append(
                f"the store holds {stored_before} trials, more than the {trials} asked for: "
                "nothing to compute, every stored trial is kept (analyses use all of them), "
                f"and the study's target stays {max(spec.trials, stored_before)}"
            )
            trials = max(spec.trials, stored_before)
    target = int(trials if trials is not None else spec.trials)
    missing = _missing_count(store, target, ranges)
    if missing or accept_changes:
        from ..store.inputs import check_inputs

        # the same check on every path into a store, before anything is written to it
        notes += check_inputs(store, accept_changes=accept_changes)
    if trials is not None and ranges is None and trials != spec.trials:
        store.set_target(trials)
        spec = store.spec
    _check_capacity(spec, target)
    executor_name = executor or spec.executor or "processes"
    pool = make_executor(
        executor_name,
        spec,
        workers if workers is not None else spec.workers,
        timeout=timeout,
    )
    size = batch_size or spec.batch_size or _auto_batch(missing, pool.workers)
    sampler = spec.sampler_for()
    spaces = {s.stage: s.space for s in store.stages()}
    summary = RunSummary(target=target, total_stored=stored_before, notes=notes)

    inflight: dict[tuple[int, int], np.ndarray] = {}

    def batches() -> Iterator[tuple[tuple[int, int], np.ndarray]]:
        for stage, start, n in plan(store, target, size, ranges):
            X = spaces[stage].scale(sampler.points(start, n))
            inflight[(stage, start)] = X
            yield (stage, start), X

    bar = None
    run_id = store.begin_run(executor_name, pool.workers, target)
    t0 = time.perf_counter()
    outcome = "completed"
    # Results held back until the run has seen FIRST_LOOK trials (or all of its work): if
    # every one of them failed, nothing is stored and the run stops.
    held: list[tuple[int, int, np.ndarray, EvalResult]] | None = [] if not keep_going else None
    seen = 0

    def store_result(stage: int, start: int, X: np.ndarray, res: EvalResult) -> None:
        wrote = store.write_batch(
            stage, start, X, res.criteria, res.functionals, res.status, res.wall, res.messages
        )
        if wrote == 0:
            summary.duplicates += res.n
            return
        summary.stored += wrote
        summary.add_failures(start + 1, res)
        summary.add_retried(res)
        if bar is not None:
            bar.update(wrote)

    def release_held() -> None:
        nonlocal held
        if held is None:
            return
        pending, held = held, None
        for args in pending:
            store_result(*args)

    try:
        with pool:
            if missing:
                pool.start()
            if progress and missing:
                from tqdm.auto import tqdm

                bar = tqdm(
                    total=stored_before + missing,
                    initial=stored_before,
                    unit="trial",
                    file=progress if not isinstance(progress, bool) else sys.stderr,
                    dynamic_ncols=True,
                    smoothing=0.1,
                )
            for (stage, start), res in pool.map_unordered(batches()):
                X = inflight.pop((stage, start))
                if held is None:
                    store_result(stage, start, X, res)
                    continue
                held.append((stage, start, X, res))
                seen += res.n
                if not np.all(res.status == FAILED):
                    release_held()
                elif seen >= min(FIRST_LOOK, missing):
                    _stop_loudly(spec, held, seen)
            release_held()
    except KeyboardInterrupt:
        outcome = "interrupted"
        raise RunInterrupted(summary) from None
    except RunFailedError as exc:
        outcome = f"stopped: {str(exc)[:200]}"
        raise
    except BaseException:
        outcome = "error"
        raise
    finally:
        summary.elapsed = time.perf_counter() - t0
        summary.total_stored = store.count_sample()
        if bar is not None:
            bar.close()
        store.end_run(run_id, outcome, _run_report(summary))
    return summary


def _run_report(summary: RunSummary) -> dict:
    """What the run record keeps of a run: failures and recovered model errors."""
    return {
        "stored": summary.stored,
        "failed": summary.failed,
        "failures": [
            {"count": g.count, "example": g.message, "trial": g.trial}
            for g in summary.failures[:10]
        ],
        "model_errors": summary.model_errors,
    }


def _stop_loudly(spec, held, seen: int) -> None:
    stage, start, _, res = held[0]
    first = int(np.flatnonzero(res.status == FAILED)[0])
    message = res.messages.get(first, "unknown failure (no message)")
    keys = collections.Counter(
        _reason_key(r.messages.get(i, "")) for _, _, _, r in held for i in range(r.n)
    )
    same = len(keys) == 1
    raise RunFailedError(
        f"all {seen} trials of the first batch{'es' if len(held) > 1 else ''} failed"
        f"{' the same way' if same else ''}, so the run stopped and stored none of them: "
        f"{message} (trial {start + first + 1}{'' if stage == 0 else f', stage {stage}'}). "
        f"Fix: {_hint(message, spec)}; or run with --keep-going (keep_going=True) to store "
        "failed trials anyway"
    )
