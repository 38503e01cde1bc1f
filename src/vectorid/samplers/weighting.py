"""How a stored sample weighs, and Kish's effective sample size.

A plain table's trials are a uniform sample of the box: every trial counts once. A sampler
that draws later trials from kernels around earlier ones (the sequential sampler) makes its
trials a *weighted* sample: :class:`Weighting` says how, and the analysis receives it
(:class:`vectorid.analysis.Analysis`'s ``weighting``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.special import logsumexp

__all__ = ["Weighting", "kish_ess"]


@dataclass(frozen=True)
class Weighting:
    """How a store's trials weigh as a sample of the box's uniform density.

    Attributes
    ----------
    kind : {"importance", "holding"}
        ``"importance"``: importance weights against the box (each trial's ``p_box / q``);
        ``"holding"``: each member of D at the stated limits weighs its holding time in the
        particles' chains (members never held weigh 0; no other trial has a weight).
    log_weight : callable
        ``log_weight(X)``: log weights of parameter vectors ``X`` (n, p) that are stored
        trials of the sample, in the study's units (NaN where a vector has no weight).
    """

    kind: str
    log_weight: Callable[[np.ndarray], np.ndarray]

    @property
    def how(self) -> str:
        """In words: "importance-weighted" or "weighted by the particles' holding times"."""
        if self.kind == "holding":
            return "weighted by the particles' holding times"
        return "importance-weighted"


def kish_ess(log_w: np.ndarray) -> float:
    """Kish's effective sample size ``(Σ w)² / Σ w²`` of weights given by their logs.

    Parameters
    ----------
    log_w : (n,) float array
        Log weights (any constant offset; ``-inf`` for a weight of 0).

    Returns
    -------
    float
        Between 1 and n for n weights not all 0; 0 for no weights.
    """
    log_w = np.asarray(log_w, dtype=float)
    if log_w.size == 0 or not np.isfinite(log_w).any():
        return 0.0
    return float(math.exp(2.0 * logsumexp(log_w) - logsumexp(2.0 * log_w)))
