"""Executors: where batches of trials are evaluated.

Contract every executor must keep (the shared test suite ``tests/run/test_executors.py``
runs each of them through it):

* :meth:`Executor.map_unordered` takes an iterable of ``(key, X)`` batches and yields
  ``(key, EvalResult)`` for every batch, in any order, each exactly once;
* a trial whose model raises, returns NaN/inf or the wrong shape comes back failed with its
  reason — the executor never stops because of a bad trial;
* a batch whose worker process died is retried once in a fresh worker and, if it kills a
  worker again, comes back with every trial failed and the reason;
* executors never touch the store: the run loop alone writes, so a batch evaluated twice is
  still stored once;
* ``close(cancel=True)`` stops quickly (Ctrl-C), dropping batches not yet evaluated.
"""

from __future__ import annotations

import abc
import concurrent.futures as cf
import multiprocessing as mp
import os
from collections.abc import Hashable, Iterable, Iterator
from typing import Any

import numpy as np

from ..errors import StudyDefinitionError, suggest
from ..problem import FAILED, EvalResult, Problem
from ..spec import StudySpec

__all__ = ["EXECUTORS", "Executor", "ProcessExecutor", "SerialExecutor", "make_executor"]


class Executor(abc.ABC):
    """Evaluates batches of parameter vectors of one study.

    Parameters
    ----------
    spec : StudySpec
        The study (its model, criteria and constraints).
    workers : int, optional
        Degree of parallelism (ignored by the serial executor).
    """

    name = "abstract"

    def __init__(self, spec: StudySpec, workers: int | None = None) -> None:
        self.spec = spec
        self.workers = self._default_workers() if workers is None else int(workers)
        if self.workers < 1:
            raise StudyDefinitionError(
                "--workers", f"expected at least 1 worker, got {workers}", "use --workers 1 or more"
            )

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


class SerialExecutor(Executor):
    """Evaluates batches in this process, one after the other."""

    name = "serial"

    def __init__(self, spec: StudySpec, workers: int | None = None) -> None:
        super().__init__(spec, 1)
        self._problem: Problem | None = None

    def _map_unordered(self, batches):
        if self._problem is None:
            self._problem = self.spec.problem()
        for key, X in batches:
            yield key, self._problem.evaluate(X)


# -- process pool --------------------------------------------------------------------------

_WORKER_PROBLEM: Problem | None = None


def _init_worker(spec: StudySpec) -> None:
    global _WORKER_PROBLEM
    # One numba/BLAS thread per worker process: the pool is the parallelism.
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    _WORKER_PROBLEM = spec.problem()


def _evaluate_in_worker(X: np.ndarray) -> EvalResult:
    assert _WORKER_PROBLEM is not None  # set by the initializer
    return _WORKER_PROBLEM.evaluate(X)


def _crashed(n: int, k: int, q: int, reason: str) -> EvalResult:
    return EvalResult(
        criteria=np.full((n, k), np.nan),
        functionals=np.full((n, q), np.nan),
        status=np.full(n, FAILED, dtype=np.int8),
        messages=dict.fromkeys(range(n), reason),
        wall=np.zeros(n),
    )


class ProcessExecutor(Executor):
    """Evaluates batches in a pool of local worker processes (default: one per core).

    Workers are started with the ``spawn`` method (safe with numba and BLAS threads) and
    build the study's model once. At most ``2 × workers`` batches are in flight.
    """

    name = "processes"

    def __init__(self, spec: StudySpec, workers: int | None = None) -> None:
        super().__init__(spec, workers)
        if callable(spec.model) and getattr(spec.model, "__module__", "") == "__main__":
            raise StudyDefinitionError(
                "model",
                "a function defined in __main__ cannot be sent to worker processes",
                "move it into a module, or use executor='serial'",
            )
        self._pool: cf.ProcessPoolExecutor | None = None

    def _default_workers(self) -> int:
        return os.cpu_count() or 1

    def _new_pool(self) -> cf.ProcessPoolExecutor:
        return cf.ProcessPoolExecutor(
            max_workers=self.workers,
            mp_context=mp.get_context("spawn"),
            initializer=_init_worker,
            initargs=(self.spec,),
        )

    def _map_unordered(self, batches):
        if self._pool is None:
            self._pool = self._new_pool()
        k, q = len(self.spec.criteria), len(self.spec.constraints)
        pending: dict[cf.Future, tuple[Hashable, np.ndarray, int]] = {}
        retry: list[tuple[Hashable, np.ndarray, int]] = []
        exhausted = False
        limit = 2 * self.workers
        while True:
            while not exhausted and len(pending) < limit:
                if retry:
                    key, X, tries = retry.pop()
                else:
                    try:
                        key, X = next(batches)
                    except StopIteration:
                        exhausted = True
                        break
                    tries = 0
                pending[self._pool.submit(_evaluate_in_worker, X)] = (key, X, tries)
            if exhausted and retry:
                key, X, tries = retry.pop()
                pending[self._pool.submit(_evaluate_in_worker, X)] = (key, X, tries)
                continue
            if not pending:
                return
            done, _ = cf.wait(pending, return_when=cf.FIRST_COMPLETED)
            broken = False
            for fut in done:
                key, X, tries = pending.pop(fut)
                try:
                    yield key, fut.result()
                except cf.process.BrokenProcessPool:
                    broken = True
                    if tries >= 1:
                        yield (
                            key,
                            _crashed(
                                len(X),
                                k,
                                q,
                                "worker process died while evaluating this batch "
                                "(twice): the model crashed the interpreter or ran out of memory",
                            ),
                        )
                    else:
                        retry.append((key, X, tries + 1))
                except Exception as exc:  # pickling problems and the like
                    yield key, _crashed(len(X), k, q, f"{type(exc).__name__}: {exc}")
            if broken:
                # Every batch still in the dead pool is re-run in a fresh one.
                for fut, (key, X, tries) in list(pending.items()):
                    retry.append((key, X, tries + 1 if fut.done() else tries))
                pending.clear()
                self._pool.shutdown(wait=False, cancel_futures=True)
                self._pool = self._new_pool()

    def close(self, cancel: bool = False) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=not cancel, cancel_futures=cancel)
            self._pool = None


EXECUTORS: dict[str, type[Executor]] = {
    "serial": SerialExecutor,
    "processes": ProcessExecutor,
}


def make_executor(name: str, spec: StudySpec, workers: int | None = None) -> Executor:
    """Executor by name (``"serial"``, ``"processes"``)."""
    try:
        cls = EXECUTORS[name]
    except KeyError:
        raise StudyDefinitionError(
            "--executor", f"unknown executor {name!r}", suggest(name, EXECUTORS)
        ) from None
    return cls(spec, workers)
