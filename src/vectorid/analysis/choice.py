"""Picking vectors to look at: the best trial per criterion (seed 000 Fig. 11) and a
suggested "chosen vector" when the expert has not named one.

The suggestion is the Pareto trial closest (Euclidean) to the ideal point in the pure
criteria, each normalised to [0, 1] over the Pareto set (0 best); it is a starting point
for the expert, who confirms or replaces it (``--chosen ID``).
"""

from __future__ import annotations

import numpy as np

from .results import Analysis

__all__ = ["best_per_criterion", "pure_scores", "suggest_choice"]


def best_per_criterion(a: Analysis, feasible_only: bool = True) -> dict[str, int]:
    """Trial id of the best trial for each criterion (within D, or among every successful
    trial with ``feasible_only=False``); criteria with no candidate are left out."""
    mask = a.feasible if feasible_only else a.functional_ok
    out = {}
    if not mask.any():
        return out
    rows = np.flatnonzero(mask)
    for j, (name, sense) in enumerate(zip(a.crit_names, a.senses)):
        col = a.trials.F[rows, j]
        i = int(np.nanargmax(col) if sense == "max" else np.nanargmin(col))
        out[name] = int(a.trials.id[rows[i]])
    return out


def pure_scores(a: Analysis, rows: np.ndarray) -> np.ndarray:
    """The pure criteria (all criteria where none is pure) of trial rows ``rows``, each
    normalised to [0, 1] over those rows with 0 the best (``max`` criteria flipped): shape
    (len(rows), k), dimensionless."""
    cols = a.pure or list(range(len(a.crit_names)))
    F = a.trials.F[np.ix_(rows, cols)].astype(float)
    for c, j in enumerate(cols):
        if a.senses[j] == "max":
            F[:, c] = -F[:, c]
    lo, hi = F.min(axis=0), F.max(axis=0)
    return (F - lo) / np.where(hi > lo, hi - lo, 1.0)


def suggest_choice(a: Analysis) -> int | None:
    """Id of the Pareto trial closest to the ideal point (see the module docstring), or None
    when the Pareto set is empty."""
    rows = np.flatnonzero(a.pareto)
    if len(rows) == 0:
        return None
    Z = pure_scores(a, rows)
    return int(a.trials.id[rows[int(np.argmin(np.sqrt((Z**2).sum(axis=1))))]])
