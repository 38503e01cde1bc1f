"""One writer per store file: an exclusive advisory lock (``flock``) on the file itself.

A process that writes holds the lock on the store file, so the lock follows the file's
identity (its inode), whatever path, symlink or hard link names it; the OS releases it when
the process dies, so a run killed with ``kill -9`` can be resumed at once.
"""

from __future__ import annotations

import fcntl
import os
import socket
import sqlite3
import threading
import time
from pathlib import Path

from ..errors import StoreError, StoreLockedError

__all__ = [
    "WriterLock",
    "close_inherited_locks",
    "file_closed",
    "file_opened",
    "forget_opened",
    "new_store_file",
    "path_identity",
    "writer_text",
]


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


def file_opened(key: tuple[int, int] | None) -> None:
    if key is not None:
        with _LOCK_GUARD:
            _OPEN[key] = _OPEN.get(key, 0) + 1


def file_closed(key: tuple[int, int] | None) -> None:
    if key is None:
        return
    with _LOCK_GUARD:
        n = _OPEN.get(key, 0) - 1
        if n > 0:
            _OPEN[key] = n
        else:
            _OPEN.pop(key, None)
        _close_unused(key)


def path_identity(path: Path) -> tuple[int, int] | None:
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


class WriterLock:
    """Exclusive advisory lock (``flock``) on the store file itself: one writer per file,
    whatever path names it (a symlink or a hard link names the same inode)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.key: tuple[int, int] | None = None

    def acquire(self, fd: int | None = None) -> None:
        """Take the lock (on ``fd`` when given: a file this process just created)."""
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


def writer_text() -> str:
    return (
        f"pid {os.getpid()} on {socket.gethostname()}, since {time.strftime('%Y-%m-%d %H:%M:%S')}"
    )


def forget_opened(key: tuple[int, int] | None) -> None:
    """A store of this process that had ``key`` open is gone without closing its lock
    descriptor (its file is being deleted)."""
    with _LOCK_GUARD:
        if key is not None and _OPEN.get(key, 0) > 0:
            _OPEN[key] -= 1


def new_store_file(path: Path) -> WriterLock:
    """Create the empty file of a new store, exclusively, and take its writer lock.

    Parameters
    ----------
    path : Path
        The ``.db`` file to create.

    Returns
    -------
    WriterLock
        Held on the new file.

    Raises
    ------
    StoreError
        If ``path`` is a folder, exists already or cannot be created.
    """
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
    lock = WriterLock(path)
    try:
        lock.acquire(fd)
    except BaseException:
        os.unlink(path)
        raise
    return lock
