"""The bounds in force on a study's criteria and functionals: one definition of D.

A trial is in the feasible set D when it computed (status ok), meets every functional
constraint and meets every criteria constraint Φ**. Criteria constraints are *bounds* on a
criterion: for a ``min`` criterion the study's ``limit`` is an upper bound, for a ``max``
criterion a lower bound (the worst value accepted). The expert may tighten, loosen or remove
them at analysis time (``--limit 'f1<=40'``, ``--limit 'f2>=0.5'``, ``--limit 'f1<=inf'``
removes one), and may override functional constraint bounds the same way.

:class:`Limits` holds the bounds of one study under the overrides of one analysis; the
analysis (:class:`vectorid.analysis.Analysis`), the samplers (which move trials toward the
stated limits) and the command line all use it, so D is defined here once.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .errors import StudyDefinitionError, suggest
from .problem import OK

__all__ = [
    "Bound",
    "Limits",
    "oriented",
    "parse_limit",
    "parse_limits",
    "parse_user_limits",
    "study_with_limits",
]

# The last operator splits name and value, so names with spaces or operators work too.
_LIMIT = re.compile(r"^\s*(.+?)\s*(<=|>=|<|>)\s*([^<>=\s]+)\s*$")


@dataclass(frozen=True)
class Bound:
    """One side of a constraint: ``name <= value`` (``side='high'``) or ``name >= value``.

    Parameters
    ----------
    name : str
        A criterion or functional constraint of the study.
    side : {"low", "high"}
        ``"high"`` for ``name <= value``, ``"low"`` for ``name >= value``.
    value : float
        The bound, in the quantity's unit (±inf for none).
    """

    name: str
    side: str  # "low" | "high"
    value: float

    def __str__(self) -> str:
        return f"{self.name} {'<=' if self.side == 'high' else '>='} {self.value:.6g}"


def parse_limit(text: str) -> Bound:
    """Parse ``'NAME<=VALUE'`` or ``'NAME>=VALUE'`` (``inf`` removes the bound).

    Parameters
    ----------
    text : str
        One ``--limit`` option.

    Returns
    -------
    Bound

    Raises
    ------
    StudyDefinitionError
        With the expected form when ``text`` does not parse.
    """
    m = _LIMIT.match(text)
    if not m:
        raise StudyDefinitionError(
            "--limit",
            f"cannot read {text!r}",
            "write NAME<=VALUE or NAME>=VALUE, e.g. --limit 'f1<=40' (quote it for the shell)",
        )
    name, op, raw = m.groups()
    try:
        value = float(raw)
    except ValueError:
        raise StudyDefinitionError(
            "--limit", f"value {raw!r} in {text!r} is not a number", "write e.g. f1<=40.5"
        ) from None
    if math.isnan(value):
        raise StudyDefinitionError("--limit", f"NaN limit in {text!r}", "write a number or inf")
    return Bound(name, "high" if op.startswith("<") else "low", value)


def parse_limits(texts: Iterable[str]) -> list[Bound]:
    """Parse several ``--limit`` options (see :func:`parse_limit`).

    Parameters
    ----------
    texts : iterable of str

    Returns
    -------
    list of Bound
    """
    return [parse_limit(t) for t in texts]


def parse_user_limits(spec: Any, texts: Sequence[str]) -> list[Bound]:
    """Parse ``--limit`` options and refuse a bound on a criterion's better side.

    A criteria constraint Φ** is the worst value accepted: ``'f1<=40'`` for a minimised
    criterion, ``'f2>=0.5'`` for a maximised one. ``'f1>=40'`` on a minimised criterion would
    keep the *worse* trials, which is never what the expert means; it is refused with the form
    to write. (Infinite values, which remove a bound, pass.)

    Parameters
    ----------
    spec : StudySpec
        The study whose criteria the limits bound.
    texts : sequence of str
        The ``--limit`` options.

    Returns
    -------
    list of Bound

    Raises
    ------
    StudyDefinitionError
        A limit that does not parse, or bounds a criterion from its better side.
    """
    bounds = parse_limits(texts)
    senses = {c.name: c.sense for c in spec.criteria}
    for text, b in zip(texts, bounds):
        sense = senses.get(b.name)
        if sense is None or math.isinf(b.value):
            continue
        better = "low" if sense == "min" else "high"
        if b.side == better:
            op, want = (">=", "<=") if sense == "min" else ("<=", ">=")
            raise StudyDefinitionError(
                "--limit",
                f"{text!r} bounds {b.name} from its better side, but {b.name} is "
                f"{'minimised' if sense == 'min' else 'maximised'} and a criteria constraint is "
                f"the worst accepted value (it would keep only the trials with {b.name} "
                f"{op} {b.value:g})",
                f"write --limit '{b.name}{want}{b.value:g}' to keep the trials with {b.name} "
                f"{want} {b.value:g}",
            )
    return bounds


def oriented(values: np.ndarray, senses: Sequence[str]) -> np.ndarray:
    """Criteria values ``(n, k)`` with ``max`` columns negated: smaller is better in every
    column.

    Parameters
    ----------
    values : (n, k) float array
        Criteria values, each in its unit.
    senses : sequence of {"min", "max"}
        The sense of each column.

    Returns
    -------
    (n, k) float array
    """
    values = np.asarray(values, dtype=float)
    sign = np.array([1.0 if s == "min" else -1.0 for s in senses])
    return values * sign


class Limits:
    """The bounds in force on a study's criteria and functional constraints.

    Parameters
    ----------
    spec : StudySpec
        The study: its criteria (senses, stated limits Φ**) and functional constraints.
    limits : iterable of Bound or mapping, optional
        Bounds overriding the study's, in each quantity's own unit: :class:`Bound` objects
        (from :func:`parse_limit`), or a mapping ``name -> value`` applied to the worse side of
        a criterion (upper for min, lower for max; ``None`` removes the limit) or, for a
        functional constraint, ``name -> (low, high)``.

    Attributes
    ----------
    crit_names, con_names : list of str
        Criterion and functional names, in the order of the study's columns.
    senses : list of str
        ``"min"`` or ``"max"`` per criterion.
    bounds : dict of str to [float, float]
        Per criterion and functional: the ``[low, high]`` bound in force (±inf where none).

    Raises
    ------
    StudyDefinitionError
        A bound on a quantity the study does not have (with the nearest name).
    """

    def __init__(
        self, spec: Any, limits: Iterable[Bound] | Mapping[str, Any] | None = None
    ) -> None:
        self.spec = spec
        self.crit_names = [c.name for c in spec.criteria]
        self.con_names = [c.name for c in spec.constraints]
        self.senses = [c.sense for c in spec.criteria]
        self.bounds: dict[str, list[float]] = {}
        for c in spec.criteria:
            lo, hi = -math.inf, math.inf
            if c.limit is not None:
                if c.sense == "min":
                    hi = c.limit
                else:
                    lo = c.limit
            self.bounds[c.name] = [lo, hi]
        for c in spec.constraints:
            self.bounds[c.name] = [
                -math.inf if c.low is None else c.low,
                math.inf if c.high is None else c.high,
            ]
        for b in self._normalise(limits):
            self.bounds[b.name][0 if b.side == "low" else 1] = b.value

    def _normalise(self, limits: Any) -> list[Bound]:
        if limits is None:
            return []
        out: list[Bound] = []
        if isinstance(limits, Limits):
            limits = [b for n, (lo, hi) in limits.bounds.items()
                      for b in (Bound(n, "low", lo), Bound(n, "high", hi))]  # fmt: skip
        if isinstance(limits, Mapping):
            for name, value in limits.items():
                if name in self.con_names:
                    lo, hi = value
                    out += [
                        Bound(name, "low", -math.inf if lo is None else float(lo)),
                        Bound(name, "high", math.inf if hi is None else float(hi)),
                    ]
                elif name in self.crit_names:
                    sense = self.senses[self.crit_names.index(name)]
                    if value is None:
                        v = math.inf if sense == "min" else -math.inf
                    else:
                        v = float(value)
                    out.append(Bound(name, "high" if sense == "min" else "low", v))
                else:
                    out.append(Bound(name, "high", 0.0))  # rejected below
        else:
            out = list(limits)
        valid = self.crit_names + self.con_names
        for b in out:
            if b.name not in valid:
                raise StudyDefinitionError(
                    "--limit",
                    f"limit on unknown criterion or constraint {b.name!r}",
                    suggest(b.name, valid),
                )
        return out

    # -- reading ---------------------------------------------------------------------------

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Limits):
            return NotImplemented
        return self.bounds == other.bounds

    def __hash__(self) -> int:  # pragma: no cover - mutable bounds: not hashable by value
        return id(self)

    def same_as_stated(self) -> bool:
        """True when every bound is the study's own (no override changes one).

        Returns
        -------
        bool
        """
        return self.bounds == Limits(self.spec).bounds

    def within(self, other: Limits) -> bool:
        """True when every bound is the same as ``other``'s or tighter (D can only shrink).

        Parameters
        ----------
        other : Limits
            Limits of the same study.

        Returns
        -------
        bool
        """
        for name, (lo, hi) in self.bounds.items():
            olo, ohi = other.bounds[name]
            if lo < olo or hi > ohi:
                return False
        return True

    def worse_side(self, name: str) -> float:
        """A criterion's limit on its worse side.

        Parameters
        ----------
        name : str
            A criterion of the study.

        Returns
        -------
        float
            The upper bound of a ``min`` criterion, the lower of a ``max`` one, in its unit
            (±inf: none).
        """
        lo, hi = self.bounds[name]
        return hi if self.senses[self.crit_names.index(name)] == "min" else lo

    def active(self) -> list[Bound]:
        """Finite bounds in force: functional constraints first, then criteria in order.

        Returns
        -------
        list of Bound
        """
        out = []
        for name in self.con_names + self.crit_names:
            lo, hi = self.bounds[name]
            if lo > -math.inf:
                out.append(Bound(name, "low", lo))
            if hi < math.inf:
                out.append(Bound(name, "high", hi))
        return out

    def constrained(self) -> tuple[list[int], np.ndarray]:
        """The criteria with a finite limit on their worse side and those limits, oriented
        (smaller is better: a ``max`` criterion's limit is negated).

        Returns
        -------
        idx : list of int
            Column indices of the constrained criteria.
        floor : (len(idx),) float array
            Their oriented limits Φ**.
        """
        idx, floor = [], []
        for j, name in enumerate(self.crit_names):
            lo, hi = self.bounds[name]
            bound = hi if self.senses[j] == "min" else -lo
            if math.isfinite(bound):
                idx.append(j)
                floor.append(bound)
        return idx, np.array(floor, dtype=float)

    def for_saving(
        self,
        where: str = "--save",
        fix: str = "drop that --limit, or use it for this analysis only (without --save)",
    ) -> tuple[dict[str, float | None], dict[str, tuple[float | None, ...]]]:
        """The bounds as the study file keeps them: each criterion's limit (its worse side;
        None where there is none) and each functional constraint's ``(low, high)``.

        Parameters
        ----------
        where, fix : str
            What the error names, and how it says to fix a better-side bound.

        Raises
        ------
        StudyDefinitionError
            A criterion bounded on its better side: a study keeps only criteria constraints
            (the worst accepted value).
        """
        criteria: dict[str, float | None] = {}
        for i, name in enumerate(self.crit_names):
            lo, hi = self.bounds[name]
            worse, other = (hi, lo) if self.senses[i] == "min" else (lo, hi)
            if math.isfinite(other):
                side = ">=" if self.senses[i] == "min" else "<="
                raise StudyDefinitionError(
                    where,
                    f"cannot save '{name}{side}{other:g}': a criteria constraint is the worst "
                    f"accepted value of a {self.senses[i]} criterion",
                    fix,
                )
            criteria[name] = float(worse) if math.isfinite(worse) else None
        constraints = {
            name: tuple(None if math.isinf(v) else float(v) for v in self.bounds[name])
            for name in self.con_names
        }
        return criteria, constraints

    # -- masks -----------------------------------------------------------------------------

    def functional_mask(self, status: np.ndarray, G: np.ndarray) -> np.ndarray:
        """Trials that computed (status ok) and meet every functional constraint.

        Parameters
        ----------
        status : (n,) int array
            Trial status (0 ok).
        G : (n, q) float array
            Functionals, each in its unit.

        Returns
        -------
        (n,) bool array
        """
        ok = np.asarray(status) == OK
        for j, name in enumerate(self.con_names):
            lo, hi = self.bounds[name]
            with np.errstate(invalid="ignore"):
                ok &= (G[:, j] >= lo) & (G[:, j] <= hi)
        return ok

    def criteria_mask(self, F: np.ndarray, rows: np.ndarray | None = None) -> np.ndarray:
        """Which trials meet every criteria constraint (NaN never does).

        Parameters
        ----------
        F : (n, k) float array
            Criteria, each in its unit.
        rows : (m,) int array, optional
            Only these rows (the result then has ``m`` entries).

        Returns
        -------
        bool array
        """
        sub = F if rows is None else F[rows]
        keep = np.ones(len(sub), dtype=bool)
        for j, name in enumerate(self.crit_names):
            lo, hi = self.bounds[name]
            with np.errstate(invalid="ignore"):  # NaN meets no bound, even an infinite one
                keep &= (sub[:, j] >= lo) & (sub[:, j] <= hi)
        return keep

    def feasible_mask(self, status: np.ndarray, F: np.ndarray, G: np.ndarray) -> np.ndarray:
        """Members of D: computed, within every functional and every criteria constraint.

        Parameters
        ----------
        status : (n,) int array
        F : (n, k) float array
        G : (n, q) float array

        Returns
        -------
        (n,) bool array
        """
        rows = np.flatnonzero(self.functional_mask(status, G))
        out = np.zeros(len(status), dtype=bool)
        out[rows[self.criteria_mask(F, rows)]] = True
        return out


def study_with_limits(
    study: dict[str, Any],
    criteria: Mapping[str, float | None] | None = None,
    constraints: Mapping[str, tuple[float | None, float | None]] | None = None,
    sources: Mapping[str, tuple[str, str]] | None = None,
) -> dict[str, Any]:
    """A study definition (``StudySpec.to_dict()``) with criteria constraints Φ** and
    functional bounds replaced, as :meth:`vectorid.store.Store.set_limits` saves them.

    Parameters
    ----------
    study : dict
        The study definition; changed in place and returned.
    criteria : mapping, optional
        ``name -> limit`` (the worst accepted value, in the criterion's unit; None or a
        non-finite value removes the limit).
    constraints : mapping, optional
        ``name -> (low, high)`` of functional constraints (None for no bound).
    sources : mapping, optional
        ``name -> (limit_source, limit_note)`` of the criteria limits set here. A limit set
        without one is the expert's, except that a limit saved again unchanged keeps its
        source and note.

    Returns
    -------
    dict

    Raises
    ------
    StudyDefinitionError
        A limit on a criterion or constraint the study does not have.
    """
    crit = {c["name"]: c for c in study["criteria"]}
    cons = {c["name"]: c for c in study.get("constraints", [])}
    for name, value in (criteria or {}).items():
        if name not in crit:
            raise StudyDefinitionError(
                "limits", f"unknown criterion {name!r}", suggest(name, list(crit))
            )
        old = crit[name].get("limit")
        if value is None or not np.isfinite(value):
            crit[name].pop("limit", None)
            for key in ("limit_source", "limit_note"):
                crit[name].pop(key, None)
        else:
            crit[name]["limit"] = float(value)
            if sources and name in sources:
                src, note = sources[name]
            elif old is not None and float(old) == float(value):
                continue  # saved again unchanged: keep its source
            else:
                src, note = "expert", ""
            crit[name].pop("limit_source", None)
            crit[name].pop("limit_note", None)
            if src and (src != "expert" or note):
                crit[name]["limit_source"] = src
            if note:
                crit[name]["limit_note"] = note
    for name, (lo, hi) in (constraints or {}).items():
        if name not in cons:
            raise StudyDefinitionError(
                "limits", f"unknown constraint {name!r}", suggest(name, list(cons))
            )
        for key, value in (("low", lo), ("high", hi)):
            if value is None or not np.isfinite(value):
                cons[name].pop(key, None)
            else:
                cons[name][key] = float(value)
    return study
