"""Plausibility of a descent log against what the user states: the checks that stop a run
whose numbers would be silently wrong, with a message naming the likely mistake.

- a log whose altitude hardly changes (a wrong column, a flat log);
- a log that starts at rest far from 0 m with the altitude said to be above the pad (an
  altitude above sea level);
- a descent rate that the stated mass and canopies cannot give by a factor near 3.28 (an
  altitude in feet read as metres, or the other way round);
- a trigger before the apogee, or above it.
"""

from __future__ import annotations

import math

import numpy as np

from vectorid.descent.plan import G0, DescentPlan, _err

__all__ = ["check_descent", "steady_rate"]

FT = 0.3048
#: A measured descent this many times faster (or slower) than the stated canopies allow, with
#: a factor near 1/0.3048 = 3.28 between, is a unit mistake rather than a wrong drag area.
_UNIT_RATIO = (2.3, 5.0)


def steady_rate(mass: float, cds: float, altitude_msl: float) -> float:
    """Steady descent rate sqrt(2 m g / (ρ C_D S)) in ISA air at ``altitude_msl`` (m), m/s."""
    from vectorid.models.atmosphere import ISA

    rho = float(ISA().density(altitude_msl))
    return math.sqrt(2.0 * mass * G0 / (rho * cds))


def check_descent(
    plan: DescentPlan,
    t: np.ndarray,
    h: np.ndarray,
    apogee: tuple[float, float],
    origin: float,
    altitude_unit: str | None,
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
    """
    span = float(np.ptp(h)) if h.size else 0.0
    if span < 10.0:
        raise _err(
            "log",
            f"the altitude changes by only {span:.3g} m over the whole log "
            f"({t[0]:.2f}-{t[-1]:.2f} s): there is no descent in it",
            "check that the altitude column is the height (--columns altitude=COL)",
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
            "give the log of the whole descent",
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
