"""Samplers: the strategies that decide which trials a study evaluates.

A study names its sampler (``[study] sampler = "sobol"``), and :func:`sampler_for` turns the
name into a :class:`Sampler` object once, through the registry of
:mod:`vectorid.sampler_kinds`. Two are built in:

* :class:`~vectorid.samplers.table.TableSampler` (``"sobol"``, ``"lhs"``) — the plain table:
  the point sequence in order;
* :class:`~vectorid.samplers.sequential.SequentialSampler` (``"sequential"``) — generations
  that move trials into the feasible set D.

A sampler plans rounds of trials and reads the store; the run driver (:mod:`vectorid.run`)
evaluates and writes. A new sampler is one module with a :class:`Sampler` subclass and one
:func:`~vectorid.sampler_kinds.register_sampler` call (docs/contributing.md).
"""

from .base import (
    Round,
    RoundResult,
    RunContext,
    RunSettings,
    Sampler,
    StageRequest,
    sampler_for,
)
from .weighting import Weighting, kish_ess

__all__ = [
    "Round",
    "RoundResult",
    "RunContext",
    "RunSettings",
    "Sampler",
    "StageRequest",
    "Weighting",
    "kish_ess",
    "sampler_for",
]
