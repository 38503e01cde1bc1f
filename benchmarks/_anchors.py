"""The strongest samplers we know, set up on a study's D for ``benchmarks/sequential.py``.

Each anchor gets the same target: the study's own model (its :class:`vectorid.problem.Problem`,
built as a store's run builds it) and D exactly as :class:`vectorid.limits.Limits` defines it,
through one score ``g(x) = max_l Φ_l(x) / Φ**_l`` over the criteria with a stated limit (``inf``
where the model fails or a functional constraint is missed), so that D = {g <= 1}:

* :func:`run_dynesty` — dynesty's static nested sampling of the box (uniform prior) under the
  flat-top likelihood ``log L = -max(1, g)``, 200 live points, stopped by ``logl_max``: when the
  likelihood reaches its maximum everywhere, i.e. every live point is in D (dynesty's plateau
  stop; ``dlogz = 0`` so that the evidence criterion never stops it earlier, since with a
  flat-top likelihood the evidence is dominated by the shell just outside a small D). Its
  proposal is dynesty's default for the dimension (uniform in the bounding ellipsoids below 10
  parameters) and ``rslice`` (random slices, ``3 + p`` slices per new point) from 10 on.
  D's members: the final live points, equal weights. dynesty calls the model one vector at a
  time.
* :func:`run_ultranest` — UltraNest's reactive nested sampler, *vectorised* (the model is
  evaluated on UltraNest's whole batch of draws at once), the same flat-top likelihood, at least
  200 live points, one pass (no improvement loops), run until every live point is in D
  (``frac_remain`` 1e-300, ``Lepsilon`` 1e-12: the same reason as dynesty's ``dlogz = 0``).
  Region sampling (MLFriends) below 10 parameters; from 10 on UltraNest's own recommendation
  for many parameters, a slice step sampler (``SliceSampler`` with mixed random directions,
  ``2 p`` steps). D's members: the weighted samples at the top of the plateau (log L = -1),
  weighted as UltraNest weighs them.
* :func:`run_subset` — OpenTURNS' ``SubsetSampling`` (subset simulation, Au & Beck 2001: the
  same idea as the sequential sampler's moves, tighten the threshold, move by MCMC) on the event
  ``g <= 1`` with the box as a product of uniforms, ``N`` samples per level evaluated in one
  batch each, conditional probability ``p0``. D's members: the last level's samples that meet
  the event (``getEventInputSample``), equal weights; N is chosen so that the last level holds
  the population (``N p0 >= population``).

Every runner returns a :class:`Sample`: D's members (in the box's units), their weights (None:
equal), the evaluations and a note; a missing package gives an empty sample whose note says how
to install it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

#: log-likelihood given to a trial whose model failed or that misses a functional constraint:
#: finite (nested samplers treat -inf poorly) and far below any score of a computed trial.
FAILED_LOGL = -1e100


class Target:
    """D of a study as one score ``g`` (module docstring), with an evaluation counter.

    Parameters
    ----------
    spec : StudySpec
        The study (its criteria with stated limits define D).
    """

    def __init__(self, spec) -> None:
        from vectorid.builders import build_problem
        from vectorid.limits import Limits, oriented

        self.spec = spec
        self.problem = build_problem(spec)
        self.limits = Limits(spec)
        self._oriented = oriented
        self.idx, self.floor = self.limits.constrained()
        if not len(self.idx) or np.any(self.floor <= 0):
            raise ValueError("the anchors need positive criteria limits (max Φ/Φ** <= 1 is D)")
        space = spec.space
        self.names = list(space.names)
        self.low = np.asarray(space.lows, dtype=float)
        self.high = np.asarray(space.highs, dtype=float)
        self.calls = 0  # model evaluations so far

    @property
    def p(self) -> int:
        return len(self.names)

    def to_box(self, U: np.ndarray) -> np.ndarray:
        """Points of the unit cube (n, p) in the box's units."""
        return self.low + np.asarray(U, float) * (self.high - self.low)

    def score(self, X: np.ndarray) -> np.ndarray:
        """``g`` (n,) of the points ``X`` (n, p) in the box's units; counts ``n`` evaluations.
        ``g <= 1`` exactly where :meth:`Limits.feasible_mask` says the trial is in D."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        if not len(X):
            return np.empty(0)
        self.calls += len(X)
        res = self.problem.evaluate(X)
        F = self._oriented(res.criteria, self.limits.senses)[:, self.idx]
        with np.errstate(invalid="ignore"):
            g = np.max(F / self.floor, axis=1)
        g = np.where(np.isfinite(g), g, np.inf)
        inside = self.limits.feasible_mask(res.status, res.criteria, res.functionals)
        # a functional missed, or a criterion with a limit on its other side: not in D
        g[~inside & (g <= 1.0)] = np.inf
        return g

    def logl(self, X: np.ndarray) -> np.ndarray:
        """The flat-top log-likelihood ``-max(1, g)`` (:data:`FAILED_LOGL` where ``g`` is inf)."""
        g = self.score(X)
        return np.where(np.isfinite(g), -np.maximum(1.0, g), FAILED_LOGL)


@dataclass
class Sample:
    """An anchor's answer: D's members and what it cost."""

    method: str
    X: np.ndarray  # (n, p) members of D, box units
    weights: np.ndarray | None  # (n,) or None (equal)
    evaluations: int
    reached: bool
    note: str = ""
    extra: dict = field(default_factory=dict)


def _missing(method: str, package: str) -> Sample:
    return Sample(method, np.empty((0, 0)), None, 0, False,
                  f"skipped: {package} not installed (pip install 'vectorid[bench]')")  # fmt: skip


def run_dynesty(t: Target, population: int, budget: int, seed: int = 1) -> Sample:
    """dynesty, static nested sampling with ``logl_max`` (module docstring)."""
    try:
        import dynesty
    except ImportError:
        return _missing("dynesty", "dynesty")
    import warnings

    p = t.p
    sample = "auto" if p < 10 else "rslice"

    def loglike(u):
        return float(t.logl(t.to_box(u[None, :]))[0])

    def prior(u):
        return u  # the unit cube; the box's units are applied inside loglike

    start = t.calls
    sampler = dynesty.NestedSampler(loglike, prior, p, nlive=population, sample=sample,
                                    rstate=np.random.default_rng(seed))  # fmt: skip
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "reached the plateau ... stopping": the stop we want
        sampler.run_nested(dlogz=0.0, logl_max=-1.0, maxcall=budget, print_progress=False,
                           add_live=False)  # fmt: skip
    live_l = np.asarray(sampler.live_logl)
    inside = live_l >= -1.0
    X = t.to_box(np.asarray(sampler.live_u)[inside])
    reached = bool(inside.all())
    evaluations = t.calls - start
    # dynesty's own call count (its ``maxcall``) includes slice steps outside the unit cube,
    # which call no model: it can stop below ``budget`` model evaluations
    note = "" if reached else (f"budget spent with {int(inside.sum())} of {population} live "
                               f"points in D (best max Φ/Φ** {-live_l.max():.3g}; dynesty's "
                               f"call count {sampler.ncall:,}, steps outside the box "
                               "included)")  # fmt: skip
    return Sample("dynesty", X, None, evaluations, reached, note,
                  {"sample": "unif (auto)" if sample == "auto" else sample})  # fmt: skip


def run_ultranest(t: Target, population: int, budget: int, seed: int = 1,
                  popsize: int = 100, nsteps: float = 2.0) -> Sample:  # fmt: skip
    """UltraNest, vectorised, flat-top likelihood (module docstring)."""
    try:
        import ultranest
        import ultranest.popstepsampler as steps
    except ImportError:
        return _missing("ultranest", "UltraNest")
    import logging

    log = logging.getLogger("ultranest")
    if not log.handlers:  # UltraNest adds a stdout handler at INFO to a logger without one
        log.addHandler(logging.NullHandler())
    log.setLevel(logging.WARNING)
    p = t.p
    np.random.seed(seed)  # UltraNest draws from numpy's global state; seeded here

    def loglike(U):
        return t.logl(t.to_box(U))

    def transform(U):
        return U

    start = t.calls
    names = [f"u{i}" for i in range(p)]  # UltraNest wants names; the unit cube's axes
    s = ultranest.ReactiveNestedSampler(names, loglike, transform, vectorized=True)
    if p >= 10:
        s.stepsampler = steps.PopulationSliceSampler(
            popsize=int(popsize), nsteps=int(nsteps * p),
            generate_direction=steps.generate_mixture_random_direction,
        )  # fmt: skip
    r = s.run(min_num_live_points=population, max_ncalls=budget, frac_remain=1e-300,
              Lepsilon=1e-12, max_num_improvement_loops=0, show_status=False,
              viz_callback=False)  # fmt: skip
    ws = r["weighted_samples"]
    L = np.asarray(ws["logl"], float)
    inside = L >= -1.0
    X = t.to_box(np.asarray(ws["upoints"], float)[inside])
    w = np.asarray(ws["weights"], float)[inside]
    evaluations = t.calls - start
    members = int(inside.sum())
    reached = members >= population and evaluations < budget
    note = "" if reached else (f"budget spent: {members} members of D "
                               f"(best max Φ/Φ** {-L.max():.3g})")  # fmt: skip
    return Sample("ultranest", X, w if members else None, evaluations, reached, note,
                  {"sampler": "slice" if p >= 10 else "MLFriends"})  # fmt: skip


#: Subset simulation: the conditional probability per level (Au & Beck's and OpenTURNS' 0.1) and
#: the proposal's range in the standard normal space. OpenTURNS' default range, 2, leaves most
#: moves rejected on these twins (parachute3, N = 2000: 134 distinct members of 655, ESS 15);
#: 0.5 gave the largest ESS that still passed the KS check on parachute3 and parachute15
#: (0.25: more distinct members, but chains too short to leave their seeds: KS fails).
SUBSET_P0 = 0.1
SUBSET_RANGE = 0.5
#: Subset simulation: samples per level N = population / p0 x 2^k, k = 0, 1, ..., until the last
#: level's members reach an ESS of ``population``.
SUBSET_TRIES = 5


def run_subset(t: Target, population: int, budget: int, seed: int = 1) -> Sample:
    """OpenTURNS SubsetSampling on ``g <= 1`` (module docstring): N doubled until the last
    level's members (repeats counted as weights) reach an ESS of ``population``; the evaluations
    are those of that run alone, as if N had been known, and the earlier tries are noted (where
    no try reaches D within ``budget``, every try's evaluations count)."""
    try:
        import openturns as ot
    except ImportError:
        return _missing("subset", "OpenTURNS")
    p = t.p
    ot.Log.Show(ot.Log.NONE)

    def g_sample(U):
        g = t.score(t.to_box(np.asarray(U, float)))
        return np.where(np.isfinite(g), g, 1e300)[:, None].tolist()  # OpenTURNS wants finite

    model = ot.PythonFunction(p, 1, func_sample=g_sample)
    box = ot.JointDistribution([ot.Uniform(0.0, 1.0)] * p)
    event = ot.ThresholdEvent(ot.CompositeRandomVector(model, ot.RandomVector(box)),
                              ot.LessOrEqual(), 1.0)  # fmt: skip
    tries: list[str] = []
    spent_all = 0
    for k in range(SUBSET_TRIES):
        n = math.ceil(population / SUBSET_P0) * 2**k
        ot.RandomGenerator.SetSeed(seed)
        start = t.calls
        algo = ot.SubsetSampling(event, SUBSET_RANGE, SUBSET_P0)
        algo.setMaximumOuterSampling(1)  # one batch of N evaluations per level
        algo.setBlockSize(n)
        algo.setKeepSample(True)

        def spent(start: int = start, cap: int = budget - spent_all) -> int:
            return int(t.calls - start >= cap)  # held in a name: OpenTURNS keeps no reference

        algo.setStopCallback(spent)
        try:
            algo.run()
            stopped = False
        except RuntimeError:  # "Interruption": the budget is spent
            stopped = True
        evaluations = t.calls - start
        spent_all += evaluations
        last = algo.getStepsNumber() - 1
        U = np.empty((0, p))
        if not stopped and last >= 0:
            U = np.asarray(algo.getInputSample(last, ot.SubsetSampling.EVENT1), float)
            U = U.reshape(-1, p)
        _, counts = np.unique(U, axis=0, return_counts=True)
        ess = float(counts.sum() ** 2 / np.sum(counts**2)) if len(counts) else 0.0
        if stopped or ess >= population - 0.5 or spent_all >= budget:
            break
        tries.append(f"N {n}: {evaluations:,} evaluations, ESS {ess:.0f}")
    X = t.to_box(U)
    reached = len(X) >= population and not stopped
    note = "" if reached else (f"{len(counts)} distinct members of D after {last + 1} levels "
                               f"(population {population}, budget {budget})")  # fmt: skip
    if tries and reached:
        note = "; ".join(x for x in (note, "tries not counted: " + "; ".join(tries)) if x)
    elif tries:  # D not reached: every try's evaluations count
        evaluations = spent_all
        note += "; all tries counted: " + "; ".join(tries)
    return Sample("subset", X, None, evaluations, reached, note,
                  {"N": n, "p0": SUBSET_P0, "range": SUBSET_RANGE, "levels": last + 1})  # fmt: skip
