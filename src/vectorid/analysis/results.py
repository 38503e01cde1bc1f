"""Test tables, the feasible set D and the Edgeworth–Pareto set, for any criteria
constraints chosen after the run (no model is ever re-run).

Criteria constraints Φ** are *bounds* on a criterion: for a ``min`` criterion the study's
``limit`` is an upper bound, for a ``max`` criterion a lower bound. The expert may tighten,
loosen or remove them at analysis time (``--limit 'f1<=40'``, ``--limit 'f2>=0.5'``,
``--limit 'f1<=inf'`` removes), and may override functional constraint bounds the same way.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..builders import variable_meanings
from ..errors import StudyDefinitionError, suggest
from ..limits import Bound, Limits, parse_limit, parse_limits
from ..problem import OK
from ..samplers import Weighting, sampler_for
from ..spec import StudySpec
from ..store import Store, Trials
from ._frames import constraint_rows, trial_columns, trials_frame, verdict_rows, verdicts_frame
from .identifiability import identifiability
from .pareto import pareto_mask

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

    from .identifiability import ParameterVerdict

__all__ = ["Analysis", "Bound", "EmptyDiagnosis", "TestTable", "parse_limit", "parse_limits"]


@dataclass
class TestTable:
    """One criterion's column of the test table (seed 000 Fig. 6): trials sorted best first.

    Attributes
    ----------
    name, sense : str
    min, max : float
        Over the rows of the table (NaN if it is empty).
    ids : (m,) int64
        Trial ids, best first.
    values : (m,) float64
    feasible : (m,) bool
        Whether each trial lies in D under the current constraints.
    limit : float or None
        The criterion's current Φ** on its worse side.
    """

    __test__ = False  # not a pytest class

    name: str
    sense: str
    min: float
    max: float
    ids: np.ndarray
    values: np.ndarray
    feasible: np.ndarray
    limit: float | None

    def to_dict(self, top: int | None = None) -> dict[str, Any]:
        """The ``vectorid table --json`` entry of this criterion.

        Parameters
        ----------
        top : int, optional
            Keep only the ``top`` best rows (default: all).

        Returns
        -------
        dict
            ``{"name", "sense", "min", "max", "limit", "rows": [{"id", "value",
            "feasible"}]}``, non-finite numbers as None.
        """
        m = len(self.ids) if top is None else min(top, len(self.ids))
        return {
            "name": self.name,
            "sense": self.sense,
            "min": None if math.isnan(self.min) else self.min,
            "max": None if math.isnan(self.max) else self.max,
            "limit": self.limit,
            "rows": [
                {
                    "id": int(self.ids[i]),
                    "value": float(self.values[i]),
                    "feasible": bool(self.feasible[i]),
                }
                for i in range(m)
            ],
        }


@dataclass
class EmptyDiagnosis:
    """Why D is empty and how to make it non-empty.

    Attributes
    ----------
    cumulative : list of (Bound, int)
        Constraints applied one after another (functional first, then criteria left to
        right) with the number of trials left after each; the first to reach 0 empties D.
    relaxations : list of (Bound, Bound, int)
        For each constraint whose relaxation alone makes D non-empty: the current bound, the
        smallest relaxed bound that does it, and how many trials D then holds.
    joint : dict or None
        When no single relaxation suffices: the trial needing the smallest relative
        relaxation and the bounds that would admit it.
    """

    cumulative: list[tuple[Bound, int]]
    relaxations: list[tuple[Bound, Bound, int]]
    joint: dict[str, Any] | None

    def describe(self) -> str:
        """The diagnosis in words, as ``vectorid pareto`` prints it."""
        lines = ["The feasible set D is empty."]
        first = next((b for b, c in self.cumulative if c == 0), None)
        if first is not None:
            lines.append(f"Applied in order, {first} is the constraint that empties it:")
            for b, c in self.cumulative:
                lines.append(f"  {b!s:<32} -> {c} trials left")
        if self.relaxations:
            lines.append("Smallest relaxation of each constraint that alone makes D non-empty:")
            for cur, new, gained in self.relaxations:
                lines.append(f"  {cur!s:<32} -> {new}  ({gained} feasible)")
        elif self.joint:
            lines.append(
                "No single relaxation is enough; the trial closest to feasibility is "
                f"{self.joint['id']}, admitted by: "
                + ", ".join(str(b) for b in self.joint["bounds"])
            )
        else:
            lines.append("No trial completed successfully; see `vectorid info` for failures.")
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """The ``"empty"`` object of ``vectorid pareto --json``."""
        return {
            "cumulative": [{"constraint": str(b), "left": c} for b, c in self.cumulative],
            "relaxations": [
                {"constraint": str(a), "relaxed": str(b), "value": b.value, "n_feasible": n}
                for a, b, n in self.relaxations
            ],
            "joint": None
            if self.joint is None
            else {"id": self.joint["id"], "bounds": [str(b) for b in self.joint["bounds"]]},
        }


class Analysis:
    """Feasible and Pareto sets of stored trials under chosen constraints.

    Made by :meth:`vectorid.Study.analysis`. Nothing here re-runs a model: a new set of
    limits is a new ``Analysis`` of the same trials. Every array has one row per trial, in
    the order of :attr:`trials`, so ``a.trials.X[a.pareto]`` are the Pareto vectors.

    Parameters
    ----------
    spec : StudySpec
        The study (criteria senses, roles, limits; functional constraints).
    trials : Trials
        Stored trials (``Store.load()``).
    limits : iterable of Bound or mapping, optional
        Bounds overriding the study's, in the criterion's or functional's own unit:
        ``Bound`` objects (from :func:`parse_limit`), or a mapping ``name -> value`` applied
        to the worse side of a criterion (upper for min, lower for max; ``None`` removes the
        limit) or, for a functional constraint, ``name -> (low, high)``.
    roles : mapping, optional
        Override pure/pseudo roles by criterion name.
    weighting : Weighting, optional
        How the trials weigh as a sample of the box's uniform density (a sequential
        sampler's importance weights or holding times; see
        :class:`vectorid.samplers.Weighting`); None: every trial counts once.

    Attributes
    ----------
    spec : StudySpec
        The study definition.
    trials : Trials
        The trials analysed: ``trials.X`` (n, p) parameters, ``trials.F`` (n, k) criteria,
        ``trials.G`` (n, q) functionals, each in its study unit; ``trials.id`` (n,) ids.
    crit_names, con_names : list of str
        Criterion and functional-constraint names, in the order of the columns of ``F``
        and ``G``.
    senses, roles : list of str
        Per criterion: ``"min"``/``"max"`` and ``"pure"``/``"pseudo"`` (after ``roles``).
    bounds : dict of str to [float, float]
        Per criterion and functional: the [low, high] bound in force (±inf where none).
    ok : (n,) bool ndarray
        The trial computed (status 0).
    functional_ok : (n,) bool ndarray
        The trial computed and meets every functional constraint.
    feasible : (n,) bool ndarray
        The trial lies in the feasible set D (functional and criteria constraints met).
    pareto : (n,) bool ndarray
        The trial lies in the Edgeworth–Pareto set of D over the pure criteria.
    pure : list of int
        Column indices (into ``F``) of the pure criteria.
    limits : Limits
        The bounds in force (the study's, under ``limits``).
    weighting : Weighting or None
        As given.

    Examples
    --------
    Two criteria (m²) of two lengths (m), 256 Sobol trials in a store, analysed under the
    study's limit f1 <= 0.5 m², then under limits chosen now (no model is re-run):

    >>> import os, tempfile
    >>> import numpy as np
    >>> from vectorid import Continuous, Criterion, Space, Study, StudySpec
    >>> def wells(X):
    ...     F = np.column_stack([X[:, 0] ** 2 + X[:, 1] ** 2, (X[:, 0] - 1) ** 2 + X[:, 1] ** 2])
    ...     return F, np.empty((len(X), 0))
    >>> space = Space([Continuous("x1", 0.0, 1.0, unit="m"), Continuous("x2", 0.0, 1.0, unit="m")])
    >>> spec = StudySpec("wells", wells, space, (Criterion("f1", limit=0.5, unit="m2"),
    ...                  Criterion("f2", unit="m2")), trials=256, seed=1)
    >>> with Study.create(spec, os.path.join(tempfile.mkdtemp(), "wells.db")) as study:
    ...     _ = study.run(executor="inline")
    ...     a = study.analysis()
    ...     b = study.analysis(limits={"f1": 0.25, "f2": 0.5})
    >>> a.n, a.n_feasible, a.n_pareto  # N, ND, NP
    (256, 99, 20)
    >>> [str(bound) for bound in b.active_bounds()], b.n_feasible
    (['f1 <= 0.25', 'f2 <= 0.5'], 11)
    >>> a.trials.X[a.pareto][:2]  # Pareto vectors, in m (a.feasible, a.pareto: row masks)
    array([[0.625  , 0.125  ],
           [0.53125, 0.03125]])
    >>> t = a.test_tables()[0]  # f1's test table: trial ids, best first
    >>> t.name, t.ids[:3].tolist()
    ('f1', [160, 240, 96])
    """

    def __init__(
        self,
        spec: StudySpec,
        trials: Trials,
        limits: Iterable[Bound] | Mapping[str, Any] | Limits | None = None,
        roles: Mapping[str, str] | None = None,
        weighting: Weighting | None = None,
    ) -> None:
        self._setup(spec, trials, Limits(spec, limits), roles, weighting)
        self._compute()

    def _setup(
        self,
        spec: StudySpec,
        trials: Trials,
        limits: Limits,
        roles: Mapping[str, str] | None,
        weighting: Weighting | None,
    ) -> None:
        self.spec = spec
        self.trials = trials
        self.weighting = weighting
        self.criteria = list(spec.criteria)
        self.constraints = list(spec.constraints)
        self.crit_names = [c.name for c in self.criteria]
        self.con_names = [c.name for c in self.constraints]
        self.senses = [c.sense for c in self.criteria]
        self.roles = [c.role for c in self.criteria]
        if roles:
            for name, role in roles.items():
                if name not in self.crit_names:
                    raise StudyDefinitionError(
                        "roles", f"unknown criterion {name!r}", suggest(name, self.crit_names)
                    )
                if role not in ("pure", "pseudo"):
                    raise StudyDefinitionError(
                        f"roles.{name}", f"expected 'pure' or 'pseudo', got {role!r}"
                    )
                self.roles[self.crit_names.index(name)] = role
        self.limits = limits
        # bounds[name] = [low, high]: the Limits' own (one definition of D)
        self.bounds: dict[str, list[float]] = limits.bounds

    @classmethod
    def of_store(
        cls,
        store: Store,
        limits: Iterable[Bound] | Mapping[str, Any] | Limits | None = None,
        roles: Mapping[str, str] | None = None,
    ) -> Analysis:
        """The analysis of a store's sample (every sample stage) under ``limits``, weighted
        as the study's sampler says (:meth:`vectorid.samplers.Sampler.weighting`).

        Parameters
        ----------
        store : Store
            An open store.
        limits, roles
            As the constructor takes them.

        Returns
        -------
        Analysis
        """
        trials = store.load()
        weighting = sampler_for(store.spec).weighting(store, trials)
        return cls(store.spec, trials, limits, roles, weighting)

    def narrowed(
        self,
        limits: Iterable[Bound] | Mapping[str, Any] | None = None,
        roles: Mapping[str, str] | None = None,
    ) -> Analysis | None:
        """The analysis of the same trials under ``limits``/``roles`` (as the constructor
        takes them), computed from this one when every bound is the same or tighter and the
        roles are the same; None otherwise (build a new :class:`Analysis` then).

        Tightening only removes trials from D, so only the rows of this D are checked
        against the new bounds. The Pareto set is updated from this one: when every trial of
        this Pareto set stays in D, it *is* the new Pareto set (every other trial of the new
        D was dominated, hence dominated by a member of it; dominance is transitive), and no
        scan is needed; otherwise only the new D is scanned.

        Parameters
        ----------
        limits : iterable of Bound or mapping, optional
            Bounds overriding the study's, as the constructor takes them.
        roles : mapping, optional
            Pure/pseudo roles by criterion name, as the constructor takes them.

        Returns
        -------
        Analysis or None
            The narrowed analysis (sharing this one's trials), or None when a bound is
            looser or a role differs.
        """
        new = Limits(self.spec, limits)
        b = Analysis.__new__(Analysis)
        b._setup(self.spec, self.trials, new, roles, self.weighting)
        if b.roles != self.roles or not new.within(self.limits):
            return None
        b.ok = self.ok
        b.pure = self.pure
        same_functional = all(new.bounds[n] == self.bounds[n] for n in self.con_names)
        if same_functional:
            b.functional_ok = self.functional_ok
        else:
            rows = np.flatnonzero(self.functional_ok)
            keep = new.functional_mask(self.trials.status[rows], self.trials.G[rows])
            b.functional_ok = np.zeros(len(self.ok), dtype=bool)
            b.functional_ok[rows[keep]] = True
        idx = np.flatnonzero(self.feasible)
        keep = b.functional_ok[idx] & new.criteria_mask(self.trials.F, idx)
        b.feasible = np.zeros(len(self.ok), dtype=bool)
        b.feasible[idx[keep]] = True
        if np.array_equal(b.feasible, self.feasible):
            b.pareto = self.pareto
        elif not (self.pareto & ~b.feasible).any():
            b.pareto = self.pareto  # every Pareto trial stays in D: still the Pareto set
        else:
            b.pareto = np.zeros(len(self.ok), dtype=bool)
            d = idx[keep]
            if self.pure and len(d):
                sub = self.trials.F[np.ix_(d, self.pure)]
                b.pareto[d[pareto_mask(sub, [self.senses[i] for i in self.pure])]] = True
        return b

    def widened(
        self,
        limits: Iterable[Bound] | Mapping[str, Any] | None = None,
        roles: Mapping[str, str] | None = None,
    ) -> Analysis | None:
        """The analysis of the same trials under ``limits``/``roles``, computed from this one
        when every criteria bound is the same or looser, the functional bounds are the same
        and the roles are the same; None otherwise.

        Loosening only adds trials to D: the ones whose value of a loosened criterion lies
        between its old and its new bound (found with one comparison per loosened bound
        over that criterion's column), checked against every new bound. The Pareto set is
        the Pareto set of this one's Pareto set and the added trials: a trial of this D
        outside its Pareto set is dominated by a member of it (dominance is transitive), so
        it stays dominated, and it dominates nothing that member does not.

        Parameters
        ----------
        limits : iterable of Bound or mapping, optional
            Bounds overriding the study's, as the constructor takes them.
        roles : mapping, optional
            Pure/pseudo roles by criterion name, as the constructor takes them.

        Returns
        -------
        Analysis or None
            The widened analysis (sharing this one's trials and functional mask), or None
            when a bound is tighter, a functional bound differs or a role differs.
        """
        new = Limits(self.spec, limits)
        b = Analysis.__new__(Analysis)
        b._setup(self.spec, self.trials, new, roles, self.weighting)
        if b.roles != self.roles or not self.limits.within(new):
            return None
        if any(new.bounds[n] != self.bounds[n] for n in self.con_names):
            return None
        b.ok, b.pure, b.functional_ok = self.ok, self.pure, self.functional_ok
        F = self.trials.F
        band = None  # trials a loosened bound may let in
        for j, name in enumerate(self.crit_names):
            (lo, hi), (olo, ohi) = new.bounds[name], self.bounds[name]
            if lo == olo and hi == ohi:
                continue
            col = F[:, j]
            with np.errstate(invalid="ignore"):  # NaN meets no bound
                side = ((col >= lo) & (col < olo)) | ((col > ohi) & (col <= hi))
            band = side if band is None else band | side
        if band is None:
            b.feasible, b.pareto = self.feasible, self.pareto
            return b
        band &= self.functional_ok
        band &= ~self.feasible
        cand = np.flatnonzero(band)
        added = cand[new.criteria_mask(F, cand)]
        if not len(added):
            b.feasible, b.pareto = self.feasible, self.pareto
            return b
        b.feasible = self.feasible.copy()
        b.feasible[added] = True
        b.pareto = np.zeros(len(self.ok), dtype=bool)
        if self.pure:
            rows = np.union1d(np.flatnonzero(self.pareto), added)
            sub = F[np.ix_(rows, self.pure)]
            b.pareto[rows[pareto_mask(sub, [self.senses[i] for i in self.pure])]] = True
        return b

    # -- computation -----------------------------------------------------------------------

    def _column(self, name: str) -> np.ndarray:
        if name in self.crit_names:
            return self.trials.F[:, self.crit_names.index(name)]
        return self.trials.G[:, self.con_names.index(name)]

    def _bound_mask(self, name: str, side: str, value: float | None = None) -> np.ndarray:
        v = self.bounds[name][0 if side == "low" else 1] if value is None else value
        col = self._column(name)
        with np.errstate(invalid="ignore"):
            return col >= v if side == "low" else col <= v

    def active_bounds(self) -> list[Bound]:
        """Finite bounds in force: functional constraints first, then criteria in order."""
        return self.limits.active()

    def _compute(self) -> None:
        t = self.trials
        self.ok = t.status == OK
        self.functional_ok = self.limits.functional_mask(t.status, t.G)
        self.feasible = np.zeros(len(t), dtype=bool)
        rows = np.flatnonzero(self.functional_ok)
        self.feasible[rows[self.limits.criteria_mask(t.F, rows)]] = True
        pure = [i for i, r in enumerate(self.roles) if r == "pure"]
        self.pure = pure
        self.pareto = np.zeros(len(t), dtype=bool)
        if pure and self.feasible.any():
            idx = np.flatnonzero(self.feasible)
            sub = t.F[np.ix_(idx, pure)]
            self.pareto[idx[pareto_mask(sub, [self.senses[i] for i in pure])]] = True

    # -- summaries -------------------------------------------------------------------------

    @property
    def n(self) -> int:
        """N: number of trials."""
        return len(self.trials)

    @property
    def n_failed(self) -> int:
        """Trials that failed (no criteria values)."""
        return int((~self.ok).sum())

    @property
    def n_functional(self) -> int:
        """Trials that meet the functional constraints."""
        return int(self.functional_ok.sum())

    @property
    def n_feasible(self) -> int:
        """ND: trials in the feasible set D."""
        return int(self.feasible.sum())

    @property
    def n_pareto(self) -> int:
        """NP: trials in the Edgeworth–Pareto set."""
        return int(self.pareto.sum())

    def test_table(
        self, name: str, feasible_only: bool = False, top: int | None = None
    ) -> TestTable:
        """The test table of one criterion: trials meeting the functional constraints (or,
        with ``feasible_only``, the feasible ones) sorted best first (seed 000, Fig. 6).

        Parameters
        ----------
        name : str
            A criterion of the study.
        feasible_only : bool
            Only the trials of D.
        top : int, optional
            Only the first ``top`` rows (found without sorting the rest; ``min``/``max``
            stay those of the whole table).

        Returns
        -------
        TestTable
            Ids, values (in the criterion's unit) and D membership, best first.
        """
        if name not in self.crit_names:
            raise StudyDefinitionError(
                "criterion", f"unknown criterion {name!r}", suggest(name, self.crit_names)
            )
        j = self.crit_names.index(name)
        rows = np.flatnonzero(self.feasible if feasible_only else self.functional_ok)
        values = self.trials.F[rows, j]
        vmin = float(values.min()) if len(values) else math.nan
        vmax = float(values.max()) if len(values) else math.nan
        key = -values if self.senses[j] == "max" else values
        if top is not None and 0 <= top < len(key):
            # the rows a stable sort puts first: every key below the top-th smallest, and
            # the earliest rows among those equal to it (NaN last, as argsort puts them)
            k = np.where(np.isnan(key), np.inf, key)
            thr = k[np.argpartition(k, top - 1)[:top]].max() if top else -np.inf
            cand = np.flatnonzero(k <= thr)
            order = cand[np.lexsort((cand, k[cand]))][:top]
            if np.isnan(key[order]).any():  # NaN among the first: the plain sort's order
                order = np.argsort(key, kind="stable")[:top]
        else:
            order = np.argsort(key, kind="stable")
        rows, values = rows[order], values[order]
        lo, hi = self.bounds[name]
        limit = hi if self.senses[j] == "min" else lo
        return TestTable(
            name=name,
            sense=self.senses[j],
            min=vmin,
            max=vmax,
            ids=self.trials.id[rows],
            values=values,
            feasible=self.feasible[rows],
            limit=None if math.isinf(limit) else float(limit),
        )

    def test_tables(self, feasible_only: bool = False, top: int | None = None) -> list[TestTable]:
        """:meth:`test_table` of every criterion, in study order.

        Parameters
        ----------
        feasible_only : bool
            Only the trials of D (default: every trial meeting the functional constraints).
        top : int, optional
            Only each table's first ``top`` rows.

        Returns
        -------
        list of TestTable
        """
        return [self.test_table(n, feasible_only, top) for n in self.crit_names]

    def rows(self, mask: np.ndarray) -> list[dict[str, Any]]:
        """Trials of ``mask`` as dicts (the rows of ``vectorid pareto --json``).

        Parameters
        ----------
        mask : (n,) array of bool
            Which trials, e.g. :attr:`pareto` or :attr:`feasible`.

        Returns
        -------
        list of dict
            ``{"id", "seq", "stage", "params", "criteria", "functionals"}`` per trial, values
            in their study units.
        """
        t = self.trials
        names = self.spec.space.names
        out = []
        for i in np.flatnonzero(mask):
            out.append(
                {
                    "id": int(t.id[i]),
                    "seq": int(t.seq[i]),
                    "stage": int(t.stage[i]),
                    "params": {n: float(v) for n, v in zip(names, t.X[i])},
                    "criteria": {n: float(v) for n, v in zip(self.crit_names, t.F[i])},
                    "functionals": {n: float(v) for n, v in zip(self.con_names, t.G[i])},
                }
            )
        return out

    def diagnose_empty(self) -> EmptyDiagnosis:
        """Which constraint empties D and the smallest relaxation of each that would not."""
        bounds = self.active_bounds()
        masks = [self._bound_mask(b.name, b.side) for b in bounds]
        cumulative = []
        cur = self.ok.copy()
        for b, m in zip(bounds, masks):
            cur = cur & m
            cumulative.append((b, int(cur.sum())))
        relax = []
        for i, b in enumerate(bounds):
            others = self.ok.copy()
            for j, m in enumerate(masks):
                if j != i:
                    others &= m
            if not others.any():
                continue
            col = self._column(b.name)[others]
            needed = float(col.min() if b.side == "high" else col.max())
            gained = int((col <= needed).sum() if b.side == "high" else (col >= needed).sum())
            relax.append((b, Bound(b.name, b.side, needed), gained))
        joint = None
        if not relax and self.ok.any() and bounds:
            # Relative violation of each bound, scaled by the column's spread over ok trials.
            viol = np.zeros((int(self.ok.sum()), len(bounds)))
            idx = np.flatnonzero(self.ok)
            for j, b in enumerate(bounds):
                col = self._column(b.name)[idx]
                spread = float(np.ptp(col)) or 1.0
                d = col - b.value if b.side == "high" else b.value - col
                viol[:, j] = np.maximum(d, 0.0) / spread
            best = int(np.argmin(viol.max(axis=1)))
            i = idx[best]
            need = []
            for j, b in enumerate(bounds):
                if viol[best, j] > 0:
                    need.append(Bound(b.name, b.side, float(self._column(b.name)[i])))
            joint = {"id": int(self.trials.id[i]), "bounds": need}
        return EmptyDiagnosis(cumulative, relax, joint)

    def summary(self) -> dict[str, Any]:
        """Counts and the constraints in force (the ``--json`` header)."""
        return {
            "n": self.n,
            "n_failed": self.n_failed,
            "n_functional": self.n_functional,
            "n_feasible": self.n_feasible,
            "n_pareto": self.n_pareto,
            "criteria": [
                {"name": c.name, "sense": self.senses[i], "role": self.roles[i]}
                for i, c in enumerate(self.criteria)
            ],
            "constraints_in_force": [str(b) for b in self.active_bounds()],
        }

    def pareto_json(self) -> dict[str, Any]:
        """The stable ``vectorid pareto --json`` document."""
        out = self.summary()
        out["pareto"] = self.rows(self.pareto)
        if self.n_feasible == 0:
            out["empty"] = self.diagnose_empty().to_dict()
        return out

    # -- for notebooks: named arrays, pandas frames, verdicts --------------------------------

    @property
    def param_names(self) -> list[str]:
        """Design-variable names, in the order of the columns of ``trials.X``."""
        return list(self.spec.space.names)

    def columns(self) -> dict[str, np.ndarray]:
        """Every trial as named columns of equal length ``n``, with the set flags.

        Returns
        -------
        dict of str to (n,) ndarray
            ``id``, ``seq``, ``stage``, ``status`` (``"ok"``/``"failed"``), ``message``
            (why it failed, else empty), ``wall_time`` (s); then one column per design
            variable, criterion and functional, named as in the study and in its unit (a
            name that clashes with a fixed column or with a quantity of another kind is
            written ``"parameter:NAME"``, ``"criterion:NAME"`` or ``"functional:NAME"``);
            then the bool flags ``functional_ok``, ``feasible`` (in D) and ``pareto``
            under the constraints in force. ``vectorid export`` writes the same columns.
        """

        return trial_columns(self)

    def to_frame(self) -> pd.DataFrame:
        """Every trial as a pandas DataFrame: the columns of :meth:`columns`.

        Needs pandas (``pip install 'vectorid[pandas]'``).

        Returns
        -------
        pandas.DataFrame
            One row per trial. ``df.attrs["units"]`` maps a column to its unit and
            ``df.attrs["constraints"]`` is :meth:`constraints_in_force`.

        Raises
        ------
        ImportError
            pandas is not installed (the message gives the command that installs it).
        """

        return trials_frame(self)

    def constraints_in_force(self) -> list[dict[str, Any]]:
        """Each finite bound in force, with its unit and where it came from.

        Returns
        -------
        list of dict
            Functional constraints first, then criteria, each ``{"name", "kind"
            ("criterion"/"functional"), "bound" ("<="/">="), "value" (in "unit"), "unit",
            "source", "note"}``. ``source`` is the criterion's stated source (``"expert"``,
            ``"noise"`` for a noise floor, ``"quantile"`` for the quantile stand-in),
            ``"study"`` for a functional bound of the study, or ``"analysis"`` for a bound
            given to this analysis (``limits=`` or ``--limit``).
        """

        return constraint_rows(self)

    def verdicts(
        self, *, identified: float = 0.25, weak: float = 0.6, min_feasible: int = 5
    ) -> list[ParameterVerdict]:
        """The identifiability verdict of each design variable, as ``vectorid
        identifiability`` prints it (see :func:`vectorid.identifiability`).

        Parameters
        ----------
        identified, weak : float
            Thresholds on width(D's range) / width(box), dimensionless.
        min_feasible : int
            Fewer trials in D than this cannot show a spread: at best ``"weak"``.

        Returns
        -------
        list of ParameterVerdict
            In the order of the study's variables; ranges in each variable's unit.
        """

        # what each variable means, from the study's builder (an identification: its model's
        # parameter meanings), through the registry: the analysis imports no builder
        return identifiability(
            self,
            identified=identified,
            weak=weak,
            min_feasible=min_feasible,
            meanings=variable_meanings(self.spec),
        )

    def verdict_columns(self, **thresholds: Any) -> dict[str, np.ndarray]:
        """:meth:`verdicts` as named numpy columns, one row per design variable.

        Parameters
        ----------
        **thresholds
            ``identified``, ``weak``, ``min_feasible`` as in :meth:`verdicts`.

        Returns
        -------
        dict of str to (p,) ndarray
            ``name``, ``verdict``, ``unit``, ``meaning``, ``feasible_low``/``feasible_high``
            (range over D), ``pareto_low``/``pareto_high``, ``box_low``/``box_high`` (all in
            ``unit``; NaN when the set is empty), ``width`` (dimensionless),
            ``n_feasible``, ``constrained_by``, ``reason`` and ``suggestion``.
        """

        rows = verdict_rows(self.verdicts(**thresholds))
        keys = list(rows[0]) if rows else ["name", "verdict"]
        return {k: np.array([r[k] for r in rows]) for k in keys}

    def verdicts_frame(self, **thresholds: Any) -> pd.DataFrame:
        """:meth:`verdicts` as a pandas DataFrame, one row per design variable.

        Parameters
        ----------
        **thresholds
            ``identified``, ``weak``, ``min_feasible`` as in :meth:`verdicts`.

        Returns
        -------
        pandas.DataFrame
            Indexed by variable name; the other columns of :meth:`verdict_columns`.
        """

        return verdicts_frame(self.verdicts(**thresholds))


def senses_of(spec: StudySpec, names: Sequence[str]) -> list[str]:
    """Senses of the named criteria."""
    lookup = {c.name: c.sense for c in spec.criteria}
    return [lookup[n] for n in names]
