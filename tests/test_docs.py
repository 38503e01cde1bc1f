"""Documentation that is executed: every code block of README.md and docs/*.md.

The convention (also in docs/contributing.md, "Documentation that runs"):

* Every fenced block has a language. ``bash``/``sh``/``shell``/``console`` blocks are run with
  bash (``set -e``, so every line must succeed); ``python`` blocks are saved as a script and
  run with the venv's Python; ``toml`` and ``json`` blocks are parsed. ``text`` (and any other
  language) is prose: equations, synopses, output; never run.
* The files are followed in order (README.md, then docs/*.md by name) in one temporary folder
  that stands for a fresh clone: its ``.venv/bin/`` holds ``vectorid``, ``python`` and ``pip``
  of the venv running the tests, and ``python3`` on ``PATH`` answers ``-m venv .venv``. That
  ``pip`` installs nothing: it checks that the extras named (``-e '.[ui]'``) are installed.
  Commands run exactly as written.
* An HTML comment on the line(s) just before a fence changes what happens to that block:

  - ``<!-- docs-test: file: PATH -->``: the block is written to ``PATH`` (relative to the
    folder) instead of being run, for the files a reader is told to save;
  - ``<!-- docs-test: output-of: COMMAND -->`` (json blocks): ``COMMAND`` is run and its
    output must hold every key of the example, at the same places;
  - ``<!-- docs-test: server: URL -->`` (bash blocks that start a server): the block runs in
    the background until ``URL`` answers, then it is stopped;
  - ``<!-- docs-test: needs: PATH -->``: run only where ``PATH`` (relative to the clone, e.g.
    ``../shared/data/eth-parafoil``) exists, as the acceptance tests on shared data do; the
    clone folder has ``../shared`` beside it when the checkout has, and the repository's
    ``examples/`` and ``scripts/`` in it;
  - ``<!-- docs-test: slow: REASON -->``: run by the ``slow`` suite (``pytest -m slow``, which
    ``.ci/run`` runs), each such block in a fresh clone folder;
  - ``<!-- docs-test: skip: REASON -->``: not run. Keep these few, each with its reason.

Failures name the file, the block's line, and the command that failed.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import textwrap
import time
import tomllib
import urllib.parse
import urllib.request
from dataclasses import dataclass, field
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
VENV_BIN = Path(sys.executable).parent
RUN = {"bash", "sh", "shell", "console"}
PARSE = {"toml", "json"}
#: Longest a block may run, s.
BLOCK_TIMEOUT = 900
#: The skips allowed across all docs; a new one needs a reason, and this number raised.
MAX_SKIPS = 2

_FENCE = re.compile(r"^(\s*)(`{3,}|~{3,})\s*([\w+-]*)\s*$")
_DIRECTIVE = re.compile(r"^\s*<!--\s*docs-test:\s*([\w-]+)\s*(?::\s*(.*?))?\s*-->\s*$")


@dataclass
class Block:
    path: Path
    line: int  # 1-based line of the opening fence
    lang: str
    text: str
    directives: dict[str, str] = field(default_factory=dict)

    @property
    def where(self) -> str:
        return f"{self.path.relative_to(ROOT)}:{self.line} (```{self.lang or '(no language)'})"


def blocks(path: Path) -> list[Block]:
    """The fenced blocks of a markdown file with the docs-test directives just above them."""
    lines = path.read_text(encoding="utf-8").splitlines()
    out: list[Block] = []
    i = 0
    while i < len(lines):
        m = _FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        indent, fence, lang = m.groups()
        directives: dict[str, str] = {}
        j = i - 1
        while j >= 0 and (d := _DIRECTIVE.match(lines[j])):
            directives[d.group(1)] = d.group(2) or ""
            j -= 1
        body = []
        k = i + 1
        while k < len(lines) and not lines[k].strip().startswith(fence):
            body.append(lines[k][len(indent) :] if lines[k].startswith(indent) else lines[k])
            k += 1
        out.append(Block(path, i + 1, lang.lower(), "\n".join(body) + "\n", directives))
        i = k + 1
    return out


ALL_BLOCKS = [b for p in DOCS for b in blocks(p)]

# --------------------------------------------------------------------------------------------
# the folder standing for a fresh clone
# --------------------------------------------------------------------------------------------

_PIP = '''\
#!{python}
"""pip of the docs test: installs nothing, checks that the extras asked for are installed."""
import re, sys, tomllib
from importlib import metadata
from pathlib import Path

args = [a for a in sys.argv[1:] if not a.startswith("-")]
if not args or args[0] != "install":
    sys.exit(f"docs-test pip: only 'install' is supported, got {{sys.argv[1:]}}")
extras = []
for spec in args[1:]:
    m = re.fullmatch(r"(\\.|vectorid)(?:\\[([\\w,]+)\\])?", spec)
    if not m:
        sys.exit(f"docs-test pip: cannot check {{spec!r}} (expected '.', '.[extra]' or "
                 "'vectorid[extra]')")
    extras += (m.group(2) or "").split(",") if m.group(2) else []
opt = tomllib.loads(Path({pyproject!r}).read_text())["project"]["optional-dependencies"]
missing = []
for extra in extras:
    for req in opt[extra]:
        name = re.match(r"[\\w.-]+", req).group(0)
        if name == "vectorid":
            continue
        try:
            metadata.version(name)
        except metadata.PackageNotFoundError:
            missing.append(f"{{name}} (extra {{extra}})")
if missing:
    sys.exit("docs-test pip: not installed in the test venv: " + ", ".join(missing))
'''

_PYTHON3 = """\
#!/bin/sh
# python3 of the docs test: the clone's .venv exists already.
if [ "$1" = "-m" ] && [ "$2" = "venv" ] && [ "$3" = ".venv" ] && [ -d .venv ]; then exit 0; fi
exec {python} "$@"
"""


def _make_clone(folder: Path) -> dict[str, str]:
    """Prepare ``folder`` as a clone with its venv; return the environment to run blocks in."""
    bin_ = folder / ".venv" / "bin"
    bin_.mkdir(parents=True)
    shims = folder / ".docs-test-path"
    shims.mkdir()
    real = VENV_BIN / "vectorid"
    script = real.read_text(encoding="utf-8")  # the console script, with its #! to the venv
    (bin_ / "vectorid").write_text(script, encoding="utf-8")
    (bin_ / "python").write_text(f'#!/bin/sh\nexec {sys.executable} "$@"\n', encoding="utf-8")
    (bin_ / "pip").write_text(
        _PIP.format(python=sys.executable, pyproject=str(ROOT / "pyproject.toml")),
        encoding="utf-8",
    )
    (shims / "python3").write_text(_PYTHON3.format(python=sys.executable), encoding="utf-8")
    for f in [*bin_.iterdir(), *shims.iterdir()]:
        f.chmod(0o755)
    for name in ("examples", "scripts", "docs"):  # what a clone has beside the package
        (folder / name).symlink_to(ROOT / name, target_is_directory=True)
    shared = ROOT.parent / "shared"
    if shared.is_dir() and not (folder.parent / "shared").exists():
        (folder.parent / "shared").symlink_to(shared, target_is_directory=True)
    env = dict(os.environ)
    # vectorid is on PATH only as .venv/bin/vectorid, as after the README's setup
    env["PATH"] = os.pathsep.join([str(shims), "/usr/local/bin", "/usr/bin", "/bin"])
    env.pop("PYTHONPATH", None)
    env["MPLBACKEND"] = "Agg"
    return env


@pytest.fixture(scope="module")
def clone(tmp_path_factory):
    """The shared folder and environment, with the docs that ran in it so far."""
    folder = tmp_path_factory.mktemp("clone")
    return folder, _make_clone(folder), set()


# --------------------------------------------------------------------------------------------
# running one block
# --------------------------------------------------------------------------------------------


def _tail(text: str, n: int = 25) -> str:
    lines = text.strip().splitlines()
    return "\n".join(lines[-n:])


def _fail(block: Block, what: str, detail: str = "") -> None:
    body = textwrap.indent(block.text.rstrip(), "    | ")
    msg = f"{block.where}: {what}\n  the block:\n{body}"
    if detail:
        msg += f"\n  output (end):\n{textwrap.indent(_tail(detail), '    ')}"
    pytest.fail(msg, pytrace=False)


def _bash(block: Block, folder: Path, env: dict[str, str]) -> str:
    # report the failing line: bash's ERR trap knows the command
    script = (
        "set -eE -o pipefail\n"
        "trap 'echo \"docs-test: failed (exit $?): $BASH_COMMAND\" >&2' ERR\n" + block.text
    )
    try:
        out = subprocess.run(
            ["bash", "-c", script], cwd=folder, env=env, capture_output=True, text=True,
            timeout=BLOCK_TIMEOUT, stdin=subprocess.DEVNULL,
        )  # fmt: skip
    except subprocess.TimeoutExpired:
        _fail(block, f"did not finish in {BLOCK_TIMEOUT} s")
    if out.returncode != 0:
        failed = re.findall(r"docs-test: failed \(exit \d+\): (.*)", out.stderr)
        what = f"command failed: `{failed[-1]}`" if failed else f"exit {out.returncode}"
        _fail(block, what, out.stdout + "\n" + out.stderr)
    if "Traceback (most recent call last)" in out.stderr:
        _fail(block, "printed a traceback (exit 0)", out.stderr)
    return out.stdout


def _server(block: Block, folder: Path, env: dict[str, str], url: str) -> None:
    parts = urllib.parse.urlsplit(url)
    with socket.socket() as sock:
        if sock.connect_ex((parts.hostname, parts.port or 80)) == 0:
            _fail(block, f"{parts.hostname}:{parts.port} is in use by another process; stop it "
                  "and run the test again")  # fmt: skip
    proc = subprocess.Popen(
        ["bash", "-c", "set -e\n" + block.text], cwd=folder, env=env, text=True,
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
        start_new_session=True,
    )  # fmt: skip
    try:
        deadline = time.monotonic() + BLOCK_TIMEOUT
        while time.monotonic() < deadline:
            if proc.poll() is not None:
                _fail(block, f"ended (exit {proc.returncode}) before {url} answered",
                      proc.stdout.read())  # fmt: skip
            try:
                with urllib.request.urlopen(url, timeout=5) as r:
                    if r.status == 200:
                        return
            except OSError:
                pass
            time.sleep(1.0)
        _fail(block, f"{url} did not answer within {BLOCK_TIMEOUT} s")
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGINT)
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()


def _python(block: Block, folder: Path, env: dict[str, str]) -> None:
    name = f"docs_{block.path.stem.lower()}_{block.line}.py"
    (folder / name).write_text(block.text, encoding="utf-8")
    try:
        out = subprocess.run(
            [str(folder / ".venv" / "bin" / "python"), name], cwd=folder, env=env,
            capture_output=True, text=True, timeout=BLOCK_TIMEOUT, stdin=subprocess.DEVNULL,
        )  # fmt: skip
    except subprocess.TimeoutExpired:
        _fail(block, f"did not finish in {BLOCK_TIMEOUT} s")
    if out.returncode != 0:
        last = out.stderr.strip().splitlines()[-1:] or [f"exit {out.returncode}"]
        _fail(block, f"the Python block failed: {last[0]}", out.stdout + "\n" + out.stderr)


def _keys_missing(example, actual, where: str = "") -> list[str]:
    """Key paths of ``example`` that ``actual`` lacks (lists: their first elements)."""
    if isinstance(example, dict):
        if not isinstance(actual, dict):
            return [f"{where or '.'} is {type(actual).__name__}, not an object"]
        out = []
        for k, v in example.items():
            if k not in actual:
                out.append(f"{where}.{k}")
            else:
                out += _keys_missing(v, actual[k], f"{where}.{k}")
        return out
    if isinstance(example, list) and example:
        if not isinstance(actual, list):
            return [f"{where} is {type(actual).__name__}, not a list"]
        return _keys_missing(example[0], actual[0], f"{where}[0]") if actual else []
    return []


def _json(block: Block, folder: Path, env: dict[str, str]) -> None:
    try:
        example = json.loads(block.text)
    except json.JSONDecodeError as exc:
        _fail(block, f"not valid JSON: {exc}")
    command = block.directives.get("output-of")
    if command is None:
        return
    out = subprocess.run(
        ["bash", "-c", "set -e -o pipefail\n" + command], cwd=folder, env=env,
        capture_output=True, text=True, timeout=BLOCK_TIMEOUT, stdin=subprocess.DEVNULL,
    )  # fmt: skip
    if out.returncode != 0:
        _fail(block, f"output-of command failed: `{command}`", out.stderr)
    missing = _keys_missing(example, json.loads(out.stdout))
    if missing:
        _fail(block, f"the output of `{command}` has no {', '.join(missing)}", out.stdout)


def run_block(block: Block, folder: Path, env: dict[str, str]) -> str | None:
    """Run (or write, or parse) one block in ``folder``; a bash block's standard output."""
    d = block.directives
    if "file" in d:
        target = folder / d["file"]
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(block.text, encoding="utf-8")
    if block.lang == "toml":
        try:
            tomllib.loads(block.text)
        except tomllib.TOMLDecodeError as exc:
            _fail(block, f"not valid TOML: {exc}")
    elif block.lang == "json":
        _json(block, folder, env)
    elif "file" in d:
        return
    elif block.lang in RUN and "server" in d:
        _server(block, folder, env, d["server"])
    elif block.lang in RUN:
        return _bash(block, folder, env)
    elif block.lang == "python":
        _python(block, folder, env)
    return None


# --------------------------------------------------------------------------------------------
# the tests
# --------------------------------------------------------------------------------------------


def _runs_here(block: Block, folder: Path) -> bool:
    needs = block.directives.get("needs")
    return needs is None or (folder / needs).exists()


def _run_doc(doc: Path, folder: Path, env: dict[str, str]) -> None:
    for block in blocks(doc):
        d = block.directives
        if "skip" not in d and "slow" not in d and _runs_here(block, folder):
            run_block(block, folder, env)


SLOW_BLOCKS = [b for b in ALL_BLOCKS if "slow" in b.directives and "skip" not in b.directives]

#: The slow blocks run in this session: (file, line) -> (clone folder, standard output), or the
#: failure, so a test that checks what a block produced (the parafoil demo's truth test reads
#: the README demo's folder and output) does not run it again.
_SLOW_RUNS: dict[tuple[Path, int], tuple[Path, str | None] | BaseException] = {}


def run_slow_block(block: Block, tmp_path_factory) -> tuple[Path, str | None]:
    """Run a slow block once per session in a fresh clone folder: (folder, its output).

    Skips where the block ``needs`` a path that is absent; a failure is kept and raised again
    for every later caller, each of which sees it.
    """
    key = (block.path, block.line)
    if key not in _SLOW_RUNS:
        folder = tmp_path_factory.mktemp("slow-clone")
        env = _make_clone(folder)
        if not _runs_here(block, folder):
            pytest.skip(f"{block.directives['needs']} not found")
        try:
            _SLOW_RUNS[key] = (folder, run_block(block, folder, env))
        except pytest.fail.Exception as exc:
            _SLOW_RUNS[key] = exc
            raise
    done = _SLOW_RUNS[key]
    if isinstance(done, BaseException):
        raise done
    return done


def readme_demo_block(command: str) -> Block:
    """The README's slow block that runs ``command`` (e.g. ``vectorid demo parafoil``)."""
    found = [b for b in SLOW_BLOCKS if b.path.name == "README.md" and command in b.text]
    assert len(found) == 1, f"README.md has {len(found)} slow blocks running {command!r}"
    return found[0]


@pytest.mark.long
@pytest.mark.slow
@pytest.mark.parametrize("block", SLOW_BLOCKS, ids=[b.where for b in SLOW_BLOCKS])
def test_slow_doc_blocks_run(block, tmp_path_factory):
    """The blocks marked ``slow`` (minutes each), each in a fresh clone folder (once per
    session: tests that read a block's output share its run)."""
    run_slow_block(block, tmp_path_factory)


@pytest.mark.parametrize("doc", DOCS, ids=[str(p.relative_to(ROOT)) for p in DOCS])
def test_doc_blocks_run(doc, clone):
    """Each file's blocks, in order, in the shared clone folder: a reader follows the README,
    then the docs; the files before this one run first if they have not (e.g. with -k)."""
    folder, env, done = clone
    for earlier in DOCS[: DOCS.index(doc)]:
        if earlier not in done:
            done.add(earlier)
            _run_doc(earlier, folder, env)
    done.add(doc)
    _run_doc(doc, folder, env)


def test_every_block_has_a_language_and_known_directives():
    known = {"file", "output-of", "server", "skip", "needs", "slow"}
    problems = []
    for b in ALL_BLOCKS:
        if not b.lang:
            problems.append(f"{b.where}: give the fence a language (```text for prose/output)")
        for name in b.directives:
            if name not in known:
                problems.append(f"{b.where}: unknown directive {name!r} (known: {sorted(known)})")
        for name in ("skip", "slow", "needs"):
            if name in b.directives and not b.directives[name].strip():
                problems.append(f"{b.where}: <!-- docs-test: {name}: ... --> needs its argument")
        if "skip" in b.directives and not b.directives["skip"].strip():
            problems.append(f"{b.where}: a skip needs its reason: <!-- docs-test: skip: WHY -->")
        if "output-of" in b.directives and b.lang != "json":
            problems.append(f"{b.where}: output-of is for json blocks")
        if "server" in b.directives and b.lang not in RUN:
            problems.append(f"{b.where}: server is for shell blocks")
    assert not problems, "\n".join(problems)


def test_skips_stay_few():
    skips = [f"{b.where}: {b.directives['skip']}" for b in ALL_BLOCKS if "skip" in b.directives]
    assert len(skips) <= MAX_SKIPS, "too many skipped doc blocks:\n" + "\n".join(skips)


def test_runnable_blocks_exist():
    # the convention's default is "runs": the docs hold blocks of each runnable kind
    langs = {b.lang for b in ALL_BLOCKS if "skip" not in b.directives}
    assert {"bash", "python", "toml", "json"} <= langs


def test_ci_runs_the_readme_test_command():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    m = re.search(r"\*\*Set up and run the tests\*\*.*?```bash\n(.+?)\n```", readme, re.S)
    assert m, "README.md: the 'Set up and run the tests' block is missing"
    command = m.group(1).strip()
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    assert command in [line.strip() for line in ci], (
        f".ci/run must run the README's test command exactly: {command}"
    )


def _titles(path: Path) -> list[str]:
    """The level-1 headings of a markdown file, outside code blocks."""
    fenced = {n for b in blocks(path) for n in range(b.line, b.line + b.text.count("\n") + 1)}
    lines = path.read_text(encoding="utf-8").splitlines()
    return [s[2:].strip() for i, s in enumerate(lines, 1) if s.startswith("# ") and i not in fenced]


#: The README is the first hour: what vectorid is, the two commands, a tour and links.
README_MAX_LINES = 250
_LINK = re.compile(r"\]\(([^)\s]+)\)")


def test_readme_is_short_and_every_local_link_resolves():
    readme = ROOT / "README.md"
    n = len(readme.read_text(encoding="utf-8").splitlines())
    assert n <= README_MAX_LINES, (
        f"README.md has {n} lines (at most {README_MAX_LINES}): move details to a page of docs/"
    )
    broken = []
    for doc in DOCS:
        fenced = {i for b in blocks(doc) for i in range(b.line, b.line + b.text.count("\n") + 1)}
        for i, line in enumerate(doc.read_text(encoding="utf-8").splitlines(), 1):
            for target in _LINK.findall(line) if i not in fenced else ():
                path = target.split("#", 1)[0]
                if path and "://" not in path and not path.startswith("mailto:"):
                    if not (doc.parent / path).exists():
                        broken.append(f"{doc.relative_to(ROOT)}:{i}: {target}")
    assert not broken, "links to files that do not exist:\n" + "\n".join(broken)


def test_each_doc_has_one_title_and_no_two_share_one():
    titles = {p.name: _titles(p) for p in DOCS}
    several = {k: v for k, v in titles.items() if len(v) != 1}
    assert not several, f"each doc needs exactly one '# ' title: {several}"
    seen: dict[str, str] = {}
    for name, (title,) in titles.items():
        assert title not in seen, f"{name} and {seen[title]} share the title {title!r}"
        seen[title] = name


def test_block_parser_sees_directives_and_languages(tmp_path):
    md = tmp_path / "x.md"
    md.write_text(
        "text\n<!-- docs-test: skip: needs a cluster -->\n```bash\nfalse\n```\n"
        "<!-- docs-test: file: a/b.toml -->\n```toml\nx = 1\n```\n~~~\nno lang\n~~~\n",
        encoding="utf-8",
    )
    got = blocks(md)
    assert [(b.line, b.lang, b.directives) for b in got] == [
        (3, "bash", {"skip": "needs a cluster"}),
        (7, "toml", {"file": "a/b.toml"}),
        (10, "", {}),
    ]
    assert got[1].text == "x = 1\n"


def test_a_failing_block_names_file_line_and_command(tmp_path):
    folder = tmp_path / "c"
    folder.mkdir()
    env = _make_clone(folder)
    b = Block(ROOT / "README.md", 99, "bash", "true\n.venv/bin/vectorid init foo\ntrue\n")
    with pytest.raises(pytest.fail.Exception) as info:
        run_block(b, folder, env)
    text = str(info.value)
    assert "README.md:99 (```bash)" in text and "`.venv/bin/vectorid init foo`" in text
    assert shutil.which("vectorid", path=env["PATH"]) is None  # only .venv/bin/vectorid


def test_json_key_check():
    example = {"n": 1, "pareto": [{"id": 1, "params": {"x1": 0.5}}], "empty": {"joint": None}}
    actual = {"n": 2, "pareto": [{"id": 3, "params": {"x1": 0.1, "x2": 1}}], "empty": {}}
    assert _keys_missing(example, actual) == [".empty.joint"]
    assert _keys_missing({"pareto": [{"id": 1}]}, {"pareto": [{"seq": 1}]}) == [".pareto[0].id"]
    assert _keys_missing({"a": {"b": 1}}, {"a": [1]}) == [".a is list, not an object"]


def test_demo_next_commands_are_the_ones_the_reader_typed(tmp_path):
    # the README installs into .venv and runs .venv/bin/vectorid: the demo's "Next:" lines
    # must say so, and `init` tells how to run what it wrote the same way
    folder = tmp_path / "c"
    folder.mkdir()
    env = _make_clone(folder)
    cmd = ".venv/bin/vectorid demo --analytic --out d --trials 64 --quiet"
    out = subprocess.run(["bash", "-c", cmd], cwd=folder, env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert "Next: .venv/bin/vectorid table d/binh-korn.db" in out.stdout
    assert "|   .venv/bin/vectorid pareto d/binh-korn.db --json" in out.stdout
    out = subprocess.run(["bash", "-c", ".venv/bin/vectorid init tanaka"], cwd=folder, env=env,
                         capture_output=True, text=True)  # fmt: skip
    assert "run it with: .venv/bin/vectorid run tanaka.toml" in out.stdout
