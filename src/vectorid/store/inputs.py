"""What a store's trials were computed from — data files and model code — checked before a
single trial is added, on every path into a store.

A store records, by content (SHA-256):

* every **data file** its study reads (flight logs, wind profiles, an FMU; see
  :func:`vectorid.store.agreement.data_file_hashes`), in the meta key ``data_files``;
* the **model's code** (:func:`code_hashes`), in the meta key ``code_files``:

  - a Python model (``model = "mymodel:evaluate"``, or a function given from Python): its
    module file and every module of the user's project it imports, directly or through
    other project modules (found by reading their ``import`` statements; a module is the
    project's when it is not in the standard library, not in site-packages and not part of
    vectorid);
  - a command-line model (``model = "cmd:..."``): the executable, and every argument that
    names an existing file (``python sim.py ...`` hashes ``sim.py`` and the project modules
    it imports);
  - a built-in model (``"binh-korn"``, an ``[identification]`` study): vectorid's model
    sources (the modules that compute the trials);
  - an FMU: its file, as a data file.

:func:`check_inputs` runs before any trial is added (:func:`vectorid.run.run_store` calls it,
so a run started from the study file, from the store, from the browser UI or on Dask, a
repair and an extra run all pass through it). When anything differs it stops with
:class:`InputsChangedError`, which names each difference (what, old and new hash) and the two
ways out: a new store, or ``--accept-changes`` (``accept_changes=True``), which takes the
change and records it — what, old and new hash, when — in the store's history
(:func:`history`, shown by ``vectorid info`` and the report).

A store written before code hashes were recorded gets them on its first run, with a note
(said once: from then on they are recorded).
"""

from __future__ import annotations

import ast
import contextlib
import hashlib
import importlib.util
import inspect
import json
import shlex
import shutil
import site
import sys
import sysconfig
import time
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .._files import file_sha256
from .._version import __version__
from ..builders import data_files as _files
from ..builders import kind_of
from ..errors import StoreError, VectoridNote
from .agreement import data_file_hashes, new_store_name

__all__ = [
    "Change",
    "InputsChangedError",
    "check_inputs",
    "code_hashes",
    "history",
    "input_changes",
    "record_history",
]


class InputsChangedError(StoreError):
    """The data files or the model's code differ from those the store's trials were computed
    with."""


# -- which files are the model's code --------------------------------------------------------


def _library_dirs() -> list[Path]:
    out = set()
    for key in ("stdlib", "platstdlib", "purelib", "platlib"):
        with contextlib.suppress(Exception):
            out.add(Path(sysconfig.get_paths()[key]).resolve())
    try:
        for p in [*site.getsitepackages(), site.getusersitepackages()]:
            out.add(Path(p).resolve())
    except Exception:  # an embedded interpreter without site
        pass
    for p in sys.path:
        if p and ("site-packages" in p or "dist-packages" in p):
            out.add(Path(p).resolve())
    return sorted(out)


def _vectorid_dir() -> Path:
    return Path(__file__).resolve().parent.parent


def _inside(path: Path, folder: Path) -> bool:
    try:
        path.relative_to(folder)
        return True
    except ValueError:
        return False


def _module_file(name: str, roots: list[Path]) -> Path | None:
    """The source file of module ``name`` (``a.b``) under one of ``roots`` (no import)."""
    parts = name.split(".")
    for root in roots:
        base = root.joinpath(*parts)
        for cand in (base.with_suffix(".py"), base / "__init__.py"):
            if cand.is_file():
                return cand.resolve()
    return None


def _top_module_file(name: str, base_dir: Path | None) -> Path | None:
    """Where ``import name`` would find its source: beside the study file first (it goes
    first on the import path), else wherever Python finds the top-level package."""
    roots = [base_dir] if base_dir is not None else []
    found = _module_file(name, roots)
    if found is not None:
        return found

    top, _, rest = name.partition(".")
    try:
        spec = importlib.util.find_spec(top)  # a top-level name: imports nothing
    except (ImportError, ValueError):
        return None
    if spec is None:
        return None
    if not rest:
        return Path(spec.origin).resolve() if spec.origin and spec.has_location else None
    locs = list(spec.submodule_search_locations or [])
    return _module_file(rest, [Path(p) for p in locs])


def _import_root(path: Path) -> Path:
    """The folder from which the module at ``path`` is imported (above its packages)."""
    folder = path.parent
    while (folder / "__init__.py").is_file() and folder.parent != folder:
        folder = folder.parent
    return folder


def _imports(path: Path) -> list[tuple[str, int, list[str]]]:
    """``(module, level, names)`` of every import statement in the file (at any depth)."""
    try:
        tree = ast.parse(path.read_bytes(), filename=str(path))
    except (OSError, SyntaxError, ValueError):
        return []
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(a.name, 0, []) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            out.append((node.module or "", node.level, [a.name for a in node.names]))
    return out


def project_modules(root_file: Path, roots: list[Path]) -> list[Path]:
    """``root_file`` and the modules of the user's project it imports, directly or not.

    A module is the project's when its source is found under one of ``roots`` (the folder of
    the study file and the import root of the model's module) and lies outside the standard
    library, site-packages and vectorid itself.
    """
    libs = _library_dirs()
    vid = _vectorid_dir()

    def project(p: Path) -> bool:
        return not _inside(p, vid) and not any(_inside(p, lib) for lib in libs)

    seen: dict[Path, None] = {}
    todo = [root_file.resolve()]
    while todo:
        f = todo.pop()
        if f in seen:
            continue
        seen[f] = None
        for module, level, names in _imports(f):
            if level:
                pkg = f.parent
                for _ in range(level - 1):
                    pkg = pkg.parent
                search = [pkg]
                targets = [module] if module else []
                targets += [f"{module}.{n}" if module else n for n in names]
            else:
                search = roots
                targets = [module] + [f"{module}.{n}" for n in names]
            for t in targets:
                found = _module_file(t, search) if t else None
                if found is not None and project(found) and found not in seen:
                    todo.append(found)
                # the packages on the way (their __init__ runs on import)
                if found is not None and not level:
                    head = t.split(".")
                    for i in range(1, len(head)):
                        init = _module_file(".".join(head[:i]), search)
                        if init is not None and project(init) and init not in seen:
                            todo.append(init)
    return list(seen)


def _label(path: Path, base_dir: Path | None) -> str:
    if base_dir is not None and _inside(path, base_dir.resolve()):
        return str(path.relative_to(base_dir.resolve()))
    return str(path)


#: vectorid's sources that compute a built-in model's trials, by kind of study.
_BUILTIN_SOURCES = {
    "analytic": ("analytic.py", "problem.py"),
    "identification": ("models", "identify", "problem.py"),
}


def _vectorid_sources(kind: str) -> dict[str, Any]:
    vid = _vectorid_dir()
    files: list[Path] = []
    for name in _BUILTIN_SOURCES[kind]:
        p = vid / name
        files += sorted(p.rglob("*.py")) if p.is_dir() else [p]
    h = hashlib.sha256()
    for f in files:
        h.update(str(f.relative_to(vid)).encode() + b"\0")
        h.update((file_sha256(f) or "unreadable").encode() + b"\0")

    return {
        f"vectorid {kind} model sources": {
            "path": str(vid),
            "sha256": h.hexdigest(),
            "files": len(files),
            "version": __version__,
        }
    }


def code_hashes(spec: Any) -> dict[str, Any]:
    """``{label: {"path", "sha256", ...}}`` of the files that are the study's model code
    (see the module docstring); empty for a model without a source file (an FMU is a data
    file; a function typed at an interactive prompt has no file)."""

    base = Path(spec.base_dir).resolve() if spec.base_dir else None
    kind = kind_of(spec)
    model = spec.model
    if kind == "fmu":
        return {}
    if kind == "identification":
        return _vectorid_sources("identification")
    files: list[tuple[Path, str]] = []
    if kind == "cmd":
        rest = str(model).partition(":")[2].strip()
        try:
            argv = shlex.split(rest) if rest else list(spec.command or [])
        except ValueError:
            return {}  # the builder reports the quoting
        if not argv:
            return {}
        exe = argv[0]
        if "/" in exe:
            p = Path(exe) if Path(exe).is_absolute() else (base or Path.cwd()) / exe
        else:
            which = shutil.which(exe)
            p = Path(which) if which else None
        if p is not None and p.is_file():
            files.append((p.resolve(), "executable"))
        for arg in argv[1:]:
            if "{" in arg or arg.startswith("-"):
                continue
            q = Path(arg) if Path(arg).is_absolute() else (base or Path.cwd()) / arg
            if q.is_file():
                q = q.resolve()
                if q.suffix == ".py":
                    roots = [r for r in (base, _import_root(q)) if r is not None]
                    files += [
                        (m, "script" if m == q else "imported module")
                        for m in project_modules(q, roots)
                    ]
                else:
                    files.append((q, "file the command reads"))
    elif callable(model):
        try:
            src = inspect.getsourcefile(model) or inspect.getsourcefile(type(model))
        except TypeError:
            src = None
        if src is None:
            mod = sys.modules.get(getattr(model, "__module__", "") or "")
            src = getattr(mod, "__file__", None)
        if src is None or not Path(src).is_file():
            return {}
        root = Path(src).resolve()
        if _inside(root, _vectorid_dir()):
            return _vectorid_sources("analytic")
        roots = [r for r in (base, _import_root(root)) if r is not None]
        files += [
            (m, "model module" if m == root else "imported module")
            for m in project_modules(root, roots)
        ]
    elif isinstance(model, str) and ":" not in model:
        return _vectorid_sources("analytic")  # a built-in analytic problem
    elif isinstance(model, str):
        module = model.partition(":")[0]
        if module == "__main__":
            # a function of the running script, stored as "__main__:name" (the Python API):
            # the script's file is its code, as when the study was created from it
            main_file = getattr(sys.modules.get("__main__"), "__file__", None)
            root = Path(main_file).resolve() if main_file and Path(main_file).is_file() else None
        else:
            root = _top_module_file(module, base)
        if root is None:
            return {}  # the builder reports the missing module
        if _inside(root, _vectorid_dir()):
            return _vectorid_sources("analytic")
        roots = [r for r in (base, _import_root(root)) if r is not None]
        files += [
            (m, "model module" if m == root else "imported module")
            for m in project_modules(root, roots)
        ]
    out: dict[str, Any] = {}
    for path, role in files:
        digest = file_sha256(path)
        if digest is not None:
            out[_label(path, base)] = {"path": str(path), "sha256": digest, "role": role}
    return out


# -- comparing and recording -----------------------------------------------------------------


@dataclass(frozen=True)
class Change:
    """One input that differs from what the store's trials were computed with."""

    what: str
    old: str | None
    new: str | None
    kind: str  # "data file" or "model code"

    def describe(self) -> str:
        old = (self.old or "(absent)")[:12]
        new = (self.new or "(absent)")[:12]
        if self.old is None:
            how = f"new since the stored trials (sha256 {new}…)"
        elif self.new is None:
            how = f"gone or unreadable now (stored sha256 {old}…)"
        else:
            how = f"content changed: sha256 {old}… (store) -> {new}… (now)"
        return f"{self.kind} {self.what}: {how}"

    def to_dict(self) -> dict[str, Any]:
        return {"what": f"{self.kind} {self.what}", "old": self.old, "new": self.new}


def _stored(store: Any, key: str) -> dict[str, Any] | None:
    return store.meta_json(key)


def _diff(kind: str, old: Mapping[str, Any], new: Mapping[str, Any]) -> list[Change]:
    out = []
    for name in sorted(set(old) | set(new)):
        a = (old.get(name) or {}).get("sha256")
        b = (new.get(name) or {}).get("sha256")
        if a != b:
            out.append(Change(name, a, b, kind))
    return out


def input_changes(store: Any, spec: Any = None) -> tuple[list[Change], list[str], dict]:
    """Compare the store's recorded inputs with the files as they are now.

    Returns
    -------
    changes : list of Change
    unrecorded : list of str
        Which records the store lacks (``"data files"``, ``"model code"``): an older store.
    current : dict
        ``{"data_files": ..., "code_files": ...}`` as they are now.
    """

    spec = spec if spec is not None else store.spec
    current = {"data_files": data_file_hashes(spec), "code_files": code_hashes(spec)}
    # a data file that cannot be read now still counts: it is gone

    try:
        for name in _files(spec):
            current["data_files"].setdefault(name, {"sha256": None})
    except Exception:
        pass
    changes: list[Change] = []
    unrecorded: list[str] = []
    for key, kind in (("data_files", "data file"), ("code_files", "model code")):
        old = _stored(store, key)
        if old is None:
            unrecorded.append(kind)
            continue
        changes += _diff(kind, old, current[key])
    return changes, unrecorded, current


def history(store: Any) -> list[dict[str, Any]]:
    """The store's history of accepted changes and first records, oldest first: dicts
    with ``at`` (time, s since the epoch), ``what``, ``old``, ``new`` (hashes) and
    ``note``."""
    text = store.meta().get("history")
    if not text:
        return []
    try:
        out = json.loads(text)
    except ValueError:
        return []
    return [e for e in out if isinstance(e, dict)] if isinstance(out, list) else []


def record_history(store: Any, entries: list[dict[str, Any]], **meta: Any) -> None:
    """Append ``entries`` to the store's history and set ``meta`` keys, in one transaction."""
    rows = [("history", json.dumps(history(store) + entries))]
    rows += [(k, json.dumps(v)) for k, v in meta.items()]
    store.set_meta(dict(rows))


def _message(store: Any, changes: list[Change]) -> str:
    n = store.count_sample()
    lines = [
        f"{len(changes)} input{'s' if len(changes) > 1 else ''} of the study in {store.path} "
        f"changed since its {n} trials were computed; trials computed now would not match "
        "them:"
    ]
    lines += [f"  {c.describe()}" for c in changes[:12]]
    if len(changes) > 12:
        lines.append(f"  ... and {len(changes) - 12} more")
    lines.append(
        "either start a new store (vectorid run STUDY.toml --store "
        f"{new_store_name(Path(store.path))}), or take the change and record it in this "
        f"store's history: vectorid run {store.path} --accept-changes (accept_changes=True)"
    )
    return "\n".join(lines)


def check_inputs(store: Any, *, accept_changes: bool = False) -> list[str]:
    """Stop before a trial is added when the data files or the model's code differ from
    those the store's trials were computed with (see the module docstring).

    Parameters
    ----------
    store : Store
        Opened for writing.
    accept_changes : bool
        Take the changes, recording each in the store's history, instead of stopping.

    Returns
    -------
    list of str
        Notes for the user (records made for an older store, changes accepted).

    Raises
    ------
    InputsChangedError
        When something changed and ``accept_changes`` is False.
    """
    changes, unrecorded, current = input_changes(store)
    held = store.count_all_blocks()
    notes: list[str] = []
    now = time.time()
    entries: list[dict[str, Any]] = []
    if changes and held and not accept_changes:
        raise InputsChangedError(_message(store, changes))
    for c in changes if held else []:
        entries.append({"at": now, **c.to_dict(), "note": "accepted (--accept-changes)"})
        notes.append(f"accepted and recorded in the store's history: {c.describe()}")
    for kind in unrecorded:
        if not held:
            continue
        what = "model-code" if kind == "model code" else "data-file"
        text = (
            f"store {store.path} recorded no {what} hashes (written by an older vectorid): "
            f"recorded now; its {held} stored batches cannot be checked against them"
        )
        entries.append(
            {"at": now, "what": f"{kind} (first record)", "old": None, "new": None, "note": text}
        )
        notes.append(text)
    if changes or unrecorded:
        record_history(store, entries, **current)
    for text in notes:
        warnings.warn(VectoridNote(text), stacklevel=3)
    return notes


def record_inputs(store: Any, spec: Any = None) -> None:
    """Record the model-code hashes of a new store (its data files are recorded when it is
    created)."""
    spec = spec if spec is not None else store.spec
    store.set_meta({"code_files": json.dumps(code_hashes(spec))})
