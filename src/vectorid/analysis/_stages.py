"""Helpers shared by the modules that add auxiliary stages (sections, robustness checks):
finding a stored trial by id, evaluating new trials through the study's Problem, and the
``key=value`` notes that describe an auxiliary stage."""

from __future__ import annotations

import re
import time
from dataclasses import dataclass

import numpy as np

from ..errors import StoreError, StudyDefinitionError
from ..problem import EvalResult, Problem
from ..store.sqlite import Store, Trials

__all__ = ["StoredTrial", "evaluate_and_store", "find_trial", "load_all", "parse_note"]

_NOTE_ITEM = re.compile(r"(\w+)=(\S+)")


@dataclass(frozen=True)
class StoredTrial:
    """One stored trial: id, stage, parameters (p,), criteria (k,), functionals (q,), status."""

    id: int
    stage: int
    x: np.ndarray
    f: np.ndarray
    g: np.ndarray
    status: int


def load_all(store: Store) -> Trials:
    """Every stored trial of every stage kind."""
    kinds = sorted({s.kind for s in store.stages()})
    return store.load(kinds=kinds)


def find_trial(store: Store, trial_id: int, trials: Trials | None = None) -> StoredTrial:
    """The stored trial with id ``trial_id`` (sample or auxiliary stage).

    Raises
    ------
    StudyDefinitionError
        When no stored trial has that id.
    """
    t = trials if trials is not None else load_all(store)
    hit = np.flatnonzero(t.id == int(trial_id))
    if len(hit) == 0:
        sample_ids = t.id[t.id < 1_000_000_000]
        hint = (
            f"sample trial ids run from {int(sample_ids.min())} to {int(sample_ids.max())}"
            if len(sample_ids)
            else "the store holds no trial yet; run the study first"
        )
        raise StudyDefinitionError(
            "--trial",
            f"no stored trial has id {trial_id}",
            f"{hint}; `vectorid pareto {store.path}` lists the Pareto trials' ids",
        )
    i = int(hit[0])
    return StoredTrial(
        id=int(t.id[i]),
        stage=int(t.stage[i]),
        x=t.X[i].copy(),
        f=t.F[i].copy(),
        g=t.G[i].copy(),
        status=int(t.status[i]),
    )


def evaluate_and_store(
    store: Store, stage: int, X: np.ndarray, problem: Problem | None = None
) -> EvalResult:
    """Evaluate ``X`` (n, p) through the study's Problem and store it as stage ``stage``
    starting at sequence index 0."""
    if not store.writable:
        raise StoreError(
            f"store {store.path} was opened read-only; open it with write=True to add trials"
        )
    prob = problem if problem is not None else store.spec.problem()
    t0 = time.perf_counter()
    res = prob.evaluate(X)
    if res.wall is None:
        res.wall = np.full(res.n, (time.perf_counter() - t0) / max(res.n, 1))
    store.write_batch(
        stage, 0, X, res.criteria, res.functionals, res.status, res.wall, res.messages
    )
    return res


def parse_note(note: str) -> dict[str, str]:
    """The ``key=value`` items of a stage note."""
    return dict(_NOTE_ITEM.findall(note))
