"""The store file's layout: schema, connections, migrations, and the batch codec.

The layout (schema version 3; ``PRAGMA application_id`` marks the file as a vectorid store)
is described in :mod:`vectorid.store`. Schema 1 (before checksums) is still read; its batches
count as *unverified*, and the first writer upgrades the file (:func:`add_checksums`). Schema 2
(before the sampler's records) is read as is; the first writer adds the empty ``generations``
table (schema 3).
"""

from __future__ import annotations

import sqlite3
import time
import zlib
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import StoreDamagedError, StoreError
from .records import ARRAYS, DamagedBatch, batch_checksum, size_problem, trial_ids

__all__ = [
    "APPLICATION_ID",
    "GENERATIONS",
    "SCHEMA",
    "SCHEMA_VERSION",
    "TABLES",
    "add_checksums",
    "blob",
    "check_file",
    "check_row",
    "connect",
    "insert_batch",
    "sqlite_damage",
    "stage_checksum_row",
    "suppress_os",
    "suppress_sqlite",
    "widths",
]

SCHEMA_VERSION = 3
APPLICATION_ID = 0x56494431  # "VID1"
#: Tables every store holds.
TABLES = ("meta", "stages", "blocks", "failures", "runs")

SCHEMA = """
CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE stages (
    stage INTEGER PRIMARY KEY,
    kind TEXT NOT NULL,
    start_seq INTEGER NOT NULL,
    created REAL NOT NULL,
    box TEXT NOT NULL,
    note TEXT NOT NULL DEFAULT ''
);
CREATE TABLE blocks (
    block INTEGER PRIMARY KEY,
    stage INTEGER NOT NULL REFERENCES stages(stage),
    seq_start INTEGER NOT NULL,
    n INTEGER NOT NULL,
    created REAL NOT NULL,
    x BLOB NOT NULL,
    f BLOB NOT NULL,
    g BLOB NOT NULL,
    status BLOB NOT NULL,
    wall BLOB NOT NULL,
    checksum TEXT
);
CREATE INDEX blocks_stage_seq ON blocks(stage, seq_start);
CREATE TABLE failures (
    stage INTEGER NOT NULL,
    seq INTEGER NOT NULL,
    message TEXT NOT NULL,
    PRIMARY KEY (stage, seq)
);
CREATE TABLE runs (
    run INTEGER PRIMARY KEY,
    started REAL NOT NULL,
    finished REAL,
    pid INTEGER,
    host TEXT,
    executor TEXT,
    workers INTEGER,
    target INTEGER,
    outcome TEXT
);
"""

#: The sampler's records (schema 3; created on upgrade of older stores). The table and its
#: columns keep the names the sequential sampler gave them when it was the only sampler with
#: records (``gen`` the record number; ``proposal`` its JSON ``info``; ``x``, ``centres``,
#: ``log_mix``, ``chol`` its four arrays): the store does not interpret them.
GENERATIONS = """
CREATE TABLE IF NOT EXISTS generations (
    gen INTEGER PRIMARY KEY,
    seq_start INTEGER NOT NULL,
    n INTEGER NOT NULL,
    created REAL NOT NULL,
    proposal TEXT NOT NULL,
    x BLOB NOT NULL,
    centres BLOB NOT NULL,
    log_mix BLOB NOT NULL,
    chol BLOB NOT NULL,
    checksum TEXT NOT NULL
);
"""


def blob(a: np.ndarray, dtype: str) -> bytes:
    return np.ascontiguousarray(a, dtype=dtype).tobytes()


def sqlite_damage(path: Path, exc: sqlite3.Error) -> StoreError:
    text = str(exc)
    if isinstance(exc, sqlite3.DatabaseError) and not isinstance(exc, sqlite3.OperationalError):
        return StoreDamagedError(
            f"store {path} is damaged (SQLite: {text}); `vectorid verify {path}` shows what is "
            f"readable, `vectorid repair {path}` rebuilds the store from it"
        )
    if "no such table" in text or "no such column" in text:
        return StoreDamagedError(
            f"store {path} is damaged ({text}); `vectorid verify {path}` shows what is "
            f"readable, `vectorid repair {path}` rebuilds the store from it"
        )
    return StoreError(f"cannot read store {path}: {text}")


def text_factory(data: bytes) -> str:
    return data.decode("utf-8", errors="replace")


def stage_checksum_row(stage: int, kind: str, start: int, box: str) -> tuple[str, str]:
    text = f"{int(stage)}:{kind}:{int(start)}:{box}"
    return (f"stage_checksum:{int(stage)}", f"{zlib.crc32(text.encode()):08x}")


@contextmanager
def suppress_os() -> Iterator[None]:
    try:
        yield
    except OSError:
        pass


def insert_batch(
    con: sqlite3.Connection,
    stage: int,
    seq_start: int,
    X: np.ndarray,
    criteria: np.ndarray,
    functionals: np.ndarray,
    status: np.ndarray,
    wall: np.ndarray,
    messages: Mapping[int, str] | None,
) -> int:
    """Insert one batch inside the caller's transaction; 0 when its range is held."""
    n = int(X.shape[0])
    if n == 0:
        return 0
    blobs = [
        blob(X, "<f8"),
        blob(criteria, "<f8"),
        blob(functionals, "<f8"),
        blob(status, "i1"),
        blob(wall, "<f8"),
    ]
    checksum = batch_checksum(stage, seq_start, n, blobs)
    overlap = con.execute(
        "SELECT 1 FROM blocks WHERE stage = ? AND seq_start < ? AND seq_start + n > ? LIMIT 1",
        (stage, seq_start + n, seq_start),
    ).fetchone()
    if overlap:
        return 0
    con.execute(
        "INSERT INTO blocks (stage, seq_start, n, created, x, f, g, status, wall, "
        "checksum) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
        (stage, seq_start, n, time.time(), *blobs, checksum),
    )
    if messages:
        con.executemany(
            "INSERT OR REPLACE INTO failures VALUES (?, ?, ?)",
            [(stage, seq_start + int(i), m) for i, m in messages.items()],
        )
    return n


@contextmanager
def suppress_sqlite() -> Iterator[None]:
    try:
        yield
    except sqlite3.Error:
        pass


def widths(spec: Any) -> dict[str, int]:
    return {
        "x": len(spec.space) * 8,
        "f": len(spec.criteria) * 8,
        "g": len(spec.constraints) * 8,
        "status": 1,
        "wall": 8,
    }


def connect(path: Path, readonly: bool = False) -> sqlite3.Connection:
    try:
        if readonly:
            con = sqlite3.connect(f"file:{path}?mode=ro", uri=True, timeout=30)
            try:
                con.execute("PRAGMA schema_version").fetchone()
            except sqlite3.OperationalError:
                # A WAL store on a read-only filesystem: SQLite cannot create the -shm
                # file, but the file cannot change under us either, so read it as
                # immutable.
                con.close()
                con = sqlite3.connect(f"file:{path}?immutable=1", uri=True, timeout=30)
        else:
            con = sqlite3.connect(path, timeout=30)
            con.execute("PRAGMA journal_mode=WAL")
            con.execute("PRAGMA synchronous=NORMAL")
        con.execute("PRAGMA foreign_keys=ON")
        con.execute("PRAGMA mmap_size=17179869184")
        # Damaged text reads as text with replacement characters (and then fails its
        # checksum) instead of stopping the query.
        con.text_factory = text_factory
    except StoreError:
        raise
    except sqlite3.Error as exc:
        if "not a database" in str(exc) or "malformed" in str(exc):
            raise StoreError(
                f"{path} is not a vectorid store (not a readable SQLite file: {exc}); "
                "was it truncated or is it another file?"
            ) from None
        raise StoreError(f"cannot open {path} as SQLite: {exc}") from None
    return con


def check_file(con: sqlite3.Connection, path: Path) -> tuple[int, int]:
    try:
        app = con.execute("PRAGMA application_id").fetchone()[0]
        version = con.execute("PRAGMA user_version").fetchone()[0]
    except sqlite3.DatabaseError as exc:
        raise StoreError(
            f"{path} is not a vectorid store (not a readable SQLite file: {exc}); "
            "was it truncated or is it another file?"
        ) from None
    if app != APPLICATION_ID:
        raise StoreError(
            f"{path} is an SQLite file but not a vectorid store (application_id {app:#x}); "
            "point to a store written by `vectorid run`"
        )
    if version > SCHEMA_VERSION:
        raise StoreError(
            f"{path} has store schema {version}, newer than this vectorid understands "
            f"({SCHEMA_VERSION}); upgrade vectorid"
        )
    try:
        names = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type='table'")}
    except sqlite3.DatabaseError as exc:
        raise sqlite_damage(path, exc) from None
    missing = [t for t in TABLES if t not in names]
    if missing:
        raise StoreDamagedError(
            f"store {path} is damaged: table{'s' if len(missing) > 1 else ''} "
            f"{', '.join(missing)} missing; `vectorid verify {path}` shows what is "
            f"readable, `vectorid repair {path}` rebuilds what it can"
        )
    try:
        con.execute("SELECT count(*) FROM blocks").fetchone()
    except sqlite3.DatabaseError as exc:
        raise sqlite_damage(path, exc) from None
    return app, version


def add_checksums(con: sqlite3.Connection, widths: Mapping[str, int]) -> tuple[int, int]:
    """Schema 1 -> 2 inside the upgrade's transaction: (batches sealed, batches bad)."""
    sealed = bad = 0
    cols = {r[1] for r in con.execute("PRAGMA table_info(blocks)")}
    if "checksum" not in cols:
        con.execute("ALTER TABLE blocks ADD COLUMN checksum TEXT")
    rows = con.execute(
        "SELECT block, stage, seq_start, n, x, f, g, status, wall FROM blocks"
    ).fetchall()
    for block, stage, start, n, *blobs in rows:
        if size_problem(n, blobs, widths) is not None:
            bad += 1  # left without checksum: it shows as damaged on every load
            continue
        con.execute(
            "UPDATE blocks SET checksum = ? WHERE block = ?",
            (batch_checksum(stage, start, n, blobs), block),
        )
        sealed += 1
    for st, kind, start, box in con.execute(
        "SELECT stage, kind, start_seq, box FROM stages"
    ).fetchall():
        con.execute(
            "INSERT OR REPLACE INTO meta VALUES (?, ?)",
            stage_checksum_row(st, kind, start, box),
        )
    return sealed, bad


def check_row(
    row: Sequence[Any],
    widths: Mapping[str, int],
    stage_kind: Mapping[int, str],
) -> DamagedBatch | None:
    """None if the batch is sound, else what is damaged."""
    block, stage, start, n, *blobs, checksum = row
    problem = size_problem(n, blobs, widths)
    parts: tuple[str, ...] = ()
    if problem is None and stage not in stage_kind:
        problem = f"it belongs to stage {stage}, which the store does not hold"
        parts = ("header",)
    if problem is None and checksum is not None:
        want = batch_checksum(stage, start, n, blobs).split(":", 1)[1].split(",")
        have = str(checksum).split(":", 1)[-1].split(",")
        if len(have) != len(want) or not str(checksum).startswith("crc32:"):
            problem = f"its checksum field is unreadable ({str(checksum)[:40]!r})"
            parts = ("checksum",)
        else:
            names = ["header"] + [a[0] for a in ARRAYS]
            labels = ["header (stage, sequence start, count)"] + [a[1] for a in ARRAYS]
            bad = [i for i, (a, b) in enumerate(zip(want, have)) if a != b]
            if bad:
                parts = tuple(names[i] for i in bad)
                problem = "checksum mismatch in " + ", ".join(labels[i] for i in bad)
    elif problem is not None:
        parts = parts or ("size",)
    if problem is None and checksum is None:
        status = np.frombuffer(blobs[3], dtype="i1")
        if np.any((status != 0) & (status != 1)):
            problem = "status codes other than 0 (ok) and 1 (failed)"
            parts = ("status",)
    if problem is None:
        return None
    kind = stage_kind.get(stage, "sample")
    try:
        n_int = int(n)
        start_int = int(start)
        ids = trial_ids(kind, int(stage), np.array([start_int, start_int + max(n_int, 1) - 1]))
        first, last = int(ids[0]), int(ids[1])
    except (TypeError, ValueError, OverflowError):
        first = last = -1
        n_int = 0
    return DamagedBatch(int(block), int(stage), int(start), n_int, first, last, problem, parts)
