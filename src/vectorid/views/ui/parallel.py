"""Data of the parallel-coordinates and history views: the figure under the constraints in
force, a brush turned into constraints (criterion axis: its criteria constraint Φ**;
functional axis: its bounds; parameter axis: a sub-box selection), and N/ND/NP against the
number of trials."""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Mapping, Sequence
from typing import Any

from ..history import history, history_figure
from ..parallel import brush_event, parallel_figure
from .context import UIContext, analysis_of, fmt

__all__ = ["brush_to_fields", "history_view", "parallel_view"]


def _ranges(selection: Mapping[str, Any] | None) -> dict[str, list[float]]:
    if selection and selection.get("kind") == "ranges":
        return {k: list(v) for k, v in dict(selection.get("ranges") or {}).items()}
    return {}


def parallel_view(
    ctx: UIContext,
    limit_texts: Any,
    roles: Any,
    functional: Any = None,
    selection: Mapping[str, Any] | None = None,
) -> Any:
    """Parallel coordinates of criteria, functionals and parameters, coloured by set, the
    constraints in force drawn as brushes on their axes."""
    a, _ = analysis_of(ctx, limit_texts, roles, functional)
    fig = parallel_figure(a, lines=ctx.parallel_lines, labels=ctx.labels, ranges=_ranges(selection))
    fig.update_layout(uirevision="parallel")
    return fig


def brush_to_fields(
    ctx: UIContext,
    event: Any,
    names: Sequence[str],
    limit_texts: Sequence[Any],
    lows: Sequence[Any],
    highs: Sequence[Any],
    selection: Mapping[str, Any] | None,
) -> tuple[list[Any], list[Any], list[Any], dict[str, Any] | None, str]:
    """What a brush on the parallel coordinates changes.

    A criterion axis sets that criterion's constraint to the brush's worse-side edge (upper
    for ``min``, lower for ``max``; removing the brush removes the limit); a functional axis
    sets both bounds; a parameter axis adds (or removes) that parameter's range in a sub-box
    selection.

    Returns
    -------
    texts, lows, highs : list
        The constraint fields after the brush.
    selection : dict or None
        The selection after the brush.
    message : str
        What changed, in words.
    """
    spec = ctx.spec
    crit = spec.criterion_names
    cons = spec.constraint_names
    params = spec.space.names
    texts = list(limit_texts) if limit_texts else [""] * len(crit)
    lo_t = list(lows) if lows else [""] * len(cons)
    hi_t = list(highs) if highs else [""] * len(cons)
    ranges = _ranges(selection)
    sel_changed = False
    done = []
    for name, rng in brush_event(event, names).items():
        if name in crit:
            j = crit.index(name)
            sense = spec.criteria[j].sense
            if rng is None:
                texts[j] = ""
                done.append(f"{name}: no limit")
            else:
                v = rng[1] if sense == "min" else rng[0]
                texts[j] = fmt(v)
                done.append(f"{name} {'<=' if sense == 'min' else '>='} {fmt(v)}")
        elif name in cons:
            j = cons.index(name)
            lo_t[j], hi_t[j] = ("", "") if rng is None else (fmt(rng[0]), fmt(rng[1]))
            done.append(
                f"{name}: no bounds" if rng is None else f"{fmt(rng[0])} <= {name} <= {fmt(rng[1])}"
            )
        elif name in params:
            sel_changed = True
            if rng is None:
                ranges.pop(name, None)
                done.append(f"{name}: range removed from the selection")
            else:
                ranges[name] = [rng[0], rng[1]]
                done.append(f"{name} in [{fmt(rng[0])}, {fmt(rng[1])}] selected")
    new_sel: dict[str, Any] | None
    if sel_changed:
        new_sel = {"kind": "ranges", "ranges": ranges} if ranges else None
    else:
        new_sel = dict(selection) if selection else None
    return texts, lo_t, hi_t, new_sel, ("brushed: " + "; ".join(done)) if done else ""


def history_view(ctx: UIContext, limit_texts: Any, roles: Any, functional: Any = None) -> Any:
    """N, ND, NP against the number of trials (memoised per constraint set and store
    version; 4 kept)."""
    a, c = analysis_of(ctx, limit_texts, roles, functional)
    memo: OrderedDict = ctx.extra.setdefault("history", OrderedDict())
    key = (ctx.cache.version(), c.key())
    h = memo.get(key)
    if h is None:
        h = history(a)
        memo[key] = h
        while len(memo) > 4:
            memo.popitem(last=False)
    fig = history_figure(h)
    fig.update_layout(uirevision="history")
    return fig
