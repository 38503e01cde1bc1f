"""What a store holds, as values: trials, stages, damaged batches, a sampler's records.

Nothing here reads or writes a file; :class:`vectorid.store.Store` does. The sampler's
records (:class:`SamplerRecord`) are rows the store keeps for a sampler without interpreting
them: the sampler (:mod:`vectorid.samplers`) turns them into its own state.
"""

from __future__ import annotations

import zlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..space import Space

__all__ = [
    "ARRAYS",
    "DamagedBatch",
    "SamplerRecord",
    "Stage",
    "Trials",
    "VerifyReport",
    "batch_checksum",
    "damage_warning",
    "record_checksum",
    "size_problem",
    "trial_ids",
]

#: The arrays of a batch, in the order of the checksum: (column, label, dtype).
ARRAYS = (
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


def damage_warning(path: Path, damaged: Sequence[DamagedBatch]) -> str:
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
    """A stage of a study: a box of trials and where in its sequence it starts.

    Attributes
    ----------
    stage : int
        Stage number (0: the study's box).
    kind : str
        ``"sample"`` for trials drawn by the study's sampler (they make up the sample every
        analysis reads); other kinds (``"section"``, ``"robustness"``, ``"search"``) hold
        extra trials that never mix into the sample's statistics.
    start_seq : int
        First sequence index of the stage.
    created : float
        Unix time.
    space : Space
        The stage's box.
    note : str
        Why it was added.
    """

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


@dataclass(frozen=True)
class SamplerRecord:
    """One record a sampler keeps in the store (the store does not interpret it).

    A sampler that decides its trials from the ones before (the sequential sampler's
    generations) records, *before* they are evaluated, which sequence indices it planned and
    whatever it needs to replay its decisions: a JSON-able ``info`` and up to four float64
    arrays. The store keeps them with a checksum and gives them back as written.

    Attributes
    ----------
    index : int
        Record number, 0, 1, 2, ... in order.
    seq_start, n : int
        The stage-0 sequence indices ``seq_start .. seq_start + n - 1`` it planned.
    created : float
        Unix time it was written.
    info : dict
        The sampler's JSON-able description.
    arrays : tuple of (m,) float64 arrays
        Four flat arrays, as written (an empty array for one the sampler left out); the
        sampler knows their shapes.
    """

    index: int
    seq_start: int
    n: int
    created: float
    info: dict[str, Any]
    arrays: tuple[np.ndarray, ...]


def record_checksum(gen: int, start: int, n: int, text: str, blobs: Sequence[bytes]) -> str:
    parts = [zlib.crc32(f"{int(gen)}:{int(start)}:{int(n)}:".encode() + text.encode())]
    parts += [zlib.crc32(b) for b in blobs]
    return "crc32:" + ",".join(f"{c:08x}" for c in parts)


def size_problem(n: Any, blobs: Sequence[Any], widths: Mapping[str, int]) -> str | None:
    """Why a batch's arrays cannot hold ``n`` trials of the study (None: they can)."""
    if not isinstance(n, int) or n < 1:
        return f"its trial count is unreadable ({n!r})"
    for (name, label, _), blob in zip(ARRAYS, blobs):
        if not isinstance(blob, bytes):
            return f"its {label} are not stored as bytes"
        want = n * widths[name]
        if len(blob) != want:
            return (
                f"its {label} hold {len(blob)} bytes, expected {want} for {n} trials "
                "(cut short or overwritten)"
            )
    return None
