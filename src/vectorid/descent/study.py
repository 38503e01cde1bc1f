"""Identify the drag areas of a rocket's recovery descent from an altimeter log.

A descent under one or two parachutes (a drogue from apogee, a main later; or one canopy) is
cut into phases from the data: the apogee and the touchdown are read from the altitude (not
from a logger's "landed" state), the main's opening from an event of the log, a stated
trigger height or time, or the change of descent rate in the data. Each phase is one
identification step of the PSI method (:func:`vectorid.workflows.twostep.run_step`) on the
point-mass model ``"rocket-descent-cds"`` (:class:`~vectorid.descent.RocketDescentCdS`,
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
(:func:`~vectorid.descent.monotone_rate_bound`) and, in a log with GPS heights, how
much of the barometric residual the GPS does not see.

Each step is a study in its own store (``OUT/NAME-PHASE.db``): ``vectorid info``, ``table``,
``pareto``, ``identifiability`` and ``ui`` work on it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from vectorid.descent.checks import (
    ReadAs,
    check_descent,
    check_drag_magnitude,
    check_time_scale,
    stated_totals,
)
from vectorid.descent.diagnose import suggest_altitude
from vectorid.descent.events import detect_apogee, detect_rate_change, detect_touchdown
from vectorid.descent.formats import column_unit, detect_format
from vectorid.descent.phases import _cds_estimate, _main_trigger, _pad_msl, _Phase, _resolve
from vectorid.descent.plan import DescentPlan, _err
from vectorid.descent.result import DescentResult, PhaseResult
from vectorid.descent.sensors import _height_ratio_se
from vectorid.descent.step import _run_phase, _safe
from vectorid.descent.verdicts import verdict
from vectorid.identify.loaders import load_flight

__all__ = ["BIG_LOG", "identify_descent"]

#: A log whose altitude holds more samples than this is read once: the phases' stores read
#: the part of its altitude they use from a two-column file written beside them.
BIG_LOG = 200_000


def _load(plan: DescentPlan):
    """The log, read as its content says: ``(path, flight, plan with the resolved format and
    mapping, the altitude's unit as read (None: stated by the format), notes, how the time
    and altitude were read (:class:`~vectorid.descent.checks.ReadAs`))``."""

    path = Path(plan.file)
    if not path.exists():
        raise _err("file", f"no such file: {path}", "check the path of the altimeter log")
    path = path.resolve()
    notes: list[str] = []
    documented = False  # the altitude's unit is the one a recognised format documents
    if plan.mapping is not None:
        mapping: dict[str, Any] | None = dict(plan.mapping)
        fmt = plan.format
        alt = mapping.get("altitude")
        if isinstance(alt, str):
            alt = {"column": alt}
            mapping["altitude"] = alt
        if isinstance(alt, Mapping) and "column" in alt:
            stated = column_unit(str(alt["column"]), "length")
            if "unit" not in alt and stated is None:
                raise _err(
                    "mapping.altitude.unit",
                    f"the altitude column {alt['column']!r} states no unit and the mapping gives "
                    "none, and units are never guessed",
                    "add unit = 'm' or 'ft' (the flight's documentation says which)",
                )
            unit = str(alt.get("unit", stated))
            if stated is not None and stated != unit:
                raise _err(
                    "mapping.altitude.unit",
                    f"the column {alt['column']!r} states {stated}, the mapping says {unit}",
                    f"set unit = {stated!r} (or fix the column's name)",
                )
            mapping["altitude"] = {**alt, "unit": unit}
        tcol = mapping.get("time")
        if isinstance(tcol, str) and "time_unit" not in mapping:
            t_stated = column_unit(tcol, "time")
            if t_stated is None:
                raise _err(
                    "mapping.time_unit",
                    f"the time column {tcol!r} states no unit and the mapping gives none "
                    "(time_unit), and units are never guessed",
                    "add time_unit = 's' or 'ms' (or 'iso' for ISO 8601 dates)",
                )
            mapping["time_unit"] = t_stated
    else:
        lf = detect_format(
            path,
            format=plan.format,
            columns=None if plan.columns is None else dict(plan.columns),
            time_unit=plan.time_unit,
            altitude_unit=plan.altitude_unit,
            extra=dict(plan.read),
        )
        fmt, mapping, notes = lf.format, lf.mapping, list(lf.notes)
        documented = lf.named is not None
    # spikes are left out and named once, in the result's notes (not as warnings)
    spikes = "strict" if plan.strict_data else "note"
    if mapping is None and fmt in ("altusmetrum", "telemega"):
        mapping = {}
    if mapping is not None:
        mapping["spikes"] = spikes
    flight = load_flight(path, mapping=mapping, format=fmt)
    if "altitude" not in flight.channels:
        raise _err(
            "mapping",
            f"{path}: the log has no altitude channel (channels: {sorted(flight.channels)})",
            "map the altitude column: altitude = { column = ..., unit = 'm' or 'ft' }",
        )
    unit = None  # None: the format states its own unit
    if mapping is not None and "altitude" in mapping and not documented:
        alt = mapping.get("altitude")
        unit = str(alt.get("unit", "m")) if isinstance(alt, Mapping) else "m"
    notes.extend(f"the log: {n}" for n in flight.notes)
    resolved = replace(plan, format=fmt, mapping=mapping)
    return path, flight, resolved, unit, notes, _read_as(plan, mapping, documented)


def _read_as(plan: DescentPlan, mapping: Mapping[str, Any] | None, documented: bool) -> ReadAs:
    """How the time and altitude columns were read (names, units, where each unit came from)."""

    if not mapping or "time" not in mapping:  # a format that names its own columns
        return ReadAs("time", "s", "format", "altitude", "m", "format")
    alt = mapping.get("altitude")
    acol = str(alt.get("column")) if isinstance(alt, Mapping) else str(alt)
    aunit = str(alt.get("unit", "m")) if isinstance(alt, Mapping) else "m"
    tcol, tunit = str(mapping["time"]), str(mapping.get("time_unit", "s"))

    def source(col: str, kind: str, given: str | None) -> str:
        if plan.mapping is not None:
            return "mapping"
        if documented:
            return "format"
        try:
            if column_unit(col, kind) is not None:
                return "header"
        except ValueError:
            pass
        return "option" if given is not None else "content"

    return ReadAs(
        tcol,
        tunit,
        source(tcol, "time", plan.time_unit),
        acol,
        aunit,
        source(acol, "length", plan.altitude_unit),
    )


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
    return _identify(plan, out, progress)


def _identify(plan: DescentPlan, out: str | Path, progress) -> DescentResult:
    path, flight, plan, altitude_unit, notes, read = _load(plan)
    name = plan.name or path.stem
    origin = _origin_altitude(plan, flight)
    alt = flight["altitude"]
    t, h = alt.t, alt.values[:, 0]
    if plan.end is not None:
        keep = t <= float(plan.end)
        if keep.sum() < 10:
            raise _err(
                "end",
                f"{plan.end:g} s keeps {int(keep.sum())} samples of the log (its altitude data "
                f"cover {t[0]:.2f}-{t[-1]:.2f} s)",
                "a later end, or none",
            )
        t, h = t[keep], h[keep]
    check_time_scale(t, h, read, plan, origin)

    def diagnose() -> str:  # what the other columns say, only when a check fails
        return suggest_altitude(
            path, plan.mapping, read, t, h, mass=plan.mass, origin=origin,
            totals=stated_totals(plan), api=read.time_from == "mapping",
        )  # fmt: skip

    events = {k: float(v) for k, v in flight.events.items()}
    if "apogee" in events:
        apogee = (events["apogee"], float(np.interp(events["apogee"], t, h)))
    else:
        apogee = detect_apogee(t, h)
        events["apogee"] = apogee[0]
    h_agl = h if plan.altitude_reference == "pad" else h - _pad_msl(plan, h)
    check_descent(plan, t, h_agl, (apogee[0], float(np.interp(apogee[0], t, h_agl))), origin,
                  altitude_unit, diagnose)  # fmt: skip
    td = detect_touchdown(t, h, after=apogee[0])
    touchdown = None
    if td is not None:
        events["touchdown"] = td.time
        touchdown = {"time_s": td.time, "ground_m": td.ground, "rate_ms": -td.rate}
        if "landed" in events:
            touchdown["landed_state_s"] = events["landed"]
        tail = td.time - 1.0
    else:
        # no touchdown in the data: the windows end 1 s before the last sample, so that the
        # end of the data decides nothing
        tail = float(t[-1]) - 1.0
    end_of_data = (float(t[-1]), float(h[-1]))
    start = (
        _resolve(events, plan.start, "start")
        if plan.start is not None
        else events.get("drogue", apogee[0])
    )
    if start < apogee[0] - 2.0 and plan.start is None:
        notes.append(
            f"the log's 'drogue' event ({start:.2f} s) comes before the apogee read from the "
            f"data ({apogee[0]:.2f} s): the descent starts at the apogee"
        )
        start = apogee[0]
    apogee_agl = (apogee[0], float(np.interp(apogee[0], t, h_agl)))

    phases: list[_Phase] = []
    skipped: list[PhaseResult] = []
    if plan.drogue is not None and plan.main is not None:
        trig, why = _main_trigger(
            plan, events, t, h, h_agl, start, tail, origin, apogee_agl, altitude_unit
        )
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
        else:
            settle = plan.drogue_settle if ph.name == "drogue" else plan.main_settle
            note = _trim_to_steady(ph, t, h, origin, settle)
            if note:
                notes.append(note)

    _check_selection(plan, phases, t, start, tail, apogee, td is not None)
    for ph in phases:
        lo, hi = float(t[0]), float(t[-1])
        if ph.t0 < lo or ph.t1 > hi:
            was = (ph.t0, ph.t1)
            ph.t0, ph.t1 = max(ph.t0, lo), min(ph.t1, hi)
            notes.append(
                f"the {ph.name} window {was[0]:.2f}-{was[1]:.2f} s is clipped to "
                f"{ph.t0:.2f}-{ph.t1:.2f} s: the altitude data cover {lo:.2f}-{hi:.2f} s"
            )
    if not any(ph.t1 - ph.t0 >= 5.0 for ph in phases):
        # the whole descent first: a unit or a mass orders of magnitude off says so better
        canopy = plan.drogue if plan.drogue is not None else plan.main
        after = np.flatnonzero(t >= apogee[0])
        low = float(t[after[np.argmin(h[after])]]) if after.size else tail
        whole = _Phase("descent", "", canopy, apogee[0], max(low, apogee[0] + 1.0), 0.0)
        said = "descent from the apogee to the lowest point"
        check_drag_magnitude(plan, [_rate_of(whole, t, h, plan, origin, said)], read, diagnose)
        _nothing_to_identify(phases, skipped, diagnose)
    check_drag_magnitude(plan, [_rate_of(ph, t, h, plan, origin) for ph in phases
                                if ph.t1 - ph.t0 >= 5.0], read, diagnose)  # fmt: skip
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    step_plan, step_path = plan, path
    if t.size > BIG_LOG:
        step_plan, step_path, note = _compact_log(plan, name, t, h, phases, events, out)
        notes.append(note)
    results: list[PhaseResult] = []
    drogue_res: PhaseResult | None = None
    for ph in phases:
        r = _run_phase(
            step_plan, step_path, name, ph, t, h, origin, events, out, drogue_res, progress,
            flight.channels,
        )  # fmt: skip
        results.append(r)
        if ph.name == "drogue":
            drogue_res = r
    results.extend(skipped)
    got = _height_ratio_se(flight, start, tail) if plan.altitude_reference == "pad" else None
    ratio = None if got is None else got[0]
    if got is not None:
        for r in results:
            r.height_ratio, r.height_ratio_se = got
        notes.append(
            f"the log's GPS heights gain {ratio:.4f} m per metre of barometric height over the "
            "descent: the air was warmer than ISA by about that ratio (T/T_ISA), and drag areas "
            "identified in ISA air on barometric heights are high by it; they are compared with "
            "the stated ones after dividing by it (cds_corrected)"
        )
    by_name = {r.name: r for r in results}
    for r in results:
        r.verdict, r.summary = verdict(r, by_name, plan)
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


def _compact_log(plan, name, t, h, phases, events, out: Path):
    """The altitude as read (s, m; spikes already left out), over the phases and the events
    with 30 s either side, written to ``OUT/NAME-altitude.csv`` for the phases' stores, which
    would otherwise each read the whole log again; the plan that reads it, and a note."""
    times = [ph.t0 for ph in phases] + [ph.t1 for ph in phases] + list(events.values())
    lo, hi = min(times) - 30.0, max(times) + 30.0
    keep = (t >= lo) & (t <= hi)
    file = (out / f"{_safe(name)}-altitude.csv").resolve()
    with file.open("w", encoding="utf-8") as fh:
        fh.write("time (s),altitude (m)\n")
        np.savetxt(fh, np.column_stack([t[keep], h[keep]]), fmt="%.17g", delimiter=",")
    mapping = {
        "time": "time (s)",
        "time_unit": "s",
        "altitude": {"column": "altitude (m)", "unit": "m"},
        "spikes": "keep",  # left out (and named) when the log was read
    }
    note = (
        f"the log's altitude holds {t.size:,} samples: it was read once, and the phases' stores "
        f"read its {int(keep.sum()):,} samples from {t[keep][0]:.2f} to {t[keep][-1]:.2f} s "
        f"(in s and m, spikes left out) from {file}"
    )
    return replace(plan, format="csv", mapping=mapping), file, note


def _rate_of(ph: _Phase, t, h, plan: DescentPlan, origin: float, name: str = ""):
    """``(name, t0, t1, mean descent rate m/s, drag area m² it implies)`` of a phase's window
    (for :func:`~vectorid.descent.checks.check_drag_magnitude`)."""

    sel = (t >= ph.t0) & (t <= ph.t1)
    if sel.sum() < 3:
        rate = 0.0
    else:
        rate = -float(np.polyfit(t[sel], h[sel], 1)[0])
    mid = 0.5 * (float(np.interp(ph.t0, t, h)) + float(np.interp(ph.t1, t, h)))
    said = name or f"{ph.name} phase"
    return said, ph.t0, ph.t1, rate, _cds_estimate(rate, mid, plan.mass, origin)


def _check_selection(plan, phases, t, start, tail, apogee, landed) -> None:
    """Stop on a selection that leaves nothing: a start at or after the end of the descent, a
    window given by hand that is empty or outside the data."""
    end = "1 s before the touchdown read from the data" if landed else "1 s before the log ends"
    if isinstance(plan.start, int | float):
        said = f"{start:g} s"
    else:
        said = f"{plan.start!r} ({start:.2f} s)"
    if plan.start is not None and start >= tail:
        raise _err(
            "start",
            f"{said} is at or after the end of the descent the phases can "
            f"use ({tail:.2f} s, {end}; the altitude data cover {t[0]:.2f}-{t[-1]:.2f} s)",
            f"give a start between the apogee ({apogee[0]:.2f} s) and {tail:.2f} s, or leave it "
            "out (the log's drogue event, else the apogee)",
        )
    if plan.start is not None and start < apogee[0] - 2.0:
        raise _err(
            "start",
            f"{said} is before the apogee read from the data "
            f"({apogee[0]:.2f} s): a phase from there would hold the climb, which no canopy "
            "flies",
            f"give a start after the apogee (up to {tail:.2f} s), or leave it out",
        )
    lo, hi = float(t[0]), float(t[-1])
    for ph in phases:
        if ph.name not in plan.windows:
            continue
        w = plan.windows[ph.name]
        if ph.t1 <= ph.t0:
            raise _err(
                f"windows.{ph.name}",
                f"{list(w)!r} is {ph.t0:.6g}-{ph.t1:.6g} s: it ends before it starts",
                "give [start, end] with the start first",
            )
        if ph.t1 <= lo or ph.t0 >= hi:
            raise _err(
                f"windows.{ph.name}",
                f"{list(w)!r} is {ph.t0:.6g}-{ph.t1:.6g} s, outside the altitude data "
                f"({lo:.2f}-{hi:.2f} s)",
                "give a window inside the log",
            )


def _nothing_to_identify(phases, skipped, diagnose) -> None:
    """Stop: no phase has a window of at least 5 s, and a result without a single phase to
    identify is not an answer."""
    why = [
        f"the {ph.name} phase's window {ph.t0:.2f}-{ph.t1:.2f} s is "
        + ("empty" if ph.t1 <= ph.t0 else f"only {ph.t1 - ph.t0:.2f} s long")
        for ph in phases
    ] + [f"the {r.name} phase has no data ({r.verdict})" for r in skipped]
    extra = diagnose()
    raise _err(
        "phases",
        "nothing to identify: " + "; ".join(why) + " (each phase needs at least 5 s of descent)",
        extra
        or "check --start, --end, the windows and the triggers against the log's events "
        "and the altitude column",
    )


def _trim_to_steady(ph: _Phase, t, h, origin: float, settle: float) -> str:
    """Move a phase window's edge past a change of drag area (×1.5 or more) in its first or
    last 35 %: a canopy still opening at its start, the next canopy (or its ejection) at its
    end. A change in the middle stays: the verdicts report it. Returns a note, '' if none."""

    span = ph.t1 - ph.t0
    if span < 30.0:
        return ""
    rc = detect_rate_change(t, h, ph.t0, ph.t1, origin_altitude=origin, min_ratio=1.5)
    if rc is None:
        return ""
    was = (ph.t0, ph.t1)
    if rc.time - ph.t0 < 0.35 * span and ph.t1 - (rc.time + settle) >= 20.0:
        ph.t0 = rc.time + settle
        where = "starts"
    elif ph.t1 - rc.time < 0.35 * span and rc.time - 1.0 - ph.t0 >= 20.0:
        ph.t1 = rc.time - 1.0
        where = "ends"
    else:
        return ""
    edge = ph.t0 if where == "starts" else ph.t1
    return (
        f"the {ph.name} window {was[0]:.2f}-{was[1]:.2f} s {where} at {edge:.2f} s "
        f"instead: the descent rate steps there (drag area ×{rc.drag_area_ratio:.2f} at "
        f"{rc.time:.2f} s, {rc.altitude:.0f} m), and a phase is one constant drag area"
    )
