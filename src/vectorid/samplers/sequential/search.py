"""The sequential sampler's local search, made when the budget is spent before D is reached.

A pattern search in unit coordinates from the best trials, its polls evaluated as rounds
through the run driver (so they are stored, in an auxiliary stage of kind ``"search"``, and
checked like every trial). It tells the user whether D is empty or the sampler only did not
reach it: a vector that meets every limit says D is not empty; a best vector pressed against
the box says the box may be too narrow there; only a best vector inside the box that still
misses lets the sampler's verdict (:meth:`SequentialSummary.verdict`) blame the model or the
limits.
"""

from __future__ import annotations

from collections.abc import Generator
from dataclasses import dataclass, field

import numpy as np

from ...errors import plural
from ...limits import oriented
from ...problem import OK
from ...store import Store
from ..base import Round, RoundResult, StageRequest
from .state import SequentialState, score, unit

__all__ = [
    "EDGE_SHARE",
    "SEARCH_EVALUATIONS",
    "SEARCH_FLOOR",
    "SEARCH_MIN_STEP",
    "SEARCH_SEPARATION",
    "LocalSearch",
    "local_search",
    "search_edges",
    "starts_text",
]

#: Most evaluations of the local search made when the budget is spent before D is reached ...
SEARCH_EVALUATIONS = 4000
#: ... and no more than the sampler's budget, but at least this many.
SEARCH_FLOOR = 500
#: A start of the local search ends when its step (share of each variable's width) falls below
#: this; the next start is the best trial farther than :data:`SEARCH_SEPARATION` (max over the
#: variables, share of the width) from every earlier start and end.
SEARCH_MIN_STEP = 1e-4
SEARCH_SEPARATION = 0.05
#: A search's best vector within this share of a variable's width from the box's side is
#: "against the edge": the search was held there (on the ETH flights it stopped 0.06 % of
#: the width from a side, its steps toward it no better).
EDGE_SHARE = 0.01


@dataclass
class LocalSearch:
    """A local search from the best trials (run when D was not reached).

    Attributes
    ----------
    start : int
        Trial id it started from.
    start_factor, factor : float
        ``max_l Φ_l / Φ**_l`` (how far the limits must be relaxed; ``<= 1`` meets them) at
        the start and at the best vector found.
    x : (p,) float array
        The best vector found.
    evaluations : int
        Model evaluations it made (stored in an auxiliary stage).
    stage : int
        The auxiliary stage (kind ``"search"``) holding them.
    edges : list of (str, str, float)
        Variables of ``x`` against the box's edge (within :data:`EDGE_SHARE` of its width):
        ``(name, "low" or "high", the edge's value)``. A search that ends pressed against the
        box says the box may be too narrow, not that the model misses.
    starts : int
        Trials it started from (the best first, then the best not near an earlier start).
    """

    start: int
    start_factor: float
    factor: float
    x: np.ndarray
    evaluations: int
    stage: int
    edges: list[tuple[str, str, float]] = field(default_factory=list)
    starts: int = 1

    @property
    def met(self) -> bool:
        return self.factor <= 1.0


def local_search(
    store: Store, spec, state: SequentialState, say, budget: int
) -> Generator[Round, RoundResult, LocalSearch | None]:
    """Pattern search in unit coordinates from the best trials, 2p points per round.

    Each poll tries the 2p coordinate steps; where none improves, it tries once more along a
    random orthonormal basis (the criteria's max-ratio score has kinks, at which no coordinate
    step may improve although a slanted one does) before halving the step. A start ends when
    its step falls below :data:`SEARCH_MIN_STEP`; the next starts from the best trial not yet
    near a start or an end (:data:`SEARCH_SEPARATION`), until a vector meets every limit or
    :data:`SEARCH_EVALUATIONS` are spent, but no more than the sampler's ``budget`` (at least
    :data:`SEARCH_FLOOR`). Seeded by the study's seed: a function of the stored trials only.

    Yields
    ------
    Round
        One poll (its trials go to the search's auxiliary stage).

    Returns
    -------
    LocalSearch or None
        None when no trial succeeded.
    """
    trials = store.load(stages=[0])
    sc0 = np.where(state.usable, score(state.phi, state.floor), np.inf)
    if not np.isfinite(sc0).any():
        return None
    order = [int(i) for i in np.argsort(sc0, kind="stable") if np.isfinite(sc0[i])]
    U0 = unit(spec.space, trials.X)
    p = U0.shape[1]
    rng = np.random.default_rng([int(spec.seed), 0x5EA])
    first = order[0]
    start_id = int(trials.id[first])
    stage: int | StageRequest = StageRequest("search", f"local search from trial {start_id}")
    senses = [spec.criteria[j].sense for j in state.constrained]
    seq = used = starts = 0
    best_u, best_s = U0[first], float(sc0[first])
    visited: list[np.ndarray] = []

    def poll(
        u: np.ndarray, E: np.ndarray
    ) -> Generator[Round, RoundResult, tuple[np.ndarray, float]]:
        nonlocal seq, used, stage
        Ub = np.clip(u + E, 0.0, 1.0)
        X = spec.space.scale(Ub)
        at = seq
        done = yield Round(stage, at, at + len(X), lambda s, n: X[s - at : s - at + n],
                           batch=len(X), results=True, bar=False)  # fmt: skip
        stage = done.stage
        res = done.result
        seq += len(X)
        used += len(X)
        ok = res.status == OK
        for c in spec.constraints:
            j = spec.constraint_names.index(c.name)
            col = res.functionals[:, j]
            with np.errstate(invalid="ignore"):
                ok &= (col >= (-np.inf if c.low is None else c.low)) & (
                    col <= (np.inf if c.high is None else c.high)
                )
        sc = np.where(ok, score(oriented(res.criteria[:, state.constrained], senses),
                                state.floor), np.inf)  # fmt: skip
        i = int(np.argmin(sc))
        return Ub[i], float(sc[i])

    cap = min(SEARCH_EVALUATIONS, max(int(budget), SEARCH_FLOOR))
    say(f"local search from trial {start_id} (limits ×{best_s:.3g})")
    for i in order:
        if used >= cap or best_s <= 1.0:
            break
        if any(np.max(np.abs(U0[i] - v)) < SEARCH_SEPARATION for v in visited):
            continue
        u, s = U0[i], float(sc0[i])
        visited.append(u)
        starts += 1
        step = 0.05
        while used < cap and step > SEARCH_MIN_STEP and s > 1.0:
            eye = np.eye(p)
            un, sn = yield from poll(u, np.vstack([eye, -eye]) * step)
            if sn >= s and used < cap:
                Q, _ = np.linalg.qr(rng.standard_normal((p, p)))
                un, sn = yield from poll(u, np.vstack([Q.T, -Q.T]) * step)
            if sn < s:
                u, s = un, sn
            else:
                step *= 0.5
        visited.append(u)
        if s < best_s:
            best_u, best_s = u, s
    say(
        f"local search: {plural(used, 'evaluation')} from {plural(starts, 'start')}, best "
        f"limits ×{best_s:.3g}"
    )
    edges = search_edges(spec, best_u)
    return LocalSearch(start_id, float(sc0[first]), best_s, spec.space.scale(best_u[None])[0],
                       used, stage if isinstance(stage, int) else -1, edges, starts)  # fmt: skip


def starts_text(s: LocalSearch) -> str:
    """ "trial (id)" or "trials (id and k more)" for the search's message."""
    return f"trial ({s.start})" if s.starts <= 1 else f"trials ({s.start} and {s.starts - 1} more)"


def search_edges(spec, u: np.ndarray, tol: float = EDGE_SHARE) -> list[tuple[str, str, float]]:
    """Variables of the unit-coordinate vector ``u`` against the box's edge (within ``tol`` of
    the width from a side): ``(name, "low" or "high", the edge in the study's unit)``."""
    out = []
    for j, var in enumerate(spec.space):
        if u[j] <= tol:
            out.append((var.name, "low", float(var.low)))
        elif u[j] >= 1.0 - tol:
            out.append((var.name, "high", float(var.high)))
    return out
