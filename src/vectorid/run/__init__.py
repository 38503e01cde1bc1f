"""Executors and the one run loop: the only place that evaluates models and writes trials.

* :mod:`.loop` — :func:`run_store`, the driver every sampler runs through;
* :mod:`.executors` — in-process, processes (and :mod:`.dask` for clusters);
* :mod:`.repair` — ``vectorid repair``: damaged batches dropped and recomputed.
"""

from .executors import EXECUTORS, Executor, ProcessExecutor, SerialExecutor, make_executor
from .loop import RunInterrupted, RunSummary, plan, run_store

__all__ = [
    "EXECUTORS",
    "Executor",
    "ProcessExecutor",
    "RunInterrupted",
    "RunSummary",
    "SerialExecutor",
    "make_executor",
    "plan",
    "run_store",
]
