"""What the user states about a descent: the canopies, the rocket's mass, how to cut the
phases, and the model-discrepancy allowance (:func:`discrepancy`) granted on top of the noise
floors. Lengths always carry a unit (:func:`parse_length`)."""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from vectorid.descent.model import DRAG_CONVENTIONS, INITIAL_SPEEDS
from vectorid.errors import StudyDefinitionError
from vectorid.identify.noise import parse_noise

__all__ = ["Canopy", "DescentPlan", "PhaseLimits", "discrepancy", "parse_length"]

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


def parse_length(text: str | float, where: str, default_unit: str | None = None) -> float:
    """A length from a number with a unit (``"24in"``, ``"550 ft"``, ``"0.61m"``), m.

    A bare number is refused unless ``default_unit`` says what it means (the Python API takes
    SI numbers: ``parse_length(0.61, ..., "m")``): "24" may be inches or metres.

    Raises
    ------
    StudyDefinitionError
        When the text is not a number with one of the units m, cm, mm, in, ft.
    """
    if isinstance(text, int | float) and not isinstance(text, bool):
        if default_unit is None:
            raise _err(where, f"{text!r} has no unit", "write a length with its unit: 24in, 0.61m")
        return float(text) * _LENGTH_UNITS[default_unit]
    m = _LENGTH.match(str(text).lower())
    if m and not m.group(2) and default_unit is None:
        v = m.group(1)
        raise _err(
            where,
            f"{v} — inches, or metres? a length needs its unit",
            f"write {v}in or {float(v) * 0.0254:.3g}m (units: {', '.join(_LENGTH_UNITS)})",
        )
    unit = (m.group(2) or default_unit) if m else ""
    unit = {"feet": "ft", "foot": "ft", "inch": "in", "inches": "in", "meters": "m",
            "metres": "m", "meter": "m", "metre": "m"}.get(unit, unit)  # fmt: skip
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
        ``csv``, ``parquet``, ``altusmetrum`` (``telemega``), ``ulog`` (default: read from the
        file's content, :func:`vectorid.descent.formats.detect_format`).
    mapping : mapping, optional
        Column/unit mapping of a CSV or Parquet log (docs/identify.md); it needs ``time`` and
        ``altitude``. Default: built from ``columns``, ``time_unit``, ``altitude_unit`` and
        ``read`` and the units the column names state.
    columns : mapping, optional
        ``{"time": COL, "altitude": COL[, "event": COL]}`` of a generic CSV (default: from the
        header when it has one time-like and one altitude-like column).
    time_unit, altitude_unit : str, optional
        The units of a generic CSV's columns when their names state none: required then
        (units are never guessed; ``time_unit = "iso"`` for ISO 8601 dates, which are also
        read from the content); an error when they contradict the names, or when the format
        states its own units (AltusMetrum, a CATS export).
    read : mapping, optional
        ``first_line``, ``last_line``, ``max_gap`` of a generic CSV.
    strict_data : bool
        Stop at a single-sample spike in the log instead of leaving it out (default False:
        spikes are left out and named with their times).
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
    columns: Mapping[str, str] | None = None
    time_unit: str | None = None
    altitude_unit: str | None = None
    read: Mapping[str, Any] = field(default_factory=dict)
    strict_data: bool = False
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
