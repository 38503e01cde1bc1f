"""The tolerance schedule: one limit per constrained criterion, tightened toward Φ**.

Criteria are *oriented* (:func:`vectorid.limits.oriented`) so that smaller is better (a ``max``
criterion and its limit are negated). Generation ``g + 1``'s tolerance for criterion ``l`` is

    eps_l,g+1 = max(Φ**_l, min(eps_l,g, quantile_q(Φ_l over the accepted population)))

with one quantile level ``q`` for all criteria, chosen (by bisection) so that a fraction
``keep`` of the accepted population meets every new limit at once. So the criteria stay
separate limits, as the PSI method wants (no summed distance), each limit is monotone
non-increasing, and none ever goes below the stated one.
"""

from __future__ import annotations

import numpy as np

__all__ = ["next_tolerance"]


def next_tolerance(
    phi: np.ndarray, current: np.ndarray, floor: np.ndarray, keep: float = 0.5
) -> np.ndarray:
    """The next generation's limits.

    Parameters
    ----------
    phi : (m, k) float array
        Oriented constrained criteria of the accepted population (all meet ``current``).
    current : (k,) float array
        This generation's limits (``inf`` at first).
    floor : (k,) float array
        The stated limits Φ** (oriented).
    keep : float
        Share of the population that meets the new limits.

    Returns
    -------
    (k,) float array
        New limits, ``floor <= new <= current``.
    """
    phi = np.asarray(phi, dtype=float)
    current = np.asarray(current, dtype=float)
    floor = np.asarray(floor, dtype=float)
    if phi.shape[0] == 0:
        return current.copy()

    def limits(q: float) -> np.ndarray:
        return np.maximum(floor, np.minimum(current, np.quantile(phi, q, axis=0)))

    def share(q: float) -> float:
        return float(np.mean(np.all(phi <= limits(q), axis=1)))

    if share(0.0) >= keep:
        return limits(0.0)
    lo, hi = 0.0, 1.0
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        if share(mid) >= keep:
            hi = mid
        else:
            lo = mid
    return limits(hi)
