"""Data of the chosen-trial view: its set, status, criteria against the bounds in force,
parameters against nominal and the box, the spread figure, its stored sections and robustness
checks, and its flight against the measured one (identification studies)."""

from __future__ import annotations

import weakref
from collections.abc import Mapping
from typing import Any

import numpy as np
import plotly.graph_objects as go
from scipy.special import logsumexp

from ...analysis.classes import point_classes
from ...analysis.correlation import parameter_spread
from ...analysis.robustness import load_robustness
from ...analysis.sections import load_sections
from ...errors import VectoridError
from ...samplers.sequential import generations
from .. import figures as fg
from .context import UIContext, analysis_of, fmt, num
from .data import parse_trial_id
from .verdicts import chosen_text, limit_sources, verdict_rows, verdicts_of

__all__ = ["drop_names", "identification_view", "trial_view"]


def trial_view(
    ctx: UIContext,
    trial_text: Any,
    limit_texts: Any,
    roles: Any,
    functional: Any = None,
    overlay: Any = None,
    drop: Any = None,
) -> dict[str, Any]:
    """Details of one sample trial: status, criteria against the constraints in force,
    parameters against nominal (seed 000 Fig. 13), its stored sections and robustness
    checks, and trajectories against the flight data for an identification study.

    Returns
    -------
    dict
        ``id``, ``summary`` (text), ``criteria`` (rows, with where each limit in force came
        from) and ``params`` (rows: the verdict fields of
        :func:`~vectorid.views.ui.verdicts.verdict_rows`, ``value`` — the trial's number —
        and ``shown``, how the page shows it: a value only where identified), ``spread``
        (figure, with D's range per parameter), ``sections`` and ``robustness`` (figures),
        ``robustness_text``, ``identification`` (figure or None), ``identification_note``,
        ``rms`` and ``drops`` (the drops one can fly it over).
    """
    tid = parse_trial_id(trial_text)
    row = ctx.cache.row_of(tid)
    a, c = analysis_of(ctx, limit_texts, roles, functional)
    sources = limit_sources(ctx, a, c)
    t = a.trials
    pc = point_classes(a)
    cls = "Pareto" if pc.pareto[row] else "feasible (in D)" if pc.feasible[row] else "infeasible"
    status = "ok" if t.status[row] == 0 else f"failed: {t.message(row) or 'no message'}"
    summary = (
        f"trial {tid}: {cls}; stage {int(t.stage[row])}, sequence index {int(t.seq[row])}"
        f"{generation_text(ctx, a, row)}; {status}; model time {t.wall[row]:.3g} s"
    )
    crit_rows = []
    for j, name in enumerate(a.crit_names):
        lo, hi = a.bounds[name]
        v = t.F[row, j]
        ok = bool(np.isfinite(v) and lo <= v <= hi)
        crit_rows.append(
            {
                "name": name,
                "sense": a.senses[j],
                "role": a.roles[j],
                "value": num(v),
                "bound": num(hi if a.senses[j] == "min" else lo),
                "unit": ctx.labels.unit.get(name, ""),
                "meets": "yes" if ok else "no",
                "limit source": sources[j]["text"],
            }
        )
    for j, name in enumerate(a.con_names):
        lo, hi = a.bounds[name]
        v = t.G[row, j]
        ok = bool(np.isfinite(v) and lo <= v <= hi)
        crit_rows.append(
            {
                "name": name,
                "sense": "functional",
                "role": f"[{fmt(lo)}, {fmt(hi)}]",
                "value": num(v),
                "bound": None,
                "unit": ctx.labels.unit.get(name, ""),
                "meets": "yes" if ok else "no",
                "limit source": "",
            }
        )
    space = a.spec.space
    x = t.X[row]
    params = []
    vs = verdicts_of(ctx, a)
    lab = ctx.labels
    for j, (v, vr) in enumerate(zip(space, verdict_rows(vs))):
        nom = lab.nominal.get(v.name)
        ident = vs[j].identified
        params.append(
            {
                **vr,
                "value": num(x[j]),
                "shown": chosen_text(vs[j], float(x[j])),
                "nominal": num(nom),
                "relative": num(x[j] / nom, 4) if ident and nom not in (None, 0) else None,
                "low": num(v.low),
                "high": num(v.high),
                "unit": "" if lab.unit.get(v.name, "") in ("", "-") else lab.unit[v.name],
            }
        )
    noms = np.array([np.nan if lab.nominal.get(n) is None else lab.nominal[n] for n in space.names])
    spread = fg.spread_figure(
        parameter_spread(x[None, :], space.names, noms, space.lows, space.highs, [f"trial {tid}"]),
        verdicts=vs,
    )
    with ctx.cache.open() as st:
        sections = [s for s in load_sections(st) if s.trial == tid]
        checks = [r for r in load_robustness(st, a) if r.trial == tid]
    ident, note, rms = identification_view(ctx, tid, x, overlay, drop)
    return {
        "id": tid,
        "summary": summary,
        "criteria": crit_rows,
        "params": params,
        "spread": spread,
        "sections": [fg.section_figure(s, a.bounds) for s in sections],
        "robustness": fg.robustness_figure(checks) if checks else None,
        "robustness_text": [f"stage {r.stage}, radius {r.radius:g}: {r.verdict}" for r in checks],
        "identification": ident,
        "identification_note": note,
        "rms": rms,
        "drops": drop_names(ctx.spec),
    }


def generation_text(ctx: UIContext, a: Any, row: int) -> str:
    """A sequential store's trial: ``"; generation g, importance weight w"`` with ``w``
    relative to the mean weight of D's members (of all trials when D is empty); empty for a
    plain store or a trial outside the generations."""
    t = a.trials
    if a.weighting is None or int(t.stage[row]) != 0:
        return ""
    with ctx.cache.open() as st:
        gens = generations(st)
    seq = int(t.seq[row])
    gen = next((g.gen for g in gens if g.seq_start <= seq < g.seq_start + g.n), None)
    if gen is None:
        return ""
    memo = ctx.extra.setdefault("log_mean_weight", weakref.WeakKeyDictionary())
    if a not in memo:
        ref = a.feasible & (t.stage == 0)
        which = "D's members" if ref.any() else "all trials"
        ref = ref if ref.any() else t.stage == 0
        lw = np.asarray(a.weighting.log_weight(t.X[ref]), float)
        memo[a] = (float(logsumexp(lw) - np.log(len(lw))), which)
    mean, which = memo[a]
    w = float(np.exp(a.weighting.log_weight(t.X[row : row + 1])[0] - mean))
    if a.weighting.kind == "holding":  # a moved store: holding times in D's chains
        if not np.isfinite(mean) or not np.isfinite(w):
            return f"; generation {gen}"
        return f"; generation {gen}, weight {w:.3g} in D (holding time; mean over {which} = 1)"
    return f"; generation {gen}, importance weight {w:.3g} (mean over {which} = 1)"


def overlay_ids(ctx: UIContext, text: Any, tid: int) -> list[int]:
    """The trials to overlay on the chosen one: up to two more ids, comma-separated."""
    out = [tid]
    if text in (None, ""):
        return out
    for part in str(text).replace(";", ",").split(","):
        if part.strip():
            i = parse_trial_id(part.strip(), "overlay trial")
            ctx.cache.row_of(i)
            if i not in out:
                out.append(i)
    if len(out) > 3:
        from ...errors import StudyDefinitionError

        raise StudyDefinitionError(
            "overlay trials",
            f"at most two trials beside the chosen one, got {len(out) - 1}",
            "list one or two ids, e.g. 110, 241",
        )
    return out


def drop_names(spec: Any) -> list[str]:
    """The drops of an identification study, by name, in the study's order (read from the
    study's ``[identification]`` table; no data file is opened); [] for another study."""
    table = spec.extra.get("identification") if isinstance(spec.extra, Mapping) else None
    if not isinstance(table, Mapping):
        return []
    out = []
    for i, d in enumerate(table.get("drops") or []):
        name = d.get("name") if isinstance(d, Mapping) else None
        out.append(str(name) if name else f"drop{i + 1}")
    return out


def identification_view(
    ctx: UIContext, tid: int, x: np.ndarray, overlay: Any = None, drop: Any = None
) -> tuple[go.Figure | None, str, list[dict[str, Any]]]:
    """The chosen trial (and up to two others) simulated over one drop (``drop``, by name;
    the first when None) against the measured flight: position, velocity and attitude over
    time with the RMS per channel component (:func:`vectorid.views.flight.flight_figure`).
    For a study without an ``[identification]`` table: None and a note saying why.

    Returns
    -------
    figure or None, note, RMS rows (one per trial)

    Raises
    ------
    StudyDefinitionError
        When ``drop`` names no drop of the study.
    """
    spec = ctx.spec
    if "identification" not in spec.extra:
        return None, "Not an identification study (no [identification] table): no flight data.", []
    ids = overlay_ids(ctx, overlay, tid)
    names = drop_names(spec)
    if drop not in (None, "") and str(drop) not in names:
        from ...errors import StudyDefinitionError, suggest

        raise StudyDefinitionError("drop", f"no drop named {drop!r}", suggest(str(drop), names))
    try:
        from ...identify.identification import Identification
        from .. import trial_runs as vd
        from ..flight import flight_figure, rms_table

        key = ("ident", ctx.cache.version()[3])
        ident = ctx.extra.get(key)
        if ident is None:
            ident = Identification.from_spec(spec)
            ctx.extra[key] = ident
        from ...identify.system import SystemIdentification

        if isinstance(ident, SystemIdentification):
            return (
                None,
                "this view compares trials with flight drops; a model of your own has records: "
                "`vectorid report` shows them against the best trials",
                [],
            )
        rows = [ctx.cache.row_of(i) for i in ids]
        X = ctx.cache.trials().X[rows]
        want = str(drop) if drop not in (None, "") else ident.drops[0].name
        d = next(dd for dd in ident.drops if dd.name == want)
        runs = vd.simulate_trials(ident, X, d, labels=[f"trial {i}" for i in ids])
    except (VectoridError, OSError, KeyError, StopIteration) as exc:
        return None, f"cannot simulate trial {tid} against the flight: {exc}", []
    idx = list(range(len(ids)))
    fig = flight_figure(
        runs, idx, title=f"Drop {d.name}: flight vs trial " + ", ".join(map(str, ids))
    )
    k = [dd.name for dd in ident.drops].index(d.name) + 1
    note = "" if len(ident.drops) == 1 else f"drop {k} of {len(ident.drops)} ({d.name})"
    return fig, note, rms_table(runs, idx)
