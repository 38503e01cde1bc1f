"""Background jobs of the browser UI: sections, robustness checks, new sample stages, and
saving the constraints in force with the study.

Jobs run in one worker process started once with the UI (``multiprocessing`` *spawn*
context, so nothing of the threaded web server is forked) and kept for every later job: its
imports and compiled models stay warm, so a job starts in milliseconds and a run goes at the
throughput of ``vectorid run`` with the same executor. For each job it opens the store for
writing, which takes the store's writer lock, and closes it when the job ends; the UI process
keeps reading with read-only connections. One job at a time: a second request while one runs
raises :class:`JobBusy`, whose message the UI shows. Progress
of a run job is read from the store itself (sample trials stored since the job began, out of
the number asked for); a section or robustness job shows its elapsed time. "Stop" sends the
worker SIGINT, so a run stores what it finished and logs itself as interrupted; the worker
then waits for the next job. A worker that died is started again for the next job.
"""

from __future__ import annotations

import atexit
import multiprocessing as mp
import os
import queue as queue_mod
import signal
import threading
import time
import traceback
import weakref
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ...errors import VectoridError

__all__ = ["JOB_KINDS", "JobBusy", "JobManager", "JobStatus", "run_job"]

#: What a job may do. The browser chooses among these names; nothing else is run.
JOB_KINDS = ("section", "robustness", "refine", "continue", "limits")


class JobBusy(VectoridError):
    """A job is already running on this store."""


@dataclass
class JobStatus:
    """What the UI shows about the current (or last) job.

    Attributes
    ----------
    id : int
        Increments with every job started (0: none yet).
    kind : str
        One of :data:`JOB_KINDS` ('' when none).
    state : str
        ``idle``, ``running``, ``done``, ``error`` or ``stopped``.
    label : str
        What the job does, in words.
    message : str
        Outcome (or error) text.
    started, finished : float
        ``time.time()`` stamps (0 when not yet).
    progress : float or None
        Fraction done for run jobs; None when unknown.
    detail : dict
        Job parameters and results (e.g. the trial of a section).
    """

    id: int = 0
    kind: str = ""
    state: str = "idle"
    label: str = ""
    message: str = ""
    started: float = 0.0
    finished: float = 0.0
    progress: float | None = None
    detail: dict[str, Any] = field(default_factory=dict)

    @property
    def running(self) -> bool:
        return self.state == "running"

    def to_dict(self) -> dict[str, Any]:
        end = self.finished or time.time()
        return {
            "id": self.id,
            "kind": self.kind,
            "state": self.state,
            "label": self.label,
            "message": self.message,
            "elapsed": round(end - self.started, 1) if self.started else 0.0,
            "progress": self.progress,
        }


def run_job(kind: str, store_path: str, params: Mapping[str, Any]) -> str:
    """Carry out one job in this process (the body of the job process; also callable
    directly, e.g. from tests). Opens the store for writing.

    Parameters
    ----------
    kind : str
        One of :data:`JOB_KINDS`.
    store_path : str
        The store, as given to the UI on the command line (never from the browser).
    params : mapping
        Already validated by the UI: ``trial``, ``param``, ``points``, ``range``, ``radius``,
        ``seed``, ``limits``, ``roles``, ``basis``, ``quantile``, ``margin``, ``bounds``,
        ``trials``, ``executor``, ``workers``; for ``limits``: ``criteria`` (name -> limit or
        None), ``constraints`` (name -> (low, high), None for no bound), ``sources`` (name ->
        (limit_source, limit_note)) and ``text`` (the bounds in words), as
        :meth:`vectoridstore.Store.set_limits` takes them.

    Returns
    -------
    str
        A one-line summary of what was stored.
    """
    from ...analysis.refine import propose_refine
    from ...analysis.results import Analysis
    from ...run.loop import run_store
    from ...store import Store
    from ...workflows.extra import apply_refine, run_robustness, run_section

    if kind not in JOB_KINDS:
        raise ValueError(f"unknown job kind {kind!r}; expected one of {JOB_KINDS}")
    with Store.open(store_path, write=True) as store:
        if kind == "limits":
            store.set_limits(
                dict(params.get("criteria") or {}),
                {k: tuple(v) for k, v in dict(params.get("constraints") or {}).items()},
                sources={
                    k: (str(v[0]), str(v[1])) for k, v in (params.get("sources") or {}).items()
                },
            )
            return f"saved with the study: {params.get('text') or 'no limits'}"
        if kind == "section":
            sec = run_section(
                store,
                int(params["trial"]),
                str(params["param"]),
                points=int(params.get("points", 21)),
                value_range=params.get("range"),
            )
            failed = int((sec.status != 0).sum())
            return (
                f"section through trial {sec.trial} along {sec.param}: {len(sec.values)} points "
                f"stored as stage {sec.stage}" + (f" ({failed} failed)" if failed else "")
            )
        a = None
        if kind in ("robustness", "refine"):
            a = Analysis.of_store(store, params.get("limits"), params.get("roles"))
        if kind == "robustness":
            rob = run_robustness(
                store,
                int(params["trial"]),
                radius=float(params.get("radius", 0.02)),
                points=params.get("points"),
                seed=int(params.get("seed", 0)),
                analysis=a,
            )
            return (
                f"robustness of trial {rob.trial}: {len(rob.X)} points stored as stage "
                f"{rob.stage}; verdict {rob.verdict}"
            )
        n = int(params["trials"])
        note = ""
        if kind == "refine":
            assert a is not None
            prop = propose_refine(
                a,
                store.stages(),
                basis=str(params.get("basis", "feasible")),
                quantile=float(params.get("quantile", 0.05)),
                margin=float(params.get("margin", 0.1)),
                bounds={k: tuple(v) for k, v in dict(params.get("bounds") or {}).items()},
            )
            stage = apply_refine(store, prop)
            note = f"new stage {stage.stage} (volume ratio {prop.volume_ratio:.3g}); "
        target = store.sequence_end() + n
        summary = run_store(
            store,
            trials=target,
            executor=params.get("executor"),
            workers=params.get("workers"),
            progress=False,
        )
        errors = "".join(f"; model error: {m}" for m in summary.model_errors)
        return note + summary.describe().splitlines()[0] + errors


def _one_job(kind: str, store_path: str, params: dict[str, Any]) -> tuple[str, str]:
    """Run one job and return ``(state, message)``; never raises."""
    from ...run.loop import RunInterrupted

    try:
        return "done", run_job(kind, store_path, params)
    except RunInterrupted as exc:
        return "stopped", str(exc)
    except KeyboardInterrupt:
        return "stopped", "stopped before anything was stored"
    except VectoridError as exc:
        return "error", str(exc)
    except BaseException as exc:  # a bug or a model error: say what, keep the trace on stderr
        traceback.print_exc()
        return "error", f"{type(exc).__name__}: {exc}"


def _worker_main(inbox: Any, out: Any, parent: int) -> None:
    """The worker process: warm the imports, then run each job from ``inbox`` and report
    ``(job id, state, message)`` on ``out``, until it receives None. It is not a daemon
    (its jobs run the study's executor, whose serial form keeps the model in a child
    process), so it ends with the UI's process instead (:func:`end_with_parent`)."""
    from vectorid.run.executors import end_with_parent

    end_with_parent(parent, pdeathsig=False)  # started from a request thread: watchdog only
    import vectorid.run.loop
    import vectorid.workflows.extra  # noqa: F401 - warmed for the jobs

    out.put((0, "ready", ""))
    while True:
        try:
            item = inbox.get()
        except KeyboardInterrupt:  # a stop that came between jobs
            continue
        if item is None:
            return
        job_id, kind, store_path, params = item
        try:
            state, message = _one_job(kind, store_path, params)
        except KeyboardInterrupt:
            state, message = "stopped", "stopped"
        while True:
            try:
                out.put((job_id, state, message))
                break
            except KeyboardInterrupt:
                continue


def _shutdown_at_exit(ref: Any) -> None:
    manager = ref()
    if manager is not None:
        manager.shutdown(timeout=5.0)


class JobManager:
    """Starts, watches and stops the one background job of a UI.

    Parameters
    ----------
    store_path : path
        The store the UI serves.
    executor, workers
        Passed to :func:`vectorid.run.run_store` for run jobs (default: the study's, else
        local processes on every core).
    progress_of : callable, optional
        ``() -> int``: sample trials now stored (read by the UI with a read-only connection);
        gives the progress of run jobs.
    """

    def __init__(
        self,
        store_path: str | Path,
        *,
        executor: str | None = None,
        workers: int | None = None,
        progress_of: Any = None,
    ) -> None:
        self.store_path = str(Path(store_path).resolve())
        self.executor = executor
        self.workers = workers
        self._progress_of = progress_of
        self._ctx = mp.get_context("spawn")
        self._lock = threading.Lock()
        self._proc: Any = None
        self._queue: Any = None
        self._inbox: Any = None
        self._status = JobStatus()
        self._base = 0  # sample trials stored when the run job began
        self._atexit = False

    def _worker_locked(self) -> None:
        """Start the worker process when none is alive."""
        if self._proc is not None and self._proc.is_alive():
            return
        self._inbox = self._ctx.Queue()
        self._queue = self._ctx.Queue()
        self._proc = self._ctx.Process(
            target=_worker_main,
            args=(self._inbox, self._queue, os.getpid()),
            name="vectorid-ui-jobs",
        )
        self._proc.start()
        if not self._atexit:  # before multiprocessing's own exit handler joins the worker
            atexit.register(_shutdown_at_exit, weakref.ref(self))
            self._atexit = True

    def warm(self) -> None:
        """Start the worker now (it imports vectorid once; jobs then start at once)."""
        with self._lock:
            self._worker_locked()

    def start(self, kind: str, params: Mapping[str, Any], label: str) -> JobStatus:
        """Start a job.

        Raises
        ------
        JobBusy
            When a job is running (its label and elapsed time are in the message).
        ValueError
            For an unknown ``kind``.
        """
        if kind not in JOB_KINDS:
            raise ValueError(f"unknown job kind {kind!r}; expected one of {JOB_KINDS}")
        with self._lock:
            self._poll_locked()
            if self._status.running:
                st = self._status
                raise JobBusy(
                    f"a job is already running: {st.label} (for {time.time() - st.started:.0f} s); "
                    "wait for it to finish or stop it, then start this one"
                )
            params = dict(params)
            if kind in ("refine", "continue"):
                params.setdefault("executor", self.executor)
                params.setdefault("workers", self.workers)
                self._base = self._progress_of() if self._progress_of else 0
            self._worker_locked()
            job_id = self._status.id + 1
            self._inbox.put((job_id, kind, self.store_path, params))
            self._status = JobStatus(
                id=job_id,
                kind=kind,
                state="running",
                label=label,
                started=time.time(),
                progress=0.0 if kind in ("refine", "continue") else None,
                detail=params,
            )
            return self._status

    def _poll_locked(self) -> None:
        st = self._status
        if not st.running or self._proc is None:
            return
        while True:
            try:
                job_id, state, message = self._queue.get_nowait()
            except queue_mod.Empty:
                if self._proc.is_alive():
                    if st.kind in ("refine", "continue") and self._progress_of:
                        try:
                            done = self._progress_of() - self._base
                            st.progress = max(
                                0.0, min(1.0, done / max(int(st.detail["trials"]), 1))
                            )
                        except Exception:  # the store is busy: keep the last progress
                            pass
                    return
                try:  # the result may have arrived before the worker ended
                    job_id, state, message = self._queue.get(timeout=0.5)
                except queue_mod.Empty:
                    job_id, state = st.id, "error"
                    message = (
                        "the job worker ended without a result (exit code "
                        f"{self._proc.exitcode}); it is started again for the next job"
                    )
                    self._proc = None
            if job_id == st.id:
                break  # 'ready' and results of earlier jobs are skipped
        st.state, st.message, st.finished = state, message, time.time()
        if state == "done" and st.progress is not None:
            st.progress = 1.0

    def status(self) -> JobStatus:
        """The current job's status (polls the job process)."""
        with self._lock:
            self._poll_locked()
            return self._status

    def stop(self) -> bool:
        """Ask the running job to stop (SIGINT to the worker: a run stores what it
        finished). Returns whether a job was running."""
        with self._lock:
            self._poll_locked()
            proc = self._proc
            if proc is None or not proc.is_alive() or not self._status.running:
                return False
            os.kill(proc.pid, signal.SIGINT)
            return True

    def shutdown(self, timeout: float = 10.0) -> None:
        """Stop the running job (if any), then the worker, and wait for it to end."""
        proc = self._proc
        if proc is None:
            return
        if proc.is_alive():
            if self._status.running:
                os.kill(proc.pid, signal.SIGINT)
            try:
                self._inbox.put(None)
            except Exception:
                pass
            proc.join(timeout)
            if proc.is_alive():
                proc.terminate()
                proc.join(5)
        with self._lock:
            self._poll_locked()
            self._proc = None
