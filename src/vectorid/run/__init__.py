"""Executors and the run loop."""

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
