"""What a worker needs to build a model imports no run machinery, and identify's own modules
import one another without a circle (imports inside functions counted)."""

from __future__ import annotations

import ast
from pathlib import Path

SRC = Path(__file__).resolve().parents[2] / "src"
#: Packages above the problem builders: identify imports none of them, lazily or not.
ABOVE = ("store", "run", "samplers", "sequential", "analysis", "study", "workflows", "views")


def _module(path: Path) -> str:
    rel = path.relative_to(SRC).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _imports(path: Path) -> set[str]:
    """Every ``vectorid`` module a file imports, at any depth of its body."""
    mod = _module(path)
    package = mod if path.name == "__init__.py" else mod.rpartition(".")[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                head = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                base = ".".join([*head, base] if base else head)
            out.add(base)
            out |= {f"{base}.{a.name}" for a in node.names}
    return {m for m in out if m.startswith("vectorid")}


def _graph(package: str) -> dict[str, set[str]]:
    root = SRC / Path(*package.split("."))
    files = {_module(p): p for p in root.rglob("*.py")}
    graph = {}
    for name, path in files.items():
        deps = set()
        for m in _imports(path):
            while m not in files and "." in m:  # a name inside a module -> the module
                m = m.rpartition(".")[0]
            if m in files and m != name:
                deps.add(m)
        graph[name] = deps
    return graph


def test_identify_imports_nothing_above_the_builders():
    bad = {}
    for path in (SRC / "vectorid" / "identify").rglob("*.py"):
        hits = sorted(m for m in _imports(path) if m.split(".")[1:2] and m.split(".")[1] in ABOVE)
        if hits:
            bad[_module(path)] = hits
    assert not bad, bad


def test_identify_modules_form_a_dag():
    graph = _graph("vectorid.identify")
    # the package __init__ re-exports its modules; a module that imports the package itself
    # would close a circle through it
    state: dict[str, int] = {}
    cycle: list[str] = []

    def visit(n: str, stack: list[str]) -> bool:
        state[n] = 1
        for m in sorted(graph[n]):
            if state.get(m) == 1:
                cycle.extend([*stack[stack.index(m) :], m])
                return True
            if m not in state and visit(m, [*stack, m]):
                return True
        state[n] = 2
        return False

    for n in sorted(graph):
        if n not in state and visit(n, [n]):
            break
    assert not cycle, " -> ".join(cycle)


def test_nothing_below_the_workflows_imports_them():
    below = ("identify", "models", "store", "run", "analysis", "sequential", "samplers")
    bad = {}
    for sub in below:
        for path in (SRC / "vectorid" / sub).rglob("*.py"):
            hits = sorted(m for m in _imports(path) if m.startswith("vectorid.workflows"))
            if hits:
                bad[_module(path)] = hits
    for name in ("study.py", "spec.py", "problem.py", "builders.py", "space.py"):
        hits = sorted(m for m in _imports(SRC / "vectorid" / name) if "workflows" in m)
        if hits:
            bad[name] = hits
    assert not bad, bad
