"""Data of the identifiability verdicts and of the limits' sources in the UI.

* :func:`verdicts_of` — each design variable's verdict (identified / weak / not identified),
  feasible and Pareto ranges, the constraints that cut it and what would identify it, under
  the constraints in force, from the same :class:`~vectorid.analysis.Analysis` the other
  views use (:func:`vectorid.analysis.identifiability.identifiability`; about 5 ms at 1e5
  trials and 12 variables and 60 ms at 1e6, memoised per analysis; the transposed
  parameters it reads are kept once per store version);
* :func:`verdict_rows`, :func:`verdict_line`, :func:`chosen_text` — the verdicts as the
  refine view, the explorer and the chosen trial show them: a value only for an identified
  variable, otherwise its feasible range with the verdict, never a lone value;
* :func:`limit_sources` — where each criterion's limit in force comes from: the study's
  noise floor (with its note), the quantile stand-in, the expert, or "this session" when
  the field differs from the limit saved with the study.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from typing import Any

import numpy as np

from ...analysis.identifiability import ParameterVerdict, identifiability
from ...analysis.results import Analysis
from ..labels import relaxed_of
from .context import SOURCE_LABELS, UIContext, analysis_of, fmt
from .data import Constraints

__all__ = [
    "UI_NOTE",
    "chosen_text",
    "identifiability_view",
    "limit_sources",
    "sources_to_save",
    "span",
    "verdict_groups",
    "verdict_line",
    "verdict_rows",
    "verdicts_of",
]

#: The note a limit set in the browser is saved with (``Store.set_limits(sources=...)``).
UI_NOTE = "set in the browser UI"

_MEMO = 8
_LOCK = threading.Lock()


def verdicts_of(ctx: UIContext, a: Analysis) -> list[ParameterVerdict]:
    """The verdict of every design variable under the constraints of ``a`` (memoised per
    analysis: the cache memoises the analysis per constraint set and store version).

    Meanings come from the study's labels (the model's parameter table for an
    identification study); the stages' boxes tell where a refined box, not the data, ends
    a range; a study that inherited a narrowed box says so in its ``[x-identifiability]``
    table (see :func:`~vectorid.analysis.identifiability.identifiability`).
    """
    with _LOCK:  # the server answers requests in threads
        memo: OrderedDict = ctx.extra.setdefault("verdicts", OrderedDict())
        hit = memo.get(id(a))
        if hit is not None and hit[0] is a:
            memo.move_to_end(id(a))
            return hit[1]
        cols = ctx.extra.get("columns")  # the parameters transposed, once per store version
        if cols is None or cols[0] is not a.trials:
            cols = (a.trials, np.ascontiguousarray(a.trials.X.T))
            ctx.extra["columns"] = cols
    _, _, stages = ctx.cache.state()
    meanings = {n: ctx.labels.meaning.get(n, "") for n in a.spec.space.names}
    vs = identifiability(
        a, meanings={k: v for k, v in meanings.items() if v}, stages=stages, columns=cols[1]
    )
    with _LOCK:
        memo[id(a)] = (a, vs)
        while len(memo) > _MEMO:
            memo.popitem(last=False)
    return vs


def span(p: tuple[float, float] | None) -> str:
    """``"[lo, hi]"`` with five significant digits ("-" for an empty set)."""
    return "-" if p is None else f"[{fmt(p[0])}, {fmt(p[1])}]"


def chosen_text(v: ParameterVerdict, value: float | None) -> str:
    """How a chosen vector shows variable ``v``: its value (with D's range) when identified;
    otherwise D's range (or the box) and the verdict, and the trial's own value only after
    them, named as one vector consistent with the data."""
    u = f" {v.unit}" if v.unit and v.unit != "-" else ""
    if v.identified and value is not None:
        return f"{fmt(value)}{u} (feasible {span(v.feasible)})"
    where = "feasible" if v.feasible is not None else "box"
    text = f"{where} {span(v.feasible if v.feasible is not None else v.box)}{u} ({v.verdict})"
    if value is not None:
        text += f"; this trial {fmt(value)}, one value the data allow"
    return text


def verdict_rows(vs: list[ParameterVerdict]) -> list[dict[str, Any]]:
    """One row per design variable: name, meaning, unit, verdict, D's / the Pareto set's /
    the box's ranges (numbers and text), the constraints that cut it, why and what would
    identify it."""
    rows = []
    for v in vs:
        rows.append(
            {
                "name": v.name,
                "meaning": v.meaning,
                "unit": "" if v.unit in ("", "-") else v.unit,
                "verdict": v.verdict,
                "feasible": span(v.feasible),
                "pareto": span(v.pareto),
                "box": span(v.box),
                "ranges": {
                    "box": list(v.box),
                    "feasible": None if v.feasible is None else list(v.feasible),
                    "pareto": None if v.pareto is None else list(v.pareto),
                },
                "width": None if v.width != v.width else round(float(v.width), 4),
                "constrained_by": ", ".join(v.constrained_by) or "-",
                "reason": v.reason,
                "suggestion": v.suggestion,
                "thin": bool(v.thin),
                "n_needed": int(v.n_needed),
            }
        )
    return rows


def verdict_line(vs: list[ParameterVerdict]) -> str:
    """The verdicts in one line: every variable under its verdict with the range of D (the
    box where D is empty), never a value."""
    if not vs:
        return ""
    parts = []
    for verdict in ("identified", "weak", "not identified"):
        names = [
            f"{v.name} {span(v.feasible if v.feasible is not None else v.box)}"
            for v in vs
            if v.verdict == verdict
        ]
        if names:
            parts.append(f"{verdict}: " + ", ".join(names))
    if vs[0].thin:  # too few members of D to show a spread: say so beside the verdicts
        parts.append(
            f"thin: D holds {vs[0].n_feasible} trials, fewer than the {vs[0].n_needed} needed "
            'to show its spread (run more trials, or sampler = "sequential")'
        )
    return "; ".join(parts)


def verdict_groups(vs: list[ParameterVerdict]) -> list[dict[str, Any]]:
    """The verdict panel's groups: identified, weak, not identified (in that order, empty
    ones left out), each variable with D's range (the box's where D is empty), its share of
    the box, its unit and meaning, and why.

    Returns
    -------
    list of dict
        ``verdict``, ``items`` (``name``, ``range`` text, ``unit``, ``meaning``, ``share``
        — D's width over the box's, 0-1, None where D is empty —, ``why``, ``ranges``).
    """
    out = []
    for verdict in ("identified", "weak", "not identified"):
        items = []
        for v in vs:
            if v.verdict != verdict:
                continue
            r = v.feasible if v.feasible is not None else v.box
            items.append(
                {
                    "name": v.name,
                    "range": span(r) if v.feasible is not None else f"none in D (box {span(r)})",
                    "unit": "" if v.unit in ("", "-") else v.unit,
                    "meaning": v.meaning,
                    "share": None if v.width != v.width else round(float(v.width), 3),
                    "why": v.reason + (f"; to identify it: {v.suggestion}" if v.suggestion else ""),
                    "ranges": {
                        "box": list(v.box),
                        "feasible": None if v.feasible is None else list(v.feasible),
                        "pareto": None if v.pareto is None else list(v.pareto),
                    },
                }
            )
        if items:
            out.append({"verdict": verdict, "items": items})
    return out


def limit_sources(ctx: UIContext, a: Analysis, c: Constraints) -> list[dict[str, Any]]:
    """Where each criterion's limit in force comes from.

    A limit equal to the one saved with the study has the saved source (``noise``: the
    noise floor, with its note; ``quantile``: the quantile stand-in; ``expert``); a limit
    typed, dragged or brushed in this page that differs from it is ``session`` ("this
    session", with the saved limit it replaces); no limit is ``none``.

    Returns
    -------
    list of dict
        Per criterion, in the study's order: ``name``, ``kind`` (``noise``, ``quantile``,
        ``relaxed`` — a stand-in saved relaxed as the last resort, D not reached at the
        stated limits —, ``expert``, ``session`` or ``none``), ``label`` (the kind in
        words), ``note``, ``bound`` (e.g. ``"<= 913.66"``, "" for none) and ``text``
        (label and note).
    """
    out = []
    for j, crit in enumerate(a.spec.criteria):
        sense = a.senses[j]
        side = "<=" if sense == "min" else ">="
        lo, hi = a.bounds[crit.name]
        worse = hi if sense == "min" else lo
        value = None if abs(worse) == float("inf") else float(worse)
        saved = crit.limit
        if crit.name in c.limits:
            same = c.limits[crit.name] == saved
        else:  # the field did not parse (or was not sent): the study's limit is in force
            same = True
        bound = "" if value is None else f"{side} {fmt(value)}"
        was = "" if saved is None else f"{side} {fmt(saved)}"
        rel = relaxed_of(crit)
        if same and saved is not None and value is not None and rel is not None:
            # relaxed as the last resort: said first and in full, never a "stand-in"
            kind, label = "relaxed", rel.label()
            note = rel.text(crit.unit).partition("; ")[2]
        elif same and saved is not None and value is not None:
            kind = crit.source or "expert"
            label = SOURCE_LABELS.get(kind, kind)
            note = crit.limit_note
        elif same or (value is None and saved is None):
            kind, label, note = "none", "no limit", ""
        else:
            kind, label = "session", "this session"
            what = (
                rel.label()
                if rel is not None
                else SOURCE_LABELS.get(crit.source or "expert", crit.source)
            )
            note = (
                f"replaces the saved {was} ({what})"
                if saved is not None
                else "no limit is saved with the study"
            )
            if value is None:
                label = "no limit (this session)"
        out.append(
            {
                "name": crit.name,
                "kind": kind,
                "label": label,
                "note": note,
                "bound": bound,
                "text": _join(label, note),
            }
        )
    return out


def _join(label: str, note: str) -> str:
    """``"label: note"``, or the note alone when it starts with the label ("noise floor
    q=0.992 ..." under "noise floor")."""
    if not note:
        return label
    return note if note.lower().startswith(label.lower()) else f"{label}: {note}"


def sources_to_save(ctx: UIContext, a: Analysis, c: Constraints) -> dict[str, tuple[str, str]]:
    """``name -> (limit_source, limit_note)`` for :meth:`Store.set_limits`: a limit still
    equal to the saved one keeps its source and note; one set in this session is the
    expert's, noted as set in the browser UI."""
    out = {}
    for s in limit_sources(ctx, a, c):
        crit = a.spec.criteria[a.crit_names.index(s["name"])]
        if s["kind"] == "session" and s["bound"]:
            out[s["name"]] = ("expert", UI_NOTE)
        elif s["kind"] == "relaxed":
            out[s["name"]] = (crit.limit_source or "quantile", crit.limit_note)
        elif s["kind"] not in ("session", "none"):
            out[s["name"]] = (crit.limit_source or "expert", crit.limit_note)
    return out


def identifiability_view(
    ctx: UIContext, limit_texts: Any, roles: Any, functional: Any = None
) -> dict[str, Any]:
    """The verdicts and the limits' sources under the constraint fields, for the views that
    show them beside other things (the explorer's and the parallel coordinates' verdict
    line, the constraints in force where a brush sets them).

    Returns
    -------
    dict
        ``line`` (:func:`verdict_line`), ``groups`` (:func:`verdict_groups`), ``rows``
        (:func:`verdict_rows`), ``sources``
        (:func:`limit_sources`), ``changed`` (the sources of the limits set in this session)
        and ``counts`` (n, nd, np).
    """
    a, c = analysis_of(ctx, limit_texts, roles, functional)
    vs = verdicts_of(ctx, a)
    sources = limit_sources(ctx, a, c)
    return {
        "line": verdict_line(vs),
        "groups": verdict_groups(vs),
        "rows": verdict_rows(vs),
        "sources": sources,
        "changed": [s for s in sources if s["kind"] == "session"],
        "counts": {"n": a.n, "nd": a.n_feasible, "np": a.n_pareto},
    }
