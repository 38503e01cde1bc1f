"""What a store's trials were computed from — data files, model code and declared inputs —
checked before a single trial is added, on every path into a store.

A store records, by content (SHA-256):

* every **data file** its study reads (flight logs, wind profiles, CSV records, an FMU; see
  :func:`vectorid.store.agreement.data_file_hashes`), in the meta key ``data_files``;
* the **model's code** (:func:`code_hashes`), in the meta key ``code_files``:

  - a Python model (``model = "mymodel:evaluate"``, or a function given from Python): its
    module file and every module of the user's project it imports, directly or through
    other project modules (found by reading their ``import`` statements, and
    ``importlib.import_module("name")`` / ``__import__("name")`` calls with a literal name; a
    module is the project's when it is not in the standard library, not in site-packages
    and not part of vectorid; a compiled extension module of the project is hashed too);
  - a model of your own identified from data (an ``[identification]`` study with a
    ``SystemModel``): vectorid's identification sources, the model class's module and the
    project modules it imports, and the module of every criterion function of your own
    (``use = "mycrit:f"``), found through the problem builder's ``code_modules`` hook
    (:func:`vectorid.builders.code_modules`);
  - a command-line model (``model = "cmd:..."``): the executable, and every argument that
    names an existing file (``python sim.py ...`` hashes ``sim.py`` and the project modules
    it imports);
  - a built-in model (``"binh-korn"``, a flight-model identification): vectorid's model
    sources (the modules that compute the trials);
  - an FMU: its file, as a data file, and the modules of reductions of your own
    (``reduce = "mypkg.reductions:overshoot"``);

* the **declared inputs** (``[study] inputs = ["lib/", "coefficients.csv"]``: files and
  folders the model reads itself), every file of each, in the meta key ``declared_inputs``.

Identity is by content, never by the path's spelling: a file is labelled by the path it is
found at (relative to the study file's folder), not by where a symbolic link points, and an
entry that only moved (the same content under another label) is not a change.

What the scan cannot see, it says: a project module that imports by a name computed at run
time (``importlib.import_module(name)``, ``__import__(name)``), changes the import path
(``sys.path.insert``), runs code from a file (``exec(open(...).read())``, ``runpy``), loads a
library (``ctypes.CDLL``), runs a program (``subprocess``) or opens a data file itself
(``open``, ``np.loadtxt``, ``pd.read_csv``, ...) is reported once, at the first run, as a
note naming each place (:func:`unseen_loads`), unless a literal path it names lies in a
declared input. An import the scan cannot find at all is reported the same way.

:func:`check_inputs` runs before any trial is added (:func:`vectorid.run.run_store` calls it,
so a run started from the study file, from the store, from the browser UI or on Dask, with
any sampler, a repair and an extra run all pass through it). When anything differs it stops
with :class:`InputsChangedError`, which names each difference (what, old and new hash) and
the two ways out: a new store, or ``--accept-changes`` (``accept_changes=True``), which
takes the change and records it — what, old and new hash, when — in the store's history
(:func:`history`, shown by ``vectorid info`` and the report).

A store written before code hashes were recorded gets them on its first run, with a note
(said once: from then on they are recorded); so does a store recorded by an older vectorid
that hashed less (a model of your own's module): what it did not record is recorded with a
note, and what it recorded is compared.
"""

from __future__ import annotations

import ast
import contextlib
import hashlib
import importlib.machinery
import importlib.util
import inspect
import json
import os
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
from ..builders import code_modules, kind_of
from ..builders import data_files as _files
from ..errors import StoreError, VectoridNote
from .agreement import data_file_hashes, new_store_name

__all__ = [
    "Change",
    "InputsChangedError",
    "check_inputs",
    "code_hashes",
    "declared_hashes",
    "history",
    "input_changes",
    "record_history",
    "record_inputs",
    "reload_edited_code",
    "unseen_loads",
]


class InputsChangedError(StoreError):
    """The data files, the model's code or the declared inputs differ from those the store's
    trials were computed with."""


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


#: Suffixes of a module's file, in the order Python's path finder tries them (a package's
#: ``__init__.py`` comes first).
_SUFFIXES = (*importlib.machinery.EXTENSION_SUFFIXES, ".py")


def _module_file(name: str, roots: list[Path]) -> Path | None:
    """The file of module ``name`` (``a.b``) under one of ``roots``, as found there (a
    symbolic link is not followed: the label is the path Python imports it by); no import."""
    parts = name.split(".")
    if not all(p.isidentifier() for p in parts):
        return None
    for root in roots:
        base = root.joinpath(*parts)
        for cand in (base / "__init__.py", *(base.with_name(base.name + s) for s in _SUFFIXES)):
            if cand.is_file():
                return Path(cand).absolute()
    return None


def _top_module_file(name: str, base_dir: Path | None) -> Path | None:
    """Where ``import name`` would find its source: beside the study file first (it goes
    first on the import path), else wherever Python finds the top-level package."""
    roots = [base_dir] if base_dir is not None else []
    found = _module_file(name, roots)
    if found is not None:
        return found

    top, _, rest = name.partition(".")
    spec = _find_spec(top)
    if spec is None:
        return None
    if not rest:
        return Path(spec.origin).absolute() if spec.origin and spec.has_location else None
    locs = list(spec.submodule_search_locations or [])
    return _module_file(rest, [Path(p) for p in locs])


def _find_spec(top: str) -> Any:
    """``importlib.util.find_spec`` of a top-level name (imports nothing); None if unknown."""
    if not top.isidentifier():
        return None
    try:
        return importlib.util.find_spec(top)
    except (ImportError, ValueError):
        return None


def _import_root(path: Path) -> Path:
    """The folder from which the module at ``path`` is imported (above its packages)."""
    folder = path.parent
    while (folder / "__init__.py").is_file() and folder.parent != folder:
        folder = folder.parent
    return folder


# What a module does at run time that the scan of its imports cannot follow, by the dotted
# name of the call (``np.loadtxt`` also as ``numpy.loadtxt``).
_DYNAMIC_IMPORTS = {
    "importlib.import_module",
    "import_module",
    "__import__",
    "importlib.__import__",
}
_PATH_CHANGES = {"sys.path.insert", "sys.path.append", "sys.path.extend", "site.addsitedir",
                 "os.chdir"}  # fmt: skip
_CODE_LOADERS = {
    "exec", "eval", "compile", "execfile", "runpy.run_path", "runpy.run_module", "run_path",
    "run_module", "importlib.util.spec_from_file_location", "spec_from_file_location",
    "importlib.machinery.SourceFileLoader", "SourceFileLoader", "imp.load_source",
    "load_source", "ctypes.CDLL", "CDLL", "ctypes.PyDLL", "ctypes.cdll.LoadLibrary",
    "cdll.LoadLibrary", "np.ctypeslib.load_library", "numpy.ctypeslib.load_library",
    "cffi.FFI.dlopen", "pkgutil.get_data",
}  # fmt: skip
_PROGRAMS = {
    "subprocess.run", "subprocess.call", "subprocess.check_call", "subprocess.check_output",
    "subprocess.Popen", "os.system", "os.popen", "os.execv", "os.execvp", "os.spawnv",
}  # fmt: skip
_FILE_READS = {
    "open", "io.open", "os.open", "codecs.open", "gzip.open", "bz2.open", "lzma.open",
    "tarfile.open", "zipfile.ZipFile", "np.load", "np.loadtxt", "np.genfromtxt", "np.fromfile",
    "np.memmap", "scipy.io.loadmat", "loadmat", "sio.loadmat", "h5py.File", "netCDF4.Dataset",
    "xr.open_dataset", "xarray.open_dataset", "tomllib.load", "pickle.load", "joblib.load",
}  # fmt: skip
_FILE_METHODS = {"read_text", "read_bytes"}


def _dotted(node: ast.AST) -> str:
    """``a.b.c`` of a called name (``?`` for a part that is not a plain name)."""
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    parts.append(node.id if isinstance(node, ast.Name) else "?")
    name = ".".join(reversed(parts))
    return name.replace("numpy.", "np.", 1) if name.startswith("numpy.") else name


def _literal(node: ast.AST | None) -> str | None:
    return node.value if isinstance(node, ast.Constant) and isinstance(node.value, str) else None


#: How a path written relative to the module's own file is kept (``HERE/name``).
_HERE = "{module}/"


def _is_here(node: ast.AST) -> bool:
    """``Path(__file__).parent``, ``Path(__file__).resolve().parent``,
    ``os.path.dirname(__file__)`` and the like: the module's folder."""
    if isinstance(node, ast.Attribute) and node.attr == "parent":
        inner = node.value
        if isinstance(inner, ast.Call) and isinstance(inner.func, ast.Attribute):
            if inner.func.attr in ("resolve", "absolute"):
                inner = inner.func.value
        return (
            isinstance(inner, ast.Call)
            and _dotted(inner.func) in ("Path", "pathlib.Path")
            and len(inner.args) == 1
            and isinstance(inner.args[0], ast.Name)
            and inner.args[0].id == "__file__"
        )
    if isinstance(node, ast.Call) and _dotted(node.func) in ("os.path.dirname", "dirname"):
        arg = node.args[0] if node.args else None
        if isinstance(arg, ast.Call) and _dotted(arg.func) in ("os.path.abspath",
                                                                "os.path.realpath"):  # fmt: skip
            arg = arg.args[0] if arg.args else None
        return isinstance(arg, ast.Name) and arg.id == "__file__"
    return False


def _path_literal(node: ast.AST | None) -> str | None:
    """The path an expression names when the scan can read it: a string, ``Path("a")``,
    ``str(...)`` of one, and a name beside the module's own file (``Path(__file__).parent /
    "a"``, ``Path(__file__).with_name("a")``, ``os.path.join(os.path.dirname(__file__),
    "a")``), kept as ``{module}/a``; None otherwise."""
    if node is None:
        return None
    lit = _literal(node)
    if lit is not None:
        return lit
    if isinstance(node, ast.Call):
        name = _dotted(node.func)
        if name in ("str", "Path", "pathlib.Path", "os.fspath") and len(node.args) == 1:
            return _path_literal(node.args[0])
        if name in ("os.path.join", "join") and len(node.args) >= 2 and _is_here(node.args[0]):
            parts = [_literal(a) for a in node.args[1:]]
            return _HERE + "/".join(parts) if all(p is not None for p in parts) else None  # type: ignore[arg-type]
        if (
            isinstance(node.func, ast.Attribute)
            and node.func.attr == "with_name"
            and len(node.args) == 1
            and _literal(node.args[0]) is not None
            and _is_here(ast.Attribute(value=node.func.value, attr="parent"))
        ):
            return _HERE + str(_literal(node.args[0]))
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Div):
        right = _literal(node.right)
        if right is not None and _is_here(node.left):
            return _HERE + right
        left = _path_literal(node.left)
        if right is not None and left is not None:
            return f"{left.rstrip('/')}/{right}"
    return None


def _candidates(lit: str, roots: list[Path], module: Path) -> list[Path]:
    """Where a path the module names may be: beside the module for ``{module}/...``, else
    as written (absolute) or relative to each root and to the module's folder."""
    if lit.startswith(_HERE):
        return [module.parent / lit[len(_HERE) :]]
    p = Path(lit)
    return [p] if p.is_absolute() else [*(r / p for r in roots), module.parent / p]


@dataclass
class _Scan:
    """What one module file does: its imports ``(module, level, names)``, the paths it adds
    to the import path (literal ones), and what the scan cannot follow ``(line, text, path
    literal or None, kind)``."""

    imports: list[tuple[str, int, list[str]]]
    paths: list[str]
    unseen: list[tuple[int, str, str | None, str]]
    #: Lines inside ``try`` bodies that catch ImportError (an optional import).
    guarded: set[int]


_GUARDS = {"ImportError", "ModuleNotFoundError", "Exception", "BaseException"}


def _guarded_lines(tree: ast.AST) -> set[int]:
    """Lines of ``try`` bodies that catch ImportError (an optional import: not a finding)."""
    out: set[int] = set()
    for node in ast.walk(tree):
        if not isinstance(node, ast.Try):
            continue
        caught = set()
        for h in node.handlers:
            types = h.type.elts if isinstance(h.type, ast.Tuple) else [h.type]
            caught |= {_dotted(t).rsplit(".", 1)[-1] for t in types if t is not None}
            if h.type is None:
                caught.add("Exception")
        if caught & _GUARDS:
            for stmt in node.body:
                out.update(range(stmt.lineno, (stmt.end_lineno or stmt.lineno) + 1))
    return out


def _scan(path: Path) -> _Scan:
    """Read ``path``'s statements (no import): see :class:`_Scan`."""
    out = _Scan([], [], [], set())
    try:
        text = path.read_bytes().decode("utf-8", "replace")
        tree = ast.parse(text, filename=str(path))
    except (OSError, SyntaxError, ValueError):
        return out
    out.guarded = _guarded_lines(tree)
    inner: set[int] = set()

    def shown(node: ast.AST) -> str:
        seg = ast.get_source_segment(text, node) or ""
        seg = " ".join(seg.split())
        return seg if len(seg) <= 60 else seg[:57] + "..."

    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.imports += [(a.name, 0, []) for a in node.names]
            continue
        if isinstance(node, ast.ImportFrom):
            out.imports.append((node.module or "", node.level, [a.name for a in node.names]))
            continue
        if isinstance(node, ast.Assign | ast.AugAssign):  # sys.path += [...], sys.path = [...]
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for t in targets:
                base = t.value if isinstance(t, ast.Subscript) else t
                if _dotted(base) == "sys.path":
                    out.unseen.append((node.lineno, shown(node), None, "changes the import path"))
            continue
        if not isinstance(node, ast.Call) or id(node) in inner:
            continue
        said = len(out.unseen)
        name = _dotted(node.func)
        first = _path_literal(node.args[0]) if node.args else None
        if name in _DYNAMIC_IMPORTS:
            first = _literal(node.args[0]) if node.args else None
            if first is not None and not first.startswith("."):
                out.imports.append((first, 0, []))
            else:
                out.unseen.append((node.lineno, shown(node), None, "imports by a computed name"))
        elif name in _PATH_CHANGES:
            arg = (
                node.args[1]
                if name == "sys.path.insert" and len(node.args) > 1
                else (node.args[0] if node.args else None)
            )
            lit = _path_literal(arg)
            if lit is not None and name != "os.chdir":
                out.paths.append(lit)
            out.unseen.append((node.lineno, shown(node), lit, "changes the import path"))
        elif name in _CODE_LOADERS:
            out.unseen.append((node.lineno, shown(node), first, "runs or loads code"))
        elif name in _PROGRAMS:
            out.unseen.append((node.lineno, shown(node), None, "runs a program"))
        elif (
            name in _FILE_READS
            or name.rsplit(".", 1)[-1] in _FILE_METHODS | {"open"}
            or (name.split(".")[0] in ("pd", "pandas") and name.rsplit(".", 1)[-1][:5] == "read_")
        ):
            mode = _literal(node.args[1]) if len(node.args) > 1 else None
            for kw in node.keywords:
                if kw.arg == "mode":
                    mode = _literal(kw.value)
                if kw.arg in ("file", "fname", "path", "filepath_or_buffer") and first is None:
                    first = _path_literal(kw.value)
            if first is None and isinstance(node.func, ast.Attribute):
                first = _path_literal(node.func.value)  # Path("a.csv").read_text()
            if name.endswith("open") and mode and any(c in mode for c in "wax") and "+" not in mode:
                continue  # the model writes a file: not an input
            out.unseen.append((node.lineno, shown(node), first, "reads a file"))
        if len(out.unseen) > said:  # exec(open(...).read()) is one place, not two
            inner.update(id(n) for n in ast.walk(node) if n is not node)
    return out


@dataclass
class _Code:
    """The model's code files ``(path as found, role)`` and what the scan could not see."""

    files: list[tuple[Path, str]]
    unseen: list[tuple[Path, int, str, str | None, str]]


def _project(path: Path, libs: list[Path], vid: Path) -> bool:
    real = path.resolve()
    return not _inside(real, vid) and not any(_inside(real, lib) for lib in libs)


def _walk_project(root_file: Path, roots: list[Path], role: str, code: _Code,
                  seen: dict[Path, None]) -> None:  # fmt: skip
    """Add ``root_file`` and the project modules it imports, directly or not, to ``code``
    (modules in ``seen``, by their real path, are there already)."""
    libs = _library_dirs()
    vid = _vectorid_dir()
    todo: list[tuple[Path, list[Path], str]] = [(root_file, list(roots), role)]
    while todo:
        f, search_roots, f_role = todo.pop()
        if f.resolve() in seen:
            continue
        seen[f.resolve()] = None
        code.files.append((f, f_role))
        if f.suffix != ".py":
            continue  # a compiled extension: hashed, not read
        scan = _scan(f)
        followed: set[str] = set()
        my_roots = list(search_roots)
        for lit in scan.paths:  # sys.path.insert(0, "lib"): a folder it names is followed
            cands = _candidates(lit, search_roots, f)
            folder = next((c for c in cands if c.is_dir()), None)
            if folder is not None:
                my_roots.append(Path(os.path.normpath(folder.absolute())))
                followed.add(lit)
        code.unseen += [
            (f, line, text, lit, kind)
            for line, text, lit, kind in scan.unseen
            if not (kind == "changes the import path" and lit in followed)
        ]
        for module, level, names in scan.imports:
            if level:
                pkg = f.parent
                for _ in range(level - 1):
                    pkg = pkg.parent
                search = [pkg]
                targets = [module] if module else []
                targets += [f"{module}.{n}" if module else n for n in names]
            else:
                search = my_roots
                targets = [module] + [f"{module}.{n}" for n in names]
            found_any = False
            for t in targets:
                found = _module_file(t, search) if t else None
                if found is None and t and not level:
                    found = _top_module_file(t, None)  # wherever Python finds it
                if found is None:
                    continue
                found_any = True
                if _project(found, libs, vid):
                    todo.append((found, my_roots, "imported module"))
                if not level:  # the packages on the way (their __init__ runs on import)
                    head = t.split(".")
                    for i in range(1, len(head)):
                        init = _module_file(".".join(head[:i]), search)
                        if init is not None and _project(init, libs, vid):
                            todo.append((init, my_roots, "imported module"))
            if found_any or level or not module or _find_spec(module.split(".")[0]) is not None:
                continue
            line = _import_line(f, module)
            if line not in scan.guarded:  # an optional import that may be absent is no input
                code.unseen.append((f, line, f"import {module}", None, "not found here"))


def _import_line(path: Path, module: str) -> int:
    try:
        tree = ast.parse(path.read_bytes())
    except (OSError, SyntaxError, ValueError):
        return 0
    for node in ast.walk(tree):
        if isinstance(node, ast.Import) and any(a.name == module for a in node.names):
            return node.lineno
        if isinstance(node, ast.ImportFrom) and node.module == module and not node.level:
            return node.lineno
    return 0


def project_modules(root_file: Path, roots: list[Path]) -> list[Path]:
    """``root_file`` and the modules of the user's project it imports, directly or not.

    A module is the project's when its file is found under one of ``roots`` (the folder of
    the study file and the import root of the model's module), or wherever Python finds it,
    and lies outside the standard library, site-packages and vectorid itself.
    """
    code = _Code([], [])
    _walk_project(Path(root_file).absolute(), roots, "module", code, {})
    return [p for p, _ in code.files]


def _label(path: Path, base_dir: Path | None) -> str:
    path = Path(path).absolute()
    if base_dir is not None and _inside(path, base_dir):
        return path.relative_to(base_dir).as_posix()
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


def _add_module(module: str, role: str, base: Path | None, code: _Code,
                seen: dict[Path, None]) -> bool:  # fmt: skip
    """Add the user's module ``module`` (``pkg.mod``) and its project imports to ``code``;
    False when it is vectorid's own (its sources are hashed as one)."""
    if module == "__main__":
        # a function of the running script, stored as "__main__:name" (the Python API):
        # the script's file is its code, as when the study was created from it
        main_file = getattr(sys.modules.get("__main__"), "__file__", None)
        root = Path(main_file).absolute() if main_file and Path(main_file).is_file() else None
    else:
        root = _top_module_file(module, base)
    if root is None:
        return True  # the builder reports the missing module
    if _inside(root.resolve(), _vectorid_dir()):
        return False
    roots = [r for r in (base, _import_root(root)) if r is not None]
    _walk_project(root, roots, role, code, seen)
    head = module.split(".")
    for i in range(1, len(head)):  # the packages on the way: their __init__ runs on import
        init = _module_file(".".join(head[:i]), roots)
        if init is not None:
            _walk_project(init, roots, "imported module", code, seen)
    return True


def _code(spec: Any) -> tuple[dict[str, Any], _Code]:
    """The study's model code: ``({label: {"path", "sha256", "role"}}, what was scanned)``."""
    base = Path(spec.base_dir).absolute() if spec.base_dir else None
    kind = kind_of(spec)
    model = spec.model
    code = _Code([], [])
    seen: dict[Path, None] = {}
    out: dict[str, Any] = {}
    if kind == "identification":
        out.update(_vectorid_sources("identification"))
    elif kind == "cmd":
        rest = str(model).partition(":")[2].strip()
        try:
            argv = shlex.split(rest) if rest else list(spec.command or [])
        except ValueError:
            argv = []  # the builder reports the quoting
        if argv:
            exe = argv[0]
            if "/" in exe:
                p = Path(exe) if Path(exe).is_absolute() else (base or Path.cwd()) / exe
            else:
                which = shutil.which(exe)
                p = Path(which) if which else None
            if p is not None and p.is_file():
                code.files.append((p.absolute(), "executable"))
            for arg in argv[1:]:
                if "{" in arg or arg.startswith("-"):
                    continue
                q = Path(arg) if Path(arg).is_absolute() else (base or Path.cwd()) / arg
                if q.is_file():
                    q = q.absolute()
                    if q.suffix == ".py":
                        roots = [r for r in (base, _import_root(q)) if r is not None]
                        _walk_project(q, roots, "script", code, seen)
                    else:
                        code.files.append((q, "file the command reads"))
    elif kind == "fmu":
        pass  # the FMU is a data file; its reductions of your own come below
    elif callable(model):
        try:
            src = inspect.getsourcefile(model) or inspect.getsourcefile(type(model))
        except TypeError:
            src = None
        if src is None:
            mod = sys.modules.get(getattr(model, "__module__", "") or "")
            src = getattr(mod, "__file__", None)
        if src is not None and Path(src).is_file():
            root = Path(src).absolute()
            if _inside(root.resolve(), _vectorid_dir()):
                out.update(_vectorid_sources("analytic"))
            else:
                roots = [r for r in (base, _import_root(root)) if r is not None]
                _walk_project(root, roots, "model module", code, seen)
    elif isinstance(model, str) and ":" not in model:
        out.update(_vectorid_sources("analytic"))  # a built-in analytic problem
    elif isinstance(model, str):
        if not _add_module(model.partition(":")[0], "model module", base, code, seen):
            out.update(_vectorid_sources("analytic"))
    for module, role in code_modules(spec).items():
        _add_module(module, role, base, code, seen)
    for path, role in code.files:
        digest = file_sha256(path)
        if digest is not None:
            out[_label(path, base)] = {"path": str(path), "sha256": digest, "role": role}
    return out, code


def code_hashes(spec: Any) -> dict[str, Any]:
    """``{label: {"path", "sha256", ...}}`` of the files that are the study's model code
    (see the module docstring); empty for a model without a source file (an FMU is a data
    file; a function typed at an interactive prompt has no file)."""
    return _code(spec)[0]


#: The content (sha256) of each own-code file as this process last ran a study with it:
#: {resolved path: digest}. :func:`reload_edited_code` reloads a module whose file differs.
_RAN_WITH: dict[Path, str] = {}


def reload_edited_code(spec: Any) -> list[str]:
    """Make this process run the study's own model code as its files are now: a module of
    the study's project code (the model's module, its package and project modules,
    criterion and reduction modules; see :func:`code_hashes`) that this process imported and
    whose file was edited since this process last ran a study with it is reloaded
    (:func:`importlib.reload`; its cached bytecode is removed first), so that the next build
    of the model — here, or in a worker process started from here — runs the edited code.

    Without it, a long-lived process (a notebook, a script that runs a study twice) would go
    on running the code it imported before an edit while the input check compares the files
    on disk: trials of the old code stored under the new code's hashes. The run driver calls
    it before each run (:func:`vectorid.run.run_store`). A model given as a Python object
    (``model = f``) is not reloaded: the object is what runs; re-create it after an edit.
    A module that no longer imports after the edit is dropped, so that building the model
    reports its error.

    Returns
    -------
    list of str
        The names of the modules reloaded.
    """
    import importlib
    import importlib.util

    try:
        hashes, code = _code(spec)
    except Exception:  # the builder reports a broken study; nothing to reload here
        return []
    now: dict[Path, str] = {}
    for info in hashes.values():
        path = Path(str(info.get("path", "")))
        if path.suffix == ".py" and info.get("sha256"):
            with contextlib.suppress(OSError, ValueError):
                if not _inside(path.resolve(), _vectorid_dir()):  # the user's code only
                    now[path.resolve()] = str(info["sha256"])
    if not now:
        return []
    own = getattr(spec.model, "__module__", None) if callable(spec.model) else None
    reloaded = []
    for name, mod in list(sys.modules.items()):
        f = getattr(mod, "__file__", None)
        if not f or name in ("__main__", "__mp_main__") or name == own:
            continue
        try:
            real = Path(f).resolve()
        except (OSError, ValueError):
            continue
        before = _RAN_WITH.get(real)
        if real not in now or before is None or before == now[real]:
            continue
        with contextlib.suppress(OSError, ValueError, NotImplementedError):
            Path(importlib.util.cache_from_source(str(real))).unlink(missing_ok=True)
        try:
            importlib.reload(mod)
        except Exception:  # the edit broke it: building the model says how
            sys.modules.pop(name, None)
        reloaded.append(name)
    _RAN_WITH.update(now)
    return reloaded


# -- declared inputs and what the scan cannot see ----------------------------------------------

#: Folders and files of a declared folder that are not inputs (caches, version control).
_SKIP_DIRS = {"__pycache__", ".git", ".hg", ".svn", ".venv", ".mypy_cache", ".pytest_cache"}
_SKIP_SUFFIXES = (".pyc", ".pyo")


def _declared_paths(spec: Any) -> list[tuple[str, Path]]:
    base = Path(spec.base_dir).absolute() if spec.base_dir else Path.cwd()
    out = []
    for item in getattr(spec, "inputs", ()) or ():
        p = Path(item)
        out.append((item, p if p.is_absolute() else base / p))
    return out


def declared_hashes(spec: Any) -> dict[str, Any]:
    """``{label: {"path", "sha256", "size"}}`` of every file of the study's declared inputs
    (``[study] inputs``): a declared file under its name as written, each file of a declared
    folder as ``folder/relative/path``; a declared input that cannot be read has
    ``sha256`` None (it is gone)."""
    out: dict[str, Any] = {}
    for item, path in _declared_paths(spec):
        if path.is_dir():
            files = []
            for folder, dirs, names in os.walk(path):
                dirs[:] = sorted(d for d in dirs if d not in _SKIP_DIRS)
                files += [Path(folder) / n for n in sorted(names)
                          if not n.endswith(_SKIP_SUFFIXES)]  # fmt: skip
            prefix = item.rstrip("/\\")
            if not files:
                out[f"{prefix}/"] = {"path": str(path), "sha256": hashlib.sha256().hexdigest(),
                                     "size": 0}  # fmt: skip
            for f in files:
                label = f"{prefix}/{f.relative_to(path).as_posix()}"
                digest = file_sha256(f)
                out[label] = {"path": str(f), "sha256": digest,
                              "size": f.stat().st_size if digest else None}  # fmt: skip
        else:
            digest = file_sha256(path)
            out[item] = {"path": str(path), "sha256": digest,
                         "size": path.stat().st_size if digest else None}  # fmt: skip
    return out


def _covered(lit: str | None, where: Path, spec: Any) -> bool:
    """Whether the literal path ``lit`` a module at ``where`` names lies in a declared
    input (relative to the study file's folder or to the module's)."""
    if not lit:
        return False
    declared = [Path(os.path.normpath(p.absolute())) for _, p in _declared_paths(spec)]
    base = Path(spec.base_dir).absolute() if spec.base_dir else Path.cwd()
    for c in _candidates(lit, [base], where):
        c = Path(os.path.normpath(c.absolute()))
        for d in declared:
            if c == d or _inside(c, d) or _inside(c.resolve(), d.resolve()):
                return True
    return False


def unseen_loads(spec: Any, code: _Code | None = None) -> list[str]:
    """Where the study's model code loads something the scan cannot follow (see the module
    docstring): ``"FILE:LINE CODE (what it does)"`` per place, in file order; a place whose
    literal path lies in a declared input is left out."""
    if code is None:
        code = _code(spec)[1]
    base = Path(spec.base_dir).absolute() if spec.base_dir else None
    out = []
    for path, line, text, lit, kind in code.unseen:
        if _covered(lit, path, spec):
            continue
        out.append(f"{_label(path, base)}:{line} {text} ({kind})")
    return list(dict.fromkeys(out))


def _unseen_note(spec: Any, places: list[str]) -> str:
    shown = "; ".join(places[:6]) + (f"; and {len(places) - 6} more" if len(places) > 6 else "")
    declared = list(getattr(spec, "inputs", ()) or ())
    said = (
        f" (declared now: {', '.join(declared)}: if they hold what these load, nothing more to do)"
        if declared
        else ""
    )
    return (
        f"vectorid cannot see what the model's code loads here: {shown} — a change to what "
        "they load would not be found before trials are added; declare it under [study] "
        'inputs = ["lib/", "coefficients.csv"] (files and folders, hashed like data files; '
        f"docs/store.md){said}"
    )


# -- comparing and recording -----------------------------------------------------------------

#: How much the model-code record covers: 1 before a model of your own's module, criterion
#: and reduction modules, compiled modules and literal dynamic imports were hashed. A store
#: recorded under an older scheme gets what it lacks recorded with a note, not refused.
CODE_SCHEME = 2


@dataclass(frozen=True)
class Change:
    """One input that differs from what the store's trials were computed with."""

    what: str
    old: str | None
    new: str | None
    kind: str  # "data file", "model code" or "declared input"

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


def _stored(store: Any, key: str) -> Any:
    text = store.meta().get(key)
    if text is None:
        return None
    try:
        return json.loads(text)
    except ValueError:
        return None


def _diff(kind: str, old: Mapping[str, Any], new: Mapping[str, Any]) -> list[Change]:
    """Entries whose content differs; an entry that only moved (the same content under
    another label: a renamed or re-linked file) is not a change."""
    out = []
    for name in sorted(set(old) | set(new)):
        a = (old.get(name) or {}).get("sha256")
        b = (new.get(name) or {}).get("sha256")
        if a != b:
            out.append(Change(name, a, b, kind))
    gone = [c for c in out if c.new is None and c.old is not None and c.what not in new]
    added = [c for c in out if c.old is None and c.new is not None and c.what not in old]
    for g in gone:
        twin = next((a for a in added if a.new == g.old), None)
        if twin is not None:  # the same content under another label: moved, not changed
            added.remove(twin)
            out.remove(twin)
            out.remove(g)
    return out


@dataclass
class _Comparison:
    changes: list[Change]
    #: Entries an older store could not record (its record covered less): recorded with a note.
    first: list[Change]
    #: Records the store lacks altogether ("data file", "model code").
    unrecorded: list[str]
    current: dict[str, Any]
    #: Places the scan cannot see, now and as recorded (None: never recorded).
    unseen: list[str]
    unseen_recorded: list[str] | None


def _compare(store: Any, spec: Any = None) -> _Comparison:
    spec = spec if spec is not None else store.spec
    code, scanned = _code(spec)
    current: dict[str, Any] = {
        "data_files": data_file_hashes(spec),
        "code_files": code,
        "declared_inputs": declared_hashes(spec),
    }
    # a data file that cannot be read now still counts: it is gone
    try:
        for name in _files(spec):
            current["data_files"].setdefault(name, {"sha256": None})
    except Exception:
        pass
    out = _Comparison([], [], [], current, unseen_loads(spec, scanned), None)
    scheme = _stored(store, "code_files_scheme")
    for key, kind in (("data_files", "data file"), ("code_files", "model code")):
        old = _stored(store, key)
        if not isinstance(old, dict):
            out.unrecorded.append(kind)
            continue
        for c in _diff(kind, old, current[key]):
            older = key == "code_files" and not (isinstance(scheme, int) and scheme >= CODE_SCHEME)
            (out.first if older and c.old is None else out.changes).append(c)
    declared = _stored(store, "declared_inputs")
    out.changes += _diff("declared input", declared if isinstance(declared, dict) else {},
                         current["declared_inputs"])  # fmt: skip
    recorded = _stored(store, "unseen_inputs")
    out.unseen_recorded = recorded if isinstance(recorded, list) else None
    current["code_files_scheme"] = CODE_SCHEME
    current["unseen_inputs"] = out.unseen
    return out


def input_changes(store: Any, spec: Any = None) -> tuple[list[Change], list[str], dict]:
    """Compare the store's recorded inputs with the files as they are now.

    Returns
    -------
    changes : list of Change
    unrecorded : list of str
        Which records the store lacks (``"data file"``, ``"model code"``): an older store.
    current : dict
        ``{"data_files": ..., "code_files": ..., "declared_inputs": ...}`` as they are now.
    """
    c = _compare(store, spec)
    return c.changes, c.unrecorded, c.current


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
    """Stop before a trial is added when the data files, the model's code or the declared
    inputs differ from those the store's trials were computed with (see the module
    docstring); say once what the scan cannot see.

    Parameters
    ----------
    store : Store
        Opened for writing.
    accept_changes : bool
        Take the changes, recording each in the store's history, instead of stopping.

    Returns
    -------
    list of str
        Notes for the user (records made for an older store, changes accepted, what the
        model loads that vectorid cannot see).

    Raises
    ------
    InputsChangedError
        When something changed and ``accept_changes`` is False.
    """
    cmp = _compare(store)
    changes, current = cmp.changes, cmp.current
    held = store.count_all_blocks()
    notes: list[str] = []
    now = time.time()
    entries: list[dict[str, Any]] = []
    if changes and held and not accept_changes:
        raise InputsChangedError(_message(store, changes))
    for c in changes if held else []:
        entries.append({"at": now, **c.to_dict(), "note": "accepted (--accept-changes)"})
        notes.append(f"accepted and recorded in the store's history: {c.describe()}")
    for kind in cmp.unrecorded:
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
    if cmp.first and held:
        names = ", ".join(c.what for c in cmp.first[:6])
        text = (
            f"store {store.path} was recorded by an older vectorid that hashed less of the "
            f"model's code: {names} recorded now; its {held} stored batches cannot be checked "
            "against them"
        )
        entries += [
            {"at": now, **c.to_dict(), "note": "first record (older store)"} for c in cmp.first
        ]
        notes.append(text)
    if cmp.unseen and cmp.unseen != cmp.unseen_recorded:
        notes.append(_unseen_note(store.spec, cmp.unseen))
    recorded = {k: _stored(store, k) for k in current}
    if entries or any(recorded[k] != v for k, v in current.items()):
        record_history(store, entries, **current)  # moved entries too: labels kept current
    for text in notes:
        warnings.warn(VectoridNote(text), stacklevel=3)
    return notes


def record_inputs(store: Any, spec: Any = None) -> None:
    """Record the model-code and declared-input hashes of a new store (its data files are
    recorded when it is created); what the scan cannot see is said at its first run."""
    spec = spec if spec is not None else store.spec
    store.set_meta(
        {
            "code_files": json.dumps(code_hashes(spec)),
            "code_files_scheme": json.dumps(CODE_SCHEME),
            "declared_inputs": json.dumps(declared_hashes(spec)),
        }
    )
