"""Data of the trial table: every trial of the chosen set (Pareto, feasible, infeasible, all,
or the selection), filtered, sorted and paged on the server over *all* its trials (never
only the rows shown), and the same rows as CSV.

The filter is the DataTable's ``filter_query`` syntax, as typed in the header cells:
``{f1} s< 0.5 && {x3} s>= 2`` (operators ``<``, ``<=``, ``>``, ``>=``, ``=``, ``!=``, with or
without the ``s`` DataTable prefixes ``s<``/``i<``, and ``eq``/``ne``/``lt``/``le``/``gt``/``ge``);
a clause the parser does not understand is reported, not ignored.
"""

from __future__ import annotations

import csv
import io
import re
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

import numpy as np

from ...analysis.results import Analysis
from ...errors import StudyDefinitionError
from .context import UIContext, analysis_of, num
from .explore import selection_mask

__all__ = ["SETS", "csv_rows", "table_columns", "table_page", "table_rows"]

#: The sets a table can show.
SETS = ("pareto", "feasible", "infeasible", "all", "selection")
_OPS = {
    "<": np.less,
    "<=": np.less_equal,
    ">": np.greater,
    ">=": np.greater_equal,
    "=": np.equal,
    "!=": np.not_equal,
    "lt": np.less,
    "le": np.less_equal,
    "gt": np.greater,
    "ge": np.greater_equal,
    "eq": np.equal,
    "ne": np.not_equal,
}
_CLAUSE = re.compile(
    r"^\s*\{([^}]+)\}\s*(?:[si](?=[<>=!]))?\s*(<=|>=|!=|<|>|=|lt|le|gt|ge|eq|ne)\s*"
    r"\"?([^\"]*?)\"?\s*$"
)


def table_columns(ctx: UIContext) -> list[dict[str, Any]]:
    """Columns: trial id, set, criteria, functionals, parameters (headers with units)."""
    lab = ctx.labels
    spec = ctx.spec
    cols = [
        {"id": "id", "name": "trial", "type": "numeric"},
        {"id": "set", "name": "set", "type": "text"},
        {"id": "stage", "name": "stage", "type": "numeric"},
    ]
    for n in spec.criterion_names + spec.constraint_names + spec.space.names:
        cols.append({"id": n, "name": lab.short(n), "type": "numeric"})
    return cols


def _values(a: Analysis, name: str) -> np.ndarray:
    t = a.trials
    if name == "id":
        return t.id.astype(float)
    if name == "stage":
        return t.stage.astype(float)
    if name in a.crit_names:
        return t.F[:, a.crit_names.index(name)]
    if name in a.con_names:
        return t.G[:, a.con_names.index(name)]
    names = a.spec.space.names
    if name in names:
        return t.X[:, names.index(name)]
    raise StudyDefinitionError(
        "table column", f"unknown column {name!r}", "use the column headers' filter cells"
    )


def _set_codes(a: Analysis) -> np.ndarray:
    code = np.zeros(a.n, np.int8)  # 0 infeasible, 1 feasible, 2 Pareto
    code[a.feasible] = 1
    code[a.pareto] = 2
    return code


_SET_NAMES = np.array(["infeasible", "feasible", "Pareto"])


def table_rows(
    ctx: UIContext,
    a: Analysis,
    which: str,
    selection: Mapping[str, Any] | None = None,
    filter_query: str | None = None,
    sort_by: Sequence[Mapping[str, Any]] | None = None,
) -> np.ndarray:
    """Rows (into the cached trials) of the set ``which`` that pass ``filter_query``, in the
    order of ``sort_by`` (default: Pareto first, then by the first pure criterion, best
    first).

    Raises
    ------
    StudyDefinitionError
        For an unknown set, column, or a filter clause that does not parse.
    """
    if which not in SETS:
        raise StudyDefinitionError("set", f"expected one of {', '.join(SETS)}, got {which!r}", "")
    mask = {
        "pareto": a.pareto,
        "feasible": a.feasible,
        "infeasible": ~a.feasible,
        "all": np.ones(a.n, bool),
    }.get(which)
    if mask is None:
        mask = selection_mask(ctx, a, selection)
    mask = mask.copy()
    for clause in [c for c in (filter_query or "").split("&&") if c.strip()]:
        m = _CLAUSE.match(clause)
        if not m:
            raise StudyDefinitionError(
                "table filter",
                f"cannot read {clause.strip()!r}",
                "type a comparison in a column's filter cell, e.g. < 0.5 or >= 2",
            )
        col, op, text = m.group(1).strip(), m.group(2), m.group(3).strip()
        if col == "set":
            if op not in ("=", "eq", "!=", "ne"):
                raise StudyDefinitionError("table filter", f"set {op} {text}", "use = Pareto")
            hit = _SET_NAMES[_set_codes(a)] == text
            mask &= hit if op in ("=", "eq") else ~hit
            continue
        try:
            value = float(text)
        except ValueError:
            raise StudyDefinitionError(
                "table filter", f"{col}: expected a number, got {text!r}", "e.g. < 0.5"
            ) from None
        v = _values(a, col)
        with np.errstate(invalid="ignore"):
            mask &= _OPS[op](v, value)
    rows = np.flatnonzero(mask)
    keys: list[np.ndarray] = []
    for s in reversed(list(sort_by or [])):  # np.lexsort: the last key is the primary one
        col = str(s.get("column_id"))
        v = _set_codes(a)[rows].astype(float) if col == "set" else _values(a, col)[rows]
        v = np.where(np.isnan(v), np.inf, v)  # NaN (failed) last
        keys.append(-v if s.get("direction") == "desc" else v)
    if not keys:
        j = a.pure[0] if a.pure else 0
        if a.crit_names:
            sign = -1.0 if a.senses[j] == "max" else 1.0
            v = sign * a.trials.F[rows, j]
            keys = [np.where(np.isnan(v), np.inf, v), -_set_codes(a)[rows].astype(float)]
    if keys:
        rows = rows[np.lexsort(keys)]
    return rows


def _records(a: Analysis, rows: np.ndarray, digits: int | None) -> list[dict[str, Any]]:
    t = a.trials
    code = _set_codes(a)
    names = a.spec.space.names
    out = []
    for i in rows:
        r: dict[str, Any] = {
            "id": int(t.id[i]),
            "set": str(_SET_NAMES[code[i]]),
            "stage": int(t.stage[i]),
        }
        for n, v in zip(a.crit_names, t.F[i]):
            r[n] = num(v, digits) if digits else (float(v) if np.isfinite(v) else None)
        for n, v in zip(a.con_names, t.G[i]):
            r[n] = num(v, digits) if digits else (float(v) if np.isfinite(v) else None)
        for n, v in zip(names, t.X[i]):
            r[n] = num(v, digits) if digits else float(v)
        out.append(r)
    return out


def table_page(
    ctx: UIContext,
    limit_texts: Any,
    roles: Any,
    functional: Any,
    which: str,
    selection: Mapping[str, Any] | None,
    page: int,
    page_size: int,
    filter_query: str | None,
    sort_by: Sequence[Mapping[str, Any]] | None,
) -> dict[str, Any]:
    """One page of the trial table.

    Returns
    -------
    dict
        ``data`` (rows of the page), ``page_count``, ``total`` (rows after the filter),
        ``note`` (text) and ``styles`` (set colours: Pareto green, feasible blue,
        infeasible red).
    """
    a, _ = analysis_of(ctx, limit_texts, roles, functional)
    rows = table_rows(ctx, a, which, selection, filter_query, sort_by)
    size = max(1, min(int(page_size or ctx.set_rows), 500))
    pages = max(1, -(-len(rows) // size))
    page = max(0, min(int(page or 0), pages - 1))
    shown = rows[page * size : (page + 1) * size]
    note = (
        f"{len(rows):,} trials in the {which} set"
        + (" after the filter" if filter_query else "")
        + f"; page {page + 1} of {pages}; sorted and filtered over all of them on the server"
    )
    return {
        "data": _records(a, shown, 5),
        "page_count": pages,
        "page": page,
        "total": len(rows),
        "note": note,
    }


#: Row styles of the trial table: the method's colours.
TABLE_STYLES = [
    {"if": {"filter_query": '{set} = "Pareto"'}, "color": "#2ca02c", "fontWeight": 600},
    {"if": {"filter_query": '{set} = "feasible"'}, "color": "#1f77b4"},
    {"if": {"filter_query": '{set} = "infeasible"'}, "color": "#d62728"},
]


def csv_rows(
    ctx: UIContext,
    limit_texts: Any,
    roles: Any,
    functional: Any,
    which: str,
    selection: Mapping[str, Any] | None,
    filter_query: str | None,
    sort_by: Sequence[Mapping[str, Any]] | None,
    chunk: int = 20_000,
) -> Iterator[str]:
    """Every row of the table (set, filter, sort as shown) as CSV text, in chunks, full
    precision, with a header of names and a second header of units; the last two columns
    flag the trials in D (``in_D``) and in the Pareto set (``pareto``), 1 or 0."""
    a, c = analysis_of(ctx, limit_texts, roles, functional)
    rows = table_rows(ctx, a, which, selection, filter_query, sort_by)
    names = ["id", "set", "stage", *a.crit_names, *a.con_names, *a.spec.space.names]
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow([*names, "in_D", "pareto"])
    w.writerow(["", "", "", *[ctx.labels.unit.get(n, "") for n in names[3:]], "", ""])
    yield buf.getvalue()
    for s in range(0, len(rows), chunk):
        buf = io.StringIO()
        w = csv.writer(buf)
        part = rows[s : s + chunk]
        flags = zip(a.feasible[part].astype(int), a.pareto[part].astype(int))
        for r, (d, p) in zip(_records(a, part, None), flags):
            w.writerow(["" if r[n] is None else r[n] for n in names] + [d, p])
        yield buf.getvalue()
