"""Plausibility of a descent log against what the user states: the checks that stop a run
whose numbers would be silently wrong, with a message naming the likely mistake.

- a log whose altitude hardly changes (a wrong column, a flat log);
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
    # the early descent rate (after the apogee's turn-over, before any main) against the
    # fastest steady rate the stated canopies allow
    k = int(np.argmin(ha))
    t_end = min(ta[0] + 3.0 + 30.0, ta[0] + 0.5 * (ta[k] - ta[0]))
    sel = (ta >= ta[0] + 3.0) & (ta <= t_end)
    if sel.sum() < 5 or t_end - ta[0] < 8.0:
        return
    rate = -float(np.polyfit(ta[sel], ha[sel], 1)[0])
    cds = [c.stated_cds for c in (plan.drogue, plan.main) if c is not None and c.stated_cds]
    if not cds or rate <= 0:
        return
    z = origin + float(np.mean(ha[sel]))
    fast = max(steady_rate(plan.mass, c, z) for c in cds)
    unit = altitude_unit or "the log's own unit"
    span_s = f"{ta[0] + 3.0:.0f}-{t_end:.0f} s"
    if _UNIT_RATIO[0] * fast < rate < _UNIT_RATIO[1] * fast and altitude_unit != "ft":
        hint = (
            "the altitude looks like feet read as metres: give --altitude-unit ft"
            if altitude_unit == "m"
            else f"check the altitude unit ({unit})"
        )
        raise _err(
            "altitude unit",
            f"the log descends at {rate:.1f} m/s over {span_s} (altitude read in {unit}), "
            f"{rate / fast:.2f} × the fastest steady rate the stated mass ({plan.mass:g} kg) "
            f"and drag areas allow there ({fast:.1f} m/s)",
            f"{hint} (or check the mass and the drag areas)",
        )
    if fast / _UNIT_RATIO[1] < rate < fast / _UNIT_RATIO[0] and altitude_unit == "ft":
        raise _err(
            "altitude unit",
            f"the log descends at {rate:.2f} m/s over {span_s} (altitude read in ft), "
            f"{fast / rate:.2f} × slower than the stated mass ({plan.mass:g} kg) and drag areas "
            f"give there ({fast:.1f} m/s): the altitude looks like metres read as feet",
            "leave --altitude-unit ft out (or check the mass and the drag areas)",
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
