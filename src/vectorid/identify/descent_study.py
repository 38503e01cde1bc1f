"""Identify the drag areas of a rocket's recovery descent from an altimeter log.

A descent under one or two parachutes (a drogue from apogee, a main later; or one canopy) is
cut into phases from the data: the apogee and the touchdown are read from the altitude (not
from a logger's "landed" state), the main's opening from an event of the log, a stated
trigger height or time, or the change of descent rate in the data. Each phase is one
identification step of the PSI method on the point-mass model ``"rocket-descent-cds"``
(:class:`~vectorid.identify.descent.RocketDescentCdS`): one design variable, the drag area
C_D S of the canopy that phase is flown under (m²), sampled by LP_tau in a box around what
the phase's mean descent rate implies, with double tuning (a coarse run, then the box narrowed
to the feasible set); two criteria, the altitude residual ``alt_sq`` (∫(h - ĥ)² dt) and the
vertical-speed residual ``vz_abs`` (∫|h' - ĥ'| dt), whose constraints Φ** come from the noise
measured in the phase's data plus a stated model-discrepancy allowance
(:func:`criteria_limits`, the one place they are set). Under a main whose drag adds to the
drogue's (``convention = "adds"``) the main's step takes the drogue's drag area in the drogue
step's feasible range as a second variable (a chained step).

Every phase ends with a verdict: the identified drag area (the Pareto trial closest to the
ideal point) with its feasible and Pareto ranges, or why there is none (the feasible set D is
empty, and the constraint that empties it); compared with the stated drag area, within ±15 %
or why not (the main did not open; the drag area is the other canopy's; the descent rate does
not fit the stated value).

Each step is a study in its own store (``OUT/NAME-PHASE.db``): ``vectorid info``, ``table``,
``pareto`` and ``ui`` work on it.
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
    crossing_time,
    detect_apogee,
    detect_rate_change,
    detect_touchdown,
    noise_floor,
)

__all__ = [
    "Canopy",
    "DescentPlan",
    "DescentResult",
    "PhaseLimits",
    "PhaseResult",
    "criteria_limits",
    "identify_descent",
    "parse_length",
]

G0 = 9.80665
#: Relative distance from the stated drag area within which the identified one "agrees".
AGREEMENT = 0.15
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
    allowance, allowance_fraction : float
        Model-discrepancy allowance on the altitude, m, plus a fraction of the phase's
        altitude loss (see :func:`criteria_limits`).
    vz_allowance, vz_allowance_fraction : float
        Allowance on the vertical speed, m/s, plus a fraction of the phase's mean descent
        rate.
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
        if not (isinstance(self.trials, int) and self.trials >= 16):
            raise _err("trials", f"expected a whole number >= 16, got {self.trials!r}")
        for k in self.windows:
            if k not in ("drogue", "main"):
                raise _err(f"windows.{k}", "unknown phase", "phases are 'drogue' and 'main'")


# -- criteria constraints -----------------------------------------------------------------------


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
        Where they come from (for every printed answer).
    """

    alt_rms: float
    vz_mean_abs: float
    source: str


def criteria_limits(
    noise_alt: float,
    noise_vz: float,
    altitude_loss: float,
    descent_rate: float,
    *,
    allowance: float = 3.0,
    allowance_fraction: float = 0.005,
    vz_allowance: float = 1.0,
    vz_allowance_fraction: float = 0.1,
) -> PhaseLimits:
    """Criteria constraints of a descent phase from its noise floor and a stated allowance.

    The single place where the descent identification sets Φ** (to be replaced by the study's
    ``limits = "noise"`` where that is available). A perfect model leaves the measurement noise:
    the criteria then take their noise floors (:func:`vectorid.identify.descent.noise_floor`),
    an altitude RMS ``noise_alt`` (m) and a mean absolute vertical-speed residual ``noise_vz``
    (m/s). The model is not perfect: ISA air on a real day and still air (the altitude may
    depart by an allowance δ_h = ``allowance`` + ``allowance_fraction`` × the phase's altitude
    loss, m), one constant drag area for a rocket that swings under a canopy that breathes,
    in turbulent air (the vertical speed may depart by δ_v = ``vz_allowance`` +
    ``vz_allowance_fraction`` × the mean descent rate, m/s). The limits add them in quadrature
    (δ_v as the mean absolute value of a Gaussian of that standard deviation):

        alt RMS ≤ sqrt(noise_alt² + δ_h²),    mean |vz residual| ≤ sqrt(noise_vz² + (2/π) δ_v²).

    Parameters
    ----------
    noise_alt, noise_vz : float
        Noise floors of the altitude (RMS, m) and of its rate (mean absolute, m/s).
    altitude_loss, descent_rate : float
        The phase's altitude loss (m) and mean descent rate (m/s).
    allowance, allowance_fraction, vz_allowance, vz_allowance_fraction : float
        m, -, m/s, -.
    """
    d_h = allowance + allowance_fraction * max(altitude_loss, 0.0)
    d_v = vz_allowance + vz_allowance_fraction * abs(descent_rate)
    alt = math.hypot(noise_alt, d_h)
    vz = math.hypot(noise_vz, math.sqrt(2 / math.pi) * d_v)
    source = (
        f"noise floor + allowance: altitude noise {noise_alt:.2f} m ⊕ allowance {d_h:.1f} m "
        f"({allowance:g} m + {100 * allowance_fraction:g} % of the {altitude_loss:.0f} m lost); "
        f"vertical-speed noise {noise_vz:.2f} m/s ⊕ allowance {d_v:.2f} m/s ({vz_allowance:g} "
        f"m/s + {100 * vz_allowance_fraction:g} % of {abs(descent_rate):.1f} m/s)"
    )
    return PhaseLimits(alt, vz, source)


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
            "limits": None if self.limits is None else asdict(self.limits),
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
            lines.append(
                f"drag-area convention: the main's drag area {self.convention} the drogue's"
            )
        for p in self.phases:
            lines.append("")
            lines.extend(_phase_lines(p))
        for n in self.notes:
            lines.append(f"note: {n}")
        return "\n".join(lines)


def _fmt_range(v, digits: int = 4) -> str:
    return "-" if v is None else f"[{v[0]:.{digits}g}, {v[1]:.{digits}g}]"


def _phase_lines(p: PhaseResult) -> list[str]:
    out = [f"{p.name}: {p.status}"]
    if p.window is not None:
        out.append(
            f"  window {p.window[0]:.2f}-{p.window[1]:.2f} s ({p.duration:.0f} s, "
            f"{p.altitude_loss:.0f} m lost at {p.descent_rate:.1f} m/s on average)"
        )
    if p.limits is not None:
        out.append(
            f"  criteria constraints: altitude RMS <= {p.limits.alt_rms:.2f} m, mean |vz "
            f"residual| <= {p.limits.vz_mean_abs:.2f} m/s ({p.limits.source})"
        )
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
        out.append(f"  C_D S in {_fmt_range(p.cds_feasible)} m² (feasible range)")
    if p.alt_rms_m is not None:
        out.append(
            f"  residuals: altitude RMS {p.alt_rms_m:.2f} m, vertical speed RMS "
            f"{p.vz_rms_ms:.2f} m/s"
        )
    if p.stated_cds is not None:
        line = f"  stated C_D S = {p.stated_cds:.4g} m²"
        if p.stated_alt_rms_m is not None:
            line += f" (altitude RMS with it: {p.stated_alt_rms_m:.1f} m)"
        out.append(line)
    if p.verdict:
        out.append(f"  verdict: {p.verdict}")
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


def _spec_dict(plan, path, name, ph: _Phase, origin, events, box, extra_vars, fixed, limits, T):
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
    variables = [
        {
            "name": ph.variable,
            "low": box[0],
            "high": box[1],
            "unit": "m²",
        }
    ]
    variables.extend(extra_vars)
    options = {"mass": float(plan.mass), "drag_convention": plan.convention or "adds"}
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
                "limit": T * limits.alt_rms**2,
                "unit": "m²·s",
                "description": f"altitude residual ∫(h - ĥ)² dt over {T:g} s; the limit is "
                f"an RMS of {limits.alt_rms:.2f} m ({limits.source})",
            },
            {
                "name": f"vz_{ph.name}",
                "role": "pure",
                "limit": T * limits.vz_mean_abs,
                "unit": "m",
                "description": f"vertical-speed residual ∫|h' - ĥ'| dt over {T:g} s; the "
                f"limit is a mean of {limits.vz_mean_abs:.2f} m/s",
            },
        ],
        "identification": {
            "dt": 0.05,
            "output_dt": 0.5,
            "init_span": 2.0,
            "model_options": options,
            "parameters": fixed,
            "drops": [drop],
            "criteria": {
                f"alt_{ph.name}": {"use": "alt_sq", "drops": [ph.name]},
                f"vz_{ph.name}": {"use": "vz_abs", "drops": [ph.name]},
            },
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


def _run_phase(
    plan, path, name, ph: _Phase, t, h, origin, events, out, drogue_res, progress, flight_channels
):
    from vectorid.analysis.choice import suggest_choice
    from vectorid.identify.identification import Identification
    from vectorid.spec import StudySpec
    from vectorid.study import Study

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
    res.noise_alt_m, res.noise_vz_ms = noise_floor(ts, hs, grid)
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
    limits = criteria_limits(
        res.noise_alt_m,
        res.noise_vz_ms,
        res.altitude_loss,
        rate,
        allowance=plan.allowance,
        allowance_fraction=plan.allowance_fraction,
        vz_allowance=plan.vz_allowance,
        vz_allowance_fraction=plan.vz_allowance_fraction,
    )
    res.limits = limits
    # the box: a factor 3 either way of the drag area the mean descent rate implies
    est = _cds_estimate(rate, 0.5 * (h0 + h1), plan.mass, origin)
    if ph.variable == "cds_main" and plan.convention == "adds" and drogue_res is not None:
        base = drogue_res.cds if drogue_res.cds is not None else drogue_res.best_cds
        est = max(est - (base or 0.0), 0.05 * est)
    box = (est / 3.0, est * 3.0)
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
    data = _spec_dict(plan, path, name, ph, origin, events, box, extra, fixed, limits, T)
    spec = StudySpec.from_dict(data, base_dir=path.parent)
    store = out / f"{_safe(name)}-{ph.name}.db"
    if store.exists():
        store.unlink()
    res.store = str(store)
    coarse = max(16, plan.trials // 4)
    with Study.create(spec, store) as st:
        st.run(trials=coarse, executor="serial", progress=progress)
        a = st.analysis()
        j = a.spec.space.index(ph.variable)
        X = a.trials.X[:, j]
        if a.n_feasible:
            lo, hi = float(X[a.feasible].min()), float(X[a.feasible].max())
        else:  # around the best altitude fits
            col = a.trials.F[:, 0]
            ok = np.isfinite(col)
            best = np.argsort(np.where(ok, col, np.inf))[: max(3, coarse // 20)]
            lo, hi = float(X[best].min()), float(X[best].max())
        w = max(hi - lo, 0.02 * 0.5 * (lo + hi))
        new_lo, new_hi = max(box[0], lo - w), min(box[1], hi + w)
        bounds = {ph.variable: (new_lo, new_hi)}
        st.store.add_stage(
            a.spec.space.with_bounds(bounds),
            kind="sample",
            note=f"narrowed to the {'feasible set' if a.n_feasible else 'best fits'} ± its width",
        )
        st.run(trials=plan.trials, executor="serial", progress=progress)
        a = st.analysis()
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
        if a.n_feasible:
            res.cds_feasible = (float(X[a.feasible].min()), float(X[a.feasible].max()))
            res.cds_pareto = (float(X[a.pareto].min()), float(X[a.pareto].max()))
            cid = suggest_choice(a)
            i = int(np.flatnonzero(a.trials.id == cid)[0])
            res.cds = float(X[i])
            res.alt_rms_m = math.sqrt(max(float(F[i, 0]), 0.0) / T)
            x_chosen = a.trials.X[i]
        else:
            diag = a.diagnose_empty()
            first = next((b for b, c in diag.cumulative if c == 0), None)
            res.empty_by = None if first is None else first.name
            x_chosen = None
    ident = Identification.from_spec(spec)
    d = ident.drops[0]
    if x_chosen is not None:
        res.vz_rms_ms = _vz_rms(ident, d, x_chosen)
        if res.alt_rms_m is None:
            res.alt_rms_m = _alt_rms(ident, d, x_chosen)
    if res.stated_cds is not None:
        xs = np.array([_center(v) for v in spec.space])
        xs[spec.space.index(ph.variable)] = res.stated_cds
        res.stated_alt_rms_m = _alt_rms(ident, d, xs)
    res.status = _status(res)
    if res.status == "not identified":  # a range, not a value
        res.best_cds = res.cds if res.best_cds is None else res.best_cds
        res.cds = None
    if "gps_altitude" in flight_channels:
        res.sensor_disagreement_m = _sensor_disagreement(flight_channels, ph.t0, ph.t1)
    return res


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


def _status(r: PhaseResult) -> str:
    """identified / weak / not identified from the feasible range, or why there is no value."""
    if r.n == 0:
        return "no data"
    if r.n_feasible == 0:
        return "D empty"
    lo, hi = r.cds_feasible
    rel = (hi - lo) / max(abs(r.cds), 1e-12)
    if rel <= 0.2:
        return "identified"
    if rel <= 1.0:
        return "weak"
    return "not identified"


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
    empty = r.status == "D empty"
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
    if r.status in ("weak", "not identified"):
        lo, hi = r.cds_feasible
        parts.append(
            f"the data bound the drag area only to {lo:.4g}-{hi:.4g} m² (feasible range; "
            f"{r.duration:.0f} s and {r.altitude_loss:.0f} m of descent in the window)"
        )
        short.append(f"{r.status}: {lo:.3g}-{hi:.3g} m²")
    value = r.compared_cds
    stated = r.stated_cds
    label = "the best fit" if empty else "identified"
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
        if abs(ratio - 1) <= AGREEMENT:
            if empty:
                parts.append(
                    f"{label}, {value:.4g} m²{corrected}, is within 15 % of the stated "
                    f"{stated:.4g} m² ({pct})"
                )
                short.append(f"best fit within 15 % ({pct})")
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
    if r.sensor_disagreement_m is not None and r.alt_rms_m is not None:
        if r.alt_rms_m > 5.0:
            parts.append(
                f"the log's GPS and barometric heights disagree by {r.sensor_disagreement_m:.1f} "
                "m RMS in this window (beyond a scale factor)"
            )
            short.append(f"GPS and baro heights disagree by {r.sensor_disagreement_m:.1f} m RMS")
    if empty:
        if r.rate_change is not None:
            rc = r.rate_change
            parts.append(
                f"the drag area changes ×{rc['drag_area_ratio']:.2f} at {rc['time_s']:.1f} s "
                f"({rc['altitude_m']:.0f} m) inside the window"
            )
            short.append(f"drag area changes ×{rc['drag_area_ratio']:.2f} at {rc['time_s']:.0f} s")
        if r.effective_cds is not None:
            parts.append(
                f"the drag area the descent rate implies goes from {r.effective_cds[0]:.3g} to "
                f"{r.effective_cds[1]:.3g} m² along the phase (10 s windows)"
            )
            short.append(
                f"descent rate implies {r.effective_cds[0]:.3g}-{r.effective_cds[1]:.3g} m²"
            )
    return "; ".join(parts), "; ".join(short)
