"""The Dask executor beyond the shared suite: an external scheduler, the CLI, options, and
the install hint. (The shared suite is tests/run/test_executors.py; the faults are in
tests/run/test_faults.py.)"""

from __future__ import annotations

import importlib.util
import subprocess
import sys

import numpy as np
import pytest

from vectorid import Study, StudyDefinitionError, VectoridError, load_study
from vectorid.run.executors import executor_options, make_executor
from vectorid.spec import StudySpec

from ..conftest import write_user_study

needs_dask = pytest.mark.skipif(
    importlib.util.find_spec("distributed") is None,
    reason="dask.distributed not installed (pip install 'vectorid[dask]')",
)


@pytest.fixture(scope="module")
def cluster():
    """A running cluster the tests connect to by address, as a user would."""
    if importlib.util.find_spec("distributed") is None:
        pytest.skip("dask.distributed not installed")
    from distributed import LocalCluster

    with LocalCluster(
        n_workers=2, threads_per_worker=1, dashboard_address=None, silence_logs=40
    ) as c:
        yield c


@needs_dask
def test_external_scheduler_from_python_and_cli(tmp_path, cluster):
    study_file = write_user_study(tmp_path / "s", trials=64)
    spec = load_study(study_file)
    address = cluster.scheduler_address
    with Study.create(spec, tmp_path / "a.db") as a:
        with executor_options(scheduler=address):
            summary = a.run(executor="dask", batch_size=8)
        ta = a.trials()
    assert summary.stored == 64
    ref = spec.problem().evaluate(spec.space.scale(spec.point_sequence().points(0, 64)))
    np.testing.assert_array_equal(ta.status, ref.status)
    ok = ta.status == 0
    np.testing.assert_array_equal(ta.F[ok], ref.criteria[ok])
    # the command line: --scheduler alone implies --executor dask
    store = tmp_path / "cli.db"
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "vectorid.cli",
            "run",
            str(study_file),
            "--store",
            str(store),
            "--scheduler",
            address,
            "--quiet",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 0, r.stderr
    assert "64 trials computed" in r.stdout
    with Study.open(store) as st:
        runs = st.store.runs()
        tc = st.trials()
    assert runs[-1]["executor"] == "dask" and runs[-1]["workers"] == 2
    np.testing.assert_array_equal(np.nan_to_num(tc.F), np.nan_to_num(ta.F))


@needs_dask
def test_unreachable_scheduler_is_a_clear_error(user_study, monkeypatch):
    from vectorid.run.dask import DaskExecutor

    monkeypatch.setattr(DaskExecutor, "connect_timeout", 1.0)
    spec = load_study(user_study)
    with pytest.raises(StudyDefinitionError, match="cannot reach the Dask scheduler"):
        make_executor("dask", spec, scheduler="tcp://127.0.0.1:9")


def test_scheduler_needs_the_dask_executor(user_study):
    spec = load_study(user_study)
    with pytest.raises(StudyDefinitionError, match="applies to the dask executor"):
        make_executor("processes", spec, scheduler="tcp://127.0.0.1:8786")
    text = user_study.read_text().replace("batch = true", 'batch = true\nscheduler = "tcp://h:1"')
    user_study.write_text(text)
    assert load_study(user_study).executor == "dask"  # a scheduler implies dask
    user_study.write_text(text.replace("batch = true", 'batch = true\nexecutor = "processes"'))
    with pytest.raises(StudyDefinitionError, match="applies to executor 'dask'"):
        load_study(user_study)


def test_new_study_keys_round_trip(user_study):
    text = user_study.read_text().replace(
        "batch = true",
        'batch = true\ntimeout = 2.5\nexecutor = "dask"\nscheduler = "tcp://10.0.0.5:8786"',
    )
    user_study.write_text(text)
    spec = load_study(user_study)
    assert spec.timeout == 2.5 and spec.scheduler == "tcp://10.0.0.5:8786"
    again = StudySpec.from_dict(spec.to_dict(), base_dir=spec.base_dir)
    assert again == spec
    cmd = StudySpec.from_dict(
        {
            **spec.to_dict(),
            "study": {**spec.to_dict()["study"], "model": "cmd", "command": ["sim", "{input}"]},
        }
    )
    assert cmd.command == ("sim", "{input}")
    assert StudySpec.from_dict(cmd.to_dict()).command == ("sim", "{input}")
    with pytest.raises(StudyDefinitionError, match="study.timeout"):
        StudySpec.from_dict({**spec.to_dict(), "study": {**spec.to_dict()["study"], "timeout": 0}})


def test_timeout_option_overrides_the_study(user_study):
    spec = load_study(user_study)
    with executor_options(timeout=3.0):
        assert make_executor("serial", spec).timeout == 3.0
    assert make_executor("serial", spec).timeout is None
    with pytest.raises(StudyDefinitionError, match="positive number of seconds"):
        make_executor("processes", spec, timeout=-1)


def test_missing_dask_gives_the_install_hint(user_study, monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)  # import fails as if not installed
    spec = load_study(user_study)
    with pytest.raises(VectoridError, match=r"pip install 'vectorid\[dask\]'"):
        make_executor("dask", spec)
    import vectorid.run.executors  # the core never imports dask

    assert "distributed" not in vars(vectorid.run.executors)


PID_MODEL = """
import os

import numpy as np


def pids(X):
    # criteria: the process that evaluates and its parent
    return np.column_stack([X[:, 0], np.full(len(X), os.getpid()), np.full(len(X), os.getppid())])
"""


def _pid_spec(folder) -> StudySpec:
    from vectorid import Continuous, Criterion, Space

    folder.mkdir(parents=True, exist_ok=True)
    (folder / "pidmodel.py").write_text(PID_MODEL, encoding="utf-8")
    return StudySpec(
        name="pids",
        model="pidmodel:pids",
        space=Space([Continuous("x", 0.0, 1.0)]),
        criteria=(Criterion("xx"), Criterion("pid"), Criterion("ppid")),
        base_dir=str(folder),
    )


@needs_dask
@pytest.mark.parametrize("isolate", [True, False])
def test_model_runs_in_a_model_process_of_each_worker(tmp_path, isolate):
    """isolate=True: the model runs in one child process per worker (so pure-Python code does
    not share the worker's GIL), the same child for every batch; isolate=False: in the worker."""
    from vectorid.run.dask import DaskExecutor

    spec = _pid_spec(tmp_path / "m")
    X = spec.space.scale(spec.point_sequence().points(0, 64))
    with DaskExecutor(spec, workers=2, isolate=isolate) as ex:
        out = dict(ex.map_unordered((i, X[i * 4 : (i + 1) * 4]) for i in range(16)))
        workers = set(ex.worker_pids().values())
        counts = ex.build_counts()
    assert sorted(out) == list(range(16))
    pid = {int(v) for res in out.values() for v in res.criteria[:, 1]}
    ppid = {int(v) for res in out.values() for v in res.criteria[:, 2]}
    if isolate:
        assert not pid & workers and ppid <= workers, (pid, ppid, workers)
        assert len(pid) == len(ppid)  # one model process per worker (1 thread each)
    else:
        assert pid <= workers
    assert sum(n for per in counts.values() for n in per.values()) == len(pid)
