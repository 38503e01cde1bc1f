"""The embedded study store: one SQLite file per study.

Layout (schema version 1; ``PRAGMA application_id`` marks the file as a vectorid store):

``meta(key, value)``
    ``schema_version``, ``vectorid_version``, ``created`` and ``study``: the study definition
    as JSON, so a store alone is enough to analyse or extend the study.
``stages(stage, kind, start_seq, created, box, note)``
    Stage 0 is the study's box Π; double tuning adds stages with a narrower box that keep
    drawing from the sequence at ``start_seq`` onward. ``kind`` is ``"sample"`` for stages
    drawn from the point sequence (other kinds, such as sections, hold extra trials that
    never mix into the sample's statistics).
``blocks(block, stage, seq_start, n, created, x, f, g, status, wall)``
    Append-only trial records. One row is one evaluated batch of ``n`` trials with
    consecutive sequence indices ``seq_start .. seq_start + n - 1``: parameters ``x``
    (n, p), criteria ``f`` (n, k), functionals ``g`` (n, q) and wall time per trial
    ``wall`` (n,) as little-endian float64, ``status`` (n,) as int8 (0 ok, 1 failed).
    Storing a batch as one columnar row makes a batch one transaction and loading a million
    trials a matter of concatenating a few hundred buffers.
``failures(stage, seq, message)``
    The reason of every failed trial.
``runs(run, started, finished, pid, host, executor, workers, target, outcome)``
    A log of run sessions (interrupted ones included).

Exactly-once: a batch whose sequence range overlaps a stored range of the same stage is
not stored again (it is counted as a duplicate), so a batch computed twice (a retried task,
a resumed run) is stored once. One process at a time may write: the writer holds an
exclusive advisory lock on ``<store>.lock``, released by the OS when the process dies, so a
run killed with ``kill -9`` can be resumed at once.
"""

from __future__ import annotations

import json
import os
import socket
import sqlite3
import time
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import StoreError, StoreLockedError
from ..space import Space
from ..spec import StudySpec

__all__ = ["SCHEMA_VERSION", "Stage", "Store", "Trials"]

SCHEMA_VERSION = 1
APPLICATION_ID = 0x56494431  # "VID1"

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
    wall BLOB NOT NULL
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

    def __len__(self) -> int:
        return int(self.id.shape[0])

    def subset(self, mask: np.ndarray) -> Trials:
        """The trials where ``mask`` is true."""
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
        )

    def message(self, i: int) -> str:
        """Failure message of row ``i`` ('' if it did not fail)."""
        return self.messages.get((int(self.stage[i]), int(self.seq[i])), "")


def trial_ids(kind: str, stage: int, seq: np.ndarray) -> np.ndarray:
    """Trial ids: LP_tau point number ``seq + 1`` for sample stages; for auxiliary stages
    ``stage * 1_000_000_000 + seq + 1``, which never collides with a sample trial."""
    seq = np.asarray(seq, dtype=np.int64)
    if kind == "sample":
        return seq + 1
    return stage * 1_000_000_000 + seq + 1


class _WriterLock:
    """Exclusive advisory lock on ``<store>.lock`` (POSIX ``flock``)."""

    def __init__(self, path: Path) -> None:
        self.path = Path(str(path) + ".lock")
        self.fd: int | None = None

    def acquire(self) -> None:
        import fcntl

        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            try:
                holder = os.pread(fd, 200, 0).decode(errors="replace").strip()
            finally:
                os.close(fd)
            raise StoreLockedError(
                f"store {self.path.with_suffix('')} is being written by another process "
                f"({holder or 'unknown'}); wait for it to finish (or stop it), or run with "
                "another --store"
            ) from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"pid {os.getpid()} on {socket.gethostname()}".encode(), 0)
        self.fd = fd

    def release(self) -> None:
        if self.fd is not None:
            import fcntl

            fcntl.flock(self.fd, fcntl.LOCK_UN)
            os.close(self.fd)
            self.fd = None


def _blob(a: np.ndarray, dtype: str) -> bytes:
    return np.ascontiguousarray(a, dtype=dtype).tobytes()


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

    # -- opening ---------------------------------------------------------------------------

    @classmethod
    def create(cls, path: str | Path, spec: StudySpec) -> Store:
        """Create a new store holding ``spec`` and its stage 0 (the box Π).

        Raises
        ------
        StoreError
            If ``path`` exists already.
        """
        path = Path(path)
        if path.exists():
            raise StoreError(
                f"{path} exists already; open it with Store.open (vectorid run {path}) to extend "
                "the study, or choose another --store path"
            )
        path.parent.mkdir(parents=True, exist_ok=True)
        lock = _WriterLock(path)
        lock.acquire()
        try:
            con = cls._connect(path)
            # Large pages make reading the columnar blobs back several times faster.
            con.execute("PRAGMA journal_mode=DELETE")
            con.execute("PRAGMA page_size = 65536")
            con.execute("VACUUM")
            con.execute("PRAGMA journal_mode=WAL")
            with con:
                con.execute(f"PRAGMA application_id = {APPLICATION_ID}")
                con.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")
                con.executescript(_SCHEMA)
            from .. import __version__

            study = spec.to_dict()
            with con:
                con.executemany(
                    "INSERT INTO meta VALUES (?, ?)",
                    [
                        ("schema_version", str(SCHEMA_VERSION)),
                        ("vectorid_version", __version__),
                        ("created", repr(time.time())),
                        ("study", json.dumps(study)),
                        ("base_dir", spec.base_dir or ""),
                    ],
                )
                con.execute(
                    "INSERT INTO stages VALUES (0, 'sample', 0, ?, ?, 'study box')",
                    (time.time(), json.dumps(spec.space.to_list())),
                )
        except sqlite3.Error as exc:
            lock.release()
            raise StoreError(f"cannot create store {path}: {exc}") from exc
        except BaseException:
            lock.release()
            raise
        store = cls(path, con, lock)
        store._spec = spec
        return store

    @classmethod
    def open(cls, path: str | Path, *, write: bool = False) -> Store:
        """Open an existing store.

        Parameters
        ----------
        path : path
            The ``.db`` file.
        write : bool
            Take the writer lock (needed to add trials or stages).
        """
        path = Path(path)
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
                cls._check_file(probe, path)
            finally:
                probe.close()
            con = cls._connect(path, readonly=not write)
        except BaseException:
            if lock:
                lock.release()
            raise
        return cls(path, con, lock)

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
        except StoreError:
            raise
        except sqlite3.Error as exc:
            if "not a database" in str(exc) or "malformed" in str(exc):
                raise StoreError(
                    f"{path} is not a vectorid store (not a readable SQLite file: {exc}); "
                    "was it truncated or is it another file?"
                ) from exc
            raise StoreError(f"cannot open {path} as SQLite: {exc}") from exc
        con.execute("PRAGMA foreign_keys=ON")
        con.execute("PRAGMA mmap_size=17179869184")
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
            ) from exc
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
            con.execute("SELECT count(*) FROM blocks").fetchone()
        except sqlite3.DatabaseError as exc:
            raise StoreError(f"{path} is damaged: {exc}") from exc
        return app, version

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
                ) from exc
            raise StoreError(f"cannot write to {self.path}: {text}") from exc

    # -- study and stages ------------------------------------------------------------------

    @property
    def spec(self) -> StudySpec:
        """The study definition held in the store."""
        if self._spec is None:
            rows = dict(self._con.execute("SELECT key, value FROM meta").fetchall())
            base = rows.get("base_dir") or None
            if base is not None and not Path(base).is_dir():
                base = str(self.path.resolve().parent)
            self._spec = StudySpec.from_dict(json.loads(rows["study"]), base_dir=base)
        return self._spec

    def meta(self) -> dict[str, str]:
        return dict(self._con.execute("SELECT key, value FROM meta").fetchall())

    def set_target(self, trials: int) -> None:
        """Record the total number of trials the study should hold."""
        self._require_write()
        spec = self.spec.to_dict()
        spec["study"]["trials"] = int(trials)
        with self._tx() as con:
            con.execute("UPDATE meta SET value = ? WHERE key = 'study'", (json.dumps(spec),))
        self._spec = None

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
        from ..errors import StudyDefinitionError, suggest

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
        with self._tx() as con:
            con.execute("UPDATE meta SET value = ? WHERE key = 'study'", (json.dumps(spec),))
        self._spec = None

    def stages(self) -> list[Stage]:
        """All stages in order."""
        rows = self._con.execute(
            "SELECT stage, kind, start_seq, created, box, note FROM stages ORDER BY stage"
        ).fetchall()
        out = []
        for stage, kind, start, created, box, note in rows:
            from ..spec import _parse_variable

            space = Space([_parse_variable(f"stages[{stage}].box", v) for v in json.loads(box)])
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
            con.execute(
                "INSERT INTO stages VALUES (?, ?, ?, ?, ?, ?)",
                (stage, kind, start_seq, time.time(), json.dumps(space.to_list()), note),
            )
        return self.stages()[stage]

    def sequence_end(self) -> int:
        """One past the largest sequence index stored or reserved in a sample stage."""
        row = self._con.execute(
            "SELECT max(b.seq_start + b.n) FROM blocks b JOIN stages s USING (stage) "
            "WHERE s.kind = 'sample'"
        ).fetchone()
        stored = row[0] or 0
        last = (
            self._con.execute("SELECT max(start_seq) FROM stages WHERE kind = 'sample'").fetchone()[
                0
            ]
            or 0
        )
        return max(stored, last)

    # -- trials ----------------------------------------------------------------------------

    def stored_ranges(self, stage: int) -> list[tuple[int, int]]:
        """Stored ``(seq_start, seq_end)`` ranges of a stage, sorted and merged."""
        rows = self._con.execute(
            "SELECT seq_start, seq_start + n FROM blocks WHERE stage = ? ORDER BY seq_start",
            (stage,),
        ).fetchall()
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
        """Store one batch in one transaction.

        Returns
        -------
        int
            Number of trials stored: ``len(X)``, or 0 when the range was stored already.
        """
        self._require_write()
        n = int(X.shape[0])
        if n == 0:
            return 0
        with self._tx() as con:
            overlap = con.execute(
                "SELECT 1 FROM blocks WHERE stage = ? AND seq_start < ? AND seq_start + n > ? "
                "LIMIT 1",
                (stage, seq_start + n, seq_start),
            ).fetchone()
            if overlap:
                return 0
            con.execute(
                "INSERT INTO blocks (stage, seq_start, n, created, x, f, g, status, wall) "
                "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                (
                    stage,
                    seq_start,
                    n,
                    time.time(),
                    _blob(X, "<f8"),
                    _blob(criteria, "<f8"),
                    _blob(functionals, "<f8"),
                    _blob(status, "i1"),
                    _blob(wall, "<f8"),
                ),
            )
            if messages:
                con.executemany(
                    "INSERT OR REPLACE INTO failures VALUES (?, ?, ?)",
                    [(stage, seq_start + int(i), m) for i, m in messages.items()],
                )
        return n

    def count(self, stage: int | None = None) -> int:
        """Number of stored trials (of one stage, or all)."""
        if stage is None:
            row = self._con.execute("SELECT coalesce(sum(n), 0) FROM blocks").fetchone()
        else:
            row = self._con.execute(
                "SELECT coalesce(sum(n), 0) FROM blocks WHERE stage = ?", (stage,)
            ).fetchone()
        return int(row[0])

    def count_sample(self) -> int:
        """Number of stored trials in sample stages (what ``--trials`` counts)."""
        row = self._con.execute(
            "SELECT coalesce(sum(b.n), 0) FROM blocks b JOIN stages s USING (stage) "
            "WHERE s.kind = 'sample'"
        ).fetchone()
        return int(row[0])

    def load(
        self, stages: Sequence[int] | None = None, kinds: Sequence[str] = ("sample",)
    ) -> Trials:
        """Load trials into arrays.

        Parameters
        ----------
        stages : sequence of int, optional
            Only these stages (default: every stage of the given kinds).
        kinds : sequence of str
            Stage kinds to load; sample stages by default, so auxiliary trials (sections,
            robustness checks) never mix into the sample's statistics.
        """
        spec = self.spec
        p, k, q = len(spec.space), len(spec.criteria), len(spec.constraints)
        stage_kind = {s.stage: s.kind for s in self.stages()}
        wanted = [
            s for s, kind in stage_kind.items() if kind in kinds and (stages is None or s in stages)
        ]
        if not wanted:
            rows: list[Any] = []
        else:
            marks = ",".join("?" * len(wanted))
            rows = self._con.execute(
                f"SELECT stage, seq_start, n, x, f, g, status, wall FROM blocks "
                f"WHERE stage IN ({marks}) ORDER BY seq_start, stage",
                wanted,
            ).fetchall()
        ns = np.array([r[2] for r in rows], dtype=np.int64)
        total = int(ns.sum()) if len(ns) else 0

        def cat(col: int, dtype: str, width: int | None) -> np.ndarray:
            shape = (total,) if width is None else (total, width)
            out = np.empty(shape, dtype=dtype.lstrip("<"))
            pos = 0
            for r in rows:
                m = r[2]
                chunk = np.frombuffer(r[col], dtype=dtype)
                out[pos : pos + m] = chunk if width is None else chunk.reshape(m, width)
                pos += m
            return out

        seq = (
            np.concatenate([np.arange(r[1], r[1] + r[2]) for r in rows])
            if rows
            else np.empty(0, np.int64)
        )
        stage = np.repeat(np.array([r[0] for r in rows], dtype=np.int64), ns)
        ids = np.empty(total, dtype=np.int64)
        for s in set(stage.tolist()):
            m = stage == s
            ids[m] = trial_ids(stage_kind[s], s, seq[m])
        messages = {}
        if wanted:
            marks = ",".join("?" * len(wanted))
            for st, sq, msg in self._con.execute(
                f"SELECT stage, seq, message FROM failures WHERE stage IN ({marks})", wanted
            ):
                messages[(st, sq)] = msg
        return Trials(
            id=ids,
            seq=seq.astype(np.int64),
            stage=stage,
            status=cat(6, "i1", None),
            X=cat(3, "<f8", p),
            F=cat(4, "<f8", k),
            G=cat(5, "<f8", q),
            wall=cat(7, "<f8", None),
            messages=messages,
        )

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

    def end_run(self, run: int, outcome: str) -> None:
        with self._tx() as con:
            con.execute(
                "UPDATE runs SET finished = ?, outcome = ? WHERE run = ?",
                (time.time(), outcome, run),
            )

    def runs(self) -> list[dict[str, Any]]:
        cur = self._con.execute("SELECT * FROM runs ORDER BY run")
        names = [d[0] for d in cur.description]
        return [dict(zip(names, row)) for row in cur.fetchall()]
