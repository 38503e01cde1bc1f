"""Fuzz table: command-line arguments. Each row is a verb with a bad argument or a bad place
to write; the answer is one ``error:`` line (or argparse's usage error) with exit 2, never a
traceback, and no half-written file left behind. Rows that must work check their result."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from vectorid import Study, load_study

from ..conftest import write_user_study
from ._harness import cli, expect, expect_error

KIND = "cli arguments"


@pytest.fixture(scope="module")
def ran(tmp_path_factory) -> tuple[Path, Path]:
    folder = tmp_path_factory.mktemp("cli")
    study = write_user_study(folder / "s", trials=256)
    store = folder / "u.db"
    with Study.create(load_study(study), store) as st:
        st.run(executor="serial")
    return study, store


def _rows(ran, tmp: Path):
    study, store = ran
    d = tmp
    return [
        # run
        (("run", study, "--trials", "0"), "expected a number >= 1"),
        (("run", study, "--trials", "-3"), "expected a number >= 1"),
        (("run", study, "--trials", "abc"), "expected a whole number"),
        (("run", study, "--trials", "1e3"), "expected a whole number"),
        (("run", study, "--workers", "0"), "expected a number >= 1"),
        (("run", study, "--workers", "x"), "expected a whole number"),
        (("run", study, "--workers", "100000", "--store", d / "w.db"), "more than this machine"),
        (("run", study, "--timeout", "0"), "positive number of seconds"),
        (("run", study, "--timeout", "-1"), "positive number of seconds"),
        (("run", study, "--timeout", "inf"), "positive number of seconds"),
        (("run", study, "--timeout", "nan"), "positive number of seconds"),
        (("run", study, "--timeout", "abc"), "number of seconds"),
        (("run", study, "--batch-size", "0"), "expected a number >= 1"),
        (("run", study, "--executor", "threads"), "invalid choice"),
        (("run", study, "--scheduler", "foo", "--store", d / "s1.db"), "HOST:PORT"),
        (("run", study, "--scheduler", "tcp://", "--store", d / "s2.db"), "HOST:PORT"),
        (("run", study, "--scheduler", "tcp://h:x", "--store", d / "s3.db"), "HOST:PORT"),
        (("run", study, "--scheduler", "tcp://h:0", "--store", d / "s4.db"), "HOST:PORT"),
        (
            ("run", study, "--scheduler", "tcp://h:1", "--executor", "serial", "--store", d / "a"),
            "applies to the dask executor",
        ),
        (("run", d / "nope.toml"), "not found"),
        (("run", d / "nope.db"), "no study store|not found"),
        (("run", d), "is a folder"),
        (("run", store, "--store", d / "x.db", "--trials", "0"), ">= 1"),
        # analysis verbs
        (("info", d / "none.db"), "no store"),
        (("info", study), "not a vectorid store|no store|SQLite"),
        (("table", store, "--limit", "f1<"), "cannot read"),
        (("table", store, "--limit", "f1<=abc"), "not a number"),
        (("table", store, "--limit", "f1=3"), "cannot read"),
        (("table", store, "--limit", "nosuch<=3"), "nosuch"),
        (("table", store, "--limit", "f1<=nan"), "NaN"),
        (("table", store, "--top", "0"), ">= 1"),
        (("table", store, "--role", "f1"), "NAME=pure"),
        (("table", store, "--role", "f1=primary"), "pure|pseudo"),
        (("pareto", store, "--limit", "x1<=3"), "x1"),
        (("export", store, "--format", "xml"), "invalid choice"),
        (("export", store, "--out", d), "directory|folder"),
        (("export", store, "--out", d / "no" / "such" / "dir.csv"), "No such file"),
        (("export", store, "--format", "parquet"), "needs a file"),
        (("report", store, "--out", d), "directory|folder"),
        (("hist", store, "--param", "nosuch", "--out", d / "h.html"), "nosuch"),
        (("plot", store, "--x", "f1", "--out", d / "p.html"), "--y"),
        (("plot", store, "--x", "f1", "--y", "zz", "--out", d / "p.html"), "zz"),
        (("section", store, "--trial", "999999", "--param", "x1"), "999999"),
        (("section", store, "--trial", "5", "--param", "zz"), "zz"),
        (("robustness", store, "--trial", "999999"), "999999"),
        (("correlation", store, "--threshold", "abc"), "invalid float"),
        (("refine", store, "--bound", "x1=2:1"), "x1"),
        (("verify", d / "none.db"), "no study store"),
        (("repair", d / "none.db"), "no study store"),
        (("init", "binh-korn", "--out", study), "exists already"),
        (("nosuchverb",), "invalid choice"),
        ((), "required|COMMAND"),
    ]


def test_bad_arguments_give_one_clear_line(ran, tmp_path):
    failures = []
    for argv, match in _rows(ran, tmp_path):
        r = cli(*argv)
        try:
            expect_error(KIND, r, match)
        except AssertionError as exc:
            failures.append(f"{argv}: {exc}")
    assert not failures, "\n".join(failures)


def test_no_partial_output_file_left(ran, tmp_path):
    study, store = ran
    for verb in (("export", store, "--format", "json"), ("report", store)):
        out = tmp_path / "ro" / "x.out"
        out.parent.mkdir(exist_ok=True)
        out.parent.chmod(0o555)
        try:
            if os.access(out.parent, os.W_OK):
                pytest.skip("running as a user that ignores permissions")
            r = cli(*verb, "--out", out)
            expect_error(KIND, r, "Permission denied|read-only|cannot")
            expect(KIND, not out.exists(), f"{out} left behind")
        finally:
            out.parent.chmod(0o755)


@pytest.mark.parametrize("verb", ["export", "report"])
def test_full_disk_leaves_no_partial_file(ran, tmpfs, verb):
    study, store = ran
    fs = tmpfs("16k")
    out = fs / "out.file"
    argv = (verb, store, "--out", out) + (("--format", "json") if verb == "export" else ())
    r = cli(*argv)
    expect_error(KIND, r, "No space left")
    expect(KIND, not out.exists(), f"{out} left behind")


@pytest.mark.parametrize("verb", ["export", "report"])
def test_read_only_folder_for_output(ran, tmpfs, verb):
    study, store = ran
    fs = tmpfs("1m", "ro", readonly=True)
    r = cli(verb, store, "--out", fs / "out.file")
    expect_error(KIND, r, "Read-only file system")


def test_new_store_on_a_read_only_filesystem(ran, tmpfs):
    study, store = ran
    fs = tmpfs("1m", "ro", readonly=True)
    r = cli("run", study, "--store", fs / "n.db", "--executor", "serial", "--quiet")
    expect_error(KIND, r, "cannot create store.*Read-only file system")


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="no /dev/full")
def test_export_to_a_full_device(ran):
    study, store = ran
    r = cli("export", store, "--out", "/dev/full")
    expect_error(KIND, r, "No space left")


def test_trials_below_what_is_stored_is_said(ran, tmp_path):
    study, store = ran
    copy = tmp_path / "c.db"
    copy.write_bytes(store.read_bytes())
    r = cli("run", copy, "--trials", "10", "--executor", "serial", "--quiet")
    said = "holds 256 trials, more than the 10 asked for" in r.out
    expect(KIND, r.code == 0 and said and "holds 256 of 256" in r.out, r.out + r.err, r)


def test_limit_on_a_criterion_named_with_spaces(tmp_path):
    study = write_user_study(tmp_path / "s", trials=64)
    text = study.read_text().replace('name = "f1"', 'name = "max speed"')
    study.write_text(text)
    store = tmp_path / "sp.db"
    assert cli("run", study, "--store", store, "--executor", "serial", "--quiet").code == 0
    r = cli("pareto", store, "--json", "--limit", "max speed <= 0.5")
    ok = r.code == 0 and "max speed <= 0.5" in json.loads(r.out)["constraints_in_force"]
    expect(KIND, ok, r.err, r)


def test_broken_pipe_is_quiet(ran):
    study, store = ran
    cmd = f"{sys.executable} -m vectorid.cli export {store} | head -1"
    r = subprocess.run(cmd, shell=True, capture_output=True, text=True, timeout=120)
    expect(KIND, "Traceback" not in r.stderr and r.stdout.startswith("id,"), r.stderr)


def test_interrupted_message_names_real_counts(tmp_path):
    """Ctrl-C in the middle of a run: exit 130, 'N new trials stored in this run; the study
    holds M of T' with M >= N (it was '250 new trials stored (0 in all)')."""
    import signal
    import time

    study = write_user_study(tmp_path / "s", trials=4000)
    store = tmp_path / "i.db"
    env = dict(os.environ, VECTORID_TEST_SLEEP="0.05")
    p = subprocess.Popen(
        [
            *(sys.executable, "-m", "vectorid.cli", "run", str(study), "--store", str(store)),
            *("--executor", "serial", "--batch-size", "8", "--quiet"),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        start_new_session=True,
    )
    time.sleep(6)
    os.killpg(p.pid, signal.SIGINT)
    out, err = p.communicate(timeout=120)
    import re

    m = re.search(r"interrupted: (\d+) new trials stored in this run; the study holds (\d+)", err)
    ok = p.returncode == 130 and m is not None and int(m.group(2)) >= int(m.group(1)) > 0
    expect(KIND, ok and "Traceback" not in err, err[-1500:])


@pytest.mark.slow
@pytest.mark.skipif(
    __import__("importlib").util.find_spec("distributed") is None,
    reason="dask.distributed not installed (pip install 'vectorid[dask]')",
)
def test_ctrl_c_with_dask_prints_no_worker_traceback(tmp_path):
    """Ctrl-C reaches every process of the terminal's group: the local cluster's workers
    ignore it (they printed 4 KeyboardInterrupt tracebacks) and the run exits 130."""
    import re
    import signal
    import time

    study = write_user_study(tmp_path / "s", trials=4000)
    store = tmp_path / "d.db"
    env = dict(os.environ, VECTORID_TEST_SLEEP="0.2")
    p = subprocess.Popen(
        [
            *(sys.executable, "-m", "vectorid.cli", "run", str(study), "--store", str(store)),
            *("--executor", "dask", "--workers", "2", "--batch-size", "8", "--quiet"),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        start_new_session=True,
    )
    deadline = time.time() + 180
    while time.time() < deadline:  # wait for the cluster to compute something
        time.sleep(1.0)
        if store.exists() and cli("info", store).out.find("trials     0 ") < 0:
            break
    os.killpg(p.pid, signal.SIGINT)
    out, err = p.communicate(timeout=180)
    ok = p.returncode == 130 and "Traceback" not in err
    ok = ok and re.search(r"interrupted: \d+ new trials stored in this run", err) is not None
    expect(KIND, ok, f"exit {p.returncode}: {err[-2000:]}")
