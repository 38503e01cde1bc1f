"""The plain table: the study's point sequence (Sobol LP_tau or Latin hypercubes) in order.

The study should hold the sequence indices ``0 .. target - 1`` across its sample stages; stage
``s`` owns the indices from its ``start_seq`` up to the next sample stage's start (a refined
box, double tuning, continues the sequence). A run computes exactly the indices no stored batch
holds, planned lazily, so a target of 10^12 trials costs no more memory than one of 10^3.
"""

from __future__ import annotations

from collections.abc import Generator

import numpy as np

from ..errors import StudyDefinitionError
from ..store import Store
from .base import Round, RoundResult, RunContext, RunSettings, Sampler

__all__ = ["SOBOL_POINTS", "TableSampler", "sample_spans"]

#: Points scipy's Sobol engine can give (``bits=30``); index i is point i + 1 unscrambled.
SOBOL_POINTS = 2**30


def sample_spans(store: Store, target: int) -> list[tuple[int, int, int]]:
    """``(stage, start, end)`` of each sample stage's share of the sequence ``0 .. target-1``.

    Parameters
    ----------
    store : Store
    target : int
        Trials the study should hold.
    """
    sample = [s for s in store.stages() if s.kind == "sample"]
    spans = []
    for i, stage in enumerate(sample):
        end = sample[i + 1].start_seq if i + 1 < len(sample) else target
        end = min(end, target)
        if end > stage.start_seq:
            spans.append((stage.stage, stage.start_seq, end))
    return spans


class TableSampler(Sampler):
    """The plain table of the PSI method: every point of the sequence, in order."""

    def _check_capacity(self, target: int) -> None:
        """Refuse a target the point sequence cannot reach (before computing anything)."""
        spec = self.spec
        if spec.point_sequence().kind != "sobol":
            return
        most = SOBOL_POINTS - (0 if spec.scramble else 1)
        if target > most:
            raise StudyDefinitionError(
                "trials",
                f"{target} trials are more than the Sobol sequence can give here: at most "
                f"{most} (scipy's Sobol engine holds 2**30 = {SOBOL_POINTS} points)",
                f'use at most {most} trials, or sampler = "lhs" (Latin hypercube blocks, no '
                "such limit)",
            )

    def _configure(
        self, store: Store, *, trials: int | None, budget: int | None, population: int | None
    ) -> RunSettings:
        spec = self.spec
        notes: list[str] = []
        save: dict[str, int] = {}
        stored = store.count_sample()
        if trials is not None:
            trials = int(trials)
            self._check_capacity(trials)
            if trials < stored:
                notes.append(
                    f"the store holds {stored} trials, more than the {trials} asked for: "
                    "nothing to compute, every stored trial is kept (analyses use all of "
                    f"them), and the study's target stays {max(spec.trials, stored)}"
                )
                trials = max(spec.trials, stored)
            if trials != spec.trials:
                save["trials"] = trials
        target = int(trials if trials is not None else spec.trials)
        self._check_capacity(target)
        work = store.missing_in(sample_spans(store, target))
        settings = RunSettings(spec, save, target, work, notes)
        if save:
            settings.spec = spec.with_study_keys(**save)
        return settings

    def _rounds(self, store: Store, ctx: RunContext) -> Generator[Round, RoundResult, None]:
        target = ctx.settings.target
        spaces = {s.stage: s.space for s in store.stages()}
        seq = self.spec.point_sequence()
        for stage, start, end in sample_spans(store, target):
            space = spaces[stage]
            yield Round(stage, start, end, lambda s, n, space=space: space.scale(seq.points(s, n)))

    def planned(self, store: Store) -> list[tuple[int, int, int]]:
        return sample_spans(store, int(self.spec.trials))

    def points(self, store: Store, stage: int, start: int, n: int) -> np.ndarray:
        space = {s.stage: s.space for s in store.stages()}[stage]
        return space.scale(self.spec.point_sequence().points(start, n))
