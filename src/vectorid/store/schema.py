"""The store file's layout: schema, connections, migrations, and the batch codec.

Layout (schema version 3; ``PRAGMA application_id`` marks the file as a vectorid store):

``meta(key, value)``
    ``schema_version``, ``vectorid_version``, ``created``, ``study`` (the study definition
    as JSON, so a store alone is enough to analyse or extend the study), ``study_checksum``
    (CRC-32 of that JSON), ``base_dir``, ``data_files`` (content hashes of the data files
    the study reads, see :mod:`vectorid.store.agreement`) and ``writer`` (the process that
    last took the writer lock).
``stages(stage, kind, start_seq, created, box, note)``
    Stage 0 is the study's box Π; double tuning adds stages with a narrower box that keep
    drawing from the sequence at ``start_seq`` onward. ``kind`` is ``"sample"`` for stages
    drawn by the study's sampler (other kinds, such as sections, hold extra trials that
    never mix into the sample's statistics).
``blocks(block, stage, seq_start, n, created, x, f, g, status, wall, checksum)``
    Append-only trial records. One row is one evaluated batch of ``n`` trials with
    consecutive sequence indices ``seq_start .. seq_start + n - 1``: parameters ``x``
    (n, p), criteria ``f`` (n, k), functionals ``g`` (n, q) and wall time per trial
    ``wall`` (n,) as little-endian float64, ``status`` (n,) as int8 (0 ok, 1 failed).
    ``checksum`` is ``"crc32:"`` followed by six CRC-32s (of the header ``stage:seq_start:n``
    and of each of the five arrays), written with the batch and verified whenever it is read:
    a batch whose bytes changed on disk is reported (which batch, which trial ids, which
    array) and left out of every analysis, never read as numbers. Storing a batch as one
    columnar row makes a batch one transaction and loading a million trials a matter of
    concatenating a few hundred buffers.
``failures(stage, seq, message)``
    The reason of every failed trial.
``runs(run, started, finished, pid, host, executor, workers, target, outcome)``
    A log of run sessions (interrupted ones and repairs included).
``generations(gen, seq_start, n, created, proposal, x, centres, log_mix, chol, checksum)``
    Schema 3: the study's sampler's records (:class:`~vectorid.store.records.SamplerRecord`),
    kept for the sampler and never interpreted here: record ``gen`` plans the stage-0
    sequence indices ``seq_start .. seq_start + n - 1``, ``proposal`` is its JSON ``info``
    and ``x``, ``centres``, ``log_mix``, ``chol`` its four float64 arrays (the names are those
    the sequential sampler, its first user, gave them). Written *before* the planned trials
    are evaluated, so a resumed run evaluates exactly the missing ones. Empty for a plain
    Sobol study.

Schema 1 (before checksums) is still read; its batches
count as *unverified*, and the first writer upgrades the file (:func:`add_checksums`). Schema 2
(before the sampler's records) is read as is; the first writer adds the empty ``generations``
table (schema 3).
"""

from __future__ import annotations

import json
import sqlite3
import time
import zlib
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..errors import StoreDamagedError, StoreError
from .lock import writer_text
from .records import ARRAYS, DamagedBatch, Trials, batch_checksum, size_problem, trial_ids

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
    "decode_batches",
    "initialise",
    "insert_batch",
    "sqlite_damage",
    "stage_checksum_row",
    "suppress_os",
    "suppress_sqlite",
    "upgrade",
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


def initialise(
    con: sqlite3.Connection,
    study: Mapping[str, Any],
    box: Sequence[Any],
    base_dir: str | None,
    data_files: Mapping[str, Any] | None,
) -> None:
    """Lay out a new store file: its pages, tables, the study definition and stage 0.

    Parameters
    ----------
    con : sqlite3.Connection
        On the new (empty) file.
    study : mapping
        The study definition (``StudySpec.to_dict()``).
    box : sequence
        Stage 0's box (``Space.to_list()``).
    base_dir : str or None
        The study file's folder.
    data_files : mapping, optional
        Content hashes of the data files the study reads.
    """
    # Large pages make reading the columnar blobs back several times faster.
    con.execute("PRAGMA journal_mode=DELETE")
    con.execute("PRAGMA page_size = 65536")
    con.execute("VACUUM")
    # written in rollback-journal mode (a megabyte less of log), then WAL by the caller
    with con:
        con.execute(f"PRAGMA application_id = {APPLICATION_ID}")
        con.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")
        con.executescript(SCHEMA)
        con.executescript(GENERATIONS)
    text = json.dumps(dict(study))
    with con:
        con.executemany(
            "INSERT INTO meta VALUES (?, ?)",
            [
                ("schema_version", str(SCHEMA_VERSION)),
                ("vectorid_version", __version__),
                ("created", repr(time.time())),
                ("study", text),
                ("study_checksum", f"{zlib.crc32(text.encode()):08x}"),
                ("base_dir", base_dir or ""),
                ("data_files", json.dumps(dict(data_files or {}))),
                ("writer", writer_text()),
            ],
        )
        box_text = json.dumps(list(box))
        con.execute(
            "INSERT INTO stages VALUES (0, 'sample', 0, ?, ?, 'study box')",
            (time.time(), box_text),
        )
        con.execute("INSERT INTO meta VALUES (?, ?)", stage_checksum_row(0, "sample", 0, box_text))


def decode_batches(
    rows: Sequence[Sequence[Any]],
    w: Mapping[str, int],
    stage_kind: Mapping[int, str],
    sizes: tuple[int, int, int],
    messages: dict[tuple[int, int], str],
    damaged: list[DamagedBatch],
) -> Trials:
    """Stored batch rows as :class:`Trials`: each row checked against its checksum and sizes
    (a damaged one is added to ``damaged`` and left out), the sound ones concatenated.

    Parameters
    ----------
    rows : sequence of rows
        ``(block, stage, seq_start, n, x, f, g, status, wall, checksum)`` as stored.
    w : mapping
        Byte widths of a trial's arrays (:func:`widths`).
    stage_kind : mapping
        Stage number -> kind.
    sizes : (p, k, q)
        Variables, criteria and functionals of the study.
    messages : dict
        ``(stage, seq) -> failure message`` of the rows' trials.
    damaged : list of DamagedBatch
        Damage found already (extended here).
    """
    p, k, q = sizes
    good = []
    unverified = 0
    for r in rows:
        bad = check_row(r, w, stage_kind)
        if bad is not None:
            damaged.append(bad)
        else:
            good.append(r)
            unverified += r[-1] is None
    ns = np.array([r[3] for r in good], dtype=np.int64)
    total = int(ns.sum()) if len(ns) else 0

    def cat(col: int, dtype: str, width: int | None) -> np.ndarray:
        shape = (total,) if width is None else (total, width)
        out = np.empty(shape, dtype=dtype.lstrip("<"))
        pos = 0
        for r in good:
            m = r[3]
            chunk = np.frombuffer(r[col], dtype=dtype)
            out[pos : pos + m] = chunk if width is None else chunk.reshape(m, width)
            pos += m
        return out

    seq = (
        np.concatenate([np.arange(r[2], r[2] + r[3]) for r in good])
        if good
        else np.empty(0, np.int64)
    )
    stage = np.repeat(np.array([r[1] for r in good], dtype=np.int64), ns)
    ids = np.empty(total, dtype=np.int64)
    for s in set(stage.tolist()):
        m = stage == s
        ids[m] = trial_ids(stage_kind[s], s, seq[m])
    return Trials(
        id=ids,
        seq=seq.astype(np.int64),
        stage=stage,
        status=cat(7, "i1", None),
        X=cat(4, "<f8", p),
        F=cat(5, "<f8", k),
        G=cat(6, "<f8", q),
        wall=cat(8, "<f8", None),
        messages=messages,
        damaged=tuple(damaged),
        unverified=unverified,
    )


def upgrade(con: sqlite3.Connection, version: int, w: Mapping[str, int]) -> tuple[int, int]:
    """Bring an older store to the current schema, inside the caller's transaction: schema
    1 -> 2 adds the checksum column and seals the batches held (after checking that their
    sizes fit the study, ``w`` from :func:`widths`); 2 -> 3 adds the (empty) table of the
    sampler's records.

    Returns
    -------
    (int, int)
        Batches sealed and batches whose sizes do not fit (both 0 from schema 2).
    """
    sealed = bad = 0
    if version < 2:
        sealed, bad = add_checksums(con, w)
    con.execute(GENERATIONS)
    study = con.execute("SELECT value FROM meta WHERE key = 'study'").fetchone()[0]
    what = (
        f"checksums added to {sealed} batches written without one"
        if version < 2
        else "generations table added"
    )
    con.executemany(
        "INSERT OR REPLACE INTO meta VALUES (?, ?)",
        [
            ("schema_version", str(SCHEMA_VERSION)),
            ("study_checksum", f"{zlib.crc32(study.encode()):08x}"),
            (
                "upgraded",
                f"schema {version} -> {SCHEMA_VERSION} on "
                f"{time.strftime('%Y-%m-%d %H:%M:%S')}: {what}",
            ),
        ],
    )
    con.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")
    return sealed, bad
