"""The "Identifiability" section of the HTML report (and, later, of the UI): which design
variables the data determine, within what range, and where each criteria constraint came from.

:func:`identifiability_html` returns an HTML fragment (tables, no figure); the report calls
it with the analysis it already holds. Numbers come from
:func:`vectorid.analysis.identifiability.identifiability`.
"""

from __future__ import annotations

import html
from collections.abc import Mapping, Sequence
from typing import Any

from ..analysis.combinations import Combination, identifiable_combinations
from ..analysis.identifiability import ParameterVerdict, identifiability
from ..analysis.results import Analysis
from ..builders import variable_meanings

__all__ = [
    "combinations_html",
    "identifiability_html",
    "limits_html",
    "report_section",
    "verdicts_for_report",
]

_COLOURS = {"identified": "#2ca02c", "weak": "#ff7f0e", "not identified": "#d62728"}


def _e(x: Any) -> str:
    return html.escape(str(x))


def _g(v: float) -> str:
    return f"{v:.4g}"


def _span(p: tuple[float, float] | None) -> str:
    return "-" if p is None else f"[{_g(p[0])}, {_g(p[1])}]"


def limits_html(a: Analysis) -> str:
    """A table of the criteria constraints in force: value, unit and where each came from."""
    rows = []
    for j, c in enumerate(a.criteria):
        lo, hi = a.bounds[c.name]
        v = hi if a.senses[j] == "min" else lo
        if abs(v) == float("inf"):
            continue
        same = c.limit is not None and abs(c.limit - v) <= 1e-12 * max(1.0, abs(v))
        src = c.source if same else "this analysis (--limit)"
        note = c.limit_note if same else ""
        side = "<=" if a.senses[j] == "min" else ">="
        rows.append(
            f"<tr><td class=l>{_e(c.name)}</td><td class=l>{_e(a.roles[j])}</td>"
            f"<td>{side} {_g(v)}</td><td class=l>{_e(c.unit)}</td>"
            f"<td class=l>{_e(src)}</td><td class=l>{_e(note)}</td></tr>"
        )
    if not rows:
        return "<p>No criteria constraint is in force.</p>"
    head = "".join(
        f"<th class=l>{h}</th>" for h in ("criterion", "role", "limit", "unit", "source", "note")
    )
    return f"<table><tr>{head}</tr>{''.join(rows)}</table>"


def identifiability_html(
    a: Analysis,
    *,
    verdicts: Sequence[ParameterVerdict] | None = None,
    chosen: Mapping[str, float] | None = None,
    meanings: Mapping[str, str] | None = None,
    stages: Sequence[Any] | None = None,
) -> str:
    """The section's HTML: the limits and their sources, then one row per design variable
    (verdict, feasible and Pareto ranges, box, the constraints that cut it, the chosen value
    only where identified, and what would identify it)."""
    vs = (
        list(verdicts)
        if verdicts is not None
        else identifiability(a, meanings=meanings, stages=stages)
    )
    parts = [
        "<p class=muted>Verdict from the spread of the feasible set D relative to the box "
        "(identified: D spans at most 25 % of it, off its edges; not identified: more than "
        "60 %) and from which constraints' limits cut each range (vectorid.analysis."
        "identifiability). A variable that is not identified has no value: only its range.</p>",
        "<h3>Criteria constraints and their sources</h3>",
        limits_html(a),
        "<h3>Design variables</h3>",
    ]
    head = ("variable", "verdict", "chosen", "feasible", "Pareto", "box", "cut by", "why / to do")
    rows = []
    for v in vs:
        colour = _COLOURS.get(v.verdict, "#222")
        value = (chosen or {}).get(v.name)
        shown = v.value_text(value) if value is not None and v.identified else "-"
        todo = v.reason + (f"; to identify it: {v.suggestion}" if v.suggestion else "")
        rows.append(
            f"<tr><td class=l><b>{_e(v.name)}</b> {_e(v.meaning)}"
            f"{' [' + _e(v.unit) + ']' if v.unit and v.unit != '-' else ''}</td>"
            f"<td class=l style='color:{colour}'><b>{_e(v.verdict)}</b></td>"
            f"<td>{_e(shown)}</td><td>{_span(v.feasible)}</td><td>{_span(v.pareto)}</td>"
            f"<td>{_span(v.box)}</td><td class=l>{_e(', '.join(v.constrained_by) or '-')}</td>"
            f"<td class=l>{_e(todo)}</td></tr>"
        )
    parts.append(
        "<table><tr>"
        + "".join(f"<th class=l>{h}</th>" for h in head)
        + "</tr>"
        + "".join(rows)
        + "</table>"
    )
    return "\n".join(parts)


def verdicts_for_report(a: Analysis, store: Any) -> list[ParameterVerdict]:
    """The verdicts of a stored study, with the model's parameter meanings when it is an
    identification study and the stages' boxes (a refined edge that cuts a range)."""
    return identifiability(a, meanings=variable_meanings(a.spec), stages=store.stages())


def report_section(
    a: Analysis, verdicts: Sequence[ParameterVerdict], chosen_ids: Sequence[int]
) -> str:
    """The report's "Identifiability" section (HTML) for the first chosen trial."""
    import numpy as np

    chosen: dict[str, float] = {}
    if chosen_ids:
        hit = np.flatnonzero(a.trials.id == int(chosen_ids[0]))
        if hit.size:
            chosen = dict(zip(a.spec.space.names, map(float, a.trials.X[hit[0]])))
    return identifiability_html(a, verdicts=verdicts, chosen=chosen)


def combinations_html(
    a: Analysis,
    *,
    combos: Sequence[Combination] | None = None,
    truth: Mapping[str, float] | None = None,
) -> str:
    """The combinations of gains D pins down, as an HTML fragment for the report and the UI's
    verdict panel: one row per identified or weak combination (narrowest first) with its
    loadings on the box-normalised gains, its range over D (in z, widened to hold D's
    boundary), the width as a share of a box side, the verdict, and the reading in the gains'
    own units. Numbers come from
    :func:`vectorid.analysis.combinations.identifiable_combinations`.

    Parameters
    ----------
    a : Analysis
        Trials and the constraints in force.
    combos : sequence of Combination, optional
        Already computed (computed here when None).
    truth : mapping, optional
        A twin's truth (gain -> value in its unit): a column says whether each range holds
        its projection.

    Returns
    -------
    str
        HTML (a paragraph and a table, or a sentence when there is none).
    """
    cs = list(combos) if combos is not None else identifiable_combinations(a)
    intro = (
        "<p class=muted>Directions in the gains, each gain as a share of its box "
        "(z = (x - low)/(high - low)), along which the feasible set D is narrow: the principal "
        "directions of D's weighted members, each kept to the few gains that carry it. Ranges "
        "are in z, widened to hold D's boundary; width as a share of one box side; verdicts "
        "by the same rules as a gain's (vectorid.analysis.combinations).</p>"
    )
    if a.n_feasible < 2:
        return intro + f"<p>D holds {a.n_feasible} member(s): no combination can show a spread.</p>"
    if not cs:
        return intro + "<p>No combination of gains is identified or weak.</p>"
    head = ["combination (z)", "range (z)", "width", "verdict", "in the gains' units"]
    if truth is not None:
        head.append("truth inside")
    rows = []
    for c in cs:
        colour = _COLOURS.get(c.verdict, "#222")
        cells = [
            f"<td class=l>{_e(c.text())}</td>",
            f"<td>{_span(c.range)}</td>",
            f"<td>{c.width_fraction:.1%}</td>",
            f"<td class=l style='color:{colour}'><b>{_e(c.verdict)}</b> {_e(c.reason)}</td>",
            f"<td class=l>{_e(c.own_units_text())}</td>",
        ]
        if truth is not None:
            t = c.value_of(truth)
            cells.append(f"<td>{'yes' if c.range[0] <= t <= c.range[1] else 'NO'} ({_g(t)})</td>")
        rows.append("<tr>" + "".join(cells) + "</tr>")
    return (
        intro
        + "<table><tr>"
        + "".join(f"<th class=l>{h}</th>" for h in head)
        + "</tr>"
        + "".join(rows)
        + "</table>"
    )
