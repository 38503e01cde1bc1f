"""Identification from flight data: flight logs, loaders, wind profiles, adequacy criteria.

Flight data (:mod:`vectorid.identify.flight`), loaders (:mod:`vectorid.identify.loaders`), wind
profiles and wind uncertainty (:mod:`vectorid.identify.windprofiles`), the adequacy-criteria
library (:mod:`vectorid.identify.criteria`) and spectral tools (:mod:`vectorid.identify.spectral`).
"""

from __future__ import annotations

from vectorid.identify.criteria import (
    CRITERIA,
    INDICES,
    OPERATORS,
    CriterionDef,
    CriterionError,
    dropout,
    evaluate_criteria,
    get_criterion,
    integrate,
    make_index_criterion,
    wrap_angle,
)
from vectorid.identify.flight import STANDARD_CHANNELS, Channel, FlightData, FlightDataError
from vectorid.identify.loaders import (
    load_csv,
    load_flight,
    load_parquet,
    load_telemega,
    load_ulog,
)
from vectorid.identify.spectral import eigenfrequencies
from vectorid.identify.windprofiles import (
    WindUncertainty,
    load_dropsonde_csv,
    load_wyoming,
)

__all__ = [
    "CRITERIA",
    "INDICES",
    "OPERATORS",
    "STANDARD_CHANNELS",
    "Channel",
    "CriterionDef",
    "CriterionError",
    "FlightData",
    "FlightDataError",
    "WindUncertainty",
    "dropout",
    "eigenfrequencies",
    "evaluate_criteria",
    "get_criterion",
    "integrate",
    "load_csv",
    "load_dropsonde_csv",
    "load_flight",
    "load_parquet",
    "load_telemega",
    "load_ulog",
    "load_wyoming",
    "make_index_criterion",
    "wrap_angle",
]

# -- identification (other engineer) --
from vectorid.identify.identification import (
    Identification,
    problem_from_spec,
    trial_trajectories,
)
from vectorid.identify.twostep import (
    ControlStepResult,
    TwoStepResult,
    control_contribution,
    run_control_step,
    run_two_step,
)

__all__ += [
    "ControlStepResult",
    "Identification",
    "TwoStepResult",
    "control_contribution",
    "problem_from_spec",
    "run_control_step",
    "run_two_step",
    "trial_trajectories",
]
