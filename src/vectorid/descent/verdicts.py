"""The verdict of each phase in words: agreement with the stated drag area (only when the
stated value lies inside the printed range, or within the stated ±15 % tolerance, said as
such), or the specific reason why not (the main did not open, a main-sized canopy, a descent
rate that does not fit the stated value, an empty feasible set and what empties it).

One story per phase: the long verdict is printed under the phase's lines
(:meth:`DescentResult.format_text`), which already give the window, the descent rate, the
limits, the ranges, the best fit and the stated value with its residual; it refers to those
("above") and adds only what they do not say (ratios, rates the stated value would give,
where the drag area changes), so each number is printed once. The short form is a table
cell of its own, with its numbers, each once as well."""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from vectorid.descent.plan import AGREEMENT, RMS_GOAL, DescentPlan
from vectorid.descent.result import PhaseResult

__all__ = ["stated_position", "verdict"]


def stated_position(r: PhaseResult) -> tuple[str, float, float] | None:
    """Where the stated drag area lies against the printed feasible range, with each edge's
    band (:attr:`PhaseResult.edge_band`, widened by twice the hot-day ratio's standard error
    where the range is corrected): ``("inside" | "edge" | "outside", lo, hi)`` of the range
    as compared (m²), None without a stated value or a range.

    ``"edge"``: within an edge's band on either side — the trials' spacing and the noise
    estimate's error cannot tell on which side of the edge it lies. Where the drag area varies
    along the phase, the range printed covers the sub-windows' drag areas too
    (:attr:`PhaseResult.cds_range`): an edge set by a sub-window is known to twice its σ."""
    if r.stated_cds is None or (r.cds_feasible is None and r.cds_range is None):
        return None
    k = r.height_ratio or 1.0
    band = list(r.edge_band or (0.0, 0.0))
    rng = r.cds_feasible
    if r.cds_range is not None:
        rng = r.cds_range
        da = r.drag_along or {}
        cds, sig = da.get("cds") or [], da.get("sigma") or []
        for i, edge in enumerate(rng):
            if cds and (r.cds_feasible is None or edge != r.cds_feasible[i]):
                j = int(np.argmin(np.abs(np.asarray(cds) - edge)))
                band[i] = 2.0 * float(sig[j])
    assert rng is not None
    lo, hi = rng[0] / k, rng[1] / k
    u_lo, u_hi = ((b / k) for b in band)
    if r.height_ratio and r.height_ratio_se:
        rel = 2.0 * r.height_ratio_se / k
        u_lo, u_hi = u_lo + rel * lo, u_hi + rel * hi
    x = r.stated_cds
    if lo + u_lo <= x <= hi - u_hi:
        return "inside", lo, hi
    if lo - u_lo <= x <= hi + u_hi:
        return "edge", lo, hi
    return "outside", lo, hi


def verdict(
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
            what = "an altitude RMS (above) over its limit"
            short.append(f"D empty ({crit}: {r.best_alt_rms_m:.1f} > {lim.alt_rms:.1f} m RMS)")
        else:
            what = (
                f"a mean vertical-speed residual of at least {r.best_vz_mean_abs_ms:.2f} m/s, "
                "over its limit"
            )
            short.append(
                f"D empty ({crit}: {r.best_vz_mean_abs_ms:.2f} > {lim.vz_mean_abs:.2f} m/s)"
            )
        parts.append(
            f"no drag area keeps the model within the criteria constraints ({crit} empties "
            f"D): the best fit leaves {what}"
        )
    shared = (r.identifiability or {}).get("verdict", r.status)
    if not empty and shared in ("weak", "not identified") and r.cds_feasible is not None:
        lo, hi = r.cds_feasible
        parts.append("the data bound the drag area only to the feasible range above")
        short.append(f"{shared}: {lo:.3g}-{hi:.3g} m²")
    value = r.compared_cds
    stated = r.stated_cds
    label = "identified" if r.cds is not None else "the best fit"
    corrected = " (hot-day corrected)" if r.height_ratio else ""
    if stated is not None and value is not None:
        ratio = value / stated
        pct = f"{100 * (ratio - 1):+.0f} %"
        # the value and the stated one are printed above; a hot-day corrected value is not
        shown = f" {value:.4g} m²{corrected}" if corrected else ""
        what = f"{label}{shown} is {ratio:.2f} × the stated value"
        dro = by_name.get("drogue")
        dval = None if dro is None else dro.compared_cds
        under = None
        if r.name == "main" and dval:
            under = value + (dval if plan.convention == "adds" else 0.0)
        # a drag area the data do not identify: the stated value is judged by D's range
        k = r.height_ratio or 1.0
        rng = r.cds_feasible if (r.cds is None and not empty) else None
        sp = stated_position(r)
        pos = None if sp is None else sp[0]
        r.stated_position = pos
        inside = rng is not None and pos == "inside"
        at_edge = pos == "edge"
        edge_words = (
            "at the edge of the feasible range{}: closer to an edge than the edge is known "
            "(the trials' spacing there and the error of the noise estimate"
            + (" and of the hot-day ratio" if r.height_ratio else "")
            + "), so the data neither confirm nor exclude it"
        )

        def the_range(v) -> str:  # the feasible range: printed above, unless corrected
            return f" {v[0] / k:.4g}-{v[1] / k:.4g} m²{corrected}" if corrected else " (above)"

        over = (
            r.stated_alt_rms_m is not None
            and r.limits is not None
            and r.stated_alt_rms_m > r.limits.alt_rms
        )
        if inside and abs(ratio - 1) > AGREEMENT:
            parts.append(
                f"the data do not exclude the stated value: it lies inside the feasible "
                f"range{the_range(rng)}"
            )
            short.append("stated value inside the feasible range")
        elif rng is not None and at_edge and abs(ratio - 1) > AGREEMENT:
            parts.append("the stated value lies " + edge_words.format(the_range(rng)))
            short.append("stated value at the edge of the feasible range")
        elif abs(ratio - 1) <= AGREEMENT:
            feas = r.cds_feasible
            in_range = pos == "inside"
            if r.cds is None:  # no value: D empty, or the drag area is not identified
                text = f"{label}{shown} is within the ±15 % tolerance of the stated value ({pct})"
                if rng is not None and at_edge:
                    text += "; the stated value lies " + edge_words.format(the_range(rng))
                parts.append(text)
                short.append(f"{label.removeprefix('the ')} within ±15 % ({pct})")
            elif at_edge:
                parts.insert(
                    0,
                    f"within the ±15 % tolerance of the stated value ({pct}){corrected}, and "
                    "the stated value lies " + edge_words.format(the_range(feas)),
                )
                short.insert(0, f"within ±15 % ({pct}), at the edge of the feasible range")
            elif in_range:
                parts.insert(0, f"agrees with the stated value ({pct}){corrected}: it lies "
                             "inside the feasible range")  # fmt: skip
                short.insert(0, f"agrees ({pct}{', hot-day corrected' if corrected else ''})")
            else:
                text = (
                    f"within the ±15 % tolerance of the stated value ({pct}), but the data "
                    f"exclude the stated value: it lies outside the feasible range"
                    f"{the_range(feas)}"
                )
                if over:
                    text += ", and its altitude RMS (above) is over the limit"
                parts.insert(0, text)
                short.insert(0, f"within ±15 % ({pct}) but outside the feasible range")
        elif under is not None and under < 2.0 * dval:
            total = f", {under:.3g} m²," if plan.convention == "adds" else ""
            parts.append(
                f"the main did not open (or not fully): {what}; the drag area under it{total} "
                f"is {under / dval:.2f} × the drogue phase's {dval:.3g} m²"
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
                f"mean descent rate (above) would be about {v_stated:.1f} m/s with it"
            )
            if rng is not None and at_edge:
                text += "; the stated value lies " + edge_words.format(the_range(rng))
            elif rng is not None:
                text += f"; the stated value lies outside the feasible range{the_range(rng)}"
            if over:
                text += "; the stated value's altitude RMS (above) is over the limit"
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
        where = "within" if rms <= floor else "above"
        near = "close to" if rms <= 1.5 * rb else "well above"
        text = (
            f"residual: the best altitude fit is {where} the noise floor and {near} the least "
            "that any descent whose rate never increases leaves (the bound above)"
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
            said = empty and (r.empty_by or "").startswith("alt_")  # the D-empty clause has it
            what = (
                f"noise floor {floor:.1f} m, no constant drag area < {rb:.1f} m"
                f"{'; baro error not in GPS' if baro else ''}"
            )
            short.append(what if said else f"alt RMS {rms:.1f} m ({what})")
    if r.sensor_disagreement_m is not None and rms is not None and rms > 5.0:
        parts.append(
            f"the log's GPS and barometric heights disagree by {r.sensor_disagreement_m:.1f} "
            "m RMS in this window (beyond a scale factor)"
        )
    da = r.drag_along
    if da is not None and da["varies"]:
        n, w = len(da["cds"]), da["windows"][0][1] - da["windows"][0][0]
        parts.insert(
            0,
            f"drag area changes along the descent (the range above) beyond the noise of the "
            f"descent rate over {n} sub-windows of {w:.0f} s: a constant drag area is not what "
            "the data show, so no single value is given",
        )
        short.insert(0, f"drag area changes along the descent: {da['low']:.3g}-{da['high']:.3g} m²")
    agrees = bool(short) and short[0].startswith("agrees")
    if empty or not agrees:
        if r.rate_change is not None and r.drag_along is None:  # the sub-windows decide
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
