"""Repairing a damaged store: drop what is damaged, recompute it, keep everything else.

:func:`repair_store` is what ``vectorid repair STORE`` runs:

1. When SQLite itself finds damage (``PRAGMA integrity_check``) or a table cannot be read,
   the store is **rebuilt**: every row that can still be read (the definition, stages, run
   log, failure reasons and each batch on its own) is copied into a fresh file, which then
   replaces the damaged one; the damaged file is kept beside it as ``STORE.damaged``.
2. Every batch whose bytes do not match its checksum (or whose sizes do not fit the study)
   is **dropped**, with its failure reasons, in one transaction logged in the run log.
3. The dropped trials are **recomputed**: sample-stage trials from their sequence indices
   (exactly the trials that were there: the sequence is deterministic), trials of other
   stages (sections, robustness checks) from their stored parameters when those are intact.
   A section batch whose parameters are damaged cannot be recomputed: it stays dropped and
   the report says so (run the section again).

The result is the store an undamaged run would have written, trial for trial.
"""

from __future__ import annotations

import os
import shutil
import sqlite3
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TextIO

import numpy as np

from ..errors import StoreDamagedError, StoreError
from ..store.sqlite import TABLES, DamagedBatch, Store
from .executors import make_executor
from .loop import run_store

__all__ = ["RepairReport", "rebuild_file", "repair_store"]


@dataclass
class RepairReport:
    """What :func:`repair_store` did."""

    path: Path
    rebuilt: bool = False
    lost_rows: list[str] = field(default_factory=list)
    dropped: list[DamagedBatch] = field(default_factory=list)
    recomputed: int = 0
    not_recomputed: list[DamagedBatch] = field(default_factory=list)
    backup: Path | None = None
    restored: Path | None = None

    def describe(self) -> str:
        lines = []
        if self.restored is not None:
            lines.append(f"study definition written back from {self.restored}")
        if self.rebuilt:
            lines.append(
                f"rebuilt {self.path} from its readable rows (the damaged file is kept as "
                f"{self.backup})"
            )
            for row in self.lost_rows:
                lines.append(f"  unreadable, not copied: {row}")
        if not self.dropped and not self.rebuilt and self.restored is None:
            lines.append(f"{self.path}: no damaged batch; nothing to repair")
        for d in self.dropped:
            lines.append(f"dropped {d.describe()}")
        if self.dropped or self.rebuilt:
            lines.append(f"recomputed {self.recomputed} trials")
        for d in self.not_recomputed:
            lines.append(
                f"not recomputed: batch {d.block} of stage {d.stage} (its parameters are "
                "damaged and the stage is not a sample stage): run that section or check again"
            )
        return "\n".join(lines)


def rebuild_file(path: Path) -> tuple[Path, list[str], list[tuple[int, int, int]]]:
    """Copy every readable row of the store at ``path`` into a fresh file that replaces it;
    the damaged file is kept as ``PATH.damaged``. The caller holds the writer lock.

    Returns
    -------
    backup, lost, lost_ranges : Path, list of str, list of (stage, start, end)
        Where the damaged file went, the rows that could not be read, and the sequence
        ranges of batches that could not be copied (to recompute).
    """
    from ..store.sqlite import _SCHEMA, APPLICATION_ID, SCHEMA_VERSION

    tmp = path.with_name(path.name + ".rebuild")
    for suffix in ("", "-wal", "-shm"):
        if os.path.exists(str(tmp) + suffix):
            os.unlink(str(tmp) + suffix)
    src = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
    src.text_factory = lambda b: b.decode("utf-8", errors="replace")
    dst = sqlite3.connect(tmp)
    lost: list[str] = []
    lost_ranges: list[tuple[int, int, int]] = []
    try:
        dst.execute("PRAGMA page_size = 65536")
        dst.execute(f"PRAGMA application_id = {APPLICATION_ID}")
        dst.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")
        dst.executescript(_SCHEMA)
        try:
            cols = {r[1] for r in src.execute("PRAGMA table_info(blocks)")}
        except sqlite3.DatabaseError:
            cols = set()
        for table in TABLES:
            key = {"meta": "key", "stages": "stage", "blocks": "block", "runs": "run"}.get(
                table, "rowid"
            )
            try:
                keys = [r[0] for r in src.execute(f"SELECT {key} FROM {table}")]
            except sqlite3.DatabaseError as exc:
                lost.append(f"table {table} ({exc})")
                continue
            select = "*"
            if table == "blocks":
                select = "block, stage, seq_start, n, created, x, f, g, status, wall, " + (
                    "checksum" if "checksum" in cols else "NULL"
                )
            for k in keys:
                try:
                    row = src.execute(
                        f"SELECT {select} FROM {table} WHERE {key} = ?", (k,)
                    ).fetchone()
                except sqlite3.DatabaseError as exc:
                    row = None
                    lost.append(f"{table} row {k!r} ({exc})")
                else:
                    if row is None:
                        lost.append(f"{table} row {k!r} (listed, but cannot be read)")
                if row is None:
                    if table == "blocks":
                        _lost_range(src, k, lost_ranges)
                    continue
                marks = ",".join("?" * len(row))
                try:
                    dst.execute(f"INSERT OR REPLACE INTO {table} VALUES ({marks})", row)
                except sqlite3.DatabaseError as exc:
                    lost.append(f"{table} row {k!r} ({exc})")
        dst.commit()
        dst.execute("PRAGMA journal_mode=WAL")
    finally:
        src.close()
        dst.close()
    backup = path.with_name(path.name + ".damaged")
    shutil.copy2(path, backup)
    for suffix in ("-wal", "-shm"):
        if os.path.exists(str(path) + suffix):
            os.unlink(str(path) + suffix)
    os.replace(tmp, path)
    return backup, lost, lost_ranges


def _lost_range(src: sqlite3.Connection, block: int, out: list[tuple[int, int, int]]) -> None:
    """The sequence range of a batch whose data cannot be read, if its header can."""
    try:
        row = src.execute(
            "SELECT stage, seq_start, n FROM blocks WHERE block = ?", (block,)
        ).fetchone()
    except sqlite3.DatabaseError:
        row = None
    if row and all(isinstance(v, int) for v in row) and row[2] > 0:
        out.append((row[0], row[1], row[1] + row[2]))
    else:
        out.append((-1, -1, -1))  # lost, range unknown


def repair_store(
    path: str | Path,
    *,
    executor: str | None = None,
    workers: int | None = None,
    progress: bool | TextIO = False,
    study: str | Path | None = None,
) -> RepairReport:
    """Repair the store at ``path`` (see the module docstring).

    Parameters
    ----------
    path : path
        The store.
    executor, workers, progress
        How the dropped trials are recomputed (as for :func:`~vectorid.run.run_store`).
    study : path, optional
        A study file whose definition replaces a damaged stored one. It must describe the
        stored trials: the same variables and box as the store's stage 0 (checked), and as
        many criteria and constraints as the stored batches hold (their sizes are checked).

    Returns
    -------
    RepairReport
    """
    path = Path(path)
    report = RepairReport(path)
    lost_ranges: list[tuple[int, int, int]] = []
    store = Store.open(path, write=True)
    try:
        if study is not None:
            _restore_definition(store, Path(study))
            report.restored = Path(study)
        rep = store.verify()
        sqlite_ok = rep.sqlite == ["ok"] and not any(
            "cannot be read" in p or "SQLite" in p for p in rep.problems
        )
        if not sqlite_ok:
            store.close()
            # hold the lock while the file is swapped
            from ..store.sqlite import _WriterLock

            lock = _WriterLock(path)
            lock.acquire()
            try:
                report.backup, report.lost_rows, lost_ranges = rebuild_file(path)
            finally:
                lock.forget()
            report.rebuilt = True
            store = Store.open(path, write=True)
            rep = store.verify()
        if rep.problems:
            raise StoreDamagedError(
                f"store {path} cannot be repaired here: " + "; ".join(rep.problems)
            )
        damaged = list(rep.damaged)
        kinds = {s.stage: s.kind for s in store.stages()}
        # read what can be recomputed from stored parameters before dropping anything
        rerun: list[tuple[DamagedBatch, np.ndarray]] = []
        for d in damaged:
            if kinds.get(d.stage) == "sample" or {"header", "size"} & set(d.parts):
                continue
            X = _intact_parameters(store, d)
            if X is None:
                report.not_recomputed.append(d)
            else:
                rerun.append((d, X))
        blocks = [d.block for d in damaged]
        if blocks:
            store.drop_batches(
                blocks,
                "repair: dropped damaged batches "
                + ", ".join(f"{d.block} (trials {d.first_id}–{d.last_id})" for d in damaged),
            )
        report.dropped = damaged
        ranges = [
            (d.stage, d.seq_start, d.seq_start + d.n)
            for d in damaged
            if kinds.get(d.stage) == "sample"
        ] + [r for r in lost_ranges if kinds.get(r[0]) == "sample"]
        # a damaged header or size says nothing sure about the range its trials held
        unknown = any(r[0] == -1 for r in lost_ranges) or any(
            {"header", "size"} & set(d.parts) for d in damaged
        )
        if unknown:
            report.lost_rows.append(
                "batches whose sequence range is not known for sure: every trial missing up to "
                f"the study's target ({store.spec.trials}) is computed"
            )
        if ranges or unknown:
            summary = run_store(
                store,
                executor=executor,
                workers=workers,
                progress=progress,
                ranges=None if unknown else ranges,
                keep_going=True,
            )
            report.recomputed += summary.stored
        if rerun:
            report.recomputed += _recompute_batches(store, rerun, executor, workers)
    finally:
        store.close()
    return report


def _restore_definition(store: Store, study: Path) -> None:
    """Write the definition of ``study`` into ``store`` after checking it against stage 0."""
    import json

    from ..spec import load_study
    from ..store.agreement import data_file_hashes

    spec = load_study(study)
    rows = store._query("SELECT box FROM stages WHERE stage = 0")
    if rows:
        try:
            box = json.loads(rows[0][0])
        except ValueError:
            box = None
        if box is not None and box != spec.space.to_list():
            raise StoreDamagedError(
                f"the study file {study} does not describe the trials in {store.path}: its "
                "variables or box differ from the store's stage 0; give the study file the "
                "store was created from"
            )
    store.replace_study(spec, data_file_hashes(spec))
    store.set_target(max(spec.trials, store.count_sample()))


def _intact_parameters(store: Store, d: DamagedBatch) -> np.ndarray | None:
    """The stored parameters of a damaged batch when they themselves are intact."""
    if d.parts and any(p in ("x", "header", "size", "checksum") for p in d.parts):
        return None
    try:
        row = store._query("SELECT x FROM blocks WHERE block = ?", (d.block,))
    except StoreError:
        return None
    if not row:
        return None
    p = len(store.spec.space)
    x = np.frombuffer(row[0][0], dtype="<f8")
    if x.size != d.n * p:
        return None
    return x.reshape(d.n, p).copy()


def _recompute_batches(
    store: Store,
    rerun: Sequence[tuple[DamagedBatch, np.ndarray]],
    executor: str | None,
    workers: int | None,
) -> int:
    pool = make_executor(executor or "serial", store.spec, workers)
    done = 0
    with pool:
        keyed = {(d.stage, d.seq_start): X for d, X in rerun}
        for (stage, start), res in pool.map_unordered(list(keyed.items())):
            X = keyed[(stage, start)]
            done += store.write_batch(
                stage, start, X, res.criteria, res.functionals, res.status, res.wall, res.messages
            )
    return done
