"""Export every stored trial, one row each, one column per quantity.

Columns: ``id, seq, stage, status, message, wall_time``, then the variables, criteria and
functionals, named as in the study.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from ..errors import StudyDefinitionError, suggest
from .sqlite import Store

__all__ = ["FORMATS", "export_trials", "trial_columns"]

FORMATS = ("csv", "json", "parquet")


def trial_columns(store: Store, kinds: tuple[str, ...] = ("sample",)) -> dict[str, np.ndarray]:
    """Every stored trial as named columns (dict of equal-length arrays)."""
    spec = store.spec
    t = store.load(kinds=kinds)
    cols: dict[str, Any] = {
        "id": t.id,
        "seq": t.seq,
        "stage": t.stage,
        "status": np.where(t.status == 0, "ok", "failed"),
        "message": np.array([t.message(i) for i in range(len(t))], dtype=object),
        "wall_time": t.wall,
    }
    for j, name in enumerate(spec.space.names):
        cols[name] = t.X[:, j]
    for j, c in enumerate(spec.criteria):
        cols[c.name] = t.F[:, j]
    for j, c in enumerate(spec.constraints):
        cols[c.name] = t.G[:, j]
    return cols


def _json_value(v: Any) -> Any:
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def export_trials(store: Store, fmt: str, out: str | Path | TextIO) -> int:
    """Write every trial to ``out`` in ``fmt`` (``csv``, ``json`` or ``parquet``).

    Returns
    -------
    int
        Number of trials written.
    """
    if fmt not in FORMATS:
        raise StudyDefinitionError("--format", f"unknown format {fmt!r}", suggest(fmt, FORMATS))
    cols = trial_columns(store)
    names = list(cols)
    n = len(cols["id"])
    if fmt == "parquet":
        try:
            import pyarrow as pa
            import pyarrow.parquet as pq
        except ImportError:
            from .._hints import install_hint

            raise StudyDefinitionError(
                "--format",
                "parquet export needs pyarrow, which is not installed",
                f"{install_hint('parquet')}, or use --format csv",
            ) from None
        if not isinstance(out, str | Path):
            raise StudyDefinitionError("--out", "parquet needs a file path", "give --out FILE")
        table = pa.table(
            {k: pa.array(list(v) if v.dtype == object else v) for k, v in cols.items()}
        )
        pq.write_table(table, out)
        return n
    own = isinstance(out, str | Path)
    fh: TextIO = open(out, "w", newline="", encoding="utf-8") if own else out
    try:
        if fmt == "csv":
            w = csv.writer(fh)
            w.writerow(names)
            for i in range(n):
                w.writerow([_csv_value(cols[k][i]) for k in names])
        else:
            rows = [{k: _json_value(cols[k][i]) for k in names} for i in range(n)]
            json.dump({"columns": names, "trials": rows}, fh, indent=1)
            fh.write("\n")
    finally:
        if own:
            fh.close()
    return n


def _csv_value(v: Any) -> Any:
    if isinstance(v, np.floating | float):
        return repr(float(v))
    if isinstance(v, np.generic):
        return v.item()
    return v
