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

Timeouts. ``timeout`` (study key or ``--timeout``) is the most seconds one trial may take,
exactly: a batch of ``n`` trials may take ``n × timeout`` seconds (:func:`batch_deadline`),
counted from the moment its worker starts on it. A batch that runs over has its worker killed
(``SIGKILL``: it works for a model stuck in compiled code too) and is re-run one trial at a
time, each in a fresh worker with ``timeout`` seconds; a trial still running then is stored
as failed, "timed out after X s", with X (its time) as its wall time. A result that comes back
late (between two looks at the clock) is judged the same way: a batch whose time per trial
passed the timeout is re-run trial by trial, and a single trial (or a per-trial model's
trial, timed on its own) that took longer fails with its time. The Dask executor does the
same through the worker's nanny (see :mod:`vectorid.run.dask`). The serial executor runs the
model in one child *model process* (a one-worker process executor), so a timeout, a crash (segfault,
``os._exit``) or ``sys.exit`` in the model fails that trial only, exactly as with
``processes``; only a model that cannot be sent to a child process at all runs in this
process, with a warning that these protections are off.

Starting workers. Worker processes are forked from this process where that is safe (Linux,
no other Python thread running, numba's OpenMP threads not started here): a fork starts in
milliseconds and inherits everything this process has imported, so a cheap model's first
result comes back about as soon as in this process. Elsewhere they are spawned (a fresh
interpreter) without re-running the caller's script: a script that calls ``study.run()``
needs no ``if __name__ == "__main__":`` guard. ``VECTORID_START_METHOD=spawn`` forces
spawning. Workers die with the process that started them (``PR_SET_PDEATHSIG`` on Linux, and
a watchdog thread everywhere), so a killed run leaves no worker computing behind it.

Bounds. More workers than the machine can hold (its available memory at about
:data:`WORKER_MEMORY` per worker, or its open-file limit) are refused with the limit and why;
more workers than cores are allowed with a warning (they share the cores).
"""

from __future__ import annotations

import abc
import contextlib
import contextvars
import ctypes
import importlib
import multiprocessing as mp
import multiprocessing.connection as mpc
import os
import pickle
import resource
import signal
import sys
import threading
import time
import types
import warnings
from collections.abc import Hashable, Iterable, Iterator
from typing import Any

import numpy as np

from ..errors import StudyDefinitionError, VectoridError, VectoridWarning, suggest
from ..problem import EvalResult, Problem
from ..spec import StudySpec
from ..store.lock import close_inherited_locks
from .faults import (
    MEMORY_POLL_S,
    SuspectTracker,
    Task,
    batch_deadline,
    crash_reason,
    describe_exception,
    failed_result,
    judge_time,
    memory_reason,
    resident_bytes,
    timeout_reason,
)

__all__ = [
    "EXECUTORS",
    "WORKER_MEMORY",
    "Executor",
    "InlineExecutor",
    "ProcessExecutor",
    "SerialExecutor",
    "check_workers",
    "end_with_parent",
    "executor_options",
    "make_executor",
]

#: Resident memory of one idle worker process (Python, numpy, scipy and vectorid imported,
#: measured 163 MiB on Linux x86-64), used to bound the number of workers.
WORKER_MEMORY = 160 * 2**20


def _available_memory() -> int | None:
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def usable_cores() -> int:
    """Cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def check_workers(n: int, what: str = "worker processes", option: str = "--workers") -> int:
    """Refuse a worker count the machine cannot hold; warn above the core count.

    Parameters
    ----------
    n : int
        Requested workers.
    what : str
        What they are, for the messages.
    option : str
        The option that set it, for the messages.

    Returns
    -------
    int
        ``n``.
    """
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise StudyDefinitionError(
            option, f"expected at least 1 worker, got {n!r}", f"use {option} 1 or more"
        )
    cores = usable_cores()
    limits = []
    mem = _available_memory()
    if mem is not None:
        limits.append(
            (
                max(1, mem // WORKER_MEMORY),
                f"{mem / 2**30:.1f} GiB of memory available, about "
                f"{WORKER_MEMORY / 2**20:.0f} MiB per worker",
            )
        )
    try:
        soft = resource.getrlimit(resource.RLIMIT_NOFILE)[0]
        if soft != resource.RLIM_INFINITY:
            limits.append((max(1, (soft - 64) // 4), f"open-file limit {soft}, 4 per worker"))
    except (ImportError, ValueError, OSError):
        pass
    for limit, why in sorted(limits):
        if n > limit:
            raise StudyDefinitionError(
                option,
                f"{n} {what} are more than this machine can hold: at most {limit} ({why}; "
                f"{cores} cores)",
                f"use {option} {cores} (one per core) or fewer",
            )
    if n > cores:
        warnings.warn(
            VectoridWarning(
                f"{n} {what} on {cores} cores: they share the cores (no faster than {cores}, "
                f"more memory); {option} {cores} is the most that helps a compute-bound model"
            ),
            stacklevel=3,
        )
    return n


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
        if workers is None:
            self.workers = self._default_workers()
        else:
            if isinstance(workers, bool) or not isinstance(workers, int | np.integer):
                raise StudyDefinitionError(
                    "--workers", f"expected a whole number of workers, got {workers!r}", "use 2"
                )
            self.workers = self._check_workers(int(workers))
        if timeout is None:
            timeout = getattr(spec, "timeout", None)
        self.timeout = _check_timeout(timeout)

    def _default_workers(self) -> int:
        return 1

    def _check_workers(self, n: int) -> int:
        """Bound a requested worker count (see :func:`check_workers`)."""
        return check_workers(n)

    def start(self) -> None:  # noqa: B027 - optional hook
        """Start the workers now (they are started on first use otherwise); the run loop
        calls it before anything else starts a thread (a progress bar), so that workers can
        be forked."""

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


# -- local processes -----------------------------------------------------------------------

#: Serialises the moments when this module swaps ``sys.modules["__main__"]`` to spawn.
_START_LOCK = threading.Lock()


def start_method() -> str:
    """``"fork"`` where forking this process is safe now, else ``"spawn"`` (see the module
    docstring); ``VECTORID_START_METHOD`` overrides it."""
    forced = os.environ.get("VECTORID_START_METHOD", "").strip()
    if forced in ("fork", "spawn", "forkserver"):
        return forced
    if not sys.platform.startswith("linux"):
        return "spawn"
    if threading.active_count() > 1:
        return "spawn"
    parallel = sys.modules.get("numba.np.ufunc.parallel")
    if parallel is not None and getattr(parallel, "_is_initialized", False):
        return "spawn"  # numba's threads (GNU OpenMP) are not safe across a fork
    return "fork"


def _needs_main(spec: StudySpec) -> bool:
    """Whether the model is defined in the caller's script (``__main__``)."""
    model = spec.model
    return callable(model) and getattr(model, "__module__", "") in ("__main__", "__mp_main__")


@contextlib.contextmanager
def _main_hidden() -> Iterator[None]:
    """Spawn without re-running the caller's script in the child: multiprocessing prepares a
    spawned child by running ``__main__`` from its path, which re-runs a script that has no
    ``if __name__ == "__main__":`` guard. Our workers never need it (a model defined there
    travels by value), so the child is prepared from a stand-in module."""
    with _START_LOCK:
        real = sys.modules.get("__main__")
        sys.modules["__main__"] = types.ModuleType("__main__")
        try:
            yield
        finally:
            if real is not None:
                sys.modules["__main__"] = real


def _set_parent_death_signal() -> None:
    """Linux: have the kernel kill this process when the thread that started it ends."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


def _watch_parent(parent: int) -> None:
    """A daemon thread that ends this process when its parent ``parent`` is gone."""

    def watch() -> None:
        while True:
            time.sleep(0.5)
            if os.getppid() != parent:
                os._exit(0)

    threading.Thread(target=watch, name="vectorid-parent-watch", daemon=True).start()


def end_with_parent(parent: int, *, pdeathsig: bool = True) -> None:
    """Make this (child) process end when its parent ``parent`` does: the kernel's parent
    death signal where it applies (Linux; the parent must have started this process from the
    thread that stays alive), and a watchdog thread everywhere. For the long-lived helper
    processes vectorid starts (executor workers, the UI's job worker)."""
    if pdeathsig:
        _set_parent_death_signal()
    if os.getppid() != parent:  # the parent died before we got here
        os._exit(0)
    _watch_parent(parent)


def _worker_main(
    conn: mpc.Connection,
    spec: StudySpec | bytes,
    parent: int,
    pdeathsig: bool,
    one_thread: bool = True,
) -> None:
    """Body of a worker process: build the model once, then evaluate what comes in."""
    end_with_parent(parent, pdeathsig=pdeathsig)

    close_inherited_locks()
    if one_thread:  # one numba/BLAS thread per worker process: the pool is the parallelism
        os.environ.setdefault("OMP_NUM_THREADS", "1")
    # Ctrl-C reaches the whole process group: the parent handles it and stops the workers.
    signal.signal(signal.SIGINT, signal.SIG_IGN)

    def send(msg: Any) -> bool:
        try:
            conn.send(msg)
            return True
        except (OSError, EOFError):  # the parent is gone: leave quietly
            return False

    try:
        if isinstance(spec, bytes):
            import cloudpickle

            spec = cloudpickle.loads(spec)
        problem = spec.problem()
        if one_thread and "numba" in sys.modules:
            # numba reads its thread count when imported (before OMP_NUM_THREADS above, in a
            # spawned worker): one thread per worker, or a parallel kernel in each of N
            # workers starts N threads more on N cores
            sys.modules["numba"].set_num_threads(1)
    except BaseException as exc:
        # A definition error already says what to fix; anything else is described.
        text = str(exc) if isinstance(exc, VectoridError) else describe_exception(exc)
        send(("init-error", (isinstance(exc, VectoridError), text)))
        return
    if not send(("ready", os.getpid())):
        return
    while True:
        try:
            X = conn.recv()
        except (EOFError, OSError, KeyboardInterrupt):
            return
        if X is None:
            return
        try:
            res = problem.evaluate(X)
        except BaseException as exc:  # evaluate catches the model's own errors
            if not send(("error", describe_exception(exc))):
                return
            continue
        try:
            conn.send(("result", res))
        except (OSError, EOFError):
            return
        except Exception as exc:  # an unpicklable result and the like
            if not send(("error", describe_exception(exc))):
                return


class _Proc:
    """A worker process, its pipe, and the task it is running."""

    def __init__(self, ctx: Any, payload: StudySpec | bytes, one_thread: bool = True) -> None:
        self.conn, child = ctx.Pipe(duplex=True)
        main_thread = threading.current_thread() is threading.main_thread()
        self.proc = ctx.Process(
            target=_worker_main,
            args=(child, payload, os.getpid(), main_thread, one_thread),
            daemon=True,
        )
        if ctx.get_start_method() == "fork":
            self.proc.start()
        else:
            with _main_hidden():
                self.proc.start()
        child.close()
        self.ready = False
        self.task: Task | None = None
        self.deadline = float("inf")
        self.started = 0.0

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

    Workers are forked where that is safe, else spawned (see the module docstring), and
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
        self._procs: list[_Proc] = []
        self._ctx: Any = None
        self._payload: StudySpec | bytes = spec
        self._method = ""

    def _default_workers(self) -> int:
        return usable_cores()

    def _prepare(self) -> None:
        """Choose how workers start and what they receive (once, before the first)."""
        if self._ctx is not None:
            return
        method = start_method()
        payload: StudySpec | bytes = self.spec
        if method != "fork" and _needs_main(self.spec):
            try:
                import cloudpickle
            except ImportError:
                raise StudyDefinitionError(
                    "model",
                    "the model is a function defined in the script being run (__main__), "
                    "which worker processes started by 'spawn' cannot import (cloudpickle, "
                    "which could send it, is not installed)",
                    "move the function into a module, or run with executor='serial'",
                ) from None
            payload = cloudpickle.dumps(self.spec)
        self._method = method
        self._payload = payload
        self._ctx = mp.get_context(method)

    #: Worker processes run numba/BLAS on one thread (the pool is the parallelism).
    one_thread = True

    def _new_proc(self) -> _Proc:
        self._prepare()
        return _Proc(self._ctx, self._payload, self.one_thread)

    def start(self) -> None:
        while len(self._procs) < self.workers:
            self._procs.append(self._new_proc())

    def _start_failed(self, p: _Proc, why: str) -> None:
        self._deaths_before_ready += 1
        if self._deaths_before_ready >= 3 * self.workers and not any(w.ready for w in self._procs):
            raise VectoridError(
                f"worker processes die before building the model ({why}); run one trial in "
                "Python (spec.problem().evaluate(X)) to see the error"
            )

    def _map_unordered(self, batches):
        k, q = len(self.spec.criteria), len(self.spec.constraints)
        tracker = SuspectTracker(k, q)
        self._deaths_before_ready = 0
        self.start()
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
                p.started = time.monotonic()
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
                        raise _init_error(payload)
                    else:
                        task, p.task, p.deadline = p.task, None, float("inf")
                        if task is None:  # pragma: no cover - a worker only answers a task
                            continue
                        res = (
                            payload
                            if kind == "result"
                            else failed_result(len(task.X), k, q, payload)
                        )
                        judged = judge_time(task, res, self.timeout, now - p.started)
                        if judged is None:  # a batch past its time: re-run trial by trial
                            finished = tracker.lost(
                                task, timeout_reason(self.timeout), timed_out=True
                            )
                        else:
                            finished = tracker.done(task, judged)
                elif not p.proc.is_alive():
                    dead = True
                if over is not None and p.task is not None and msg is None and not dead:
                    # Stopped for its memory: deterministic, like a timeout (no second try).
                    task = p.task
                    p.kill()
                    self._procs[i] = self._new_proc()
                    finished = tracker.lost(task, over, timed_out=True)
                elif dead or (p.task is not None and now > p.deadline):
                    timed_out = not dead
                    task = p.task
                    p.kill()
                    if not p.ready:
                        self._start_failed(p, _exit_text(p.proc.exitcode))
                    self._procs[i] = self._new_proc()
                    if task is not None:
                        took = now - p.started
                        reason = (
                            timeout_reason(self.timeout, took)
                            if timed_out and self.timeout is not None
                            else crash_reason(p.proc.exitcode)
                        )
                        finished = tracker.lost(
                            task, reason, timed_out, took=took if timed_out else None
                        )
                yield from finished

    def close(self, cancel: bool = False) -> None:
        for p in self._procs:
            if cancel or p.task is not None:
                p.kill()
            else:
                p.stop()
        self._procs = []


def _init_error(payload: Any) -> VectoridError:
    """The error a worker reported while building the model, raised in the parent."""
    definition, text = payload if isinstance(payload, tuple) else (False, str(payload))
    if definition:
        return VectoridError(text)
    return StudyDefinitionError(
        "study.model",
        f"the worker processes cannot build the model: {text}",
        "fix the model or its module (the message says where)",
    )


def _exit_text(code: int | None) -> str:
    if code is None:
        return "exit code unknown"
    if code < 0:
        try:
            return f"killed by signal {-code} ({signal.Signals(-code).name})"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit code {code}"


class SerialExecutor(ProcessExecutor):
    """Evaluates batches one after the other in one child *model process*.

    The model runs outside this process, so a trial that hangs past ``timeout``, crashes the
    interpreter (segfault, ``os._exit``) or calls ``sys.exit`` fails alone with its reason and
    the study goes on, as with ``processes``. A model that cannot be sent to a child process
    (a spawned one needs it picklable) runs in this process instead, with a
    :class:`~vectorid.errors.VectoridWarning` that timeouts and crashes are then not caught.
    """

    name = "serial"
    #: The one model process may use every core (a compiled model parallel over trials).
    one_thread = False

    def __init__(
        self,
        spec: StudySpec,
        workers: int | None = None,
        timeout: float | None = None,
        memory_limit: int | None = None,
    ) -> None:
        super().__init__(spec, 1, timeout, memory_limit)
        self._inline: Problem | None = None

    def _check_workers(self, n: int) -> int:
        return 1

    def _prepare(self) -> None:
        if self._ctx is not None:
            return
        super()._prepare()
        if self._method == "fork" or isinstance(self._payload, bytes):
            return

        try:
            pickle.dumps(self.spec)
        except Exception as exc:
            raise _Inline(describe_exception(exc)) from None

    def start(self) -> None:
        if self._inline is not None:
            return
        try:
            super().start()
        except _Inline as why:
            warnings.warn(
                VectoridWarning(
                    f"the model cannot be sent to a model process ({why}); it runs in this "
                    "process, where a timeout, a crash or sys.exit in the model is not caught"
                ),
                stacklevel=2,
            )
            self._inline = self.spec.problem()

    def _map_unordered(self, batches):
        self.start()
        if self._inline is None:
            yield from super()._map_unordered(batches)
            return
        for key, X in batches:
            yield key, self._inline.evaluate(X)


class _Inline(Exception):
    """The model cannot be sent to a child process (internal)."""


class InlineExecutor(SerialExecutor):
    """Evaluates batches one after the other in this process, with no model process.

    For a model that only this process can build: a function whose module keeps state the
    calling script set up (the real-parafoil examples), or one that cannot be imported or
    pickled by a fresh interpreter. Nothing protects the study from the model: a timeout is
    not enforced, and a crash or ``sys.exit`` in the model ends the run (what was stored
    stays stored; ``vectorid run STORE`` resumes). Use ``serial`` when the model can run in
    a child process.
    """

    name = "inline"

    def __init__(
        self,
        spec: StudySpec,
        workers: int | None = None,
        timeout: float | None = None,
        memory_limit: int | None = None,
    ) -> None:
        if timeout is not None:
            raise StudyDefinitionError(
                "timeout",
                f"executor 'inline' runs the model in this process and cannot stop a trial "
                f"after {timeout:g} s",
                "use executor 'serial' (one model process) for a timeout, or drop it",
            )
        super().__init__(spec, workers, None, memory_limit)

    def start(self) -> None:
        if self._inline is None:
            self._inline = self.spec.problem()

    def use_problem(self, problem: Problem) -> None:
        """Evaluate with ``problem`` (the study's, built already by the caller)."""
        self._inline = problem


# -- registry ------------------------------------------------------------------------------

#: Executors by name: a class, or ``"module:Class"`` imported on first use (so importing
#: vectorid never imports Dask).
EXECUTORS: dict[str, type[Executor] | str] = {
    "serial": SerialExecutor,
    "inline": InlineExecutor,
    "processes": ProcessExecutor,
    "dask": "vectorid.run.dask:DaskExecutor",
}

_OPTIONS: contextvars.ContextVar[dict[str, Any] | None] = contextvars.ContextVar(
    "vectorid_executor_options", default=None
)


@contextlib.contextmanager
def executor_options(**options: Any) -> Iterator[None]:
    """Defaults for :func:`make_executor` within a ``with`` block (``timeout=``,
    ``scheduler=``, ``workers=``); None values are ignored. The command line uses it to pass
    ``--timeout``, ``--scheduler`` and (through workflows that run several studies, such as
    the demos) ``--workers`` to every run of :func:`vectorid.run.run_store`."""
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
        (``"tcp://HOST:PORT"``) for ``"dask"``. Unset options (and ``workers``) come from an
        enclosing :func:`executor_options` block, then from the study.
    """
    cls = executor_class(name)
    opts = {**(_OPTIONS.get() or {}), **{k: v for k, v in options.items() if v is not None}}
    in_block = opts.pop("workers", None)
    if workers is None:
        workers = in_block if in_block is not None else getattr(spec, "workers", None)
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
