"""Progress where someone watches: ``Study.run`` shows a bar on a terminal, nothing in a pipe
(issue 37)."""

from __future__ import annotations

import fcntl
import io
import os
import pty
import select
import struct
import subprocess
import sys
import termios
import textwrap

from vectorid import _hints
from vectorid.run.loop import progress_wanted

from ..conftest import write_user_study


class _Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_wanted_on_a_terminal_only(monkeypatch):
    monkeypatch.delenv(_hints.QUIET_ENV, raising=False)
    assert progress_wanted(_Tty()) is True
    assert progress_wanted(io.StringIO()) is False
    with _hints.quiet_notices():  # --quiet wins over a terminal
        assert progress_wanted(_Tty()) is False


SCRIPT = """
from vectorid import Study, load_study

with Study.create(load_study("user.toml"), "u.db") as study:
    summary = study.run(trials=64, executor="serial")  # progress not given: auto
print("stored", summary.stored)
"""


def _run(folder, stderr_tty: bool) -> tuple[str, str]:
    """Run the script with its stderr on a pseudo-terminal or a pipe; (stdout, stderr)."""
    env = dict(os.environ)
    env.pop(_hints.QUIET_ENV, None)
    for key in [k for k in env if k.startswith("TQDM_")]:  # a CI's tqdm settings
        env.pop(key)
    script = textwrap.dedent(SCRIPT)
    if not stderr_tty:
        out = subprocess.run([sys.executable, "-c", script], cwd=folder, env=env,
                             capture_output=True, text=True, timeout=300)  # fmt: skip
        assert out.returncode == 0, out.stderr
        return out.stdout, out.stderr
    leader, follower = pty.openpty()
    fcntl.ioctl(follower, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))  # 100 columns
    # the follower stays open here until the child has exited and everything it wrote is
    # read: a terminal whose last follower closes may drop what is still buffered (Linux)
    try:
        proc = subprocess.Popen([sys.executable, "-c", script], cwd=folder, env=env,
                                stdout=subprocess.PIPE, stderr=follower, text=True)  # fmt: skip
        chunks = []
        while True:
            ready, _, _ = select.select([leader], [], [], 0.1)
            if ready:
                chunks.append(os.read(leader, 4096))
            elif proc.poll() is not None:
                break
        stdout = proc.stdout.read()
        assert proc.wait(timeout=300) == 0
    finally:
        os.close(follower)
        os.close(leader)
    return stdout, b"".join(chunks).decode("utf-8", "replace")


def test_study_run_shows_a_bar_on_a_terminal_and_nothing_in_a_pipe(tmp_path):
    folder = write_user_study(tmp_path / "tty", trials=64).parent
    out, err = _run(folder, stderr_tty=True)
    assert "stored 64" in out
    assert "64/64" in err and "trial" in err, err  # tqdm's bar: done/total, trials
    folder = write_user_study(tmp_path / "pipe", trials=64).parent
    out, err = _run(folder, stderr_tty=False)
    assert "stored 64" in out and "64/64" not in err and "trial/s" not in err
