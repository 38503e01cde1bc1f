"""Named columns and pandas frames of an :class:`~vectorid.analysis.Analysis`.

The one place that turns stored trials, the feasible set D, the Pareto set, the constraints in
force and the identifiability verdicts into columns with names, units and sources: used by
:meth:`Analysis.columns`, :meth:`Analysis.to_frame`, :meth:`Analysis.verdicts_frame` and
``vectorid export``, so a notebook and an exported file hold the same numbers.

pandas is optional (extra ``pandas``): it is imported only here, when a frame is asked for.
"""

from __future__ import annotations

import math
from collections import Counter
from typing import TYPE_CHECKING, Any

import numpy as np

from .._hints import install_hint

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

    from .identifiability import ParameterVerdict
    from .results import Analysis

__all__ = [
    "FLAG_COLUMNS",
    "TRIAL_COLUMNS",
    "constraint_rows",
    "import_pandas",
    "trial_columns",
    "verdict_rows",
]

#: Columns every trial has, before the study's quantities.
TRIAL_COLUMNS = ("id", "seq", "stage", "status", "message", "wall_time")
#: Set membership under the constraints in force, after the study's quantities.
FLAG_COLUMNS = ("functional_ok", "feasible", "pareto")


def import_pandas() -> Any:
    """pandas, or an :class:`ImportError` that says how to install it here."""
    try:
        import pandas
    except ImportError:
        raise ImportError(
            "DataFrames need pandas, which is not installed; install it with "
            f"{install_hint('pandas')} (the numpy arrays a.trials.X, a.trials.F, "
            "a.feasible and a.pareto need nothing more)"
        ) from None
    return pandas


def column_names(a: Analysis) -> dict[tuple[str, str], str]:
    """The column of each study quantity, keyed by (kind, name), kind one of ``"parameter"``,
    ``"criterion"``, ``"functional"``: the name itself, or ``"kind:name"`` where it would
    clash with a fixed column (``id``, ``feasible``...) or with a quantity of another kind."""
    quantities = (
        [("parameter", n) for n in a.spec.space.names]
        + [("criterion", n) for n in a.crit_names]
        + [("functional", n) for n in a.con_names]
    )
    counts = Counter(n for _, n in quantities)
    fixed = set(TRIAL_COLUMNS) | set(FLAG_COLUMNS)
    return {
        (kind, n): (f"{kind}:{n}" if counts[n] > 1 or n in fixed else n) for kind, n in quantities
    }


def trial_columns(a: Analysis) -> dict[str, np.ndarray]:
    """Every trial of ``a`` as named, equal-length columns (see :meth:`Analysis.columns`)."""
    t = a.trials
    names = column_names(a)
    cols: dict[str, np.ndarray] = {
        "id": t.id,
        "seq": t.seq,
        "stage": t.stage,
        "status": np.where(t.status == 0, "ok", "failed").astype(object),
        "message": np.array([t.message(i) for i in range(len(t))], dtype=object),
        "wall_time": t.wall,
    }
    for j, n in enumerate(a.spec.space.names):
        cols[names["parameter", n]] = t.X[:, j]
    for j, n in enumerate(a.crit_names):
        cols[names["criterion", n]] = t.F[:, j]
    for j, n in enumerate(a.con_names):
        cols[names["functional", n]] = t.G[:, j]
    cols["functional_ok"] = a.functional_ok
    cols["feasible"] = a.feasible
    cols["pareto"] = a.pareto
    return cols


def column_units(a: Analysis) -> dict[str, str]:
    """The unit of each column that has one (``wall_time``: s)."""
    names = column_names(a)
    out = {"wall_time": "s"}
    for v in a.spec.space:
        if getattr(v, "unit", ""):
            out[names["parameter", v.name]] = v.unit
    for c in a.criteria:
        if c.unit:
            out[names["criterion", c.name]] = c.unit
    for c in a.constraints:
        if c.unit:
            out[names["functional", c.name]] = c.unit
    return out


def constraint_rows(a: Analysis) -> list[dict[str, Any]]:
    """Each bound in force with where it came from (see :meth:`Analysis.constraints_in_force`)."""
    crit = {c.name: c for c in a.criteria}
    func = {c.name: c for c in a.constraints}
    rows = []
    for b in a.active_bounds():
        if b.name in crit:
            c = crit[b.name]
            stated = c.limit is not None and math.isclose(c.limit, b.value)
            worse = "high" if c.sense == "min" else "low"
            if stated and b.side == worse:
                source, note = c.source, c.limit_note
            else:
                source, note = "analysis", "given for this analysis (--limit or limits=)"
            kind, unit = "criterion", c.unit
        else:
            f = func[b.name]
            stated_value = f.high if b.side == "high" else f.low
            stated = stated_value is not None and math.isclose(stated_value, b.value)
            source = "study" if stated else "analysis"
            note = "" if stated else "given for this analysis (--limit or limits=)"
            kind, unit = "functional", f.unit
        rows.append(
            {
                "name": b.name,
                "kind": kind,
                "bound": "<=" if b.side == "high" else ">=",
                "value": float(b.value),
                "unit": unit,
                "source": source,
                "note": note,
            }
        )
    return rows


def verdict_rows(verdicts: list[ParameterVerdict]) -> list[dict[str, Any]]:
    """One flat row per verdict, ranges split into low and high (NaN where a set is empty)."""
    out = []
    for v in verdicts:
        feasible = v.feasible or (math.nan, math.nan)
        pareto = v.pareto or (math.nan, math.nan)
        out.append(
            {
                "name": v.name,
                "verdict": v.verdict,
                "unit": v.unit,
                "meaning": v.meaning,
                "feasible_low": float(feasible[0]),
                "feasible_high": float(feasible[1]),
                "pareto_low": float(pareto[0]),
                "pareto_high": float(pareto[1]),
                "box_low": float(v.box[0]),
                "box_high": float(v.box[1]),
                "width": float(v.width),
                "n_feasible": int(v.n_feasible),
                "constrained_by": "; ".join(v.constrained_by),
                "reason": v.reason,
                "suggestion": v.suggestion,
            }
        )
    return out


def trials_frame(a: Analysis) -> pd.DataFrame:
    """:meth:`Analysis.to_frame`."""
    pd = import_pandas()
    df = pd.DataFrame(trial_columns(a))
    df.attrs["units"] = column_units(a)
    df.attrs["constraints"] = constraint_rows(a)
    return df


def verdicts_frame(verdicts: list[ParameterVerdict]) -> pd.DataFrame:
    """:meth:`Analysis.verdicts_frame`."""
    pd = import_pandas()
    rows = verdict_rows(verdicts)
    columns = list(rows[0]) if rows else ["name", "verdict"]
    return pd.DataFrame(rows, columns=columns).set_index("name")
