"""The house's layers hold: the import-linter contract of pyproject.toml passes, a forbidden
import breaks it, no module imports another that imports it back (imports inside functions
counted), and the core imports vectorid modules at the top of its files only."""

from __future__ import annotations

import ast
import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import grimp

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "vectorid"
LINT = Path(sys.executable).with_name("lint-imports")

#: Packages and modules that import vectorid modules at the top of their files only (the
#: command line, the demos and the views load heavy parts where a verb or a page needs them,
#: so ``vectorid --help`` and the UI start fast).
CORE = (
    "store/", "samplers/", "run/", "analysis/", "identify/", "models/", "workflows/", "descent/",
    "limits.py", "spec.py", "space.py", "problem.py", "builders.py", "sampling.py",
    "summary.py", "sampler_kinds.py", "errors.py", "timesteps.py", "analytic.py",
    "external.py", "study.py", "_toml.py", "_files.py",
)  # fmt: skip
#: ... but for these, which load numba's compiled kernels only when first used.
HEAVY = {("analysis/pareto.py", "._pareto_kernels")}


def _lint(cwd: Path, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [str(LINT), "--no-cache"], cwd=cwd, capture_output=True, text=True, timeout=300,
        env=env,
    )  # fmt: skip


def test_the_layers_contract_holds():
    r = _lint(ROOT)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "vectorid's layers KEPT" in r.stdout


def test_a_forbidden_import_breaks_the_contract(tmp_path):
    """A copy of the package whose store imports the command line fails the same check."""
    copy = tmp_path / "src"
    shutil.copytree(SRC, copy / "vectorid", ignore=shutil.ignore_patterns("__pycache__"))
    store = copy / "vectorid" / "store" / "store.py"
    store.write_text(store.read_text() + "\n\ndef _probe():\n    from ..cli import main  # noqa\n")
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]
    layers = ",\n    ".join(f'"{x}"' for x in config["contracts"][0]["layers"])
    (tmp_path / "pyproject.toml").write_text(
        '[tool.importlinter]\nroot_package = "vectorid"\nexclude_type_checking_imports = true\n\n'
        '[[tool.importlinter.contracts]]\nname = "layers"\ntype = "layers"\n'
        f"layers = [\n    {layers},\n]\n"
    )
    env = {**os.environ, "PYTHONPATH": str(copy)}
    r = _lint(tmp_path, env)
    assert r.returncode != 0, r.stdout
    assert "vectorid.store is not allowed to import vectorid.cli" in r.stdout, r.stdout


def test_no_import_circle_between_modules():
    graph = grimp.build_graph("vectorid", exclude_type_checking_imports=True)
    modules = sorted(graph.modules)
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    circles: list[list[str]] = []

    def visit(v: str) -> None:  # Tarjan's strongly connected components
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph.find_modules_directly_imported_by(v):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                circles.append(sorted(comp))

    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10 * len(modules)))
    for m in modules:
        if m not in index:
            visit(m)
    assert not circles, circles


def test_the_core_imports_vectorid_at_the_top_of_its_files():
    found = []
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC).as_posix()
        if not rel.startswith(CORE):
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        parents = {c: n for n in ast.walk(tree) for c in ast.iter_child_nodes(n)}
        for node in ast.walk(tree):
            if not isinstance(node, ast.Import | ast.ImportFrom):
                continue
            n, inside, typing_only = node, False, False
            while n in parents:
                n = parents[n]
                inside |= isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef)
                typing_only |= isinstance(n, ast.If) and "TYPE_CHECKING" in ast.unparse(n.test)
            if isinstance(node, ast.ImportFrom):
                name = "." * node.level + (node.module or "")
                if node.module is None:  # "from . import x"
                    name += ".".join(a.name for a in node.names)
            else:
                name = node.names[0].name
            own = name.startswith((".", "vectorid"))
            if inside and own and not typing_only and (rel, name) not in HEAVY:
                found.append(f"{rel}:{node.lineno} imports {name} inside a function")
    assert not found, found
