"""The study file and its store agree, or the user is told: every difference listed, the
harmless ones taken, the trial-changing ones refused with the commands, empty stores
re-created."""

from __future__ import annotations

import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

from vectorid import StoreError, Study, load_study
from vectorid.builders import register_problem_builder
from vectorid.errors import VectoridNote
from vectorid.problem import Problem
from vectorid.store import Store
from vectorid.store.agreement import compare

from ..conftest import write_user_study


@pytest.fixture
def ran(tmp_path):
    study = write_user_study(tmp_path / "s", trials=64)
    store = tmp_path / "a.db"
    with Study.create(load_study(study), store) as st:
        st.run(executor="serial")
    return study, store


def edited(study: Path, old: str, new: str, name: str = "edited.toml") -> Path:
    text = study.read_text()
    assert old in text, old
    out = study.with_name(name)
    out.write_text(text.replace(old, new, 1))
    return out


def open_again(study: Path, store: Path) -> list[str]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        Study.create_or_open(load_study(study), store, study_file=study).close()
    return [str(w.message) for w in caught if issubclass(w.category, VectoridNote)]


TAKEN = [
    ("limit = 1.0", "limit = 0.5", "criteria.f2.limit: 1.0 (store) -> 0.5 (file)"),
    ("high = 1.5", "high = 1.2", "constraints.g.high: 1.5 (store) -> 1.2 (file)"),
    ('name = "user"', 'name = "renamed"', "study.name"),
    ("seed = 1", "seed = 7", "an unscrambled Sobol sequence does not use it"),
    ("trials = 64", "trials = 96", "study.trials: 64 (store) -> 96 (file)"),
    ('sense = "min"\n\n[[criteria]]', 'sense = "max"\n\n[[criteria]]', "criteria.f1.sense"),
]


@pytest.mark.parametrize(("old", "new", "said"), TAKEN, ids=[t[2][:30] for t in TAKEN])
def test_harmless_changes_are_taken_and_said(ran, old, new, said):
    study, store = ran
    path = edited(study, old, new)
    notes = open_again(path, store)
    assert any("taken from the study file" in n and said in n for n in notes), notes
    with Store.open(store) as st:  # stored, and the trials untouched
        assert compare(st.spec, load_study(path)).differences == []
        assert st.count() == 64


REFUSED = [
    ("high = 1.0", "high = 2.0", "variables.x1.high: 1.0 (store) -> 2.0 (file)"),
    ('model = "usermodel:evaluate"', 'model = "usermodel:one"', "study.model"),
    ("seed = 1", 'seed = 1\nsampler = "lhs"', "study.sampler"),
    ("seed = 1", "seed = 1\nscramble = true", "study.scramble"),
    ('name = "f2"', 'name = "f3"', "criteria: 'f1, f2' (store) -> 'f1, f3' (file)"),
    ('name = "g"', 'name = "h"', "constraints: 'g' (store) -> 'h' (file)"),
    ("batch = true", "batch = false", "study.batch"),
]


@pytest.mark.parametrize(("old", "new", "said"), REFUSED, ids=[t[2][:30] for t in REFUSED])
def test_trial_changing_edits_are_refused_with_the_commands(ran, old, new, said):
    study, store = ran
    path = edited(study, old, new)
    with pytest.raises(StoreError) as err:
        open_again(path, store)
    text = str(err.value)
    assert said in text and "64 trials computed" in text
    assert f"vectorid run {path} --store {store.with_name('a-2.db')}" in text
    assert f"vectorid run {store}" in text
    with Store.open(store) as st:  # nothing changed
        assert st.spec == load_study(study)


def test_scrambled_seed_change_is_refused(tmp_path):
    study = edited(
        write_user_study(tmp_path / "s", trials=16), "seed = 1", "seed = 1\nscramble = true"
    )
    store = tmp_path / "b.db"
    with Study.create(load_study(study), store) as st:
        st.run(executor="serial")
    with pytest.raises(StoreError, match="study.seed"):
        open_again(edited(study, "seed = 1", "seed = 2", "e2.toml"), store)


def test_store_without_trials_is_recreated_from_the_fixed_file(tmp_path):
    study = write_user_study(tmp_path / "s", trials=16)
    broken = edited(study, 'model = "usermodel:evaluate"', 'model = "usermodel:evaluat"')
    store = tmp_path / "c.db"
    Study.create(load_study(broken), store).close()  # a first run that failed before a trial
    notes = open_again(study, store)
    assert any("held no computed trial; re-created" in n and "study.model" in n for n in notes)
    with Study.open(store, write=True) as st:
        assert st.spec.model == "usermodel:evaluate"
        assert st.run(executor="serial").stored == 16


def _coef_files(spec):
    return {"campaign-coef.file": Path(spec.base_dir) / spec.extra["campaign-coef"]["file"]}


def _coef_problem(spec):
    a = float(_coef_files(spec)["campaign-coef.file"].read_text())

    def model(X):
        return X[:, :2] * a, X[:, :1]

    return Problem(model, spec.criteria, spec.constraints)


def test_data_file_moved_with_the_same_content_is_taken_edited_is_refused(tmp_path):
    """A builder that names its data file: a copy elsewhere is taken, an edit is refused."""
    register_problem_builder("campaign-coef", _coef_problem, table=True, data_files=_coef_files)
    folder = tmp_path / "s"
    study = write_user_study(folder, trials=16)
    (folder / "coef.txt").write_text("2.0")
    path = folder / "c.toml"
    path.write_text(study.read_text() + '\n[campaign-coef]\nfile = "coef.txt"\n')
    store = tmp_path / "d.db"
    with Study.create(load_study(path), store) as st:
        st.run(executor="serial")
        before = st.trials()
    shutil.copy(folder / "coef.txt", folder / "moved.txt")
    moved = edited(path, 'file = "coef.txt"', 'file = "moved.txt"', "m.toml")
    notes = open_again(moved, store)
    assert any("campaign-coef.file" in n and "the same file content" in n for n in notes)
    (folder / "moved.txt").write_text("3.0")  # edited in place: its trials would change
    with pytest.raises(StoreError, match="content differs from the file the store's trials"):
        open_again(moved, store)
    with Study.open(store) as st:
        np.testing.assert_array_equal(st.trials().F, before.F)


def test_units_newly_stated_are_taken_when_they_are_the_ones_the_trials_were_read_in(tmp_path):
    # stores made before mappings had to state units read them in s, m, m/s, deg (lat/lon)
    import copy

    from vectorid.demos.own_model import write_own_model
    from vectorid.spec import StudySpec
    from vectorid.store.agreement import _MISSING, _flatten, _long_mappings, _stated_unit, compare

    write_own_model(tmp_path / "own")
    given = load_study(tmp_path / "own" / "study.toml")
    data = copy.deepcopy(given.to_dict())
    del data["identification"]["data"][0]["time_unit"]
    held = StudySpec.from_dict(data, base_dir=tmp_path / "own")
    ag = compare(held, given)
    assert not ag.refused and [d.field for d in ag.taken] == ["identification.data[0].time_unit"]
    data["identification"]["data"][0]["time_unit"] = "ms"
    ag = compare(StudySpec.from_dict(data, base_dir=tmp_path / "own"), given)
    assert [d.field for d in ag.refused] == ["identification.data[0].time_unit"]
    # a flight mapping: the short form of a channel and the former defaults
    m_old = {"time": "t", "altitude": "h", "position": {"north": "n", "east": "e", "up": "u"},
             "controls": ["l", "r"]}  # fmt: skip
    m_new = {"time": "t", "time_unit": "s", "altitude": {"column": "h", "unit": "m"},
             "position": {"north": "n", "east": "e", "up": "u", "unit": "m"},
             "controls": {"columns": ["l", "r"], "unit": "1"}}  # fmt: skip
    fa: dict = {}
    fb: dict = {}
    _flatten("identification", _long_mappings({"drops": [{"mapping": m_old}]}), fa)
    _flatten("identification", _long_mappings({"drops": [{"mapping": m_new}]}), fb)
    new = sorted(set(fb) - set(fa))
    assert set(fa) <= set(fb) and all(fa[k] == fb[k] for k in fa)
    assert all(_stated_unit(k, fa.get(k, _MISSING), fb[k]) for k in new), new
    assert not _stated_unit("identification.drops[0].mapping.altitude.unit", _MISSING, "ft")
