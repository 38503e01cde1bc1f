"""The Dask executor: batches of trials on a Dask cluster (``--executor dask``).

Without an address it starts a :class:`distributed.LocalCluster` on this machine (worker
processes with one thread each, default one per core); with ``--scheduler tcp://HOST:PORT``
(or ``scheduler = "tcp://HOST:PORT"`` under ``[study]``) it connects to a running cluster,
whose workers must be able to import the model (the same Python environment and the study's
model module or files, at the same paths).

How it keeps the executor contract (see :mod:`vectorid.run.executors`):

* **Tasks.** One task is one batch from the run loop (the loop already sizes batches to
  amortise the per-task overhead of a few milliseconds); at most ``2 × threads`` tasks are in
  flight, so a study of millions of trials never floods the scheduler.
* **The model runs in a model process**: each worker thread starts, on its first task, one
  child process (a one-worker :class:`~vectorid.run.executors.ProcessExecutor`) that builds
  the model once and evaluates every batch the thread gets. The study definition travels with
  every task as a small pickled blob; the model process is cached by the blob's hash. So
  pure-Python model code never competes for the GIL with the worker's event loop (it did:
  10-15 % slower), and a model that crashes, hangs past its ``timeout`` or grows past the
  worker's memory limit (divided among its threads) loses that process, not the worker: the
  batch is re-run one trial at a time in fresh model processes and only the guilty trial
  fails, exactly as with ``--executor processes``. Workers that cannot start children
  (daemonic, see :class:`DaskExecutor`) and models defined in ``__main__`` run in the
  worker itself instead, with the timeouts below.
* **The client alone writes to the store** (the run loop does); workers only compute.
* **Lost workers.** On the local cluster every task a dying worker held comes back at once as
  ``KilledWorker`` (``distributed.scheduler.allowed-failures = 0``; a cluster you connect to
  keeps its own setting). Its batch is then re-run one trial at a time, and each suspect trial
  runs *alone* on the cluster, so when it kills its worker again no innocent task queued on
  that worker is blamed with it. A single trial gets one more try as a fresh task before it is
  failed. Tasks are submitted with ``retries=1`` for exceptions outside the model. Whatever ran
  twice is stored once: the store refuses a batch whose range is stored.
* **Timeouts without a model process.** With ``timeout`` the worker runs the model in a helper
  thread and stops waiting after ``n × timeout`` seconds: the batch comes back "timed out",
  the client restarts that worker through its nanny (a Python thread cannot be killed, a
  process can) and re-runs the batch one trial at a time; a single trial that overruns is
  failed. A model stuck in compiled code that never releases the GIL also blocks the worker's
  watchdog; Dask then notices the unresponsive worker only through its own heartbeat timeout.
"""

from __future__ import annotations

import contextlib
import hashlib
import logging
import multiprocessing as mp
import os
import threading
import uuid
from collections.abc import Hashable, Iterator
from typing import Any

import numpy as np

from ..errors import StudyDefinitionError, VectoridError
from ..problem import EvalResult, Problem
from ..spec import StudySpec, check_scheduler_address
from ..store.inputs import code_hashes
from .executors import Executor, ProcessExecutor
from .faults import (
    CRASH_REASON,
    SuspectTracker,
    Task,
    batch_deadline,
    describe_exception,
    failed_result,
    judge_time,
    timeout_reason,
)

__all__ = ["DaskExecutor", "import_distributed"]

INSTALL_HINT = "pip install 'vectorid[dask]'"


def import_distributed() -> Any:
    """Import :mod:`distributed`, or say how to install it."""
    try:
        import distributed
    except ImportError as exc:
        raise VectoridError(
            f"the dask executor needs dask.distributed, which cannot be imported ({exc}); "
            f"install it with {INSTALL_HINT}, or use --executor processes"
        ) from None
    return distributed


# -- worker side ---------------------------------------------------------------------------

_PROBLEMS: dict[str, Problem] = {}
_BUILDS: dict[str, int] = {}
#: Model processes of this worker, by (study token, timeout, worker thread).
_MODEL_PROCESSES: dict[tuple[str, float | None, int], ProcessExecutor] = {}


def _problem(token: str, blob: bytes) -> Problem:
    """The study's Problem, built once per worker process (cached by ``token``)."""
    problem = _PROBLEMS.get(token)
    if problem is None:
        import cloudpickle

        spec = cloudpickle.loads(blob)
        os.environ.setdefault("OMP_NUM_THREADS", "1")
        problem = _PROBLEMS[token] = spec.problem()
        _BUILDS[token] = _BUILDS.get(token, 0) + 1
    return problem


def build_counts() -> dict[str, int]:
    """How often this worker process built each study's model, in its model processes or
    itself (for tests)."""
    return dict(_BUILDS)


def _memory_share() -> int | None:
    """This worker's memory limit divided among its threads (bytes; None: no limit)."""
    try:
        from distributed import get_worker

        worker = get_worker()
        limit = worker.memory_manager.memory_limit
        return int(limit // max(1, worker.state.nthreads)) if limit else None
    except Exception:  # not in a worker (tests calling the task directly)
        return None


def _model_process(token: str, blob: bytes, timeout: float | None) -> ProcessExecutor | None:
    """This worker thread's model process for the study ``token`` (started on first use).

    None where the worker cannot start child processes (a daemonic worker process, see
    :class:`DaskExecutor`) or the model cannot be sent to one (a function defined in
    ``__main__``): the task then runs the model in the worker itself.
    """
    key = (token, timeout, threading.get_ident())
    ex = _MODEL_PROCESSES.get(key)
    if ex is None:
        if mp.current_process().daemon:
            return None
        import cloudpickle

        spec = cloudpickle.loads(blob)
        try:
            ex = ProcessExecutor(spec, workers=1, timeout=timeout, memory_limit=_memory_share())
        except StudyDefinitionError:
            return None
        _MODEL_PROCESSES[key] = ex
        _BUILDS[token] = _BUILDS.get(token, 0) + 1
    return ex


def _evaluate_task(
    token: str, blob: bytes, X: np.ndarray, timeout: float | None, isolate: bool = True
) -> tuple[str, Any]:
    """A Dask task: evaluate one batch. Returns ``(kind, payload)``."""
    if isolate:
        try:
            ex = _model_process(token, blob, timeout)
        except Exception as exc:
            return "init-error", f"{exc} [on {_where()}]"
        if ex is not None:
            try:
                ((_, res),) = list(ex.map_unordered([(0, X)]))
            except VectoridError as exc:  # the model process cannot build the model
                _MODEL_PROCESSES.pop((token, timeout, threading.get_ident()), None)
                ex.close(cancel=True)
                return "init-error", f"{exc} [on {_where()}]"
            return "result", res
    try:
        problem = _problem(token, blob)
    except Exception as exc:
        return "init-error", f"{exc} [on {_where()}]"
    if timeout is None:
        return "result", problem.evaluate(X)
    box: dict[str, Any] = {}

    def run() -> None:
        try:
            box["result"] = problem.evaluate(X)
        except BaseException as exc:  # pragma: no cover - evaluate never raises for a trial
            box["error"] = describe_exception(exc)

    helper = threading.Thread(target=run, name="vectorid-model", daemon=True)
    helper.start()
    helper.join(batch_deadline(len(X), timeout))
    if helper.is_alive():
        # The helper thread cannot be stopped: forget this (busy) model and ask the client
        # to restart the worker process.
        _PROBLEMS.pop(token, None)
        return "timeout", _where()
    if "error" in box:  # pragma: no cover
        return "error", box["error"]
    return "result", box["result"]


#: Preload of the local cluster's workers (``distributed.worker.preload``, given as the text
#: of a module so that a starting worker imports nothing heavy): Ctrl-C in the terminal
#: reaches the whole process group and the client stops the cluster, so a worker ignores it
#: (no KeyboardInterrupt traceback from each worker); and a worker ends when the process that
#: started the cluster is gone (killed with ``kill -9``) instead of computing on.
WORKER_PRELOAD = """
import os, signal, threading, time


def dask_setup(worker):
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    except ValueError:  # not the main thread
        pass
    parent = os.getppid()

    def watch():
        while True:
            time.sleep(0.5)
            if os.getppid() != parent:
                os._exit(0)

    threading.Thread(target=watch, name="vectorid-parent-watch", daemon=True).start()
"""


def _code_on_worker(blob: bytes) -> dict[str, str]:
    """``{file: sha256}`` of the model code as this worker sees it (see
    :func:`vectorid.store.inputs.code_hashes`)."""
    import cloudpickle

    spec = cloudpickle.loads(blob)
    return {k: str(v.get("sha256")) for k, v in code_hashes(spec).items()}


def _where() -> str:
    try:
        from distributed import get_worker

        return get_worker().address
    except Exception:  # not in a worker (tests calling the task directly)
        return f"pid {os.getpid()}"


# -- client side ---------------------------------------------------------------------------


class DaskExecutor(Executor):
    """Evaluates batches on a Dask cluster (a local one when no scheduler is given).

    Parameters
    ----------
    spec : StudySpec
    workers : int, optional
        Worker processes of the local cluster (default: one per core); ignored when
        connecting to a scheduler (the cluster's threads count instead).
    timeout : float, optional
        Most seconds one trial may take (default: the study's ``timeout``).
    scheduler : str, optional
        ``"tcp://HOST:PORT"`` of a running scheduler (default: the study's ``scheduler``,
        else a new local cluster).
    cluster_kwargs : dict, optional
        Extra arguments of :class:`distributed.LocalCluster` (e.g. ``memory_limit``).
    isolate : bool, optional
        Run the model in a model process of each worker thread (default True): pure-Python
        models then do not share the GIL with the worker's event loop, a timeout or a memory
        leak stops that process instead of the worker, and a crash kills it alone. Workers
        that are daemonic processes (``dask worker`` with a nanny, by default) cannot start
        one and run the model themselves; start them with
        ``DASK_DISTRIBUTED__WORKER__DAEMON=False`` (the local cluster does this).
    """

    name = "dask"
    #: Seconds to wait for the scheduler when connecting.
    connect_timeout = 10.0

    def __init__(
        self,
        spec: StudySpec,
        workers: int | None = None,
        timeout: float | None = None,
        scheduler: str | None = None,
        cluster_kwargs: dict[str, Any] | None = None,
        isolate: bool = True,
    ) -> None:
        self._distributed = import_distributed()
        self.isolate = bool(isolate)
        self._config: Any = None
        self.scheduler = scheduler if scheduler is not None else getattr(spec, "scheduler", None)
        self._cluster: Any = None
        self._client: Any = None
        self._cluster_kwargs = dict(cluster_kwargs or {})
        super().__init__(spec, workers, timeout)
        if self.scheduler is not None:
            # Connect now: the run loop sizes batches from the cluster's thread count.
            self._connect()
            self.workers = max(1, sum(self._client.nthreads().values()))

    def _default_workers(self) -> int:
        return os.cpu_count() or 1

    def _connect(self) -> Any:
        if self._client is not None:
            return self._client
        dist = self._distributed
        import dask

        if self.scheduler is None:
            kwargs = {
                "n_workers": self.workers,
                "threads_per_worker": 1,
                "processes": True,
                "dashboard_address": None,
                "silence_logs": logging.ERROR,
            }
            kwargs.update(self._cluster_kwargs)
            config = {
                # A task on a worker that died comes back at once as KilledWorker; the
                # executor then re-runs it trial by trial, alone (see _map_unordered).
                "distributed.scheduler.allowed-failures": 0,
                # A one-thread worker running a pure-Python model shares the GIL with its
                # event loop: Dask's profiler (every 10 ms), tick (20 ms), memory (100 ms) and
                # system (500 ms) monitors slowed such a model by 10-25 % here. Sample less.
                "distributed.worker.profile.enabled": False,
                "distributed.admin.tick.interval": "1s",
                "distributed.admin.system-monitor.interval": "2s",
                "distributed.worker.memory.monitor-interval": "500ms",
                # Workers may start model processes (isolate=True). Held while the executor
                # lives, so that a worker the nanny restarts gets it too.
                "distributed.worker.daemon": False,
                # Workers ignore Ctrl-C and end with this process.
                "distributed.worker.preload": [WORKER_PRELOAD],
            }
            self._config = dask.config.set(config)
            self._config.__enter__()
            try:
                self._cluster = dist.LocalCluster(**kwargs)
                self._client = dist.Client(self._cluster)
            except BaseException:
                self.close(cancel=True)
                raise
        else:
            check_scheduler_address(self.scheduler)
            try:
                self._client = dist.Client(self.scheduler, timeout=self.connect_timeout)
            except (OSError, TimeoutError, ValueError) as exc:
                raise StudyDefinitionError(
                    "--scheduler",
                    f"cannot reach the Dask scheduler at {self.scheduler!r} ({exc})",
                    "start it (`dask scheduler` and `dask worker ADDRESS`), check the address, "
                    "or leave --scheduler out to use a local cluster",
                ) from None
            try:
                self._client.wait_for_workers(1, timeout=60)
            except (OSError, TimeoutError):
                self.close(cancel=True)
                raise StudyDefinitionError(
                    "--scheduler",
                    f"the Dask scheduler at {self.scheduler!r} has no workers (waited 60 s)",
                    "start workers with `dask worker ADDRESS`",
                ) from None
        return self._client

    def _map_unordered(self, batches: Iterator[tuple[Hashable, np.ndarray]]):
        import cloudpickle

        dist = self._distributed
        client = self._connect()
        killed_worker = getattr(dist, "KilledWorker", None)
        if killed_worker is None:  # pragma: no cover - older distributed
            from distributed.scheduler import KilledWorker as killed_worker
        blob = cloudpickle.dumps(self.spec)
        token = hashlib.sha1(blob).hexdigest()
        self._check_worker_code(client, blob)
        k, q = len(self.spec.criteria), len(self.spec.constraints)
        tracker = SuspectTracker(k, q)
        threads = sum(client.nthreads().values()) or self.workers
        limit = max(2, 2 * threads)
        inflight: dict[str, tuple[Any, Task]] = {}
        self._inflight = inflight
        done = dist.as_completed()

        def top_up() -> None:
            while len(inflight) < limit:
                # After a worker died, its batches are re-run one trial at a time and each
                # suspect trial runs alone: when it kills its worker again, no innocent task
                # queued on that worker is blamed with it.
                if any(t.row is not None for _, t in inflight.values()):
                    return
                if tracker.queue and inflight:
                    return
                task = tracker.next_task(batches)
                if task is None:
                    return
                fut = client.submit(
                    _evaluate_task,
                    token,
                    blob,
                    task.X,
                    self.timeout,
                    self.isolate,
                    pure=False,
                    retries=1,
                    key=f"vectorid-batch-{uuid.uuid4().hex}",
                )
                inflight[fut.key] = (fut, task)
                done.add(fut)

        top_up()
        while inflight:
            fut = next(done)
            _, task = inflight.pop(fut.key)
            finished: list[tuple[Hashable, EvalResult]]
            try:
                kind, payload = fut.result()
            except killed_worker:
                # A task waiting on a worker behind the guilty one is blamed too when the
                # worker dies, so a single trial gets one more try (a fresh task) before it
                # is failed.
                finished = tracker.lost(task, CRASH_REASON, timed_out=False)
            except Exception as exc:
                if fut.status == "cancelled" or isinstance(exc, OSError | TimeoutError):
                    raise VectoridError(
                        f"lost the Dask cluster ({describe_exception(exc)}); everything "
                        "finished so far is stored: run the same command again to resume"
                    ) from exc
                finished = tracker.done(
                    task, failed_result(len(task.X), k, q, describe_exception(exc))
                )
            else:
                if kind == "init-error":
                    raise StudyDefinitionError(
                        "study.model",
                        f"the Dask workers cannot build the model: {payload}",
                        "make the model importable on every worker (same environment and "
                        "files), or run with --executor processes",
                    )
                if kind == "timeout":
                    assert self.timeout is not None
                    self._restart(payload)
                    finished = tracker.lost(task, timeout_reason(self.timeout), timed_out=True)
                elif kind == "error":
                    finished = tracker.done(task, failed_result(len(task.X), k, q, payload))
                else:
                    judged = judge_time(task, payload, self.timeout, 0.0)
                    if judged is None:  # a batch past n x timeout: re-run trial by trial
                        assert self.timeout is not None
                        finished = tracker.lost(task, timeout_reason(self.timeout), True)
                    else:
                        finished = tracker.done(task, judged)
            fut.release()
            yield from finished
            top_up()

    def _check_worker_code(self, client: Any, blob: bytes) -> None:
        """Refuse to run when a worker's copy of the model code differs from this machine's
        (the code the store records): its trials would come from another model. A worker
        that finds no source file of the model cannot be compared (it reports an error of
        its own if it cannot build the model)."""

        here = {k: str(v.get("sha256")) for k, v in code_hashes(self.spec).items()}
        if not here:
            return
        try:
            seen = client.run(_code_on_worker, blob)
        except Exception as exc:  # a worker without vectorid, ...: building reports it
            logging.getLogger(__name__).info("model code not compared on workers: %s", exc)
            return
        for address, theirs in sorted(seen.items()):
            if not theirs or set(theirs.values()) == set(here.values()):
                continue
            diff = sorted({*here, *theirs} - {k for k in here if theirs.get(k) == here[k]})
            raise StudyDefinitionError(
                "study.model",
                f"Dask worker {address} has other model code than this machine "
                f"(differs: {', '.join(diff[:4])}); its trials would not match the store's",
                "give every worker the same model files (the same project checkout), or run "
                "with --executor processes",
            )

    def _restart(self, address: str) -> None:
        """Restart a worker whose model thread is stuck (through its nanny)."""
        try:
            self._client.restart_workers([address], timeout=60, raise_for_error=False)
        except Exception as exc:  # no nanny, or the worker left already
            logging.getLogger(__name__).warning(
                "could not restart Dask worker %s after a timeout (%s); its stuck model "
                "thread keeps running",
                address,
                exc,
            )

    def close(self, cancel: bool = False) -> None:
        inflight = getattr(self, "_inflight", {})
        if self._client is not None:
            with contextlib.suppress(Exception):
                if inflight:
                    self._client.cancel([f for f, _ in inflight.values()], force=True)
            inflight.clear()
            with contextlib.suppress(Exception):
                self._client.close(timeout=10)
            self._client = None
        if self._cluster is not None:
            with contextlib.suppress(Exception):
                self._cluster.close(timeout=10)
            self._cluster = None
        if self._config is not None:
            self._config.__exit__(None, None, None)
            self._config = None

    def worker_pids(self) -> dict[str, int]:
        """Process id of every worker (for fault-injection tests)."""
        return self._connect().run(os.getpid)

    def build_counts(self) -> dict[str, dict[str, int]]:
        """Per worker: how many times it built each study's model."""
        return self._connect().run(build_counts)
