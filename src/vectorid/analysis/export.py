"""Export every stored trial, one row each, one column per quantity, with the set flags.

Columns (:meth:`vectorid.analysis.Analysis.columns`): ``id, seq, stage, status, message,
wall_time`` (s), then the variables, criteria and functionals named as in the study, then the
flags ``functional_ok``, ``feasible`` (in D) and ``pareto`` under the constraints in force (the
study's, or those given with ``--limit``). Each bound in force, with its source (``expert``,
``noise``, ``quantile``, ``study``, ``analysis``), goes into the JSON document
(``"constraints"``) and the Parquet file's metadata (key ``vectorid.constraints``, JSON);
``--constraints`` writes that table alone, in any format.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from .._hints import install_hint
from ..errors import StudyDefinitionError, suggest
from ..store import Store
from .results import Analysis

__all__ = ["FORMATS", "export_trials", "trial_columns", "write_analysis"]

FORMATS = ("csv", "json", "parquet")


def _analysis(store: Store, limits: Any = None, roles: Mapping[str, str] | None = None) -> Any:
    return Analysis.of_store(store, limits, roles)


def trial_columns(
    store: Store,
    limits: Iterable[Any] | Mapping[str, Any] | None = None,
    roles: Mapping[str, str] | None = None,
) -> dict[str, np.ndarray]:
    """Every stored sample trial as named columns with the set flags (dict of equal-length
    arrays; see :meth:`vectorid.analysis.Analysis.columns`)."""
    return _analysis(store, limits, roles).columns()


def _check(fmt: str, out: Any) -> None:
    if fmt not in FORMATS:
        raise StudyDefinitionError("--format", f"unknown format {fmt!r}", suggest(fmt, FORMATS))
    if fmt == "parquet" and not isinstance(out, str | Path):
        raise StudyDefinitionError("--out", "parquet needs a file path", "give --out FILE")


def export_trials(
    store: Store,
    fmt: str,
    out: str | Path | TextIO,
    limits: Iterable[Any] | Mapping[str, Any] | None = None,
    roles: Mapping[str, str] | None = None,
) -> int:
    """Write every trial to ``out`` in ``fmt`` (``csv``, ``json`` or ``parquet``).

    Parameters
    ----------
    store : Store
        The study store.
    fmt : {"csv", "json", "parquet"}
        The file format.
    out : path or text file
        Where to write (parquet needs a path).
    limits, roles : optional
        Constraints and roles for the flags, as for :class:`~vectorid.analysis.Analysis`
        (default: the study's).

    Returns
    -------
    int
        Number of trials written.
    """
    _check(fmt, out)
    return write_analysis(_analysis(store, limits, roles), fmt, out)


def write_analysis(a: Any, fmt: str, out: str | Path | TextIO, *, constraints: bool = False) -> int:
    """Write the trials of the analysis ``a`` with its flags (JSON and Parquet carry the
    constraints in force too), or with ``constraints=True`` only the constraints in force,
    one row per bound with its unit and source.

    Returns
    -------
    int
        Number of rows written.
    """
    _check(fmt, out)
    rows = a.constraints_in_force()
    if not constraints:
        return _write(a.columns(), fmt, out, {"constraints": rows})
    names = ["name", "kind", "bound", "value", "unit", "source", "note"]
    cols = {k: np.array([r[k] for r in rows], dtype=float if k == "value" else object)
            for k in names}  # fmt: skip
    return _write(cols, fmt, out, None, key="constraints")


def _write(
    cols: Mapping[str, np.ndarray],
    fmt: str,
    out: str | Path | TextIO,
    meta: Mapping[str, Any] | None,
    key: str = "trials",
) -> int:
    names = list(cols)
    n = len(next(iter(cols.values()))) if cols else 0
    if fmt == "parquet":
        try:
            import pyarrow as pa
            import pyarrow.parquet as pq
        except ImportError:
            raise StudyDefinitionError(
                "--format",
                "parquet export needs pyarrow, which is not installed",
                f"{install_hint('parquet')}, or use --format csv",
            ) from None
        table = pa.table(
            {k: pa.array(list(v) if v.dtype == object else v) for k, v in cols.items()}
        )
        if meta:
            table = table.replace_schema_metadata(
                {f"vectorid.{k}": json.dumps(v) for k, v in meta.items()}
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
            doc: dict[str, Any] = {"columns": names, key: rows}
            for k, v in (meta or {}).items():
                doc[k] = [{kk: _json_value(vv) for kk, vv in r.items()} for r in v]
            json.dump(doc, fh, indent=1)
            fh.write("\n")
    finally:
        if own:
            fh.close()
    return n


def _json_value(v: Any) -> Any:
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def _csv_value(v: Any) -> Any:
    if isinstance(v, np.bool_ | bool):
        return "true" if v else "false"
    if isinstance(v, np.floating | float):
        return repr(float(v))
    if isinstance(v, np.generic):
        return v.item()
    return v
