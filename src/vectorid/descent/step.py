"""One phase of a descent as one identification step of the PSI method: the study file of
the phase (one drag area, two pure criteria whose limits are the noise floors plus the
discrepancy allowance), its run, and its result in the units a person reads."""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from typing import Any

import numpy as np

from vectorid.analysis.identifiability import identifiability
from vectorid.descent.bounds import monotone_rate_bound
from vectorid.descent.events import detect_rate_change
from vectorid.descent.phases import _cds_estimate, _effective_cds, _Phase
from vectorid.descent.plan import PhaseLimits, _err, _noise_table, discrepancy
from vectorid.descent.result import PhaseResult
from vectorid.descent.sensors import _fast_error, _sensor_disagreement
from vectorid.descent.varying import drag_along
from vectorid.identify.identification import Identification
from vectorid.identify.noise import ComponentNoise, estimate_correlated, estimate_sigma
from vectorid.spec import StudySpec
from vectorid.store import Store
from vectorid.workflows.twostep import run_step

__all__: list[str] = []


def _spec_dict(plan, path, name, ph: _Phase, origin, events, box, nominal, extra_vars, fixed, T,
               allow, noise):  # fmt: skip
    drop: dict[str, Any] = {
        "name": ph.name,
        "file": str(path),
        "window": [ph.t0, ph.t1],
        "inputs": {"main": ph.main_input},
        "origin_altitude": origin,
        "events": dict(events),
        # the criteria compare the altitude alone: other channels (a GPS that stops before
        # touchdown) do not bound the window
        "channels": ["altitude"],
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


def _run_phase(
    plan, path, name, ph: _Phase, t, h, origin, events, out, drogue_res, progress, flight_channels
):
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
    along = drag_along(
        ts, hs, ph.t0, ph.t1, mass=plan.mass, origin=origin,
        noise_sigma=res.noise_sigma_m or 0.0,
    )  # fmt: skip
    if along is not None:
        res.drag_along = along.to_dict()
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
        rel_se = _noise_rel_se(noise, ts) if plan.noise == "estimate" else 0.0
        res.edge_band = _edge_band(a, j, res.limits, T, rel_se)
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
    if along is not None and along.varies:
        # the data say the drag area is not constant: no single value, and the range printed
        # covers what the sub-windows span as well as the constant-drag feasible range
        lo, hi = along.low, along.high
        if res.cds_feasible is not None:
            lo, hi = min(lo, res.cds_feasible[0]), max(hi, res.cds_feasible[1])
        res.cds_range = (lo, hi)
        res.best_cds = res.cds if res.best_cds is None else res.best_cds
        res.cds = None
    if res.status != "identified":  # a range, not a value
        res.best_cds = res.cds if res.best_cds is None else res.best_cds
        res.cds = None
    if along is not None and along.varies:
        res.status = "varies"  # no single value: never "identified"
    if "gps_altitude" in flight_channels:
        res.sensor_disagreement_m = _sensor_disagreement(flight_channels, ph.t0, ph.t1)
        res.fast_error = _fast_error(flight_channels, ph.t0, ph.t1)
    return res


def _noise_rel_se(noise, t) -> float:
    """Relative standard error of a noise σ estimated from the window's samples ``t`` (0 for
    a stated noise): 1 / sqrt(2 n_eff), n_eff the effectively independent samples, the window
    over max(sample step, the noise's correlation time τ) — the sample variance of a
    Gauss–Markov series over T has a relative variance of about 2 τ / T."""
    if not (isinstance(noise, Mapping) and "altitude" in noise) or t.size < 3:
        return 0.0
    alt = noise["altitude"]
    tau = float(alt.get("correlation_time", 0.0)) if isinstance(alt, Mapping) else 0.0
    step = float(np.median(np.diff(t)))
    n_eff = max(2.0, (t[-1] - t[0]) / max(step, tau))
    return 1.0 / math.sqrt(2.0 * n_eff)


def _edge_band(a, j: int, lim: PhaseLimits, T: float, rel_se: float) -> tuple[float, float]:
    """How well each edge of the feasible range of variable ``j`` is known, m² (low, high).

    The edge lies between the outermost feasible trial and the nearest infeasible trial beyond
    it (their gap), and moves with the limits: each limit's noise floor rests on a noise σ
    estimated with the relative standard error ``rel_se``, and a change δL of the limit moves
    the edge by δL / |dΦ/dx| (the criterion's slope there, from the trials nearest the edge,
    for the criterion that cuts that edge). The band is the gap plus twice that movement."""
    X = a.trials.X[:, j]
    F = a.trials.F[:, :2]
    ok = a.ok & np.all(np.isfinite(F), axis=1)
    feas = a.feasible & ok
    # each criterion's limit in its own unit, and its standard error
    lims = np.array([T * lim.alt_rms**2, T * lim.vz_mean_abs])
    d_lims = np.array(
        [T * 2.0 * lim.alt_rms * lim.floor_alt_rms * rel_se, T * lim.floor_vz_mean_abs * rel_se]
    )
    out = []
    for edge, side in ((float(X[feas].min()), -1.0), (float(X[feas].max()), 1.0)):
        beyond = ok & ~feas & (side * (X - edge) > 0)
        if not beyond.any():  # D reaches the box: the verdict says so; no edge to judge
            out.append(0.0)
            continue
        k = np.flatnonzero(beyond)[np.argmin(np.abs(X[beyond] - edge))]
        gap = abs(float(X[k]) - edge)
        c = int(np.argmax(F[k] / np.where(lims > 0, lims, np.inf)))  # the cutting criterion
        near = np.flatnonzero(ok)[np.argsort(np.abs(X[ok] - edge))[:10]]
        move = 0.0
        if near.size >= 3 and np.ptp(X[near]) > 0:
            slope = float(np.polyfit(X[near], F[near, c], 1)[0])
            if slope != 0.0:
                move = float(d_lims[c]) / abs(slope)
        out.append(gap + 2.0 * move)
    return out[0], out[1]


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
    sim = -res.position[0, :n, 2]  # relative to the drop's origin, as the data
    meas = d.measured("altitude")[:n, 0]
    return sim, meas


def _alt_rms(ident, d, x) -> float:
    sim, meas = _sim_alt(ident, d, x)
    return float(np.sqrt(np.mean((sim - meas) ** 2)))


def _vz_rms(ident, d, x) -> float:
    sim, meas = _sim_alt(ident, d, x)
    e = np.gradient(sim, ident.output_dt) - np.gradient(meas, ident.output_dt)
    return float(np.sqrt(np.mean(e**2)))
