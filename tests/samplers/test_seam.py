"""The sampler seam: every sampler runs through the one run loop and gets the same checks and
counts (input check, first look, retries, failures, the run report), and a new sampler is one
file and a registration."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from vectorid import Analysis, Study, load_study
from vectorid.errors import RunFailedError, StudyDefinitionError
from vectorid.run.repair import verify_store
from vectorid.sampler_kinds import register_sampler, sampler_names
from vectorid.samplers import sampler_for
from vectorid.store.inputs import InputsChangedError

ROOT = Path(__file__).resolve().parents[2]

MODEL = """
import numpy as np

CALLS = [0]
MODE = {mode!r}
SHIFT = {shift!r}


def evaluate(X):
    CALLS[0] += 1
    if MODE == "nan":
        return np.full((len(X), 2), np.nan), np.zeros((len(X), 1))
    if MODE == "flaky" and CALLS[0] == 1:
        raise ValueError("not warmed up yet")
    f1 = np.sum((X - 0.3) ** 2, axis=1) + SHIFT
    f2 = np.sum((X - 0.7) ** 2, axis=1)
    f = np.column_stack([f1, f2])
    if MODE == "some_fail":
        f[X[:, 0] > 0.9] = np.nan
    return f, (X[:, 0] + X[:, 1])[:, None]
"""

STUDY = """
[study]
name = "seam"
model = "seammodel:evaluate"
trials = {trials}
seed = 3
sampler = "{sampler}"
{extra}

[[variables]]
name = "x0"
low = 0.0
high = 1.0

[[variables]]
name = "x1"
low = 0.0
high = 1.0

[[variables]]
name = "x2"
low = 0.0
high = 1.0

[[criteria]]
name = "f1"
limit = 0.15

[[criteria]]
name = "f2"

[[constraints]]
name = "g"
high = 1.9
"""

SAMPLERS = ["sobol", "sequential", "random"]


@pytest.fixture(autouse=True, scope="module")
def random_sampler():
    """The plain random sampler of ``random_sampler.py``, registered as a plug-in would be."""
    register_sampler("random", "tests.samplers.random_sampler:RandomSampler")
    yield
    from vectorid import sampler_kinds

    sampler_kinds._KINDS.pop("random", None)


def write_study(folder: Path, sampler: str, mode: str = "ok", shift: float = 0.0) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "seammodel.py").write_text(MODEL.format(mode=mode, shift=shift))
    extra = "budget = 600\npopulation = 30" if sampler == "sequential" else ""
    path = folder / "seam.toml"
    path.write_text(STUDY.format(trials=64, sampler=sampler, extra=extra))
    return path


def run(study: Study, **kw):
    return study.run(executor="serial", batch_size=16, **kw)


@pytest.mark.parametrize("sampler", SAMPLERS)
def test_first_look_stops_a_study_whose_every_trial_fails(tmp_path, sampler):
    path = write_study(tmp_path / "s", sampler, mode="nan")
    with Study.create(load_study(path), tmp_path / "s.db") as st:
        with pytest.raises(RunFailedError, match=r"all \d+ trials of the first batch"):
            run(st)
        assert st.store.count() == 0
        assert st.store.sampler_record_count() <= 1  # at most the plan of generation 0


@pytest.mark.parametrize("sampler", SAMPLERS)
def test_changed_model_code_adds_no_trial(tmp_path, sampler):
    folder = tmp_path / "s"
    path = write_study(folder, sampler)
    db = tmp_path / "s.db"
    with Study.create(load_study(path), db) as st:
        run(st)
        held, runs = st.store.count(), len(st.store.runs())
        records = st.store.sampler_record_count()
    write_study(folder, sampler, shift=0.01)  # the model's code changed
    more = {"budget": 900, "population": 60} if sampler == "sequential" else {"trials": 128}
    with Study.open(db, write=True) as st:
        with pytest.raises(InputsChangedError, match=r"seammodel\.py: content changed"):
            run(st, **more)
        assert st.store.count() == held
        assert len(st.store.runs()) == runs  # a refused run leaves no record either
        assert st.store.sampler_record_count() == records
        assert st.spec.trials == 64 and st.spec.population in (None, 30)  # nothing saved


@pytest.mark.parametrize("sampler", SAMPLERS)
def test_retries_failures_and_the_run_report(tmp_path, sampler):
    path = write_study(tmp_path / "f", sampler, mode="flaky")
    with Study.create(load_study(path), tmp_path / "f.db") as st:
        s = run(st)
        assert s.model_errors and "raised ValueError: not warmed up yet" in s.model_errors[0]
        report = st.store.runs()[-1]["report"]
        assert report is not None and report["model_errors"] == s.model_errors
        assert report["stored"] == s.stored > 0
    path = write_study(tmp_path / "g", sampler, mode="some_fail")
    with Study.create(load_study(path), tmp_path / "g.db") as st:
        s = run(st)
        failed = int(np.sum(st.trials().status != 0))
        assert s.failed == failed > 0
        report = st.store.runs()[-1]["report"]
        assert report["failed"] == failed and report["failures"][0]["count"] == failed


@pytest.mark.parametrize("sampler", SAMPLERS)
def test_verify_counts_what_the_sampler_planned(tmp_path, sampler):
    path = write_study(tmp_path / "v", sampler)
    with Study.create(load_study(path), tmp_path / "v.db") as st:
        run(st)
        rep = verify_store(st.store)
        planned = sum(e - s for _, s, e in sampler_for(st.spec).planned(st.store))
        assert rep.sound and rep.planned == planned == st.store.count_sample() > 0


def test_a_new_sampler_is_one_file_and_a_registration(tmp_path):
    """``random_sampler.py`` and one ``register_sampler`` call: the study file, the run, the
    analysis, resuming, verify and the command line take ``sampler = "random"``."""
    assert "random" in sampler_names()
    path = write_study(tmp_path / "r", "random")
    db = tmp_path / "r.db"
    with Study.create(load_study(path), db) as st:
        run(st, trials=40)  # stops early: an interrupted run, as far as the plan is concerned
        run(st, trials=100)  # resumes and extends
        t = st.trials()
        a = st.analysis()
    assert sorted(t.seq.tolist()) == list(range(100))
    # the same points as one uninterrupted run
    with Study.create(load_study(path), tmp_path / "one.db") as st:
        run(st, trials=100)
        one = st.trials()
    order = np.argsort(t.seq)
    np.testing.assert_array_equal(t.X[order], one.X[np.argsort(one.seq)])
    assert isinstance(a, Analysis) and a.n == 100 and 0 < a.n_feasible < 100
    with pytest.raises(StudyDefinitionError, match="budget"):
        with Study.open(db, write=True) as st:
            st.run(budget=10)
    # the command line, in a process where the plug-in registered itself
    code = (
        "import sys; from vectorid.sampler_kinds import register_sampler; "
        "register_sampler('random', 'tests.samplers.random_sampler:RandomSampler'); "
        "from vectorid.cli import main; sys.exit(main(sys.argv[1:]))"
    )
    for verb in (["table", str(db), "--top", "3"], ["verify", str(db)], ["info", str(db)]):
        r = subprocess.run(
            [sys.executable, "-c", code, *verb], capture_output=True, text=True, cwd=ROOT,
            timeout=120,
        )  # fmt: skip
        assert r.returncode == 0, (verb, r.stdout, r.stderr)
    assert "sound" in subprocess.run(
        [sys.executable, "-c", code, "verify", str(db)], capture_output=True, text=True,
        cwd=ROOT, timeout=120,
    ).stdout  # fmt: skip
