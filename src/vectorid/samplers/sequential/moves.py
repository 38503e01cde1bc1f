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
  :func:`~vectorid.samplers.sequential.tolerance.next_tolerance`, never below Φ**) only once the
  particles are diverse again — at least :data:`DIVERSE` of them distinct — and the
  particles that meet the new limits are copied (evenly) back to ``N``;
* at the stated limits Φ** each particle is a Markov chain whose target is uniform on D. The
  first :data:`WARMUP` share of the moves made there is discarded; over the rest, each chain
  state counts with its *holding time* (the moves it survived, rejected proposals included),
  so D's members weigh the number of kept moves that ended on them: an MCMC sample of
  uniform-on-D. Counting distinct states instead favours the parts of D where moves are
  accepted (its interior) over its thin ends, and counting every member found in D once
  counts the proposals' density, not D's (``scripts/moves_faithful.py`` measures both);
* the effective sample size is that of the chains, from their autocorrelation
  (:func:`chain_ess`: the rank-normalised bulk ESS of Vehtari et al. 2021, min over the
  variables); the run has converged after at least :data:`MIN_FINAL_MOVES` moves at Φ** with
  that ESS at least the population wanted.

Every draw evaluated is still a draw from a known density — the equal-weight mixture of the
Gaussians on the particles, truncated to the box — so the deterministic-mixture importance
weights over all generations (:mod:`.weights`) stay valid for D at loosened limits.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "DIVERSE",
    "MIN_FINAL_MOVES",
    "MOVE_FROM",
    "TARGET_ACCEPT",
    "WARMUP",
    "adapt_scale",
    "chain_ess",
    "chains_ess",
    "copy_evenly",
    "in_box_mass",
    "kept_moves",
    "move_draws",
]

#: Studies with this many variables or more use moves (fewer: the importance-weighted mixture).
MOVE_FROM = 20
#: Share of distinct particles needed before the limits tighten again.
DIVERSE = 0.8
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


#: With moves: share of the moves made at the stated limits discarded as warm-up before the
#: chains' states are D's sample (the rest are kept: their holding-time counts are D's weights).
WARMUP = 0.5
#: Fewest moves at the stated limits before the chains' ESS is trusted.
MIN_FINAL_MOVES = 50


def kept_moves(m: int) -> int:
    """How many of ``m`` moves at the stated limits are kept after the warm-up (the last ones)."""
    return m - math.floor(WARMUP * m)


def _normal_scores(x: np.ndarray) -> np.ndarray:
    """Rank-normalised values (Vehtari et al. 2021): Φ⁻¹((r - 3/8) / (S + 1/4)), ties averaged."""
    from scipy.special import ndtri
    from scipy.stats import rankdata

    r = rankdata(x.ravel(), method="average").reshape(x.shape)
    return ndtri((r - 0.375) / (x.size + 0.25))


def _autocov(x: np.ndarray) -> np.ndarray:
    """Autocovariances (biased: over n) of the columns of ``x`` (n, M), lags 0..n-1, by FFT."""
    n = x.shape[0]
    z = x - x.mean(axis=0)
    size = 1 << int(2 * n - 1).bit_length()
    f = np.fft.rfft(z, n=size, axis=0)
    return np.fft.irfft(f * np.conj(f), n=size, axis=0)[:n] / n


def chain_ess(x: np.ndarray) -> float:
    """Multi-chain effective sample size of one variable from its autocorrelation.

    The rank-normalised bulk ESS of Vehtari, Gelman, Simpson, Carpenter & Bürkner (2021):
    the draws are replaced by normal scores of their ranks over all chains, the
    autocorrelation ``ρ_t = 1 - (W - mean_m c_{m,t}) / var⁺`` combines the chains'
    autocovariances ``c`` with the between-chain variance (``var⁺ = (n-1)/n W + B/n``), and
    Geyer's initial monotone sequence truncates its sum: ``ESS = M n / τ``. The chains are
    not split in halves (the warm-up is discarded before), and lags run to ``n - 2`` rather
    than ``n - 5``: the sampler's chains are many (hundreds of particles) and short.

    Parameters
    ----------
    x : (n, M) float array
        ``n`` successive states of ``M`` chains.

    Returns
    -------
    float
        The ESS (``M n`` at most; 0 for fewer than 4 states per chain or a constant variable).
    """
    x = np.asarray(x, dtype=float)
    n, m = x.shape
    if n < 4 or m < 1 or np.ptp(x) == 0.0:
        return 0.0
    z = _normal_scores(x)
    acov = _autocov(z)
    chain_var = acov[0] * n / (n - 1.0)
    w = float(chain_var.mean())
    var_plus = w * (n - 1.0) / n + (float(np.var(z.mean(axis=0), ddof=1)) if m > 1 else 0.0)
    if var_plus <= 0.0:
        return 0.0
    rho = 1.0 - (w - acov.mean(axis=1)) / var_plus
    rho[0] = 1.0
    # Geyer: sums of pairs while positive, made monotone
    pairs = []
    t = 0
    while t + 1 < n - 1:
        s = rho[t] + rho[t + 1]
        if s <= 0.0:
            break
        pairs.append(min(s, pairs[-1]) if pairs else s)
        t += 2
    tau = -1.0 + 2.0 * float(np.sum(pairs))
    tau = max(tau, 1.0 / math.log10(n * m))
    return float(n * m / tau)


def chains_ess(states: np.ndarray) -> np.ndarray:
    """:func:`chain_ess` of every variable of ``states`` (n, M, p): (p,) array."""
    states = np.asarray(states, dtype=float)
    return np.array([chain_ess(states[:, :, j]) for j in range(states.shape[2])])
