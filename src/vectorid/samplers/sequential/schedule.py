"""The sequential sampler's schedule: how far each generation tightens the limits, how many
points it draws, and from which kernel (a Gaussian mixture on the accepted members, or, with
many variables, one random-walk move of every particle).

Every function here is a function of the seed, the generation number, the study's limits and
the stored trials of earlier generations only: a resumed run proposes exactly the generations an
uninterrupted one does.
"""

from __future__ import annotations

import math

import numpy as np

from ...store import Trials
from .kernel import MASS_DRAWS, Proposal, cholesky, fit_proposal
from .moves import (
    DIVERSE,
    MIN_FINAL_MOVES,
    adapt_scale,
    copy_evenly,
    in_box_mass,
    initial_scale,
    move_draws,
    particle_cov,
)
from .state import (
    Generation,
    SequentialState,
    cached_log_weights,
    moved_particles,
    score,
    tolerance_json,
    tolerance_of,
    unit,
)
from .tolerance import next_tolerance

#: Until D at the stated limits holds a member ("searching"), generations follow a careful
#: schedule (SEARCH_*): where D is hard to reach, the population must not narrow onto the first
#: region that looks good. Measured on the ETH flights (12 variables, D not reached, 50,000
#: evaluations; ``examples/eth_parafoil.py``): keeping half the trials and drawing 4 x population
#: per generation, the nearest generation meets the limits x1.02 with Cnr against its physical
#: floor; 0.3 and 2 x population stalled at x1.11 inside the box, and the faster settings below
#: at x1.33 (docs/sequential.md). Once a member of D is known, the population knows where D is,
#: and the faster settings reach a faithful sample in a third of the evaluations (parachute15
#: twins seeds 0-5: 1,894 evaluations on average against 5,957).
#: Members of D at the stated limits that end the search.
FOUND = 1
#: Searching: share of the trials within the last limits that meet the next ones ...
SEARCH_KEEP = 0.5
#: ... this many times ``population`` points per generation ...
SEARCH_GENERATION_FACTOR = 4
#: ... and the kernel's covariance factor (Beaumont et al. 2009), every axis Gaussian.
SEARCH_SCALE = 2.0
#: D found: later generations propose this many times ``population`` points (2 was tried:
#: the run stops a whole generation later than it needs; parachute15 twin 2,224 against 1,824).
GENERATION_FACTOR = 1
#: A generation that aims at the stated limits is sized to the ESS still wanted at the last
#: generation's rate, with this margin ...
SIZE_MARGIN = 1.15
#: ... and at least this share of ``population`` trials.
MIN_GENERATION = 0.25
#: D found: share of the trials within the last limits that meet the next generation's
#: limits ...
KEEP = 0.05
#: ... but at least this share of ``population`` (and ``2 (p + 1)``) trials: the limits drop
#: as fast as enough centres allow (0.3 of the trials took four generations to the stated
#: limits on the parachute15 twin where this takes two).
MIN_KEEP_SHARE = 0.25
#: The run has converged when D's ESS reaches this share of ``population``.
ESS_SHARE = 1.0
#: Below this share of ``population``, D's ESS means the population has collapsed.
COLLAPSE_SHARE = 0.1
#: D found: the kernel's covariance factor on the tied axes (the free ones are uniform).
#: Beaumont et al.'s 2 (2009) was the factor while every axis was Gaussian; with the free axes
#: drawn uniformly the tied block has few axes, and a narrower kernel wastes fewer draws outside
#: D. Measured (parachute15 twins seeds 0-3, mean evaluations to ESS 200): 0.5: 1,684;
#: 0.75: 1,864; 1: 1,877 (KEEP 0.1); 2: more. 0.5 made the 8-axis slab's weighted
#: marginals deviate from uniform more than their ESS allows (16 runs: Kolmogorov p 0.03 on
#: the tied axes, 0.2 at 0.75). A factor from the centres' spacing (12 n^(-2/t), t tied
#: axes) was tried: 2,145 on parachute15, 10,536 against 6,224 on the quiet twin.
SCALE = 0.75
#: D found: axes along which the accepted members spread at least this share of the box's
#: spread, unpredicted by the others, are drawn uniformly
#: (:func:`~vectorid.samplers.sequential.kernel.free_axes`).
FREE_FROM = 0.8
#: With moves (:data:`~vectorid.samplers.sequential.moves.MOVE_FROM` or more variables): particles
#: per ``population``.
PARTICLES_FACTOR = 2
#: With moves: share of the particles that meet the next generation's limits.
MOVE_KEEP = 0.7


def propose(cache, spec, state: SequentialState, gens, n: int, trials: Trials,
             population: int):  # fmt: skip
    """Generation ``len(gens)``'s points and record (a function of the seed, the generation
    number, the limits and the stored trials of earlier generations only)."""
    g = len(gens)
    rng = np.random.default_rng([int(spec.seed), g, 0x5E0])
    eps_prev = tolerance_of(gens[-1], spec, state.constrained)
    phi = state.phi
    with np.errstate(invalid="ignore"):
        in_prev = state.usable & np.all(phi <= eps_prev, axis=1)
    is_searching = searching(state)
    least = max((0 if is_searching else MIN_KEEP_SHARE) * population, 2 * (len(spec.space) + 1))
    keep = min(1.0, max(SEARCH_KEEP if is_searching else KEEP, least / max(int(in_prev.sum()), 1)))
    eps = next_tolerance(phi[in_prev], eps_prev, state.floor, keep)
    with np.errstate(invalid="ignore"):
        centres = state.usable & np.all(phi <= eps, axis=1)
    if np.all(eps <= state.floor):
        n = final_size(state, gens, n, population)
    scale = SEARCH_SCALE if is_searching else SCALE
    U = unit(spec.space, trials.X[centres])
    log_w = cached_log_weights(cache, spec, trials, state.generation, state.proposals,
                                state.counts, centres)  # fmt: skip
    kernel = fit_proposal(U, log_w, rng, scale=scale,
                          free_from=None if is_searching else FREE_FROM)  # fmt: skip
    try:
        Unew, kernel = kernel.sample(n, rng)
    except RuntimeError:
        return None
    X = spec.space.scale(Unew)
    record = {
        "kind": "mixture",
        "tolerance": tolerance_json(spec, state.constrained, eps),
        "log_mass": kernel.log_mass,
        "draws": kernel.draws,
        "centres_from": int(centres.sum()),
        "keep": keep,
        "scale": scale,
        "search": is_searching,
        "free": [int(j) for j in kernel.free],
    }
    return X, record, kernel


def move_status(spec, state: SequentialState, trials: Trials, gen: Generation, population: int):
    """(converged, ESS) after a generation of moves: converged when the limits are the stated
    ones, the chains have made at least :data:`~vectorid.samplers.sequential.moves.MIN_FINAL_MOVES`
    moves there and their ESS (from the autocorrelation of the kept moves) reaches
    ``population``."""
    _, _, eps = moved_particles(spec, state, trials, gen)
    at_floor = bool(np.all(eps <= state.floor))
    m = 0 if state.chains is None else int(state.chains.shape[0])
    done = at_floor and m >= MIN_FINAL_MOVES and state.ess >= ESS_SHARE * population
    return done, state.ess


def propose_move(cache, spec, state: SequentialState, gens, n: int, trials: Trials,
                  left: int):  # fmt: skip
    """Generation ``len(gens)`` with moves (:mod:`vectorid.samplers.sequential.moves`): ``n``
    particles, each moved once; at most ``left`` draws evaluated. A function of the seed, the
    generation number, the limits and the stored trials of earlier generations only."""
    g = len(gens)
    rng = np.random.default_rng([int(spec.seed), g, 0x5E1])
    p = len(spec.space)
    last = gens[-1]
    mv = last.proposal.get("move")
    if mv is None:  # the first moves start from the Sobol table (generation 0)
        eps_prev = tolerance_of(last, spec, state.constrained)
        P = np.flatnonzero(state.usable & (state.generation == 0))
        scale, level_moves, tighten = initial_scale(p), 0, True
    else:
        P, accepted, eps_prev = moved_particles(spec, state, trials, last)
        scale = adapt_scale(float(mv["scale"]), accepted)
        level_moves = int(mv["level_moves"])
        tighten = len(np.unique(P)) >= DIVERSE * len(P)
    if not len(P):
        return None
    eps = eps_prev
    if tighten and not np.all(eps_prev <= state.floor):
        eps = next_tolerance(state.phi[P], eps_prev, state.floor, MOVE_KEEP)
        with np.errstate(invalid="ignore"):
            alive = np.unique(P[np.all(state.phi[P] <= eps, axis=1)])
        P = copy_evenly(alive, n, rng)
        level_moves = 0
    elif len(P) != n:
        P = copy_evenly(np.unique(P), n, rng)
    level_moves += 1
    U = unit(spec.space, trials.X[P])
    cov = particle_cov(U)
    for _ in range(12):
        L = cholesky(cov * scale)
        draws, parents = move_draws(U, L, rng)
        if len(draws):
            break
        scale *= 0.5
    else:
        return None
    draws, parents = draws[:left], parents[:left]
    rows, copies = np.unique(P, return_counts=True)
    mass = in_box_mass(U, L, rng, MASS_DRAWS)
    kernel = Proposal("mixture", unit(spec.space, trials.X[rows]),
                      np.log(copies / copies.sum()), L, math.log(mass), MASS_DRAWS)  # fmt: skip
    record = {
        "kind": "mixture",
        "tolerance": tolerance_json(spec, state.constrained, eps),
        "log_mass": kernel.log_mass,
        "draws": kernel.draws,
        "centres_from": len(rows),
        "keep": KEEP,
        "scale": scale,
        "move": {
            "particles": [int(v) for v in trials.seq[P]],
            "parents": [int(v) for v in parents],
            "scale": scale,
            "level_moves": level_moves,
        },
    }
    return spec.space.scale(draws), record, kernel


def searching(state: SequentialState) -> bool:
    """True while D at the stated limits holds fewer than :data:`FOUND` members: the next
    generation follows the careful schedule (``SEARCH_*``)."""
    return int(state.members.sum()) < FOUND


def final_size(state: SequentialState, gens, full: int, population: int) -> int:
    """Trials of a generation that aims at the stated limits: as many as the ESS still wanted
    needs at the rate of the last generation (members of D it added per trial x D's ESS per
    member; a generation aiming at the stated limits does at least as well as one aiming
    wider), with :data:`SIZE_MARGIN` to spare; ``full`` when the last generation added none."""
    if len(gens) < 2:
        return full
    last = gens[-1].gen
    added = int(np.sum(state.members & (state.generation == last)))
    members = int(state.members.sum())
    if not added or not members:
        return full
    rate = added / max(state.counts[last], 1) * state.ess / members
    need = (population * ESS_SHARE - state.ess) / max(rate, 1e-12) * SIZE_MARGIN
    return int(min(full, max(MIN_GENERATION * population, math.ceil(need))))


def relaxed_of_best(state: SequentialState, population: int) -> float | None:
    """Generation 0 only: the factor on the limits that ``population`` trials meet."""
    s = score(state.phi[state.usable], state.floor)
    if not len(s) or not np.all(state.floor > 0):
        return None
    s = np.sort(s)
    return float(max(1.0, s[min(population, len(s)) - 1]))
