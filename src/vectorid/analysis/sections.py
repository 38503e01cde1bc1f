"""Sections ("criterion vs parameter, type II": seed 000 Fig. 10, seed 001 Fig. 12).

Around a chosen trial, one parameter is varied over its range (or a chosen sub-range) with
all others fixed at the trial's values; the new trials are evaluated through the study's
Problem (:func:`vectorid.run.extra.run_section`) and stored as an auxiliary stage of kind
``"section"``, which never mixes into the Sobol sample's statistics (``Store.load()`` reads
sample stages only). The stage's note records ``trial=ID param=NAME low=LO high=HI points=N``
so the section can be read back.

The grid is ``points`` evenly spaced values over ``[low, high]`` plus the chosen trial's own
value when it lies inside, so the section passes through the trial (integer variables: the
integers of the range, evenly thinned to ``points``; choice variables: the values in range).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..errors import StudyDefinitionError
from ..space import Choice, Integer, Space
from ..store.sqlite import Store
from ._stages import find_trial, load_all, parse_note

__all__ = ["Section", "check_range", "load_sections", "section_points"]


@dataclass
class Section:
    """The criteria along one section.

    Attributes
    ----------
    stage : int
        The section stage in the store (-1 when not stored).
    trial : int
        Id of the trial the section passes through.
    param : str
    values : (m,) float
        The varied parameter's values, increasing.
    X : (m, p) float
    F : (m, k) float
        Criteria (NaN where a trial failed).
    G : (m, q) float
    status : (m,) int8
    ids : (m,) int64
        Trial ids of the section trials.
    x0 : (p,) float
        The chosen trial's parameters; ``f0`` (k,) its stored criteria.
    crit_names, con_names : list of str
    messages : dict
        Row -> failure message.
    """

    stage: int
    trial: int
    param: str
    values: np.ndarray
    X: np.ndarray
    F: np.ndarray
    G: np.ndarray
    status: np.ndarray
    ids: np.ndarray
    x0: np.ndarray
    f0: np.ndarray
    crit_names: list[str]
    con_names: list[str]
    messages: dict[int, str] = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {
            "stage": self.stage,
            "trial": self.trial,
            "param": self.param,
            "points": [
                {
                    "id": int(self.ids[i]),
                    "value": float(self.values[i]),
                    "ok": bool(self.status[i] == 0),
                    "criteria": {n: float(v) for n, v in zip(self.crit_names, self.F[i])},
                    "functionals": {n: float(v) for n, v in zip(self.con_names, self.G[i])},
                }
                for i in range(len(self.values))
            ],
            "trial_criteria": {n: float(v) for n, v in zip(self.crit_names, self.f0)},
        }


def check_range(param: str, value_range: Sequence[float]) -> tuple[float, float]:
    """``(lo, hi)`` of a section range, checked (two finite numbers, lo < hi)."""
    if len(value_range) != 2:
        raise StudyDefinitionError(
            "--range", f"expected two numbers LO HI, got {list(value_range)}", "e.g. --range 0 1.5"
        )
    lo, hi = float(value_range[0]), float(value_range[1])
    if not (math.isfinite(lo) and math.isfinite(hi)) or not lo < hi:
        raise StudyDefinitionError(
            "--range",
            f"expected finite LO < HI for {param}, got {lo!r} {hi!r}",
            "write the smaller value first, e.g. --range 0.2 0.8",
        )
    return lo, hi


def section_points(
    space: Space,
    x0: np.ndarray,
    param: str,
    points: int = 21,
    value_range: Sequence[float] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The section's parameter vectors.

    Parameters
    ----------
    space : Space
        The study's variables (the default range is the variable's box).
    x0 : (p,) float
        The vector the section passes through.
    param : str
        The variable to vary.
    points : int
        Evenly spaced values over the range (>= 2); the trial's own value is added when it
        lies inside the range.
    value_range : (lo, hi), optional
        Sub-range (or wider range) of the variable, in its unit.

    Returns
    -------
    values : (m,) float
        The varied values, increasing and distinct.
    X : (m, p) float
        ``x0`` repeated with column ``param`` replaced by ``values``.
    """
    if points < 2:
        raise StudyDefinitionError(
            "--points", f"a section needs at least 2 points, got {points}", "use --points 21"
        )
    j = space.index(param)
    var = space.variables[j]
    lo, hi = (var.low, var.high) if value_range is None else check_range(param, value_range)
    if isinstance(var, Integer):
        ints = np.arange(math.ceil(lo), math.floor(hi) + 1, dtype=float)
        if len(ints) > points:
            ints = np.unique(ints[np.round(np.linspace(0, len(ints) - 1, points)).astype(int)])
        values = ints
    elif isinstance(var, Choice):
        values = np.array(sorted(v for v in var.values if lo <= v <= hi), dtype=float)
    else:
        values = np.linspace(lo, hi, int(points))
    x0 = np.asarray(x0, dtype=float)
    if lo <= x0[j] <= hi:
        values = np.union1d(values, [x0[j]])
    if len(values) == 0:
        raise StudyDefinitionError(
            "--range",
            f"no admissible value of {param} lies in [{lo}, {hi}]",
            "widen the range",
        )
    X = np.repeat(x0[None, :], len(values), axis=0)
    X[:, j] = values
    return values, X


def load_sections(store: Store) -> list[Section]:
    """Every section stored in ``store``, in stage order."""
    spec = store.spec
    secs = [s for s in store.stages() if s.kind == "section"]
    if not secs:
        return []
    t = load_all(store)
    out = []
    for s in secs:
        info = parse_note(s.note)
        param = info.get("param")
        if param not in spec.space.names:
            continue
        j = spec.space.index(param)
        m = t.stage == s.stage
        order = np.argsort(t.X[m, j], kind="stable")
        trial = int(info.get("trial", "0"))
        try:
            base = find_trial(store, trial, t)
            x0, f0 = base.x, base.f
        except StudyDefinitionError:
            x0 = np.full(len(spec.space), np.nan)
            f0 = np.full(len(spec.criteria), np.nan)
        rows = np.flatnonzero(m)[order]
        out.append(
            Section(
                stage=s.stage,
                trial=trial,
                param=param,
                values=t.X[rows, j],
                X=t.X[rows],
                F=t.F[rows],
                G=t.G[rows],
                status=t.status[rows],
                ids=t.id[rows],
                x0=x0,
                f0=f0,
                crit_names=spec.criterion_names,
                con_names=spec.constraint_names,
                messages={
                    k: t.messages[(s.stage, int(t.seq[r]))]
                    for k, r in enumerate(rows)
                    if (s.stage, int(t.seq[r])) in t.messages
                },
            )
        )
    return out
