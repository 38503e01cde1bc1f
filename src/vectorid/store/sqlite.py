"""The embedded study store: one SQLite file per study.

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
    drawn from the point sequence (other kinds, such as sections, hold extra trials that
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
    Schema 3, the sequential sampler (:mod:`vectorid.run.sequential`): generation ``gen``
    holds the stage-0 sequence indices ``seq_start .. seq_start + n - 1``; ``proposal`` is
    JSON (kind, the tolerance it aimed at, the kernel's in-box mass and draws), ``x`` the
    proposed points (n, p) written *before* they are evaluated (so a resumed run evaluates
    exactly the missing ones), ``centres``/``log_mix``/``chol`` the kernel's parameters, from
    which every trial's importance weight is recomputed. Empty for a plain Sobol study.

Schema 1 (before checksums) is still read; its batches count as *unverified*, and the first
writer (any run, or ``vectorid repair``) upgrades the file, computing checksums of the batches
it holds after checking their sizes, and says so. Schema 2 (before generations) is read as
is; the first writer adds the empty ``generations`` table (schema 3).

Exactly-once: a batch whose sequence range overlaps a stored range of the same stage is
not stored again (it is counted as a duplicate), so a batch computed twice (a retried task,
a resumed run) is stored once.

One writer: a process that writes holds an exclusive advisory lock (``flock``) on the store
file itself, so the lock follows the file's identity (its inode), whatever path, symlink or
hard link names it; the OS releases it when the process dies, so a run killed with
``kill -9`` can be resumed at once. Readers take no lock and read one consistent snapshot
(one SQLite read transaction per load) while a writer appends.
"""

from __future__ import annotations

import itertools
import json
import os
import socket
import sqlite3
import threading
import time
import warnings
import zlib
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import (
    StoreDamagedError,
    StoreError,
    StoreLockedError,
    StudyDefinitionError,
    VectoridError,
    VectoridWarning,
)
from ..space import Space
from ..spec import StudySpec

__all__ = [
    "SCHEMA_VERSION",
    "DamagedBatch",
    "Generation",
    "Stage",
    "Store",
    "Trials",
    "VerifyReport",
    "batch_checksum",
]

SCHEMA_VERSION = 3
APPLICATION_ID = 0x56494431  # "VID1"
#: Tables every store holds.
TABLES = ("meta", "stages", "blocks", "failures", "runs")

_SCHEMA = """
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

#: The sequential sampler's generations (schema 3; created on upgrade of older stores).
_GENERATIONS = """
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

#: The arrays of a batch, in the order of the checksum: (column, label, dtype, item size).
_ARRAYS = (
    ("x", "parameters (x)", "<f8"),
    ("f", "criteria (f)", "<f8"),
    ("g", "functionals (g)", "<f8"),
    ("status", "status", "i1"),
    ("wall", "wall times", "<f8"),
)


def batch_checksum(stage: int, seq_start: int, n: int, blobs: Sequence[bytes]) -> str:
    """The checksum stored with a batch: CRC-32 of its header and of each of its arrays.

    Parameters
    ----------
    stage, seq_start, n : int
        The batch's stage, first sequence index and number of trials.
    blobs : sequence of bytes
        The arrays ``x, f, g, status, wall`` as stored.
    """
    head = zlib.crc32(f"{int(stage)}:{int(seq_start)}:{int(n)}".encode())
    return "crc32:" + ",".join(f"{c:08x}" for c in (head, *(zlib.crc32(b) for b in blobs)))


@dataclass(frozen=True)
class DamagedBatch:
    """A stored batch whose bytes do not match its checksum (or its declared size).

    Attributes
    ----------
    block : int
        Row id of the batch in the ``blocks`` table.
    stage, seq_start, n : int
        Stage, first sequence index and number of trials.
    first_id, last_id : int
        Trial ids it holds (``first_id .. last_id``).
    reason : str
        What does not match, e.g. ``"checksum mismatch in criteria (f)"``.
    parts : tuple of str
        The damaged columns (``"x"``, ``"f"``, ...; ``"header"`` for stage/seq/n).
    """

    block: int
    stage: int
    seq_start: int
    n: int
    first_id: int
    last_id: int
    reason: str
    parts: tuple[str, ...] = ()

    def describe(self) -> str:
        ids = (
            f"trials {self.first_id}–{self.last_id}, "
            if self.first_id >= 0
            else f"sequence {self.seq_start}.., "
        )
        return f"batch {self.block} (stage {self.stage}, {ids}{self.n} trials): {self.reason}"


def _damage_warning(path: Path, damaged: Sequence[DamagedBatch]) -> str:
    n = sum(d.n for d in damaged)
    shown = "; ".join(d.describe() for d in damaged[:3])
    more = f"; and {len(damaged) - 3} more" if len(damaged) > 3 else ""
    return (
        f"store {path}: {len(damaged)} damaged batch{'es' if len(damaged) > 1 else ''} "
        f"({n} trials) left out of this analysis — {shown}{more}; `vectorid verify {path}` "
        f"lists them all, `vectorid repair {path}` drops and recomputes them"
    )


@dataclass(frozen=True)
class Stage:
    """A stage of a study: a box and where in the sequence it starts."""

    stage: int
    kind: str
    start_seq: int
    created: float
    space: Space
    note: str = ""


@dataclass
class Trials:
    """All stored trials as arrays, in sequence order within each stage.

    Attributes
    ----------
    id : (n,) int64
        Trial id: ``seq + 1`` for sample stages (the LP_tau point number).
    seq, stage : (n,) int64
    status : (n,) int8
        0 ok, 1 failed.
    X : (n, p) float64
        Parameters, columns as the study's variables.
    F : (n, k) float64
        Criteria (NaN for failed trials).
    G : (n, q) float64
        Functionals (NaN for failed trials).
    wall : (n,) float64
        Wall time per trial in seconds.
    messages : dict
        ``(stage, seq) -> failure message``.
    damaged : tuple of DamagedBatch
        Stored batches left out because their bytes do not match their checksum (empty for
        a sound store; see :meth:`Store.verify`).
    unverified : int
        Batches loaded without a checksum to verify (a schema-1 store opened read-only).
    log_weight : callable or None
        Sequential stores only: ``log_weight(X)`` gives the importance weights (log) of
        parameter vectors ``X`` (n, p) against the box over every stored generation (see
        :mod:`vectorid.sequential.weights`); densities of a subset such as D use them.
        None for a plain study (every trial weighs the same).
    """

    id: np.ndarray
    seq: np.ndarray
    stage: np.ndarray
    status: np.ndarray
    X: np.ndarray
    F: np.ndarray
    G: np.ndarray
    wall: np.ndarray
    messages: dict[tuple[int, int], str] = field(default_factory=dict)
    damaged: tuple[DamagedBatch, ...] = ()
    unverified: int = 0
    log_weight: Any = field(default=None, compare=False, repr=False)

    def __len__(self) -> int:
        return int(self.id.shape[0])

    def subset(self, mask: np.ndarray) -> Trials:
        """The trials where ``mask`` is true.

        Parameters
        ----------
        mask : (n,) array of bool
            Which rows to keep.

        Returns
        -------
        Trials
        """
        keep = {(int(s), int(q)) for s, q in zip(self.stage[mask], self.seq[mask])}
        return Trials(
            self.id[mask],
            self.seq[mask],
            self.stage[mask],
            self.status[mask],
            self.X[mask],
            self.F[mask],
            self.G[mask],
            self.wall[mask],
            {k: v for k, v in self.messages.items() if k in keep},
            self.damaged,
            self.unverified,
            self.log_weight,
        )

    def message(self, i: int) -> str:
        """Failure message of one trial.

        Parameters
        ----------
        i : int
            Row of the trial in these arrays.

        Returns
        -------
        str
            Why it failed ('' if it did not fail).
        """
        return self.messages.get((int(self.stage[i]), int(self.seq[i])), "")


def trial_ids(kind: str, stage: int, seq: np.ndarray) -> np.ndarray:
    """Trial ids: LP_tau point number ``seq + 1`` for sample stages; for auxiliary stages
    ``stage * 1_000_000_000 + seq + 1``, which never collides with a sample trial."""
    seq = np.asarray(seq, dtype=np.int64)
    if kind == "sample":
        return seq + 1
    return stage * 1_000_000_000 + seq + 1


#: Writer locks of this process by file identity ``(st_dev, st_ino)``: the descriptor the
#: ``flock`` is taken on, whether a Store of this process holds it now, and how many Stores
#: of this process have the file open. A descriptor is closed only when no Store of this
#: process has the file open any more: closing a descriptor of the store file drops the
#: POSIX locks SQLite holds on it for the process's other connections.
_LOCK_FDS: dict[tuple[int, int], int] = {}
_HELD: set[tuple[int, int]] = set()
_OPEN: dict[tuple[int, int], int] = {}
_LOCK_GUARD = threading.Lock()


def _close_unused(key: tuple[int, int] | None) -> None:
    """Close the lock descriptor of ``key`` when nothing of this process uses the file
    (called with ``_LOCK_GUARD`` held)."""
    if key is None or key in _HELD or _OPEN.get(key, 0) > 0:
        return
    fd = _LOCK_FDS.pop(key, None)
    if fd is not None:
        try:
            os.close(fd)
        except OSError:
            pass


def _opened(key: tuple[int, int] | None) -> None:
    if key is not None:
        with _LOCK_GUARD:
            _OPEN[key] = _OPEN.get(key, 0) + 1


def _closed(key: tuple[int, int] | None) -> None:
    if key is None:
        return
    with _LOCK_GUARD:
        n = _OPEN.get(key, 0) - 1
        if n > 0:
            _OPEN[key] = n
        else:
            _OPEN.pop(key, None)
        _close_unused(key)


def _path_identity(path: Path) -> tuple[int, int] | None:
    try:
        st = os.stat(path)
    except OSError:
        return None
    return (st.st_dev, st.st_ino)


def _identity(fd: int) -> tuple[int, int]:
    st = os.fstat(fd)
    return (st.st_dev, st.st_ino)


def _writer_of(path: Path) -> str:
    """Who holds the writer lock, as far as the store says (``pid N on HOST ...``)."""
    try:
        con = sqlite3.connect(f"file:{path}?mode=ro", uri=True, timeout=2)
        try:
            # written by the holder right after it took the lock (a 'running' row in the run
            # log may be left from a run that was killed)
            row = con.execute("SELECT value FROM meta WHERE key = 'writer'").fetchone()
            if row:
                return str(row[0])
            row = con.execute(
                "SELECT pid, host, started FROM runs WHERE outcome = 'running' "
                "ORDER BY run DESC LIMIT 1"
            ).fetchone()
            if row:
                started = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(row[2]))
                return f"pid {row[0]} on {row[1]}, running since {started}"
            return ""
        finally:
            con.close()
    except sqlite3.Error:
        return ""


class _WriterLock:
    """Exclusive advisory lock (``flock``) on the store file itself: one writer per file,
    whatever path names it (a symlink or a hard link names the same inode)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.key: tuple[int, int] | None = None

    def acquire(self, fd: int | None = None) -> None:
        """Take the lock (on ``fd`` when given: a file this process just created)."""
        import fcntl

        if fd is None:
            try:
                fd = os.open(self.path, os.O_RDONLY)
            except OSError as exc:
                raise StoreError(f"cannot open store {self.path}: {exc.strerror}") from None
        key = _identity(fd)
        with _LOCK_GUARD:
            if key in _HELD:
                os.close(fd)
                raise StoreLockedError(
                    f"store {self.path} is already open for writing in this process "
                    f"(pid {os.getpid()}); close that Study/Store first"
                )
            old = _LOCK_FDS.get(key)
            if old is not None:
                os.close(fd)
                fd = old
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                _LOCK_FDS[key] = fd
                _close_unused(key)
                holder = _writer_of(self.path)
                real = self.path.resolve()
                named = "" if real == self.path.absolute() else f" (= {real})"
                raise StoreLockedError(
                    f"store {self.path}{named} is being written by another process "
                    f"({holder or 'unknown'}); wait for it to finish (or stop it), or run "
                    "with another --store"
                ) from None
            _LOCK_FDS[key] = fd
            _HELD.add(key)
            self.key = key

    def release(self) -> None:
        if self.key is None:
            return
        import fcntl

        with _LOCK_GUARD:
            fd = _LOCK_FDS.get(self.key)
            if fd is not None:
                fcntl.flock(fd, fcntl.LOCK_UN)
            _HELD.discard(self.key)
            _close_unused(self.key)
            self.key = None

    def forget(self) -> None:
        """Release and close the descriptor (the file is being deleted)."""
        key = self.key
        self.release()
        with _LOCK_GUARD:
            fd = _LOCK_FDS.pop(key, None) if key is not None else None
        if fd is not None:
            os.close(fd)


def close_inherited_locks() -> None:
    """In a forked child: close the descriptors the writer locks are held on (the parent
    keeps the lock; a child must not keep it alive after the parent died)."""
    with _LOCK_GUARD:
        for fd in _LOCK_FDS.values():
            try:
                os.close(fd)
            except OSError:
                pass
        _LOCK_FDS.clear()
        _HELD.clear()
        _OPEN.clear()


def _blob(a: np.ndarray, dtype: str) -> bytes:
    return np.ascontiguousarray(a, dtype=dtype).tobytes()


def _sqlite_damage(path: Path, exc: sqlite3.Error) -> StoreError:
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


@dataclass
class VerifyReport:
    """What :meth:`Store.verify` found.

    Attributes
    ----------
    path : Path
    schema : int
        Schema version of the file.
    sqlite : list of str
        SQLite's ``PRAGMA integrity_check`` lines (``["ok"]`` when sound).
    problems : list of str
        Damage outside the trial batches (missing tables, an unreadable study definition).
    damaged : list of DamagedBatch
    batches, trials : int
        Batches and trials stored (damaged ones included).
    unverified : int
        Batches without a checksum (schema 1).
    planned, missing : int
        Trials the study's plan holds (sample stages up to its target) and how many of them
        no batch holds (an interrupted run or repair).
    notes : list of str
        Things that are not damage (overlapping batches are impossible; orphan failure rows).
    """

    path: Path
    schema: int = 0
    sqlite: list[str] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)
    damaged: list[DamagedBatch] = field(default_factory=list)
    batches: int = 0
    trials: int = 0
    unverified: int = 0
    planned: int = 0
    missing: int = 0
    notes: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """True when nothing is damaged."""
        return self.sqlite == ["ok"] and not self.problems and not self.damaged

    @property
    def sound(self) -> bool:
        """True when nothing is damaged and every planned trial is stored."""
        return self.ok and not self.missing

    def describe(self) -> str:
        lines = [f"store      {self.path}  (schema {self.schema})"]
        if self.sqlite == ["ok"]:
            lines.append("sqlite     ok")
        else:
            found = [ln for s in self.sqlite for ln in s.splitlines() if ln.strip()]
            found = [ln for ln in found if not ln.startswith("***")]
            more = f" (and {len(found) - 3} more)" if len(found) > 3 else ""
            lines.append(f"sqlite     damaged pages: {'; '.join(found[:3])}{more}")
        lines.append(
            f"batches    {self.batches} ({self.trials} trials): "
            f"{self.batches - len(self.damaged) - self.unverified} verified, "
            f"{len(self.damaged)} damaged, {self.unverified} without checksum"
        )
        for p in self.problems:
            lines.append(f"damaged    {p}")
        for d in self.damaged:
            lines.append(f"damaged    {d.describe()}")
        if self.planned:
            lines.append(
                f"plan       {self.planned - self.missing} of {self.planned} planned trials "
                f"stored" + (f", {self.missing} missing" if self.missing else "")
            )
        for n in self.notes:
            lines.append(f"note       {n}")
        if self.sound:
            extra = " (batches without checksum: schema 1)" if self.unverified else ""
            lines.append("verdict    sound" + extra)
        elif self.ok:
            lines.append(
                f"verdict    INCOMPLETE: {self.missing} of the {self.planned} planned trials "
                f"are missing (an interrupted run or repair); `vectorid run {self.path}` "
                "computes them"
            )
        else:
            lines.append(
                f"verdict    DAMAGED: `vectorid repair {self.path}` drops the damaged batches "
                "and recomputes them"
            )
        return "\n".join(lines)


class Store:
    """A study store on disk (SQLite, WAL mode).

    Use :meth:`create` for a new study and :meth:`open` for an existing one. A store opened
    for writing holds the writer lock until :meth:`close`.
    """

    def __init__(self, path: Path, con: sqlite3.Connection, lock: _WriterLock | None) -> None:
        self.path = path
        self._con = con
        self._lock = lock
        self._spec: StudySpec | None = None
        self._warned: set[str] = set()
        self._key = lock.key if lock is not None else _path_identity(path)
        _opened(self._key)

    # -- opening ---------------------------------------------------------------------------

    @classmethod
    def create(
        cls, path: str | Path, spec: StudySpec, data_files: Mapping[str, Any] | None = None
    ) -> Store:
        """Create a new store holding ``spec`` and its stage 0 (the box Π).

        Parameters
        ----------
        path : path
            The ``.db`` file to create.
        spec : StudySpec
        data_files : mapping, optional
            Content hashes of the data files the study reads (recorded so that a later run
            can tell an edited data file; see :mod:`vectorid.store.agreement`).

        Raises
        ------
        StoreError
            If ``path`` exists already or cannot be created.
        """
        path = Path(path)
        if path.is_dir():
            raise StoreError(
                f"{path} is a folder; give the store a file name, e.g. --store {path / 'study.db'}"
            )
        if path.exists() or path.is_symlink():
            raise StoreError(
                f"{path} exists already; open it with Store.open (vectorid run {path}) to extend "
                "the study, Study.create_or_open to resume it from Python, or choose another "
                "--store path"
            )
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise StoreError(
                f"cannot create store {path}: its folder {path.parent} cannot be made "
                f"({exc.strerror}); choose a writable folder with --store"
            ) from None
        try:
            fd = os.open(path, os.O_RDONLY | os.O_CREAT | os.O_EXCL, 0o644)
        except FileExistsError:
            raise StoreError(
                f"{path} exists already (created just now by another process); open it with "
                f"`vectorid run {path}`, or choose another --store path"
            ) from None
        except OSError as exc:
            raise StoreError(
                f"cannot create store {path}: {exc.strerror}; choose a writable folder with "
                "--store (or store = ... under [study])"
            ) from None
        lock = _WriterLock(path)
        try:
            lock.acquire(fd)
        except BaseException:
            os.unlink(path)
            raise
        con = None
        try:
            con = cls._connect(path)
            # Large pages make reading the columnar blobs back several times faster.
            con.execute("PRAGMA journal_mode=DELETE")
            con.execute("PRAGMA page_size = 65536")
            con.execute("VACUUM")
            # written in rollback-journal mode (a megabyte less of log), then WAL below
            with con:
                con.execute(f"PRAGMA application_id = {APPLICATION_ID}")
                con.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")
                con.executescript(_SCHEMA)
                con.executescript(_GENERATIONS)
            from .. import __version__

            study = json.dumps(spec.to_dict())
            with con:
                con.executemany(
                    "INSERT INTO meta VALUES (?, ?)",
                    [
                        ("schema_version", str(SCHEMA_VERSION)),
                        ("vectorid_version", __version__),
                        ("created", repr(time.time())),
                        ("study", study),
                        ("study_checksum", f"{zlib.crc32(study.encode()):08x}"),
                        ("base_dir", spec.base_dir or ""),
                        ("data_files", json.dumps(dict(data_files or {}))),
                        ("writer", _writer_text()),
                    ],
                )
                box = json.dumps(spec.space.to_list())
                con.execute(
                    "INSERT INTO stages VALUES (0, 'sample', 0, ?, ?, 'study box')",
                    (time.time(), box),
                )
                con.execute(
                    "INSERT INTO meta VALUES (?, ?)", _stage_checksum_row(0, "sample", 0, box)
                )
            con.execute("PRAGMA journal_mode=WAL")
        except BaseException as exc:
            if con is not None:
                con.close()
            for suffix in ("", "-wal", "-shm", "-journal"):
                with _suppress_os():
                    os.unlink(str(path) + suffix)
            lock.forget()
            if isinstance(exc, sqlite3.Error):
                raise StoreError(f"cannot create store {path}: {exc}") from None
            raise
        store = cls(path, con, lock)
        store._spec = spec
        store._trim_wal()  # creating wrote a megabyte of log: fold it in
        return store

    @classmethod
    def open(cls, path: str | Path, *, write: bool = False) -> Store:
        """Open an existing store.

        Parameters
        ----------
        path : path
            The ``.db`` file.
        write : bool
            Take the writer lock (needed to add trials or stages). A schema-1 store is
            upgraded to schema 2 (checksums added), with a :class:`VectoridWarning`.
        """
        path = Path(path)
        if path.is_dir():
            raise StoreError(
                f"{path} is a folder, not a study store; point to the .db file "
                "(`ls` it for *.db), or run a study file (`vectorid run STUDY.toml`)"
            )
        if not path.is_file():
            raise StoreError(
                f"no study store at {path}; "
                f"create one with `vectorid run STUDY.toml --store {path}`"
            )
        lock = None
        if write:
            if not os.access(path, os.W_OK) or not os.access(path.parent, os.W_OK):
                raise StoreError(
                    f"store {path} is read-only (or its folder is); copy it somewhere writable "
                    "to extend the study, or analyse it as it is"
                )
            lock = _WriterLock(path)
            lock.acquire()
        try:
            # Check what the file is through a read-only connection first, so a foreign or
            # damaged file is refused without a single byte of it changed.
            probe = cls._connect(path, readonly=True)
            try:
                _, version = cls._check_file(probe, path)
            finally:
                probe.close()
            con = cls._connect(path, readonly=not write)
        except BaseException:
            if lock:
                lock.release()
            raise
        store = cls(path, con, lock)
        if write:
            try:
                with store._tx() as c:
                    c.execute("INSERT OR REPLACE INTO meta VALUES ('writer', ?)", (_writer_text(),))
                if version < SCHEMA_VERSION:
                    store._upgrade(version)
            except BaseException:
                store.close()
                raise
        return store

    @staticmethod
    def _connect(path: Path, readonly: bool = False) -> sqlite3.Connection:
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
            con.text_factory = _text
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

    @staticmethod
    def _check_file(con: sqlite3.Connection, path: Path) -> tuple[int, int]:
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
            raise _sqlite_damage(path, exc) from None
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
            raise _sqlite_damage(path, exc) from None
        return app, version

    def _upgrade(self, version: int) -> None:
        """Bring an older store to the current schema: schema 1 -> 2 adds the checksum
        column and seals the batches held (after checking that their sizes fit the study);
        2 -> 3 adds the (empty) generations table of the sequential sampler."""
        sealed = bad = 0
        with self._tx() as con:
            if version < 2:
                sealed, bad = self._add_checksums(con)
            con.execute(_GENERATIONS)
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
        if version >= 2:
            return  # nothing a person needs to know: no stored number changed
        warnings.warn(
            VectoridWarning(
                f"store {self.path} upgraded from schema {version} to {SCHEMA_VERSION}: "
                f"checksums added to its {sealed} batches (written by an older vectorid, so "
                "not verified when written; from now on every batch is verified when read)"
                + (f"; {bad} batches whose sizes do not fit the study are damaged" if bad else "")
            ),
            stacklevel=3,
        )

    def _add_checksums(self, con: sqlite3.Connection) -> tuple[int, int]:
        """Schema 1 -> 2 inside the upgrade's transaction: (batches sealed, batches bad)."""
        widths = self._widths(self.spec)
        sealed = bad = 0
        cols = {r[1] for r in con.execute("PRAGMA table_info(blocks)")}
        if "checksum" not in cols:
            con.execute("ALTER TABLE blocks ADD COLUMN checksum TEXT")
        rows = con.execute(
            "SELECT block, stage, seq_start, n, x, f, g, status, wall FROM blocks"
        ).fetchall()
        for block, stage, start, n, *blobs in rows:
            if _size_problem(n, blobs, widths) is not None:
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
                _stage_checksum_row(st, kind, start, box),
            )
        return sealed, bad

    def close(self) -> None:
        """Close the connection and release the writer lock."""
        try:
            if self._lock is not None:
                try:  # fold the WAL into the main file: later reads are faster
                    self._con.execute("PRAGMA wal_checkpoint(TRUNCATE)")
                except sqlite3.Error:
                    pass
            self._con.close()
        finally:
            if self._lock:
                self._lock.release()
                self._lock = None
            key, self._key = self._key, None
            _closed(key)

    def delete(self) -> None:
        """Close and remove the store file (used to re-create a store that holds no
        computed trial from a fixed study file). Needs the writer lock."""
        self._require_write()
        if self.count() or self.count_all_blocks():
            raise StoreError(f"store {self.path} holds computed trials; it is not deleted")
        self._con.close()
        lock, self._lock = self._lock, None
        key, self._key = self._key, None
        with _LOCK_GUARD:
            if key is not None and _OPEN.get(key, 0) > 0:
                _OPEN[key] -= 1
        try:
            for suffix in ("", "-wal", "-shm", "-journal"):
                with _suppress_os():
                    os.unlink(str(self.path) + suffix)
        finally:
            if lock is not None:
                lock.forget()

    def __enter__(self) -> Store:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def writable(self) -> bool:
        return self._lock is not None

    def _require_write(self) -> None:
        if not self.writable:
            raise StoreError(f"store {self.path} was opened read-only; open it with write=True")

    @contextmanager
    def _tx(self) -> Iterator[sqlite3.Connection]:
        try:
            with self._con:
                yield self._con
        except sqlite3.OperationalError as exc:
            text = str(exc)
            if "disk" in text or "full" in text or "readonly" in text or "read-only" in text:
                raise StoreError(
                    f"cannot write to {self.path}: {text}; nothing already stored was lost — "
                    "free disk space (or fix permissions) and run again to resume"
                ) from None
            raise _sqlite_damage(self.path, exc) from None
        except sqlite3.DatabaseError as exc:
            raise _sqlite_damage(self.path, exc) from None

    @contextmanager
    def snapshot(self) -> Iterator[Store]:
        """Read one consistent state of the store while another process appends: every
        query inside the block sees the same snapshot (one SQLite read transaction)."""
        if self._con.in_transaction:
            yield self
            return
        try:
            self._con.execute("BEGIN")
        except sqlite3.Error as exc:
            raise _sqlite_damage(self.path, exc) from None
        try:
            yield self
        finally:
            if self._con.in_transaction:
                try:
                    self._con.execute("COMMIT")
                except sqlite3.Error:
                    self._con.rollback()

    def _query(self, sql: str, args: Sequence[Any] = ()) -> list[Any]:
        try:
            return self._con.execute(sql, args).fetchall()
        except sqlite3.Error as exc:
            raise _sqlite_damage(self.path, exc) from None

    # -- study and stages ------------------------------------------------------------------

    @property
    def spec(self) -> StudySpec:
        """The study definition held in the store."""
        if self._spec is None:
            rows = dict(self._query("SELECT key, value FROM meta"))
            base = rows.get("base_dir") or None
            if base is not None and not Path(base).is_dir():
                base = str(self.path.resolve().parent)
            text = rows.get("study")
            fix = (
                f"`vectorid repair {self.path} --study STUDY.toml` writes the definition back "
                "from the study file"
            )
            if text is None:
                raise StoreDamagedError(
                    f"store {self.path} is damaged: it holds no study definition; {fix}"
                )
            stored_sum = rows.get("study_checksum")
            if stored_sum is not None and stored_sum != f"{zlib.crc32(text.encode()):08x}":
                raise StoreDamagedError(
                    f"store {self.path} is damaged: its study definition does not match its "
                    f"checksum (the text changed on disk); {fix}"
                )
            try:
                data = json.loads(text)
            except ValueError as exc:
                raise StoreDamagedError(
                    f"store {self.path} is damaged: its study definition is not JSON ({exc}); {fix}"
                ) from None
            try:
                self._spec = StudySpec.from_dict(data, base_dir=base)
            except VectoridError as exc:
                raise StoreDamagedError(
                    f"store {self.path} is damaged: its study definition is invalid ({exc}); {fix}"
                ) from None
        return self._spec

    def meta(self) -> dict[str, str]:
        return dict(self._query("SELECT key, value FROM meta"))

    def set_meta(self, rows: Mapping[str, str]) -> None:
        """Set meta keys (text values) in one transaction."""
        self._require_write()
        with self._tx() as con:
            con.executemany("INSERT OR REPLACE INTO meta VALUES (?, ?)", list(rows.items()))
        self._trim_wal()

    def _write_study(self, spec_dict: Mapping[str, Any], base_dir: str | None = None) -> None:
        text = json.dumps(spec_dict)
        rows = [("study", text), ("study_checksum", f"{zlib.crc32(text.encode()):08x}")]
        if base_dir is not None:
            rows.append(("base_dir", base_dir))
        with self._tx() as con:
            con.executemany("INSERT OR REPLACE INTO meta VALUES (?, ?)", rows)
        self._spec = None

    def replace_study(self, spec: StudySpec, data_files: Mapping[str, Any] | None = None) -> None:
        """Store ``spec`` as the study definition (the caller has checked that it changes
        no computed trial, see :mod:`vectorid.store.agreement`)."""
        self._require_write()
        self._write_study(spec.to_dict(), spec.base_dir or "")
        if data_files is not None:
            with self._tx() as con:
                con.execute(
                    "INSERT OR REPLACE INTO meta VALUES ('data_files', ?)",
                    (json.dumps(dict(data_files)),),
                )

    def data_files(self) -> dict[str, Any] | None:
        """Content hashes of the data files recorded at creation (None: not recorded)."""
        text = self.meta().get("data_files")
        if text is None:
            return None
        try:
            out = json.loads(text)
        except ValueError:
            return None
        return out if isinstance(out, dict) else None

    def set_target(self, trials: int) -> None:
        """Record the total number of trials the study should hold."""
        self._require_write()
        spec = self.spec.to_dict()
        spec["study"]["trials"] = int(trials)
        self._write_study(spec)

    def set_sequential(self, budget: int | None = None, population: int | None = None) -> None:
        """Record a sequential study's ``budget`` and/or ``population`` (run settings)."""
        self._require_write()
        spec = self.spec.to_dict()
        for key, value in (("budget", budget), ("population", population)):
            if value is not None:
                spec["study"][key] = int(value)
        StudySpec.from_dict(spec, base_dir=self.spec.base_dir)  # validate before writing
        self._write_study(spec)

    def set_limits(
        self,
        criteria: Mapping[str, float | None] | None = None,
        constraints: Mapping[str, tuple[float | None, float | None]] | None = None,
        sources: Mapping[str, tuple[str, str]] | None = None,
    ) -> None:
        """Save criteria constraints Φ** (and functional constraint bounds) in the study.

        The expert's constraints are part of the study definition, so every later analysis
        (``table``, ``pareto``, ``report``, the UI) starts from them; no trial changes.

        Parameters
        ----------
        criteria : mapping, optional
            ``name -> limit`` (the worst accepted value; None removes the limit).
        constraints : mapping, optional
            ``name -> (low, high)`` of functional constraints (None for no bound).
        sources : mapping, optional
            ``name -> (limit_source, limit_note)`` of the criteria limits set here (see
            :class:`~vectorid.problem.Criterion`). A limit set without one is the expert's,
            except that a limit saved again unchanged keeps its source and note.
        """
        self._require_write()
        spec = self.spec.to_dict()
        crit = {c["name"]: c for c in spec["criteria"]}
        cons = {c["name"]: c for c in spec.get("constraints", [])}
        from ..errors import suggest

        for name, value in (criteria or {}).items():
            if name not in crit:
                raise StudyDefinitionError(
                    "limits", f"unknown criterion {name!r}", suggest(name, list(crit))
                )
            old = crit[name].get("limit")
            if value is None or not np.isfinite(value):
                crit[name].pop("limit", None)
                for key in ("limit_source", "limit_note"):
                    crit[name].pop(key, None)
            else:
                crit[name]["limit"] = float(value)
                if sources and name in sources:
                    src, note = sources[name]
                elif old is not None and float(old) == float(value):
                    continue  # saved again unchanged: keep its source
                else:
                    src, note = "expert", ""
                crit[name].pop("limit_source", None)
                crit[name].pop("limit_note", None)
                if src and (src != "expert" or note):
                    crit[name]["limit_source"] = src
                if note:
                    crit[name]["limit_note"] = note
        for name, (lo, hi) in (constraints or {}).items():
            if name not in cons:
                raise StudyDefinitionError(
                    "limits", f"unknown constraint {name!r}", suggest(name, list(cons))
                )
            for key, value in (("low", lo), ("high", hi)):
                if value is None or not np.isfinite(value):
                    cons[name].pop(key, None)
                else:
                    cons[name][key] = float(value)
        # validate before writing
        StudySpec.from_dict(spec, base_dir=self.spec.base_dir)
        self._write_study(spec)

    def stages(self) -> list[Stage]:
        """All stages in order."""
        rows = self._query(
            "SELECT stage, kind, start_seq, created, box, note FROM stages ORDER BY stage"
        )
        out = []
        from ..spec import _parse_variable

        sums = dict(self._query("SELECT key, value FROM meta WHERE key LIKE 'stage_checksum:%'"))
        for stage, kind, start, created, box, note in rows:
            want = sums.get(f"stage_checksum:{stage}")
            if want is not None and want != _stage_checksum_row(stage, kind, start, box)[1]:
                raise StoreDamagedError(
                    f"store {self.path} is damaged: stage {stage} (its box, kind or start) does "
                    f"not match its checksum; `vectorid verify {self.path}` shows what is "
                    "readable"
                )
            try:
                space = Space([_parse_variable(f"stages[{stage}].box", v) for v in json.loads(box)])
            except (ValueError, TypeError, VectoridError) as exc:
                raise StoreDamagedError(
                    f"store {self.path} is damaged: the box of stage {stage} cannot be read "
                    f"({exc}); `vectorid verify {self.path}` shows what is readable"
                ) from None
            out.append(Stage(stage, kind, start, created, space, note))
        return out

    def add_stage(
        self, space: Space, *, kind: str = "sample", start_seq: int | None = None, note: str = ""
    ) -> Stage:
        """Append a stage. A sample stage starts by default where the sequence ends."""
        self._require_write()
        if space.names != self.spec.space.names:
            raise StoreError(
                f"a stage must keep the study's variables {self.spec.space.names}, "
                f"got {space.names}"
            )
        with self._tx() as con:
            stage = con.execute("SELECT coalesce(max(stage), -1) + 1 FROM stages").fetchone()[0]
            if start_seq is None:
                start_seq = 0
                if kind == "sample":
                    start_seq = self.sequence_end()
            box = json.dumps(space.to_list())
            con.execute(
                "INSERT INTO stages VALUES (?, ?, ?, ?, ?, ?)",
                (stage, kind, start_seq, time.time(), box, note),
            )
            con.execute(
                "INSERT OR REPLACE INTO meta VALUES (?, ?)",
                _stage_checksum_row(stage, kind, start_seq, box),
            )
        return self.stages()[stage]

    def sequence_end(self) -> int:
        """One past the largest sequence index stored or reserved in a sample stage."""
        with self.snapshot():
            row = self._query(
                "SELECT max(b.seq_start + b.n) FROM blocks b JOIN stages s USING (stage) "
                "WHERE s.kind = 'sample'"
            )[0]
            stored = row[0] or 0
            last = self._query("SELECT max(start_seq) FROM stages WHERE kind = 'sample'")[0][0]
        return max(stored, last or 0)

    # -- trials ----------------------------------------------------------------------------

    def stored_ranges(self, stage: int) -> list[tuple[int, int]]:
        """Stored ``(seq_start, seq_end)`` ranges of a stage, sorted and merged."""
        rows = self._query(
            "SELECT seq_start, seq_start + n FROM blocks WHERE stage = ? ORDER BY seq_start",
            (stage,),
        )
        merged: list[tuple[int, int]] = []
        for a, b in rows:
            if merged and a <= merged[-1][1]:
                merged[-1] = (merged[-1][0], max(merged[-1][1], b))
            else:
                merged.append((a, b))
        return merged

    def missing(self, stage: int, start: int, end: int) -> list[tuple[int, int]]:
        """Sequence ranges in ``[start, end)`` of ``stage`` that hold no stored trial."""
        out = []
        pos = start
        for a, b in self.stored_ranges(stage):
            if b <= pos:
                continue
            if a >= end:
                break
            if a > pos:
                out.append((pos, min(a, end)))
            pos = max(pos, b)
        if pos < end:
            out.append((pos, end))
        return out

    def missing_planned(self, target: int | None = None) -> int:
        """Trials of the plan (sample stages up to the study's target) that no stored batch
        holds: an interrupted run or repair leaves some; ``vectorid run STORE`` computes
        them. Damaged batches count as held (``verify`` names them)."""
        target = int(self.spec.trials if target is None else target)
        sample = [s for s in self.stages() if s.kind == "sample"]
        out = 0
        for i, stage in enumerate(sample):
            end = sample[i + 1].start_seq if i + 1 < len(sample) else target
            end = min(end, target)
            if end > stage.start_seq:
                out += sum(b - a for a, b in self.missing(stage.stage, stage.start_seq, end))
        return out

    def write_batch(
        self,
        stage: int,
        seq_start: int,
        X: np.ndarray,
        criteria: np.ndarray,
        functionals: np.ndarray,
        status: np.ndarray,
        wall: np.ndarray,
        messages: dict[int, str] | None = None,
    ) -> int:
        """Store one batch in one transaction, with its checksum.

        Returns
        -------
        int
            Number of trials stored: ``len(X)``, or 0 when the range was stored already.
        """
        self._require_write()
        if int(X.shape[0]) == 0:
            return 0
        with self._tx() as con:
            n = _insert_batch(
                con, stage, seq_start, X, criteria, functionals, status, wall, messages
            )
        if n:
            self._trim_wal()
        return n

    def replace_batches(
        self, drop: Sequence[int], batches: Sequence[tuple[int, int, np.ndarray, Any]], why: str
    ) -> int:
        """Drop the batches ``drop`` and store ``batches`` (``(stage, seq_start, X,
        EvalResult)``) in **one** transaction, logged in the run log: a process killed at any
        moment leaves the store as it was before or as it is after (a crash-safe repair).
        Returns the number of trials stored."""
        self._require_write()
        stored = 0
        with self._tx() as con:
            for block in drop:
                row = con.execute(
                    "SELECT stage, seq_start, n FROM blocks WHERE block = ?", (block,)
                ).fetchone()
                if row is None:
                    continue
                con.execute("DELETE FROM blocks WHERE block = ?", (block,))
                stage, start, n = row
                if all(isinstance(v, int) for v in row):
                    con.execute(
                        "DELETE FROM failures WHERE stage = ? AND seq >= ? AND seq < ? AND NOT "
                        "EXISTS (SELECT 1 FROM blocks b WHERE b.stage = failures.stage AND "
                        "failures.seq >= b.seq_start AND failures.seq < b.seq_start + b.n)",
                        (stage, start, start + n),
                    )
            for stage, start, X, res in batches:
                stored += _insert_batch(
                    con,
                    stage,
                    start,
                    X,
                    res.criteria,
                    res.functionals,
                    res.status,
                    res.wall if res.wall is not None else np.zeros(len(X)),
                    res.messages,
                )
            con.execute(
                "INSERT INTO runs (started, finished, pid, host, executor, workers, target, "
                "outcome) VALUES (?, ?, ?, ?, 'repair', 0, NULL, ?)",
                (time.time(), time.time(), os.getpid(), socket.gethostname(), why),
            )
        self._trim_wal()
        return stored

    #: The write-ahead log is folded into the store once it passes this share of the store's
    #: size (and this many bytes at least), so that the files on disk stay within about 2x
    #: the store's size during a run.
    WAL_SHARE = 0.5
    WAL_FLOOR = 1 << 18

    def _trim_wal(self) -> None:
        """Fold the write-ahead log into the store and truncate it when it has grown past
        :data:`WAL_SHARE` of the store, if no reader holds an old snapshot (then it waits for
        a later batch: a reader is never blocked, nor is the run)."""
        try:
            wal = os.path.getsize(f"{self.path}-wal")
            main = os.path.getsize(self.path)
        except OSError:
            return
        if wal <= max(self.WAL_SHARE * main, self.WAL_FLOOR):
            return
        try:
            self._con.execute("PRAGMA busy_timeout = 0")
            self._con.execute("PRAGMA wal_checkpoint(TRUNCATE)").fetchall()
        except sqlite3.Error:
            pass
        finally:
            with _suppress_sqlite():
                self._con.execute("PRAGMA busy_timeout = 30000")

    def count(self, stage: int | None = None) -> int:
        """Number of stored trials (of one stage, or all; damaged batches included)."""
        if stage is None:
            row = self._query("SELECT coalesce(sum(n), 0) FROM blocks")[0]
        else:
            row = self._query("SELECT coalesce(sum(n), 0) FROM blocks WHERE stage = ?", (stage,))[0]
        return int(row[0])

    def count_all_blocks(self) -> int:
        """Number of stored batches (damaged ones included)."""
        return int(self._query("SELECT count(*) FROM blocks")[0][0])

    def count_sample(self) -> int:
        """Number of stored trials in sample stages (what ``--trials`` counts)."""
        row = self._query(
            "SELECT coalesce(sum(b.n), 0) FROM blocks b JOIN stages s USING (stage) "
            "WHERE s.kind = 'sample'"
        )[0]
        return int(row[0])

    @staticmethod
    def _widths(spec: StudySpec) -> dict[str, int]:
        return {
            "x": len(spec.space) * 8,
            "f": len(spec.criteria) * 8,
            "g": len(spec.constraints) * 8,
            "status": 1,
            "wall": 8,
        }

    def _has_checksums(self) -> bool:
        cols = {r[1] for r in self._query("PRAGMA table_info(blocks)")}
        return "checksum" in cols

    def _check_row(
        self,
        row: Sequence[Any],
        widths: Mapping[str, int],
        stage_kind: Mapping[int, str],
    ) -> DamagedBatch | None:
        """None if the batch is sound, else what is damaged."""
        block, stage, start, n, *blobs, checksum = row
        problem = _size_problem(n, blobs, widths)
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
                names = ["header"] + [a[0] for a in _ARRAYS]
                labels = ["header (stage, sequence start, count)"] + [a[1] for a in _ARRAYS]
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

    def load(
        self, stages: Sequence[int] | None = None, kinds: Sequence[str] = ("sample",)
    ) -> Trials:
        """Load trials into arrays, from one consistent snapshot of the store.

        Every batch is verified against its checksum; a damaged batch is left out (listed in
        :attr:`Trials.damaged`) with a :class:`~vectorid.errors.VectoridWarning`.

        Parameters
        ----------
        stages : sequence of int, optional
            Only these stages (default: every stage of the given kinds).
        kinds : sequence of str
            Stage kinds to load; sample stages by default, so auxiliary trials (sections,
            robustness checks) never mix into the sample's statistics.
        """
        with self.snapshot():
            trials = self._load(stages, kinds)
            gens = self.generations() if "sample" in kinds else []
        # a sampler that moved its particles (many variables): its importance weights
        # degenerate there, so D's members weigh their holding times in the particles' chains
        # at the stated limits instead (docs/sequential.md)
        if gens and gens[-1].proposal.get("move") is None:
            trials.log_weight = _weigher(self.spec, gens)
        elif gens:
            trials.log_weight = _chain_weigher(self.spec, gens, trials)
        if trials.damaged:
            self._warn(_damage_warning(self.path, trials.damaged))
        if trials.unverified:
            self._warn(
                f"store {self.path} was written by an older vectorid (schema 1): its "
                f"{trials.unverified} batches carry no checksum, so damage to their numbers "
                f"cannot be detected; any run on it, or `vectorid repair {self.path}`, adds "
                "checksums"
            )
        return trials

    def _warn(self, text: str) -> None:
        if text in self._warned:
            return
        self._warned.add(text)
        warnings.warn(VectoridWarning(text), stacklevel=3)

    def _load(self, stages: Sequence[int] | None, kinds: Sequence[str]) -> Trials:
        spec = self.spec
        p, k, q = len(spec.space), len(spec.criteria), len(spec.constraints)
        widths = self._widths(spec)
        stage_kind = {s.stage: s.kind for s in self.stages()}
        wanted = [
            s for s, kind in stage_kind.items() if kind in kinds and (stages is None or s in stages)
        ]
        checksum_col = "checksum" if self._has_checksums() else "NULL"
        if not wanted:
            rows: list[Any] = []
        else:
            marks = ",".join("?" * len(wanted))
            rows = self._query(
                f"SELECT block, stage, seq_start, n, x, f, g, status, wall, {checksum_col} "
                f"FROM blocks WHERE stage IN ({marks}) ORDER BY seq_start, stage",
                wanted,
            )
        damaged = []
        good = []
        unverified = 0
        # batches of a stage the store does not hold (a damaged stage number) are damage too
        known = ",".join(str(int(s)) for s in stage_kind) or "-1"
        for block, stage, start, n in self._query(
            f"SELECT block, stage, seq_start, n FROM blocks WHERE stage NOT IN ({known})"
        ):
            damaged.append(
                DamagedBatch(
                    int(block),
                    int(stage) if isinstance(stage, int) else -1,
                    int(start) if isinstance(start, int) else -1,
                    int(n) if isinstance(n, int) else 0,
                    -1,
                    -1,
                    f"it belongs to stage {stage!r}, which the store does not hold",
                    ("header",),
                )
            )
        for r in rows:
            bad = self._check_row(r, widths, stage_kind)
            if bad is not None:
                damaged.append(bad)
            else:
                good.append(r)
                unverified += r[-1] is None
        rows = good
        ns = np.array([r[3] for r in rows], dtype=np.int64)
        total = int(ns.sum()) if len(ns) else 0

        def cat(col: int, dtype: str, width: int | None) -> np.ndarray:
            shape = (total,) if width is None else (total, width)
            out = np.empty(shape, dtype=dtype.lstrip("<"))
            pos = 0
            for r in rows:
                m = r[3]
                chunk = np.frombuffer(r[col], dtype=dtype)
                out[pos : pos + m] = chunk if width is None else chunk.reshape(m, width)
                pos += m
            return out

        seq = (
            np.concatenate([np.arange(r[2], r[2] + r[3]) for r in rows])
            if rows
            else np.empty(0, np.int64)
        )
        stage = np.repeat(np.array([r[1] for r in rows], dtype=np.int64), ns)
        ids = np.empty(total, dtype=np.int64)
        for s in set(stage.tolist()):
            m = stage == s
            ids[m] = trial_ids(stage_kind[s], s, seq[m])
        messages = {}
        if wanted:
            marks = ",".join("?" * len(wanted))
            for st, sq, msg in self._query(
                f"SELECT stage, seq, message FROM failures WHERE stage IN ({marks})", wanted
            ):
                messages[(st, sq)] = msg
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

    # -- integrity -------------------------------------------------------------------------

    def verify(self) -> VerifyReport:
        """Check the whole store: SQLite's own pages, the tables, the study definition, and
        every batch against its checksum (all stages, sections included).

        Returns
        -------
        VerifyReport
        """
        rep = VerifyReport(self.path)
        try:
            rep.schema = int(self._query("PRAGMA user_version")[0][0])
        except StoreError as exc:
            rep.problems.append(str(exc))
        try:
            rep.sqlite = [str(r[0]) for r in self._con.execute("PRAGMA integrity_check(20)")]
        except sqlite3.Error as exc:
            rep.sqlite = [f"integrity check failed: {exc}"]
        try:
            spec = self.spec
            stage_kind = {s.stage: s.kind for s in self.stages()}
        except StoreError as exc:
            rep.problems.append(str(exc))
            return rep
        widths = self._widths(spec)
        checksum_col = "checksum" if self._has_checksums() else "NULL"
        try:
            blocks = self._query("SELECT block FROM blocks ORDER BY stage, seq_start")
        except StoreError as exc:
            rep.problems.append(str(exc))
            return rep
        ranges: dict[int, list[tuple[int, int]]] = {}
        failed = 0
        for (block,) in blocks:
            try:
                found = self._query(
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
            bad = self._check_row(r, widths, stage_kind)
            if bad is not None:
                rep.damaged.append(bad)
                continue
            rep.unverified += r[-1] is None
            failed += int(np.count_nonzero(np.frombuffer(r[7], dtype="i1")))
            ranges.setdefault(r[1], []).append((r[2], r[2] + r[3]))
        try:
            n_msgs = int(self._query("SELECT count(*) FROM failures")[0][0])
            if n_msgs < failed:
                rep.notes.append(
                    f"{failed - n_msgs} of {failed} failed trials have no stored reason "
                    "(their numbers are sound; only the text is missing)"
                )
        except StoreError as exc:
            rep.problems.append(f"the failure reasons cannot be read ({exc})")
        try:
            rep.planned = int(spec.trials)
            rep.missing = self.missing_planned()
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

    def check_batches(self) -> list[DamagedBatch]:
        """Every batch (all stages) checked against its checksum and sizes, one at a time:
        the damaged ones (a cheaper :meth:`verify`, without SQLite's page check)."""
        spec = self.spec
        widths = self._widths(spec)
        checksum_col = "checksum" if self._has_checksums() else "NULL"
        out = []
        with self.snapshot():
            stage_kind = {s.stage: s.kind for s in self.stages()}
            for (block,) in self._query("SELECT block FROM blocks ORDER BY stage, seq_start"):
                found = self._query(
                    f"SELECT block, stage, seq_start, n, x, f, g, status, wall, {checksum_col} "
                    "FROM blocks WHERE block = ?",
                    (block,),
                )
                if not found:
                    raise StoreDamagedError(
                        f"store {self.path} is damaged: batch {block} is listed but cannot be "
                        f"read; `vectorid repair {self.path}` rebuilds the store"
                    )
                bad = self._check_row(found[0], widths, stage_kind)
                if bad is not None:
                    out.append(bad)
        return out

    def drop_batches(self, blocks: Sequence[int], why: str) -> int:
        """Delete batches (and their failure reasons) in one transaction; logs it in the run
        log. Returns the number of trials dropped."""
        self._require_write()
        if not blocks:
            return 0
        dropped = 0
        with self._tx() as con:
            for block in blocks:
                row = con.execute(
                    "SELECT stage, seq_start, n FROM blocks WHERE block = ?", (block,)
                ).fetchone()
                if row is None:
                    continue
                stage, start, n = row
                con.execute("DELETE FROM blocks WHERE block = ?", (block,))
                # reasons of the dropped trials only: a damaged header may claim a range
                # that overlaps a sound neighbour
                con.execute(
                    "DELETE FROM failures WHERE stage = ? AND seq >= ? AND seq < ? AND NOT "
                    "EXISTS (SELECT 1 FROM blocks b WHERE b.stage = failures.stage AND "
                    "failures.seq >= b.seq_start AND failures.seq < b.seq_start + b.n)",
                    (stage, start, start + n),
                )
                dropped += int(n)
            con.execute(
                "INSERT INTO runs (started, finished, pid, host, executor, workers, target, "
                "outcome) VALUES (?, ?, ?, ?, 'repair', 0, NULL, ?)",
                (time.time(), time.time(), os.getpid(), socket.gethostname(), why),
            )
        return dropped

    # -- run log ---------------------------------------------------------------------------

    def begin_run(self, executor: str, workers: int, target: int) -> int:
        self._require_write()
        with self._tx() as con:
            # We hold the writer lock, so a run still marked running has died.
            con.execute(
                "UPDATE runs SET outcome = 'died (killed or crashed)' WHERE outcome = 'running'"
            )
            cur = con.execute(
                "INSERT INTO runs (started, pid, host, executor, workers, target, outcome) "
                "VALUES (?, ?, ?, ?, ?, ?, 'running')",
                (time.time(), os.getpid(), socket.gethostname(), executor, workers, target),
            )
            return int(cur.lastrowid)

    def end_run(self, run: int, outcome: str, report: Mapping[str, Any] | None = None) -> None:
        """Close a run record; ``report`` (failures, recovered model errors) is kept with
        it (meta key ``run_report:RUN``) and shown by :meth:`runs`."""
        with self._tx() as con:
            con.execute(
                "UPDATE runs SET finished = ?, outcome = ? WHERE run = ?",
                (time.time(), outcome, run),
            )
            if report:
                con.execute(
                    "INSERT OR REPLACE INTO meta VALUES (?, ?)",
                    (f"run_report:{int(run)}", json.dumps(dict(report))),
                )

    def runs(self) -> list[dict[str, Any]]:
        """The run log, oldest first; a run's ``report`` (failures and the model errors it
        recovered from) is None where none was kept."""
        try:
            cur = self._con.execute("SELECT * FROM runs ORDER BY run")
            names = [d[0] for d in cur.description]
            out = [dict(zip(names, row)) for row in cur.fetchall()]
            reports = dict(
                self._con.execute(
                    "SELECT key, value FROM meta WHERE key LIKE 'run_report:%'"
                ).fetchall()
            )
        except sqlite3.Error as exc:
            raise _sqlite_damage(self.path, exc) from None
        for r in out:
            try:
                r["report"] = json.loads(reports.get(f"run_report:{r['run']}", "null"))
            except ValueError:
                r["report"] = None
        return out

    # -- generations (sequential sampler) --------------------------------------------------

    def _has_generations(self) -> bool:
        rows = self._query("SELECT 1 FROM sqlite_master WHERE type='table' AND name='generations'")
        return bool(rows)

    def add_generation(
        self,
        gen: int,
        seq_start: int,
        X: np.ndarray,
        proposal: Mapping[str, Any],
        centres: np.ndarray,
        log_mix: np.ndarray,
        chol: np.ndarray,
    ) -> None:
        """Record generation ``gen`` of a sequential study before its trials are evaluated.

        Parameters
        ----------
        gen, seq_start : int
            Generation number and the first stage-0 sequence index of its trials.
        X : (n, p) float array
            The proposed parameter vectors, in the study's units.
        proposal : mapping
            JSON-able description (kind, tolerance, in-box mass, draws, ...).
        centres, log_mix, chol : float arrays
            The kernel's parameters (unit coordinates).

        Raises
        ------
        StoreError
            When generation ``gen`` is recorded already, or does not follow the last one.
        """
        self._require_write()
        n = int(X.shape[0])
        text = json.dumps(dict(proposal))
        blobs = [_blob(X, "<f8"), _blob(centres, "<f8"), _blob(log_mix, "<f8"), _blob(chol, "<f8")]
        checksum = _generation_checksum(gen, seq_start, n, text, blobs)
        with self._tx() as con:
            con.execute(_GENERATIONS)
            last = con.execute("SELECT max(gen) FROM generations").fetchone()[0]
            want = 0 if last is None else last + 1
            if gen != want:
                raise StoreError(
                    f"store {self.path}: generation {gen} cannot follow generation {last}; "
                    "another process may be running this study"
                )
            con.execute(
                "INSERT INTO generations VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                (gen, seq_start, n, time.time(), text, *blobs, checksum),
            )

    def generations(self) -> list[Generation]:
        """The sequential sampler's generations, in order (empty for a plain study).

        Raises
        ------
        StoreDamagedError
            When a generation's record does not match its checksum.
        """
        if not self._has_generations():
            return []
        p = len(self.spec.space)
        out = []
        for gen, start, n, created, text, x, c, lm, ch, checksum in self._query(
            "SELECT gen, seq_start, n, created, proposal, x, centres, log_mix, chol, checksum "
            "FROM generations ORDER BY gen"
        ):
            blobs = [x, c, lm, ch]
            if checksum != _generation_checksum(gen, start, n, text, blobs):
                raise StoreDamagedError(
                    f"store {self.path} is damaged: generation {gen} of the sequential sampler "
                    f"does not match its checksum; `vectorid verify {self.path}` shows what is "
                    "readable"
                )
            out.append(
                Generation(
                    gen=int(gen),
                    seq_start=int(start),
                    n=int(n),
                    created=float(created),
                    proposal=json.loads(text),
                    X=np.frombuffer(x, "<f8").reshape(int(n), p).astype(float),
                    centres=np.frombuffer(c, "<f8").reshape(-1, p).astype(float),
                    log_mix=np.frombuffer(lm, "<f8").astype(float),
                    chol=np.frombuffer(ch, "<f8").reshape(p, p).astype(float),
                )
            )
        return out


def _insert_batch(
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
        _blob(X, "<f8"),
        _blob(criteria, "<f8"),
        _blob(functionals, "<f8"),
        _blob(status, "i1"),
        _blob(wall, "<f8"),
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
def _suppress_sqlite() -> Iterator[None]:
    try:
        yield
    except sqlite3.Error:
        pass


@dataclass(frozen=True)
class Generation:
    """One generation of a sequential study, as stored (see the module docstring).

    Attributes
    ----------
    gen, seq_start, n : int
        Generation number; its trials are the stage-0 sequence indices
        ``seq_start .. seq_start + n - 1``.
    created : float
        Unix time it was recorded.
    proposal : dict
        ``kind`` (``"sobol"`` or ``"mixture"``), ``tolerance`` (criterion -> limit aimed
        at), ``log_mass`` and ``draws`` of the kernel, ...
    X : (n, p) float array
        The proposed vectors (empty for generation 0: the Sobol points of its indices).
    centres, log_mix, chol : float arrays
        The kernel's parameters in unit coordinates.
    """

    gen: int
    seq_start: int
    n: int
    created: float
    proposal: dict[str, Any]
    X: np.ndarray
    centres: np.ndarray
    log_mix: np.ndarray
    chol: np.ndarray


def _weigher(spec: StudySpec, gens: Sequence[Generation]) -> Any:
    """``X -> log importance weights`` over a sequential store's generations."""
    from ..sequential.kernel import Proposal
    from ..sequential.weights import log_weights

    lows, widths = spec.space.lows, spec.space.highs - spec.space.lows
    props = [Proposal.stored(g.proposal, g.centres, g.log_mix, g.chol) for g in gens]
    counts = [g.n for g in gens]

    def log_weight(X: np.ndarray) -> np.ndarray:
        return log_weights((np.asarray(X, dtype=float) - lows) / widths, props, counts)

    return log_weight


def _chain_weigher(spec: StudySpec, gens: Sequence[Generation], trials: Trials) -> Any:
    """``X -> log weights`` of a moved store's trials (computed on first use): each member of
    D at the stated limits weighs its holding time in the particles' chains there (``-inf``
    when it held none); a vector that is no member of D (or not a trial) has no weight (NaN),
    and none has one before the chains have moved enough at the stated limits."""
    memo: dict[bytes, float] = {}
    done: list[bool] = []

    def log_weight(X: np.ndarray) -> np.ndarray:
        if not done:
            # replayed from the stored generations (the run package owns the chains' rules)
            from ..run.sequential import holding_log_weights

            lw = holding_log_weights(spec, trials, gens)
            if lw is not None:
                rows = np.flatnonzero(~np.isnan(lw))
                memo.update({trials.X[i].tobytes(): float(lw[i]) for i in rows})
            done.append(True)
        X = np.ascontiguousarray(np.asarray(X, dtype=float).reshape(-1, trials.X.shape[1]))
        return np.array([memo.get(x.tobytes(), np.nan) for x in X])

    log_weight.chains = True  # type: ignore[attr-defined]
    return log_weight


def _generation_checksum(gen: int, start: int, n: int, text: str, blobs: Sequence[bytes]) -> str:
    parts = [zlib.crc32(f"{int(gen)}:{int(start)}:{int(n)}:".encode() + text.encode())]
    parts += [zlib.crc32(b) for b in blobs]
    return "crc32:" + ",".join(f"{c:08x}" for c in parts)


def _size_problem(n: Any, blobs: Sequence[Any], widths: Mapping[str, int]) -> str | None:
    """Why a batch's arrays cannot hold ``n`` trials of the study (None: they can)."""
    if not isinstance(n, int) or n < 1:
        return f"its trial count is unreadable ({n!r})"
    for (name, label, _), blob in zip(_ARRAYS, blobs):
        if not isinstance(blob, bytes):
            return f"its {label} are not stored as bytes"
        want = n * widths[name]
        if len(blob) != want:
            return (
                f"its {label} hold {len(blob)} bytes, expected {want} for {n} trials "
                "(cut short or overwritten)"
            )
    return None


def _text(data: bytes) -> str:
    return data.decode("utf-8", errors="replace")


def _stage_checksum_row(stage: int, kind: str, start: int, box: str) -> tuple[str, str]:
    text = f"{int(stage)}:{kind}:{int(start)}:{box}"
    return (f"stage_checksum:{int(stage)}", f"{zlib.crc32(text.encode()):08x}")


def _writer_text() -> str:
    return (
        f"pid {os.getpid()} on {socket.gethostname()}, since {time.strftime('%Y-%m-%d %H:%M:%S')}"
    )


@contextmanager
def _suppress_os() -> Iterator[None]:
    try:
        yield
    except OSError:
        pass
