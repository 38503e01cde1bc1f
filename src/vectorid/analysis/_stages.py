"""Helpers shared by the modules that read auxiliary stages (sections, robustness checks):
finding a stored trial by id and the ``key=value`` notes that describe an auxiliary stage.
Evaluating and storing them is :mod:`vectorid.workflows.extra`'s."""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ..errors import StudyDefinitionError
from ..store import Store, Trials

__all__ = ["StoredTrial", "find_trial", "load_all", "parse_note"]

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


def parse_note(note: str) -> dict[str, str]:
    """The ``key=value`` items of a stage note."""
    return dict(_NOTE_ITEM.findall(note))
