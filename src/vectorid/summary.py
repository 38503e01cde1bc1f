"""What a run did: trials stored and failed, failures grouped by reason, recovered model errors.

A value type shared by the samplers (which add what they track, e.g. the sequential sampler's
generations and ESS) and the run driver (:mod:`vectorid.run`), which fills the counts.
"""

from __future__ import annotations

import collections
import math
import re
from dataclasses import dataclass, field

import numpy as np

from .errors import plural
from .problem import FAILED, EvalResult

__all__ = ["FailureGroup", "RunSummary", "group_failures", "reason_key"]


@dataclass(frozen=True)
class FailureGroup:
    """Failed trials that failed the same way (their messages differ at most in numbers).

    Attributes
    ----------
    count : int
        How many trials.
    message : str
        The full message of the first of them (real numbers and names).
    trial : int
        Its trial id.
    """

    count: int
    message: str
    trial: int


@dataclass
class RunSummary:
    """What a run did.

    Attributes
    ----------
    target : int
        Trials the study should hold.
    stored, failed, duplicates : int
        Trials stored by this run, how many of them failed, and trials computed twice and
        stored once.
    total_stored : int
        Trials the study holds after the run.
    elapsed : float
        Seconds.
    reasons : Counter
        Failed trials by group key (digits masked: a key, not a message).
    examples : dict
        Group key -> ``(trial id, full message)`` of the first trial of the group.
    notes : list of str
        Things the run decided that the user must know (a target below what is stored, ...).
    retried : dict
        Model errors the run recovered from by re-running trials (a batch that raised,
        returned too few rows, lost its worker or ran past its time): group key ->
        ``[batches, trials lost, example text]``; :attr:`model_errors` says them.
    """

    target: int
    stored: int = 0
    failed: int = 0
    duplicates: int = 0
    total_stored: int = 0
    elapsed: float = 0.0
    reasons: collections.Counter = field(default_factory=collections.Counter)
    examples: dict[str, tuple[int, str]] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    retried: dict[str, list] = field(default_factory=dict)

    def add_retried(self, res: EvalResult) -> None:
        """Count the model errors a batch recovered from (once per batch and kind; the run
        loop calls it).

        Parameters
        ----------
        res : EvalResult
            The evaluated batch, with the errors it was re-run after (``res.retried``).
        """
        if not res.retried:
            return
        lost = int(res.retry_lost)
        for text in dict.fromkeys(res.retried):
            key = reason_key(text)
            entry = self.retried.setdefault(key, [0, 0, text])
            entry[0] += 1
            entry[1] += lost

    @property
    def model_errors(self) -> list[str]:
        """One line per kind of model error the run recovered from, e.g. "3 batches raised
        ValueError: ... ; re-run trial by trial: 0 lost"."""
        out = []
        for batches, lost, text in sorted(self.retried.values(), key=lambda e: -e[0]):
            out.append(
                f"{batches} batch{'es' if batches > 1 else ''} {text}; re-run trial by "
                f"trial: {lost} lost"
            )
        return out

    @property
    def rate(self) -> float:
        """Trials per second."""
        return self.stored / self.elapsed if self.elapsed > 0 else math.nan

    @property
    def failures(self) -> list[FailureGroup]:
        """Failure groups, most frequent first, each with a real example message."""
        return [
            FailureGroup(count, self.examples[key][1], self.examples[key][0])
            for key, count in self.reasons.most_common()
        ]

    def add_failures(self, start_id: int, res: EvalResult) -> None:
        """Count the failed trials of one evaluated batch (the run loop calls it).

        Parameters
        ----------
        start_id : int
            Trial id of the batch's first row.
        res : EvalResult
            The batch's evaluation.
        """
        failed = np.flatnonzero(res.status == FAILED)
        self.failed += len(failed)
        for i in failed:
            msg = res.messages.get(int(i), "unknown failure (no message)")
            key = reason_key(msg)
            self.reasons[key] += 1
            self.examples.setdefault(key, (int(start_id + i), msg))

    def to_dict(self) -> dict:
        """The summary as JSON-ready values (``vectorid run --json``).

        Returns
        -------
        dict
            ``stored``, ``failed``, ``duplicates``, ``total_stored``, ``target`` (trials),
            ``elapsed_s`` (s), ``trials_per_s``, ``notes``, ``failures`` (count, example,
            trial per group) and ``model_errors``.
        """
        return {
            "stored": self.stored,
            "failed": self.failed,
            "duplicates": self.duplicates,
            "total_stored": self.total_stored,
            "target": self.target,
            "elapsed_s": self.elapsed,
            "trials_per_s": self.rate if math.isfinite(self.rate) else None,
            "notes": list(self.notes),
            "failures": [
                {"count": g.count, "example": g.message, "trial": g.trial} for g in self.failures
            ],
            "model_errors": self.model_errors,
        }

    def describe(self) -> str:
        """Human-readable summary, with failure reasons (real example messages)."""
        lines = [
            f"{plural(self.stored, 'trial')} computed in {self.elapsed:.1f} s "
            f"({self.rate:.0f} trials/s); the study holds {self.total_stored} of {self.target}"
        ]
        lines += [f"note: {n}" for n in self.notes]
        if self.retried:
            lines.append(
                "model errors (the values were re-computed; failed trials are counted below):"
            )
            lines += [f"  {m}" for m in self.model_errors]
        if self.failed:
            share = 100.0 * self.failed / max(self.stored, 1)
            lines.append(f"{self.failed} of {plural(self.stored, 'trial')} failed ({share:.0f} %):")
            for g in self.failures[:10]:
                lines.append(f"  {g.count:>7} × {g.message} (e.g. trial {g.trial})")
            if len(self.reasons) > 10:
                rest = sum(c for _, c in self.reasons.most_common()[10:])
                lines.append(f"  {rest:>7} × other reasons (`vectorid info` lists them)")
            if share > 50:
                lines.append(
                    "warning: most trials failed; check the reasons above before analysing "
                    "the study"
                )
        if self.duplicates:
            lines.append(
                f"{plural(self.duplicates, 'trial')} {'was' if self.duplicates == 1 else 'were'} "
                "computed twice and stored once"
            )
        return "\n".join(lines)


_NUMBER = re.compile(r"(?<![\w.])[-+]?\d+(\.\d+)?([eE][-+]?\d+)?(?![\w.])")


def reason_key(message: str) -> str:
    """Group key of a failure message: numbers standing alone masked ("shape (#, #)"), names
    such as ``f1`` or ``x12`` kept, the source location dropped. A key, never shown alone."""
    text = re.sub(r" \(at [^)]*\)$", "", message)
    text = _NUMBER.sub("#", text)
    return text[:160]


def group_failures(
    messages: dict[tuple[int, int], str], ids: dict[tuple[int, int], int] | None = None
) -> list[FailureGroup]:
    """Group stored failure messages (``(stage, seq) -> message``) by reason, most frequent
    first, each with the full message of its first trial (``ids`` maps keys to trial ids;
    default ``seq + 1``)."""
    counts: collections.Counter = collections.Counter()
    first: dict[str, tuple[int, str]] = {}
    for (stage, seq), msg in sorted(messages.items()):
        key = reason_key(msg)
        counts[key] += 1
        if key not in first:
            tid = ids.get((stage, seq), seq + 1) if ids is not None else seq + 1
            first[key] = (tid, msg)
    return [FailureGroup(c, first[k][1], first[k][0]) for k, c in counts.most_common()]
