"""Identification from flight data: flight logs, loaders, wind profiles, adequacy criteria,
measurement noise, and the identification that turns them into a PSI Problem.

Flight data (:mod:`vectorid.identify.flight`), loaders (:mod:`vectorid.identify.loaders`), wind
profiles and wind uncertainty (:mod:`vectorid.identify.windprofiles`), the adequacy-criteria
library (:mod:`vectorid.identify.criteria`), spectral tools (:mod:`vectorid.identify.spectral`),
noise statements, estimates and noise floors (:mod:`vectorid.identify.noise`), the
identification of a drop or of several (:mod:`vectorid.identify.identification`,
:mod:`vectorid.identify.multiflight`) and of a model of your own
(:mod:`vectorid.identify.system`): what a worker needs to build and evaluate a model.

This package imports nothing from the store, the run, the samplers, the analysis, the
workflows or the views. Running identifications (double tuning, stages, the two-step
identification of seed 001) is :mod:`vectorid.workflows`'s. In this package a *step* is a
time step only (integration ``dt``, comparison grid ``output_dt``, a sensor's sampling); an
identification's steps and stages are the workflows' words.
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
from vectorid.identify.flight import STANDARD_CHANNELS, FlightChannel, FlightData, FlightDataError
from vectorid.identify.identification import (
    Identification,
    problem_from_spec,
    trial_trajectories,
)
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
    "CriterionDef",
    "CriterionError",
    "FlightChannel",
    "FlightData",
    "FlightDataError",
    "Identification",
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
    "problem_from_spec",
    "trial_trajectories",
    "wrap_angle",
]
