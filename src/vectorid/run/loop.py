"""The run loop: which trials are missing, batching, progress, storing, resuming.

The study should hold the sequence indices ``0 .. target - 1`` across its sample stages;
stage ``s`` owns the indices from its ``start_seq`` up to the next sample stage's start.
A run computes exactly the indices that no stored batch holds, so a run interrupted at any
point (Ctrl-C, ``kill -9``) resumes with no trial lost and none stored twice: a batch is
written in one transaction, and a batch that was being computed when the run died was not
stored and is computed again.
"""

from __future__ import annotations

import collections
import math
import re
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import TextIO

import numpy as np

from ..problem import FAILED
from ..store.sqlite import Store
from .executors import make_executor

__all__ = ["RunInterrupted", "RunSummary", "plan", "run_store"]


class RunInterrupted(KeyboardInterrupt):
    """The run was stopped by the user; everything finished so far is stored."""

    def __init__(self, summary: RunSummary) -> None:
        super().__init__(
            f"interrupted: {summary.stored} new trials stored ({summary.total_stored} in all); "
            "run the same command again to resume"
        )
        self.summary = summary


@dataclass
class RunSummary:
    """What a run did."""

    target: int
    stored: int = 0
    failed: int = 0
    duplicates: int = 0
    total_stored: int = 0
    elapsed: float = 0.0
    reasons: collections.Counter = field(default_factory=collections.Counter)
    examples: dict[str, int] = field(default_factory=dict)

    @property
    def rate(self) -> float:
        """Trials per second."""
        return self.stored / self.elapsed if self.elapsed > 0 else math.nan

    def describe(self) -> str:
        """Human-readable summary, with failure reasons."""
        lines = [
            f"{self.stored} trials computed in {self.elapsed:.1f} s "
            f"({self.rate:.0f} trials/s); the study holds {self.total_stored} of {self.target}"
        ]
        if self.failed:
            lines.append(f"{self.failed} failed:")
            for reason, count in self.reasons.most_common(10):
                lines.append(f"  {count:>7} × {reason} (e.g. trial {self.examples[reason]})")
        if self.duplicates:
            lines.append(f"{self.duplicates} trials were computed twice and stored once")
        return "\n".join(lines)


def _reason_key(message: str) -> str:
    """Group failure messages: drop numbers and locations so similar failures count once."""
    text = re.sub(r" \(at [^)]*\)$", "", message)
    text = re.sub(r"[-+]?\d+(\.\d+)?(e[-+]?\d+)?", "#", text)
    return text[:160]


def plan(store: Store, target: int, batch_size: int) -> list[tuple[int, int, int]]:
    """Missing work as ``(stage, seq_start, n)`` batches, in sequence order."""
    sample = [s for s in store.stages() if s.kind == "sample"]
    out = []
    for i, stage in enumerate(sample):
        end = sample[i + 1].start_seq if i + 1 < len(sample) else target
        end = min(end, target)
        if end <= stage.start_seq:
            continue
        for a, b in store.missing(stage.stage, stage.start_seq, end):
            for s in range(a, b, batch_size):
                out.append((stage.stage, s, min(batch_size, b - s)))
    return out


def _auto_batch(missing: int, workers: int) -> int:
    if missing <= 0:
        return 1
    per_worker = math.ceil(missing / (workers * 8))
    return int(min(1024, max(16, per_worker)))


def run_store(
    store: Store,
    *,
    trials: int | None = None,
    executor: str | None = None,
    workers: int | None = None,
    batch_size: int | None = None,
    progress: bool | TextIO = True,
) -> RunSummary:
    """Run (or resume, or extend) the study held by a writable store.

    Parameters
    ----------
    store : Store
        Opened with ``write=True``.
    trials : int, optional
        Total number of trials the study should hold (default: the study's ``trials``). A
        larger number than before extends the study along the same sequence.
    executor : {"serial", "processes"}, optional
        Default: the study's executor, else ``"processes"``.
    workers : int, optional
        Worker processes (default: all cores).
    batch_size : int, optional
        Trials per batch (default: the study's, else chosen from the work size).
    progress : bool or file
        Show a progress bar (on stderr, or on the given file).

    Returns
    -------
    RunSummary

    Raises
    ------
    RunInterrupted
        On Ctrl-C, after storing everything already finished.
    """
    spec = store.spec
    target = int(trials if trials is not None else spec.trials)
    if trials is not None and trials != spec.trials:
        store.set_target(trials)
        spec = store.spec
    executor_name = executor or spec.executor or "processes"
    pool = make_executor(executor_name, spec, workers if workers is not None else spec.workers)
    stored_before = store.count_sample()
    missing = sum(n for _, _, n in plan(store, target, 1 << 62))
    size = batch_size or spec.batch_size or _auto_batch(missing, pool.workers)
    work = plan(store, target, size)
    sampler = spec.sampler_for()
    spaces = {s.stage: s.space for s in store.stages()}
    summary = RunSummary(target=target, total_stored=stored_before)

    inflight: dict[tuple[int, int], np.ndarray] = {}

    def batches() -> Iterator[tuple[tuple[int, int], np.ndarray]]:
        for stage, start, n in work:
            X = spaces[stage].scale(sampler.points(start, n))
            inflight[(stage, start)] = X
            yield (stage, start), X

    bar = None
    if progress and missing:
        from tqdm.auto import tqdm

        bar = tqdm(
            total=stored_before + missing,
            initial=stored_before,
            unit="trial",
            file=progress if not isinstance(progress, bool) else sys.stderr,
            dynamic_ncols=True,
            smoothing=0.1,
        )
    run_id = store.begin_run(executor_name, pool.workers, target)
    t0 = time.perf_counter()
    outcome = "completed"
    try:
        with pool:
            for (stage, start), res in pool.map_unordered(batches()):
                X = inflight.pop((stage, start))
                wrote = store.write_batch(
                    stage,
                    start,
                    X,
                    res.criteria,
                    res.functionals,
                    res.status,
                    res.wall,
                    res.messages,
                )
                if wrote == 0:
                    summary.duplicates += res.n
                    continue
                summary.stored += wrote
                failed = np.flatnonzero(res.status == FAILED)
                summary.failed += len(failed)
                for i in failed:
                    key = _reason_key(res.messages.get(int(i), "unknown failure"))
                    summary.reasons[key] += 1
                    summary.examples.setdefault(key, int(start + i + 1))
                if bar is not None:
                    bar.update(wrote)
    except KeyboardInterrupt:
        outcome = "interrupted"
        raise RunInterrupted(summary) from None
    except BaseException:
        outcome = "error"
        raise
    finally:
        summary.elapsed = time.perf_counter() - t0
        summary.total_stored = store.count_sample()
        if bar is not None:
            bar.close()
        store.end_run(run_id, outcome)
    return summary
