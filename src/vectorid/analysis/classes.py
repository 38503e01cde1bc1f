"""Colour classes of trials (seed 001, Fig. 6) and deterministic decimation for plots.

Every trial of an :class:`~vectorid.analysis.Analysis` falls in exactly one class:

* ``infeasible`` (red): outside the feasible set D (failed, violating a functional
  constraint or a criteria constraint), N − ND trials;
* ``feasible`` (blue): in D but not Edgeworth–Pareto optimal, ND − NP trials;
* ``pareto`` (green): in the Edgeworth–Pareto set, NP trials.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .results import Analysis

__all__ = ["CLASS_COLOURS", "PointClasses", "point_classes", "subsample"]

#: The seeds' colour convention: infeasible red, feasible blue, Pareto green.
CLASS_COLOURS = {"infeasible": "#d62728", "feasible": "#1f77b4", "pareto": "#2ca02c"}


@dataclass(frozen=True)
class PointClasses:
    """Disjoint boolean masks (n,) over the analysed trials.

    Attributes
    ----------
    infeasible, feasible, pareto : (n,) bool
        ``feasible`` excludes the Pareto trials, so the three masks partition the trials.
    failed : (n,) bool
        Failed trials (a subset of ``infeasible``; their criteria are NaN, so they cannot be
        drawn).
    """

    infeasible: np.ndarray
    feasible: np.ndarray
    pareto: np.ndarray
    failed: np.ndarray

    def counts(self) -> dict[str, int]:
        """Trials per class: N − ND, ND − NP, NP (and how many of the first failed)."""
        return {
            "infeasible": int(self.infeasible.sum()),
            "feasible": int(self.feasible.sum()),
            "pareto": int(self.pareto.sum()),
            "failed": int(self.failed.sum()),
        }

    def items(self) -> list[tuple[str, np.ndarray]]:
        """``(class name, mask)`` in drawing order (infeasible below, Pareto on top)."""
        return [
            ("infeasible", self.infeasible),
            ("feasible", self.feasible),
            ("pareto", self.pareto),
        ]


def point_classes(a: Analysis) -> PointClasses:
    """Split the trials of ``a`` into the three colour classes."""
    pareto = a.pareto.copy()
    feasible = a.feasible & ~pareto
    infeasible = ~a.feasible
    return PointClasses(infeasible, feasible, pareto, ~a.ok)


def subsample(mask: np.ndarray, max_points: int | None, seed: int = 0) -> np.ndarray:
    """Row indices of ``mask``, at most ``max_points`` of them.

    When the mask holds more rows, a uniform random subset (without replacement, from
    ``numpy.random.default_rng(seed)``) is returned in increasing order, so the same call
    always keeps the same trials.

    Parameters
    ----------
    mask : (n,) bool
    max_points : int or None
        None keeps every row.
    seed : int

    Returns
    -------
    (m,) int64
    """
    idx = np.flatnonzero(mask)
    if max_points is None or len(idx) <= max_points:
        return idx
    if max_points < 0:
        raise ValueError(f"max_points must be >= 0 or None, got {max_points}")
    rng = np.random.default_rng(seed)
    keep = rng.choice(len(idx), size=int(max_points), replace=False)
    keep.sort()
    return idx[keep]
