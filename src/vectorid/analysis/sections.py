"""Sections ("criterion vs parameter, type II": seed 000 Fig. 10, seed 001 Fig. 12).

Around a chosen trial, one parameter is varied over its range (or a chosen sub-range) with
all others fixed at the trial's values; the new trials are evaluated through the study's
Problem (:func:`vectorid.workflows.extra.run_section`) and stored as an auxiliary stage of kind
``"section"``, which never mixes into the Sobol sample's statistics (``Store.load()`` reads
sample stages only). The stage's note records ``trial=ID param=NAME low=LO high=HI points=N``
so the section can be read back.

The grid is ``points`` evenly spaced values over ``[low, high]`` plus the chosen trial's own
value when it lies inside, so the section passes through the trial (integer variables: the
integers of the range, evenly thinned to ``points``; choice variables: the values in range).

:func:`sections_through` sections through any point (on a twin: the truth) with an evaluator
of the user's, and returns per variable the interval around the point that stays inside the
criteria constraints: what the data hold about each variable *if the others were known*.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..errors import StudyDefinitionError
from ..space import Choice, Integer, Space
from ..store import Store
from ._stages import find_trial, load_all, parse_note

__all__ = ["Section", "check_range", "load_sections", "section_points", "sections_through"]


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


def sections_through(
    evaluate: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
    x0: Sequence[float] | np.ndarray,
    names: Sequence[str],
    crit_names: Sequence[str],
    limits: Mapping[str, float],
    boxes: Mapping[str, tuple[float, float]],
    *,
    points: int = 25,
    near: float = 0.06,
) -> dict[str, tuple[float, float] | None]:
    """One-variable sections through a point, read as intervals inside the criteria limits.

    Per variable, the others stay at ``x0`` and the variable takes ``points`` evenly spaced
    values over its box, as many again within ``near`` (share of the box) on each side of
    its value in ``x0``, and that value itself; all sections are evaluated in one batch. The
    interval is the connected run of values around ``x0`` where every limited criterion meets
    its limit (a failed trial, NaN, meets none). On a twin, through the truth, it is what the
    data hold about each variable *if the others were known*: an inner bound of what they
    determine jointly (a real flight has no truth to section through).

    Parameters
    ----------
    evaluate : callable
        ``X (n, p) -> (F (n, k), G (n, q))``, the batch model protocol (e.g.
        :meth:`vectorid.identify.Identification.evaluate`).
    x0 : (p,) float
        The point, in the variables' units, in the order of ``names``.
    names : sequence of str
        The variables (columns of ``X``).
    crit_names : sequence of str
        The criteria (columns of ``F``).
    limits : mapping
        Criterion name -> limit Φ** (its unit; a criterion without one is not limited).
    boxes : mapping
        Variable name -> (low, high), in its unit.
    points : int
        Values over the box (>= 2).
    near : float
        Half-width of the refined grid around ``x0``, as a share of the box.

    Returns
    -------
    dict
        Variable name -> (low, high) of the interval, in its unit; None where ``x0`` itself
        exceeds a limit.
    """
    if points < 2:
        raise StudyDefinitionError(
            "points", f"a section needs at least 2 points, got {points}", "use points=25"
        )
    names = list(names)
    x0 = np.asarray(x0, dtype=float)
    if x0.shape != (len(names),):
        raise StudyDefinitionError(
            "x0",
            f"expected {len(names)} values (one per variable), got shape {x0.shape}",
            "give the point in the order of names",
        )
    L = np.array([float(limits.get(c, np.inf)) for c in crit_names])
    batches, where = [], []
    for j, n in enumerate(names):
        lo, hi = (float(v) for v in boxes[n])
        fine = np.clip(x0[j] + near * (hi - lo) * np.linspace(-1, 1, points), lo, hi)
        g = np.unique(np.concatenate([np.linspace(lo, hi, points), fine, [x0[j]]]))
        X = np.tile(x0, (g.size, 1))
        X[:, j] = g
        batches.append(X)
        where.append((n, g, int(np.searchsorted(g, x0[j]))))
    F = np.asarray(evaluate(np.vstack(batches))[0], dtype=float)
    with np.errstate(invalid="ignore"):
        ok = np.all(F <= L[None, :], axis=1)
    out: dict[str, tuple[float, float] | None] = {}
    start = 0
    for n, g, k in where:
        m = ok[start : start + g.size]
        start += g.size
        if not m[k]:
            out[n] = None
            continue
        a, b = k, k
        while a > 0 and m[a - 1]:
            a -= 1
        while b < g.size - 1 and m[b + 1]:
            b += 1
        out[n] = (float(g[a]), float(g[b]))
    return out
