"""Fault tolerance, done for real: kill -9 runners and workers, hang, crash and leak in the
model, fill the disk, make the store read-only, feed foreign and truncated files, race two
runners. Each test compares what was stored with an uninterrupted reference run."""

from __future__ import annotations

import importlib.util
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from vectorid import StoreError, Study, StudyDefinitionError, load_study
from vectorid.problem import FAILED, OK
from vectorid.store import Store

from ..conftest import write_user_study
from .test_resume import assert_same_as_uninterrupted, start_run, wait_for_trials

HAVE_DASK = importlib.util.find_spec("distributed") is not None
needs_dask = pytest.mark.skipif(
    not HAVE_DASK, reason="dask.distributed not installed (pip install 'vectorid[dask]')"
)
#: The Dask variants take 10-30 s each (cluster start, worker restarts): run with -m slow.
slow_dask = [needs_dask, pytest.mark.slow]

# Two trials of the user study (sequence indices 26 and 35) misbehave. The rest of each
# batch is the user model of conftest, so innocent neighbours must come out exactly as in a
# run without faults.
FAULT_MODEL = """
import ctypes
import os
import time

import numpy as np

from usermodel import evaluate

A, B = 0.40625, 0.421875  # x1 of trials 27 and 36 (sequence 26 and 35)


def _has(X, v):
    return bool(np.any(np.abs(X[:, 0] - v) < 1e-12))


def hang(X):
    if _has(X, A):
        time.sleep(600)               # stuck in Python
    if _has(X, B):
        ctypes.CDLL(None).pause()     # stuck in C, waiting for a signal that never comes
    return evaluate(X)


def hang_python(X):
    if _has(X, A):
        time.sleep(600)
    return evaluate(X)


def crash(X):
    if _has(X, A):
        os._exit(7)                   # the interpreter exits
    if _has(X, B):
        ctypes.string_at(0)           # segmentation fault
    return evaluate(X)


_LEAK = []


def leak(X):
    if _has(X, A):
        while True:                   # 16 MB every 20 ms until someone stops it
            _LEAK.append(np.ones(2_000_000))
            time.sleep(0.02)
    return evaluate(X)
"""

FAULTY_SEQ = {"hang": (26, 35), "hang_python": (26,), "crash": (26, 35), "leak": (26,)}


def fault_study(folder: Path, func: str, trials: int = 48, timeout: float | None = None) -> Path:
    path = write_user_study(folder, trials=trials)
    (folder / "faultmodel.py").write_text(textwrap.dedent(FAULT_MODEL), encoding="utf-8")
    text = path.read_text().replace('model = "usermodel:evaluate"', f'model = "faultmodel:{func}"')
    if timeout is not None:
        text = text.replace("batch = true", f"batch = true\ntimeout = {timeout}")
    fault = folder / f"{func}.toml"
    fault.write_text(text, encoding="utf-8")
    return fault


def check_against_reference(t, study_file: Path, faulty: tuple[int, ...], reason: str) -> None:
    """Faulty trials failed with ``reason``; every other trial as in a run without faults."""
    spec = load_study(study_file)
    X = spec.space.scale(spec.point_sequence().points(0, spec.trials))
    ref = load_study(Path(study_file).with_name("user.toml")).problem().evaluate(X)
    assert len(t) == spec.trials and len(np.unique(t.seq)) == len(t.seq)
    np.testing.assert_array_equal(t.X, X)
    innocent = np.ones(len(t), bool)
    innocent[list(faulty)] = False
    for s in faulty:
        assert t.status[s] == FAILED, f"trial {s + 1} should have failed"
        assert reason in t.message(s), t.message(s)
    wrong = np.flatnonzero(innocent & (t.status != ref.status))
    assert not len(wrong), [(int(s), t.message(s), ref.messages.get(int(s))) for s in wrong]
    ok = innocent & (t.status == OK)
    np.testing.assert_array_equal(t.F[ok], ref.criteria[ok])
    np.testing.assert_array_equal(t.G[ok], ref.functionals[ok])


# -- the runner killed with kill -9, again and again -----------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize("executor", ["processes", pytest.param("dask", marks=needs_dask)])
def test_runner_killed_repeatedly_at_random_points_then_resumed(tmp_path, executor):
    rng = np.random.default_rng(20240607)
    study_file = write_user_study(tmp_path / "s", trials=480)
    store = tmp_path / "killed.db"
    kills = 3 if executor == "processes" else 2
    counts = []
    for _ in range(kills):
        proc = start_run(study_file, store, executor, sleep=0.1)
        try:
            before = 0
            if store.exists():
                with Store.open(store) as st:
                    before = st.count()
            # some progress, then a random moment (seeded) before the kill
            wait_for_trials(store, before + 8, proc, timeout=90)
            time.sleep(float(rng.uniform(0.0, 0.4)))
            os.kill(proc.pid, signal.SIGKILL)
            proc.wait(timeout=10)
        finally:
            try:
                os.killpg(proc.pid, signal.SIGKILL)  # orphaned workers, if any
            except ProcessLookupError:
                pass
        with Store.open(store) as st:
            counts.append(st.count())
    assert counts == sorted(counts) and counts[-1] < 480, counts
    final = start_run(study_file, store, executor, sleep=0.0)
    out, err = final.communicate(timeout=180)
    assert final.returncode == 0, err
    assert f"{480 - counts[-1]} trials computed" in out
    runs = assert_same_as_uninterrupted(tmp_path, study_file, store)
    assert [r["outcome"] for r in runs] == ["died (killed or crashed)"] * kills + ["completed"]


# -- a Dask worker killed mid-run ----------------------------------------------------------


def _spawned_children() -> list:
    import psutil

    out = []
    for child in psutil.Process().children(recursive=False):
        try:
            if "spawn_main" in " ".join(child.cmdline()):
                out.append(child)
        except psutil.Error:
            pass
    return out


@pytest.mark.slow
@needs_dask
def test_dask_worker_killed_mid_run_gives_identical_results(tmp_path, monkeypatch):
    monkeypatch.setenv("VECTORID_TEST_SLEEP", "0.25")  # inherited by the cluster's workers
    study_file = write_user_study(tmp_path / "s", trials=96)
    spec = load_study(study_file)
    killed: list[int] = []
    others = {p.pid for p in _spawned_children()}  # not ours to kill

    def killer(path: Path) -> None:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not killed:
            try:
                with Store.open(path) as st:
                    n = st.count()
            except StoreError:
                n = 0
            workers = [p for p in _spawned_children() if p.pid not in others]
            if n >= 16 and workers:
                killed.append(workers[0].pid)
                os.kill(workers[0].pid, signal.SIGKILL)
            time.sleep(0.02)

    with Study.create(spec, tmp_path / "d.db") as study:
        watcher = threading.Thread(target=killer, args=(tmp_path / "d.db",), daemon=True)
        watcher.start()
        summary = study.run(executor="dask", workers=2, batch_size=8)
        watcher.join(5)
        t = study.trials()
    assert killed, "no worker was killed: the test did not test anything"
    assert summary.stored == 96
    monkeypatch.setenv("VECTORID_TEST_SLEEP", "0")
    with Study.create(spec, tmp_path / "ref.db") as ref:
        ref.run(executor="serial")
        tr = ref.trials()
    np.testing.assert_array_equal(t.status, tr.status)
    np.testing.assert_array_equal(np.nan_to_num(t.F, nan=-3), np.nan_to_num(tr.F, nan=-3))
    np.testing.assert_array_equal(np.nan_to_num(t.G, nan=-3), np.nan_to_num(tr.G, nan=-3))
    assert t.messages == tr.messages


@needs_dask
def test_dask_builds_the_model_once_per_worker(user_study):
    from vectorid.run.dask import DaskExecutor

    spec = load_study(user_study)
    X = spec.space.scale(spec.point_sequence().points(0, 96))
    with DaskExecutor(spec, workers=2) as ex:
        out = dict(ex.map_unordered((i, X[i * 4 : (i + 1) * 4]) for i in range(24)))
        counts = ex.build_counts()
    assert sorted(out) == list(range(24))
    assert len(counts) == 2
    for per_study in counts.values():
        assert list(per_study.values()) in ([1], [])  # built once, or never used


# -- models that hang, crash or leak -------------------------------------------------------


def _dask_options(monkeypatch, **options) -> None:
    """Make ``study.run(executor="dask")`` build its executor with ``options``."""
    from vectorid.run.dask import DaskExecutor

    original = DaskExecutor.__init__

    def init(self, *a, **kw):
        original(self, *a, **{**kw, **options})

    monkeypatch.setattr(DaskExecutor, "__init__", init)


@pytest.mark.parametrize(
    "executor, func, isolate",
    [
        ("processes", "hang", None),
        pytest.param("dask", "hang", True, marks=slow_dask),
        # without model processes the worker's watchdog thread gives up and the worker is
        # restarted through its nanny (a model stuck in Python only: see vectorid.run.dask)
        pytest.param("dask", "hang_python", False, marks=slow_dask),
    ],
)
def test_hanging_model_times_out_and_the_study_goes_on(
    tmp_path, monkeypatch, executor, func, isolate
):
    study_file = fault_study(tmp_path / "s", func, timeout=0.3)
    spec = load_study(study_file)
    if isolate is not None:
        _dask_options(monkeypatch, isolate=isolate)
    with Study.create(spec, tmp_path / "h.db") as study:
        summary = study.run(executor=executor, workers=2, batch_size=8)
        t = study.trials()
    check_against_reference(t, study_file, FAULTY_SEQ[func], "timed out")
    assert summary.stored == 48


@pytest.mark.parametrize(
    "executor, func, isolate",
    [
        ("processes", "crash", None),
        pytest.param("dask", "crash", True, marks=slow_dask),
        pytest.param("dask", "leak", True, marks=slow_dask),
        # without model processes the model kills the Dask worker itself (KilledWorker)
        pytest.param("dask", "crash", False, marks=slow_dask),
    ],
)
def test_model_crashing_or_leaking_its_worker_fails_only_its_trial(
    tmp_path, monkeypatch, executor, func, isolate
):
    study_file = fault_study(tmp_path / "s", func)
    spec = load_study(study_file)
    if executor == "dask":
        # a worker's model process is stopped when it grows past this (the leak test)
        _dask_options(monkeypatch, isolate=isolate, cluster_kwargs={"memory_limit": "600MiB"})
    with Study.create(spec, tmp_path / "c.db") as study:
        summary = study.run(executor=executor, workers=2, batch_size=8)
        t = study.trials()
    reason = "more than the memory limit of 600 MiB" if func == "leak" else "worker process died"
    check_against_reference(t, study_file, FAULTY_SEQ[func], reason)
    assert summary.stored == 48


def test_process_executor_memory_limit_fails_only_the_leaking_trial(tmp_path):
    from vectorid.run.executors import ProcessExecutor

    study_file = fault_study(tmp_path / "s", "leak")
    spec = load_study(study_file)
    X = spec.space.scale(spec.point_sequence().points(0, 48))
    with ProcessExecutor(spec, workers=2, memory_limit=400 * 2**20) as ex:
        out = dict(ex.map_unordered((s, X[s : s + 8]) for s in range(0, 48, 8)))
    direct = load_study(study_file.with_name("user.toml")).problem().evaluate(X)
    for start, res in out.items():
        for r in range(8):
            if start + r == FAULTY_SEQ["leak"][0]:
                assert res.status[r] == FAILED
                assert "more than the memory limit of 400 MiB" in res.messages[r]
            else:
                assert res.status[r] == direct.status[start + r]
                np.testing.assert_array_equal(res.criteria[r], direct.criteria[start + r])


def test_process_executor_refuses_a_bad_memory_limit(user_study):
    from vectorid.run.executors import ProcessExecutor

    with pytest.raises(StudyDefinitionError, match="positive number of bytes"):
        ProcessExecutor(load_study(user_study), memory_limit=-5)


def test_process_executor_keeps_innocent_batches_when_a_worker_dies(user_study, tmp_path):
    """Direct check of the executor: only the dead worker's batch is re-run."""
    from vectorid.run.executors import ProcessExecutor

    study_file = fault_study(tmp_path / "s", "crash")
    spec = load_study(study_file)
    X = spec.space.scale(spec.point_sequence().points(0, 48))
    with ProcessExecutor(spec, workers=2) as ex:
        out = dict(ex.map_unordered((s, X[s : s + 8]) for s in range(0, 48, 8)))
    assert sorted(out) == list(range(0, 48, 8))
    direct = load_study(study_file.with_name("user.toml")).problem().evaluate(X)
    for start, res in out.items():
        rows = np.arange(start, start + 8)
        bad = np.isin(rows, FAULTY_SEQ["crash"])
        assert (res.status[bad] == FAILED).all()
        np.testing.assert_array_equal(res.status[~bad], direct.status[rows[~bad]])
        for i in np.flatnonzero(bad):
            assert res.messages[i].startswith("worker process died")


# -- the store: full disk, read-only, foreign and truncated files, two runners ---------------


@pytest.fixture
def tmpfs(tmp_path):
    """Mount small tmpfs filesystems (root only; skipped elsewhere)."""
    mounts: list[Path] = []

    def make(size: str, name: str = "fs") -> Path:
        if os.geteuid() != 0 or shutil.which("mount") is None:
            pytest.skip("needs root and mount(8) to make a small or read-only filesystem")
        d = tmp_path / name
        d.mkdir()
        r = subprocess.run(
            ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(d)],
            capture_output=True,
            text=True,
        )
        if r.returncode != 0:
            pytest.skip(f"cannot mount a tmpfs here: {r.stderr.strip()}")
        mounts.append(d)
        return d

    yield make
    for d in reversed(mounts):
        subprocess.run(["umount", "-l", str(d)], capture_output=True)


def remount(path: Path, options: str) -> None:
    subprocess.run(["mount", "-o", f"remount,{options}", str(path)], check=True)


def test_full_disk_stops_with_clear_error_and_loses_nothing(tmp_path, tmpfs):
    # the store ends at 832 KiB (ten 64-KiB pages of tables before any trial) and its log,
    # folded in as it goes, holds up to half the store more: a 1.25 MiB disk fills mid-run
    fs = tmpfs("1280k")
    study_file = write_user_study(tmp_path / "s", trials=2000)
    spec = load_study(study_file)
    store = fs / "full.db"
    with Study.create(spec, store) as study:
        with pytest.raises(StoreError, match="nothing already stored was lost"):
            study.run(executor="serial", batch_size=8)
    with Store.open(store) as st:  # everything stored before the disk filled is there
        stored = st.load()
    assert 0 < len(stored) < 2000
    remount(fs, "size=64m")
    with Study.open(store, write=True) as study:
        study.run(executor="serial", batch_size=8)
        t = study.trials()
    assert len(t) == 2000 and len(np.unique(t.seq)) == 2000
    keep = np.isin(t.seq, stored.seq)
    np.testing.assert_array_equal(t.X[keep], stored.X)
    np.testing.assert_array_equal(np.nan_to_num(t.F[keep]), np.nan_to_num(stored.F))
    X = spec.space.scale(spec.point_sequence().points(0, 2000))
    ref = spec.problem().evaluate(X)
    np.testing.assert_array_equal(t.status, ref.status)
    np.testing.assert_array_equal(np.nan_to_num(t.F, nan=-1), np.nan_to_num(ref.criteria, nan=-1))


def _read_only_store(tmp_path, tmpfs) -> tuple[Path, Path, object]:
    fs = tmpfs("8m", "ro")
    spec = load_study(write_user_study(tmp_path / "s", trials=32))
    store = fs / "s.db"
    with Study.create(spec, store) as study:
        study.run(executor="serial")
        before = study.trials()
    remount(fs, "ro")
    return fs, store, before


def test_read_only_store_refuses_writes_with_clear_error(tmp_path, tmpfs):
    fs, store, before = _read_only_store(tmp_path, tmpfs)
    with pytest.raises(StoreError, match="read-only"):
        Store.open(store, write=True)
    r = subprocess.run(
        [sys.executable, "-m", "vectorid.cli", "run", str(store), "--trials", "64", "--quiet"],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 2 and "read-only" in r.stderr and "Traceback" not in r.stderr
    remount(fs, "rw")
    with Study.open(store) as study:  # nothing lost
        t = study.trials()
    np.testing.assert_array_equal(t.X, before.X)
    np.testing.assert_array_equal(np.nan_to_num(t.F), np.nan_to_num(before.F))


def test_read_only_store_can_still_be_analysed(tmp_path, tmpfs):
    """A store on a read-only filesystem (no -shm file can be made) still opens for reading."""
    fs, store, before = _read_only_store(tmp_path, tmpfs)
    with Study.open(store) as study:
        t = study.trials()
    np.testing.assert_array_equal(t.X, before.X)


def _cli_run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "vectorid.cli", "run", *args, "--quiet"],
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_foreign_and_truncated_files_are_refused_and_left_untouched(tmp_path):
    import sqlite3

    foreign = tmp_path / "foreign.db"
    con = sqlite3.connect(foreign)
    con.execute("create table t(x)")
    con.execute("insert into t values (42)")
    con.commit()
    con.close()
    study_file = write_user_study(tmp_path / "s", trials=64)
    data = foreign.read_bytes()
    for args in ([str(foreign)], [str(study_file), "--store", str(foreign)]):
        r = _cli_run(*args)
        assert r.returncode == 2, r.stderr
        assert "not a vectorid store" in r.stderr and "Traceback" not in r.stderr
        assert foreign.read_bytes() == data
    # a real store, cut in half
    good = tmp_path / "good.db"
    assert _cli_run(str(study_file), "--store", str(good), "--executor", "serial").returncode == 0
    con = sqlite3.connect(good)
    con.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    con.close()
    cut = tmp_path / "cut.db"
    cut.write_bytes(good.read_bytes()[: good.stat().st_size // 2])
    data = cut.read_bytes()
    r = _cli_run(str(cut), "--executor", "serial")
    assert r.returncode == 2, (r.returncode, r.stderr)
    assert "Traceback" not in r.stderr and "error:" in r.stderr
    assert cut.read_bytes() == data


def test_two_runners_on_one_store(tmp_path):
    study_file = write_user_study(tmp_path / "s", trials=160)
    store = tmp_path / "two.db"
    first = start_run(study_file, store, "serial", sleep=0.05)
    try:
        wait_for_trials(store, 8, first)
        second = start_run(study_file, store, "serial", sleep=0.0)
        out, err = second.communicate(timeout=60)
        assert second.returncode == 3, err
        assert "being written by another process (pid" in err
        out, err = first.communicate(timeout=120)
        assert first.returncode == 0, err
    finally:
        if first.poll() is None:
            os.killpg(first.pid, signal.SIGKILL)
    assert_same_as_uninterrupted(tmp_path, study_file, store)
