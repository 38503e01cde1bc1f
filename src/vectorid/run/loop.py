"""The run loop: the one driver that evaluates and stores trials, for every sampler.

The study's sampler (:mod:`vectorid.samplers`) plans rounds of trials; this loop owns the
rest, the same way for every sampler:

* the **input check** (:func:`vectorid.store.inputs.check_inputs`) before the first write: a
  run whose model code or data changed since the stored trials were computed adds nothing;
* the **executor** (in-process, processes, Dask) and the **batches** a round is split into;
* the **first look**: when every trial of the first batches (at least :data:`FIRST_LOOK`
  trials) failed, the study as defined cannot work (the model's output does not fit the study,
  an import fails in the model, every trial times out, ...): the run stops with
  :class:`~vectorid.errors.RunFailedError` naming the reason and the fix, and stores none of
  those trials, so a fixed study or model starts from a clean store. ``keep_going=True``
  (``--keep-going``) stores them anyway;
* **retries** (the executors re-run a batch that raised, lost its worker or ran past its time,
  trial by trial) and their count in the summary;
* every **write** (the sampler's records, new stages, batches), exactly once: a batch is
  written in one transaction, and a batch whose range is stored already is counted as a
  duplicate, not stored again; a run interrupted at any point (Ctrl-C, ``kill -9``) resumes
  with no trial lost and none stored twice;
* **progress** (a bar, or the sampler's lines; by default only where someone watches: a
  terminal or a notebook, :func:`progress_wanted`) and the **run log** with its report
  (failures, recovered model errors).
"""

from __future__ import annotations

import collections
import math
import sys
import time
from collections.abc import Iterator, Sequence
from typing import Any, TextIO

import numpy as np
from tqdm.auto import tqdm

from .._hints import quiet
from ..errors import RunFailedError, StoreError, plural
from ..problem import FAILED, EvalResult, Problem
from ..samplers import Round, RoundResult, RunContext, RunSettings, StageRequest, sampler_for
from ..samplers.table import sample_spans
from ..store import Store
from ..store.inputs import check_inputs, reload_edited_code
from ..summary import FailureGroup, RunSummary, group_failures, reason_key
from .executors import make_executor

__all__ = [
    "FIRST_LOOK",
    "FailureGroup",
    "RunInterrupted",
    "RunSummary",
    "evaluate_into",
    "group_failures",
    "plan",
    "progress_wanted",
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


def progress_wanted(file: Any = None) -> bool:
    """Whether a run shows progress when it is not told (``progress=None``): when ``file``
    (default: standard error) is a terminal, or in a notebook (IPython's kernel), and
    notices are not turned off (``--quiet``, :func:`vectorid._hints.quiet`); a script whose
    standard error goes to a file or a pipe runs silently.

    Parameters
    ----------
    file : text file, optional
        Where the progress would go (default ``sys.stderr``).
    """
    if quiet():
        return False
    out = sys.stderr if file is None else file
    try:
        if out is not None and out.isatty():
            return True
    except (AttributeError, ValueError, OSError):
        pass
    shell = None
    ipython = sys.modules.get("IPython")
    if ipython is not None and "ipykernel" in sys.modules:
        try:
            shell = ipython.get_ipython()
        except Exception:  # an IPython without a shell
            shell = None
    return shell is not None and type(shell).__name__ == "ZMQInteractiveShell"


def plan(
    store: Store,
    target: int,
    batch_size: int,
    ranges: Sequence[tuple[int, int, int]] | None = None,
) -> Iterator[tuple[int, int, int]]:
    """Missing work of the plain table as ``(stage, seq_start, n)`` batches, in sequence
    order, one at a time (so a target of 10^12 trials costs no memory).

    Parameters
    ----------
    store : Store
    target : int
        Trials the study should hold.
    batch_size : int
    ranges : sequence of (stage, start, end), optional
        Only these sequence ranges, instead of everything up to ``target``.
    """
    spans = list(ranges) if ranges is not None else sample_spans(store, target)
    for stage, start, end in spans:
        yield from _batches(store, stage, start, end, batch_size)


def _batches(
    store: Store, stage: int, start: int, end: int, size: int
) -> Iterator[tuple[int, int, int]]:
    for a, b in store.missing(stage, start, end):
        for s in range(a, b, size):
            yield (stage, s, min(size, b - s))


def _batch_size(work: int, workers: int, parts: int) -> int:
    if work <= 0:
        return 1
    return int(min(1024, max(16, math.ceil(work / (workers * parts)))))


def _hint(message: str, spec: Any) -> str:
    """How to fix a study whose every trial failed with ``message``."""
    names = lambda items: ", ".join(c.name for c in items)  # noqa: E731
    p, k, q = len(spec.space), len(spec.criteria), len(spec.constraints)
    if ("model returned" in message and "shape" in message) or "model returned no" in message:
        return (
            f"the model's output does not fit the study, which has {plural(k, 'criterion')} "
            f"({names(spec.criteria)}) and {plural(q, 'functional constraint')} "
            f"({names(spec.constraints) or 'none'}): make [[criteria]] and [[constraints]] "
            "match the model's output columns, in order"
        )
    if message.startswith("IndexError") or "out of bounds" in message:
        return (
            f"the model reads a column the batch does not have: the study has {p} "
            f"variables ({', '.join(spec.space.names)}) — check [[variables]] against what "
            "the model expects"
        )
    if message.startswith("ModelOutputError"):
        return "make the function the message names return the shape and numbers it expects"
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


class _Run:
    """One run of the driver: the store, the pool, the summary, the first look."""

    def __init__(self, store: Store, summary: RunSummary, pool: Any, keep_going: bool,
                 accept_changes: bool, settings: Any, executor: str) -> None:  # fmt: skip
        self.store = store
        self.executor = executor
        self.run_id: int | None = None
        self.started = False
        self.summary = summary
        self.pool = pool
        self.settings = settings
        self.accept_changes = accept_changes
        self.checked = False
        self.held: list[tuple[int, int, np.ndarray, EvalResult]] | None = None if keep_going else []
        self.seen = 0
        self.bar: Any = None

    def before_write(self) -> None:
        """The input check, then the run's record and settings, once, before the run writes
        anything: a refused run leaves the store as it was."""
        if not self.checked:
            self.checked = True
            self.summary.notes += check_inputs(self.store, accept_changes=self.accept_changes)
        self.begin()
        if self.settings.save:
            self.store.set_study_keys(**self.settings.save)
            self.settings.save = {}

    def begin(self) -> None:
        """Open the run's record in the store's run log."""
        if self.run_id is None:
            self.run_id = self.store.begin_run(
                self.executor, self.pool.workers, self.settings.target
            )

    def store_result(self, stage: int, start: int, X: np.ndarray, res: EvalResult) -> None:
        wrote = self.store.write_batch(
            stage, start, X, res.criteria, res.functionals, res.status, res.wall, res.messages
        )
        if wrote == 0:
            self.summary.duplicates += res.n
            return
        self.summary.stored += wrote
        self.summary.add_failures(start + 1, res)
        self.summary.add_retried(res)
        if self.bar is not None:
            self.bar.update(wrote)

    def release(self) -> None:
        """Store what the first look held back (some trial succeeded, or the look is over)."""
        if self.held is None:
            return
        pending, self.held = self.held, None
        for args in pending:
            self.store_result(*args)

    def evaluate(self, rnd: Round, batch_size: int | None) -> RoundResult:
        """Evaluate and store the trials of ``rnd`` the store does not hold."""
        store = self.store
        stage = rnd.stage
        if isinstance(stage, StageRequest):
            self.before_write()
            stage = store.add_stage(store.spec.space, kind=stage.kind, note=stage.note).stage
        todo = store.missing(stage, rnd.start, rnd.end)
        work = sum(b - a for a, b in todo)
        if rnd.record is not None and not self._recorded(rnd.record):
            self.before_write()
            r = rnd.record
            store.add_sampler_record(r["index"], r["seq_start"], r["n"], r["info"], r["arrays"])
        if not work:
            return RoundResult(stage, 0)
        self.before_write()
        if not self.started:
            self.pool.start()  # now: a Dask cluster says how many threads it has
            self.started = True
        size = rnd.batch or batch_size or _batch_size(work, self.pool.workers, rnd.parts_per_worker)
        inflight: dict[tuple[int, int], np.ndarray] = {}

        def batches() -> Iterator[tuple[tuple[int, int], np.ndarray]]:
            for a, b in todo:
                for s in range(a, b, size):
                    X = np.asarray(rnd.points(s, min(size, b - s)), dtype=float)
                    inflight[(stage, s)] = X
                    yield (stage, s), X

        kept: dict[int, tuple[np.ndarray, EvalResult]] = {}
        limit = min(FIRST_LOOK, work)
        for (st, start), res in self.pool.map_unordered(batches()):
            X = inflight.pop((st, start))
            if rnd.results:
                kept[start] = (X, res)
            if self.held is None:
                self.store_result(st, start, X, res)
                continue
            self.held.append((st, start, X, res))
            self.seen += res.n
            if not np.all(res.status == FAILED):
                self.release()
            elif self.seen >= limit:
                _stop_loudly(store.spec, self.held, self.seen)
        self.release()
        out = RoundResult(stage, work)
        if rnd.results and kept:
            order = sorted(kept)
            out.X = np.concatenate([kept[s][0] for s in order])
            out.result = EvalResult.concatenate([kept[s][1] for s in order])
        return out

    def _recorded(self, record: dict) -> bool:
        """Whether the sampler record ``record`` is in the store already (a resumed run)."""
        return int(record["index"]) < self.store.sampler_record_count()


def run_store(
    store: Store,
    *,
    trials: int | None = None,
    executor: str | None = None,
    workers: int | None = None,
    batch_size: int | None = None,
    progress: bool | TextIO | None = True,
    keep_going: bool = False,
    timeout: float | None = None,
    budget: int | None = None,
    population: int | None = None,
    accept_changes: bool = False,
    search: bool = True,
) -> RunSummary:
    """Run (or resume, or extend) the study held by a writable store, with its sampler.

    Parameters
    ----------
    store : Store
        Opened with ``write=True``.
    trials : int, optional
        Total number of trials the study should hold (default: the study's ``trials``); for a
        sequential study (``sampler = "sequential"``) the size of generation 0. A larger
        number than before extends the study along the same sequence; a smaller one than is
        stored computes nothing and keeps every stored trial (the summary says so).
    executor : {"serial", "processes", "dask", "inline"}, optional
        Default: the study's executor, else ``"processes"``.
    workers : int, optional
        Worker processes (default: all cores).
    batch_size : int, optional
        Trials per batch (default: the study's, else chosen from the work size).
    progress : bool, file or None
        Show progress (on stderr, or on the given file): one line per generation of the
        sequential sampler, and a bar over the trials of the plain table where someone
        watches it (:func:`progress_wanted`: a terminal or a notebook; a pipe or a log file
        gets the lines, not the bar). None: all of it where someone watches, else silent.
    keep_going : bool
        Store the first batches even when every one of their trials failed (see the module
        docstring); default False: stop with :class:`~vectorid.errors.RunFailedError`.
    timeout : float, optional
        Most seconds one trial may take (default: the study's ``timeout``; see
        :mod:`vectorid.run.executors` for how a batch that runs over is split).
    budget, population : int, optional
        Sequential studies only: most model evaluations and members of D wanted (saved in
        the study; default: the study's).
    accept_changes : bool
        When the data files or the model's code changed since the stored trials were
        computed, take the change and record it in the store's history instead of stopping
        (:func:`vectorid.store.inputs.check_inputs`).
    search : bool
        Let the sampler run its extra search when it did not reach what it aims at (the
        sequential sampler's local search).

    Returns
    -------
    RunSummary
        The sampler's kind of summary (a sequential study's says how far D was reached).

    Raises
    ------
    RunInterrupted
        On Ctrl-C, after storing everything already finished.
    RunFailedError
        When every trial of the first batches failed (unless ``keep_going``).
    """
    reload_edited_code(store.spec)  # the model's code as its files are now, not as imported
    sampler = sampler_for(store.spec)
    settings = sampler.configure(store, trials=trials, budget=budget, population=population)
    spec = settings.spec
    stored_before = store.count_sample()
    summary = sampler.new_summary(settings, stored_before)
    if accept_changes:
        summary.notes += check_inputs(store, accept_changes=True)
    executor_name = executor or spec.executor or "processes"
    pool = make_executor(executor_name, spec, workers, timeout=timeout)
    if progress is None:
        progress = progress_wanted()
    out = progress if not isinstance(progress, bool) else sys.stderr
    say = (lambda text: print(text, file=out, flush=True)) if progress else (lambda text: None)
    ctx = RunContext(settings, summary, pool.workers, say, search)
    size = batch_size or spec.batch_size
    bar = None
    run = _Run(store, summary, pool, keep_going, accept_changes, settings, executor_name)
    run.checked = accept_changes
    planned = False
    t0 = time.perf_counter()
    outcome = "completed"
    try:
        with pool:
            rounds = sampler.rounds(store, ctx)
            try:
                rnd = next(rounds)
            except StopIteration:
                rnd = None
            planned = rnd is not None
            while rnd is not None:
                if rnd.bar and progress and bar is None and settings.work and progress_wanted(out):
                    bar = tqdm(total=stored_before + settings.work, initial=stored_before,
                               unit="trial", file=out, dynamic_ncols=True,
                               smoothing=0.1)  # fmt: skip
                    run.bar = bar
                result = run.evaluate(rnd, size)
                try:
                    rnd = rounds.send(result)
                except StopIteration:
                    rnd = None
            run.release()
    except KeyboardInterrupt:
        outcome = "interrupted"
        raise RunInterrupted(summary) from None
    except RunFailedError as exc:
        outcome = f"stopped: {str(exc)[:200]}"
        raise
    except BaseException as exc:
        outcome = f"stopped: {str(exc)[:200]}" if str(exc) else "error"
        raise
    finally:
        summary.elapsed = time.perf_counter() - t0
        summary.total_stored = store.count_sample()
        if bar is not None:
            bar.close()
        if run.run_id is None and outcome == "completed" and planned:
            run.begin()  # a run with nothing to compute is logged too
        if run.run_id is not None:
            store.end_run(run.run_id, outcome, _run_report(summary))
    return summary


def evaluate_into(
    store: Store, stage: int, X: np.ndarray, problem: Problem | None = None
) -> EvalResult:
    """Evaluate ``X`` (n, p) in this process and store it as auxiliary stage ``stage`` from
    sequence index 0 (the trials of a section or a robustness check), through this loop: the
    same input check, write and run log as every run.

    Parameters
    ----------
    store : Store
        Opened for writing.
    stage : int
        An auxiliary stage of the store (not a sample stage).
    X : (n, p) float array
        Parameter vectors, in the study's units.
    problem : Problem, optional
        The study's Problem, when built already (default: built from the study).

    Returns
    -------
    EvalResult
        The trials' criteria, functionals and status.

    Raises
    ------
    StoreError
        When the store was opened read-only.
    InputsChangedError
        When the model's code or a data file changed since the stored trials were computed.
    """
    if not store.writable:
        raise StoreError(
            f"store {store.path} was opened read-only; open it with write=True to add trials"
        )
    spec = store.spec
    X = np.asarray(X, dtype=float)
    pool = make_executor("inline", spec)
    if problem is not None:
        pool.use_problem(problem)
    settings = RunSettings(spec, target=len(X), work=len(X))
    summary = RunSummary(target=len(X), total_stored=store.count_sample())
    run = _Run(store, summary, pool, True, False, settings, "inline")
    outcome = "completed"
    rnd = Round(stage, 0, len(X), lambda s, n: X[s : s + n], batch=max(len(X), 1), results=True,
                bar=False)  # fmt: skip
    try:
        with pool:
            out = run.evaluate(rnd, None)
    except BaseException as exc:
        outcome = f"stopped: {str(exc)[:200]}" if str(exc) else "error"
        raise
    finally:
        if run.run_id is not None:
            store.end_run(run.run_id, outcome, _run_report(summary))
    if out.result is None:  # every trial was stored already
        t = store.load(stages=[stage], kinds=(store.stage_kind(stage),))
        order = np.argsort(t.seq)
        return EvalResult(t.F[order], t.G[order], t.status[order],
                          {i: t.message(int(r)) for i, r in enumerate(order) if t.status[r]},
                          t.wall[order])  # fmt: skip
    return out.result


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


def _stop_loudly(spec: Any, held: list, seen: int) -> None:
    stage, start, _, res = held[0]
    first = int(np.flatnonzero(res.status == FAILED)[0])
    message = res.messages.get(first, "unknown failure (no message)")
    keys = collections.Counter(
        reason_key(r.messages.get(i, "")) for _, _, _, r in held for i in range(r.n)
    )
    same = len(keys) == 1
    raise RunFailedError(
        f"all {seen} trials of the first batch{'es' if len(held) > 1 else ''} failed"
        f"{' the same way' if same else ''}, so the run stopped and stored none of them: "
        f"{message} (trial {start + first + 1}{'' if stage == 0 else f', stage {stage}'}). "
        f"Fix: {_hint(message, spec)}; or run with --keep-going (keep_going=True) to store "
        "failed trials anyway"
    )
