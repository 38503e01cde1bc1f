"""The embedded study store: one SQLite file per study.

The file's layout (tables, checksums, schema versions) is described in
:mod:`vectorid.store.schema`. Older schemas are read, and upgraded by the first writer.

Exactly-once: a batch whose sequence range overlaps a stored range of the same stage is
not stored again (it is counted as a duplicate), so a batch computed twice (a retried task,
a resumed run) is stored once.

One writer (:mod:`vectorid.store.lock`): a process that writes holds an exclusive advisory
lock on the store file itself. Readers take no lock and read one consistent snapshot (one
SQLite read transaction per load) while a writer appends.

The store stores; it knows no sampler, no analysis and no model.
"""

from __future__ import annotations

import json
import os
import socket
import sqlite3
import time
import warnings
import zlib
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import (
    StoreDamagedError,
    StoreError,
    VectoridError,
    VectoridWarning,
)
from ..limits import study_with_limits
from ..space import Space
from ..spec import StudySpec, parse_variable
from . import integrity
from .lock import (
    WriterLock,
    file_closed,
    file_opened,
    forget_opened,
    new_store_file,
    path_identity,
    writer_text,
)
from .records import (
    DamagedBatch,
    SamplerRecord,
    Stage,
    Trials,
    VerifyReport,
    damage_warning,
    record_checksum,
)
from .schema import (
    GENERATIONS,
    SCHEMA_VERSION,
    blob,
    check_file,
    connect,
    decode_batches,
    initialise,
    insert_batch,
    sqlite_damage,
    stage_checksum_row,
    suppress_os,
    suppress_sqlite,
    upgrade,
    widths,
)

__all__ = ["Store"]


class Store:
    """A study store on disk (SQLite, WAL mode).

    Use :meth:`create` for a new study and :meth:`open` for an existing one. A store opened
    for writing holds the writer lock until :meth:`close`.
    """

    def __init__(self, path: Path, con: sqlite3.Connection, lock: WriterLock | None) -> None:
        self.path = path
        self._con = con
        self._lock = lock
        self._spec: StudySpec | None = None
        self._warned: set[str] = set()
        self._key = lock.key if lock is not None else path_identity(path)
        file_opened(self._key)

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
        lock = new_store_file(path)
        con = None
        try:
            con = connect(path)
            initialise(con, spec.to_dict(), spec.space.to_list(), spec.base_dir, data_files)
            con.execute("PRAGMA journal_mode=WAL")
        except BaseException as exc:
            if con is not None:
                con.close()
            for suffix in ("", "-wal", "-shm", "-journal"):
                with suppress_os():
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
            lock = WriterLock(path)
            lock.acquire()
        try:
            # Check what the file is through a read-only connection first, so a foreign or
            # damaged file is refused without a single byte of it changed.
            probe = connect(path, readonly=True)
            try:
                _, version = check_file(probe, path)
            finally:
                probe.close()
            con = connect(path, readonly=not write)
        except BaseException:
            if lock:
                lock.release()
            raise
        store = cls(path, con, lock)
        if write:
            try:
                with store._tx() as c:
                    c.execute("INSERT OR REPLACE INTO meta VALUES ('writer', ?)", (writer_text(),))
                if version < SCHEMA_VERSION:
                    store._upgrade(version)
            except BaseException:
                store.close()
                raise
        return store

    def _upgrade(self, version: int) -> None:
        """Bring an older store to the current schema: schema 1 -> 2 adds the checksum
        column and seals the batches held (after checking that their sizes fit the study);
        2 -> 3 adds the (empty) generations table of the sequential sampler."""
        with self._tx() as con:
            sealed, bad = upgrade(con, version, widths(self.spec))
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
            file_closed(key)

    def delete(self) -> None:
        """Close and remove the store file (used to re-create a store that holds no
        computed trial from a fixed study file). Needs the writer lock."""
        self._require_write()
        if self.count() or self.count_all_blocks():
            raise StoreError(f"store {self.path} holds computed trials; it is not deleted")
        self._con.close()
        lock, self._lock = self._lock, None
        key, self._key = self._key, None
        forget_opened(key)
        try:
            for suffix in ("", "-wal", "-shm", "-journal"):
                with suppress_os():
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
            raise sqlite_damage(self.path, exc) from None
        except sqlite3.DatabaseError as exc:
            raise sqlite_damage(self.path, exc) from None

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
            raise sqlite_damage(self.path, exc) from None
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
            raise sqlite_damage(self.path, exc) from None

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
        return self.meta_json("data_files")

    def meta_json(self, key: str) -> dict[str, Any] | None:
        """The JSON object a meta key holds (None: no such key, or not a JSON object)."""
        text = self.meta().get(key)
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

    def set_study_keys(self, **keys: Any) -> None:
        """Record run settings of the study's ``[study]`` table (a sampler's ``budget`` or
        ``population``), validated as a study file would be before anything is written.

        Parameters
        ----------
        **keys
            ``[study]`` keys and their values (None leaves a key as it is).
        """
        self._require_write()
        spec = self.spec.to_dict()
        for key, value in keys.items():
            if value is not None:
                spec["study"][key] = value
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
        spec = study_with_limits(self.spec.to_dict(), criteria, constraints, sources)
        StudySpec.from_dict(spec, base_dir=self.spec.base_dir)  # validate before writing
        self._write_study(spec)

    def stages(self) -> list[Stage]:
        """All stages in order."""
        rows = self._query(
            "SELECT stage, kind, start_seq, created, box, note FROM stages ORDER BY stage"
        )
        out = []
        sums = dict(self._query("SELECT key, value FROM meta WHERE key LIKE 'stage_checksum:%'"))
        for stage, kind, start, created, box, note in rows:
            want = sums.get(f"stage_checksum:{stage}")
            if want is not None and want != stage_checksum_row(stage, kind, start, box)[1]:
                raise StoreDamagedError(
                    f"store {self.path} is damaged: stage {stage} (its box, kind or start) does "
                    f"not match its checksum; `vectorid verify {self.path}` shows what is "
                    "readable"
                )
            try:
                space = Space([parse_variable(f"stages[{stage}].box", v) for v in json.loads(box)])
            except (ValueError, TypeError, VectoridError) as exc:
                raise StoreDamagedError(
                    f"store {self.path} is damaged: the box of stage {stage} cannot be read "
                    f"({exc}); `vectorid verify {self.path}` shows what is readable"
                ) from None
            out.append(Stage(stage, kind, start, created, space, note))
        return out

    def stage_kind(self, stage: int) -> str:
        """The kind of stage ``stage`` (``"sample"``, ``"section"``, ...)."""
        row = self._query("SELECT kind FROM stages WHERE stage = ?", (stage,))
        if not row:
            raise StoreError(f"store {self.path} holds no stage {stage}")
        return str(row[0][0])

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
                stage_checksum_row(stage, kind, start_seq, box),
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

    def batch_headers(self) -> list[tuple[Any, Any, Any, Any]]:
        """``(block, stage, seq_start, n)`` of every stored batch, as stored (a damaged header
        may hold something other than integers)."""
        return [tuple(r) for r in self._query("SELECT block, stage, seq_start, n FROM blocks")]

    def batch_parameters(self, block: int) -> bytes | None:
        """The raw parameter array of batch ``block`` (None: no such batch)."""
        row = self._query("SELECT x FROM blocks WHERE block = ?", (block,))
        return bytes(row[0][0]) if row else None

    def stage_box_text(self, stage: int) -> str | None:
        """The JSON text of a stage's box, unparsed (None: no such stage)."""
        row = self._query("SELECT box FROM stages WHERE stage = ?", (stage,))
        return str(row[0][0]) if row else None

    def missing_in(self, plan: Sequence[tuple[int, int, int]]) -> int:
        """Trials of ``plan`` (``(stage, start, end)`` sequence ranges, as a sampler plans
        them) that no stored batch holds: an interrupted run or repair leaves some;
        ``vectorid run STORE`` computes them. Damaged batches count as held (``verify``
        names them).

        Parameters
        ----------
        plan : sequence of (stage, start, end)

        Returns
        -------
        int
        """
        return sum(b - a for stage, s, e in plan for a, b in self.missing(stage, s, e))

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
            n = insert_batch(
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
                stored += insert_batch(
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
            with suppress_sqlite():
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

    def _has_checksums(self) -> bool:
        cols = {r[1] for r in self._query("PRAGMA table_info(blocks)")}
        return "checksum" in cols

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
        if trials.damaged:
            self._warn(damage_warning(self.path, trials.damaged))
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
        w = widths(spec)
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
        messages = {}
        if wanted:
            marks = ",".join("?" * len(wanted))
            for st, sq, msg in self._query(
                f"SELECT stage, seq, message FROM failures WHERE stage IN ({marks})", wanted
            ):
                messages[(st, sq)] = msg
        return decode_batches(rows, w, stage_kind, (p, k, q), messages, damaged)

    # -- integrity -------------------------------------------------------------------------

    def verify(self, plan: Sequence[tuple[int, int, int]] | None = None) -> VerifyReport:
        """Check the whole store (:func:`vectorid.store.integrity.verify`).

        Parameters
        ----------
        plan : sequence of (stage, start, end), optional
            The sequence ranges the study's sampler planned (see there).

        Returns
        -------
        VerifyReport
        """
        return integrity.verify(self, plan)

    def check_batches(self) -> list[DamagedBatch]:
        """Every batch checked against its checksum and sizes, one at a time
        (:func:`vectorid.store.integrity.check_batches`).

        Returns
        -------
        list of DamagedBatch
        """
        return integrity.check_batches(self)

    def read_rows(self, sql: str, args: Sequence[Any] = ()) -> list[Any]:
        """Rows of one read-only SQL query (``sql`` with ``args``) on the store file: the
        integrity checks read what :meth:`load` would refuse this way. A file SQLite cannot
        read raises :class:`StoreError` saying how to repair it."""
        return self._query(sql, args)

    def sqlite_check(self) -> list[str]:
        """SQLite's own ``PRAGMA integrity_check`` of the file's pages (``["ok"]`` when
        sound)."""
        try:
            return [str(r[0]) for r in self._con.execute("PRAGMA integrity_check(20)")]
        except sqlite3.Error as exc:
            return [f"integrity check failed: {exc}"]

    def has_checksums(self) -> bool:
        """Whether the batches carry checksums (every store written since schema 2)."""
        return self._has_checksums()

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
            raise sqlite_damage(self.path, exc) from None
        for r in out:
            try:
                r["report"] = json.loads(reports.get(f"run_report:{r['run']}", "null"))
            except ValueError:
                r["report"] = None
        return out

    # -- a sampler's records ----------------------------------------------------------------

    def _has_records(self) -> bool:
        rows = self._query("SELECT 1 FROM sqlite_master WHERE type='table' AND name='generations'")
        return bool(rows)

    def add_sampler_record(
        self,
        index: int,
        seq_start: int,
        n: int,
        info: Mapping[str, Any],
        arrays: Sequence[np.ndarray] = (),
    ) -> None:
        """Keep record ``index`` of the study's sampler, before its trials are evaluated.

        The store keeps it as given (with a checksum) and never interprets it (see
        :class:`~vectorid.store.records.SamplerRecord`).

        Parameters
        ----------
        index : int
            Record number: 0 for the first, then one more than the last.
        seq_start, n : int
            The stage-0 sequence indices ``seq_start .. seq_start + n - 1`` it plans.
        info : mapping
            JSON-able description.
        arrays : sequence of float arrays
            At most four arrays, kept as flat little-endian float64 (shapes are the
            sampler's to know).

        Raises
        ------
        StoreError
            When record ``index`` is kept already, or does not follow the last one.
        """
        self._require_write()
        if len(arrays) > 4:
            raise ValueError(f"a sampler record keeps at most 4 arrays, got {len(arrays)}")
        text = json.dumps(dict(info))
        blobs = [blob(a, "<f8") for a in arrays] + [b""] * (4 - len(arrays))
        checksum = record_checksum(index, seq_start, n, text, blobs)
        with self._tx() as con:
            con.execute(GENERATIONS)
            last = con.execute("SELECT max(gen) FROM generations").fetchone()[0]
            want = 0 if last is None else last + 1
            if index != want:
                raise StoreError(
                    f"store {self.path}: sampler record {index} cannot follow record {last}; "
                    "another process may be running this study"
                )
            con.execute(
                "INSERT INTO generations VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                (index, seq_start, n, time.time(), text, *blobs, checksum),
            )

    def sampler_record_count(self) -> int:
        """How many records the study's sampler keeps (records are numbered from 0)."""
        if not self._has_records():
            return 0
        return int(self._query("SELECT count(*) FROM generations")[0][0])

    def sampler_records(self) -> list[SamplerRecord]:
        """The sampler's records, in order (empty for a sampler that keeps none).

        Raises
        ------
        StoreDamagedError
            When a record does not match its checksum.
        """
        if not self._has_records():
            return []
        out = []
        for index, start, n, created, text, *blobs, checksum in self._query(
            "SELECT gen, seq_start, n, created, proposal, x, centres, log_mix, chol, checksum "
            "FROM generations ORDER BY gen"
        ):
            if checksum != record_checksum(index, start, n, text, blobs):
                raise StoreDamagedError(
                    f"store {self.path} is damaged: record {index} of the study's sampler "
                    f"(generation {index}) does not match its checksum; `vectorid verify "
                    f"{self.path}` shows what is readable"
                )
            arrays = tuple(np.frombuffer(x, "<f8").astype(float) for x in blobs)
            record = SamplerRecord(
                int(index), int(start), int(n), float(created), json.loads(text), arrays
            )
            out.append(record)
        return out
