"""Two-step identification (seed 001 §VI) and the control-contribution analysis.

Step 1 identifies the model on the *uncontrolled* drop; step 2 identifies it on the
*controlled* drop, starting from step 1's refined box (the step-1 variables keep that box and
take step 1's chosen vector as nominal) and adding the variables that only control excites
(x15, the riser force gain, in the seed). Each step uses the "double tuning" of the seed: a
coarse run in the initial box, a narrower box proposed from the feasible set
(:func:`vectorid.analysis.refine.propose_refine`), and the main run in that box, continuing
the same Sobol sequence in the same store (no trial is lost).

Criteria constraints Φ** are the expert's choice. Where a study gives none, a step sets each
criterion's limit at a quantile of its values over the successful trials (``auto_quantile``,
default 0.3), loosened until the feasible set holds ``min_feasible`` trials — a stand-in for
the expert that is written into the step's report.

The control contribution (seed 001 §VI.C, Fig. 8): simulate the model identified on the
uncontrolled drop, *without control*, in the controlled drop's wind ("No control + Wind"),
and subtract it from the measured trajectory; what is left approximates the part of the
motion due to the control.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, TextIO

import numpy as np
from numpy.typing import NDArray

from vectorid.analysis.choice import suggest_choice
from vectorid.analysis.refine import RefineProposal, apply_refine, propose_refine
from vectorid.analysis.results import Analysis
from vectorid.errors import StudyDefinitionError
from vectorid.space import Continuous, Space
from vectorid.spec import StudySpec
from vectorid.study import Study

__all__ = [
    "ControlContribution",
    "StepResult",
    "TwoStepResult",
    "auto_limits",
    "control_contribution",
    "run_step",
    "run_two_step",
]


def auto_limits(a: Analysis, quantile: float = 0.3, min_feasible: int = 20) -> dict[str, float]:
    """Criteria constraints Φ** at a quantile of each criterion over the successful trials.

    Criteria that already have a limit keep it. The quantile is raised (by steps of 0.05, up
    to 1) until the feasible set D holds at least ``min_feasible`` trials (or every
    successful trial).

    Returns
    -------
    dict
        Criterion name -> limit (the worse side: upper for ``min``, lower for ``max``).
    """
    ok = a.ok
    if not ok.any():
        raise StudyDefinitionError(
            "limits",
            "no trial completed successfully, so no criteria constraint can be set",
            "see `vectorid info STORE` for the failures",
        )
    q = float(quantile)
    while True:
        limits: dict[str, float] = {}
        for j, c in enumerate(a.criteria):
            if c.limit is not None:
                continue
            col = a.trials.F[ok, j]
            limits[c.name] = float(np.quantile(col, q if c.sense == "min" else 1.0 - q))
        b = Analysis(a.spec, a.trials, limits)
        if b.n_feasible >= min(min_feasible, int(ok.sum())) or q >= 1.0:
            return limits
        q = min(1.0, q + 0.05)


@dataclass
class StepResult:
    """One identification step: its store, analysis, refine proposal and chosen vector."""

    name: str
    store: Path
    spec: StudySpec
    analysis: Analysis
    limits: dict[str, float]
    proposal: RefineProposal | None
    final_box: Space
    chosen_id: int | None
    chosen: dict[str, float]
    criteria: dict[str, float]
    trials: int
    elapsed: float

    def describe(self) -> str:
        a = self.analysis
        lines = [
            f"{self.name}: N = {a.n}   ND = {a.n_feasible}   NP = {a.n_pareto}   "
            f"({self.trials} trials in {self.elapsed:.1f} s)",
            "  criteria constraints: "
            + ", ".join(f"{k} <= {v:.4g}" for k, v in self.limits.items()),
        ]
        return "\n".join(lines)


@dataclass
class TwoStepResult:
    """Both steps of :func:`run_two_step`."""

    step1: StepResult
    step2: StepResult
    step2_spec: StudySpec
    notes: list[str] = field(default_factory=list)


def _run_to(study: Study, total: int, executor: str, progress) -> None:
    study.run(trials=total, executor=executor, progress=progress)


def run_step(
    spec: StudySpec,
    store: str | Path,
    *,
    trials: int,
    coarse: int | None = None,
    executor: str = "serial",
    auto_quantile: float = 0.3,
    min_feasible: int = 20,
    refine: Mapping[str, Any] | None = None,
    progress: bool | TextIO = False,
    name: str = "step",
) -> StepResult:
    """One identification step with double tuning.

    Parameters
    ----------
    spec : StudySpec
        The step's study (an identification study, or any study).
    store : path
        SQLite store (created, or resumed when it holds the same study).
    trials : int
        Trials in the refined box (the main run).
    coarse : int, optional
        Trials of the coarse run in the initial box (default ``trials // 4``; 0 skips double
        tuning).
    executor : str
        ``"serial"`` (one process; the compiled models use every core) or ``"processes"``.
    auto_quantile, min_feasible : float, int
        Criteria constraints where the study sets none (see :func:`auto_limits`).
    refine : mapping, optional
        Keyword arguments of :func:`~vectorid.analysis.refine.propose_refine`
        (``basis``, ``quantile``, ``margin``, ``bounds``).
    """
    import time

    coarse = max(1, trials // 4) if coarse is None else int(coarse)
    t0 = time.perf_counter()
    proposal = None
    with Study.create_or_open(spec, store) as study:
        stages = [s for s in study.store.stages() if s.kind == "sample"]
        if coarse > 0 and len(stages) == 1:
            _run_to(study, coarse, executor, progress)
            a = study.analysis()
            limits = auto_limits(a, auto_quantile, min_feasible)
            a = study.analysis(limits)
            proposal = propose_refine(a, study.store.stages(), **dict(refine or {}))
            apply_refine(study.store, proposal)
        _run_to(study, coarse + trials, executor, progress)
        a = study.analysis()
        limits = auto_limits(a, auto_quantile, min_feasible)
        a = study.analysis(limits)
        final = propose_refine(a, study.store.stages(), **dict(refine or {})).new
        cid = suggest_choice(a)
        chosen, crit = {}, {}
        if cid is not None:
            i = int(np.flatnonzero(a.trials.id == cid)[0])
            chosen = {n: float(v) for n, v in zip(a.spec.space.names, a.trials.X[i])}
            crit = {n: float(v) for n, v in zip(a.crit_names, a.trials.F[i])}
        out = StepResult(
            name=name,
            store=Path(store),
            spec=study.spec,
            analysis=a,
            limits=limits,
            proposal=proposal,
            final_box=final,
            chosen_id=cid,
            chosen=chosen,
            criteria=crit,
            trials=a.n,
            elapsed=time.perf_counter() - t0,
        )
    return out


def step2_spec(step2: StudySpec, step1: StepResult) -> StudySpec:
    """Step 2's study with the step-1 variables in step 1's refined box, nominal = chosen."""
    box = {v.name: v for v in step1.final_box}
    new_vars = []
    for v in step2.space:
        if v.name in box and isinstance(v, Continuous):
            b = box[v.name]
            nominal = step1.chosen.get(v.name, v.nominal)
            new_vars.append(Continuous(v.name, b.low, b.high, nominal, v.unit))
        else:
            new_vars.append(v)
    return replace(step2, space=Space(new_vars))


def run_two_step(
    step1: StudySpec,
    step2: StudySpec,
    out_dir: str | Path,
    *,
    trials: int = 2048,
    coarse: int | None = None,
    executor: str = "serial",
    auto_quantile: float = 0.3,
    min_feasible: int = 20,
    refine: Mapping[str, Any] | None = None,
    progress: bool | TextIO = False,
) -> TwoStepResult:
    """Seed 001 §VI: identify on the uncontrolled drop, then on the controlled drop.

    Parameters
    ----------
    step1, step2 : StudySpec
        The uncontrolled-drop and controlled-drop studies. Step 2's variables should include
        step 1's (they take step 1's refined box) plus the control variables (e.g. x15).
    out_dir : path
        Folder of the two stores (``<step name>.db``).
    trials, coarse, executor, auto_quantile, min_feasible, refine
        As in :func:`run_step`, for each step.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    missing = [n for n in step1.space.names if n not in step2.space.names]
    notes = []
    if missing:
        notes.append(
            f"step 2 does not vary {missing}: they keep step 1's chosen values only if step 2 "
            "fixes them under [identification.parameters]"
        )
    r1 = run_step(
        step1,
        out / f"{step1.name}.db",
        trials=trials,
        coarse=coarse,
        executor=executor,
        auto_quantile=auto_quantile,
        min_feasible=min_feasible,
        refine=refine,
        progress=progress,
        name="step 1 (uncontrolled drop)",
    )
    if not r1.chosen:
        raise StudyDefinitionError(
            "step 1",
            "the Pareto set of step 1 is empty, so step 2 has no starting box",
            "loosen the criteria constraints or widen the box of step 1",
        )
    s2 = step2_spec(step2, r1)
    r2 = run_step(
        s2,
        out / f"{step2.name}.db",
        trials=trials,
        coarse=coarse,
        executor=executor,
        auto_quantile=auto_quantile,
        min_feasible=min_feasible,
        refine=refine,
        progress=progress,
        name="step 2 (controlled drop)",
    )
    return TwoStepResult(r1, r2, s2, notes)


@dataclass
class ControlContribution:
    """Seed 001 Fig. 8: measured trajectory, "No control + Wind", and their difference.

    Attributes
    ----------
    t : (T,) s, absolute times of the drop's output grid
    altitude : (T,) m above the origin (measured)
    measured, no_control, contribution : (T, 3) NED position relative to the origin, m
    """

    t: NDArray[np.float64]
    altitude: NDArray[np.float64]
    measured: NDArray[np.float64]
    no_control: NDArray[np.float64]
    contribution: NDArray[np.float64]

    @property
    def horizontal(self) -> NDArray[np.float64]:
        """Horizontal magnitude of the contribution (T,), m."""
        return np.hypot(self.contribution[:, 0], self.contribution[:, 1])


def control_contribution(
    ident, params: Mapping[str, float], drop: str | None = None
) -> ControlContribution:
    """Simulate the uncontrolled model in a controlled drop's wind and subtract it from the data.

    Parameters
    ----------
    ident : Identification
        The controlled drop's identification (its drop, wind and model).
    params : mapping
        Model parameter values by name (e.g. step 1's chosen vector); others stay at the
        identification's base values.
    drop : str, optional
        Drop name (default: the first).
    """
    d = ident.drops[0] if drop is None else ident.drop(drop)
    pnames = list(ident.model.parameter_names)
    P = ident.base.copy()
    for k, v in params.items():
        if k not in pnames:
            raise StudyDefinitionError(
                "params", f"unknown model parameter {k!r}", f"expected one of {pnames}"
            )
        P[pnames.index(k)] = float(v)
    res = ident.model.simulate(
        P[None, :],
        t_final=d.duration,
        dt=ident.dt,
        inputs=None,
        wind=d.wind,
        output_dt=ident.output_dt,
        initial=d.initial,
        atmosphere=ident.atmosphere,
    )
    if res.status[0] != 0:
        raise StudyDefinitionError(
            "params",
            f"the uncontrolled simulation failed: {res.messages[0]}",
            "check the parameter values",
        )
    sim = np.array(res.position[0])
    sim[:, 2] += d.origin_altitude
    meas = d.measured("position")
    alt = -meas[:, 2] if "altitude" not in d.flight.channels else d.measured("altitude")[:, 0]
    if not math.isfinite(float(sim[-1, 0])):
        raise StudyDefinitionError("params", "non-finite simulation", "check the parameters")
    return ControlContribution(d.grid.copy(), alt, meas, sim, meas - sim)


def chosen_params(result: StepResult) -> dict[str, float]:
    """The chosen vector of a step, by variable name."""
    return dict(result.chosen)
