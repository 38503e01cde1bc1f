"""How workers start and end: forked where safe, spawned without re-running the caller's
script, bounded by what the machine holds, and gone when their parent is killed."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
import warnings
from pathlib import Path

import pytest

from vectorid import StudyDefinitionError, VectoridError, load_study
from vectorid.errors import VectoridWarning
from vectorid.run.executors import check_workers, make_executor, start_method, usable_cores

from ..conftest import write_user_study

ROOT = Path(__file__).parents[2]

SCRIPT = """
from vectorid import Study, load_study

with Study.create_or_open(load_study("user.toml"), "script.db") as study:
    s = study.run(trials={trials}, executor="processes", workers=2)
    print("computed", s.stored, "holds", s.total_stored)
"""

MAIN_MODEL_SCRIPT = """
import numpy as np
from vectorid import Criterion, Study, StudySpec
from vectorid.space import Continuous


def model(X):
    return np.column_stack([X[:, 0] ** 2, (X[:, 0] - 2) ** 2])


spec = StudySpec(
    name="main-model",
    model=model,
    space=[Continuous("x", 0.0, 3.0)],
    criteria=(Criterion("f1"), Criterion("f2")),
    trials=64,
)
with Study.create_or_open(spec, "main.db") as study:
    s = study.run(executor="processes", workers=2)
    a = study.analysis()
    print("stored", s.stored, "failed", s.failed, "pareto", a.n_pareto)
"""


def _python(code: str, cwd: Path, method: str | None) -> subprocess.CompletedProcess:
    env = dict(os.environ)
    env.pop("VECTORID_START_METHOD", None)
    if method:
        env["VECTORID_START_METHOD"] = method
    path = cwd / "script.py"
    path.write_text(textwrap.dedent(code))
    return subprocess.run(
        [sys.executable, str(path)], cwd=cwd, capture_output=True, text=True, env=env, timeout=300
    )


@pytest.mark.parametrize("method", [None, "spawn"])
def test_script_without_main_guard_runs_and_resumes(tmp_path, method):
    folder = tmp_path / "s"
    write_user_study(folder, trials=64)
    r = _python(SCRIPT.format(trials=64), folder, method)
    assert r.returncode == 0, r.stderr
    assert "computed 64 holds 64" in r.stdout and "Traceback" not in r.stderr
    r = _python(SCRIPT.format(trials=96), folder, method)  # the same script again: resumes
    assert r.returncode == 0, r.stderr
    assert "computed 32 holds 96" in r.stdout


@pytest.mark.parametrize("method", [None, "spawn"])
def test_model_defined_in_the_script_runs_in_worker_processes(tmp_path, method):
    r = _python(MAIN_MODEL_SCRIPT, tmp_path, method)
    assert r.returncode == 0, r.stderr
    assert "stored 64 failed 0" in r.stdout and "Traceback" not in r.stderr


def test_fork_only_when_no_other_thread_runs(monkeypatch):
    monkeypatch.delenv("VECTORID_START_METHOD", raising=False)
    if threading.active_count() > 1:
        pytest.skip("another thread already runs in this test process")
    parallel = sys.modules.get("numba.np.ufunc.parallel")
    if getattr(parallel, "_is_initialized", False):
        # an earlier test in this worker ran a compiled kernel in-process (the demos' stages
        # do): numba's threads run, which is the other rule
        assert start_method() == "spawn"
        pytest.skip("numba's threads already run in this test process")
    assert start_method() == "fork" if sys.platform.startswith("linux") else "spawn"
    stop = threading.Event()
    t = threading.Thread(target=stop.wait)
    t.start()
    try:
        assert start_method() == "spawn"
    finally:
        stop.set()
        t.join()
    monkeypatch.setenv("VECTORID_START_METHOD", "spawn")
    assert start_method() == "spawn"


def test_worker_counts_beyond_the_machine_are_refused_with_the_limit(user_study):
    spec = load_study(user_study)
    with pytest.raises(StudyDefinitionError, match=r"100000 worker processes .* at most \d+ \("):
        make_executor("processes", spec, workers=100000)
    with pytest.raises(StudyDefinitionError, match="at least 1 worker"):
        check_workers(0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_workers(usable_cores() + 1)
    assert any(
        issubclass(w.category, VectoridWarning) and "share the cores" in str(w.message)
        for w in caught
    )


def _children(pid: int) -> set[int]:
    out: set[int] = set()
    try:
        for task in os.listdir(f"/proc/{pid}/task"):
            with open(f"/proc/{pid}/task/{task}/children") as fh:
                out |= {int(c) for c in fh.read().split()}
    except OSError:
        pass
    return out


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().split()[2] != "Z"
    except OSError:
        return False


@pytest.mark.skipif(not Path("/proc/self/task").exists(), reason="needs /proc")
@pytest.mark.parametrize("executor", ["processes", "serial"])
def test_workers_die_with_their_parent(tmp_path, executor):
    study = write_user_study(tmp_path / "s", trials=100000)
    env = dict(os.environ, VECTORID_TEST_SLEEP="0.5")
    p = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "vectorid.cli",
            "run",
            str(study),
            "--store",
            str(tmp_path / "k.db"),
            "--executor",
            executor,
            "--workers",
            "2",
            "--batch-size",
            "4",
            "--quiet",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        start_new_session=True,
    )
    try:
        deadline = time.time() + 120
        workers: set[int] = set()
        while time.time() < deadline and not (tmp_path / "k.db").exists():
            time.sleep(0.2)
        while time.time() < deadline:
            workers = _children(p.pid)
            if len(workers) >= 1 and (tmp_path / "k.db").stat().st_size > 0:
                break
            time.sleep(0.2)
        time.sleep(2.0)  # workers busy in their batch
        workers = _children(p.pid)
        assert workers, "no worker started"
        os.kill(p.pid, signal.SIGKILL)
        p.wait(30)
        end = time.time() + 10
        while time.time() < end and any(_alive(w) for w in workers):
            time.sleep(0.1)
        assert not any(_alive(w) for w in workers), "workers outlived their parent"
        _, err = p.communicate(timeout=30)
        assert "Traceback" not in err and "BrokenPipeError" not in err, err
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)


def test_worker_start_errors_name_the_model(tmp_path):
    study = write_user_study(tmp_path / "s", trials=16)
    text = study.read_text().replace("usermodel:evaluate", "usermodel:nothere")
    study.write_text(text)
    spec = load_study(study)
    with make_executor("processes", spec, workers=2) as ex:
        with pytest.raises(VectoridError, match="has no attribute 'nothere'"):
            list(ex.map_unordered([(0, spec.space.scale(spec.point_sequence().points(0, 4)))]))


def test_planning_is_lazy_and_huge_targets_bounded(tmp_path):
    """1e12 trials: the plan yields batches one at a time (no list of 1e9 batches); Sobol
    refuses beyond its 2**30 points with the limit, Latin hypercubes run and store."""
    import itertools
    import tracemalloc

    from vectorid import Study
    from vectorid.run.loop import plan

    study = write_user_study(tmp_path / "s", trials=16)
    spec = load_study(study)
    with Study.create(spec, tmp_path / "p.db") as st:
        tracemalloc.start()
        first = list(itertools.islice(plan(st.store, 10**12, 1024), 3))
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        assert first == [(0, 0, 1024), (0, 1024, 1024), (0, 2048, 1024)]
        assert peak < 10 * 2**20
        with pytest.raises(StudyDefinitionError, match=r"at most 1073741823 .*sampler = \"lhs\""):
            st.run(trials=10**12, executor="serial")
        assert st.spec.trials == 16  # the refused target was not stored
    lhs = study.with_name("lhs.toml")
    lhs.write_text(study.read_text().replace("seed = 1", 'seed = 1\nsampler = "lhs"'))
    store = tmp_path / "l.db"
    env = dict(os.environ, VECTORID_TEST_SLEEP="0.02")
    p = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "vectorid.cli",
            "run",
            str(lhs),
            "--store",
            str(store),
            "--trials",
            str(10**12),
            "--executor",
            "serial",
            "--batch-size",
            "64",
            "--quiet",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        start_new_session=True,
    )
    try:
        deadline = time.time() + 120
        rss = 0
        while time.time() < deadline:
            time.sleep(1.0)
            with open(f"/proc/{p.pid}/statm") as fh:
                rss = int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
            if store.exists():
                from vectorid.store import Store

                with Store.open(store) as st:
                    if st.count() >= 512:
                        break
        assert rss < 1 << 30, f"{rss / 2**20:.0f} MiB"
    finally:
        os.killpg(p.pid, signal.SIGKILL)
        p.wait()
    from vectorid.store import Store

    with Store.open(store) as st:
        assert st.count() >= 512
