"""Data of the study overview: definition (with units), stages and boxes, failures by
reason, timing and the run log; and the trial shown first."""

from __future__ import annotations

import math
import time
from typing import Any

from ...analysis.choice import best_per_criterion, suggest_choice
from ...analysis.refine import refine_history
from .context import UIContext, fmt, limit_source_of, num

__all__ = ["initial_choice", "overview_view"]


def overview_view(ctx: UIContext) -> dict[str, Any]:
    """Study definition, stages and boxes, failures by reason, timing and the run log.

    Returns
    -------
    dict
        ``study`` (key/value rows), ``variables``, ``criteria``, ``constraints``, ``stages``,
        ``boxes`` (variable rows, a low..high column per sample stage), ``failures``
        (reason, count, example trial), ``runs`` and ``timing`` (text).
    """
    from ...run.loop import group_failures

    _, t, stages = ctx.cache.state()  # first: it re-reads a definition saved meanwhile
    spec = ctx.spec
    d = spec.to_dict()["study"]
    study = [{"key": k, "value": str(v)} for k, v in d.items()]
    study.append({"key": "store", "value": str(ctx.cache.path)})
    variables = [
        {
            "name": v.name,
            "kind": v.kind,
            "low": num(v.low),
            "high": num(v.high),
            "nominal": num(ctx.labels.nominal.get(v.name)),
            "unit": v.unit or "",
            "meaning": ctx.labels.meaning.get(v.name, ""),
        }
        for v in spec.space
    ]
    criteria = [
        {
            "name": c.name,
            "sense": c.sense,
            "role": c.role,
            "limit": num(c.limit),
            "unit": ctx.labels.unit.get(c.name, ""),
            "limit source": limit_source_of(c),
            "meaning": ctx.labels.meaning.get(c.name, ""),
        }
        for c in spec.criteria
    ]
    constraints = [
        {
            "name": c.name,
            "low": num(c.low),
            "high": num(c.high),
            "unit": ctx.labels.unit.get(c.name, ""),
        }
        for c in spec.constraints
    ]
    with ctx.cache.open() as st:
        counts = {s.stage: st.count(s.stage) for s in stages}
        runs = st.runs()
        hist = {h["stage"]: h for h in refine_history(st)}
    stage_rows = []
    for s in stages:
        changed = hist.get(s.stage, {}).get("changed", [])
        stage_rows.append(
            {
                "stage": s.stage,
                "kind": s.kind,
                "start_seq": s.start_seq,
                "trials": counts.get(s.stage, 0),
                "created": time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(s.created)),
                "note": s.note,
                "box changes": "; ".join(
                    f"{c['name']} [{fmt(c['old'][0])}, {fmt(c['old'][1])}] → "
                    f"[{fmt(c['new'][0])}, {fmt(c['new'][1])}]"
                    for c in changed
                ),
            }
        )
    boxes = []
    sample = [s for s in stages if s.kind == "sample"]
    for j, v in enumerate(spec.space):
        row: dict[str, Any] = {"name": v.name}
        for s in sample:
            var = s.space.variables[j]
            row[f"stage {s.stage}"] = f"[{fmt(var.low)}, {fmt(var.high)}]"
        boxes.append(row)
    # grouped by reason; each shown with the real message of its first trial (no masked digits)
    ids = {(int(s), int(q)): int(i) for s, q, i in zip(t.stage, t.seq, t.id)}
    failures = [
        {"reason": g.message, "count": g.count, "example trial": g.trial}
        for g in group_failures(t.messages, ids)
    ]
    n_failed = int((t.status != 0).sum())
    if n_failed and not failures:
        failures = [{"reason": "(no message stored)", "count": n_failed, "example trial": None}]
    run_rows = []
    total = 0.0
    for r in runs:
        dur = None if r["finished"] is None else r["finished"] - r["started"]
        total += dur or 0.0
        run_rows.append(
            {
                "run": r["run"],
                "started": time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(r["started"])),
                "duration, s": num(dur),
                "executor": f"{r['executor']} × {r['workers']}",
                "target": r["target"],
                "outcome": r["outcome"],
            }
        )
    cpu = float(t.wall.sum()) if len(t) else 0.0
    timing = (
        f"{len(t)} sample trials; model time {cpu:.3g} s in all, "
        f"{(cpu / len(t) if len(t) else math.nan):.3g} s per trial; runs took {total:.3g} s "
        f"of wall time ({len(t) / total if total > 0 else math.nan:.0f} trials/s)"
    )
    return {
        "study": study,
        "variables": variables,
        "criteria": criteria,
        "constraints": constraints,
        "stages": stage_rows,
        "boxes": boxes,
        "failures": failures,
        "n_failed": n_failed,
        "runs": run_rows,
        "timing": timing,
    }


def initial_choice(ctx: UIContext) -> int | None:
    """The trial to show first: the suggested choice (Pareto trial nearest the ideal point),
    else the best trial of the first criterion, else None."""
    a = ctx.cache.analysis()
    s = suggest_choice(a)
    if s is None:
        best = best_per_criterion(a, feasible_only=False)
        s = next(iter(best.values()), None)
    return s
