"""Plausibility of a descent log against physics and against what the user states: the checks
that stop a run whose numbers would be silently wrong, with a message naming the column, what
it looks like, and the likely mistake.

- a descent faster than a free fall from the apogee (:func:`check_time_scale`: a time column
  whose unit is wrong, e.g. seconds read as milliseconds);
- a log whose altitude hardly changes (a wrong column, a flat log);
- a log that starts at rest far from 0 m with the altitude said to be above the pad (an
  altitude above sea level);
- a descent rate that the stated mass and canopies cannot give by a factor near 3.28 (an
  altitude in feet read as metres, or the other way round);
- a phase whose descent rate implies a drag area orders of magnitude off every stated canopy
  (:func:`check_drag_magnitude`: a wrong mass, a column that is not the altitude, a unit off by
  a factor 1000);
- a trigger before the apogee, or above it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from vectorid.descent.events import _running_median
from vectorid.descent.plan import G0, DescentPlan, _err
from vectorid.models.atmosphere import ISA

__all__ = ["check_descent", "check_drag_magnitude", "check_time_scale", "steady_rate"]

FT = 0.3048
#: A descent faster than this fraction of a free fall's time from the apogee to the lowest
#: point is not a descent the log's time can hold (a free fall is the fastest any descent from
#: rest can be; half of it leaves room for an apogee read a little late).
FREE_FALL_SHARE = 0.5
#: A phase whose descent rate implies a drag area more than this many times the largest stated
#: total drag area (or less than the smallest / :data:`TOO_SMALL`) is not what the stated mass
#: and canopies can give: a canopy of 100 × the drag area is 10 × its diameter. A main-sized
#: canopy open under a stated drogue is up to about 40 × the drogue's drag area (NDRT: 16.05 /
#: 0.4378 m²), and a rocket falling with no canopy open at all about 1/200 of a main's.
TOO_LARGE, TOO_SMALL = 100.0, 1000.0
#: Drag areas no rocket descent can have, m²: less than the nose-first drag area of the
#: smallest model rocket (an 18-mm body, C_D 0.3: 7.6e-5 m²), more than the largest parachutes
#: ever flown (about 1000 m² of C_D S).
CDS_PHYSICAL = (5e-5, 5e3)
_TIME_FACTORS = {"ns": 1e-9, "us": 1e-6, "ms": 1e-3, "s": 1.0, "min": 60.0}


@dataclass(frozen=True)
class ReadAs:
    """How the log's time and altitude were read, for messages that name them.

    Attributes
    ----------
    time, altitude : str or None
        The columns (None: a format that names its own, e.g. AltusMetrum).
    time_unit, altitude_unit : str or None
        Their units as read (``"s"``, ``"ms"``, ``"iso"``; ``"m"``, ``"ft"``).
    time_from, altitude_from : str or None
        Where each unit came from: ``"header"`` (the column's name), ``"option"``
        (``--time-unit``/``--altitude-unit``), ``"format"`` (the logger's documentation),
        ``"content"`` (ISO 8601 dates), ``"mapping"`` (a plan's mapping).
    """

    time: str | None = None
    time_unit: str | None = None
    time_from: str | None = None
    altitude: str | None = None
    altitude_unit: str | None = None
    altitude_from: str | None = None

    def column(self, key: str) -> str:
        """``"the time column 't (ms)' (read in ms from its name)"``, as messages say it."""
        name, unit, src = (
            (self.time, self.time_unit, self.time_from)
            if key == "time"
            else (self.altitude, self.altitude_unit, self.altitude_from)
        )
        if name is None:
            return f"the log's {key}"
        how = {
            "header": "from its name",
            "option": f"as --{key}-unit says",
            "format": "as the format documents",
            "content": "from its content",
            "mapping": "as the mapping says",
        }.get(src or "", "")
        return f"the {key} column {name!r} (read in {unit}{' ' + how if how else ''})"

    def unit_fix(self, key: str, unit: str) -> str:
        """How to read the ``key`` column in ``unit`` instead."""
        src = self.time_from if key == "time" else self.altitude_from
        name = self.time if key == "time" else self.altitude
        if src == "header":
            return (
                f"correct the unit in the column's name ({name!r} says otherwise), or choose "
                f"another {key} column with --columns"
            )
        if src == "mapping":
            return f"set the mapping's {key} unit to {unit!r}"
        if src == "format":
            return (
                f"check that the file is the logger export its header says (its {key} unit is "
                "the one that logger documents)"
            )
        return f"give --{key}-unit {unit}"


def check_time_scale(
    t: np.ndarray, h: np.ndarray, read: ReadAs, plan: DescentPlan | None = None,
    origin: float = 0.0,
) -> None:  # fmt: skip
    """Stop where the log comes down from its apogee faster than a free fall from rest: no
    descent can, so its time or its altitude is not in the unit it was read in (seconds read
    as milliseconds make a 25-s descent 0.025 s long; metres read as kilometres make it 1000 ×
    as tall).

    The apogee and the lowest point after it are read from a 5-sample running median (by
    sample, whatever the time scale), so a spike decides neither. The unit suggested is the one
    (of the time's, or the altitude's) that makes the descent no faster than a free fall and
    whose mean descent rate is closest to the steady rate of the stated canopies (20 m/s where
    none is stated).

    Raises
    ------
    StudyDefinitionError
        Naming the columns and their units, the descent's duration against the free fall's,
        and the unit that would make it a descent.
    """

    if t.size < 5:
        return
    s = _running_median(np.asarray(h, dtype=float), 5)
    i = int(np.argmax(s))
    if i >= s.size - 1:
        return
    k = i + 1 + int(np.argmin(s[i + 1 :]))
    drop = float(s[i] - s[k])
    if drop < 10.0:
        return
    took = float(t[k] - t[i])

    def physical(d: float, dur: float) -> bool:
        return dur >= FREE_FALL_SHARE * math.sqrt(2.0 * d / G0)

    if physical(drop, took):
        return
    t_ff = math.sqrt(2.0 * drop / G0)
    step = float(np.median(np.diff(t)))
    said = (
        f"the altitude comes down {drop:.4g} m from its top (at {t[i]:.4g} s) in {took:.3g} s, "
        f"where a free fall from rest takes {t_ff:.3g} s (no descent is faster; a sample every "
        f"{step:.3g} s): {read.column('time')} or {read.column('altitude')} is not in that unit"
    )
    cds = stated_totals(plan) if plan is not None else []

    def v_ref(d: float) -> float:  # the stated canopies' steady rate half-way down
        if not cds or plan is None:
            return 20.0
        return steady_rate(plan.mass, max(cds), origin + d / 2)

    options = []  # (how far from v_ref, key, unit, drop, duration)
    lengths = {"km": 1000.0, "m": 1.0, "ft": FT}
    f0 = _TIME_FACTORS.get(read.time_unit or "")
    if f0 is not None:
        for u, f in _TIME_FACTORS.items():
            if f > f0:
                options.append(("time", u, drop, took * f / f0))
    g0 = lengths.get(read.altitude_unit or "")
    if g0 is not None:
        for u, g in lengths.items():
            if g < g0:
                options.append(("altitude", u, drop * g / g0, took))
    good = [
        (abs(math.log(d / dur / v_ref(d))), key, u, d, dur)
        for key, u, d, dur in options
        if physical(d, dur)
    ]
    if good:
        _, key, u, d, dur = min(good)
        fix = (
            f"the {key} looks like {u} (a descent of {d:.4g} m in {dur:.3g} s, "
            f"{d / dur:.3g} m/s): {read.unit_fix(key, u)}"
        )
    else:
        fix = "check the time and altitude columns and their units (--columns, --time-unit)"
    raise _err("units", said, fix)


def stated_totals(plan: DescentPlan) -> list[float]:
    """The total drag areas the stated canopies can give, m²: each canopy's alone, and under
    ``adds`` the drogue's plus the main's."""
    d = plan.drogue.stated_cds if plan.drogue is not None else None
    m = plan.main.stated_cds if plan.main is not None else None
    out = [v for v in (d, m) if v]
    if d and m and plan.convention == "adds":
        out.append(d + m)
    return out


def check_drag_magnitude(
    plan: DescentPlan,
    phases: Sequence[tuple[str, float, float, float, float]],
    read: ReadAs,
    diagnose=None,
) -> None:
    """Stop where a phase's descent rate implies a drag area orders of magnitude off every
    stated canopy (more than :data:`TOO_LARGE` × the largest stated total, less than the
    smallest / :data:`TOO_SMALL`), or off what any rocket descent can have
    (:data:`CDS_PHYSICAL`), before any trial is run.

    Parameters
    ----------
    plan : DescentPlan
    phases : sequence of (name, t0, t1, rate, cds)
        Each phase's name as said (``"drogue phase"``), its window (s), its mean descent rate
        (m/s, a least-squares line) and the drag area 2 m g / (ρ v²) that rate implies (m²).
    read : ReadAs
    diagnose : callable, optional
        ``diagnose() -> str``: what the log's other columns say (a column that descends as
        the stated rocket would), '' if nothing; called only when a phase fails.

    Raises
    ------
    StudyDefinitionError
        Naming the phase, its rate and drag area against the stated ones, the inputs to check
        and the factor a likely unit mistake would explain.
    """
    totals = stated_totals(plan)
    lo_ok = max(min(totals) / TOO_SMALL, CDS_PHYSICAL[0]) if totals else CDS_PHYSICAL[0]
    hi_ok = min(max(totals) * TOO_LARGE, CDS_PHYSICAL[1]) if totals else CDS_PHYSICAL[1]
    for name, t0, t1, rate, cds in phases:
        if lo_ok <= cds <= hi_ok:
            continue
        big = cds > hi_ok
        if rate <= 0.0:
            how = f"does not descend ({rate:.2g} m/s on average)"
        elif rate <= 0.5:
            how = f"hardly descends ({rate:.2g} m/s on average)"
        else:
            how = f"descends at {rate:.3g} m/s on average"
        ref = (max(totals) if big else min(totals)) if totals else None
        if ref is not None:
            versus = (
                f"{cds / ref:.3g} × the {'largest' if big else 'smallest'} stated drag area "
                f"({ref:.4g} m²)"
            )
        elif big:
            versus = "more than the largest parachutes have"
        else:
            versus = "less than the smallest model rocket falling nose first has"
        what = read.column("altitude").split(" (read")[0]
        said = (
            f"in the {name} ({t0:.2f}-{t1:.2f} s) {what} {how}: with the stated mass "
            f"({plan.mass:g} kg) that is a drag area of {cds:.3g} m² (2 m g / ρ v²), {versus}, "
            "which no stated canopy can give"
        )
        fix = diagnose() if diagnose is not None else ""
        if not fix:
            hints = _unit_hints(cds, totals, read)
            if ref is not None:
                hints.append(
                    f"at this rate the stated {ref:.4g} m² needs a mass of "
                    f"{plan.mass * ref / cds:.3g} kg"
                )
            fix = (
                f"check the mass (--mass, kg), the drag areas, and {read.column('altitude')} "
                f"and {read.column('time')}"
            )
            if hints:
                fix += " (" + "; ".join(hints) + ")"
        raise _err("drag area", said, fix)


def _unit_hints(cds: float, totals: list[float], read: ReadAs) -> list[str]:
    """The unit mistakes (a time or an altitude read in the wrong unit) that would bring
    ``cds`` within a factor 3 of a stated drag area (the factors are 3.28 and more, and a
    phase cut from a log read in a wrong unit is not the phase it would be). Read in unit B
    instead of A, times scale by r = f_B / f_A, so the rate by 1 / r and C_D S by r²; lengths
    scale the rate by r and C_D S by 1 / r²."""
    if not totals:
        return []
    out = []
    lengths = {"m": 1.0, "ft": FT, "km": 1000.0}
    for key, table, power in (("time", _TIME_FACTORS, 2), ("altitude", lengths, -2)):
        unit = read.time_unit if key == "time" else read.altitude_unit
        if unit not in table:
            continue
        for other, f in table.items():
            if other == unit:
                continue
            v = cds * (f / table[unit]) ** power
            if any(1 / 3 <= v / c <= 3.0 for c in totals):
                name = read.time if key == "time" else read.altitude
                out.append(f"{name!r} read in {other} instead of {unit} would give {v:.3g} m²")
    return out


#: A measured descent this many times faster (or slower) than the stated canopies allow, with
#: a factor near 1/0.3048 = 3.28 between, is a unit mistake rather than a wrong drag area.
_UNIT_RATIO = (2.3, 5.0)


def steady_rate(mass: float, cds: float, altitude_msl: float) -> float:
    """Steady descent rate sqrt(2 m g / (ρ C_D S)) in ISA air at ``altitude_msl`` (m), m/s."""

    # clipped to ISA's range: a log read in a wrong unit can put the rocket in space
    rho = float(ISA().density(min(max(altitude_msl, -4999.0), 70999.0)))
    return math.sqrt(2.0 * mass * G0 / (rho * cds))


def check_descent(
    plan: DescentPlan,
    t: np.ndarray,
    h: np.ndarray,
    apogee: tuple[float, float],
    origin: float,
    altitude_unit: str | None,
    diagnose=None,
) -> None:
    """Stop (:class:`~vectorid.errors.StudyDefinitionError`) on a log that cannot be what the
    plan says (see the module docstring).

    Parameters
    ----------
    plan : DescentPlan
    t, h : ndarray
        Times (s) and altitudes (m, after the unit conversion) of the log.
    apogee : (float, float)
        Time (s) and altitude (m) of the apogee.
    origin : float
        Altitude of the altitude's zero above sea level, m.
    altitude_unit : str or None
        The unit the altitude column was read in (None: stated by the format itself).
    diagnose : callable, optional
        ``diagnose() -> str``: another column of the log that comes down as the stated rocket
        would ('' if none), said where the altitude has no descent.
    """
    span = float(np.ptp(h)) if h.size else 0.0
    if span < 10.0:
        raise _err(
            "log",
            f"the altitude changes by only {span:.3g} m over the whole log "
            f"({t[0]:.2f}-{t[-1]:.2f} s): there is no descent in it",
            (diagnose() if diagnose is not None else "")
            or "check that the altitude column is the height (--columns altitude=COL)",
        )
    if plan.altitude_reference == "pad":
        # a log that starts on the pad (at rest, or lifting off: under 30 m/s over its first
        # 0.5 s, then a climb of more than 100 m to the apogee) reads ~0 there; far from 0, its
        # altitude is above sea level (a GNSS log) or another zero, and the air density would
        # be taken far too high up. A log that starts in the air (fast, or at its apogee) is
        # not judged.
        first = t <= t[0] + 0.5
        if first.sum() >= 3 and apogee[0] > t[0] + 0.5:
            h0 = float(np.median(h[first]))
            rate = abs(float(np.polyfit(t[first], h[first], 1)[0]))
            if rate < 30.0 and apogee[1] - h0 > 100.0 and abs(h0) > 50.0:
                raise _err(
                    "altitude reference",
                    f"the log starts on the ground at {h0:.0f} m (apogee {apogee[1]:.0f} m), "
                    "not near 0 m: its altitude is not above the pad",
                    "an altitude above sea level (GNSS): give --altitude-reference msl (and no "
                    "--pad-altitude); else check the altitude column",
                )
    after = t >= apogee[0]
    ta, ha = t[after], h[after]
    drop = apogee[1] - float(np.min(ha)) if ha.size else 0.0
    if ha.size < 5 or drop < 10.0:
        raise _err(
            "log",
            f"the log ends {ta[-1] - apogee[0] if ta.size else 0:.1f} s after the apogee "
            f"({apogee[1]:.0f} m at {apogee[0]:.2f} s) with {drop:.1f} m of descent: nothing to "
            "identify",
            (diagnose() if diagnose is not None else "") or "give the log of the whole descent",
        )
    # the descent rate early (after the apogee's turn-over) against the fastest steady rate the
    # stated canopies allow, and late (before the lowest point) against the slowest: a unit
    # mistake scales both alike; a canopy that did not open, or one the user did not state,
    # moves only one of them
    if altitude_unit is None:  # the format states its unit: no unit to mistake
        return
    cds = [c.stated_cds for c in (plan.drogue, plan.main) if c is not None and c.stated_cds]
    low = float(np.min(ha))
    k = int(np.argmax(ha <= low + 0.05 * (apogee[1] - low)))  # first near the ground (or end)
    t_lo = ta[k]
    span = t_lo - ta[0]
    if not cds or span < 20.0:
        return
    early = (ta >= ta[0] + 3.0) & (ta <= ta[0] + min(33.0, 0.5 * span))
    late = (ta >= t_lo - 3.0 - min(30.0, 0.3 * span)) & (ta <= t_lo - 3.0)
    if early.sum() < 5 or late.sum() < 5:
        return
    rates, vs = [], []
    for sel, pick in ((early, max), (late, min)):
        r = -float(np.polyfit(ta[sel], ha[sel], 1)[0])
        z = origin + float(np.mean(ha[sel]))
        rates.append(r)
        vs.append(pick(steady_rate(plan.mass, c, z) for c in cds))
    ratios = [r / v for r, v in zip(rates, vs)]
    lo, hi = _UNIT_RATIO
    said = (
        f"the log descends at {rates[0]:.1f} m/s after the apogee and {rates[1]:.1f} m/s before "
        f"its lowest point (altitude read in {altitude_unit}): {ratios[0]:.2f} × and "
        f"{ratios[1]:.2f} × the steady rates the stated mass ({plan.mass:g} kg) and drag areas "
        f"give there ({vs[0]:.1f} and {vs[1]:.1f} m/s)"
    )
    if all(lo < q < hi for q in ratios) and altitude_unit != "ft":
        raise _err(
            "altitude unit",
            said,
            "the altitude looks like feet read as metres: give --altitude-unit ft (or check the "
            "mass and the drag areas)",
        )
    if all(1 / hi < q < 1 / lo for q in ratios) and altitude_unit == "ft":
        raise _err(
            "altitude unit",
            said,
            "the altitude looks like metres read as feet: give --altitude-unit m (or check the "
            "mass and the drag areas)",
        )


def check_trigger(level: float, apogee: tuple[float, float], altitude_unit: str | None) -> str:
    """Why a trigger height ``level`` (m above the pad) is never reached, '' if it can be."""
    if level < apogee[1]:
        return ""
    text = (
        f"the trigger was never reached: the main's trigger height ({level:.0f} m above the pad) "
        f"is above the apogee ({apogee[1]:.0f} m)"
    )
    if altitude_unit == "ft" and apogee[1] / FT > level:
        text += "; with the altitude in metres (not feet) the apogee would be above it"
    return text
