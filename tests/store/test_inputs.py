"""What a store's trials were computed from is checked before a trial is added
(vectorid.store.inputs): a model of your own identified from data, the modules it imports,
criterion and reduction modules, declared inputs, content rather than path spelling, and
what the scan cannot see, said once."""

from __future__ import annotations

import importlib.machinery
import json
import re
import sqlite3
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from vectorid import Study, load_study
from vectorid.demos.own_model import write_own_model
from vectorid.spec import StudySpec
from vectorid.store import Store
from vectorid.store.inputs import (
    InputsChangedError,
    _diff,
    code_hashes,
    declared_hashes,
    history,
    unseen_loads,
)

from ..conftest import write_user_study

MYCRIT = """
import numpy as np


def peak(sim, meas, t):
    return np.max(np.abs(sim[:, :, 0] - meas[None, :, 0]), axis=1)
"""


@pytest.fixture(autouse=True)
def _forget_user_modules():
    """Each test writes its own ``msd`` package and criterion module: none stays imported."""
    before = set(sys.modules)
    path = list(sys.path)
    yield
    for name in set(sys.modules) - before:
        if name.split(".")[0] in ("msd", "mycrit", "usermodel", "pmodel", "helpers", "libk"):
            sys.modules.pop(name, None)
    sys.path[:] = path


def own_model(folder: Path, trials: int = 128, sampler: str = "sobol") -> Path:
    """The tutorial's own-model study (docs/own-model.md), small, with a criterion function
    of its own (``use = "mycrit:peak"``)."""
    write_own_model(folder)
    (folder / "mycrit.py").write_text(MYCRIT)
    study = folder / "study.toml"
    text = study.read_text()
    text = text.replace("trials = 32768", f"trials = {trials}").replace("batch_size = 4096", "")
    if sampler == "sequential":
        text = text.replace("seed = 1\n", 'seed = 1\nsampler = "sequential"\nbudget = 600\n')
        text = text.replace("seed = 1\n", "seed = 1\npopulation = 20\n", 1)
    text = text.replace(
        "[identification]\n",
        '[[criteria]]\nname = "x_peak"\n\n[identification]\n',
    )
    text += '\n[identification.criteria.x_peak]\nchannel = "x"\nuse = "mycrit:peak"\n'
    study.write_text(text)
    return study


def run(target: Path, **kw) -> Study:
    if target.suffix == ".toml":
        study = Study.create_or_open(target, target.with_suffix(".db"))
    else:
        study = Study.open(target, write=True)
    with study:
        study.run(executor="serial", **kw)
    return study


def count(db: Path) -> int:
    with Store.open(db) as st:
        return st.count_sample()


EDITS = {
    "model module": (
        "msd/dynamics.py",
        "self.force_amplitude * np",
        "1.5 * self.force_amplitude * np",
    ),
    "package of the model": ("msd/__init__.py", '"""A mass', 'SCALE = 1.0  # edited\n"""A mass'),
    "criterion module": ("mycrit.py", "np.max(", "1.01 * np.max("),
}


def test_an_accepted_edit_runs_the_edited_code_in_the_same_process(tmp_path):
    # a notebook runs a study, the user edits a criterion module and accepts the change: the
    # new trials must be the edited code's, not what this process imported before the edit
    study = own_model(tmp_path / "om")
    db = study.with_suffix(".db")
    run(study)
    f = study.parent / "mycrit.py"
    f.write_text(
        MYCRIT.replace("return np.max(", "return 0 * np.max(").replace("axis=1)", "axis=1) + 123.0")
    )
    run(db, accept_changes=True, trials=256)
    with Store.open(db) as st:
        trials = st.load()
        k = [c.name for c in st.spec.criteria].index("x_peak")
    old, new = trials.F[:128, k], trials.F[128:, k]
    assert len(new) == 128 and np.all(old != 123.0) and np.all(new == 123.0)


@pytest.mark.parametrize(
    ("edit", "sampler"),
    [("model module", "sobol"), ("package of the model", "sobol"),
     ("criterion module", "sobol"), ("model module", "sequential")],
)  # fmt: skip
def test_an_own_models_code_is_checked_with_every_sampler(tmp_path, edit, sampler):
    study = own_model(tmp_path / "om", sampler=sampler)
    db = study.with_suffix(".db")
    run(study)
    held = count(db)
    with Store.open(db) as st:
        recorded = json.loads(st.meta()["code_files"])
    assert {"msd/dynamics.py", "msd/__init__.py", "mycrit.py"} <= set(recorded)
    name, old, new = EDITS[edit]
    f = study.parent / name
    f.write_text(f.read_text().replace(old, new, 1))
    more = {"population": 60, "budget": 1200} if sampler == "sequential" else {"trials": 256}
    for target in (db, study):  # through the store and through the study file
        with pytest.raises(InputsChangedError, match=rf"model code {name}: content changed"):
            run(target, **more)
        assert count(db) == held
    run(db, accept_changes=True, **more)  # taken on purpose: recorded in the history
    assert count(db) > held
    with Store.open(db) as st:
        assert [e["what"] for e in history(st)] == [f"model code {name}"]


def test_a_store_that_hashed_less_records_the_rest_with_a_note_then_compares(tmp_path):
    study = own_model(tmp_path / "om")
    db = study.with_suffix(".db")
    run(study)
    with Store.open(db, write=True) as st:  # as an older vectorid recorded it
        code = json.loads(st.meta()["code_files"])
        old = {k: v for k, v in code.items() if k.startswith("vectorid ")}
        st.set_meta({"code_files": json.dumps(old)})
    con = sqlite3.connect(db)
    with con:
        con.execute("DELETE FROM meta WHERE key = 'code_files_scheme'")
    con.close()
    said = r"hashed less of the model's code: .*msd/dynamics\.py.* recorded now"
    with pytest.warns(Warning, match=said):
        run(db, trials=160)
    assert count(db) == 160
    with Store.open(db) as st:
        notes = [e for e in history(st) if e["note"] == "first record (older store)"]
    assert {e["what"] for e in notes} >= {"model code msd/dynamics.py", "model code mycrit.py"}
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # said once
        run(db, trials=192)
    (study.parent / "mycrit.py").write_text(MYCRIT.replace("np.max(", "2 * np.max("))
    with pytest.raises(InputsChangedError, match=r"mycrit\.py: content changed"):
        run(db, trials=224)


def test_identity_is_by_content_not_by_path_spelling(tmp_path):
    study = write_user_study(tmp_path / "s", trials=16)
    db = tmp_path / "s.db"
    with Study.create(load_study(study), db) as st:
        st.run(executor="serial")
    model = study.parent / "usermodel.py"
    elsewhere = tmp_path / "shelf" / "usermodel.py"
    elsewhere.parent.mkdir()
    elsewhere.write_text(model.read_text())
    model.unlink()
    model.symlink_to(elsewhere)  # a symlink to identical content: no change
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        run(db, trials=32)
    assert count(db) == 32
    elsewhere.write_text(elsewhere.read_text() + "\n# edited through the link\n")
    with pytest.raises(InputsChangedError, match=r"model code usermodel\.py: content changed"):
        run(db, trials=48)
    # the same content under another label (a re-linked interpreter, a moved module) moved
    h = {"sha256": "ab" * 32}
    assert _diff("model code", {"/usr/bin/python3.11": h}, {"/venv/bin/python": h}) == []
    assert [c.what for c in _diff("model code", {"a.py": h}, {"b.py": {"sha256": "cd"}})] == [
        "a.py",
        "b.py",
    ]


PMODEL = """
import importlib
import sys

import numpy as np

sys.path.insert(0, "lib")
import libk

SHAPE = importlib.import_module("helpers").SHAPE


def evaluate(X):
    return np.column_stack([X[:, 0] * libk.K * SHAPE, X[:, 1] + X[:, 2]]), X[:, :1]
"""


SIMPLE = """
import numpy as np


def evaluate(X):
    return np.column_stack([X[:, 0], X[:, 1] + X[:, 2]]), X[:, :1]
"""


def _pmodel(tmp_path: Path, body: str = SIMPLE, inputs: str = "") -> Path:
    folder = tmp_path / "p"
    study = write_user_study(folder, trials=16)
    (folder / "lib").mkdir()
    (folder / "lib" / "libk.py").write_text("K = 2.0\n")
    (folder / "helpers.py").write_text("SHAPE = 1.0\n")
    (folder / "pmodel.py").write_text(body)
    text = study.read_text().replace("usermodel:evaluate", "pmodel:evaluate")
    if inputs:
        text = text.replace("[study]\n", f"[study]\ninputs = {inputs}\n")
    study.write_text(text)
    return study


@pytest.mark.parametrize("edited", ["helpers.py", "lib/libk.py"])
def test_literal_dynamic_imports_and_import_paths_are_followed(tmp_path, edited, monkeypatch):
    study = _pmodel(tmp_path, PMODEL)
    monkeypatch.chdir(study.parent)  # sys.path.insert(0, "lib") reads from the working folder
    assert {"pmodel.py", "helpers.py", "lib/libk.py"} <= set(code_hashes(load_study(study)))
    assert unseen_loads(load_study(study)) == []  # nothing it cannot follow
    run(study)
    f = study.parent / edited
    f.write_text(f.read_text().replace("= ", "= 1.5 * "))
    with pytest.raises(InputsChangedError, match=rf"model code {edited}: content changed"):
        run(study.with_suffix(".db"), trials=32)


UNSEEN = [
    ("importlib.import_module(name)", "imports by a computed name", 'name = "json"\n'),
    ("__import__(name)", "imports by a computed name", 'name = "json"\n'),
    ("sys.path.insert(0, str(HERE / 'lib'))", "changes the import path",
     "from pathlib import Path\nHERE = Path(__file__).parent\n"),
    ("exec(open('extra.py').read())", "runs or loads code", ""),
    ("np.loadtxt(DATA)", "reads a file", 'DATA = "coef.csv"\n'),
    ("open('coef.csv').read()", "reads a file", ""),
    ("pd.read_csv('coef.csv')", "reads a file", "import pandas as pd\n"),
    ("Path('coef.csv').read_text()", "reads a file", "from pathlib import Path\n"),
    ("ctypes.CDLL('./libfast.so')", "runs or loads code", "import ctypes\n"),
    ("subprocess.run(['./helper'])", "runs a program", "import subprocess\n"),
]  # fmt: skip


@pytest.mark.parametrize(("call", "kind", "pre"), UNSEEN, ids=[u[1] + ": " + u[0] for u in UNSEEN])
def test_what_the_scan_cannot_see_is_named(tmp_path, call, kind, pre):
    body = f"import sys\nimport numpy as np\n{pre}\ndef evaluate(X):\n    {call}\n    return X\n"
    study = _pmodel(tmp_path, body)
    places = unseen_loads(load_study(study))
    assert len(places) == 1 and places[0].startswith("pmodel.py:") and f"({kind})" in places[0]
    assert call.removesuffix(".read()")[:40] in places[0]


def test_a_place_whose_literal_path_is_declared_is_not_named(tmp_path):
    body = "import numpy as np\n\ndef evaluate(X):\n    np.loadtxt('data/coef.csv')\n    return X\n"
    study = _pmodel(tmp_path, body)
    (study.parent / "data").mkdir()
    (study.parent / "data" / "coef.csv").write_text("1.0\n")
    assert len(unseen_loads(load_study(study))) == 1
    study.write_text(study.read_text().replace("[study]\n", '[study]\ninputs = ["data/"]\n'))
    assert unseen_loads(load_study(study)) == []
    # an import that cannot be found at all is named too, unless it is optional
    (study.parent / "pmodel.py").write_text(
        body + "\nimport nowhere_to_be_found\ntry:\n    import optional_xyz\nexcept ImportError:\n"
        "    optional_xyz = None\n"
    )
    places = unseen_loads(load_study(study))
    assert [p.split(" ", 1)[1] for p in places] == ["import nowhere_to_be_found (not found here)"]


def test_the_unseen_note_is_said_once_at_the_first_run(tmp_path, capsys, monkeypatch):
    from vectorid.cli import main

    body = (
        "import numpy as np\n\nW = float(open('w.txt').read())\n\n\n"
        "def evaluate(X):\n    return X[:, :2] * W, X[:, :1]\n"
    )
    study = _pmodel(tmp_path, body)
    (study.parent / "w.txt").write_text("1.0\n")
    monkeypatch.chdir(study.parent)  # where open('w.txt') finds it
    assert main(["run", str(study), "--quiet", "--executor", "serial"]) == 0
    err = capsys.readouterr().err
    assert err.count("note: vectorid cannot see what the model's code loads here: ") == 1
    assert "pmodel.py:3 open('w.txt') (reads a file)" in err
    assert main(["run", str(study), "--trials", "32", "--quiet", "--executor", "serial"]) == 0
    assert "cannot see" not in capsys.readouterr().err


def test_declared_inputs_are_hashed_like_data_files(tmp_path, capsys):
    from vectorid.cli import main

    study = _pmodel(tmp_path, inputs='["tables/", "coef.csv"]')
    folder = study.parent
    (folder / "tables" / "sub").mkdir(parents=True)
    (folder / "tables" / "sub" / "cd.txt").write_text("0.5\n")
    (folder / "tables" / "__pycache__").mkdir()
    (folder / "tables" / "__pycache__" / "x.pyc").write_bytes(b"\0")
    (folder / "coef.csv").write_text("3.0\n")
    assert set(declared_hashes(load_study(study))) == {"tables/sub/cd.txt", "coef.csv"}
    assert main(["run", str(study), "--quiet", "--executor", "serial"]) == 0
    capsys.readouterr()
    db = study.with_suffix(".db")
    (folder / "tables" / "sub" / "cd.txt").write_text("0.6\n")
    code = main(["run", str(db), "--trials", "32", "--quiet", "--executor", "serial"])
    err = capsys.readouterr().err
    assert code == 2 and "declared input tables/sub/cd.txt: content changed" in err
    assert count(db) == 16
    (folder / "coef.csv").unlink()
    code = main(["run", str(db), "--trials", "32", "--quiet", "--accept-changes",
                 "--executor", "serial"])  # fmt: skip
    assert code == 0 and count(db) == 32
    with Store.open(db) as st:
        assert [e["what"] for e in history(st)] == [
            "declared input coef.csv",
            "declared input tables/sub/cd.txt",
        ]
    # declaring a new input into a store that holds trials: its content before is unknown
    (folder / "more.txt").write_text("x\n")
    study.write_text(study.read_text().replace('"coef.csv"]', '"more.txt"]'))
    code = main(["run", str(study), "--trials", "48", "--quiet", "--executor", "serial"])
    err = capsys.readouterr().err
    assert code == 2 and "declared input more.txt: new since the stored trials" in err


@pytest.mark.parametrize(
    ("value", "said"),
    [
        ('"lib/"', r"study\.inputs: expected a list of paths, got [\"']lib/[\"']"),
        ("3", r"study\.inputs: expected a list of paths, got 3"),
        ('["a.txt", ""]', r"study\.inputs\[1\]: expected a file or folder path, got (''|\"\")"),
        ('["a.txt", 7]', r"study\.inputs\[1\]: expected a file or folder path, got 7"),
        ('["a.txt", "./a.txt"]', r"study\.inputs\[1\]: '\./a\.txt' is declared twice"),
        ('["missing.csv"]', r"study\.inputs\[0\]: 'missing\.csv' does not exist \(looked for "),
    ],
)
def test_declared_inputs_are_validated_in_one_line(tmp_path, value, said, capsys):
    from vectorid.cli import main

    study = _pmodel(tmp_path, inputs=value)
    (study.parent / "a.txt").write_text("a")
    assert main(["run", str(study), "--quiet", "--executor", "serial"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and err.startswith("error: ")
    assert re.search(said, err), err


def test_compiled_and_reduction_modules_are_hashed(tmp_path):
    ext = importlib.machinery.EXTENSION_SUFFIXES[0]
    (tmp_path / f"fastlib{ext}").write_bytes(b"\x7fELF not really")
    (tmp_path / "cmodel.py").write_text("import fastlib\n\ndef evaluate(X):\n    return X\n")
    (tmp_path / "myred.py").write_text("def overshoot(t, y):\n    return 0.0\n")
    base = dict(
        space=[{"name": "x", "low": 0.0, "high": 1.0}],
        criteria=[{"name": "f"}],
        base_dir=str(tmp_path),
    )
    py = StudySpec.from_dict(
        {"study": {"name": "c", "model": "cmodel:evaluate"}, "variables": base["space"],
         "criteria": base["criteria"]}, base_dir=tmp_path,
    )  # fmt: skip
    assert set(code_hashes(py)) == {"cmodel.py", f"fastlib{ext}"}
    fmu = StudySpec.from_dict(
        {"study": {"name": "c", "model": "fmu:plant.fmu",
                   "fmu": {"outputs": {"f": {"variable": "y", "reduce": "myred:overshoot"}}}},
         "variables": base["space"], "criteria": base["criteria"]}, base_dir=tmp_path,
    )  # fmt: skip
    assert set(code_hashes(fmu)) == {"myred.py"}


IDIOMS = """
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent / "lib"))
import libq

A = np.loadtxt(Path(__file__).with_name("data") / "c.csv")
B = np.loadtxt(os.path.join(os.path.dirname(__file__), "data", "c.csv"))
C = (Path(__file__).resolve().parent / "data" / "c.csv").read_text()
D = open(Path(__file__).parent / "other.csv")
"""


def test_paths_beside_the_module_are_read_from_the_usual_idioms(tmp_path):
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "libq.py").write_text("K = 1\n")
    (tmp_path / "data").mkdir()
    (tmp_path / "m.py").write_text(IDIOMS)
    spec = StudySpec.from_dict(
        {"study": {"name": "i", "model": "m:f", "inputs": ["data/"]},
         "variables": [{"name": "x", "low": 0.0, "high": 1.0}], "criteria": [{"name": "f"}]},
        base_dir=tmp_path,
    )  # fmt: skip
    assert set(code_hashes(spec)) == {"m.py", "lib/libq.py"}  # the import path it adds
    # the three reads of data/c.csv lie in the declared folder; other.csv does not
    assert unseen_loads(spec) == [
        'm.py:14 open(Path(__file__).parent / "other.csv") (reads a file)'
    ]
