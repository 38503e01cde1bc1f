"""What the user is shown beside the results: commands written the way this installation is
invoked, and signs of life during long waits.

A README that installs into ``.venv`` and runs ``.venv/bin/vectorid`` should not be answered
with ``vectorid ...`` or ``pip install 'vectorid[parquet]'``, which would use another
interpreter (or none): the hints printed by the CLI follow how the user actually started it.

A long wait (a model's first compile, a noise-floor Monte Carlo) says what it waits for and
how long it has waited (:func:`waiting`), instead of a fixed estimate that a busy machine
turns into minutes of silence.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import TextIO

__all__ = ["QUIET_ENV", "command_name", "install_hint", "quiet", "quiet_notices", "waiting"]

#: Environment variable that silences progress and waiting notices (``vectorid --quiet`` sets
#: it for the command and the worker processes it starts).
QUIET_ENV = "VECTORID_QUIET"

#: The package's folder: ``<clone>/src/vectorid`` in a source checkout.
_PACKAGE = Path(__file__).resolve().parent


def _shown(path: Path, name: str, cwd: Path) -> str:
    """``name`` if ``path`` is what the shell finds under that name, else ``path`` relative to
    ``cwd`` when it lies below it (``.venv/bin/pip``), else absolute."""
    try:
        found = shutil.which(name)
        if found and Path(found).resolve() == path.resolve():
            return name
    except OSError:  # pragma: no cover - unreadable PATH entries
        pass
    try:
        return str(path.resolve().relative_to(cwd.resolve()))
    except ValueError:
        return str(path)


def command_name(argv0: str | None = None, cwd: str | os.PathLike | None = None) -> str:
    """How to write the ``vectorid`` command for this user.

    ``vectorid`` when the script that runs is the one found on ``PATH`` (or when vectorid was
    not started from its console script, e.g. from Python), else its path relative to ``cwd``
    (``.venv/bin/vectorid``) or absolute.

    Parameters
    ----------
    argv0 : str, optional
        The script path (default ``sys.argv[0]``).
    cwd : path, optional
        The folder the commands will be typed in (default: the current one).
    """
    argv0 = sys.argv[0] if argv0 is None else argv0
    if not argv0 or Path(argv0).name != "vectorid" or not Path(argv0).is_file():
        return "vectorid"
    return _shown(Path(argv0), "vectorid", Path.cwd() if cwd is None else Path(cwd))


def install_hint(extra: str, cwd: str | os.PathLike | None = None) -> str:
    """The command that installs vectorid's optional dependencies ``extra`` here.

    For a source checkout installed in editable mode (``pip install -e .``, as the README
    does) it is ``.venv/bin/pip install -e '.[EXTRA]'`` (pip of the running interpreter, the
    checkout relative to ``cwd``); otherwise ``pip install 'vectorid[EXTRA]'`` with that pip.

    Parameters
    ----------
    extra : str
        Name of the extra in ``pyproject.toml``, e.g. ``"parquet"``, ``"ui"``.
    cwd : path, optional
        The folder the command will be typed in (default: the current one).
    """
    here = Path.cwd() if cwd is None else Path(cwd)
    pip_path = Path(sys.executable).parent / "pip"
    pip = _shown(pip_path, "pip", here) if pip_path.is_file() else f"{sys.executable} -m pip"
    root = _PACKAGE.parent.parent
    if _PACKAGE.parent.name == "src" and (root / "pyproject.toml").is_file():
        try:
            rel = os.path.relpath(root, here.resolve())
        except ValueError:  # pragma: no cover - another drive on Windows
            rel = str(root)
        where = "." if rel == "." else (rel if rel.startswith(".") else f"./{rel}")
        return f"{pip} install -e '{where}[{extra}]'"
    return f"{pip} install 'vectorid[{extra}]'"


def quiet() -> bool:
    """Whether progress and waiting notices are off (``--quiet``, :data:`QUIET_ENV`)."""
    return os.environ.get(QUIET_ENV, "") not in ("", "0")


@contextlib.contextmanager
def quiet_notices(on: bool = True) -> Iterator[None]:
    """Within the block, progress and waiting notices are off (``on``), here and in the
    worker processes started meanwhile (they inherit :data:`QUIET_ENV`)."""
    if not on:
        yield
        return
    old = os.environ.get(QUIET_ENV)
    os.environ[QUIET_ENV] = "1"
    try:
        yield
    finally:
        if old is None:
            os.environ.pop(QUIET_ENV, None)
        else:
            os.environ[QUIET_ENV] = old


#: The waits under way in this process, innermost last (only the innermost speaks).
_WAITS: list[object] = []
#: A terminal's notice is rewritten every this many seconds; elsewhere (a log, a notebook) a
#: new line comes at these elapsed times, s, then every 120 s.
TICK = 1.0
LINES_AT = (10.0, 30.0, 60.0)


@contextlib.contextmanager
def waiting(
    what: str, *, after: float = 0.0, file: TextIO | None = None, note: str = ""
) -> Iterator[None]:
    """Signs of life while the block runs: ``what`` and the seconds waited so far.

    Nothing is shown when the block ends within ``after`` seconds, nor when notices are off
    (:func:`quiet`). On a terminal one line is rewritten every second (``compiling ... 12
    s``); elsewhere (a log file, a notebook's stderr) a line comes at 10, 30 and 60 s, then
    every two minutes. At the end one line says how long it took. A daemon thread keeps the
    time and is joined before the block returns (no thread outlives it: worker processes
    started afterwards may still be forked).

    Parameters
    ----------
    what : str
        What is waited for, e.g. ``"compiling the parafoil8dof model's kernel"``.
    after : float
        Seconds of silence before anything is said, s.
    file : text file, optional
        Where to say it (default: standard error).
    note : str
        Said once, after ``what`` on the first line (e.g. how long it takes on a quiet
        machine).
    """
    if quiet():
        yield
        return
    out = sys.stderr if file is None else file
    tty = bool(getattr(out, "isatty", lambda: False)())
    me = object()
    _WAITS.append(me)  # an inner wait (a compile inside a noise floor) speaks alone meanwhile
    stop = threading.Event()
    shown = threading.Event()
    t0 = time.perf_counter()
    lock = threading.Lock()

    def say(text: str, end: str = "\n", always: bool = False) -> None:
        if not always and _WAITS and _WAITS[-1] is not me:
            return
        with lock, contextlib.suppress(OSError, ValueError):
            out.write(text + end)
            out.flush()

    def tick() -> None:
        if stop.wait(after):
            return
        shown.set()
        head = f"{what} ({note})" if note else what
        if tty:
            while True:
                say(f"\r{head} ... {time.perf_counter() - t0:.0f} s", end="")
                if stop.wait(TICK):
                    return
        say(f"{head} ...")
        marks = list(LINES_AT)
        while True:
            elapsed = time.perf_counter() - t0
            nxt = marks.pop(0) if marks else (elapsed // 120.0 + 1) * 120.0
            if stop.wait(max(0.0, nxt - elapsed)):
                return
            say(f"  ... still {what}: {time.perf_counter() - t0:.0f} s so far")

    thread = threading.Thread(target=tick, name="vectorid-waiting", daemon=True)
    thread.start()
    ok = False
    try:
        yield
        ok = True
    finally:
        stop.set()
        thread.join()
        _WAITS.remove(me)
        if shown.is_set():
            took = time.perf_counter() - t0
            how = "done" if ok else "stopped"
            say(
                f"{chr(13) if tty else ''}{what}: {how} after {took:.1f} s"
                + (" " * 8 if tty else ""),
                always=True,
            )
