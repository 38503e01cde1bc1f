"""``vectorid ui`` without its extra: one line with the install command, exit 2."""

import sys

from vectorid.cli import main


def test_ui_without_dash_prints_the_install_hint_once(tmp_path, capsys, monkeypatch):
    store = tmp_path / "s.db"
    store.write_bytes(b"")  # the check for dash comes before the store is read
    monkeypatch.setitem(sys.modules, "dash", None)  # as if dash were not installed
    code = main(["ui", str(store)])
    out, err = capsys.readouterr()
    assert code == 2 and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "needs dash, which is not installed" in lines[0]
    assert lines[0].count("install") == 2  # "not installed" and the one command
    assert "[ui]'" in lines[0]
