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

Crash-safe: a repair is all or nothing. The replacement trials are computed first, while the
store is left as it is; then the damaged batches are dropped and the recomputed ones written
in **one SQLite transaction**. A rebuild is made in a temporary file (recomputed trials
included) that replaces the store with one atomic rename. A repair killed at any moment
(``kill -9``, a power cut) leaves either the old store (run ``vectorid repair`` again) or the
repaired one — never a store with trials missing. Trials of the plan that were missing before
the repair (an interrupted run) are not the repair's to compute: the report names them, and
``vectorid run STORE`` computes them.
"""

from __future__ import annotations

import json
import os
import shutil
import sqlite3
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from ..errors import StoreDamagedError, StoreError, plural
from ..samplers import sampler_for
from ..spec import load_study
from ..store import DamagedBatch, Store, VerifyReport
from ..store.agreement import data_file_hashes
from ..store.inputs import check_inputs
from ..store.lock import WriterLock
from ..store.schema import APPLICATION_ID, GENERATIONS, SCHEMA, SCHEMA_VERSION, TABLES
from .executors import make_executor

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
    #: Planned trials no batch holds after the repair (missing before it: an interrupted
    #: run); ``vectorid run STORE`` computes them.
    missing: int = 0

    def to_dict(self) -> dict:
        """The report as JSON-ready values (``vectorid repair --json``)."""
        batch = lambda d: {  # noqa: E731
            "block": d.block, "stage": d.stage, "first_id": d.first_id, "last_id": d.last_id,
            "n": d.n, "reason": d.reason,
        }  # fmt: skip
        return {
            "store": str(self.path),
            "rebuilt": self.rebuilt,
            "backup": None if self.backup is None else str(self.backup),
            "restored_from": None if self.restored is None else str(self.restored),
            "lost_rows": list(self.lost_rows),
            "dropped": [batch(d) for d in self.dropped],
            "recomputed": self.recomputed,
            "not_recomputed": [batch(d) for d in self.not_recomputed],
            "missing": self.missing,
        }

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
            lines.append(f"recomputed {plural(self.recomputed, 'trial')}")
        if self.missing:
            lines.append(
                f"{self.missing} planned trials are missing (not damage: an interrupted run); "
                f"`vectorid run {self.path}` computes them"
            )
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
    tmp, lost, lost_ranges = rebuild_copy(path)
    return swap_in(path, tmp), lost, lost_ranges


def swap_in(path: Path, tmp: Path) -> Path:
    """Replace the store at ``path`` by ``tmp`` (one atomic rename); the old file is kept
    as ``PATH.damaged``. Returns the backup's path."""
    backup = path.with_name(path.name + ".damaged")
    shutil.copy2(path, backup)
    os.replace(tmp, path)
    for suffix in ("-wal", "-shm"):
        if os.path.exists(str(path) + suffix):
            os.unlink(str(path) + suffix)
    return backup


def rebuild_copy(path: Path) -> tuple[Path, list[str], list[tuple[int, int, int]]]:
    """Copy every readable row of the store at ``path`` into ``PATH.rebuild`` (the store
    itself is not touched). Returns the copy's path, the rows that could not be read, and the
    sequence ranges of batches that could not be copied."""
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
        dst.executescript(SCHEMA)
        dst.executescript(GENERATIONS)
        try:
            cols = {r[1] for r in src.execute("PRAGMA table_info(blocks)")}
        except sqlite3.DatabaseError:
            cols = set()
        try:
            sequential = bool(
                src.execute(
                    "SELECT 1 FROM sqlite_master WHERE type='table' AND name='generations'"
                ).fetchone()
            )
        except sqlite3.DatabaseError:
            sequential = True  # unknown: try to read it (a failure is reported below)
        for table in (*TABLES, "generations") if sequential else TABLES:
            key = {
                "meta": "key",
                "stages": "stage",
                "blocks": "block",
                "runs": "run",
                "generations": "gen",
            }.get(table, "rowid")
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
        _drop_blocks_without_messages(dst, lost, lost_ranges)
        dst.commit()
        dst.execute("PRAGMA journal_mode=WAL")
    finally:
        src.close()
        dst.close()
    return tmp, lost, lost_ranges


def _drop_blocks_without_messages(
    dst: sqlite3.Connection, lost: list[str], lost_ranges: list[tuple[int, int, int]]
) -> None:
    """Batches of the copy whose failed trials lost their failure messages (the failures
    table, or some of its rows, could not be read) are dropped from the copy and their
    ranges recomputed: a failed trial is never kept without its reason."""
    rows = dst.execute("SELECT block, stage, seq_start, n, status FROM blocks").fetchall()
    for block, stage, start, n, status in rows:
        try:
            failed = np.flatnonzero(np.frombuffer(status, dtype="i1") != 0)
        except (TypeError, ValueError):
            continue  # a damaged status array: verify names the batch and repair recomputes it
        if not len(failed):
            continue
        have = {
            r[0]
            for r in dst.execute(
                "SELECT seq FROM failures WHERE stage = ? AND seq >= ? AND seq < ?",
                (stage, start, start + n),
            )
        }
        if all(int(start + i) in have for i in failed):
            continue
        dst.execute("DELETE FROM blocks WHERE block = ?", (block,))
        lost_ranges.append((int(stage), int(start), int(start + n)))
        lost.append(
            f"batch {block}: the failure messages of its failed trials could not be read "
            "(recomputed)"
        )


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
    store = Store.open(path, write=True)
    try:
        if study is not None:
            _restore_definition(store, Path(study))
            report.restored = Path(study)
        rep = verify_store(store)
        sqlite_ok = rep.sqlite == ["ok"] and not any(
            "cannot be read" in p or "SQLite" in p for p in rep.problems
        )
        if sqlite_ok:
            _repair_batches(store, rep, report, executor, workers, progress)
            report.missing = missing_planned(store)
            return report
    finally:
        store.close()
    # SQLite itself is damaged: rebuild a copy, repair the copy, then swap it in (one
    # rename), all while holding the lock on the store
    lock = WriterLock(path)
    lock.acquire()
    try:
        tmp, report.lost_rows, lost_ranges = rebuild_copy(path)
        copy = Store.open(tmp, write=True)
        try:
            rep = verify_store(copy)
            _repair_batches(copy, rep, report, executor, workers, progress, lost_ranges)
            report.missing = missing_planned(copy)
        finally:
            copy.close()
        report.backup = swap_in(path, tmp)
        report.rebuilt = True
    finally:
        lock.forget()
    return report


def _repair_batches(
    store: Store,
    rep,
    report: RepairReport,
    executor: str | None,
    workers: int | None,
    progress: bool | TextIO,
    lost_ranges: Sequence[tuple[int, int, int]] = (),
) -> None:
    """Recompute the damaged batches of ``store`` (and the ``lost_ranges`` a rebuild could
    not copy), then drop and replace them in one transaction."""
    if rep.problems:
        raise StoreDamagedError(
            f"store {report.path} cannot be repaired here: " + "; ".join(rep.problems)
        )
    damaged = list(rep.damaged)
    if not damaged and not lost_ranges:
        return
    kinds = {s.stage: s.kind for s in store.stages()}
    # Other stages' trials come back from their stored parameters when those are intact.
    rerun: dict[tuple[int, int], np.ndarray] = {}
    for d in damaged:
        if kinds.get(d.stage) == "sample" or {"header", "size"} & set(d.parts):
            continue
        X = _intact_parameters(store, d)
        if X is None:
            report.not_recomputed.append(d)
        else:
            rerun[(d.stage, d.seq_start)] = X
    # Sample trials: exactly those the plan loses when the damaged batches go (a damaged
    # header says nothing sure about its range: what the others do not hold is computed).
    keep = {d.block for d in damaged}
    sampler = sampler_for(store.spec)
    lost = _plan_gaps(store, keep, sampler.planned(store))
    untrusted = {
        d.block for d in damaged if {"header", "size"} & set(d.parts) or d.stage not in kinds
    }
    if untrusted:  # the range such a batch held is not known: every gap of the plan
        ranges = lost
    else:
        ranges = _subtract(lost, _plan_gaps(store, set(), sampler.planned(store)))
    ranges += [r for r in lost_ranges if kinds.get(r[0]) == "sample"]
    if any(r[0] == -1 for r in lost_ranges):
        report.lost_rows.append(
            "batches whose sequence range is not known: the trials the plan misses are "
            "named below; `vectorid run STORE` computes them"
        )
    spec = store.spec
    if ranges or rerun:
        check_inputs(store)  # recomputed trials must come from the same model and data
    size = spec.batch_size or 256
    work: dict[tuple[int, int], np.ndarray] = dict(rerun)
    for stage, a, b in ranges:
        for s0 in range(a, b, size):
            n = min(size, b - s0)
            work[(stage, s0)] = sampler.points(store, stage, s0, n)  # as the sampler planned
    results = _evaluate(spec, work, executor, workers)
    why = "repair: replaced damaged batches " + ", ".join(
        f"{d.block} (trials {d.first_id}–{d.last_id})" for d in damaged
    )
    hook = os.environ.get("VECTORID_TEST_REPAIR_PAUSE")
    if hook:  # tests: a moment to kill the repair between computing and committing
        time.sleep(float(hook))
    batches: Any = [
        (stage, start, work[(stage, start)], res) for (stage, start), res in results.items()
    ]
    inside = os.environ.get("VECTORID_TEST_REPAIR_TX_PAUSE")
    if inside:  # tests: a moment to kill the repair inside its one transaction
        batches = _pause_inside(batches, float(inside), os.environ.get("VECTORID_TEST_REPAIR_MARK"))
    report.recomputed += store.replace_batches([d.block for d in damaged], batches, why)
    report.dropped = damaged


def _pause_inside(batches: list, seconds: float, mark: str | None) -> Iterator[Any]:
    """``batches``, pausing before the second is written: by then the transaction of
    :meth:`Store.replace_batches` has dropped the damaged batches and written one new one,
    and holds the store's write lock (tests kill the repair there; ``mark`` names a file
    written at that moment, so the test knows the kill lands inside)."""
    for i, item in enumerate(batches):
        if i == 1:
            if mark:
                Path(mark).write_text(f"inside the transaction, pid {os.getpid()}\n")
            time.sleep(seconds)
        yield item


def _plan_gaps(
    store: Store, exclude: set[int], plan: Sequence[tuple[int, int, int]]
) -> list[tuple[int, int, int]]:
    """``(stage, start, end)`` of the sampler's ``plan`` that no batch holds, batches
    ``exclude`` left out."""
    held: dict[int, list[tuple[int, int]]] = {}
    for block, stage, start, n in store.batch_headers():
        if block in exclude or not all(isinstance(v, int) for v in (stage, start, n)):
            continue
        held.setdefault(stage, []).append((start, start + n))
    out = []
    for stage, pos, end in plan:
        for a, b in sorted(held.get(stage, [])):
            if b <= pos:
                continue
            if a >= end:
                break
            if a > pos:
                out.append((stage, pos, min(a, end)))
            pos = max(pos, b)
        if pos < end:
            out.append((stage, pos, end))
    return out


def verify_store(store: Store) -> VerifyReport:
    """:meth:`Store.verify` with the plan of the study's sampler (what the store should hold);
    a store whose study definition cannot be read is verified without one."""
    try:
        plan = sampler_for(store.spec).planned(store)
    except StoreError:
        plan = None
    return store.verify(plan)


def missing_planned(store: Store) -> int:
    """Trials the study's sampler planned that no stored batch holds."""
    return store.missing_in(sampler_for(store.spec).planned(store))


def _subtract(
    a: list[tuple[int, int, int]], b: list[tuple[int, int, int]]
) -> list[tuple[int, int, int]]:
    """Ranges of ``a`` not in ``b`` (same stage)."""
    out = []
    for stage, x0, x1 in a:
        pieces = [(x0, x1)]
        for s2, y0, y1 in b:
            if s2 != stage:
                continue
            nxt = []
            for p0, p1 in pieces:
                if y1 <= p0 or y0 >= p1:
                    nxt.append((p0, p1))
                    continue
                if p0 < y0:
                    nxt.append((p0, y0))
                if y1 < p1:
                    nxt.append((y1, p1))
            pieces = nxt
        out += [(stage, p0, p1) for p0, p1 in pieces if p1 > p0]
    return out


def _evaluate(spec, work: dict, executor: str | None, workers: int | None) -> dict:
    if not work:
        return {}
    pool = make_executor(executor or spec.executor or "serial", spec, workers)
    out = {}
    with pool:
        pool.start()
        for key, res in pool.map_unordered(list(work.items())):
            out[key] = res
    return out


def _restore_definition(store: Store, study: Path) -> None:
    """Write the definition of ``study`` into ``store`` after checking it against stage 0."""

    spec = load_study(study)
    text = store.stage_box_text(0)
    if text is not None:
        try:
            box = json.loads(text)
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
        raw = store.batch_parameters(d.block)
    except StoreError:
        return None
    if raw is None:
        return None
    p = len(store.spec.space)
    x = np.frombuffer(raw, dtype="<f8")
    if x.size != d.n * p:
        return None
    return x.reshape(d.n, p).copy()
