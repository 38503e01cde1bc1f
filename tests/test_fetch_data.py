"""Data a newcomer can get: ``scripts/fetch_data.py`` and the examples' errors (issue 37).

The download itself needs the network, which the tests do not use: ``--from`` feeds the script
the source files of ``../shared/data`` (byte-for-byte copies of the public ones), so the checks
(git blob ids) and the conversions are the ones a download goes through.
"""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared" / "data"


def _script():
    spec = importlib.util.spec_from_file_location("fetch_data", ROOT / "scripts" / "fetch_data.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules["fetch_data"] = mod  # its dataclasses look their module up while created
    spec.loader.exec_module(mod)
    return mod


def test_every_example_that_reads_real_data_is_covered():
    fd = _script()
    covered = {e for d in fd.DATASETS.values() for e in d.examples}
    readers = {
        f"examples/{p.name}"
        for p in (ROOT / "examples").glob("*.py")
        if "shared" in p.read_text(encoding="utf-8")
    }
    assert readers and readers <= covered, f"examples without a data source: {readers - covered}"
    for d in fd.DATASETS.values():
        assert d.files and all(len(f.blob) == 40 for f in d.files)
        assert d.files[0].url.startswith("https://raw.githubusercontent.com/")
        assert d.licence and d.source


def test_list_names_source_and_licence(capsys):
    assert _script().main(["--list", "eth-parafoil"]) == 0
    out = capsys.readouterr().out
    assert "github.com/yuliangzhong/6dof_parafoil_simulation" in out and "licence" in out


@pytest.mark.skipif(not (SHARED / "eth-parafoil").is_dir(), reason="needs ../shared/data")
def test_fetched_and_converted_files_are_the_shared_ones(tmp_path, capsys):
    pytest.importorskip("pandas")
    fd = _script()
    names = ["eth-parafoil", "ssi-parafoil"]
    assert fd.main([*names, "--from", str(SHARED), "--dest", str(tmp_path)]) == 0
    for name in names:
        ds = fd.DATASETS[name]
        assert ds.made
        for rel in [f.dest for f in ds.files] + list(ds.made):
            got = (tmp_path / name / rel).read_bytes()
            assert got == (SHARED / name / rel).read_bytes(), f"{name}/{rel} differs"
    # a file that is not the one the source lists is refused, and not written
    bad = tmp_path / "bad"
    (bad / "eth-parafoil").mkdir(parents=True)
    for f in fd.DATASETS["eth-parafoil"].files:
        data = (SHARED / "eth-parafoil" / f.dest).read_bytes()
        if f.dest == "states2.mat":
            data = data[:-1] + bytes([data[-1] ^ 1])
        (bad / "eth-parafoil" / f.dest).write_bytes(data)
    capsys.readouterr()
    out = tmp_path / "out"
    assert fd.main(["eth-parafoil", "--from", str(bad), "--dest", str(out)]) == 2
    err = capsys.readouterr().err
    assert "states2.mat" in err and "is not the file the source lists" in err
    assert not (out / "eth-parafoil" / "states2.mat").exists()


@pytest.mark.parametrize(
    "example, needle, command",
    [
        ("eth_parafoil.py", "github.com/yuliangzhong/6dof_parafoil_simulation",
         "scripts/fetch_data.py eth-parafoil"),
        ("ssi_parafoil.py", "github.com/stanford-ssi/balloons-Parafoil",
         "scripts/fetch_data.py ssi-parafoil"),
        ("telemega_drogue.py", "github.com/RocketPy-Team/RocketPy",
         "scripts/fetch_data.py prometheus-2022"),
        ("descent_gallery.py", "github.com/RocketPy-Team/RocketPy",
         "scripts/fetch_data.py rocketpy-descents"),
    ],
)  # fmt: skip
def test_an_example_without_its_data_names_the_source_and_the_command(
    tmp_path, example, needle, command
):
    r = subprocess.run(
        [sys.executable, str(ROOT / "examples" / example), str(tmp_path / "nowhere")],
        capture_output=True, text=True, cwd=tmp_path, timeout=300,
    )  # fmt: skip
    assert r.returncode == 2, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:"), r.stderr
    assert needle in r.stderr and command in r.stderr
