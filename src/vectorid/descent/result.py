"""The results of a descent's identification, phase by phase, and how a person reads them
(:meth:`DescentResult.format_text`: every number with its unit)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

from vectorid.descent.plan import PhaseLimits

__all__ = ["DescentResult", "PhaseResult"]

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
    height_ratio_se: float | None = None
    edge_band: tuple[float, float] | None = None
    stated_position: str | None = None
    sensor_disagreement_m: float | None = None
    rate_bound: dict[str, float] | None = None
    fast_error: dict[str, float] | None = None
    drag_along: dict[str, Any] | None = None
    cds_range: tuple[float, float] | None = None
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
            "height_ratio_se": self.height_ratio_se,
            "edge_uncertainty": _pair(self.edge_band),
            "stated_position": self.stated_position,
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
            "drag_along": self.drag_along,
            "cds_range": _pair(self.cds_range),
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
    if p.status == "varies":
        head += " (the drag area changes along the descent: no single value"
        if v and v.get("verdict"):
            head += f"; one constant drag area would be {v['verdict']}"
            head += f": {v['reason']}" if v.get("reason") else ""
        head += ")"
    elif v and v.get("reason"):
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
        how = lim.criteria[0].get("limit_note", "") if lim.criteria else ""
        how = how.split(";")[0].strip()
        if how:
            out.append(f"    noise floors: {how.removeprefix('noise floor ')}")
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
    elif p.cds_range is not None:
        feas = (
            ""
            if p.cds_feasible is None
            else f"; constant-drag feasible {_fmt_range(p.cds_feasible)}"
        )
        da = p.drag_along or {}
        sub = (da.get("low"), da.get("high"))
        own = (
            f" {_fmt_range(sub)} m²"
            if None not in sub and _fmt_range(sub) != _fmt_range(p.cds_range)
            else ""
        )
        out.append(
            f"  C_D S in {_fmt_range(p.cds_range)} m² (the drag area is not constant: the range "
            f"covers the sub-windows{own}{feas})"
        )
    elif p.cds_feasible is not None:
        out.append(f"  C_D S in {_fmt_range(p.cds_feasible)} m² (feasible range, {p.status})")
    da = p.drag_along
    if da is not None and not da["varies"]:
        n, w = len(da["cds"]), da["windows"][0][1] - da["windows"][0][0]
        out.append(
            f"  drag area from the descent rate over {n} sub-windows of {w:.0f} s: "
            f"{da['low']:.4g}-{da['high']:.4g} m², constant within the noise"
        )
    if p.cds is not None and p.alt_rms_m is not None:
        line = (
            f"  residuals of the identified C_D S: altitude RMS {p.alt_rms_m:.2f} m, vertical "
            f"speed RMS {p.vz_rms_ms:.2f} m/s"
        )
        if p.best_alt_rms_m is not None and abs(p.best_alt_rms_m - p.alt_rms_m) > 0.05:
            line += (
                f"; the lowest altitude RMS of any trial: {p.best_alt_rms_m:.2f} m (C_D S "
                f"{p.best_cds:.4g} m²)"
            )
        out.append(line)
    elif p.best_alt_rms_m is not None:
        out.append(
            f"  best fit in altitude: C_D S {p.best_cds:.4g} m², altitude RMS "
            f"{p.best_alt_rms_m:.2f} m"
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
