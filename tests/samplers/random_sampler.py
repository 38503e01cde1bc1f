"""A plain random sampler, written as a user would add one: this file and one registration.

``register_sampler("random", "tests.samplers.random_sampler:RandomSampler")`` makes
``[study] sampler = "random"`` work in study files, runs, every analysis and the command line;
nothing in the store, the analysis or the command line names it.
"""

from __future__ import annotations

from collections.abc import Generator

import numpy as np

from vectorid.samplers import Round, RoundResult, RunContext, RunSettings, Sampler
from vectorid.store import Store

BLOCK = 256


class RandomSampler(Sampler):
    """Uniform points of the box, block ``b`` drawn from a generator seeded ``(seed, b)``, so
    sequence index ``i`` is always the same point however a run is split."""

    def _configure(self, store: Store, *, trials, budget, population) -> RunSettings:
        spec = self.spec
        save = {}
        if trials is not None and int(trials) != spec.trials:
            save["trials"] = int(trials)
            spec = spec.with_study_keys(trials=int(trials))
        plan = [(0, 0, spec.trials)]
        return RunSettings(spec, save, spec.trials, store.missing_in(plan))

    def _unit(self, start: int, n: int) -> np.ndarray:
        p = len(self.spec.space)
        out = np.empty((n, p))
        for b in range(start // BLOCK, (start + n - 1) // BLOCK + 1):
            pts = np.random.default_rng([self.spec.seed, b]).random((BLOCK, p))
            lo, hi = max(start, b * BLOCK), min(start + n, (b + 1) * BLOCK)
            out[lo - start : hi - start] = pts[lo - b * BLOCK : hi - b * BLOCK]
        return out

    def _rounds(self, store: Store, ctx: RunContext) -> Generator[Round, RoundResult, None]:
        space = ctx.settings.spec.space
        yield Round(0, 0, ctx.settings.target, lambda s, n: space.scale(self._unit(s, n)))

    def planned(self, store: Store) -> list[tuple[int, int, int]]:
        return [(0, 0, int(self.spec.trials))]

    def points(self, store: Store, stage: int, start: int, n: int) -> np.ndarray:
        return self.spec.space.scale(self._unit(start, n))
