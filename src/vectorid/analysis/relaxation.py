"""Relaxed criteria constraints: the last resort when the trials miss D at the stated limits.

Criteria constraints Φ** stated from the sensor noise (and a discrepancy allowance) define the
feasible set D the data cannot tell apart. When the trials of a study hold too few members of
that D to read ranges from, the tool first samples further (the sequential sampler). Only when
that is not possible, or did not reach D within its budget, are the limits *relaxed*: every
limit times the smallest common factor f >= 1 at which D holds enough trials. Relaxed limits
keep every vector of the stated D, so ranges read over them are *outer bounds* of the data's,
and f says how far the sampling is from resolving them. A relaxation is always printed and
saved under its name ("limits relaxed xf — last resort: D at the stated limits was not
reached"), never passed off as the stated limits.

:func:`relaxed_limits` computes the factor from an analysis (this module only reads);
:func:`vectorid.workflows.extra.relax_study` saves the relaxed limits (or the stated ones, where no
relaxation is needed) in a study's store.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = [
    "MIN_D",
    "RELAX_SHARE",
    "Relaxation",
    "relaxation_text",
    "relaxed_limits",
]

#: D must hold at least this share of the successful trials (and :data:`MIN_D`) for its ranges
#: to mean something; where the stated limits leave fewer, they are relaxed.
RELAX_SHARE = 0.02
#: The fewest members of D that ranges are read from.
MIN_D = 50


def relaxation_text(factor: float) -> str:
    """The name a relaxation is printed and saved under.

    Parameters
    ----------
    factor : float
        The common factor (dimensionless, > 1) on every criteria constraint.

    Returns
    -------
    str
        ``"limits relaxed x{factor} — last resort: D at the stated limits was not reached"``.
    """
    return f"limits relaxed x{factor:g} — last resort: D at the stated limits was not reached"


def relaxed_limits(
    a: Any, limits: Mapping[str, float], *, share: float = RELAX_SHARE, min_count: int = MIN_D
) -> tuple[float, dict[str, float]]:
    """The smallest common factor f >= 1 on every limit at which D holds enough trials.

    Enough is ``max(min_count, share * successful trials)``. Criteria constraints only
    (functional constraints stay in force as they are); criteria of ``min`` sense.

    Parameters
    ----------
    a : vectorid.analysis.results.Analysis
        An analysis of the study (its successful trials and functional bounds are used).
    limits : mapping
        Criterion name -> stated limit Φ**, in the criterion's unit.
    share : float
        Share (0-1) of the successful trials that D must hold.
    min_count : int
        Fewest trials D must hold.

    Returns
    -------
    factor : float
        Dimensionless, rounded up to 0.01; 1.0 where D already holds enough trials; ``inf``
        where no trial succeeded.
    relaxed : dict
        Criterion name -> ``factor * limit`` (the criterion's unit).
    """
    names = [c for c in a.crit_names if c in limits]
    if not names:
        return 1.0, {}
    cols = [a.crit_names.index(c) for c in names]
    L = np.array([float(limits[c]) for c in names])
    m = a.ok.copy()
    for b in a.active_bounds():  # functional constraints stay in force
        if b.name in a.con_names:
            m &= a._bound_mask(b.name, b.side)
    F = a.trials.F[m][:, cols]
    if not len(F):
        return math.inf, {c: math.inf for c in names}
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.nanmax(F / L[None, :], axis=1)
    k = min(max(int(min_count), math.ceil(share * len(F))), len(F))
    f = float(np.sort(ratio)[k - 1])
    f = 1.0 if f <= 1.0 else float(math.ceil(f * 100.0) / 100.0)
    return f, {c: f * float(limits[c]) for c in names}


@dataclass
class Relaxation:
    """What :func:`vectorid.workflows.extra.relax_study` saved.

    Attributes
    ----------
    factor : float
        Common factor on every stated limit (1.0: the stated limits are in force).
    n_at_limits : int
        Members of D under the stated limits.
    n_needed : int
        Members D needs for its ranges to be read.
    n_ok : int
        Successful trials.
    """

    factor: float
    n_at_limits: int
    n_needed: int
    n_ok: int

    @property
    def relaxed(self) -> bool:
        """Whether the limits in force are relaxed ones."""
        return self.factor > 1.0

    def describe(self) -> str:
        """One line: the stated limits hold, or the relaxation under its name."""
        if not self.relaxed:
            return f"D at the stated limits: {self.n_at_limits} of {self.n_ok} successful trials"
        return (
            f"{relaxation_text(self.factor)} ({self.n_at_limits} of {self.n_ok} successful "
            f"trials meet them; relaxed, D holds {self.n_needed})"
        )
