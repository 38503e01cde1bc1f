"""Robustness of chosen vectors (seed 001 Table 4 and Sec. VI.D).

Before the final choice the seed compares a few Pareto vectors (their criteria side by
side with the minimum and maximum over them: :func:`chosen_table`) and checks that each
one's criteria respond smoothly in its vicinity. :func:`vectorid.workflows.extra.run_robustness`
evaluates a small neighbourhood of a trial and stores it as an auxiliary stage of kind
``"robustness"`` (never mixed into the sample's statistics); the stage note records
``trial=ID radius=R points=N seed=S``.

Neighbourhood (two scales): the trial itself, then ``x0 ± d_i`` and ``x0 ± d_i / 2`` for
``n`` directions ``d_i = radius · (high − low) ⊙ (2 u_i − 1)``, where ``u_i`` are points of an
Owen-scrambled Sobol sequence seeded with ``seed``; a direction that would leave the study
box is shortened so that every point stays inside (integers are then rounded and choice
values snapped to the nearest admissible value). Rows: ``[x0, x0 + d, x0 − d, x0 + d/2,
x0 − d/2]``, ``1 + 4 n`` in all.

Smoothness verdict, per criterion. From the outer pairs, ``a_i = (F(x0+d) − F(x0−d)) / 2``
(slope term, O(r)) and ``m_i = (F(x0+d) + F(x0−d)) / 2 − F(x0)`` (curvature term, O(r²))
predict the inner points by Taylor's theorem: ``F(x0 ± d/2) ≈ F(x0) ± a_i / 2 + m_i / 4``,
with an error O(r³) for a smooth criterion, including at an optimum where the slope
vanishes. The score is ``1 − Σ error² / Σ (F(x0 ± d/2) − F(x0))²``: close to 1 for a smooth
response, near or below 0 for noise or kinks.

* ``failed``: some neighbour failed (the model is not defined all around the vector);
* ``flat``: the criterion does not change (range ≤ 1e-12 · max(1, |value|));
* ``smooth``: score ≥ ``smooth_score`` (default 0.9);
* ``rough``: otherwise (noise, kinks, or a radius too large for the local curvature).

The vector is ``smooth`` when every criterion is ``smooth`` or ``flat``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import StudyDefinitionError
from ..problem import OK
from ..space import Choice, Integer, Space
from ..store import Store
from ._stages import find_trial, load_all, parse_note
from .results import Analysis

__all__ = [
    "ChosenTable",
    "Robustness",
    "build_robustness",
    "chosen_table",
    "load_robustness",
    "neighbourhood",
    "robustness_stats",
]


@dataclass
class ChosenTable:
    """Criteria of a few chosen trials with the min and max over them (seed 001 Table 4).

    Attributes
    ----------
    ids : (m,) int64
    crit_names : list of str
    F : (m, k) float
    min, max : (k,) float
    X : (m, p) float
    """

    ids: np.ndarray
    crit_names: list[str]
    F: np.ndarray
    min: np.ndarray
    max: np.ndarray
    X: np.ndarray

    def to_dict(self) -> dict[str, Any]:
        return {
            "criteria": self.crit_names,
            "min": self.min.tolist(),
            "max": self.max.tolist(),
            "rows": [
                {"id": int(i), "criteria": dict(zip(self.crit_names, map(float, f)))}
                for i, f in zip(self.ids, self.F)
            ],
        }


def chosen_table(a: Analysis, ids: Sequence[int]) -> ChosenTable:
    """Criteria of the chosen sample trials, with min and max over them.

    Raises
    ------
    StudyDefinitionError
        When an id is not a loaded trial.
    """
    rows = []
    for i in ids:
        hit = np.flatnonzero(a.trials.id == int(i))
        if len(hit) == 0:
            raise StudyDefinitionError(
                "--trial", f"no sample trial has id {i}", "`vectorid pareto STORE` lists ids"
            )
        rows.append(int(hit[0]))
    F = a.trials.F[rows]
    with np.errstate(all="ignore"):
        lo = np.nanmin(F, axis=0) if len(rows) else np.full(len(a.crit_names), np.nan)
        hi = np.nanmax(F, axis=0) if len(rows) else np.full(len(a.crit_names), np.nan)
    return ChosenTable(
        ids=a.trials.id[rows],
        crit_names=list(a.crit_names),
        F=F,
        min=lo,
        max=hi,
        X=a.trials.X[rows],
    )


def neighbourhood(
    space: Space, x0: np.ndarray, *, radius: float = 0.02, points: int | None = None, seed: int = 0
) -> np.ndarray:
    """The trial and its two-scale neighbours (see the module docstring), (1 + 4 n, p).

    Parameters
    ----------
    space : Space
        The study's variables (box, kinds).
    x0 : (p,) float
    radius : float in (0, 1]
        Half-width of the outer neighbourhood as a fraction of each variable's box width.
    points : int, optional
        Number of neighbours, rounded up to a multiple of 4 (default 32: 8 directions).
    seed : int
    """
    p = len(space)
    if not (0.0 < radius <= 1.0):
        raise StudyDefinitionError(
            "--radius", f"expected 0 < radius <= 1 (fraction of the box), got {radius}", "e.g. 0.02"
        )
    n = 32 if points is None else int(points)
    if n < 4:
        raise StudyDefinitionError(
            "--points", f"expected at least 4 neighbours, got {n}", "use --points 32"
        )
    dirs = math.ceil(n / 4)
    from scipy.stats import qmc  # imported where used: scipy.stats loads slowly

    sob = qmc.Sobol(p, scramble=True, seed=np.random.default_rng(seed))
    u = sob.random_base2(max(0, math.ceil(math.log2(dirs))))[:dirs]
    lows, highs = space.lows, space.highs
    x0 = np.clip(np.asarray(x0, float), lows, highs)
    d = radius * (highs - lows) * (2.0 * u - 1.0)
    # shorten each direction so that x0 ± d stays in the box
    with np.errstate(divide="ignore", invalid="ignore"):
        room = np.minimum(highs - x0, x0 - lows)[None, :] / np.abs(d)
    shrink = np.minimum(1.0, np.nan_to_num(room, nan=np.inf, posinf=np.inf).min(axis=1))
    d = d * shrink[:, None]
    X = np.vstack([x0[None, :], x0 + d, x0 - d, x0 + 0.5 * d, x0 - 0.5 * d])
    X = np.clip(X, lows, highs)
    for j, v in enumerate(space):
        if isinstance(v, Integer):
            X[:, j] = np.round(X[:, j])
        elif isinstance(v, Choice):
            vals = np.asarray(v.values, float)
            X[:, j] = vals[np.argmin(np.abs(X[:, j, None] - vals[None, :]), axis=1)]
    return X


@dataclass
class Robustness:
    """Criteria in the neighbourhood of one trial and the smoothness verdict.

    Attributes
    ----------
    stage, trial : int
    radius : float
    X : (m, p) float
        Row 0 is the trial itself (re-evaluated), then the neighbours.
    F : (m, k) float
    status : (m,) int8
    f0 : (k,) float
        The trial's stored criteria.
    crit_names : list of str
    min, max : (k,) float
        Over the successful neighbourhood rows.
    relative_range : (k,) float
        ``(max − min)`` divided by the criterion's span over the sample (``span``), or by
        ``|f0|`` when no span is given.
    score : (k,) float
        Two-scale smoothness score (1 for a smooth response).
    verdicts : list of str
        Per criterion: ``smooth``, ``flat``, ``rough`` or ``failed``.
    verdict : str
        ``smooth`` or ``rough: f1, f3`` or ``failed: n of m neighbours failed``.
    feasible_fraction : float or None
        Share of the neighbourhood inside D under the analysis' constraints.
    """

    stage: int
    trial: int
    radius: float
    X: np.ndarray
    F: np.ndarray
    status: np.ndarray
    f0: np.ndarray
    crit_names: list[str]
    min: np.ndarray
    max: np.ndarray
    relative_range: np.ndarray
    score: np.ndarray
    verdicts: list[str]
    verdict: str
    feasible_fraction: float | None = None
    seed: int = 0
    extra: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {
            "stage": self.stage,
            "trial": self.trial,
            "radius": self.radius,
            "points": len(self.X),
            "failed": int((self.status != OK).sum()),
            "verdict": self.verdict,
            "feasible_fraction": self.feasible_fraction,
            "criteria": [
                {
                    "name": n,
                    "value": float(self.f0[j]),
                    "min": float(self.min[j]),
                    "max": float(self.max[j]),
                    "relative_range": float(self.relative_range[j]),
                    "score": float(self.score[j]),
                    "verdict": self.verdicts[j],
                }
                for j, n in enumerate(self.crit_names)
            ],
        }


def robustness_stats(
    F: np.ndarray,
    status: np.ndarray,
    f0: np.ndarray,
    *,
    span: np.ndarray | None = None,
    smooth_score: float = 0.9,
) -> dict[str, Any]:
    """Min, max, relative range, two-scale smoothness score and verdicts (see the module
    docstring).

    Parameters
    ----------
    F : (1 + 4 n, k)
        Criteria over the neighbourhood of :func:`neighbourhood` (row order matters).
    status : (1 + 4 n,)
    f0 : (k,)
        The trial's stored criteria.
    span : (k,), optional
        Each criterion's range over the sample, to scale ``relative_range``.
    """
    ok = status == OK
    m, k = F.shape
    n = (m - 1) // 4
    if m != 1 + 4 * n:
        raise ValueError(f"expected 1 + 4 n neighbourhood rows, got {m}")
    failed = int((~ok).sum())
    Fo = F[ok]
    with np.errstate(all="ignore"):
        lo = Fo.min(axis=0) if len(Fo) else np.full(k, np.nan)
        hi = Fo.max(axis=0) if len(Fo) else np.full(k, np.nan)
        scale = np.abs(f0) if span is None else np.asarray(span, float)
        rel = (hi - lo) / np.where(scale > 0, scale, np.nan)
    score = np.full(k, np.nan)
    verdicts = []
    for j in range(k):
        if failed:
            verdicts.append("failed")
            continue
        if (hi[j] - lo[j]) <= 1e-12 * max(1.0, abs(float(f0[j]))):
            score[j] = 1.0
            verdicts.append("flat")
            continue
        c = F[0, j]
        P, M = F[1 : 1 + n, j], F[1 + n : 1 + 2 * n, j]
        Ph, Mh = F[1 + 2 * n : 1 + 3 * n, j], F[1 + 3 * n :, j]
        a, curv = 0.5 * (P - M), 0.5 * (P + M) - c
        err = np.concatenate([Ph - (c + a / 2 + curv / 4), Mh - (c - a / 2 + curv / 4)])
        var = np.concatenate([Ph - c, Mh - c])
        ss = float((var**2).sum())
        score[j] = 1.0 - float((err**2).sum()) / ss if ss > 0 else 1.0
        verdicts.append("smooth" if score[j] >= smooth_score else "rough")
    if failed:
        verdict = f"failed: {failed} of {m} neighbourhood trials failed"
    else:
        rough = [j for j, v in enumerate(verdicts) if v == "rough"]
        verdict = "smooth" if not rough else "rough: " + ", ".join(str(j) for j in rough)
    return {
        "min": lo,
        "max": hi,
        "relative_range": rel,
        "score": score,
        "verdicts": verdicts,
        "verdict": verdict,
    }


def _in_d(a: Analysis, F: np.ndarray, G: np.ndarray, status: np.ndarray) -> np.ndarray:
    m = status == OK
    with np.errstate(invalid="ignore"):
        for j, n in enumerate(a.crit_names):
            lo, hi = a.bounds[n]
            m &= (F[:, j] >= lo) & (F[:, j] <= hi)
        for j, n in enumerate(a.con_names):
            lo, hi = a.bounds[n]
            m &= (G[:, j] >= lo) & (G[:, j] <= hi)
    return m


def build_robustness(
    crit_names: list[str],
    stage: int,
    trial: int,
    radius: float,
    seed: int,
    X: np.ndarray,
    F: np.ndarray,
    G: np.ndarray,
    status: np.ndarray,
    f0: np.ndarray,
    a: Analysis | None,
) -> Robustness:
    """The :class:`Robustness` of a neighbourhood already evaluated (rows as
    :func:`neighbourhood` makes them), judged against the constraints of ``a`` when given."""
    span = None
    if a is not None:
        base = a.feasible if a.n_feasible >= 2 else a.ok
        if base.any():
            span = np.nanmax(a.trials.F[base], axis=0) - np.nanmin(a.trials.F[base], axis=0)
    st = robustness_stats(F, status, f0, span=span)
    verdict = st["verdict"]
    if verdict.startswith("rough: "):
        idx = [int(s) for s in verdict[7:].split(", ")]
        verdict = "rough: " + ", ".join(crit_names[j] for j in idx)
    return Robustness(
        stage=stage,
        trial=trial,
        radius=radius,
        X=X,
        F=F,
        status=status,
        f0=f0,
        crit_names=crit_names,
        min=st["min"],
        max=st["max"],
        relative_range=st["relative_range"],
        score=st["score"],
        verdicts=st["verdicts"],
        verdict=verdict,
        feasible_fraction=None if a is None else float(_in_d(a, F, G, status).mean()),
        seed=seed,
    )


def load_robustness(store: Store, analysis: Analysis | None = None) -> list[Robustness]:
    """Every robustness check stored in ``store``, in stage order."""
    spec = store.spec
    stages = [s for s in store.stages() if s.kind == "robustness"]
    if not stages:
        return []
    t = load_all(store)
    out = []
    for s in stages:
        info = parse_note(s.note)
        trial = int(info.get("trial", "0"))
        m = t.stage == s.stage
        if not m.any():
            continue
        try:
            f0 = find_trial(store, trial, t).f
        except StudyDefinitionError:
            f0 = t.F[np.flatnonzero(m)[0]]
        out.append(
            build_robustness(
                spec.criterion_names,
                s.stage,
                trial,
                float(info.get("radius", "nan")),
                int(info.get("seed", "0")),
                t.X[m],
                t.F[m],
                t.G[m],
                t.status[m],
                f0,
                analysis,
            )
        )
    return out
