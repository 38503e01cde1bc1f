"""The commands the CLI prints follow how vectorid was installed and started."""

import os
import sys
from pathlib import Path

from vectorid import _hints

ROOT = Path(__file__).resolve().parents[1]


def _venv_script(tmp_path: Path) -> Path:
    script = tmp_path / ".venv" / "bin" / "vectorid"
    script.parent.mkdir(parents=True)
    script.write_text("#!/bin/sh\n", encoding="utf-8")
    script.chmod(0o755)
    return script


def test_command_name_relative_to_the_folder_when_not_on_path(tmp_path, monkeypatch):
    script = _venv_script(tmp_path)
    monkeypatch.setenv("PATH", "/usr/bin:/bin")
    # as typed (".venv/bin/vectorid") or as the shell expanded it (absolute)
    monkeypatch.chdir(tmp_path)
    assert _hints.command_name(".venv/bin/vectorid") == ".venv/bin/vectorid"
    assert _hints.command_name(str(script)) == ".venv/bin/vectorid"
    # from another folder the path still works when typed there
    elsewhere = tmp_path / "other"
    elsewhere.mkdir()
    assert _hints.command_name(str(script), cwd=elsewhere) == str(script)


def test_command_name_is_plain_when_path_finds_the_same_script(tmp_path, monkeypatch):
    script = _venv_script(tmp_path)
    monkeypatch.setenv("PATH", f"{script.parent}{os.pathsep}/usr/bin")
    assert _hints.command_name(str(script), cwd=tmp_path) == "vectorid"


def test_command_name_outside_the_console_script():
    assert _hints.command_name("/usr/lib/python3/pytest") == "vectorid"
    assert _hints.command_name("") == "vectorid"
    assert _hints.command_name("-c") == "vectorid"


def test_install_hint_for_this_source_checkout(monkeypatch):
    # the test suite runs from an editable install of the checkout (README's setup)
    monkeypatch.setenv("PATH", "/usr/bin:/bin")
    hint = _hints.install_hint("parquet", cwd=ROOT)
    pip = Path(sys.executable).parent / "pip"
    try:
        shown = str(pip.resolve().relative_to(ROOT))  # e.g. .venv/bin/pip
    except ValueError:
        shown = str(pip)
    assert hint == f"{shown} install -e '.[parquet]'"
    below = _hints.install_hint("ui", cwd=ROOT / "docs")
    assert below.endswith(" install -e '..[ui]'")


def test_install_hint_for_an_installed_package(monkeypatch, tmp_path):
    fake = tmp_path / "site-packages" / "vectorid"
    fake.mkdir(parents=True)
    monkeypatch.setattr(_hints, "_PACKAGE", fake)
    assert _hints.install_hint("parquet").endswith(" install 'vectorid[parquet]'")


class _Out:
    """A text file that says whether it is a terminal."""

    def __init__(self, tty: bool) -> None:
        self.tty, self.text = tty, ""

    def isatty(self) -> bool:
        return self.tty

    def write(self, s: str) -> None:
        self.text += s

    def flush(self) -> None:
        pass


def test_waiting_in_a_log_says_what_then_how_long(monkeypatch):
    import threading
    import time

    monkeypatch.delenv(_hints.QUIET_ENV, raising=False)
    monkeypatch.setattr(_hints, "LINES_AT", (0.2, 0.4))
    out = _Out(tty=False)
    before = threading.active_count()
    with _hints.waiting("compiling the x model's kernel", note="about 3 s", file=out):
        time.sleep(0.7)
    lines = out.text.splitlines()
    assert lines[0] == "compiling the x model's kernel (about 3 s) ..."
    assert lines[1].startswith("  ... still compiling the x model's kernel: 0 s so far")
    assert len(lines) == 4 and "still" in lines[2]
    took = float(lines[-1].split("done after ")[1].split(" s")[0])
    assert lines[-1].startswith("compiling the x model's kernel: done after ") and took >= 0.7
    assert threading.active_count() == before  # the timer thread is gone (workers may fork)


def test_waiting_on_a_terminal_rewrites_one_line_and_says_nothing_when_short(monkeypatch):
    import time

    monkeypatch.delenv(_hints.QUIET_ENV, raising=False)
    monkeypatch.setattr(_hints, "TICK", 0.1)
    out = _Out(tty=True)
    with _hints.waiting("building the noise floor", file=out):
        time.sleep(0.35)
    assert out.text.startswith("\rbuilding the noise floor ... 0 s")
    assert out.text.count("\r") >= 3 and out.text.endswith("\n")
    assert "\rbuilding the noise floor: done after 0." in out.text
    short = _Out(tty=True)
    with _hints.waiting("quick", after=5.0, file=short):
        pass
    assert short.text == ""  # ended within `after`: nothing said
    failed = _Out(tty=False)
    try:
        with _hints.waiting("doomed", file=failed):
            time.sleep(0.05)
            raise KeyError
    except KeyError:
        pass
    assert "doomed: stopped after" in failed.text


def test_quiet_silences_waiting(monkeypatch):
    out = _Out(tty=False)
    with _hints.quiet_notices():
        assert _hints.quiet() and os.environ[_hints.QUIET_ENV] == "1"
        with _hints.waiting("anything", file=out):
            pass
    assert out.text == "" and not _hints.quiet()


def test_an_inner_wait_speaks_alone(monkeypatch):
    """A compile inside a noise floor: while the inner wait lasts, only it speaks."""
    import time

    monkeypatch.delenv(_hints.QUIET_ENV, raising=False)
    monkeypatch.setattr(_hints, "LINES_AT", (0.15, 0.3, 0.45))
    out = _Out(tty=False)
    with _hints.waiting("outer", file=out):
        with _hints.waiting("inner", file=out):
            time.sleep(0.5)
    lines = out.text.splitlines()
    assert lines[0] == "outer ..." or lines[0] == "inner ...", lines
    inner = [ln for ln in lines if "still inner" in ln]
    assert inner and not [ln for ln in lines if "still outer" in ln], lines
    assert lines[-2].startswith("inner: done after") and lines[-1].startswith("outer: done after")
