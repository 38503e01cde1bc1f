"""Workflows: what a study does beyond its run, composed from the run, the store and the
analysis below it (nothing below imports this package).

- :mod:`~vectorid.workflows.extra`: extra runs beside a study's sample — sections,
  robustness checks, a refined box (double tuning), saved limits relaxed as a last resort;
- :mod:`~vectorid.workflows.twostep`: one identification *step* with double tuning
  (:func:`run_step`), the two-step identification of seed 001 (:func:`run_two_step`), its
  control step and the control contribution;
- :mod:`~vectorid.workflows.stages`: one identification *stage* (:func:`run_stage`: one
  sampler run of a chained identification, read under its stated limits) and how a chosen
  vector is printed (:func:`print_verdicts`);
- :mod:`~vectorid.workflows.reduction`: seed 000's fix/tie reduction from correlation and
  sensitivity over D (:func:`propose_reduction`);
- :mod:`~vectorid.workflows.truth`: a twin's known truth against the limits and the ranges
  (:func:`check_truth`, :func:`truth_in_ranges`).

Words: a *step* is a run of the two-step identification, an identification *stage* a sampler
run of a chained identification, and a store's *stage* a box and kind of trials inside one
store (:class:`vectorid.store.Stage`).
"""

from __future__ import annotations

from vectorid.workflows.extra import (
    apply_refine,
    evaluate_and_store,
    relax_study,
    run_robustness,
    run_section,
)
from vectorid.workflows.reduction import Reduction, Tie, propose_reduction
from vectorid.workflows.stages import (
    IdentificationStage,
    print_stage_limits,
    print_verdicts,
    run_stage,
)
from vectorid.workflows.truth import TruthCheck, check_truth, truth_in_ranges
from vectorid.workflows.twostep import (
    ControlContribution,
    ControlStepResult,
    StepResult,
    TwoStepResult,
    auto_limits,
    control_contribution,
    control_step_spec,
    noise_refine,
    run_control_step,
    run_step,
    run_two_step,
)

__all__ = [
    "ControlContribution",
    "ControlStepResult",
    "IdentificationStage",
    "Reduction",
    "StepResult",
    "Tie",
    "TruthCheck",
    "TwoStepResult",
    "apply_refine",
    "auto_limits",
    "check_truth",
    "control_contribution",
    "control_step_spec",
    "evaluate_and_store",
    "noise_refine",
    "print_stage_limits",
    "print_verdicts",
    "propose_reduction",
    "relax_study",
    "run_control_step",
    "run_robustness",
    "run_section",
    "run_stage",
    "run_step",
    "run_two_step",
    "truth_in_ranges",
]
