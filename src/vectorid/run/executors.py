"""Executors: where batches of trials are evaluated.

Contract every executor must keep (the shared test suite ``tests/run/test_executors.py``
runs each of them through it):

* :meth:`Executor.map_unordered` takes an iterable of ``(key, X)`` batches and yields
  ``(key, EvalResult)`` for every batch, in any order, each exactly once;
* a trial whose model raises, returns NaN/inf or the wrong shape comes back failed with its
  reason — the executor never stops because of a bad trial;
* a batch whose worker process died (or, with a ``timeout``, ran past its deadline and had
  its worker killed) is re-run one trial at a time in fresh workers ("suspects"), so only the
  guilty trials fail: a single trial that kills a worker twice, or runs past the timeout once,
  comes back failed with the reason; batches running in other workers are not affected;
* executors never touch the store: the run loop alone writes, so a batch evaluated twice is
  still stored once;
* ``close(cancel=True)`` stops quickly (Ctrl-C), dropping batches not yet evaluated.

Executors by name (:data:`EXECUTORS`): ``"serial"`` (this process), ``"processes"`` (local
worker processes) and ``"dask"`` (:mod:`vectorid.run.dask`, imported only when used).

Timeouts. ``timeout`` (study key or ``--timeout``) is the most seconds one trial may take; a
batch of ``n`` trials may take ``n × timeout`` (plus 10 % and 1 s of grace, see
:func:`batch_deadline`), counted from the moment its worker starts on it. The process
executor kills a worker whose batch overruns (``SIGKILL``: it works for a model stuck in
compiled code too) and starts a fresh one; the Dask executor does the same through the
worker's nanny (see :mod:`vectorid.run.dask`). The serial executor runs the model in this
process and cannot stop it: it ignores ``timeout``.
"""

from __future__ import annotations

import abc
import collections
import contextlib
import contextvars
import importlib
import multiprocessing as mp
import multiprocessing.connection as mpc
import os
import signal
import time
import traceback
from collections.abc import Hashable, Iterable, Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import StudyDefinitionError, VectoridError, suggest
from ..problem import FAILED, EvalResult, Problem
from ..spec import StudySpec

__all__ = [
    "EXECUTORS",
    "Executor",
    "ProcessExecutor",
    "SerialExecutor",
    "executor_options",
    "make_executor",
]


class Executor(abc.ABC):
    """Evaluates batches of parameter vectors of one study.

    Parameters
    ----------
    spec : StudySpec
        The study (its model, criteria and constraints).
    workers : int, optional
        Degree of parallelism (ignored by the serial executor).
    timeout : float, optional
        Most seconds one trial may take (default: the study's ``timeout``; None: no limit).
    """

    name = "abstract"

    def __init__(
        self, spec: StudySpec, workers: int | None = None, timeout: float | None = None
    ) -> None:
        self.spec = spec
        self.workers = self._default_workers() if workers is None else int(workers)
        if self.workers < 1:
            raise StudyDefinitionError(
                "--workers", f"expected at least 1 worker, got {workers}", "use --workers 1 or more"
            )
        if timeout is None:
            timeout = getattr(spec, "timeout", None)
        self.timeout = _check_timeout(timeout)

    def _default_workers(self) -> int:
        return 1

    def map_unordered(
        self, batches: Iterable[tuple[Hashable, np.ndarray]]
    ) -> Iterator[tuple[Hashable, EvalResult]]:
        """Evaluate every batch; yield ``(key, result)`` as batches complete."""
        yield from self._map_unordered(iter(batches))

    @abc.abstractmethod
    def _map_unordered(
        self, batches: Iterator[tuple[Hashable, np.ndarray]]
    ) -> Iterator[tuple[Hashable, EvalResult]]:
        """The executor-specific hook behind :meth:`map_unordered`."""

    def close(self, cancel: bool = False) -> None:  # noqa: B027 - optional hook
        """Release workers."""

    def __enter__(self) -> Executor:
        return self

    def __exit__(self, exc_type: Any, *rest: object) -> None:
        self.close(cancel=exc_type is not None)


def _check_timeout(value: Any) -> float | None:
    if value is None:
        return None
    try:
        out = float(value)
    except (TypeError, ValueError):
        out = float("nan")
    if not (out > 0 and np.isfinite(out)) or isinstance(value, bool):
        raise StudyDefinitionError(
            "timeout",
            f"expected a positive number of seconds per trial, got {value!r}",
            "write e.g. timeout = 60 (or leave it out for no limit)",
        )
    return out


class SerialExecutor(Executor):
    """Evaluates batches in this process, one after the other (``timeout`` is ignored: a
    model running in this process cannot be stopped; use ``processes`` or ``dask``)."""

    name = "serial"

    def __init__(
        self, spec: StudySpec, workers: int | None = None, timeout: float | None = None
    ) -> None:
        super().__init__(spec, 1, timeout)
        self._problem: Problem | None = None

    def _map_unordered(self, batches):
        if self._problem is None:
            self._problem = self.spec.problem()
        for key, X in batches:
            yield key, self._problem.evaluate(X)


# -- helpers shared by the process and Dask executors -------------------------------------


def failed_result(n: int, k: int, q: int, reason: str) -> EvalResult:
    """An :class:`EvalResult` of ``n`` trials, all failed with ``reason``."""
    return EvalResult(
        criteria=np.full((n, k), np.nan),
        functionals=np.full((n, q), np.nan),
        status=np.full(n, FAILED, dtype=np.int8),
        messages=dict.fromkeys(range(n), reason),
        wall=np.zeros(n),
    )


@dataclass
class Task:
    """One unit of work sent to a worker: a whole batch, or one trial of a suspect batch.

    ``key`` is the batch's key; ``row`` is None for a whole batch, else the trial's row in
    the batch; ``tries`` counts the worker deaths this task has already caused.
    """

    key: Hashable
    X: np.ndarray
    row: int | None = None
    tries: int = 0


@dataclass
class _Split:
    n: int
    result: EvalResult
    left: int


@dataclass
class SuspectTracker:
    """Re-runs a batch that killed its worker one trial at a time and reassembles it.

    The executor calls :meth:`lost` when a task's worker died or overran its deadline and
    :meth:`done` when a task came back; both return the finished ``(key, EvalResult)`` pairs
    (possibly none) and queue the single-trial tasks still to run in :attr:`queue`.
    """

    k: int
    q: int
    queue: collections.deque = field(default_factory=collections.deque)
    _splits: dict[Hashable, _Split] = field(default_factory=dict)

    def next_task(self, batches: Iterator[tuple[Hashable, np.ndarray]]) -> Task | None:
        """What a free worker runs next: a queued suspect first (so a split batch finishes
        and is stored soon), else the next new batch; None when neither is left."""
        if self.queue:
            return self.queue.popleft()
        for key, X in batches:
            return Task(key, X)
        return None

    def done(self, task: Task, res: EvalResult) -> list[tuple[Hashable, EvalResult]]:
        if task.row is None:
            return [(task.key, res)]
        split = self._splits[task.key]
        r, out = task.row, split.result
        out.criteria[r] = res.criteria[0]
        out.functionals[r] = res.functionals[0]
        out.status[r] = res.status[0]
        out.wall[r] = res.wall[0] if res.wall is not None else 0.0
        if 0 in res.messages:
            out.messages[r] = res.messages[0]
        split.left -= 1
        if split.left == 0:
            del self._splits[task.key]
            return [(task.key, out)]
        return []

    def lost(
        self, task: Task, reason: str, timed_out: bool, retried: bool = False
    ) -> list[tuple[Hashable, EvalResult]]:
        """A task's worker died (``timed_out=False``) or was stopped at its deadline.

        ``retried`` says the task was already re-run after a worker death (Dask does that
        itself), so a single trial fails at once.
        """
        n = len(task.X)
        if task.row is None and n > 1:
            self._splits[task.key] = _Split(n, failed_result(n, self.k, self.q, ""), n)
            self._splits[task.key].result.messages.clear()
            # Suspects run before new batches, so the batch is finished (and stored) soon.
            for r in reversed(range(n)):
                self.queue.appendleft(Task(task.key, task.X[r : r + 1], r, 0))
            return []
        if not timed_out and not retried and task.tries < 1:
            self.queue.appendleft(Task(task.key, task.X, task.row, task.tries + 1))
            return []
        if not timed_out:
            reason += " (twice)" if not retried else " (in every worker that tried it)"
        return self.done(task, failed_result(1, self.k, self.q, reason))


def describe_exception(exc: BaseException) -> str:
    """One line naming an exception and where it came from."""
    tb = traceback.extract_tb(exc.__traceback__)
    where = f" (at {os.path.basename(tb[-1].filename)}:{tb[-1].lineno})" if tb else ""
    text = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
    return f"{type(exc).__name__}: {text}{where}"


CRASH_REASON = (
    "worker process died while evaluating this trial: the model crashed the interpreter "
    "or ran out of memory"
)


def batch_deadline(n: int, timeout: float) -> float:
    """Seconds a batch of ``n`` trials may run: ``n × timeout`` plus 10 % and 1 s of grace
    (so a model that enforces ``timeout`` per trial itself, such as a command-line model,
    reports its own timeouts first)."""
    return 1.1 * n * timeout + 1.0


def timeout_reason(seconds: float) -> str:
    return f"timed out: the trial ran longer than the timeout of {seconds:g} s (worker stopped)"


def memory_reason(used: int, limit: int) -> str:
    return (
        f"worker process stopped: it used {used / 2**20:.0f} MiB, more than the memory limit "
        f"of {limit / 2**20:.0f} MiB (the model leaks memory or needs more)"
    )


def resident_bytes(pid: int) -> int | None:
    """Resident memory of process ``pid`` in bytes (None where it cannot be read)."""
    try:
        with open(f"/proc/{pid}/statm", "rb") as fh:
            return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        pass
    try:
        import psutil

        return int(psutil.Process(pid).memory_info().rss)
    except Exception:
        return None


#: Seconds between two looks at the workers' memory when a memory limit is set.
MEMORY_POLL_S = 0.1


# -- local processes -----------------------------------------------------------------------


def _worker_main(conn: mpc.Connection, spec: StudySpec) -> None:
    """Body of a worker process: build the model once, then evaluate what comes in."""
    # One numba/BLAS thread per worker process: the pool is the parallelism.
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    # Ctrl-C reaches the whole process group: the parent handles it and stops the workers.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        problem = spec.problem()
    except BaseException as exc:
        conn.send(("init-error", str(exc) or describe_exception(exc)))
        return
    conn.send(("ready", os.getpid()))
    while True:
        try:
            X = conn.recv()
        except (EOFError, OSError, KeyboardInterrupt):
            return
        if X is None:
            return
        try:
            conn.send(("result", problem.evaluate(X)))
        except Exception as exc:  # an unpicklable result and the like
            conn.send(("error", describe_exception(exc)))


class _Proc:
    """A worker process, its pipe, and the task it is running."""

    def __init__(self, ctx: Any, spec: StudySpec) -> None:
        self.conn, child = ctx.Pipe(duplex=True)
        self.proc = ctx.Process(target=_worker_main, args=(child, spec), daemon=True)
        self.proc.start()
        child.close()
        self.ready = False
        self.task: Task | None = None
        self.deadline = float("inf")

    def kill(self) -> None:
        with contextlib.suppress(Exception):
            self.proc.kill()
        self.proc.join(5)
        self.conn.close()

    def stop(self) -> None:
        with contextlib.suppress(Exception):
            self.conn.send(None)
        self.proc.join(2)
        if self.proc.is_alive():
            self.kill()
        else:
            self.conn.close()


class ProcessExecutor(Executor):
    """Evaluates batches in local worker processes (default: one per core).

    Workers are started with the ``spawn`` method (safe with numba and BLAS threads) and
    build the study's model once. Each worker runs one batch at a time over its own pipe, so
    the executor knows which batch a dead worker was running: only that batch is re-run (one
    trial at a time), and a batch that overruns ``n × timeout`` seconds has its worker killed
    (``SIGKILL``) and replaced.

    Parameters
    ----------
    spec, workers, timeout
        As for :class:`Executor`.
    memory_limit : int, optional
        Most bytes of resident memory one worker process may use. A worker found above it
        (looked at every 0.1 s while it runs a batch) is killed like one that overran its
        timeout: its batch is re-run one trial at a time and the trial that grows past the
        limit fails with the reason. Default: no limit (the operating system's OOM killer
        is the limit; such a death counts as a crash).
    """

    name = "processes"

    def __init__(
        self,
        spec: StudySpec,
        workers: int | None = None,
        timeout: float | None = None,
        memory_limit: int | None = None,
    ) -> None:
        super().__init__(spec, workers, timeout)
        if memory_limit is not None and not (isinstance(memory_limit, int) and memory_limit > 0):
            raise StudyDefinitionError(
                "memory_limit",
                f"expected a positive number of bytes per worker, got {memory_limit!r}",
                "give e.g. memory_limit=2**31 (2 GiB), or None for no limit",
            )
        self.memory_limit = memory_limit
        if callable(spec.model) and getattr(spec.model, "__module__", "") == "__main__":
            raise StudyDefinitionError(
                "model",
                "a function defined in __main__ cannot be sent to worker processes",
                "move it into a module, or use executor='serial'",
            )
        self._procs: list[_Proc] = []
        self._ctx = mp.get_context("spawn")

    def _default_workers(self) -> int:
        return os.cpu_count() or 1

    def _start_failed(self, p: _Proc, why: str) -> None:
        self._deaths_before_ready += 1
        if self._deaths_before_ready >= 3 * self.workers and not any(w.ready for w in self._procs):
            raise VectoridError(
                f"worker processes die before building the model ({why}); run with "
                "--executor serial to see the error in this process"
            )

    def _map_unordered(self, batches):
        k, q = len(self.spec.criteria), len(self.spec.constraints)
        tracker = SuspectTracker(k, q)
        self._deaths_before_ready = 0
        while len(self._procs) < self.workers:
            self._procs.append(_Proc(self._ctx, self.spec))
        exhausted = False  # no new batches and no suspects left to hand out
        while True:
            # hand work to idle workers: suspects first, then new batches
            for p in self._procs:
                if not p.ready or p.task is not None:
                    continue
                task = tracker.next_task(batches)
                if task is None:
                    exhausted = True
                    break
                try:
                    p.conn.send(task.X)
                except OSError:  # died since; the sentinel reports it below
                    pass
                p.task = task
                p.deadline = (
                    time.monotonic() + batch_deadline(len(task.X), self.timeout)
                    if self.timeout is not None
                    else float("inf")
                )
            busy = [p for p in self._procs if p.task is not None]
            if not busy and exhausted and not tracker.queue:
                return
            wait_for = None
            if any(p.deadline < float("inf") for p in busy):
                wait_for = max(0.0, min(p.deadline for p in busy) - time.monotonic())
            if self.memory_limit is not None and busy:
                wait_for = MEMORY_POLL_S if wait_for is None else min(wait_for, MEMORY_POLL_S)
            handles = [p.conn for p in self._procs] + [p.proc.sentinel for p in self._procs]
            mpc.wait(handles, timeout=wait_for)
            now = time.monotonic()
            for i, p in enumerate(self._procs):
                finished: list[tuple[Hashable, EvalResult]] = []
                dead = False
                msg = None
                over = None
                if self.memory_limit is not None and p.task is not None:
                    used = resident_bytes(p.proc.pid)
                    if used is not None and used > self.memory_limit:
                        over = memory_reason(used, self.memory_limit)
                try:
                    if p.conn.poll():
                        msg = p.conn.recv()
                except (EOFError, OSError):
                    dead = True
                if msg is not None:
                    kind, payload = msg
                    if kind == "ready":
                        p.ready = True
                    elif kind == "init-error":
                        raise StudyDefinitionError(
                            "study.model",
                            f"the worker processes cannot build the model: {payload}",
                            "fix the model reference (vectorid run --executor serial shows "
                            "the error in this process)",
                        )
                    else:
                        task, p.task, p.deadline = p.task, None, float("inf")
                        assert task is not None  # a worker only answers a task
                        res = (
                            payload
                            if kind == "result"
                            else failed_result(len(task.X), k, q, payload)
                        )
                        finished = tracker.done(task, res)
                elif not p.proc.is_alive():
                    dead = True
                if over is not None and p.task is not None and msg is None and not dead:
                    # Stopped for its memory: deterministic, like a timeout (no second try).
                    task = p.task
                    p.kill()
                    self._procs[i] = _Proc(self._ctx, self.spec)
                    finished = tracker.lost(task, over, timed_out=True)
                elif dead or (p.task is not None and now > p.deadline):
                    timed_out = not dead
                    task = p.task
                    p.kill()
                    if not p.ready:
                        self._start_failed(p, f"exit code {p.proc.exitcode}")
                    self._procs[i] = _Proc(self._ctx, self.spec)
                    if task is not None:
                        assert self.timeout is not None or not timed_out
                        reason = timeout_reason(self.timeout) if timed_out else CRASH_REASON
                        finished = tracker.lost(task, reason, timed_out)
                yield from finished

    def close(self, cancel: bool = False) -> None:
        for p in self._procs:
            if cancel or p.task is not None:
                p.kill()
            else:
                p.stop()
        self._procs = []


# -- registry ------------------------------------------------------------------------------

#: Executors by name: a class, or ``"module:Class"`` imported on first use (so importing
#: vectorid never imports Dask).
EXECUTORS: dict[str, type[Executor] | str] = {
    "serial": SerialExecutor,
    "processes": ProcessExecutor,
    "dask": "vectorid.run.dask:DaskExecutor",
}

_OPTIONS: contextvars.ContextVar[dict[str, Any] | None] = contextvars.ContextVar(
    "vectorid_executor_options", default=None
)


@contextlib.contextmanager
def executor_options(**options: Any) -> Iterator[None]:
    """Defaults for :func:`make_executor` within a ``with`` block (``timeout=``,
    ``scheduler=``); None values are ignored. The command line uses it to pass
    ``--timeout`` and ``--scheduler`` through :func:`vectorid.run.run_store`."""
    merged = {**(_OPTIONS.get() or {}), **{k: v for k, v in options.items() if v is not None}}
    token = _OPTIONS.set(merged)
    try:
        yield
    finally:
        _OPTIONS.reset(token)


def executor_class(name: str) -> type[Executor]:
    """The executor class registered under ``name`` (importing it if needed)."""
    try:
        cls = EXECUTORS[name]
    except (KeyError, TypeError):
        raise StudyDefinitionError(
            "--executor", f"unknown executor {name!r}", suggest(str(name), EXECUTORS)
        ) from None
    if isinstance(cls, str):
        module, _, attr = cls.partition(":")
        cls = getattr(importlib.import_module(module), attr)
    return cls


def make_executor(
    name: str, spec: StudySpec, workers: int | None = None, **options: Any
) -> Executor:
    """Executor by name (``"serial"``, ``"processes"``, ``"dask"``).

    Parameters
    ----------
    name : str
    spec : StudySpec
    workers : int, optional
    **options
        ``timeout`` (seconds per trial) for every executor; ``scheduler``
        (``"tcp://HOST:PORT"``) for ``"dask"``. Unset options come from an enclosing
        :func:`executor_options` block, then from the study.
    """
    cls = executor_class(name)
    opts = {**(_OPTIONS.get() or {}), **{k: v for k, v in options.items() if v is not None}}
    scheduler = opts.pop("scheduler", None)
    if scheduler is not None:
        if name != "dask":
            raise StudyDefinitionError(
                "--scheduler",
                f"a scheduler address applies to the dask executor, got executor {name!r}",
                "add --executor dask, or drop --scheduler",
            )
        opts["scheduler"] = scheduler
    unknown = set(opts) - {"timeout", "scheduler"}
    if unknown:
        raise TypeError(f"make_executor() got unknown options {sorted(unknown)}")
    return cls(spec, workers, **opts)
