"""Print the fuzz tally (cases per input kind and outcome) at the end of the session."""

from __future__ import annotations

from ._harness import NOTES, TALLY


def pytest_terminal_summary(terminalreporter) -> None:  # pragma: no cover - reporting
    if not TALLY:
        return
    tr = terminalreporter
    tr.section("fuzz cases per input kind")
    tr.write_line(f"{'kind':<16}{'cases':>7}{'clear':>8}{'tracebacks':>12}{'silent':>8}")
    total = {"cases": 0, "clear": 0, "traceback": 0, "silent": 0}
    for kind in sorted(TALLY):
        c = TALLY[kind]
        n = sum(c.values())
        total["cases"] += n
        for k in ("clear", "traceback", "silent"):
            total[k] += c[k]
        tr.write_line(f"{kind:<16}{n:>7}{c['clear']:>8}{c['traceback']:>12}{c['silent']:>8}")
    tr.write_line(
        f"{'all':<16}{total['cases']:>7}{total['clear']:>8}{total['traceback']:>12}"
        f"{total['silent']:>8}"
    )
    for line in NOTES:
        tr.write_line(line)


import os  # noqa: E402
import shutil  # noqa: E402
import subprocess  # noqa: E402
from pathlib import Path  # noqa: E402

import pytest  # noqa: E402


@pytest.fixture
def tmpfs(tmp_path):
    """Mount a small tmpfs (``size``, ``ro``): a full disk or a read-only folder even for
    root (root ignores permission bits). Root only; skipped elsewhere."""
    mounts: list[Path] = []

    def make(size: str, name: str = "fs", readonly: bool = False) -> Path:
        if os.geteuid() != 0 or shutil.which("mount") is None:
            pytest.skip("needs root and mount(8) to make a small or read-only filesystem")
        d = tmp_path / name
        d.mkdir()
        opts = f"size={size}" + (",ro" if readonly else "")
        r = subprocess.run(
            ["mount", "-t", "tmpfs", "-o", opts, "tmpfs", str(d)], capture_output=True, text=True
        )
        if r.returncode != 0:
            pytest.skip(f"cannot mount a tmpfs here: {r.stderr.strip()}")
        mounts.append(d)
        return d

    yield make
    for d in reversed(mounts):
        subprocess.run(["umount", "-l", str(d)], capture_output=True)
