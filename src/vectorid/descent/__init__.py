"""Rocket recovery descents: drag areas of the parachutes from an altimeter log.

``vectorid descent LOG --mass KG ...`` on the command line, :func:`identify_descent` in Python.
One concept a module:

- :mod:`~vectorid.descent.model`: the point-mass model under a drogue and a main
  (``"rocket-descent"``, ``"rocket-descent-cds"``);
- :mod:`~vectorid.descent.events`: apogee, touchdown, trigger crossings, drag-area changes,
  read from the altitude;
- :mod:`~vectorid.descent.bounds`: what any constant-drag descent can do with the data;
- :mod:`~vectorid.descent.formats`: the log's format, columns and units, read from its content;
- :mod:`~vectorid.descent.checks`: plausibility against the stated rocket (unit mistakes);
- :mod:`~vectorid.descent.varying`: is the drag area constant along a phase (sub-windows);
- :mod:`~vectorid.descent.plan`: what the user states (canopies, mass, allowances);
- :mod:`~vectorid.descent.phases`: the log cut into phases;
- :mod:`~vectorid.descent.step`: one phase as one PSI identification step;
- :mod:`~vectorid.descent.sensors`: a second altimeter (GPS heights) in the log;
- :mod:`~vectorid.descent.verdicts`: each phase's verdict in words;
- :mod:`~vectorid.descent.result`: the results and their text;
- :mod:`~vectorid.descent.study`: :func:`identify_descent`, which orders the above.
"""

from __future__ import annotations

from vectorid.descent.bounds import FastVariation, RateBound, fast_variation, monotone_rate_bound
from vectorid.descent.events import (
    RateChange,
    Touchdown,
    crossing_time,
    detect_apogee,
    detect_rate_change,
    detect_touchdown,
)
from vectorid.descent.model import (
    DRAG_CONVENTIONS,
    INCH,
    INITIAL_SPEEDS,
    RocketDescent,
    RocketDescentCdS,
)
from vectorid.descent.plan import Canopy, DescentPlan, PhaseLimits, discrepancy, parse_length
from vectorid.descent.result import DescentResult, PhaseResult
from vectorid.descent.study import identify_descent

__all__ = [
    "DRAG_CONVENTIONS",
    "INCH",
    "INITIAL_SPEEDS",
    "Canopy",
    "DescentPlan",
    "DescentResult",
    "FastVariation",
    "PhaseLimits",
    "PhaseResult",
    "RateBound",
    "RateChange",
    "RocketDescent",
    "RocketDescentCdS",
    "Touchdown",
    "crossing_time",
    "detect_apogee",
    "detect_rate_change",
    "detect_touchdown",
    "discrepancy",
    "fast_variation",
    "identify_descent",
    "monotone_rate_bound",
    "parse_length",
]
