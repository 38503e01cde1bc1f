"""The samplers a study may name: ``[study] sampler = "NAME"``, resolved through this registry.

A *sampler* decides which trials a study evaluates (:class:`vectorid.samplers.Sampler`): the
plain table evaluates a point sequence in order; the sequential sampler moves generations of
trials into the feasible set D. The study definition (:mod:`vectorid.spec`) only needs to know
a sampler's name and which of the ``[study]`` keys it takes, so the registry holds those and a
``"module:Class"`` reference to the implementation, imported when a run or an analysis first
needs it (the way :mod:`vectorid.builders` registers problem builders). A package adds its
own::

    from vectorid.sampler_kinds import register_sampler
    register_sampler("random", "mypkg.random_sampler:RandomSampler")

and then ``sampler = "random"`` works in study files, ``vectorid run`` and every analysis.
"""

from __future__ import annotations

import importlib
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from .errors import StudyDefinitionError, suggest

__all__ = ["SAMPLER_OPTIONS", "SamplerKind", "register_sampler", "sampler_kind", "sampler_names"]

#: ``[study]`` keys that only some samplers take, and what each means.
SAMPLER_OPTIONS = {
    "budget": "most model evaluations (integer >= 1)",
    "population": "members of D wanted (integer >= 2)",
}


@dataclass
class SamplerKind:
    """A registered sampler (see the module docstring).

    Attributes
    ----------
    name : str
        The name a study file gives (``sampler = "sequential"``).
    sampler : str or type
        The :class:`vectorid.samplers.Sampler` subclass, or a ``"module:Class"`` reference to
        it imported on first use.
    options : tuple of str
        The keys of :data:`SAMPLER_OPTIONS` it takes.
    sequence : {"sobol", "lhs"}
        The point sequence its first trials come from (:class:`vectorid.sampling.PointSequence`).
    scramble : bool
        Whether ``scramble = true`` may Owen-scramble that sequence.
    continuous_only : bool
        It needs continuous variables (no integer or choice variable).
    help : str
        One line for ``--help`` and error messages.
    """

    name: str
    sampler: str | type
    options: tuple[str, ...] = ()
    sequence: str = "sobol"
    scramble: bool = True
    continuous_only: bool = False
    help: str = ""

    def resolve(self) -> type:
        """The sampler class (imported on first use)."""
        if isinstance(self.sampler, str):
            module, _, name = self.sampler.partition(":")
            self.sampler = getattr(importlib.import_module(module), name)
        return self.sampler  # type: ignore[return-value]


_KINDS: dict[str, SamplerKind] = {}


def register_sampler(
    name: str,
    sampler: str | type,
    *,
    options: Sequence[str] = (),
    sequence: str = "sobol",
    scramble: bool = True,
    continuous_only: bool = False,
    help: str = "",
) -> None:
    """Register a sampler under ``name`` (see the module docstring).

    Parameters
    ----------
    name : str
        The name study files give.
    sampler : type or str
        A :class:`vectorid.samplers.Sampler` subclass or its ``"module:Class"`` reference.
    options : sequence of str
        The keys of :data:`SAMPLER_OPTIONS` it takes (``budget``, ``population``).
    sequence : {"sobol", "lhs"}
        The point sequence its first trials come from.
    scramble : bool
        Whether the sequence may be scrambled.
    continuous_only : bool
        It needs continuous variables.
    help : str
        One line describing it.
    """
    if not isinstance(name, str) or not name.isidentifier():
        raise ValueError(f"a sampler name is an identifier, got {name!r}")
    unknown = [o for o in options if o not in SAMPLER_OPTIONS]
    if unknown:
        raise ValueError(f"unknown sampler options {unknown}; known: {list(SAMPLER_OPTIONS)}")
    _KINDS[name] = SamplerKind(
        name, sampler, tuple(options), sequence, scramble, continuous_only, help
    )


def sampler_names() -> list[str]:
    """The registered samplers' names, in registration order."""
    return list(_KINDS)


def sampler_kind(name: Any, where: str = "study.sampler") -> SamplerKind:
    """The registered sampler ``name``.

    Parameters
    ----------
    name : str
        The name a study gives (``[study] sampler``).
    where : str
        The field named in the error.

    Returns
    -------
    SamplerKind

    Raises
    ------
    StudyDefinitionError
        For a name nobody registered (with the nearest registered name).

    Examples
    --------
    Which ``[study]`` keys (sampler options) each sampler takes, and what they mean:

    >>> from vectorid.sampler_kinds import SAMPLER_OPTIONS, sampler_kind, sampler_names
    >>> sampler_names()
    ['sobol', 'lhs', 'sequential']
    >>> sampler_kind("sequential").options, sampler_kind("sobol").options
    (('budget', 'population'), ())
    >>> for key in sampler_kind("sequential").options:
    ...     print(f"{key}: {SAMPLER_OPTIONS[key]}")
    budget: most model evaluations (integer >= 1)
    population: members of D wanted (integer >= 2)

    :meth:`vectorid.Study.run` takes them as ``budget=`` and ``population=`` (its Examples).
    """
    kind = _KINDS.get(name) if isinstance(name, str) else None
    if kind is None:
        raise StudyDefinitionError(
            where, f"unknown sampler {name!r}", suggest(str(name), list(_KINDS))
        )
    return kind


register_sampler(
    "sobol",
    "vectorid.samplers.table:TableSampler",
    sequence="sobol",
    help="Sobol LP_tau points in order (the PSI method's table; default)",
)
register_sampler(
    "lhs",
    "vectorid.samplers.table:TableSampler",
    sequence="lhs",
    help="Latin hypercube blocks in order",
)
register_sampler(
    "sequential",
    "vectorid.samplers.sequential:SequentialSampler",
    options=("budget", "population"),
    sequence="sobol",
    scramble=False,
    continuous_only=True,
    help="generations of trials that move into D (docs/sequential.md)",
)
