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
