"""Cutting a descent into phases: events named by the user or the log (with +/- offsets),
the main's trigger (an event, a time, a height with a unit, or the change of descent rate in
the data), and what a phase's mean descent rate implies for its drag area."""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from vectorid.descent.checks import check_trigger
from vectorid.descent.events import crossing_time, detect_rate_change
from vectorid.descent.plan import G0, Canopy, DescentPlan, _err, parse_length
from vectorid.models.atmosphere import ISA

__all__: list[str] = []


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
    isa = ISA()
    # clipped to ISA's range: a log read in a wrong unit can put the rocket in space
    rho = float(isa.density(min(max(origin + h_mid, -4999.0), 70999.0)))
    return 2 * mass * G0 / (rho * max(rate, 0.5) ** 2)


@dataclass
class _Phase:
    name: str
    variable: str
    canopy: Canopy
    t0: float
    t1: float
    main_input: float


def _pad_msl(plan: DescentPlan, h) -> float:
    """Altitude of the pad above sea level for a log in MSL altitudes (for trigger heights)."""
    if plan.pad_altitude is not None:
        return float(plan.pad_altitude)
    return float(np.median(h[:20]))


_TIME = re.compile(r"^\s*([-+]?(?:\d+(?:\.\d*)?|\.\d+))\s*s\s*$")
_BARE = re.compile(r"^\s*[-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?\s*$")


def _main_trigger(
    plan, events, t, h, h_agl, start, tail, origin, apogee, altitude_unit=None
) -> tuple[float | None, str]:
    """Time the main is triggered (s), or None and why the main phase has no data.

    The trigger is an event of the log (with +/- seconds), a height with its unit (``870m``,
    ``550ft``), a time with its unit (``204s``; a number from Python is a time in s), or
    ``detect``; a bare number in text is refused (a height or a time?).
    """

    at = plan.main_at
    if at is None:
        if "main" in events:
            tc = float(events["main"])
            _before_apogee(tc, apogee, "the log's 'main' event", altitude_unit)
            return tc, ""
        raise _err(
            "main_at",
            "the log has no 'main' event, so when the main opened is unknown",
            "give it: an event of the log, a trigger height above the pad (870m, 550ft), a "
            "time (204s), or 'detect' (the change of descent rate in the data)",
        )
    text = at.strip() if isinstance(at, str) else None
    if text == "detect":
        rc = detect_rate_change(
            t, h, start + plan.drogue_settle, tail, origin_altitude=origin, min_ratio=2.0
        )
        if rc is None or rc.rate_after >= rc.rate_before:
            return None, (
                "no main opening in the data: no change of descent rate that a main canopy "
                "would make (drag area ×2 or more) after the drogue phase starts"
            )
        return rc.time, ""
    if text is not None and _BARE.match(text):
        raise _err(
            "main_at",
            f"{text} — a height or a time? a trigger needs its unit",
            f"write {text}m or {text}ft (a height above the pad), {text}s (a time), or an event",
        )
    if text is not None and _TIME.match(text):
        tc = float(_TIME.match(text).group(1))
        _before_apogee(tc, apogee, f"the trigger time {text}", altitude_unit)
        return tc, ""
    if text and text[-1].isalpha() and text not in events and text[0] in "+-.0123456789":
        level = parse_length(text, "main_at")
        why = check_trigger(level, apogee, altitude_unit)
        if why:
            return None, why
        tc = crossing_time(t, h_agl, level, after=apogee[0])
        if tc is None:
            return None, (
                f"the trigger was never reached: the main's trigger height ({level:.0f} m above "
                f"the pad) is not crossed before the log ends at {h_agl[-1]:.0f} m above the pad"
            )
        return tc, ""
    tc = _resolve(events, at, "main_at")
    _before_apogee(tc, apogee, f"the trigger {at!r}", altitude_unit)
    return tc, ""


def _before_apogee(tc: float, apogee, what: str, altitude_unit) -> None:
    if tc < apogee[0]:
        hint = (
            "; with --altitude-unit ft on a log in metres the heights read 3.28 × too low"
            if altitude_unit == "ft"
            else ""
        )
        raise _err(
            "main_at",
            f"{what} comes at {tc:.2f} s, before the apogee ({apogee[0]:.2f} s): a main "
            f"opens on the way down{hint}",
            "check the trigger and the altitude unit",
        )
