"""Data of the refine view (double tuning): the proposed box under the constraints in force,
its rows (editable), and the per-parameter ranges and histograms with the current and the
proposed box in their own colours."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ...analysis.histograms import histograms
from ...analysis.refine import propose_refine
from ...analysis.results import Analysis
from ...errors import StudyDefinitionError
from .. import clouds
from .context import UIContext, analysis_of, fmt, num
from .data import finite, parse_number
from .verdicts import verdict_line, verdict_rows, verdicts_of

__all__ = ["refine_view"]

#: The current box (grey) and the proposed one (purple, its own colour).
CURRENT_BOX = "#7f7f7f"


def _refine_args(basis: Any, quantile: Any, margin: Any) -> dict[str, Any]:
    if basis not in ("feasible", "pareto"):
        raise StudyDefinitionError("basis", f"expected feasible or pareto, got {basis!r}", "")
    q = parse_number(quantile, "quantile", allow_empty=False, example="0.05")
    mg = parse_number(margin, "margin", allow_empty=False, example="0.1")
    return {"basis": basis, "quantile": q, "margin": mg}


def refine_view(
    ctx: UIContext,
    limit_texts: Any,
    roles: Any,
    basis: Any,
    quantile: Any,
    margin: Any,
    functional: Any = None,
) -> dict[str, Any]:
    """The proposed box (double tuning, :func:`~vectorid.analysis.propose_refine`) under the
    constraints in force: editable rows (old and new bounds per variable, with each
    variable's identifiability verdict), the figure of the old and new box, a summary line,
    and the verdicts under the same constraints
    (:func:`~vectorid.views.ui.verdicts.verdict_rows`: ``verdicts``, and ``verdict_line``)."""
    args = _refine_args(basis, quantile, margin)
    a, _ = analysis_of(ctx, limit_texts, roles, functional)
    _, _, stages = ctx.cache.state()
    prop = propose_refine(a, stages, **args)
    vs = verdicts_of(ctx, a)
    verdict = {v.name: v.verdict for v in vs}
    rows = [
        {
            "name": r["name"],
            "old_low": num(r["old_low"]),
            "old_high": num(r["old_high"]),
            "new_low": finite(r["new_low"]),  # full precision: an unedited row is no override
            "new_high": finite(r["new_high"]),
            "width_ratio": num(r["width_ratio"], 3),
            "unit": ctx.labels.unit.get(r["name"], ""),
            "identifiability": verdict.get(r["name"], ""),
        }
        for r in prop.rows()
    ]
    summary = (
        f"from the {prop.basis} set ({prop.n_basis:,} trials): volume ratio "
        f"{fmt(prop.volume_ratio, 3)}, {prop.feasible_inside:,} of {prop.n_feasible:,} feasible "
        f"trials inside, {prop.pareto_outside:,} Pareto trials outside"
    )
    return {
        "rows": rows,
        "figure": ranges_figure(ctx, a, prop),
        "summary": summary,
        "verdicts": verdict_rows(vs),
        "verdict_line": verdict_line(vs),
    }


def ranges_figure(ctx: UIContext, a: Analysis, prop: Any) -> Any:
    """Per parameter: the histograms of every set on its own scale (as the explorer's), the
    current box (grey) and the proposed box (purple) as shaded intervals."""
    boxes = {}
    for r in prop.rows():
        boxes[r["name"]] = [
            (r["old_low"], r["old_high"], CURRENT_BOX, "current box"),
            (r["new_low"], r["new_high"], clouds.PROPOSED_COLOUR, "proposed box"),
        ]
    fig = clouds.histograms_figure(
        histograms(a),
        labels=ctx.labels,
        boxes=boxes,
        title="Ranges per parameter: sets (share of each set, %), current box (grey), "
        "proposed box (purple)",
        raw=True,
    )
    fig["layout"]["uirevision"] = "refine"
    return fig


def _overrides(
    ctx: UIContext, a: Analysis, stages: Any, args: Mapping[str, Any], rows: Any
) -> dict[str, tuple[float, float]]:
    """Bounds the user edited in the proposal table (rows that differ from the proposal)."""
    prop = propose_refine(a, stages, **args)
    proposed = {r["name"]: (r["new_low"], r["new_high"]) for r in prop.rows()}
    out: dict[str, tuple[float, float]] = {}
    for r in rows or []:
        if not isinstance(r, Mapping):
            continue
        name = ctx.cache.check_name(r.get("name"), "parameter")
        lo = parse_number(r.get("new_low"), f"new low of {name}", allow_empty=False, example="0.3")
        hi = parse_number(r.get("new_high"), f"new high of {name}", allow_empty=False, example="1")
        assert lo is not None and hi is not None
        plo, phi = proposed[name]
        tol = 1e-9 * max(1.0, abs(plo), abs(phi))
        if abs(lo - plo) > tol or abs(hi - phi) > tol:
            if not lo < hi:
                raise StudyDefinitionError(
                    f"box of {name}", f"expected low < high, got {lo:g} .. {hi:g}", "swap them"
                )
            out[name] = (lo, hi)
    return out
