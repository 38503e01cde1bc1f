"""The suite every executor must pass (serial, processes, and dask when installed)."""

import importlib.util

import numpy as np
import pytest

from vectorid import Study, load_study
from vectorid.problem import FAILED, OK
from vectorid.run import EXECUTORS, make_executor

from ..conftest import write_user_study

EXECUTOR_NAMES = [
    name
    if name != "dask" or importlib.util.find_spec("distributed") is not None
    else pytest.param(
        name,
        marks=pytest.mark.skip(
            reason="dask.distributed not installed (pip install 'vectorid[dask]')"
        ),
    )
    for name in sorted(EXECUTORS)
]


def reference(spec, n):
    """The trials computed directly, without executor or store."""
    sampler = spec.point_sequence()
    X = spec.space.scale(sampler.points(0, n))
    return X, spec.problem().evaluate(X)


@pytest.mark.parametrize("name", EXECUTOR_NAMES)
def test_map_unordered_returns_every_batch_once(name, user_study):
    spec = load_study(user_study)
    X = spec.space.scale(spec.point_sequence().points(0, 64))
    batches = [(i, X[i * 8 : (i + 1) * 8]) for i in range(8)]
    with make_executor(name, spec, workers=2) as ex:
        out = dict(ex.map_unordered(batches))
    assert sorted(out) == list(range(8))
    direct = spec.problem().evaluate(X)
    got = np.vstack([out[i].criteria for i in range(8)])
    np.testing.assert_array_equal(np.isnan(got), np.isnan(direct.criteria))
    np.testing.assert_array_equal(got[~np.isnan(got)], direct.criteria[~np.isnan(got)])


@pytest.mark.parametrize("name", EXECUTOR_NAMES)
@pytest.mark.parametrize("batch", [True, False])
def test_study_through_executor_matches_direct_evaluation(name, batch, tmp_path):
    spec = load_study(write_user_study(tmp_path / "s", trials=200, batch=batch))
    with Study.create(spec, tmp_path / "s.db") as study:
        summary = study.run(executor=name, workers=2, batch_size=16)
        t = study.trials()
    X, ref = reference(spec, 200)
    assert summary.stored == 200 and summary.total_stored == 200
    np.testing.assert_array_equal(t.X, X)
    np.testing.assert_array_equal(t.status, ref.status)
    ok = t.status == OK
    np.testing.assert_array_equal(t.F[ok], ref.criteria[ok])
    np.testing.assert_array_equal(t.G[ok], ref.functionals[ok])
    # failures are stored with their reasons and the run went on
    failed = np.flatnonzero(t.status == FAILED)
    assert len(failed) > 0 and ok.sum() > 0
    assert summary.failed == len(failed)
    for i in failed:
        msg = t.message(i)
        if t.X[i, 0] > 0.9:
            assert msg.startswith("RuntimeError: x1 above 0.9")
        else:
            assert "non-finite result: f2=nan" in msg
    text = summary.describe()
    assert "failed" in text and "RuntimeError" in text


@pytest.mark.parametrize(
    "name",
    [pytest.param(n, marks=pytest.mark.slow) if n == "dask" else n for n in EXECUTOR_NAMES],
)
def test_continuation_equals_one_long_run(name, tmp_path):
    spec = load_study(write_user_study(tmp_path / "s", trials=96))
    with Study.create(spec, tmp_path / "a.db") as a:
        a.run(trials=48, executor=name, workers=2, batch_size=7)
        a.run(trials=96, executor=name, workers=2, batch_size=13)
        ta = a.trials()
    with Study.create(spec, tmp_path / "b.db") as b:
        b.run(executor=name, workers=2, batch_size=32)
        tb = b.trials()
    for field in ("id", "seq", "stage", "status"):
        np.testing.assert_array_equal(getattr(ta, field), getattr(tb, field))
    np.testing.assert_array_equal(ta.X, tb.X)
    np.testing.assert_array_equal(np.nan_to_num(ta.F, nan=-1), np.nan_to_num(tb.F, nan=-1))
    assert ta.messages == tb.messages


def test_second_run_with_same_target_computes_nothing(tmp_path):
    spec = load_study(write_user_study(tmp_path / "s", trials=40))
    with Study.create(spec, tmp_path / "a.db") as a:
        assert a.run(executor="serial").stored == 40
        again = a.run(executor="serial")
        assert again.stored == 0 and again.total_stored == 40


def test_new_stage_keeps_drawing_from_the_sequence(tmp_path):
    spec = load_study(write_user_study(tmp_path / "s", trials=64))
    with Study.create(spec, tmp_path / "a.db") as a:
        a.run(executor="serial")
        narrow = spec.space.with_bounds({"x1": (0.1, 0.3)})
        a.store.add_stage(narrow, note="double tuning")
        a.run(trials=128, executor="serial")
        t = a.trials()
    assert (t.stage[:64] == 0).all() and (t.stage[64:] == 1).all()
    np.testing.assert_array_equal(t.seq, np.arange(128))
    unit = spec.point_sequence().points(64, 64)
    np.testing.assert_allclose(t.X[64:], narrow.scale(unit))
    assert (t.X[64:, 0] >= 0.1).all() and (t.X[64:, 0] <= 0.3).all()


def test_unknown_executor_and_bad_workers(user_study):
    from vectorid import StudyDefinitionError

    spec = load_study(user_study)
    with pytest.raises(StudyDefinitionError, match="unknown executor"):
        make_executor("threads", spec)
    with pytest.raises(StudyDefinitionError, match="at least 1 worker"):
        make_executor("processes", spec, workers=0)
