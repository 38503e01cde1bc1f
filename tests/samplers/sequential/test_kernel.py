"""The mixture kernel (fewer than 20 variables): free axes and a density that is exactly the
one sampled from."""

from __future__ import annotations

import numpy as np

from vectorid.samplers.sequential.kernel import Proposal, fit_proposal, free_axes


def slab_population(n: int, rng: np.random.Generator) -> np.ndarray:
    """Axes 0-1 pinned near 0.4 and 0.6, axis 2 spread over the box but tied to axis 0
    (x2 = 0.5 + 8 (x0 - 0.4) + a little), axes 3-6 uniform on the box."""
    U = rng.random((n, 7))
    U[:, 0] = 0.4 + 0.05 * (U[:, 0] - 0.5)
    U[:, 1] = 0.6 + 0.05 * (U[:, 1] - 0.5)
    U[:, 2] = np.clip(0.5 + 8.0 * (U[:, 0] - 0.4) + 0.05 * rng.standard_normal(n), 0.0, 1.0)
    return U


def test_free_axes_are_the_uniform_unpredicted_ones():
    rng = np.random.default_rng(0)
    U = slab_population(400, rng)
    assert free_axes(np.cov(U.T), 0.8, 400) == (3, 4, 5, 6)
    # sixteen members explain any axis by chance (unadjusted, no axis is free for half of
    # these seeds): the regression's R² is adjusted for the number of members
    unadjusted = []
    for seed in range(6):
        few = slab_population(16, np.random.default_rng(seed))
        unadjusted.append(free_axes(np.cov(few.T), 0.8))
        free = free_axes(np.cov(few.T), 0.8, 16)
        assert set(free) <= {3, 4, 5, 6} and len(free) >= 3, (seed, free)
    assert () in unadjusted


def test_free_axes_are_drawn_uniformly_and_the_density_is_normalised():
    """E_q[1_R / q] is the volume of R: the density the weights use is the one the draws
    come from, free axes, truncation to the box and all."""
    rng = np.random.default_rng(1)
    U = slab_population(300, rng)
    kernel = fit_proposal(U, np.zeros(len(U)), rng, scale=0.75, free_from=0.8)
    assert kernel.free == (3, 4, 5, 6)
    V, kernel = kernel.sample(40_000, rng)
    assert np.all((V >= 0) & (V <= 1))
    for j in kernel.free:  # uniform on [0, 1], whatever the centres
        assert abs(np.mean(V[:, j]) - 0.5) < 0.01 and abs(np.var(V[:, j]) - 1 / 12) < 0.003
    # R: a region the kernel covers well (x0, x1 on the slab, x2 around its middle)
    R = (np.abs(V[:, 0] - 0.4) < 0.01) & (np.abs(V[:, 1] - 0.6) < 0.01)
    R &= np.abs(V[:, 2] - 0.5) < 0.05
    terms = np.where(R, np.exp(-kernel.logpdf(V)), 0.0) / (0.02 * 0.02 * 0.1)
    assert abs(terms.mean() - 1.0) < 4 * terms.std() / np.sqrt(len(V)), terms.mean()
    # a density off by a factor 1.2 would be seen
    assert 4 * terms.std() / np.sqrt(len(V)) < 0.15
    # stored and read back, the same density
    record = {"kind": "mixture", "log_mass": kernel.log_mass, "draws": kernel.draws,
              "free": list(kernel.free)}  # fmt: skip
    again = Proposal.stored(record, kernel.centres, kernel.log_mix, kernel.chol)
    np.testing.assert_array_equal(again.logpdf(V[:500]), kernel.logpdf(V[:500]))
    # a record without free axes (a store written before them) reads as all axes tied
    old = Proposal.stored({k: v for k, v in record.items() if k != "free"}, kernel.centres,
                          kernel.log_mix, kernel.chol)  # fmt: skip
    assert old.free == ()
