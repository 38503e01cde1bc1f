"""Extra runs: the trials a study adds beside its Sobol sample, in one place that evaluates
and stores. Each goes into its own *stage* of the store (the store's word for a box and a kind
of trials: ``"sample"``, ``"section"``, ``"robustness"``), never into an identification stage
(:mod:`vectorid.workflows.stages`).

* :func:`run_section` — a section ("criterion vs parameter, type II", seed 000 Fig. 10)
  through a stored trial, stored as an auxiliary stage of kind ``"section"``;
* :func:`run_robustness` — the two-scale neighbourhood of a stored trial (seed 001 Table 4),
  stored as an auxiliary stage of kind ``"robustness"``;
* :func:`apply_refine` — a refined box (double tuning) added as a new *sample* stage, where
  :func:`vectorid.run.run_store` continues the sequence;
* :func:`evaluate_and_store` — the common step: evaluate a batch through the study's Problem
  and append it to a stage.

:mod:`vectorid.analysis` only reads the store and derives (the grids of
:func:`~vectorid.analysis.sections.section_points` and
:func:`~vectorid.analysis.robustness.neighbourhood`, the proposal of
:func:`~vectorid.analysis.refine.propose_refine`, and reading these stages back with
``load_sections`` / ``load_robustness``); everything that writes is here.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..analysis._stages import find_trial
from ..analysis.refine import RefineProposal
from ..analysis.relaxation import (
    MIN_D,
    RELAX_SHARE,
    Relaxation,
    relaxation_text,
    relaxed_limits,
)
from ..analysis.results import Analysis
from ..analysis.robustness import Robustness, build_robustness, neighbourhood
from ..analysis.sections import Section, check_range, section_points
from ..problem import EvalResult, Problem
from ..run.loop import evaluate_into
from ..store import Stage, Store

__all__ = ["apply_refine", "evaluate_and_store", "relax_study", "run_robustness", "run_section"]


def evaluate_and_store(
    store: Store, stage: int, X: np.ndarray, problem: Problem | None = None
) -> EvalResult:
    """Evaluate ``X`` (n, p) through the study's Problem and store it as stage ``stage``
    starting at sequence index 0.

    Raises
    ------
    StoreError
        When the store was opened read-only.
    InputsChangedError
        When the model's code or a data file changed since the stored trials were computed.
    """
    return evaluate_into(store, stage, X, problem)  # through the one run loop


def run_section(
    store: Store,
    trial: int,
    param: str,
    *,
    points: int = 21,
    value_range: Sequence[float] | None = None,
    problem: Problem | None = None,
) -> Section:
    """Evaluate and store a section through a stored trial.

    Parameters
    ----------
    store : Store
        Opened with ``write=True``.
    trial : int
        Id of a stored trial (``vectorid pareto`` lists ids).
    param : str
        Variable to vary.
    points : int
        Evenly spaced values (see :func:`~vectorid.analysis.sections.section_points`).
    value_range : (lo, hi), optional
        Range of ``param`` in its unit (default: its box in the study).
    problem : Problem, optional
        Evaluate with this Problem instead of the study's model (tests, notebooks).

    Returns
    -------
    Section
    """
    spec = store.spec
    t = find_trial(store, trial)
    values, X = section_points(spec.space, t.x, param, points, value_range)
    lo, hi = float(values.min()), float(values.max())
    if value_range is not None:
        lo, hi = check_range(param, value_range)
    box = spec.space
    if lo < hi:
        box = spec.space.with_bounds({param: (lo, hi)})
    stage = store.add_stage(
        box,
        kind="section",
        note=f"section trial={t.id} param={param} low={lo!r} high={hi!r} points={len(values)}",
    )
    res = evaluate_and_store(store, stage.stage, X, problem)
    return Section(
        stage=stage.stage,
        trial=t.id,
        param=param,
        values=values,
        X=X,
        F=res.criteria,
        G=res.functionals,
        status=res.status,
        ids=stage.stage * 1_000_000_000 + np.arange(len(values), dtype=np.int64) + 1,
        x0=t.x,
        f0=t.f,
        crit_names=spec.criterion_names,
        con_names=spec.constraint_names,
        messages=dict(res.messages),
    )


def run_robustness(
    store: Store,
    trial: int,
    *,
    radius: float = 0.02,
    points: int | None = None,
    seed: int = 0,
    analysis: Analysis | None = None,
    problem: Problem | None = None,
) -> Robustness:
    """Evaluate and store the neighbourhood of a stored trial; return its verdict.

    Parameters
    ----------
    store : Store
        Opened with ``write=True``.
    trial : int
        Id of a stored trial.
    radius, points, seed
        See :func:`~vectorid.analysis.robustness.neighbourhood` (radius as a fraction of
        each variable's box width).
    analysis : Analysis, optional
        Constraints in force: gives ``feasible_fraction`` and scales ``relative_range`` by
        each criterion's span over D.
    problem : Problem, optional
        Evaluate with this Problem instead of the study's model.
    """
    spec = store.spec
    t = find_trial(store, trial)
    X = neighbourhood(spec.space, t.x, radius=radius, points=points, seed=seed)
    stage = store.add_stage(
        spec.space,
        kind="robustness",
        note=f"robustness trial={t.id} radius={radius!r} points={len(X) - 1} seed={seed}",
    )
    res = evaluate_and_store(store, stage.stage, X, problem)
    return build_robustness(
        spec.criterion_names,
        stage.stage,
        t.id,
        radius,
        seed,
        X,
        res.criteria,
        res.functionals,
        res.status,
        t.f,
        analysis,
    )


def apply_refine(store: Store, proposal: RefineProposal) -> Stage:
    """Add the proposed box as a new sample stage starting where the sequence ends.

    ``vectorid run STORE --trials N`` (or :func:`vectorid.run.run_store`) then draws the
    next sequence indices in the new box.
    """
    return store.add_stage(proposal.new, kind="sample", note=proposal.note())


def relax_study(
    study: Any,
    limits: Mapping[str, float],
    notes: Mapping[str, str] | None = None,
    *,
    share: float = RELAX_SHARE,
    min_count: int = MIN_D,
) -> Relaxation:
    """Save in ``study`` the stated limits, or, where D under them is too small, relaxed ones.

    The relaxed limits are saved as stand-ins (source ``quantile``) whose note names the
    relaxation (:func:`relaxation_text`) and gives the stated limit; the stated ones keep
    source ``noise`` and their ``notes``. No trial changes.

    Parameters
    ----------
    study : vectorid.Study
        An open study (write access).
    limits : mapping
        Criterion name -> stated limit Φ** (the criterion's unit).
    notes : mapping, optional
        Criterion name -> note of the stated limit (where it comes from).
    share, min_count
        As in :func:`relaxed_limits`.

    Returns
    -------
    Relaxation
    """
    notes = dict(notes or {})
    a0 = study.analysis(dict(limits))
    f, lim = relaxed_limits(a0, limits, share=share, min_count=min_count)
    n_ok = int(a0.ok.sum())
    k = min(max(int(min_count), math.ceil(share * n_ok)), n_ok)
    if f > 1.0:
        src = {
            c: (
                "quantile",
                f"stand-in, {relaxation_text(f)}: stated limit {limits[c]:.4g} "
                f"({notes.get(c, 'stated')}) x {f:g}, the smallest common factor at which D "
                f"holds {k} of {n_ok} trials (under the stated limits: {a0.n_feasible})",
            )
            for c in lim
        }
        study.store.set_limits(lim, sources=src)
    else:
        study.store.set_limits(
            dict(limits), sources={c: ("noise", notes.get(c, "")) for c in limits}
        )
    return Relaxation(f, int(a0.n_feasible), k, n_ok)
