"""Commands to show the user, written the way this installation is invoked.

A README that installs into ``.venv`` and runs ``.venv/bin/vectorid`` should not be answered
with ``vectorid ...`` or ``pip install 'vectorid[parquet]'``, which would use another
interpreter (or none): the hints printed by the CLI follow how the user actually started it.
"""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

__all__ = ["command_name", "install_hint"]

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
