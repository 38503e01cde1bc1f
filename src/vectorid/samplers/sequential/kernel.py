"""The proposal kernel: a Gaussian mixture on accepted members, truncated to the box.

Everything is in unit-cube coordinates ``u = (x - low) / (high - low)``, where the box Π
has volume 1 and its uniform density is 1. A mixture component sits on each centre (an
accepted member, or a member drawn in proportion to its weight when there are more than
``max_centres``); every component shares one covariance, ``scale`` times the weighted
covariance of the accepted members (Beaumont et al. 2009: twice the population's covariance
is the kernel that minimises the Kullback–Leibler divergence to the next target for a
Gaussian-like target; the sampler's schedule, :mod:`vectorid.samplers.sequential.schedule`,
uses a narrower factor on the tied axes, see ``SCALE`` there). The covariance follows the
shape of the accepted region, so a thin slab of D (a few parameters the data pin, others
free) is sampled along the slab, not across it.

Axes along which the members spread like the box's uniform density, unpredicted by the other
axes (:func:`free_axes`), are *free*: they are drawn uniformly on [0, 1], independently of
the centre, and only the other (*tied*) axes follow the mixture. A Gaussian kernel as wide as
the box, truncated to it, is lower near its faces (about 0.6 of its centre per axis), and
over a dozen such axes the importance weights of D's members spread by orders of magnitude:
on the 15-parameter parachute twin, D's effective sample size was 14 % of its members with
every axis Gaussian and about 85 % with eleven axes free.

Draws that fall outside the box are discarded without evaluating the model; the kernel's
mass inside the box, ``Z``, is estimated from the draws (at least :data:`MASS_DRAWS` of
them), so the truncated density ``q(u) = mixture(u) / Z`` that the weights need is known.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["MASS_DRAWS", "Proposal", "fit_proposal"]

#: Fewest draws used to estimate a kernel's in-box mass Z.
MASS_DRAWS = 20_000
#: Share of a kernel's draws that must land inside the box (else the kernel is narrowed).
MIN_IN_BOX = 0.05
#: Draws used to check that share.
_PROBE = 4000
#: Rows per chunk when evaluating mixture densities (bounds memory to chunk x centres).
_CHUNK = 2048


@dataclass(frozen=True)
class Proposal:
    """One generation's proposal density on the unit cube.

    Attributes
    ----------
    kind : {"sobol", "mixture"}
        ``"sobol"``: the uniform density of the box (generation 0, the Sobol table).
    centres : (m, p) float array
        Component means (unit coordinates); empty for ``"sobol"``.
    log_mix : (m,) float array
        Log mixture weights (they sum to one).
    chol : (p, p) float array
        Lower Cholesky factor of the shared covariance (unit coordinates).
    log_mass : float
        Log of the mixture's mass inside the box (0 for ``"sobol"``).
    draws : int
        Draws made to estimate the mass.
    """

    kind: str
    centres: np.ndarray
    log_mix: np.ndarray
    chol: np.ndarray
    log_mass: float = 0.0
    draws: int = 0
    free: tuple[int, ...] = ()

    @classmethod
    def uniform(cls, p: int) -> Proposal:
        """The box's uniform density (generation 0)."""
        return cls("sobol", np.empty((0, p)), np.empty(0), np.eye(p))

    @classmethod
    def stored(
        cls, record: dict, centres: np.ndarray, log_mix: np.ndarray, chol: np.ndarray
    ) -> Proposal:
        """The proposal a stored generation records (its JSON ``record`` and arrays)."""
        p = chol.shape[0]
        if record.get("kind") == "sobol":
            return cls.uniform(p)
        return cls("mixture", centres, log_mix, chol, float(record.get("log_mass", 0.0)),
                   int(record.get("draws", 0)),
                   tuple(int(j) for j in record.get("free", ())))  # fmt: skip

    @property
    def tied(self) -> np.ndarray:
        """Axes the Gaussian mixture draws (the others, :attr:`free`, are uniform)."""
        p = self.centres.shape[1]
        return np.setdiff1d(np.arange(p), np.asarray(self.free, dtype=np.int64))

    def logpdf(self, U: np.ndarray) -> np.ndarray:
        """Log density of the box-truncated proposal at unit points ``U`` (n, p); ``-inf``
        outside the box."""
        U = np.atleast_2d(np.asarray(U, dtype=float))
        inside = np.all((U >= 0.0) & (U <= 1.0), axis=1)
        out = np.full(U.shape[0], -np.inf)
        if self.kind == "sobol":
            out[inside] = 0.0
            return out
        tied = self.tied
        if not len(tied):  # every axis uniform: the box's density
            out[inside] = 0.0
            return out
        # the free axes are uniform on [0, 1] (density 1): only the tied axes count
        U = U[:, tied]
        p = U.shape[1]
        L = self.chol[np.ix_(tied, tied)]
        centres = self.centres[:, tied]
        log_det = float(np.sum(np.log(np.diag(L))))
        const = -0.5 * p * math.log(2.0 * math.pi) - log_det - self.log_mass
        from scipy.linalg import solve_triangular

        # whitening by L^-1 once (p x p), then matrix products: far cheaper than a
        # triangular solve per chunk of points
        Linv_t = solve_triangular(L, np.eye(p), lower=True).T
        C = centres @ Linv_t  # whitened centres (m, p)
        c2 = np.einsum("ij,ij->i", C, C)
        half_c = self.log_mix - 0.5 * c2  # (m,)
        for a in range(0, U.shape[0], _CHUNK):
            Y = U[a : a + _CHUNK] @ Linv_t
            # log_mix - d2/2 with d2 = |y|^2 + |c|^2 - 2 y.c; |y|^2 is common to every centre
            e = Y @ C.T
            e += half_c[None, :]
            top = e.max(axis=1)
            e -= top[:, None]
            np.exp(e, out=e)
            y2 = np.einsum("ij,ij->i", Y, Y)
            out[a : a + _CHUNK] = top + np.log(e.sum(axis=1)) - 0.5 * y2 + const
        out[~inside] = -np.inf
        return out

    def sample(self, n: int, rng: np.random.Generator) -> tuple[np.ndarray, Proposal]:
        """``n`` draws inside the box and the proposal with its in-box mass estimated.

        Draws outside the box are discarded (never evaluated). Returns the in-box points
        (n, p), in draw order, and a copy of the proposal with ``log_mass`` and ``draws``
        set from every draw made (at least :data:`MASS_DRAWS`).

        Raises
        ------
        RuntimeError
            When fewer than one draw in 10^4 lands in the box.
        """
        p = self.centres.shape[1]
        kept: list[np.ndarray] = []
        have = drawn = inside_total = 0
        block = max(4 * n, 1024)
        while have < n or drawn < MASS_DRAWS:
            idx = rng.choice(len(self.log_mix), size=block, p=np.exp(self.log_mix))
            U = self.centres[idx] + rng.standard_normal((block, p)) @ self.chol.T
            if self.free:
                U[:, list(self.free)] = rng.random((block, len(self.free)))
            ok = np.all((U >= 0.0) & (U <= 1.0), axis=1)
            drawn += block
            inside_total += int(ok.sum())
            if have < n:
                take = U[ok][: n - have]
                kept.append(take)
                have += len(take)
            if drawn >= 1000 * max(n, MASS_DRAWS) and inside_total * 10_000 < drawn:
                raise RuntimeError("the proposal puts almost no mass inside the box")
        mass = inside_total / drawn
        fitted = Proposal(self.kind, self.centres, self.log_mix, self.chol, math.log(mass), drawn,
                          self.free)  # fmt: skip
        return np.concatenate(kept)[:n], fitted


def _weighted_cov(U: np.ndarray, w: np.ndarray) -> np.ndarray:
    w = w / w.sum()
    mean = w @ U
    D = U - mean
    cov = (D * w[:, None]).T @ D
    ess = 1.0 / float(np.sum(w**2))
    return cov * (ess / max(ess - 1.0, 1.0))


def fit_proposal(
    U: np.ndarray,
    log_w: np.ndarray,
    rng: np.random.Generator,
    *,
    scale: float = 2.0,
    max_centres: int = 1000,
    free_from: float | None = None,
) -> Proposal:
    """The next generation's kernel from the accepted members.

    Parameters
    ----------
    U : (m, p) float array
        Accepted members in unit coordinates.
    log_w : (m,) float array
        Their log importance weights (any constant offset).
    rng : numpy.random.Generator
        Draws the centres when there are more than ``max_centres`` members.
    scale : float
        Covariance (of the tied axes) = ``scale`` x the weighted covariance of the members,
        halved until at least :data:`MIN_IN_BOX` of the kernel's draws land inside the box.
    max_centres : int
        Most mixture components.
    free_from : float, optional
        Axes along which the members spread at least this share of the box's own spread
        (weighted standard deviation against ``1/sqrt(12)``), and which the other axes do not
        predict (:func:`free_axes`), are drawn uniformly on [0, 1] instead (:attr:`Proposal.free`).
        None: every axis is drawn from the mixture.
    """
    U = np.asarray(U, dtype=float)
    m, p = U.shape
    w = np.exp(log_w - np.max(log_w))
    if m > max_centres:
        pick = rng.choice(m, size=max_centres, replace=True, p=w / w.sum())
        idx, counts = np.unique(pick, return_counts=True)
        centres = U[idx]
        mix = counts.astype(float)
    else:
        centres = U
        mix = w
    log_mix = np.log(mix) - math.log(float(mix.sum()))
    cov = _weighted_cov(U, w) if m >= 2 else np.zeros((p, p))
    n_eff = float(w.sum() ** 2 / np.sum(w**2)) if m else 0.0
    free = free_axes(cov, free_from, n_eff) if free_from is not None and m >= p + 1 else ()
    cov = scale * cov
    if free:
        # the free axes are drawn on their own: no covariance with the tied ones
        cov[list(free), :] = 0.0
        cov[:, list(free)] = 0.0
        cov[list(free), list(free)] = 1.0
    # Keep the kernel proper: no direction narrower than 1e-4 of the box (a population
    # of identical members, or fewer members than parameters).
    cov = 0.5 * (cov + cov.T) + np.eye(p) * 1e-8
    floor = np.maximum(np.diag(cov), 1e-8)
    if m < p + 1:
        cov = np.diag(np.maximum(floor, 0.05**2))
    # In many dimensions a kernel as wide as the population puts almost no draw inside the
    # box (0.6 per axis is 5e-8 over 33 axes): narrow it until at least MIN_IN_BOX of the
    # draws land inside. The density stays exactly known: the weights use this kernel.
    shrink = 1.0
    mix = np.exp(log_mix)
    for _ in range(12):
        L = cholesky(cov * shrink)
        idx = rng.choice(len(mix), size=_PROBE, p=mix)
        Z = centres[idx] + rng.standard_normal((_PROBE, p)) @ L.T
        Z[:, list(free)] = 0.5
        if np.mean(np.all((Z >= 0.0) & (Z <= 1.0), axis=1)) >= MIN_IN_BOX:
            break
        shrink *= 0.5
    return Proposal("mixture", centres, log_mix, L, free=tuple(free))


#: A free axis may be predicted by the tied ones at most this well (R² of the regression).
FREE_R2 = 0.2


def free_axes(cov: np.ndarray, spread: float, n: float = math.inf) -> tuple[int, ...]:
    """Axes a population spreads across like the box's uniform density, unpredicted by the
    others.

    An axis is free when the population's standard deviation along it is at least ``spread``
    times the box's (``1/sqrt(12)`` in unit coordinates) and a linear regression on the
    remaining (tied) axes explains less than :data:`FREE_R2` of its variance; axes are moved
    from free to tied until that holds for all. Drawing the free axes uniformly keeps the
    proposal flat along them: a Gaussian kernel truncated to the box is lower near its faces
    by a factor that compounds over axes (0.6 per axis of a population as wide as the box),
    which spreads the importance weights of D's members and lowers their effective sample
    size.
    """
    p = len(cov)
    sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
    free = [j for j in range(p) if sd[j] >= spread / math.sqrt(12.0)]
    while free:
        tied = [j for j in range(p) if j not in free]
        if not tied:
            break
        S = cov[np.ix_(tied, tied)] + np.eye(len(tied)) * 1e-12
        B = np.linalg.solve(S, cov[np.ix_(tied, free)])  # (t, f)
        r2 = np.einsum("tf,tf->f", cov[np.ix_(tied, free)], B) / np.maximum(sd[free] ** 2, 1e-300)
        # adjusted for the regressors' number: n members regressed on k axes explain
        # k / (n - 1) of the variance by chance alone
        k = len(tied)
        if math.isfinite(n):
            dof = n - k - 1.0
            r2 = 1.0 - (1.0 - r2) * (n - 1.0) / dof if dof > 1.0 else np.zeros_like(r2)
        worst = int(np.argmax(r2))
        if r2[worst] < FREE_R2:
            break
        free.pop(worst)
    return tuple(free)


def cholesky(cov: np.ndarray) -> np.ndarray:
    jitter = 1e-10
    for _ in range(12):
        try:
            return np.linalg.cholesky(cov + np.eye(len(cov)) * jitter)
        except np.linalg.LinAlgError:
            jitter *= 10.0
    return np.diag(np.sqrt(np.maximum(np.diag(cov), 1e-8)))
