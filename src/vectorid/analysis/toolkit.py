"""The analysis toolkit of issue 5 in one namespace: histograms, colour classes, sections,
double tuning, correlation and spread, robustness, sensitivity, signal tools and choice.

Every function returns plain data (numpy arrays, dataclasses); :mod:`vectorid.views`
draws them. Nothing here writes the store: the extra runs (sections, robustness checks,
refined stages) are :mod:`vectorid.workflows.extra`'s.
"""

from .choice import best_per_criterion, suggest_choice
from .classes import CLASS_COLOURS, PointClasses, point_classes, subsample
from .correlation import CorrelationResult, Spread, correlation, correlation_of, parameter_spread
from .histograms import Histogram, default_bins, histogram, histograms, stage_histograms
from .identifiability import ParameterVerdict, identifiability, verdicts_json
from .refine import RefineProposal, propose_refine, refine_history
from .robustness import (
    ChosenTable,
    Robustness,
    build_robustness,
    chosen_table,
    load_robustness,
    neighbourhood,
    robustness_stats,
)
from .sections import Section, check_range, load_sections, section_points
from .sensitivity import Sensitivity, ks_filtering, rank_correlation, sensitivity
from .signals import dominant_frequency, envelope, power_spectrum, uniform

__all__ = [
    "CLASS_COLOURS",
    "ChosenTable",
    "CorrelationResult",
    "Histogram",
    "ParameterVerdict",
    "PointClasses",
    "RefineProposal",
    "Robustness",
    "Section",
    "Sensitivity",
    "Spread",
    "best_per_criterion",
    "build_robustness",
    "check_range",
    "chosen_table",
    "correlation",
    "correlation_of",
    "default_bins",
    "dominant_frequency",
    "envelope",
    "histogram",
    "histograms",
    "identifiability",
    "ks_filtering",
    "load_robustness",
    "load_sections",
    "neighbourhood",
    "parameter_spread",
    "point_classes",
    "power_spectrum",
    "propose_refine",
    "rank_correlation",
    "refine_history",
    "robustness_stats",
    "section_points",
    "sensitivity",
    "stage_histograms",
    "subsample",
    "suggest_choice",
    "uniform",
    "verdicts_json",
]
