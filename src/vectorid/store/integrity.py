"""Integrity checks of a store: every batch against its checksum, SQLite's own pages, the
tables, the study definition, and the trials a sampler planned but no batch holds.

Used by ``vectorid verify``, ``vectorid repair`` and before every run (damaged batches are
named and left out of every analysis, never read as numbers).
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..errors import StoreDamagedError, StoreError
from .records import DamagedBatch, VerifyReport
from .schema import check_row, widths

if TYPE_CHECKING:  # pragma: no cover - the store imports this module
    from .store import Store

__all__ = ["check_batches", "verify"]


def verify(store: Store, plan: Sequence[tuple[int, int, int]] | None = None) -> VerifyReport:
    """Check the whole store: SQLite's own pages, the tables, the study definition, and
    every batch against its checksum (all stages, sections included).

    Parameters
    ----------
    plan : sequence of (stage, start, end), optional
        The sequence ranges the study's sampler planned
        (:meth:`vectorid.samplers.Sampler.planned`): the report counts those that no
        batch holds. Without it, nothing is said about missing trials.

    Returns
    -------
    VerifyReport
    """
    rep = VerifyReport(store.path)
    try:
        rep.schema = int(store.read_rows("PRAGMA user_version")[0][0])
    except StoreError as exc:
        rep.problems.append(str(exc))
    rep.sqlite = store.sqlite_check()
    try:
        spec = store.spec
        stage_kind = {s.stage: s.kind for s in store.stages()}
    except StoreError as exc:
        rep.problems.append(str(exc))
        return rep
    w = widths(spec)
    checksum_col = "checksum" if store.has_checksums() else "NULL"
    try:
        blocks = store.read_rows("SELECT block FROM blocks ORDER BY stage, seq_start")
    except StoreError as exc:
        rep.problems.append(str(exc))
        return rep
    ranges: dict[int, list[tuple[int, int]]] = {}
    failed = 0
    for (block,) in blocks:
        try:
            found = store.read_rows(
                f"SELECT block, stage, seq_start, n, x, f, g, status, wall, {checksum_col} "
                "FROM blocks WHERE block = ?",
                (block,),
            )
        except StoreError as exc:
            rep.problems.append(f"batch {block} cannot be read: {exc}")
            continue
        if not found:
            rep.problems.append(f"batch {block} is listed but cannot be read (SQLite index)")
            continue
        r = found[0]
        rep.batches += 1
        rep.trials += int(r[3]) if isinstance(r[3], int) else 0
        bad = check_row(r, w, stage_kind)
        if bad is not None:
            rep.damaged.append(bad)
            continue
        rep.unverified += r[-1] is None
        failed += int(np.count_nonzero(np.frombuffer(r[7], dtype="i1")))
        ranges.setdefault(r[1], []).append((r[2], r[2] + r[3]))
    try:
        n_msgs = int(store.read_rows("SELECT count(*) FROM failures")[0][0])
        if n_msgs < failed:
            rep.notes.append(
                f"{failed - n_msgs} of {failed} failed trials have no stored reason "
                "(their numbers are sound; only the text is missing)"
            )
    except StoreError as exc:
        rep.problems.append(f"the failure reasons cannot be read ({exc})")
    try:
        if plan is not None:
            rep.planned = sum(e - s for _, s, e in plan)
            rep.missing = store.missing_in(plan)
    except StoreError as exc:
        rep.problems.append(f"the plan cannot be read ({exc})")
    for stage, rs in ranges.items():
        rs.sort()
        for (_, a1), (b0, b1) in itertools.pairwise(rs):
            if b0 < a1:
                rep.problems.append(
                    f"stage {stage}: batches overlap at sequence {b0}..{min(a1, b1) - 1}"
                )
    return rep


def check_batches(store: Store) -> list[DamagedBatch]:
    """Every batch (all stages) checked against its checksum and sizes, one at a time:
    the damaged ones (a cheaper :meth:`verify`, without SQLite's page check)."""
    spec = store.spec
    w = widths(spec)
    checksum_col = "checksum" if store.has_checksums() else "NULL"
    out = []
    with store.snapshot():
        stage_kind = {s.stage: s.kind for s in store.stages()}
        for (block,) in store.read_rows("SELECT block FROM blocks ORDER BY stage, seq_start"):
            found = store.read_rows(
                f"SELECT block, stage, seq_start, n, x, f, g, status, wall, {checksum_col} "
                "FROM blocks WHERE block = ?",
                (block,),
            )
            if not found:
                raise StoreDamagedError(
                    f"store {store.path} is damaged: batch {block} is listed but cannot be "
                    f"read; `vectorid repair {store.path}` rebuilds the store"
                )
            bad = check_row(found[0], w, stage_kind)
            if bad is not None:
                out.append(bad)
    return out
