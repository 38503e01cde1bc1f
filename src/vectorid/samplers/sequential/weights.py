"""Importance weights against the box over every generation (Kish's effective sample size of
them: :func:`vectorid.samplers.weighting.kish_ess`).

The trials of all generations together are one sample from the *deterministic mixture*
``q(u) = sum_g (n_g / N) q_g(u)`` of the generations' proposals (``n_g`` trials evaluated in
generation ``g``, ``N`` in all; generation 0 is the uniform Sobol table). Weighting every
trial by ``p_box(u) / q(u)`` (Owen & Zhou's balance heuristic, as in adaptive multiple
importance sampling) makes any subset selected by limits — D at the stated Φ**, or D at
limits loosened after the run — a weighted sample of the box's uniform density restricted to
that subset: the population a plain Sobol table would give with unboundedly many trials.
Unlike the sequential weights of ABC-SMC (each generation reweighted from the last), these
never degenerate when one generation's kernel was too narrow: a region any generation
covered keeps the density of that generation in the denominator.

Computed in log space (no underflow, whatever the dimension).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy.special import logsumexp

from .kernel import Proposal

__all__ = ["log_weights"]


def log_weights(U: np.ndarray, proposals: Sequence[Proposal], counts: Sequence[int]) -> np.ndarray:
    """Log importance weights ``log p_box(u) - log sum_g (n_g/N) q_g(u)``.

    Parameters
    ----------
    U : (n, p) float array
        Trials in unit coordinates (inside the box).
    proposals : sequence of Proposal
        Every generation's proposal, in order.
    counts : sequence of int
        Trials evaluated in each generation (failed ones included: they were drawn).

    Returns
    -------
    (n,) float array
        Log weights (the box has density 1 in unit coordinates).
    """
    U = np.atleast_2d(np.asarray(U, dtype=float))
    total = float(sum(counts))
    if U.shape[0] == 0 or total <= 0:
        return np.zeros(U.shape[0])
    terms = [prop.logpdf(U) + math.log(n / total) for prop, n in zip(proposals, counts) if n > 0]
    return -logsumexp(np.vstack(terms), axis=0)
