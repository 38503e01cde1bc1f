"""What becomes of a batch whose model fails, is slow, crashes or leaks: the helpers the
process and Dask executors share (failed results with their reason, single-trial re-runs of a
suspect batch, deadlines, crash and memory reasons).
"""

from __future__ import annotations

import collections
import os
import signal
import traceback
from collections.abc import Hashable, Iterator
from dataclasses import dataclass, field

import numpy as np

from ..problem import FAILED, EvalResult

__all__ = [
    "CRASH_REASON",
    "MEMORY_POLL_S",
    "SuspectTracker",
    "Task",
    "batch_deadline",
    "crash_reason",
    "describe_exception",
    "failed_result",
    "judge_time",
    "memory_reason",
    "resident_bytes",
    "timeout_reason",
]


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
        out.retried += res.retried
        out.retry_lost += int(res.status[0] == FAILED)
        split.left -= 1
        if split.left == 0:
            del self._splits[task.key]
            return [(task.key, out)]
        return []

    def lost(
        self,
        task: Task,
        reason: str,
        timed_out: bool,
        retried: bool = False,
        took: float | None = None,
    ) -> list[tuple[Hashable, EvalResult]]:
        """A task's worker died (``timed_out=False``) or was stopped at its deadline.

        ``retried`` says the task was already re-run after a worker death (Dask does that
        itself), so a single trial fails at once. ``took``: seconds the task ran (the wall
        time of a single trial that fails).
        """
        n = len(task.X)
        if task.row is None and n > 1:
            self._splits[task.key] = _Split(n, failed_result(n, self.k, self.q, ""), n)
            self._splits[task.key].result.messages.clear()
            what = "ran past its time" if timed_out else reason.split(":")[0]
            self._splits[task.key].result.retried.append(f"{what} (batch of {n} trials)")
            # Suspects run before new batches, so the batch is finished (and stored) soon.
            for r in reversed(range(n)):
                self.queue.appendleft(Task(task.key, task.X[r : r + 1], r, 0))
            return []
        if not timed_out and not retried and task.tries < 1:
            self.queue.appendleft(Task(task.key, task.X, task.row, task.tries + 1))
            return []
        if not timed_out:
            reason += " (twice)" if not retried else " (in every worker that tried it)"
        res = failed_result(1, self.k, self.q, reason)
        if took is not None and res.wall is not None:
            res.wall[0] = took
        return self.done(task, res)


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


def crash_reason(exitcode: int | None) -> str:
    """Why a worker process died, from its exit code (negative: killed by that signal)."""
    if exitcode is None:
        return CRASH_REASON
    if exitcode < 0:
        try:
            name = signal.Signals(-exitcode).name
        except ValueError:
            name = "an unknown signal"
        what = {
            "SIGSEGV": "a segmentation fault in the model",
            "SIGBUS": "a bus error in the model",
            "SIGABRT": "the model aborted",
            "SIGKILL": "killed from outside (out of memory?)",
            "SIGFPE": "a floating-point exception in the model",
            "SIGILL": "an illegal instruction in the model",
        }.get(name, "the model crashed the interpreter")
        return (
            f"worker process died while evaluating this trial: killed by signal {-exitcode} "
            f"({name}, {what})"
        )
    return (
        f"worker process died while evaluating this trial: it exited with status {exitcode} "
        "(the model ended the process, e.g. os._exit)"
    )


def batch_deadline(n: int, timeout: float) -> float:
    """Seconds a batch of ``n`` trials may run: ``n × timeout`` (no grace: ``timeout`` is
    the most one trial may take)."""
    return n * timeout


def timeout_reason(seconds: float, took: float | None = None) -> str:
    """Why a trial failed for its time: ``took`` seconds (at least) against ``seconds``."""
    took = seconds if took is None else took
    return f"timed out after {took:.3g} s: the limit is {seconds:g} s per trial (--timeout)"


def judge_time(
    task: Task, res: EvalResult, timeout: float | None, elapsed: float
) -> EvalResult | None:
    """A result that came back after its trials' time ran out, judged as if the clock had
    been looked at in time (see the module docstring). Returns the result to keep (rows
    whose own time — for a batch model, its call's time shared equally — passed ``timeout``
    failed), or None when a batch of several trials ran past ``n × timeout`` and must be
    re-run trial by trial. ``elapsed`` (this process's clock) is used only when the result
    holds no wall times."""
    if timeout is None:
        return res
    n = res.n
    # the worker's own clock (this process may have been busy storing when it came back)
    wall = res.wall if res.wall is not None else np.full(n, elapsed / max(n, 1))
    judged = np.array([str(res.messages.get(i, "")).startswith("timed out") for i in range(n)])
    if n > 1 and float(np.sum(wall[~judged])) > batch_deadline(n, timeout):
        return None
    slow = np.flatnonzero((wall > timeout) & (res.status != FAILED))
    for r in slow:
        res.status[r] = FAILED
        res.criteria[r] = np.nan
        res.functionals[r] = np.nan
        res.messages[int(r)] = timeout_reason(timeout, float(wall[r]))
        if res.wall is not None:
            res.wall[r] = float(wall[r])
    return res


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
