"""Identify the drag areas of a rocket's recovery descent from an altimeter log.

A descent under one or two parachutes (a drogue from apogee, a main later; or one canopy) is
cut into phases from the data: the apogee and the touchdown are read from the altitude (not
from a logger's "landed" state), the main's opening from an event of the log, a stated
trigger height or time, or the change of descent rate in the data. Each phase is one
identification step of the PSI method (:func:`vectorid.identify.twostep.run_step`) on the
point-mass model ``"rocket-descent-cds"`` (:class:`~vectorid.identify.descent.RocketDescentCdS`,
started at each trial's own steady descent rate): one design variable, the drag area C_D S of
the canopy that phase is flown under (m²), sampled by LP_tau in a box of a factor 1.5 either
way of what the phase's mean descent rate implies, with double tuning; two pure criteria, the
altitude residual ``alt_sq`` (∫(h - ĥ)² dt) and the vertical-speed residual ``vz_abs``
(∫|h' - ĥ'| dt). Their constraints Φ** are the study's noise floors
(:mod:`vectorid.identify.noise`, ``limits = "noise"``): the altitude noise estimated from the
phase's data by the documented estimator (or stated), plus a model-discrepancy allowance
(:func:`discrepancy`, stated by the plan and justified in docs/identify.md). Under a main whose
drag adds to the drogue's (``convention = "adds"``) the main's step takes the drogue's drag
area in the drogue step's feasible range as a second variable (a chained step).

Every phase ends with the identifiability verdict of its drag area
(:func:`vectorid.analysis.identifiability.identifiability`: identified, weak, not identified;
a value only when identified) with its feasible and Pareto ranges, and the descent's own
explanation beside it: compared with the stated drag area, within ±15 % or why not (the main
did not open; the drag area is the other canopy's; the descent rate does not fit the stated
value; the trigger height is never reached), which constraint empties D, and, where the
residual exceeds the noise floor, how close any constant-drag descent can come at all
(:func:`~vectorid.identify.descent.monotone_rate_bound`) and, in a log with GPS heights, how
much of the barometric residual the GPS does not see.

Each step is a study in its own store (``OUT/NAME-PHASE.db``): ``vectorid info``, ``table``,
``pareto``, ``identifiability`` and ``ui`` work on it.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from vectorid.errors import StudyDefinitionError
from vectorid.identify.descent import (
    DRAG_CONVENTIONS,
    INITIAL_SPEEDS,
    crossing_time,
    detect_apogee,
    detect_rate_change,
    detect_touchdown,
    fast_variation,
    monotone_rate_bound,
)

__all__ = [
    "Canopy",
    "DescentPlan",
    "DescentResult",
    "PhaseLimits",
    "PhaseResult",
    "discrepancy",
    "identify_descent",
    "parse_length",
]

G0 = 9.80665
#: Relative distance from the stated drag area within which the identified one "agrees".
AGREEMENT = 0.15
#: Altitude RMS (m) the issue asks of each phase; a phase whose best fit leaves more (or
#: more than 1.5 × its noise floor) says in its summary what the residual is made of.
RMS_GOAL = 5.0
_LENGTH_UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254, "ft": 0.3048}
_LENGTH = re.compile(r"^\s*([-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?)\s*([a-z]*)\s*$")


def _err(where: str, problem: str, fix: str = "") -> StudyDefinitionError:
    return StudyDefinitionError(where, problem, fix)


def parse_length(text: str | float, where: str, default_unit: str = "m") -> float:
    """A length from a number with an optional unit (``"24in"``, ``"550 ft"``, ``"0.61"``), m.

    Raises
    ------
    StudyDefinitionError
        When the text is not a number with one of the units m, cm, mm, in, ft.
    """
    if isinstance(text, int | float) and not isinstance(text, bool):
        return float(text) * _LENGTH_UNITS[default_unit]
    m = _LENGTH.match(str(text))
    unit = (m.group(2) or default_unit) if m else ""
    if not m or unit not in _LENGTH_UNITS:
        raise _err(
            where,
            f"expected a length like 24in, 0.61m or 550ft, got {text!r}",
            f"units: {', '.join(_LENGTH_UNITS)}",
        )
    return float(m.group(1)) * _LENGTH_UNITS[unit]


# -- what the user states -----------------------------------------------------------------------


@dataclass(frozen=True)
class Canopy:
    """A parachute as stated: its drag area, or its nominal diameter (and drag coefficient).

    Parameters
    ----------
    cds : float, optional
        Stated drag area C_D S, m².
    diameter : float, optional
        Nominal diameter D, m; the drag coefficient is then reported as C_D S / (π D² / 4).
    cd : float, optional
        Stated drag coefficient on π D² / 4 (needs ``diameter``; not with ``cds``).
    """

    cds: float | None = None
    diameter: float | None = None
    cd: float | None = None

    def __post_init__(self) -> None:
        for name in ("cds", "diameter", "cd"):
            v = getattr(self, name)
            if v is not None and not (math.isfinite(v) and v > 0):
                raise _err(name, f"expected a number > 0, got {v!r}")
        if self.cd is not None and self.diameter is None:
            raise _err("cd", "a drag coefficient needs the canopy's diameter", "give diameter")
        if self.cd is not None and self.cds is not None:
            raise _err("cd", "give either the drag area cds or the drag coefficient cd, not both")

    @property
    def area(self) -> float | None:
        """Nominal area π D² / 4, m² (None without a diameter)."""
        return None if self.diameter is None else math.pi * self.diameter**2 / 4

    @property
    def stated_cds(self) -> float | None:
        """The stated drag area, m² (from ``cds``, or ``cd`` × area; None if not stated)."""
        if self.cds is not None:
            return self.cds
        if self.cd is not None and self.area is not None:
            return self.cd * self.area
        return None


@dataclass
class DescentPlan:
    """A descent to identify: the log, the rocket as stated, and how to cut the phases.

    Parameters
    ----------
    file : path
        The altimeter log.
    mass : float
        Descending mass, kg (after burn-out: dry mass with the empty motor).
    drogue, main : Canopy, optional
        The parachutes flown (at least one). A lone main is flown from the apogee.
    convention : {"adds", "replaces"}, optional
        With two parachutes: whether the main's drag area adds to the drogue's (the drogue
        stays attached) or replaces it (RocketPy's convention). Required with two parachutes.
    format : str, optional
        ``csv``, ``parquet``, ``telemega``, ``ulog`` (default: from the file).
    mapping : mapping, optional
        Column/unit mapping of a CSV or Parquet log (docs/identify.md); it needs ``time`` and
        ``altitude``.
    pad_altitude : float, optional
        Altitude above mean sea level of the altitude's zero (the pad), m: the air density
        depends on it. Default: from a TeleMega log's pad pressure (ISA pressure altitude);
        required otherwise, unless ``altitude_reference = "msl"``.
    altitude_reference : {"pad", "msl"}
        Whether the log's altitude is above the pad (default) or above mean sea level.
    main_at : float or str, optional
        When the main is triggered: an event of the log (default ``"main"`` if the log has
        one), a time in s, a height above the pad (``"870m"``, ``"550ft"``), or ``"detect"``
        (the largest change of drag area in the data, at least ×2).
    main_lag : float
        Seconds from the trigger to the main being open (added to ``main_at``).
    start : float or str, optional
        Start of the descent under the first canopy: a time in s or an event (default: the
        log's ``drogue`` event, else the apogee read from the altitude).
    end : float, optional
        Ignore the log after this time, s (e.g. corrupt last rows).
    windows : mapping, optional
        Phase name -> [start, end] overriding the windows (times in s, or events ``apogee``,
        ``touchdown``, ``main``, ``main_trigger`` and the log's, with ``+``/``-`` offsets in s).
    drogue_settle, main_settle : float
        Seconds left out after the start / the main's opening (deployment transients).
    noise : "estimate", float or mapping
        The altitude's measurement noise: ``"estimate"`` (default: σ of each phase's white
        noise by :func:`vectorid.identify.noise.estimate_sigma`), a σ in m, or a Gauss–Markov
        statement ``{"sigma": m, "correlation_time": s, "white": m}``.
    allowance, allowance_fraction : float
        Model-discrepancy allowance on the altitude, m, plus a fraction of the phase's
        altitude loss (see :func:`discrepancy`).
    vz_allowance, vz_allowance_fraction : float
        Allowance on the mean vertical-speed residual, m/s, plus a fraction of the phase's
        mean descent rate.
    initial_speed : {"steady", "data"}
        Where each simulated phase starts its descent rate: every trial's own steady rate
        (default; the phases start seconds after a canopy opened) or the slope of the data
        at the window's start.
    box_factor : float
        Each phase's box of the drag area: this factor either way of what the phase's mean
        descent rate implies (default 1.5). The verdicts are judged against it (identified:
        D at most a quarter of the box wide, about ±10 % at 1.5); a D that reaches an edge
        is at best "weak" and says to widen it.
    trials : int
        Trials per phase (a quarter in the coarse run, the rest in the narrowed box).
    seed : int
    name : str, optional
        Name of the flight (default: the file's stem).
    """

    file: str | Path
    mass: float
    drogue: Canopy | None = None
    main: Canopy | None = None
    convention: str | None = None
    format: str | None = None
    mapping: Mapping[str, Any] | None = None
    pad_altitude: float | None = None
    altitude_reference: str = "pad"
    main_at: float | str | None = None
    main_lag: float = 0.0
    start: float | str | None = None
    end: float | None = None
    windows: Mapping[str, Sequence[float | str]] = field(default_factory=dict)
    drogue_settle: float = 5.0
    main_settle: float = 6.0
    allowance: float = 3.0
    allowance_fraction: float = 0.005
    vz_allowance: float = 1.0
    vz_allowance_fraction: float = 0.1
    noise: float | Mapping[str, float] | str = "estimate"
    initial_speed: str = "steady"
    box_factor: float = 1.5
    trials: int = 1024
    seed: int = 1
    name: str | None = None

    def check(self) -> None:
        """Raise :class:`StudyDefinitionError` on a plan that cannot be run."""
        if not (isinstance(self.mass, int | float) and math.isfinite(self.mass) and self.mass > 0):
            raise _err("mass", f"expected the descending mass in kg (> 0), got {self.mass!r}")
        if self.drogue is None and self.main is None:
            raise _err(
                "canopies",
                "no parachute stated",
                "state the drogue and/or the main (drag area, or diameter and drag coefficient)",
            )
        if self.drogue is not None and self.main is not None:
            if self.convention not in DRAG_CONVENTIONS:
                raise _err(
                    "convention",
                    f"with two parachutes, say what the main's drag area means; got "
                    f"{self.convention!r}",
                    "'adds' (the drogue stays attached and the main adds its drag) or "
                    "'replaces' (the main's drag area is the whole drag area under it, as "
                    "RocketPy states it)",
                )
        elif self.convention is not None and self.convention not in DRAG_CONVENTIONS:
            raise _err("convention", f"expected 'adds' or 'replaces', got {self.convention!r}")
        if self.altitude_reference not in ("pad", "msl"):
            raise _err(
                "altitude_reference", f"expected 'pad' or 'msl', got {self.altitude_reference!r}"
            )
        for name in (
            "main_lag",
            "drogue_settle",
            "main_settle",
            "allowance",
            "allowance_fraction",
            "vz_allowance",
            "vz_allowance_fraction",
        ):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise _err(name, f"expected a number >= 0, got {v!r}")
        if not (isinstance(self.box_factor, int | float) and 1.05 <= self.box_factor <= 10):
            raise _err("box_factor", f"expected a number in [1.05, 10], got {self.box_factor!r}")
        if self.initial_speed not in INITIAL_SPEEDS:
            raise _err(
                "initial_speed",
                f"expected 'steady' or 'data', got {self.initial_speed!r}",
                "'steady': each trial's steady descent rate; 'data': the slope at the start",
            )
        _noise_table(self.noise)  # raises on a bad statement
        if not (isinstance(self.trials, int) and self.trials >= 16):
            raise _err("trials", f"expected a whole number >= 16, got {self.trials!r}")
        for k in self.windows:
            if k not in ("drogue", "main"):
                raise _err(f"windows.{k}", "unknown phase", "phases are 'drogue' and 'main'")


# -- criteria constraints -----------------------------------------------------------------------


def _noise_table(noise: Any) -> dict[str, Any] | str:
    """The ``[identification] noise`` statement of a phase from the plan's ``noise``."""
    from vectorid.identify.noise import parse_noise

    if isinstance(noise, str):
        value: dict[str, Any] | str = noise
    elif isinstance(noise, int | float) and not isinstance(noise, bool):
        value = {"altitude": float(noise)}
    elif isinstance(noise, Mapping):
        value = {"altitude": dict(noise)}
    else:
        raise _err("noise", f'expected "estimate", a σ in m or a table, got {noise!r}')
    parse_noise(value, "noise")  # one-line errors: unknown keys, negative σ
    return value


def discrepancy(
    altitude_loss: float,
    descent_rate: float,
    *,
    allowance: float = 3.0,
    allowance_fraction: float = 0.005,
    vz_allowance: float = 1.0,
    vz_allowance_fraction: float = 0.1,
) -> tuple[float, float]:
    """The model-discrepancy allowance of a descent phase, (δ_h m, δ_v m/s).

    What the point mass of one constant drag area, flown in ISA and still air, may miss of a
    real descent, granted on top of the noise floors (the ``discrepancy`` of
    :mod:`vectorid.identify.noise`): the altitude may depart from the truth by δ_h =
    ``allowance`` + ``allowance_fraction`` × the phase's altitude loss (a temperature profile
    other than ISA's, vertical air motion: both grow with the height descended), and the
    vertical speed by δ_v = ``vz_allowance`` + ``vz_allowance_fraction`` × the mean descent
    rate on average over the window (a canopy that breathes and swings, turbulence). The
    noise-floor machinery turns them into each criterion's limit by the triangle inequality:
    the altitude RMS limit is the floor's RMS + δ_h, the mean |vz residual| limit the floor's +
    δ_v. The defaults, and the figures that justify them, are in docs/identify.md.
    """
    d_h = allowance + allowance_fraction * max(altitude_loss, 0.0)
    d_v = vz_allowance + vz_allowance_fraction * abs(descent_rate)
    return d_h, d_v


@dataclass(frozen=True)
class PhaseLimits:
    """Criteria constraints Φ** of one phase, in the units a person reads.

    Attributes
    ----------
    alt_rms : float
        Largest accepted altitude RMS residual, m (``alt_sq`` ≤ T · alt_rms²).
    vz_mean_abs : float
        Largest accepted mean absolute vertical-speed residual, m/s (``vz_abs`` ≤ T · it).
    source : str
        Where they come from (the criteria's limit notes).
    floor_alt_rms, floor_vz_mean_abs : float
        The noise floors alone (without the allowance), m and m/s.
    allowance_alt, allowance_vz : float
        The discrepancy allowances δ_h (m) and δ_v (m/s).
    criteria : list of dict
        Each criterion as stored: ``name``, ``limit`` (criterion unit), ``unit``,
        ``limit_source`` ("noise" here), ``limit_note``.
    """

    alt_rms: float
    vz_mean_abs: float
    source: str
    floor_alt_rms: float = math.nan
    floor_vz_mean_abs: float = math.nan
    allowance_alt: float = 0.0
    allowance_vz: float = 0.0
    criteria: tuple[dict[str, Any], ...] = ()


# -- results ------------------------------------------------------------------------------------


@dataclass
class PhaseResult:
    """One phase's identification and verdict (all values in SI units: s, m, m/s, m²)."""

    name: str
    variable: str
    window: tuple[float, float] | None = None
    duration: float = 0.0
    altitude_loss: float = 0.0
    descent_rate: float = 0.0
    noise_alt_m: float = math.nan
    noise_vz_ms: float = math.nan
    noise: str = ""
    noise_sigma_m: float | None = None
    limits: PhaseLimits | None = None
    stated_cds: float | None = None
    diameter: float | None = None
    n: int = 0
    n_feasible: int = 0
    n_pareto: int = 0
    box: tuple[float, float] | None = None
    cds: float | None = None
    cds_feasible: tuple[float, float] | None = None
    cds_pareto: tuple[float, float] | None = None
    alt_rms_m: float | None = None
    vz_rms_ms: float | None = None
    best_cds: float | None = None
    best_alt_rms_m: float | None = None
    best_vz_mean_abs_ms: float | None = None
    stated_alt_rms_m: float | None = None
    empty_by: str | None = None
    effective_cds: tuple[float, float] | None = None
    rate_change: dict[str, float] | None = None
    height_ratio: float | None = None
    sensor_disagreement_m: float | None = None
    rate_bound: dict[str, float] | None = None
    fast_error: dict[str, float] | None = None
    identifiability: dict[str, Any] | None = None
    status: str = "no data"
    verdict: str = ""
    summary: str = ""
    store: str | None = None

    @property
    def area(self) -> float | None:
        return None if self.diameter is None else math.pi * self.diameter**2 / 4

    def _cd(self, v):
        if v is None or self.area is None:
            return None
        if isinstance(v, tuple):
            return (v[0] / self.area, v[1] / self.area)
        return v / self.area

    @property
    def cd(self) -> float | None:
        """Drag coefficient on the nominal area (None without a diameter or a value)."""
        return self._cd(self.cds)

    @property
    def cds_corrected(self) -> float | None:
        """The drag area divided by the GPS/barometric height ratio (a warm day), m²; None
        without the ratio."""
        if self.cds is None or self.height_ratio is None:
            return None
        return self.cds / self.height_ratio

    @property
    def compared_cds(self) -> float | None:
        """The value compared with the stated one: the corrected drag area where a height
        ratio is known, else the identified one, else (D empty) the best fit."""
        v = self.cds if self.cds is not None else self.best_cds
        if v is None:
            return None
        return v / self.height_ratio if self.height_ratio else v

    def to_dict(self) -> dict[str, Any]:
        out = {
            "name": self.name,
            "cd": self.cd,
            "pareto": _pair(self._cd(self.cds_pareto)),
            "feasible": _pair(self._cd(self.cds_feasible)),
            "alt_rms_m": self.alt_rms_m,
            "vz_rms_ms": self.vz_rms_ms,
            "cds": self.cds,
            "cds_pareto": _pair(self.cds_pareto),
            "cds_feasible": _pair(self.cds_feasible),
            "stated_cds": self.stated_cds,
            "ratio_to_stated": None
            if self.compared_cds is None or self.stated_cds is None
            else self.compared_cds / self.stated_cds,
            "height_ratio": self.height_ratio,
            "sensor_disagreement_m": self.sensor_disagreement_m,
            "cds_corrected": self.cds_corrected,
            "cd_corrected": self._cd(self.cds_corrected),
            "diameter_m": self.diameter,
            "status": self.status,
            "verdict": self.verdict,
            "summary": self.summary,
            "window_s": _pair(self.window),
            "descent_rate_ms": self.descent_rate,
            "altitude_loss_m": self.altitude_loss,
            "noise_alt_m": self.noise_alt_m,
            "noise_vz_ms": self.noise_vz_ms,
            "noise": self.noise,
            "noise_sigma_m": self.noise_sigma_m,
            "limits": None if self.limits is None else asdict(self.limits),
            "identifiability": self.identifiability,
            "rate_bound": self.rate_bound,
            "fast_error": self.fast_error,
            "n": self.n,
            "n_feasible": self.n_feasible,
            "n_pareto": self.n_pareto,
            "box": _pair(self.box),
            "best_fit": None
            if self.best_cds is None
            else {
                "cds": self.best_cds,
                "alt_rms_m": self.best_alt_rms_m,
                "vz_mean_abs_ms": self.best_vz_mean_abs_ms,
            },
            "stated_alt_rms_m": self.stated_alt_rms_m,
            "empty_by": self.empty_by,
            "effective_cds_range": _pair(self.effective_cds),
            "rate_change": self.rate_change,
            "store": self.store,
        }
        return out


def _pair(v) -> list[float] | None:
    return None if v is None else [float(v[0]), float(v[1])]


@dataclass
class DescentResult:
    """A descent's phases, the events read from the data, and the settings used."""

    name: str
    file: str
    mass: float
    convention: str | None
    origin_altitude: float
    apogee: tuple[float, float]
    touchdown: dict[str, float] | None
    end_of_data: tuple[float, float]
    events: dict[str, float]
    phases: list[PhaseResult]
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return {
            "flight": self.name,
            "file": self.file,
            "mass_kg": self.mass,
            "convention": self.convention,
            "origin_altitude_m": self.origin_altitude,
            "apogee": {"time_s": self.apogee[0], "altitude_m": self.apogee[1]},
            "touchdown": self.touchdown,
            "end_of_data": {"time_s": self.end_of_data[0], "altitude_m": self.end_of_data[1]},
            "events_s": self.events,
            "phases": [p.to_dict() for p in self.phases],
            "notes": self.notes,
        }

    def phase(self, name: str) -> PhaseResult:
        for p in self.phases:
            if p.name == name:
                return p
        raise KeyError(name)

    def format_text(self) -> str:
        """The result as a person reads it (units on every number)."""
        lines = [
            f"{self.name}: {self.mass:g} kg, altitude zero at {self.origin_altitude:.0f} m above "
            f"sea level, apogee {self.apogee[1]:.0f} m at {self.apogee[0]:.2f} s"
        ]
        if self.touchdown:
            td = self.touchdown
            line = (
                f"touchdown at {td['time_s']:.2f} s (read from the data: altitude and vertical "
                f"speed settle; descent {td['rate_ms']:.1f} m/s just before)"
            )
            if "landed_state_s" in td:
                line += (
                    f"; the logger's 'landed' state comes {td['landed_state_s'] - td['time_s']:.1f}"
                    " s later"
                )
            lines.append(line)
        else:
            lines.append(
                f"no touchdown in the data: the log ends at {self.end_of_data[0]:.2f} s, "
                f"{self.end_of_data[1]:.0f} m above the pad, still descending"
            )
        if self.convention:
            verb = "adds to" if self.convention == "adds" else "replaces"
            lines.append(f"drag-area convention: the main's drag area {verb} the drogue's")
        for p in self.phases:
            lines.append("")
            lines.extend(_phase_lines(p))
        for n in self.notes:
            lines.append(f"note: {n}")
        return "\n".join(lines)


def _fmt_range(v, digits: int = 4) -> str:
    return "-" if v is None else f"[{v[0]:.{digits}g}, {v[1]:.{digits}g}]"


def _phase_lines(p: PhaseResult) -> list[str]:
    head = f"{p.name}: {p.status}"
    v = p.identifiability
    if v and v.get("reason"):
        head += f" ({v['reason']})"
    out = [head]
    if p.window is not None:
        out.append(
            f"  window {p.window[0]:.2f}-{p.window[1]:.2f} s ({p.duration:.0f} s, "
            f"{p.altitude_loss:.0f} m lost at {p.descent_rate:.1f} m/s on average)"
        )
    if p.noise:
        out.append(f"  altitude noise: {p.noise}")
    lim = p.limits
    if lim is not None:
        out.append(
            f"  criteria constraints (noise floor + discrepancy allowance): altitude RMS <= "
            f"{lim.alt_rms:.2f} m ({lim.floor_alt_rms:.2f} + {lim.allowance_alt:.2f} m), mean "
            f"|vz residual| <= {lim.vz_mean_abs:.2f} m/s ({lim.floor_vz_mean_abs:.2f} + "
            f"{lim.allowance_vz:.2f} m/s)"
        )
        out.append(f"    limits: {lim.source}")
        out.append(
            f"  N = {p.n}   ND = {p.n_feasible}   NP = {p.n_pareto}   box of {p.variable} "
            f"{_fmt_range(p.box)} m²"
        )
    if p.cds is not None:
        line = (
            f"  C_D S = {p.cds:.4g} m² (feasible {_fmt_range(p.cds_feasible)}, Pareto "
            f"{_fmt_range(p.cds_pareto)} m²)"
        )
        if p.cd is not None:
            line += (
                f"; C_D = {p.cd:.3f} on the {p.diameter:.3g} m canopy (Pareto "
                f"{_fmt_range(p._cd(p.cds_pareto), 3)})"
            )
        out.append(line)
    elif p.cds_feasible is not None:
        out.append(f"  C_D S in {_fmt_range(p.cds_feasible)} m² (feasible range, {p.status})")
    if p.alt_rms_m is not None:
        out.append(
            f"  residuals: altitude RMS {p.alt_rms_m:.2f} m, vertical speed RMS "
            f"{p.vz_rms_ms:.2f} m/s"
        )
    if p.rate_bound is not None:
        out.append(
            f"  no descent whose rate never increases (a constant drag area in still air) comes "
            f"closer than {p.rate_bound['rms_m']:.2f} m RMS"
        )
    if p.stated_cds is not None:
        line = f"  stated C_D S = {p.stated_cds:.4g} m²"
        if p.stated_alt_rms_m is not None:
            line += f" (altitude RMS with it: {p.stated_alt_rms_m:.1f} m)"
        out.append(line)
    if p.verdict:
        out.append(f"  verdict: {p.verdict}")
    if v and v.get("suggestion") and p.status != "identified":
        out.append(f"  to identify it: {v['suggestion']}")
    if p.store:
        out.append(f"  store: {p.store}")
    return out


# -- the identification -------------------------------------------------------------------------


def _load(plan: DescentPlan):
    from vectorid.identify import load_flight

    path = Path(plan.file)
    if not path.exists():
        raise _err("file", f"no such file: {path}", "check the path of the altimeter log")
    path = path.resolve()
    flight = load_flight(path, mapping=plan.mapping, format=plan.format)
    if "altitude" not in flight.channels:
        raise _err(
            "mapping",
            f"{path}: the log has no altitude channel (channels: {sorted(flight.channels)})",
            "map the altitude column: altitude = { column = ..., unit = 'm' or 'ft' }",
        )
    return path, flight


def _origin_altitude(plan: DescentPlan, flight) -> float:
    if plan.altitude_reference == "msl":
        return 0.0
    if plan.pad_altitude is not None:
        return float(plan.pad_altitude)
    if "pressure" in flight.channels:
        c = flight["pressure"]
        p = float(np.median(c.values[:20, 0]))
        if c.unit in ("Pa", "pa") and 10_000 < p < 110_000:
            return 44_330.8 * (1.0 - (p / 101_325.0) ** 0.190263)
    raise _err(
        "pad_altitude",
        "the altitude above sea level of the log's zero (the pad) is not known, and the air "
        "density depends on it",
        "give the pad altitude in m (--pad-altitude), or say the altitude is above sea level "
        "(--altitude-reference msl)",
    )


def _resolve(flight_events: Mapping[str, float], key: float | str, where: str) -> float:
    if isinstance(key, int | float) and not isinstance(key, bool):
        return float(key)
    text = str(key).strip()
    if text in flight_events:
        return float(flight_events[text])
    m = re.match(r"^(.+?)\s*([+-])\s*(\d+(?:\.\d*)?|\.\d+)$", text)
    if m and m.group(1) in flight_events:
        sign = 1.0 if m.group(2) == "+" else -1.0
        return float(flight_events[m.group(1)]) + sign * float(m.group(3))
    try:
        return float(text)
    except ValueError:
        raise _err(
            where,
            f"expected a time in s or an event (with +/- seconds), got {key!r}",
            f"events: {', '.join(sorted(flight_events))}",
        ) from None


def _effective_cds(t, h, t0, t1, mass, origin, span=10.0) -> tuple[float, float] | None:
    from vectorid.models.atmosphere import ISA

    isa = ISA()
    vals = []
    a = t0
    while a + span <= t1 + 1e-9:
        m = (t >= a) & (t <= a + span)
        if m.sum() >= 5:
            v = -np.polyfit(t[m], h[m], 1)[0]
            if v > 0.5:
                rho = float(isa.density(origin + float(np.mean(h[m]))))
                vals.append(
                    2 * mass * float(isa.gravity(origin + float(np.mean(h[m])))) / (rho * v * v)
                )
        a += span
    if len(vals) < 2:
        return None
    return float(min(vals)), float(max(vals))


def _cds_estimate(rate: float, h_mid: float, mass: float, origin: float) -> float:
    from vectorid.models.atmosphere import ISA

    isa = ISA()
    rho = float(isa.density(origin + h_mid))
    return 2 * mass * G0 / (rho * max(rate, 0.5) ** 2)


@dataclass
class _Phase:
    name: str
    variable: str
    canopy: Canopy
    t0: float
    t1: float
    main_input: float


def identify_descent(
    plan: DescentPlan, out: str | Path, *, progress: bool | TextIO = False
) -> DescentResult:
    """Identify the drag areas of a descent (see the module docstring).

    Parameters
    ----------
    plan : DescentPlan
    out : path
        Folder of the stores (created); a store of the same name is replaced.
    progress : bool or file
        Progress bars of the runs.

    Returns
    -------
    DescentResult

    Raises
    ------
    StudyDefinitionError, FlightDataError
        A plan or a log that cannot be used (one line: what, what came, how to fix it).
    """
    plan.check()
    path, flight = _load(plan)
    name = plan.name or path.stem
    origin = _origin_altitude(plan, flight)
    alt = flight["altitude"]
    t, h = alt.t, alt.values[:, 0]
    if plan.end is not None:
        keep = t <= float(plan.end)
        if keep.sum() < 10:
            raise _err("end", f"keeps {int(keep.sum())} samples of the log", "a later end")
        t, h = t[keep], h[keep]
    events = {k: float(v) for k, v in flight.events.items()}
    if "apogee" in events:
        apogee = (events["apogee"], float(alt.at(np.array([events["apogee"]]))[0, 0]))
    else:
        apogee = detect_apogee(t, h)
        events["apogee"] = apogee[0]
    td = detect_touchdown(t, h, after=apogee[0])
    notes: list[str] = []
    touchdown = None
    if td is not None:
        events["touchdown"] = td.time
        touchdown = {"time_s": td.time, "ground_m": td.ground, "rate_ms": -td.rate}
        if "landed" in events:
            touchdown["landed_state_s"] = events["landed"]
        tail = td.time - 1.0
    else:
        tail = float(t[-1])
    end_of_data = (float(t[-1]), float(h[-1]))
    start = (
        _resolve(events, plan.start, "start")
        if plan.start is not None
        else events.get("drogue", apogee[0])
    )
    h_agl = h if plan.altitude_reference == "pad" else h - _pad_msl(plan, h)

    phases: list[_Phase] = []
    skipped: list[PhaseResult] = []
    if plan.drogue is not None and plan.main is not None:
        trig, why = _main_trigger(plan, events, t, h, h_agl, start, tail, origin)
        if trig is not None:
            events["main_trigger"] = trig
            events["main_open"] = trig + plan.main_lag
        drogue_end = (trig - 1.0) if trig is not None else tail
        phases.append(
            _Phase("drogue", "cds_drogue", plan.drogue, start + plan.drogue_settle, drogue_end, 0.0)
        )
        if trig is not None:
            phases.append(
                _Phase(
                    "main",
                    "cds_main",
                    plan.main,
                    trig + plan.main_lag + plan.main_settle,
                    tail,
                    1.0,
                )
            )
        else:
            skipped.append(
                PhaseResult(
                    "main",
                    "cds_main",
                    stated_cds=plan.main.stated_cds,
                    diameter=plan.main.diameter,
                    status="no data",
                    verdict=why,
                )
            )
    elif plan.drogue is not None:
        phases.append(
            _Phase("drogue", "cds_drogue", plan.drogue, start + plan.drogue_settle, tail, 0.0)
        )
    else:
        assert plan.main is not None
        phases.append(_Phase("main", "cds_main", plan.main, start + plan.main_settle, tail, 1.0))
    for ph in phases:
        if ph.name in plan.windows:
            w = plan.windows[ph.name]
            if isinstance(w, str) or len(w) != 2:
                raise _err(f"windows.{ph.name}", f"expected [start, end], got {w!r}")
            ph.t0 = _resolve(events, w[0], f"windows.{ph.name}")
            ph.t1 = _resolve(events, w[1], f"windows.{ph.name}")

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    results: list[PhaseResult] = []
    drogue_res: PhaseResult | None = None
    for ph in phases:
        r = _run_phase(
            plan, path, name, ph, t, h, origin, events, out, drogue_res, progress, flight.channels
        )
        results.append(r)
        if ph.name == "drogue":
            drogue_res = r
    results.extend(skipped)
    ratio = _height_ratio(flight, start, tail) if plan.altitude_reference == "pad" else None
    if ratio is not None:
        for r in results:
            r.height_ratio = ratio
        notes.append(
            f"the log's GPS heights gain {ratio:.4f} m per metre of barometric height over the "
            "descent: the air was warmer than ISA by about that ratio (T/T_ISA), and drag areas "
            "identified in ISA air on barometric heights are high by it; they are compared with "
            "the stated ones after dividing by it (cds_corrected)"
        )
    by_name = {r.name: r for r in results}
    for r in results:
        r.verdict, r.summary = _verdict(r, by_name, plan)
    if td is not None and "landed" in events and events["landed"] - td.time > 2.0:
        notes.append(
            f"the logger's 'landed' state ({events['landed']:.2f} s) comes "
            f"{events['landed'] - td.time:.1f} s after the touchdown read from the data; "
            "windows end at the touchdown"
        )
    return DescentResult(
        name=name,
        file=str(path),
        mass=float(plan.mass),
        convention=plan.convention if plan.drogue and plan.main else None,
        origin_altitude=origin,
        apogee=(float(apogee[0]), float(apogee[1])),
        touchdown=touchdown,
        end_of_data=end_of_data,
        events=events,
        phases=results,
        notes=notes,
    )


def _height_ratio(flight, t0: float, t1: float) -> float | None:
    """GPS over barometric height gain over [t0, t1] (least squares), when the log has GPS
    heights (``gps_altitude``, a TeleMega log) with at least 20 fixes there; else None."""
    if "gps_altitude" not in flight.channels:
        return None
    g = flight["gps_altitude"]
    a = flight["altitude"]
    sel = (g.t >= max(t0, a.t[0])) & (g.t <= min(t1, a.t[-1]))
    if sel.sum() < 20:
        return None
    gps = g.values[sel, 0]
    baro = a.at(g.t[sel])[:, 0]
    A = np.stack([baro, np.ones_like(baro)], axis=1)
    coef, *_ = np.linalg.lstsq(A, gps, rcond=None)
    k = float(coef[0])
    return k if 0.8 < k < 1.25 else None


def _pad_msl(plan: DescentPlan, h) -> float:
    """Altitude of the pad above sea level for a log in MSL altitudes (for trigger heights)."""
    if plan.pad_altitude is not None:
        return float(plan.pad_altitude)
    return float(np.median(h[:20]))


def _main_trigger(plan, events, t, h, h_agl, start, tail, origin) -> tuple[float | None, str]:
    """Time the main is triggered (s), or None and why the main phase has no data."""
    at = plan.main_at
    if at is None:
        if "main" in events:
            return float(events["main"]), ""
        raise _err(
            "main_at",
            "the log has no 'main' event, so when the main opened is unknown",
            "give it: an event of the log, a time in s, a trigger height above the pad "
            "(870m, 550ft), or 'detect' (the change of descent rate in the data)",
        )
    if isinstance(at, str) and at.strip() == "detect":
        rc = detect_rate_change(
            t, h, start + plan.drogue_settle, tail, origin_altitude=origin, min_ratio=2.0
        )
        if rc is None or rc.rate_after >= rc.rate_before:
            return None, (
                "no main opening in the data: no change of descent rate that a main canopy "
                "would make (drag area ×2 or more) after the drogue phase starts"
            )
        return rc.time, ""
    if isinstance(at, str) and at.strip() and at.strip()[-1].isalpha() and at.strip() not in events:
        level = parse_length(at, "main_at")
        tc = crossing_time(t, h_agl, level, after=events["apogee"])
        if tc is None:
            return None, (
                f"the main's trigger height ({level:.0f} m above the pad) is never reached: the "
                f"log ends at {h_agl[-1]:.0f} m above the pad"
            )
        return tc, ""
    return _resolve(events, at, "main_at"), ""


def _spec_dict(plan, path, name, ph: _Phase, origin, events, box, nominal, extra_vars, fixed, T,
               allow, noise):  # fmt: skip
    drop: dict[str, Any] = {
        "name": ph.name,
        "file": str(path),
        "window": [ph.t0, ph.t1],
        "inputs": {"main": ph.main_input},
        "origin_altitude": origin,
        "events": dict(events),
    }
    if plan.format is not None:
        drop["format"] = plan.format
    if plan.mapping is not None:
        drop["mapping"] = dict(plan.mapping)
    var: dict[str, Any] = {"name": ph.variable, "low": box[0], "high": box[1], "unit": "m²"}
    if box[0] <= nominal <= box[1]:
        var["nominal"] = nominal  # the noise floor's reference truth
    variables = [var, *extra_vars]
    options = {
        "mass": float(plan.mass),
        "drag_convention": plan.convention or "adds",
        "initial_speed": plan.initial_speed,
    }
    d_h, d_v = allow
    return {
        "study": {
            "name": f"{name}-{ph.name}",
            "model": "rocket-descent-cds",
            "trials": plan.trials,
            "seed": plan.seed,
            "executor": "serial",
            "description": f"drag area of the {ph.name} phase of {path.name} (vectorid descent)",
        },
        "variables": variables,
        "criteria": [
            {
                "name": f"alt_{ph.name}",
                "role": "pure",
                "unit": "m²·s",
                "description": f"altitude residual ∫(h - ĥ)² dt over {T:g} s (the limit / "
                f"{T:g} s is a mean square)",
            },
            {
                "name": f"vz_{ph.name}",
                "role": "pure",
                "unit": "m",
                "description": f"vertical-speed residual ∫|h' - ĥ'| dt over {T:g} s (the limit "
                f"/ {T:g} s is a mean, m/s)",
            },
        ],
        "identification": {
            "dt": 0.05,
            "output_dt": 0.5,
            # the initial state's line: with a steady start only its altitude is used, and a
            # longer line averages more of an altitude error correlated over seconds
            "init_span": 5.0 if plan.initial_speed == "steady" else 2.0,
            "model_options": options,
            "parameters": fixed,
            "drops": [drop],
            "criteria": {
                f"alt_{ph.name}": {"use": "alt_sq", "drops": [ph.name]},
                f"vz_{ph.name}": {"use": "vz_abs", "drops": [ph.name]},
            },
            "noise": noise,
            "limits": "noise",
            "noise_seed": plan.seed,
            # the allowance: the altitude's by channel (Minkowski on the RMS), the vertical
            # speed's under the criterion's name, in its unit (m: δ_v over the window)
            "discrepancy": {"altitude": d_h, f"vz_{ph.name}": d_v * T},
        },
    }


def _sensor_disagreement(channels, t0: float, t1: float) -> float | None:
    """RMS (m) of the GPS heights about the best line through the barometric heights at the
    GPS fixes in [t0, t1]: how far the log's two altimeters disagree beyond a scale factor."""
    g, a = channels["gps_altitude"], channels["altitude"]
    sel = (g.t >= max(t0, a.t[0])) & (g.t <= min(t1, a.t[-1]))
    if sel.sum() < 10:
        return None
    gps = g.values[sel, 0]
    baro = a.at(g.t[sel])[:, 0]
    A = np.stack([baro, np.ones_like(baro)], axis=1)
    coef, *_ = np.linalg.lstsq(A, gps, rcond=None)
    return float(np.sqrt(np.mean((A @ coef - gps) ** 2)))


def _fast_error(channels, t0: float, t1: float) -> dict[str, float] | None:
    """:func:`~vectorid.identify.descent.fast_variation` of the barometric heights against
    the log's GPS heights over [t0, t1], as ``{"baro_m", "gps_m", "correlation", "span_s"}``."""
    if "gps_altitude" not in channels:
        return None
    a, g = channels["altitude"], channels["gps_altitude"]
    fv = fast_variation(a.t, a.values[:, 0], g.t, g.values[:, 0], t0, t1)
    if fv is None:
        return None
    return {"baro_m": fv.rms, "gps_m": fv.rms_ref, "correlation": fv.correlation, "span_s": fv.span}


def _run_phase(
    plan, path, name, ph: _Phase, t, h, origin, events, out, drogue_res, progress, flight_channels
):
    from vectorid.analysis.identifiability import identifiability
    from vectorid.identify.identification import Identification
    from vectorid.identify.twostep import run_step
    from vectorid.spec import StudySpec
    from vectorid.store import Store

    res = PhaseResult(
        ph.name, ph.variable, stated_cds=ph.canopy.stated_cds, diameter=ph.canopy.diameter
    )
    output_dt = 0.5
    if not (ph.t1 - ph.t0 >= 5.0):
        res.window = (ph.t0, ph.t1)
        res.verdict = (
            f"the {ph.name} phase's window {ph.t0:.2f}-{ph.t1:.2f} s is shorter than 5 s: "
            "nothing to identify"
        )
        return res
    if ph.t0 < t[0] or ph.t1 > t[-1]:
        raise _err(
            f"windows.{ph.name}",
            f"window {ph.t0:.2f}-{ph.t1:.2f} s leaves the data ({t[0]:.2f}-{t[-1]:.2f} s)",
            "move the window inside the log",
        )
    sel = (t >= ph.t0) & (t <= ph.t1)
    ts, hs = t[sel], h[sel]
    n_out = math.floor((ph.t1 - ph.t0) / output_dt + 1e-9)
    T = n_out * output_dt
    grid = ph.t0 + output_dt * np.arange(n_out + 1)
    h0, h1 = float(np.interp(ph.t0, t, h)), float(np.interp(ph.t1, t, h))
    rate = -float(np.polyfit(ts, hs, 1)[0])
    res.window = (float(ph.t0), float(ph.t1))
    res.duration = T
    res.altitude_loss = h0 - h1
    res.descent_rate = rate
    res.effective_cds = _effective_cds(ts, hs, ph.t0, ph.t1, plan.mass, origin)
    rc = detect_rate_change(ts, hs, ph.t0, ph.t1, origin_altitude=origin, min_ratio=1.2)
    if rc is not None:
        res.rate_change = {
            "time_s": rc.time,
            "altitude_m": rc.altitude,
            "rate_before_ms": rc.rate_before,
            "rate_after_ms": rc.rate_after,
            "drag_area_ratio": rc.drag_area_ratio,
        }
    if grid.size >= 3:
        rb = monotone_rate_bound(t, h, grid)
        res.rate_bound = {
            "rms_m": rb.rms,
            "rate_first_ms": rb.rate_first,
            "rate_last_ms": rb.rate_last,
        }
    allow = discrepancy(
        res.altitude_loss,
        rate,
        allowance=plan.allowance,
        allowance_fraction=plan.allowance_fraction,
        vz_allowance=plan.vz_allowance,
        vz_allowance_fraction=plan.vz_allowance_fraction,
    )
    # the box: a factor box_factor either way of the drag area the mean descent rate implies
    est = _cds_estimate(rate, 0.5 * (h0 + h1), plan.mass, origin)
    if ph.variable == "cds_main" and plan.convention == "adds" and drogue_res is not None:
        base = drogue_res.cds if drogue_res.cds is not None else drogue_res.best_cds
        est = max(est - (base or 0.0), 0.05 * est)
    box = (est / plan.box_factor, est * plan.box_factor)
    res.box = box
    extra: list[dict[str, Any]] = []
    fixed: dict[str, float] = {}
    other = "cds_drogue" if ph.variable == "cds_main" else "cds_main"
    if ph.variable == "cds_main" and plan.drogue is None:
        fixed["cds_drogue"] = 0.0  # a lone main
    elif ph.variable == "cds_main" and plan.convention == "adds" and drogue_res is not None:
        rng = drogue_res.cds_feasible
        if rng is not None and rng[1] > rng[0]:
            extra.append({"name": "cds_drogue", "low": rng[0], "high": rng[1], "unit": "m²"})
        else:
            fixed["cds_drogue"] = float(
                drogue_res.cds if drogue_res.cds is not None else drogue_res.best_cds or 0.0
            )
    elif ph.variable == "cds_main":
        fixed["cds_drogue"] = 0.0  # replaced: the drogue's drag is not in the main phase
    else:
        fixed[other] = 0.0  # main stowed in the drogue phase (input 0): any value
    noise, res.noise, res.noise_sigma_m = _phase_noise(plan, ts, hs)
    data = _spec_dict(plan, path, name, ph, origin, events, box, est, extra, fixed, T, allow, noise)
    spec = StudySpec.from_dict(data, base_dir=path.parent)
    store = out / f"{_safe(name)}-{ph.name}.db"
    if store.exists():
        store.unlink()
    res.store = str(store)
    coarse = max(8, plan.trials // 4)
    meanings = {
        "cds_drogue": "drogue drag area C_D S (m²)",
        "cds_main": "main drag area C_D S (m², " + (plan.convention or "adds") + " the drogue's)",
    }
    hints = {
        "cds_drogue": "the drogue phase, where the drogue's drag area alone sets the descent"
        if ph.variable == "cds_main"
        else "a log whose altitude has less error",
        "cds_main": "a log whose altitude has less error",
    }
    step = run_step(
        spec,
        store,
        trials=max(8, plan.trials - coarse),
        coarse=coarse,
        auto_quantile=None,
        progress=progress,
        name=ph.name,
        meanings=meanings,
        hints=hints,
    )
    a = step.analysis
    with Store.open(store) as st:
        stages = st.stages()
    verdicts = identifiability(a, meanings=meanings, hints=hints, stages=stages)
    verdict = next(v for v in verdicts if v.name == ph.variable)
    res.identifiability = verdict.to_dict()
    res.status = verdict.verdict
    res.limits = _phase_limits(step.spec, T, allow)
    res.noise_alt_m = res.limits.floor_alt_rms
    res.noise_vz_ms = res.limits.floor_vz_mean_abs
    j = a.spec.space.index(ph.variable)
    X = a.trials.X[:, j]
    res.n, res.n_feasible, res.n_pareto = a.n, a.n_feasible, a.n_pareto
    F = a.trials.F
    ok = a.ok & np.isfinite(F[:, 0])
    if ok.any():
        ib = int(np.flatnonzero(ok)[np.argmin(F[ok, 0])])
        res.best_cds = float(X[ib])
        res.best_alt_rms_m = math.sqrt(max(float(F[ib, 0]), 0.0) / T)
        okv = a.ok & np.isfinite(F[:, 1])
        res.best_vz_mean_abs_ms = float(F[okv, 1].min()) / T if okv.any() else None
    x_chosen = None
    if a.n_feasible:
        res.cds_feasible = verdict.feasible
        res.cds_pareto = verdict.pareto
        i = int(np.flatnonzero(a.trials.id == step.chosen_id)[0])
        res.cds = float(X[i])
        res.alt_rms_m = math.sqrt(max(float(F[i, 0]), 0.0) / T)
        x_chosen = a.trials.X[i]
    else:
        diag = a.diagnose_empty()
        first = next((b for b, c in diag.cumulative if c == 0), None)
        res.empty_by = None if first is None else first.name
    ident = Identification.from_spec(spec)
    d = ident.drops[0]
    if x_chosen is not None:
        res.vz_rms_ms = _vz_rms(ident, d, x_chosen)
    if res.stated_cds is not None:
        xs = np.array([_center(v) for v in spec.space])
        xs[spec.space.index(ph.variable)] = res.stated_cds
        res.stated_alt_rms_m = _alt_rms(ident, d, xs)
    if res.status != "identified":  # a range, not a value
        res.best_cds = res.cds if res.best_cds is None else res.best_cds
        res.cds = None
    if "gps_altitude" in flight_channels:
        res.sensor_disagreement_m = _sensor_disagreement(flight_channels, ph.t0, ph.t1)
        res.fast_error = _fast_error(flight_channels, ph.t0, ph.t1)
    return res


def _phase_limits(spec, T: float, allow: tuple[float, float]) -> PhaseLimits:
    """The phase's criteria constraints as computed at the store's creation (noise floors +
    allowance), in m and m/s, with the criteria's own limit notes."""
    crit = {c.name.split("_", 1)[0]: c for c in spec.criteria}
    alt, vz = crit["alt"], crit["vz"]
    d_h, d_v = allow
    alt_rms = math.sqrt(max(float(alt.limit), 0.0) / T)
    vz_mean = float(vz.limit) / T
    rows = tuple(
        {
            "name": c.name,
            "limit": float(c.limit),
            "unit": c.unit,
            "limit_source": c.source,
            "limit_note": c.limit_note,
        }
        for c in (alt, vz)
    )

    def short(note: str) -> str:  # the estimated noise is printed on its own line
        return re.sub(r" \([^()]*estimated[^()]*\)$", "", note or "")

    return PhaseLimits(
        alt_rms=alt_rms,
        vz_mean_abs=vz_mean,
        source=f"{alt.name}: {short(alt.limit_note)}; {vz.name}: {short(vz.limit_note)}",
        floor_alt_rms=max(alt_rms - d_h, 0.0),
        floor_vz_mean_abs=max(vz_mean - d_v, 0.0),
        allowance_alt=d_h,
        allowance_vz=d_v,
        criteria=rows,
    )


def _phase_noise(plan, t, h) -> tuple[dict[str, Any] | str, str, float | None]:
    """The ``[identification] noise`` of a phase, the noise in words, and its σ (m).

    ``plan.noise == "estimate"``: white plus Gauss–Markov noise of the window's altitude
    (:func:`vectorid.identify.noise.estimate_correlated`), else its white noise
    (:func:`~vectorid.identify.noise.estimate_sigma`) where the window is too short for
    that; a stated noise is used as stated."""
    from vectorid.identify.noise import ComponentNoise, estimate_correlated, estimate_sigma

    if not isinstance(plan.noise, str):
        table = _noise_table(plan.noise)
        c = table["altitude"]
        if isinstance(c, Mapping):
            cn = ComponentNoise(c.get("sigma", 0.0), c.get("correlation_time", 0.0),
                                c.get("white", 0.0))  # fmt: skip
            return table, f"stated: {cn.describe(1.0, 'm')}", cn.total
        return table, f"stated: σ {float(c):.3g} m white", float(c)
    max_lag = min(5.0, (t[-1] - t[0]) / 4) if t.size > 1 else 0.0
    cn = estimate_correlated(t, h, max_lag) if max_lag > 0 else None
    how = f"third differences at lags up to {max_lag:.2g} s"
    if cn is None:
        sigma = float(estimate_sigma(t, h)[0])
        if not math.isfinite(sigma):
            return "estimate", "estimated by the study (too few samples here)", None
        cn, how = ComponentNoise(sigma), "third differences"
    table: dict[str, Any] = {"altitude": cn.total}
    if cn.correlation_time > 0:
        table = {
            "altitude": {
                "sigma": cn.sigma,
                "correlation_time": cn.correlation_time,
                "white": cn.white,
            }
        }
    text = f"{cn.describe(1.0, 'm')}, estimated from the window's {t.size} samples ({how})"
    return table, text, cn.total


def _center(v) -> float:
    return 0.5 * (float(v.low) + float(v.high))


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name) or "descent"


def _sim_alt(ident, d, x) -> tuple[np.ndarray, np.ndarray]:
    res = ident.simulate(np.atleast_2d(x), d)
    n = min(len(d.grid), res.position.shape[1])
    sim = -res.position[0, :n, 2] - d.origin_altitude
    meas = d.measured("altitude")[:n, 0]
    return sim, meas


def _alt_rms(ident, d, x) -> float:
    sim, meas = _sim_alt(ident, d, x)
    return float(np.sqrt(np.mean((sim - meas) ** 2)))


def _vz_rms(ident, d, x) -> float:
    sim, meas = _sim_alt(ident, d, x)
    e = np.gradient(sim, ident.output_dt) - np.gradient(meas, ident.output_dt)
    return float(np.sqrt(np.mean(e**2)))


def _verdict(
    r: PhaseResult, by_name: Mapping[str, PhaseResult], plan: DescentPlan
) -> tuple[str, str]:
    """A specific sentence (agreement with the stated drag area, or why not) and its short
    form for a table."""
    if r.status == "no data":
        v = r.verdict or "no data in the window"
        return v, v
    parts: list[str] = []
    short: list[str] = []
    empty = r.n > 0 and r.n_feasible == 0
    if empty:
        lim = r.limits
        crit = r.empty_by or "a constraint"
        if crit.startswith("alt_"):
            what = (
                f"an altitude RMS of {r.best_alt_rms_m:.1f} m against {lim.alt_rms:.1f} m allowed"
            )
            short.append(f"D empty ({crit}: {r.best_alt_rms_m:.1f} > {lim.alt_rms:.1f} m RMS)")
        else:
            what = (
                f"a mean vertical-speed residual of at least {r.best_vz_mean_abs_ms:.2f} m/s "
                f"against {lim.vz_mean_abs:.2f} m/s allowed"
            )
            short.append(
                f"D empty ({crit}: {r.best_vz_mean_abs_ms:.2f} > {lim.vz_mean_abs:.2f} m/s)"
            )
        parts.append(
            f"no drag area keeps the model within the criteria constraints ({crit} empties "
            f"D): the best fit leaves {what}"
        )
    if not empty and r.status in ("weak", "not identified") and r.cds_feasible is not None:
        lo, hi = r.cds_feasible
        why = (r.identifiability or {}).get("reason", "")
        parts.append(
            f"the data bound the drag area only to {lo:.4g}-{hi:.4g} m² (feasible range, "
            f"{r.status}: {why}; {r.duration:.0f} s and {r.altitude_loss:.0f} m of descent in "
            "the window)"
        )
        short.append(f"{r.status}: {lo:.3g}-{hi:.3g} m²")
    value = r.compared_cds
    stated = r.stated_cds
    label = "identified" if r.cds is not None else ("the best fit" if empty else "the chosen")
    corrected = " (hot-day corrected)" if r.height_ratio else ""
    if stated is not None and value is not None:
        ratio = value / stated
        pct = f"{100 * (ratio - 1):+.0f} %"
        what = f"{label} {value:.4g} m²{corrected} is {ratio:.2f} × the stated {stated:.4g} m²"
        dro = by_name.get("drogue")
        dval = None if dro is None else dro.compared_cds
        under = None
        if r.name == "main" and dval:
            under = value + (dval if plan.convention == "adds" else 0.0)
        # a drag area the data do not identify: the stated value is judged by D's range
        k = r.height_ratio or 1.0
        rng = r.cds_feasible if (r.cds is None and not empty) else None
        inside = rng is not None and rng[0] / k <= stated <= rng[1] / k
        if inside and abs(ratio - 1) > AGREEMENT:
            parts.append(
                f"the data do not exclude the stated {stated:.4g} m²: it lies inside the "
                f"feasible range {rng[0] / k:.4g}-{rng[1] / k:.4g} m²{corrected}"
            )
            short.append("stated value inside the feasible range")
        elif abs(ratio - 1) <= AGREEMENT:
            if r.cds is None:  # no value: D empty, or the drag area is not identified
                parts.append(
                    f"{label}, {value:.4g} m²{corrected}, is within 15 % of the stated "
                    f"{stated:.4g} m² ({pct})"
                )
                short.append(f"{label.removeprefix('the ')} within 15 % ({pct})")
            else:
                parts.insert(0, f"agrees with the stated {stated:.4g} m² ({pct}){corrected}")
                short.insert(0, f"agrees ({pct}{', hot-day corrected' if corrected else ''})")
        elif under is not None and under < 2.0 * dval:
            parts.append(
                f"the main did not open (or not fully): {what}; the drag area under it, "
                f"{under:.3g} m², is {under / dval:.2f} × the drogue phase's {dval:.3g} m²"
            )
            short.append(
                f"the main did not open (or not fully): {under / dval:.2f} × the drogue "
                "phase's drag area"
            )
        elif (
            r.name == "drogue"
            and plan.main is not None
            and plan.main.stated_cds
            and abs(value / plan.main.stated_cds - 1) <= 2 * AGREEMENT
        ):
            sm = plan.main.stated_cds
            parts.append(
                f"{what}, but {value / sm:.2f} × the stated main's {sm:.4g} m²: a main-sized "
                "canopy was open in this phase"
            )
            short.append(
                f"{ratio:.1f} × the stated drogue, {value / sm:.2f} × the stated main: a "
                "main-sized canopy was open"
            )
        else:
            v_stated = r.descent_rate * math.sqrt(value / stated)
            text = (
                f"the descent rate does not fit the stated drag area: {what}; the measured "
                f"mean descent rate, {r.descent_rate:.1f} m/s, would be about {v_stated:.1f} "
                "m/s with it"
            )
            if rng is not None:
                text += (
                    f"; the stated value lies outside the feasible range "
                    f"{rng[0] / k:.4g}-{rng[1] / k:.4g} m²{corrected}"
                )
            if r.stated_alt_rms_m is not None and r.limits is not None:
                text += (
                    f" (altitude RMS with the stated value {r.stated_alt_rms_m:.0f} m, "
                    f"{r.limits.alt_rms:.1f} m allowed)"
                )
            parts.append(text)
            short.append(
                f"the descent rate ({r.descent_rate:.1f} m/s) does not fit the stated value: "
                f"{ratio:.2f} × it (it would give {v_stated:.1f} m/s)"
            )
    elif stated is None:
        parts.append("no stated drag area to compare with")
    rms = r.best_alt_rms_m  # the closest any drag area of the box comes
    floor = r.limits.floor_alt_rms if r.limits is not None else math.nan
    if rms is not None and r.rate_bound is not None:
        # what the residual is made of: the noise, what no constant drag area can follow
        # (the monotone-rate bound), and, with GPS heights, the barometer's own error
        rb = r.rate_bound["rms_m"]
        text = (
            f"residual: the best fit leaves {rms:.1f} m RMS, the noise floor is {floor:.1f} m, "
            f"and no descent whose rate never increases (a constant drag area in still air, in "
            f"any atmosphere) comes closer than {rb:.1f} m"
        )
        fe = r.fast_error
        baro = fe is not None and fe["baro_m"] > 2.0 * fe["gps_m"] and abs(fe["correlation"]) < 0.3
        if baro:
            text += (
                f"; the barometric heights vary by {fe['baro_m']:.1f} m RMS about their "
                f"{fe['span_s']:.0f}-s trend and the log's GPS heights by {fe['gps_m']:.1f} m, "
                f"uncorrelated ({fe['correlation']:+.2f}): pressure error at the barometer, "
                "not motion"
            )
        parts.append(text)
        if rms <= floor:
            if rms > RMS_GOAL:
                short.append(f"alt RMS {rms:.1f} m, within the noise floor ({floor:.1f} m)")
        elif rms > RMS_GOAL or rms > 1.5 * floor:  # say so in the table too
            short.append(
                f"alt RMS {rms:.1f} m (noise floor {floor:.1f} m, no constant drag area "
                f"< {rb:.1f} m{'; baro error not in GPS' if baro else ''})"
            )
    if r.sensor_disagreement_m is not None and rms is not None and rms > 5.0:
        parts.append(
            f"the log's GPS and barometric heights disagree by {r.sensor_disagreement_m:.1f} "
            "m RMS in this window (beyond a scale factor)"
        )
    agrees = bool(short) and short[0].startswith("agrees")
    if empty or not agrees:
        if r.rate_change is not None:
            rc = r.rate_change
            parts.append(
                f"the drag area changes ×{rc['drag_area_ratio']:.2f} at {rc['time_s']:.1f} s "
                f"({rc['altitude_m']:.0f} m) inside the window"
            )
            short.append(f"drag area changes ×{rc['drag_area_ratio']:.2f} at {rc['time_s']:.0f} s")
        if r.effective_cds is not None and empty:
            parts.append(
                f"the drag area the descent rate implies goes from {r.effective_cds[0]:.3g} to "
                f"{r.effective_cds[1]:.3g} m² along the phase (10 s windows)"
            )
            short.append(
                f"descent rate implies {r.effective_cds[0]:.3g}-{r.effective_cds[1]:.3g} m²"
            )
    return "; ".join(parts), "; ".join(short)
