"""Moves inside the tolerance region: the sampler's mode for many parameters.

With many parameters (:data:`MOVE_FROM` or more) the importance weights of a Gaussian-mixture
population against the box degenerate: on the parafoil twin with 33 gains their effective
sample size fell to 1–2 while thousands of trials met the limits, and a kernel fitted to
weights that degenerate contracts onto a few points (the population ended far from the
truth, in 30 of 33 gains outside every member's range). So there the sampler follows
ABC-SMC with Markov-chain moves (Del Moral, Doucet & Jasra 2012; Drovandi & Pettitt 2011),
in PSI's terms:

* a population of ``N`` *particles*, each a stored trial that meets the current limits (one
  per criterion). Its target is the box's uniform density restricted to the region those
  limits define, so every particle weighs the same: no importance weight can degenerate;
* each generation moves every particle once by a random-walk Metropolis step: a draw from a
  Gaussian centred on it, with the covariance of the distinct particles times a scale tuned to
  an acceptance near :data:`TARGET_ACCEPT`. A draw outside the box is refused without
  evaluating the model; a draw inside it is evaluated and replaces its particle when it meets
  the current limits. The step is symmetric and the target uniform, so the move leaves the
  uniform density on the region invariant — the particles stay a uniform sample of it;
* the limits tighten (a quantile of the particles' criteria, as
  :func:`~vectorid.sequential.tolerance.next_tolerance`, never below Φ**) only once the
  particles are diverse again — at least :data:`DIVERSE` of them distinct — and the
  particles that meet the new limits are copied (evenly) back to ``N``;
* at the stated limits Φ**, after at least :data:`FINAL_MOVES` moves, the distinct particles
  are D's sample (uniform on D, equal weights): its effective sample size is their number.

Every draw evaluated is still a draw from a known density — the equal-weight mixture of the
Gaussians on the particles, truncated to the box — so the deterministic-mixture importance
weights over all generations (:mod:`.weights`) stay valid for D at loosened limits.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "DIVERSE",
    "FINAL_MOVES",
    "MOVE_FROM",
    "TARGET_ACCEPT",
    "adapt_scale",
    "copy_evenly",
    "in_box_mass",
    "move_draws",
]

#: Studies with this many variables or more use moves (fewer: the importance-weighted mixture).
MOVE_FROM = 20
#: Share of distinct particles needed before the limits tighten again.
DIVERSE = 0.8
#: Moves made at the stated limits before the particles are D's sample.
FINAL_MOVES = 30
#: Acceptance (of all proposed moves) the step scale is tuned toward.
TARGET_ACCEPT = 0.25
#: Bounds on the step scale (a factor on the particles' covariance).
SCALE_BOUNDS = (1e-4, 4.0)


def initial_scale(p: int) -> float:
    """Roberts & Rosenthal's 2.38² / p: the random-walk scale for a Gaussian-like target."""
    return 2.38**2 / p


def adapt_scale(scale: float, accepted: float) -> float:
    """Next step scale from the share of moves accepted (Robbins–Monro in log scale)."""
    lo, hi = SCALE_BOUNDS
    return float(min(hi, max(lo, scale * math.exp(2.0 * (accepted - TARGET_ACCEPT)))))


def copy_evenly(alive: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` particles from the ``alive`` ones (equal weights): each copied ``n // a`` times,
    the remainder drawn without replacement (fewer copies than multinomial resampling)."""
    alive = np.asarray(alive)
    a = len(alive)
    if a >= n:
        return np.sort(rng.choice(alive, size=n, replace=False))
    rest = rng.choice(alive, size=n % a, replace=False)
    return np.sort(np.concatenate([np.repeat(alive, n // a), rest]))


def particle_cov(U: np.ndarray) -> np.ndarray:
    """Covariance of the distinct particles (unit coordinates), kept proper: a floor of
    (0.05 of the box)² per axis when there are fewer particles than parameters."""
    U = np.unique(np.asarray(U, dtype=float), axis=0)
    m, p = U.shape
    if m < p + 1:
        return np.diag(np.full(p, 0.05**2))
    cov = np.cov(U, rowvar=False)
    return 0.5 * (cov + cov.T) + np.eye(p) * 1e-10


def move_draws(
    U: np.ndarray, chol: np.ndarray, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """One random-walk draw per particle: the draws inside the box and their particles.

    Parameters
    ----------
    U : (N, p) float array
        The particles (unit coordinates).
    chol : (p, p) float array
        Lower Cholesky factor of the step covariance.

    Returns
    -------
    draws : (n, p) float array
        The draws that land inside the box (the others are refused unevaluated).
    parents : (n,) int array
        Index of each draw's particle.
    """
    U = np.asarray(U, dtype=float)
    Z = U + rng.standard_normal(U.shape) @ chol.T
    ok = np.all((Z >= 0.0) & (Z <= 1.0), axis=1)
    return Z[ok], np.flatnonzero(ok)


def in_box_mass(U: np.ndarray, chol: np.ndarray, rng: np.random.Generator,
                draws: int = 20_000) -> float:  # fmt: skip
    """Share of the equal-weight mixture of Gaussians on the particles ``U`` (copies count)
    with step factor ``chol`` that lies inside the box, estimated from ``draws`` draws."""
    U = np.asarray(U, dtype=float)
    idx = rng.integers(0, len(U), size=draws)
    Z = U[idx] + rng.standard_normal((draws, U.shape[1])) @ chol.T
    return max(float(np.mean(np.all((Z >= 0.0) & (Z <= 1.0), axis=1))), 1.0 / draws)
