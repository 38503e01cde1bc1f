"""An identification stage: run a study until D at the stated limits can be read.

Words: an identification *stage* is one sampler run of a chained identification (the
parafoil demo's stage 1, 2, 3; each in a fresh store), read as a
:class:`~vectorid.workflows.twostep.StepResult` plus the limits it was judged under
(:class:`IdentificationStage`). It is not the store's *stage* (a box and kind of trials inside
one store, :class:`vectorid.store.Stage`), nor a *step* of the two-step identification
(:mod:`vectorid.workflows.twostep`).

:func:`run_stage` runs one study with double tuning (a coarse run, the box narrowed where it
identifies a variable, the main run), keeps the criteria constraints stated from the noise
(and a discrepancy allowance) and reads the identifiability verdicts. Where D at the stated
limits holds too few trials to read ranges from, the limits are relaxed as a named last resort
(:mod:`vectorid.analysis.relaxation`), printed as such by :func:`print_stage_limits`.
:func:`print_verdicts` prints a chosen vector the way every chosen vector is printed: a value
only for an identified variable, otherwise its range.

The parafoil demo and the examples on real parafoils run their studies through it.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..analysis.identifiability import identifiability
from ..analysis.relaxation import Relaxation, relaxation_text
from ..errors import plural
from ..sampler_kinds import sampler_kind
from ..study import Study
from .extra import apply_refine, relax_study
from .truth import truth_in_ranges
from .twostep import noise_refine, step_result

__all__ = ["IdentificationStage", "print_stage_limits", "print_verdicts", "run_stage"]


def print_verdicts(
    verdicts: Sequence[Any],
    chosen: Mapping[str, float],
    *,
    truth: Mapping[str, float] | None = None,
    units: Mapping[str, str] | None = None,
    indent: str = "  ",
) -> dict[str, bool | None]:
    """Print a chosen vector the way every chosen vector is printed: per variable its meaning,
    unit and identifiability verdict (:func:`vectorid.analysis.identifiability`), the chosen
    value only where the verdict is "identified" (else the feasible range), the constraints
    that cut its range and, with ``truth``, whether the truth lies in the feasible range.

    Returns name -> truth inside the feasible range (None without truth or for an empty D).
    """
    units = dict(units or {})
    w = max(9, *(len(v.name) for v in verdicts))
    wm = max(7, *(len(v.meaning) for v in verdicts))
    head = f"{'parameter':<{w}} {'meaning':<{wm}} {'unit':<7} {'verdict':<14} "
    head += f"{'value or range':<30}"
    if truth is not None:
        head += f" {'truth':>8} {'in range':<8}"
    print(indent + head + " cut by")
    inside = {v.name: None for v in verdicts} if truth is None else truth_in_ranges(verdicts, truth)
    for v in verdicts:
        u = units.get(v.name, v.unit or "-")
        value = chosen.get(v.name)
        span = "-" if v.feasible is None else f"[{v.feasible[0]:.4g}, {v.feasible[1]:.4g}]"
        text = f"{value:.4g} in {span}" if v.identified and value is not None else span
        line = f"{v.name:<{w}} {v.meaning:<{wm}} {u:<7} {v.verdict:<14} {text:<30}"
        if truth is not None:
            ok = inside[v.name]
            mark = "-" if ok is None else ("yes" if ok else "NO")
            line += f" {truth.get(v.name, np.nan):8.4g} {mark:<8}"
        print(indent + line + " " + (", ".join(v.constrained_by) or "-"))
    return inside


def _allowance_of(note: str) -> str:
    """The discrepancy part of a noise-floor note, in words ("" when none)."""
    note = note.removesuffix("; computed for stage 1")
    if "; discrepancy " in note:
        return "discrepancy " + note.split("; discrepancy ", 1)[1].split(";")[0]
    if note.endswith(" discrepancy") and " + " in note:
        return "discrepancy " + note.rsplit(" + ", 1)[1].removesuffix(" discrepancy")
    return ""


def print_stage_limits(st: IdentificationStage, indent: str = "  ") -> None:
    """Print a stage's noise-grounded criteria constraints with their units and allowances,
    how many trials meet them, and the relaxation the sampling needed (if any)."""
    r = st.result
    units = {c.name: c.unit for c in r.spec.criteria}
    print(f"{indent}criteria constraints: noise floor (joint 95 %) + allowance")
    heads = []
    for name, lim in st.noise_limits.items():
        note = st.noise_notes.get(name, "")
        print(
            f"{indent}  {name:<10} <= {lim:<10.4g} {units.get(name, ''):<6} {_allowance_of(note)}"
        )
        head = note.split(";")[0].split(" + ")[0]
        if head and head not in heads:
            heads.append(head)
    for h in heads:
        print(f"{indent}  ({h})")
    n_ok = int(r.analysis.ok.sum())
    seq = st.sequential
    if seq is not None:
        print(f"{indent}sequential sampler: {seq.verdict()}")
        if not seq.converged:
            weighted = "not weighted: D was not reached"
        elif seq.moves:
            weighted = "particles' chains; members of D weigh their holding times"
        else:
            weighted = "importance-weighted"
        print(
            f"{indent}effective sample size {seq.ess:.0f} of {plural(seq.members, 'member')} "
            f"({weighted})"
        )
    faithful = seq is None or seq.converged
    enough = "" if st.factor > 1 else " (enough to read ranges from)"
    if st.factor <= 1 and not faithful:
        enough = (
            " (not a faithful sample of D: its ranges below are\n"
            f"{indent}inner bounds, and a gain called identified may be wider in D)"
        )
    print(f"{indent}D under them: {st.n_noise_feasible} of {n_ok} successful trials{enough}")
    if st.factor > 1:
        print(
            f"{indent}{relaxation_text(st.factor)}\n{indent}(too few members to read ranges "
            f"from: x{st.factor:g} is the smallest common factor at which D holds "
            f"{r.analysis.n_feasible} trials;\n{indent}saved as a stand-in: every vector the "
            "data admit is kept, so the ranges below are outer bounds of theirs)"
        )


@dataclass
class IdentificationStage:
    """One identification stage: its run, read as a step result, and the limits it was
    judged under.

    Attributes
    ----------
    result : vectorid.workflows.twostep.StepResult
        Store, analysis under the limits in force, verdicts, chosen vector.
    noise_limits : dict
        Criterion name -> stated limit Φ** (the criterion's unit).
    noise_notes : dict
        Criterion name -> where the stated limit comes from.
    factor : float
        Relaxation factor of the limits in force (1.0: the stated limits hold).
    n_noise_feasible : int
        Members of D at the stated limits.
    proposals : list
        The double-tuning proposals applied (narrowed boxes).
    sequential : vectorid.samplers.sequential.SequentialSummary or None
        The sequential sampler's summary (evaluations, generations, ESS, converged).
    """

    result: Any
    noise_limits: dict[str, float]
    noise_notes: dict[str, str]
    factor: float
    n_noise_feasible: int
    proposals: list = field(default_factory=list)
    sequential: Any = None

    @property
    def relaxed(self) -> bool:
        """Whether the limits in force are relaxed (the last resort)."""
        return self.factor > 1.0


def _unconverged(verdicts: list, summary: Any) -> None:
    """A sequential run that did not converge has no faithful sample of D: a range read from
    it may be too narrow (or miss part of D), so no variable is called identified or weak —
    each is "not identified", saying why; the range printed is the sampled set's."""
    why = (
        f"the sequential sampler did not converge (D: {plural(summary.members, 'member')}, ESS "
        f"{summary.ess:.0f} of {summary.population} wanted): the range is that of the trials "
        "sampled, not of D, and may be too narrow"
    )
    for v in verdicts:
        if v.verdict != "not identified":
            v.verdict = "not identified"
            v.reason = f"{why}; {v.reason}" if v.reason else why
            v.suggestion = "raise the budget and run again"


def run_stage(
    spec: Any,
    store: Path,
    *,
    coarse: int = 0,
    trials: int,
    reference: Mapping[str, tuple[float, float]] | None = None,
    progress: bool = False,
    name: str = "stage",
    meanings: Mapping[str, str] | None = None,
    hints: Mapping[str, str] | None = None,
    sampler: str | None = None,
    budget: int | None = None,
    population: int | None = None,
    executor: str | None = None,
) -> IdentificationStage:
    """Run one stage of an identification into a fresh store.

    With the sequential sampler (``sampler="sequential"``, or the study's own), generation 0
    is ``trials`` Sobol points and later generations move into D at the stated limits until
    it holds ``population`` members with an effective sample size as large, or ``budget``
    evaluations are spent (:func:`vectorid.run.run_store`). With a plain
    sampler, ``coarse`` trials in the study box, the box narrowed where the coarse run
    identifies a variable (double tuning, :func:`vectorid.workflows.twostep.noise_refine`),
    then ``trials`` more.

    The stated limits (e.g. noise floors plus allowance) stay in force wherever D under them
    can be read. Only where it cannot (a plain table too sparse, or a sequential run that did
    not converge within its budget) are they relaxed by the smallest common factor that fills
    D (:func:`vectorid.workflows.extra.relax_study`), saved and printed as the named last
    resort. Verdicts: :func:`vectorid.analysis.identifiability`; where the sequential sampler did
    not converge, no variable is called identified (its sample of D is not faithful).

    Parameters
    ----------
    spec : StudySpec
        The study (its criteria carry the stated limits).
    store : Path
        The stage's store (deleted first: a stage starts afresh).
    coarse : int
        Plain sampler: trials of the coarse run (0: no double tuning).
    trials : int
        Plain sampler: trials after the coarse run; sequential: generation 0's size.
    reference : mapping, optional
        Variable name -> the box it was first given, where this stage inherits a narrowed one.
    progress : bool
        Progress bars (one line per generation for the sequential sampler).
    name : str
        The stage's name in its result.
    meanings, hints : mapping, optional
        Variable name -> what it is / what would identify it (printed with the verdicts).
    sampler : {"sobol", "lhs", "sequential"}, optional
        Default: the study's.
    budget : int, optional
        Sequential: most model evaluations (default: the study's).
    population : int, optional
        Sequential: members of D wanted (default: the study's, else 200).
    executor : str, optional
        Where the trials run (default: the study's, else ``"serial"``: one model process,
        whose compiled kernel uses every core).

    Returns
    -------
    IdentificationStage
    """
    sampler = sampler or spec.sampler
    # a sampler that aims at D's population itself (the sequential one) runs as it is; the
    # plain table gets the coarse table, the double tuning and the fine table
    aims_at_d = "population" in sampler_kind(sampler).options
    if aims_at_d:
        spec = dataclasses.replace(
            spec, sampler=sampler, trials=int(trials),
            budget=budget if budget is not None else spec.budget,
            population=population if population is not None else spec.population,
        )  # fmt: skip
    t0 = time.perf_counter()
    proposals = []
    notes: list[str] = []
    Path(store).unlink(missing_ok=True)  # a stage starts afresh (its limits are recomputed)
    with Study.create(spec, store) as study:
        held = study.spec  # with the noise floors computed at creation (or given)
        noise = {c.name: float(c.limit) for c in held.criteria if c.limit is not None}
        notes0 = {c.name: c.limit_note for c in held.criteria if c.limit is not None}
        # the study's own executor ("inline" for the examples' stateful models), else serial
        executor = executor or study.spec.executor or "serial"
        summary = None
        if aims_at_d:
            summary = study.run(executor=executor, progress=progress)
            if summary.converged:  # D at the stated limits holds the population: no relaxation
                study.store.set_limits(
                    noise, sources={c: ("noise", notes0.get(c, "")) for c in noise}
                )
                a0 = study.analysis()
                rel = Relaxation(1.0, int(a0.n_feasible), int(summary.population),
                                 int(a0.ok.sum()))  # fmt: skip
            else:  # the last resort, named as such: outer bounds of the stated D
                rel = relax_study(study, noise, notes0, min_count=int(summary.population))
        elif coarse > 0 and len([s for s in study.store.stages() if s.kind == "sample"]) == 1:
            study.run(trials=coarse, executor=executor, progress=progress)
            relax_study(study, noise, notes0)
            a = study.analysis()
            if a.n_feasible >= 5:
                proposal = noise_refine(a, study.store.stages(), reference)
                apply_refine(study.store, proposal)
                proposals.append(proposal)
        if not aims_at_d:
            study.run(trials=coarse + trials, executor=executor, progress=progress)
            rel = relax_study(study, noise, notes0)
        a = study.analysis()
        spec_now = study.spec
        stages = study.store.stages()
        final = noise_refine(a, stages, reference).new if a.n_feasible else spec_now.space
        if not a.n_feasible:
            notes.append(a.diagnose_empty().describe().replace("\n", " "))
        verdicts = identifiability(a, meanings=meanings, hints=hints, stages=stages,
                                   reference=reference)  # fmt: skip
        if summary is not None and not summary.converged:
            _unconverged(verdicts, summary)
    result = step_result(
        name, store, spec_now, a, proposal=proposals[0] if proposals else None,
        final_box=final, verdicts=verdicts, notes=notes, started=t0,
    )  # fmt: skip
    return IdentificationStage(
        result, noise, notes0, rel.factor, rel.n_at_limits, proposals, summary
    )
