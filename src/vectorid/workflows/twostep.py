"""Two-step identification (seed 001 §VI) and the control-contribution analysis.

Words: a *step* is one identification run with double tuning (:func:`run_step`); the
two-step identification chains two (and the control step between them). An identification
*stage* (:mod:`vectorid.workflows.stages`) is one sampler run of a chained identification, and
the store's *stages* are its boxes and kinds of trials (a refined box is a new sample stage).

Step 1 identifies the model on the *uncontrolled* drop; step 2 identifies it on the
*controlled* drop, starting from step 1's refined box (the step-1 variables keep that box;
"nominal" stays the model's value everywhere, step 1's chosen vector is a result) and adding
the variables that only control excites (x15, the riser force gain, in the seed). Each step
uses the "double tuning" of the seed: a coarse run in the initial box, a narrower box
proposed from the feasible set (:func:`vectorid.analysis.refine.propose_refine`), and the
main run in that box, continuing the same Sobol sequence in the same store (no trial is lost).

Criteria constraints Φ** are the expert's choice. Where a study gives none, a step sets each
criterion's limit at a quantile of its values over the successful trials (``auto_quantile``,
default 0.3), loosened until the feasible set holds ``min_feasible`` trials — a stand-in for
the expert that is written into the step's report.

The control contribution (seed 001 §VI.C, Fig. 8): simulate the model identified on the
uncontrolled drop, *without control*, in the controlled drop's wind ("No control + Wind"),
and subtract it from the measured trajectory; what is left approximates the part of the
motion due to the control.

The control step (seed 001 §VI.C, Figs. 9–11, :func:`run_control_step`): the control
contribution plus the same uncontrolled model flown in still air is the controlled drop as it
would have been in still air; x15 alone is identified on it by PSI, with criteria 1 and 3
(horizontal and vertical position errors), driving the model with no wind and the recorded
control inputs. Its refined x15 box (from the Pareto set) initialises the full-scale step 2
(``run_two_step(..., control_step=True)``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, TextIO

import numpy as np
from numpy.typing import NDArray

from vectorid._toml import toml_tables
from vectorid.analysis.choice import suggest_choice
from vectorid.analysis.identifiability import ParameterVerdict, identifiability
from vectorid.analysis.refine import RefineProposal, current_box, propose_refine
from vectorid.analysis.results import Analysis
from vectorid.builders import variable_meanings
from vectorid.errors import StudyDefinitionError
from vectorid.identify.identification import Identification
from vectorid.identify.noise import NOISE_KEYS
from vectorid.space import Continuous, Space
from vectorid.spec import StudySpec, load_study
from vectorid.study import Study
from vectorid.workflows.extra import apply_refine

__all__ = [
    "ControlContribution",
    "ControlStepResult",
    "StepResult",
    "TwoStepResult",
    "auto_limits",
    "control_contribution",
    "control_step_spec",
    "run_control_step",
    "run_step",
    "run_two_step",
    "step_result",
]


def _simulate_uncontrolled(ident, P: np.ndarray, d, wind) -> Any:
    """One full parameter vector ``P`` over drop ``d``'s window with no control input."""
    return ident.model.simulate(
        P[None, :],
        t_final=d.duration,
        dt=ident.dt,
        inputs=None,
        wind=wind,
        output_dt=ident.output_dt,
        initial=d.initial,
        atmosphere=ident.atmosphere,
    )


def _fly_uncontrolled(ident, P: np.ndarray, d, wind, what: str, fix: str) -> tuple[Any, NDArray]:
    """:func:`_simulate_uncontrolled` and its NED position relative to the data's origin, (T, 3)
    m; a failed simulation is an error naming ``what`` was flown and how to ``fix`` it."""
    res = _simulate_uncontrolled(ident, P, d, wind)
    if res.status[0] != 0:
        raise StudyDefinitionError(
            "params", f"the uncontrolled {what}simulation failed: {res.messages[0]}", fix
        )
    pos = np.array(res.position[0])
    pos[:, 2] += d.origin_altitude
    return res, pos


def auto_limits(
    a: Analysis, quantile: float = 0.3, min_feasible: int = 20, *, pseudo: bool = False
) -> dict[str, float]:
    """The quantile stand-in for the expert's criteria constraints Φ**: each criterion
    without a limit gets the ``quantile`` of its values over the successful trials.

    It is a ranking, not a statement about the data (noise-grounded limits are,
    :mod:`vectorid.identify.noise`). Criteria that already have a limit keep it; pseudo
    criteria get none unless ``pseudo`` (a pseudo criterion constrains without entering the
    Pareto set, and a quantile of it would cut the truth as often as not). The quantile is
    raised (by steps of 0.05, up to 1) until the feasible set D holds at least
    ``min_feasible`` trials (or every successful trial).

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
            if c.limit is not None or (c.role == "pseudo" and not pseudo):
                continue
            col = a.trials.F[ok, j]
            limits[c.name] = float(np.quantile(col, q if c.sense == "min" else 1.0 - q))
        b = Analysis(a.spec, a.trials, limits)
        if b.n_feasible >= min(min_feasible, int(ok.sum())) or q >= 1.0:
            return limits
        q = min(1.0, q + 0.05)


@dataclass
class StepResult:
    """One identification step: its store, analysis, refine proposal, chosen vector and the
    identifiability verdict of each variable.

    ``limits`` are the criteria constraints in force (name -> value) and ``sources`` where
    each came from (name -> (source, note): "noise", "expert" or "quantile", see
    :class:`~vectorid.problem.Criterion`). ``verdicts`` say which variables the data
    determine (:func:`vectorid.analysis.identifiability.identifiability`); ``chosen`` holds
    every variable's value in the chosen trial, but only an identified variable's value
    means anything: print them with :meth:`chosen_text`.
    """

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
    sources: dict[str, tuple[str, str]] = field(default_factory=dict)
    verdicts: list[ParameterVerdict] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def verdict(self, name: str) -> ParameterVerdict | None:
        return next((v for v in self.verdicts if v.name == name), None)

    def chosen_text(self, name: str, *, with_verdict: bool = True) -> str:
        """The chosen value of an identified variable, else its range (and verdict)."""
        v = self.verdict(name)
        value = self.chosen.get(name)
        if v is None:
            return "-" if value is None else f"{value:.4g}"
        return v.value_text(value, with_verdict=with_verdict)

    def describe(self) -> str:
        a = self.analysis
        lines = [
            f"{self.name}: N = {a.n}   ND = {a.n_feasible}   NP = {a.n_pareto}   "
            f"({self.trials} trials in {self.elapsed:.1f} s)",
            "  criteria constraints:",
        ]
        units = {c.name: c.unit for c in a.criteria}
        for k, v in self.limits.items():
            src, note = self.sources.get(k, ("expert", ""))
            u = f" {units.get(k)}" if units.get(k) else ""
            lines.append(f"    {k} <= {v:.4g}{u}  ({src}{': ' + note if note else ''})")
        if self.verdicts:
            lines.append(f"  chosen vector {self.chosen_id} and identifiability:")
            for v in self.verdicts:
                lines.append(f"    {v.label()}: {self.chosen_text(v.name)}")
                if v.suggestion:
                    lines.append(f"      to identify it: {v.suggestion}")
        lines += [f"  note: {n}" for n in self.notes]
        return "\n".join(lines)


@dataclass
class TwoStepResult:
    """Both steps of :func:`run_two_step` (and the control step between them, if run)."""

    step1: StepResult
    step2: StepResult
    step2_spec: StudySpec
    notes: list[str] = field(default_factory=list)
    control: ControlStepResult | None = None


def _run_to(study: Study, total: int, executor: str, progress) -> None:
    study.run(trials=total, executor=executor, progress=progress)


def noise_refine(
    a: Analysis,
    stages,
    reference: Mapping[str, tuple[float, float]] | None = None,
    **kwargs: Any,
) -> RefineProposal:
    """Double tuning under noise-grounded limits: narrow only what the data identify.

    A variable identified by the run so far (:func:`identifiability`) gets D's whole range
    (no quantile trimmed: every vector in D is consistent with the data) widened on each side
    by half its width and at least 5 % of the box (the run samples D sparsely, so its true
    edges lie further out); every other variable keeps its current box, so a weakly
    identified range is never cut by the sampling. ``kwargs`` go to
    :func:`~vectorid.analysis.refine.propose_refine` (explicit ``bounds`` win)."""
    current, _, _ = current_box(stages, a.spec.space)
    bounds: dict[str, tuple[float, float]] = {}
    for v, var in zip(identifiability(a, stages=stages, reference=reference), current):
        lo, hi = float(var.low), float(var.high)
        if v.identified and v.feasible is not None:
            m = max(0.5 * (v.feasible[1] - v.feasible[0]), 0.05 * (v.box[1] - v.box[0]))
            lo, hi = max(lo, v.feasible[0] - m), min(hi, v.feasible[1] + m)
        bounds[v.name] = (lo, hi)
    bounds.update(dict(kwargs.pop("bounds", None) or {}))
    kwargs.setdefault("quantile", 0.0)
    return propose_refine(a, stages, bounds=bounds, **kwargs)


def run_step(
    spec: StudySpec,
    store: str | Path,
    *,
    trials: int,
    coarse: int | None = None,
    executor: str = "serial",
    auto_quantile: float | None = 0.3,
    min_feasible: int = 20,
    refine: Mapping[str, Any] | None = None,
    progress: bool | TextIO = False,
    name: str = "step",
    auto_pseudo: bool = False,
    meanings: Mapping[str, str] | None = None,
    hints: Mapping[str, str] | None = None,
    reference: Mapping[str, tuple[float, float]] | None = None,
) -> StepResult:
    """One identification step with double tuning.

    Parameters
    ----------
    spec : StudySpec
        The step's study (an identification study, or any study). Its criteria constraints
        are used as they are: the expert's numbers, and the noise floors of
        ``limit = "noise"`` / ``[identification] limits = "noise"`` (computed when the
        store is created, :mod:`vectorid.identify.noise`).
    store : path
        SQLite store (created, or resumed when it holds the same study).
    trials : int
        Trials in the refined box (the main run).
    coarse : int, optional
        Trials of the coarse run in the initial box (default ``trials // 4``; 0 skips double
        tuning).
    executor : str
        ``"serial"`` (one process; the compiled models use every core) or ``"processes"``.
    auto_quantile, min_feasible : float or None, int
        The quantile stand-in (:func:`auto_limits`) for the pure criteria that have no limit
        (None: leave them unconstrained). ``auto_pseudo`` extends it to pseudo criteria.
    refine : mapping, optional
        Keyword arguments of :func:`~vectorid.analysis.refine.propose_refine`
        (``basis``, ``quantile``, ``margin``, ``bounds``); default: the refine rule's own
        defaults, or :func:`noise_refine` when the limits are noise floors.
    meanings, hints, reference : mapping, optional
        Passed to :func:`~vectorid.analysis.identifiability.identifiability` (default
        meanings: the model's parameter meanings; ``reference``: the boxes variables were
        first given, when this step inherits narrowed ones).

    A feasible set D that comes out empty does not stop the step: the double tuning is
    skipped (the main run stays in the initial box), ``chosen`` is empty, the verdicts say
    "not identified" and ``notes`` say which constraint empties D.
    """
    coarse = max(1, trials // 4) if coarse is None else int(coarse)
    t0 = time.perf_counter()
    proposal = None
    notes: list[str] = []
    with Study.create_or_open(spec, store) as study:
        held = study.spec  # with the noise floors computed at creation
        noisy = any(c.source == "noise" for c in held.criteria)
        rule = dict(refine or {})

        def propose(a: Analysis) -> RefineProposal:
            if noisy and refine is None:
                return noise_refine(a, study.store.stages(), reference)
            return propose_refine(a, study.store.stages(), **rule)

        def limits_of(a: Analysis) -> dict[str, float]:
            if auto_quantile is None:
                return {}
            return auto_limits(a, auto_quantile, min_feasible, pseudo=auto_pseudo)

        stages = [s for s in study.store.stages() if s.kind == "sample"]
        if coarse > 0 and len(stages) == 1:
            _run_to(study, coarse, executor, progress)
            a = study.analysis()
            a = study.analysis(limits_of(a))
            if a.n_feasible >= 5:
                proposal = propose(a)
                apply_refine(study.store, proposal)
            elif a.n_feasible:
                notes.append(
                    f"the coarse run's feasible set holds {a.n_feasible} trials, too few to "
                    "refine the box from: the main run stays in the initial box"
                )
            else:
                notes.append(
                    "the coarse run's feasible set is empty, so the box was not refined: "
                    + a.diagnose_empty().describe().replace("\n", " ")
                )
        _run_to(study, coarse + trials, executor, progress)
        a = study.analysis()
        auto = limits_of(a)
        a = study.analysis(auto)
        # The stand-in constraints are saved with the study (named as such), so table,
        # pareto, report and the UI start from them.
        if auto:
            note = f"quantile stand-in: q={auto_quantile:g} of {a.n} trials (not the expert's)"
            study.store.set_limits(auto, sources={k: ("quantile", note) for k in auto})
        spec_now = study.spec
        if a.n_feasible:
            final = propose(a).new
        else:
            final = spec_now.space
            notes.append(a.diagnose_empty().describe().replace("\n", " "))
        verdicts = identifiability(
            a,
            meanings=meanings if meanings is not None else variable_meanings(spec_now),
            hints=hints,
            stages=study.store.stages(),
            reference=reference,
        )
        return step_result(
            name, store, spec_now, a, proposal=proposal, final_box=final, verdicts=verdicts,
            notes=notes, started=t0, extra_limits=auto,
        )  # fmt: skip


def step_result(
    name: str,
    store: str | Path,
    spec: StudySpec,
    a: Analysis,
    *,
    proposal: RefineProposal | None,
    final_box: Space,
    verdicts: list[ParameterVerdict],
    notes: list[str],
    started: float,
    extra_limits: Mapping[str, float] | None = None,
) -> StepResult:
    """A run read as a :class:`StepResult`: the limits in force (``spec``'s, plus
    ``extra_limits`` given to the analysis) with their sources, the chosen vector (the Pareto
    trial nearest the ideal point, :func:`~vectorid.analysis.choice.suggest_choice`) with its
    criteria, and the time since ``started`` (:func:`time.perf_counter`)."""
    limits = {c.name: c.limit for c in spec.criteria if c.limit is not None}
    limits.update(dict(extra_limits or {}))
    sources = {c.name: (c.source, c.limit_note) for c in spec.criteria if c.limit is not None}
    cid = suggest_choice(a)
    chosen, crit = {}, {}
    if cid is not None:
        i = int(np.flatnonzero(a.trials.id == cid)[0])
        chosen = {n: float(v) for n, v in zip(a.spec.space.names, a.trials.X[i])}
        crit = {n: float(v) for n, v in zip(a.crit_names, a.trials.F[i])}
    return StepResult(
        name=name,
        store=Path(store),
        spec=spec,
        analysis=a,
        limits=limits,
        proposal=proposal,
        final_box=final_box,
        chosen_id=cid,
        chosen=chosen,
        criteria=crit,
        trials=a.n,
        elapsed=time.perf_counter() - started,
        sources=sources,
        verdicts=verdicts,
        notes=notes,
    )


def step2_spec(step2: StudySpec, step1: StepResult, control: StepResult | None = None) -> StudySpec:
    """Step 2's study with the step-1 variables in step 1's refined box.

    ``control`` (the control step): its variables (x15) take its refined box in the same
    way. Each variable keeps step 2's own ``nominal`` (the model's value, the one every view
    and the CLI call "nominal") where it lies inside the new box, else none; step 1's chosen
    vector stays in step 1's store and in :class:`StepResult` (it is not a nominal)."""
    boxes = {v.name: v for v in step1.final_box}
    if control is not None:
        boxes.update({v.name: v for v in control.final_box})
    new_vars = []
    for v in step2.space:
        if v.name in boxes and isinstance(v, Continuous):
            b = boxes[v.name]
            nominal = v.nominal
            if nominal is not None and not b.low <= nominal <= b.high:
                nominal = None
            new_vars.append(Continuous(v.name, b.low, b.high, nominal, v.unit))
        else:
            new_vars.append(v)
    # the boxes the inherited variables were first given, for the verdicts (kept in the store)
    ref = {
        v.name: [float(v.low), float(v.high)]
        for v in step1.spec.space
        if v.name in boxes and hasattr(v, "low")
    }
    if control is not None:
        ref.update({v.name: [float(v.low), float(v.high)] for v in control.spec.space})
    extra = dict(step2.extra)
    extra["x-identifiability"] = {"reference": ref}
    return replace(step2, space=Space(new_vars), extra=extra)


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
    control_step: bool = False,
    control_variables: tuple[str, ...] = ("x15",),
    control_trials: int | None = None,
    control_box: bool = True,
    hints: Mapping[str, str] | None = None,
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
    control_step : bool
        Run :func:`run_control_step` between the steps (seed 001 §VI.C): the
        ``control_variables`` are identified alone on the control contribution, and their
        refined box initialises step 2.
    control_trials : int, optional
        Trials of the control step in its refined box (default ``trials``; its coarse run
        has ``coarse`` trials like the other steps).
    control_box : bool
        Whether the control step's refined box initialises step 2 (the seed's procedure;
        default). False runs the control step for its own result only, and step 2 keeps its
        own box for the control variables.
    hints : mapping, optional
        Variable name -> what would excite it, for the identifiability suggestions.
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
    # what every step of the two shares (the control step takes its own refine rule)
    common: dict[str, Any] = dict(
        coarse=coarse, executor=executor, auto_quantile=auto_quantile,
        min_feasible=min_feasible, progress=progress, hints=hints,
    )  # fmt: skip
    r1 = run_step(
        step1, out / f"{step1.name}.db", trials=trials, refine=refine,
        name="step 1 (uncontrolled drop)", **common,
    )  # fmt: skip
    if not r1.chosen:
        why = " ".join(r1.notes[-1:])
        raise StudyDefinitionError(
            "step 1",
            f"the Pareto set of step 1 is empty, so step 2 has no starting box ({why})",
            "loosen the criteria constraints (a discrepancy allowance) or widen the box of step 1",
        )
    rc = None
    if control_step:
        rc = run_control_step(
            r1, step2, out, variables=control_variables,
            trials=trials if control_trials is None else int(control_trials), **common,
        )  # fmt: skip
        if not rc.step.chosen:
            raise StudyDefinitionError(
                "control step",
                "the Pareto set of the control step is empty, so x15 has no refined box",
                "widen the x15 box of step 2 or run without control_step",
            )
    s2 = step2_spec(step2, r1, rc.step if rc is not None and control_box else None)
    r2 = run_step(
        s2, out / f"{step2.name}.db", trials=trials, refine=refine,
        name="step 2 (controlled drop)", **common,
    )  # fmt: skip
    return TwoStepResult(r1, r2, s2, notes, rc)


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
    _, sim = _fly_uncontrolled(ident, P, d, d.wind, "", "check the parameter values")
    meas = d.measured("position")
    alt = -meas[:, 2] if "altitude" not in d.flight.channels else d.measured("altitude")[:, 0]
    if not math.isfinite(float(sim[-1, 0])):
        raise StudyDefinitionError("params", "non-finite simulation", "check the parameters")
    return ControlContribution(d.grid.copy(), alt, meas, sim, meas - sim)


def chosen_params(result: StepResult) -> dict[str, float]:
    """The chosen vector of a step, by variable name."""
    return dict(result.chosen)


# -- the control step (seed 001 §VI.C, Figs. 9-11) ------------------------------------------------


#: Refine rule of the control step: the Pareto set's envelope (Figs. 10-11), widened by 25 %
#: of its width on each side and at least 10 % of the initial box wide. With one variable and
#: two criteria that agree (a twin experiment) the Pareto set is a few trials wide; the floor
#: keeps the sensor-noise scatter of the optimum inside the box that initialises step 2.
CONTROL_REFINE: dict[str, Any] = {"basis": "pareto", "margin": 0.25, "min_width": 0.1}


@dataclass
class ControlStepResult:
    """The PSI identification of the control variables on the control contribution.

    Attributes
    ----------
    step : StepResult
        Its run (store, analysis, limits, refined box ``step.final_box``, chosen vector).
    contribution : ControlContribution
        Measured minus "No control + Wind" (seed 001 Fig. 8).
    still_air : (T, 3) float
        The data it is identified on: the controlled drop in still air, NED position
        relative to the origin, m (``contribution`` + the uncontrolled model in still air).
    study_file : Path
        Its study file (TOML), next to the data files it reads.
    variables : tuple of str
    """

    step: StepResult
    contribution: ControlContribution
    still_air: NDArray[np.float64]
    study_file: Path
    variables: tuple[str, ...]

    def box(self) -> dict[str, tuple[float, float]]:
        """Refined box of each control variable, by name."""
        return {v.name: (v.low, v.high) for v in self.step.final_box}


def control_step_spec(
    step2: StudySpec,
    params: Mapping[str, float],
    out_dir: str | Path,
    *,
    variables: tuple[str, ...] = ("x15",),
    criteria: tuple[str, ...] = ("pos_h_abs", "pos_v_abs"),
    drop: str | None = None,
    trials: int | None = None,
) -> tuple[StudySpec, ControlContribution, NDArray[np.float64], Path]:
    """The study of the control step: data files, study file and spec.

    Writes ``out_dir/<name>.toml`` and its data ``out_dir/data/<name>*.csv``, where
    ``<name>`` is ``<step 2 name>-control``.

    Parameters
    ----------
    step2 : StudySpec
        The controlled-drop study (its model, options, fixed parameters, drop, window, wind,
        control history and the box of ``variables``).
    params : mapping
        Model parameter values of the uncontrolled model (step 1's chosen vector); they are
        fixed in the control step.
    variables : tuple of str
        The control variables identified (default x15, the only one the risers act through).
    criteria : tuple of str
        Library criteria (default 1 and 3 of Table I: horizontal and vertical position).
    drop : str, optional
        The controlled drop (default: step 2's first).

    Returns
    -------
    spec, contribution, still_air, study_file
    """
    ident = Identification.from_spec(step2)
    d = ident.drops[0] if drop is None else ident.drop(drop)
    for v in variables:
        if v not in step2.space.names or v not in ident.model.parameter_names:
            raise StudyDefinitionError(
                "control_variables",
                f"{v!r} is not both a variable of step 2 and a parameter of model "
                f"{ident.model.name!r}",
                f"use variables of step 2 such as {step2.space.names}",
            )
    if "position" not in d.flight.channels:
        raise StudyDefinitionError(
            "control step",
            f"drop {d.name!r} has no position channel, so criteria 1 and 3 cannot be formed",
            "map the position (north, east, down or lat/lon/alt) of the controlled drop",
        )
    pnames = list(ident.model.parameter_names)
    fixed = {k: float(v) for k, v in params.items() if k not in variables and k in pnames}
    cc = control_contribution(ident, fixed, d.name)
    P = ident.base.copy()
    for k, v in fixed.items():
        P[pnames.index(k)] = float(v)
    calm, calm_pos = _fly_uncontrolled(
        ident, P, d, None, "still-air ", "check step 1's chosen vector"
    )
    still = cc.contribution + calm_pos
    t = cc.t
    cols = {"time_s": t, "north_m": still[:, 0], "east_m": still[:, 1], "down_m": still[:, 2]}
    mapping: dict[str, Any] = {
        "time": "time_s",
        "time_unit": "s",
        "position": {"north": "north_m", "east": "east_m", "down": "down_m", "unit": "m"},
    }
    if "velocity" in d.flight.channels:  # for the initial state only (criteria 1, 3 only)
        wind_sim = _simulate_uncontrolled(ident, P, d, d.wind)
        vel = d.measured("velocity") - wind_sim.velocity[0] + calm.velocity[0]
        cols.update({"v_north_ms": vel[:, 0], "v_east_ms": vel[:, 1], "v_down_ms": vel[:, 2]})
        mapping["velocity"] = {
            "north": "v_north_ms",
            "east": "v_east_ms",
            "down": "v_down_ms",
            "unit": "m/s",
        }
    for ch, names, unit in (
        ("euler", ("roll_rad", "pitch_rad", "yaw_rad"), "rad"),
        ("rates", ("p_rads", "q_rads", "r_rads"), "rad/s"),
    ):
        if ch in d.flight.channels:
            vals = d.measured(ch)
            cols.update({n: vals[:, j] for j, n in enumerate(names)})
            mapping[ch] = {"columns": list(names), "unit": unit}
    name = f"{step2.name}-control"
    out = Path(out_dir)
    data_dir = out / "data"
    data_dir.mkdir(parents=True, exist_ok=True)
    main_csv = data_dir / f"{name}.csv"
    table = np.column_stack(list(cols.values()))
    np.savetxt(main_csv, table, delimiter=",", header=",".join(cols), comments="", fmt="%.17g")
    files: list[dict[str, Any]] = [{"file": f"data/{main_csv.name}", "mapping": mapping}]
    if "controls" in d.flight.channels:
        c = d.flight["controls"]
        ctl_csv = data_dir / f"{name}_controls.csv"
        comps = [str(x) for x in c.components]
        hdr = ["time_s", *comps]
        np.savetxt(ctl_csv, np.column_stack([c.t, c.values]), delimiter=",",
                   header=",".join(hdr), comments="", fmt="%.17g")  # fmt: skip
        files.append(
            {
                "file": f"data/{ctl_csv.name}",
                "mapping": {
                    "time": "time_s",
                    "time_unit": "s",
                    "controls": {"columns": comps, "components": comps, "unit": c.unit},
                },
            }
        )
    src = step2.extra["identification"]
    src_drop = next(
        (t for i, t in enumerate(src["drops"]) if t.get("name", f"drop{i + 1}") == d.name),
        src["drops"][0],
    )
    drop_t: dict[str, Any] = {
        "name": "still_air",
        "files": files,
        "window": [float(t[0]), float(t[-1])],
        "origin_altitude": float(d.origin_altitude),
    }
    events = {k: float(v) for k, v in d.flight.events.items()}
    if events:
        drop_t["events"] = events
    for key in ("inputs", "interpolation"):
        if key in src_drop:
            drop_t[key] = src_drop[key]
    ident_t: dict[str, Any] = {
        k: src[k]
        for k in (
            "model",
            "model_options",
            "atmosphere",
            "dt",
            "output_dt",
            "init_span",
            "noise",
            "limits",
            "noise_quantile",
            "noise_coverage",
            "noise_draws",
            "noise_seed",
        )
        if k in src
    }
    # The measured position keeps its noise (the subtracted simulations are noiseless);
    # channel allowances carry over, criterion-named ones only for these criteria.
    if isinstance(src.get("discrepancy"), Mapping):
        disc = {k: v for k, v in src["discrepancy"].items() if k in NOISE_KEYS or k in criteria}
        if disc:
            ident_t["discrepancy"] = disc
    if "noise" in src_drop:
        drop_t["noise"] = src_drop["noise"]
    base_fixed = {k: float(v) for k, v in dict(src.get("parameters", {})).items()}
    base_fixed.update({k: float(v) for k, v in fixed.items() if k in pnames})
    if base_fixed:
        ident_t["parameters"] = base_fixed
    ident_t["drops"] = [drop_t]
    space = {v.name: v for v in step2.space}
    var_t = []
    for v in variables:
        item: dict[str, Any] = {"name": v, "low": float(space[v].low), "high": float(space[v].high)}
        var_t.append(item)
    study_t: dict[str, Any] = {
        "name": name,
        "model": step2.model if isinstance(step2.model, str) else ident.model.name,
        "trials": int(trials if trials is not None else step2.trials),
        "seed": int(step2.seed),
        "executor": "serial",
    }
    tables = [
        ("study", study_t),
        ("variables", var_t),
        ("criteria", [{"name": c, "role": "pure"} for c in criteria]),
        ("identification", {k: v for k, v in ident_t.items() if k != "drops"}),
        ("identification.drops", ident_t["drops"]),
    ]
    study_file = out / f"{name}.toml"
    fixed_txt = ", ".join(f"{k} = {v:.4g}" for k, v in fixed.items())
    header = (
        "vectorid control step (seed 001 §VI.C): identification of "
        f"{', '.join(variables)} on the control contribution of drop {d.name!r} of "
        f"{step2.name!r}.\nData: measured position - uncontrolled model in the drop's wind + "
        "the same model in still air (the controlled drop in still air).\n"
        f"Uncontrolled model (step 1's chosen vector): {fixed_txt}.\n"
        "The model is flown with no wind and the recorded control inputs."
    )
    study_file.write_text(toml_tables(tables, header), encoding="utf-8")
    return load_study(study_file), cc, still, study_file


def run_control_step(
    step1: StepResult | Mapping[str, float],
    step2: StudySpec,
    out_dir: str | Path,
    *,
    variables: tuple[str, ...] = ("x15",),
    criteria: tuple[str, ...] = ("pos_h_abs", "pos_v_abs"),
    trials: int = 2048,
    coarse: int | None = None,
    executor: str = "serial",
    auto_quantile: float = 0.3,
    min_feasible: int = 20,
    refine: Mapping[str, Any] | None = None,
    progress: bool | TextIO = False,
    drop: str | None = None,
    hints: Mapping[str, str] | None = None,
) -> ControlStepResult:
    """Seed 001 §VI.C: identify x15 alone by PSI on the control contribution.

    The most reliable vector of step 1 (its chosen vector) is flown without control in the
    controlled drop's wind ("No control + Wind") and subtracted from the flight data (the
    control contribution, Fig. 8); adding the same uncontrolled model flown in still air gives
    the controlled drop as it would have been in still air. ``variables`` (x15) are
    identified on it with ``criteria`` (1 and 3 of Table I) by the model flown with no wind
    and the recorded control inputs, everything else fixed at step 1's values, with double
    tuning; the refined box comes from the Pareto set (``refine`` default
    :data:`CONTROL_REFINE`, Figs. 10–11) and initialises step 2.

    Parameters
    ----------
    step1 : StepResult or mapping
        Step 1's result (its chosen vector is used) or parameter values by name.
    step2 : StudySpec
        The controlled-drop study (see :func:`control_step_spec`).
    out_dir : path
        Folder of the study file, its data (``data/``) and its store (``<name>.db``).
    trials, coarse, executor, auto_quantile, min_feasible, progress
        As in :func:`run_step`.

    Returns
    -------
    ControlStepResult
    """
    params = dict(step1.chosen) if isinstance(step1, StepResult) else dict(step1)
    if not params:
        raise StudyDefinitionError(
            "step 1",
            "step 1 has no chosen vector, so the uncontrolled model is unknown",
            "loosen step 1's criteria constraints so that its Pareto set is not empty",
        )
    spec, cc, still, study_file = control_step_spec(
        step2, params, out_dir, variables=variables, criteria=criteria, drop=drop, trials=trials
    )
    r = run_step(
        spec,
        Path(out_dir) / f"{spec.name}.db",
        trials=trials,
        coarse=coarse,
        executor=executor,
        auto_quantile=auto_quantile,
        min_feasible=min_feasible,
        refine={**CONTROL_REFINE, **dict(refine or {})},
        progress=progress,
        hints=hints,
        name="control step (x15 on the control contribution)"
        if tuple(variables) == ("x15",)
        else f"control step ({', '.join(variables)} on the control contribution)",
    )
    return ControlStepResult(r, cc, still, study_file, tuple(variables))
