"""Interrupt real runs (kill -9, Ctrl-C) and resume: nothing lost, nothing repeated."""

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from vectorid import Study, load_study
from vectorid.store import Store

from ..conftest import write_user_study


def start_run(study_file, store, executor, sleep):
    env = dict(os.environ, VECTORID_TEST_SLEEP=str(sleep))
    return subprocess.Popen(
        [
            sys.executable,
            "-m",
            "vectorid.cli",
            "run",
            str(study_file),
            "--store",
            str(store),
            "--executor",
            executor,
            "--workers",
            "2",
            "--batch-size",
            "8",
            "--quiet",
        ],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )


def wait_for_trials(store, at_least, proc, timeout=60):
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        if store.exists():
            try:
                with Store.open(store) as st:
                    if st.count() >= at_least:
                        return st.count()
            except Exception:
                pass
        if proc.poll() is not None:
            raise AssertionError(f"run ended early: {proc.communicate()}")
        time.sleep(0.05)
    raise AssertionError("run made no progress")


def assert_same_as_uninterrupted(tmp_path, study_file, store):
    spec = load_study(study_file)
    with Study.create(spec, tmp_path / "reference.db") as ref:
        ref.run(executor="serial")
        tr = ref.trials()
    with Study.open(store) as st:
        t = st.trials()
        runs = st.store.runs()
    assert len(np.unique(t.seq)) == len(t.seq), "a trial was stored twice"
    np.testing.assert_array_equal(t.seq, tr.seq)
    np.testing.assert_array_equal(t.X, tr.X)
    np.testing.assert_array_equal(t.status, tr.status)
    np.testing.assert_array_equal(np.nan_to_num(t.F, nan=-7), np.nan_to_num(tr.F, nan=-7))
    assert t.messages == tr.messages
    return runs


@pytest.mark.parametrize("executor", ["serial", "processes"])
def test_kill_9_mid_run_then_resume(tmp_path, executor):
    study_file = write_user_study(tmp_path / "s", trials=160)
    store = tmp_path / "killed.db"
    proc = start_run(study_file, store, executor, sleep=0.2)
    try:
        seen = wait_for_trials(store, 24, proc)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10)
    finally:
        try:
            os.killpg(proc.pid, signal.SIGKILL)  # orphaned workers, if any
        except ProcessLookupError:
            pass
    with Store.open(store) as st:
        partial = st.count()
    assert seen <= partial < 160, "the run should have been killed mid-way"
    # resume: the same command, on the same store
    again = start_run(study_file, store, executor, sleep=0.0)
    out, err = again.communicate(timeout=120)
    assert again.returncode == 0, err
    assert f"{160 - partial} trials computed" in out
    runs = assert_same_as_uninterrupted(tmp_path, study_file, store)
    assert runs[0]["outcome"].startswith("died")
    assert runs[-1]["outcome"] == "completed"


def test_ctrl_c_stores_finished_batches_and_exits_130(tmp_path):
    study_file = write_user_study(tmp_path / "s", trials=160)
    store = tmp_path / "int.db"
    proc = start_run(study_file, store, "serial", sleep=0.2)
    wait_for_trials(store, 16, proc)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 130, (proc.returncode, out, err)
    assert "interrupted" in err and "run the same command again to resume" in err
    resumed = start_run(study_file, store, "serial", sleep=0.0)
    _, err2 = resumed.communicate(timeout=60)
    assert resumed.returncode == 0, err2
    runs = assert_same_as_uninterrupted(tmp_path, study_file, store)
    assert runs[0]["outcome"] == "interrupted"
