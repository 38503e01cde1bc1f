"""Fuzz table, round three (issue 35): a model of your own's code, what models return, errors
that blame the right thing, and the cases no one had run.

One input kind per group, each counted in the printed table:

``own code``     a model of your own (``[identification]``), a module it imports, its criterion
                 module, edited between runs with either sampler; what the scan cannot see
                 (named once at the first run); declared inputs; a symlink to identical content
``shapes``       rhs, output and criterion functions returning (n, 1), a scalar, (n, 3), a
                 transposed array, a list, text: one ``error:`` line naming the function and
                 both shapes (exit 2) when every trial does it, failed trials with that reason
                 when some do
``blame``        a NaN model, a folder given to ``vectorid ui``, type-malformed values sent to
                 every server callback of the browser UI (one log line, never a traceback)
``two writers``  two processes on one sequential store: one runs, the other is told; the store
                 is the one a single run writes
``study edits``  a study edited between runs (sampler switched, budget, population, seed,
                 limits): taken with a note and run on, or refused naming the field
``own timeout``  ``--timeout`` with a slow model of your own: the slow trials fail "timed out"
``own csv``      records with a unit off by 1000, an unknown unit, a missing column, time going
                 backwards, times in ms stated as s
``repair tx``    ``vectorid repair`` killed inside its transaction (shown: the store's write lock
                 is held when the kill lands): the old store, then a repair gives the reference
``seq on dask``  the sequential sampler on a local Dask cluster: the serial run's trials
``store promises`` what docs/store.md promises on the paths no other case takes: a section, a
                 robustness check, a refined stage and a repair after the model was edited; the
                 inline executor and a timeout; a Dask worker with other model code
"""

from __future__ import annotations

import io
import json
import logging
import os
import re
import shutil
import signal
import sqlite3
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

from vectorid import Study, load_study
from vectorid.demos.own_model import write_own_model
from vectorid.store import Store
from vectorid.store.inputs import unseen_loads

from ..conftest import write_user_study
from ._harness import cli, expect, expect_error, write


@pytest.fixture(autouse=True)
def _forget_user_modules():
    """Each case writes its own ``msd`` package: none stays imported across cases."""
    before = set(sys.modules)
    path = list(sys.path)
    yield
    for name in set(sys.modules) - before:
        if name.split(".")[0] in ("msd", "mycrit", "seqm", "slowm"):
            sys.modules.pop(name, None)
    sys.path[:] = path


def _own(folder: Path, trials: int = 64, extra: str = "") -> Path:
    """The tutorial's model of your own (docs/own-model.md), small."""
    write_own_model(folder)
    study = folder / "study.toml"
    text = study.read_text().replace("trials = 32768", f"trials = {trials}")
    text = text.replace("batch_size = 4096", "").replace("seed = 1\n", f"seed = 1\n{extra}")
    study.write_text(text)
    return study


def _edit(path: Path, old: str, new: str) -> None:
    text = path.read_text()
    assert old in text, old
    path.write_text(text.replace(old, new, 1))


def _run(*args: object) -> object:
    return cli("run", *args, "--quiet", "--executor", "serial")


def _count(db: Path) -> int:
    with Store.open(db) as st:
        return st.count_sample()


def _values(db: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Trial ids, parameters and criteria, in id order (NaN as -1 to compare)."""
    with Store.open(db) as st, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = st.load()
    order = np.argsort(t.id)
    return t.id[order], t.X[order], np.nan_to_num(t.F[order], nan=-1.0)


# -- own code -----------------------------------------------------------------------------------

OWN = "own code"
FORCE = "self.force_amplitude * np.sin"
OWN_EDITS = [
    ("model module, sobol", "", "msd/dynamics.py", FORCE, "1.01 * " + FORCE),
    ("model module, sequential", 'sampler = "sequential"\nbudget = 400\npopulation = 20\n',
     "msd/dynamics.py", FORCE, "1.01 * " + FORCE),
    ("package init, sobol", "", "msd/__init__.py", '"""', '"""\nSCALE = 2.0\n"""'),
]  # fmt: skip


@pytest.mark.parametrize(("case", "extra", "name", "old", "new"), OWN_EDITS,
                         ids=[e[0] for e in OWN_EDITS])  # fmt: skip
def test_own_model_code_edited_between_runs(tmp_path, case, extra, name, old, new):
    study = _own(tmp_path / "om", extra=extra)
    db = tmp_path / "om.db"
    r = _run(study, "--store", db)
    expect(OWN, r.code == 0, r.err, r)
    held = _count(db)
    _edit(study.parent / name, old, new)
    more = ("--population", 60, "--budget", 900) if "sequential" in case else ("--trials", 128)
    for target in (db, study):
        r = _run(target, "--store", db, *more)
        expect_error(OWN, r, rf"model code {re.escape(name)}: content changed", 2, False)
        expect(OWN, _count(db) == held, "trials were added on changed code")


def test_a_symlink_to_identical_content_is_no_change(tmp_path):
    study = _own(tmp_path / "om")
    db = tmp_path / "om.db"
    expect(OWN, _run(study, "--store", db).code == 0, "first run")
    model = study.parent / "msd" / "dynamics.py"
    copy = tmp_path / "elsewhere.py"
    shutil.copy(model, copy)
    model.unlink()
    model.symlink_to(copy)
    r = _run(db, "--trials", 96)
    expect(OWN, r.code == 0 and _count(db) == 96 and "changed" not in r.err, r.err, r)


SCAN_CASES = [
    ("importlib.import_module(NAME)", "imports by a computed name"),
    ("__import__(NAME)", "imports by a computed name"),
    ("sys.path.insert(0, HERE)", "changes the import path"),
    ("exec(open('extra.py').read())", "runs or loads code"),
    ("np.loadtxt(NAME)", "reads a file"),
    ("open('coef.csv').read()", "reads a file"),
    ("subprocess.run(['./helper'])", "runs a program"),
    ("import not_installed_anywhere_xyz", "not found here"),
]


@pytest.mark.parametrize(("line", "kind"), SCAN_CASES, ids=[c[0] for c in SCAN_CASES])
def test_what_an_own_model_loads_unseen_is_named(tmp_path, line, kind):
    study = _own(tmp_path / "om")
    _edit(study.parent / "msd" / "dynamics.py", "import numpy as np\n",
          f"import subprocess\nimport sys\n\nimport numpy as np\n\nNAME = 'x'\nHERE = 'y'\n"
          f"if NAME == 'z':\n    {line}\n")  # fmt: skip
    places = unseen_loads(load_study(study))
    ok = len(places) == 1 and places[0].startswith("msd/dynamics.py:") and f"({kind})" in places[0]
    expect(OWN, ok, f"{places}")


def test_the_unseen_note_once_then_a_declared_input_is_checked(tmp_path):
    study = _own(tmp_path / "om")
    write(study.parent / "msd" / "gain.txt", "1.0\n")
    _edit(study.parent / "msd" / "dynamics.py", "import numpy as np\n",
          "from pathlib import Path\n\nimport numpy as np\n\n"
          "GAIN = float(open(Path(__file__).parent / 'gain.txt').read())\n")  # fmt: skip
    _edit(study.parent / "msd" / "dynamics.py", FORCE, "GAIN * " + FORCE)
    db = tmp_path / "om.db"
    r = _run(study, "--store", db)
    said = r.err.count("note: vectorid cannot see what the model's code loads here: ")
    named = re.search(r"msd/dynamics\.py:\d+ open\(Path\(__file__\)\.parent / 'gain\.txt'\)", r.err)
    expect(OWN, r.code == 0 and said == 1 and named is not None, r.err, r)
    r = _run(db, "--trials", 96)
    expect(OWN, r.code == 0 and "cannot see" not in r.err, r.err, r)
    # declared: a new store checks it
    _edit(study, "seed = 1\n", 'seed = 1\ninputs = ["msd/gain.txt"]\n')
    db2 = tmp_path / "om2.db"
    r = _run(study, "--store", db2)
    expect(OWN, r.code == 0 and "cannot see" not in r.err, r.err, r)
    write(study.parent / "msd" / "gain.txt", "1.5\n")
    r = _run(db2, "--trials", 96)
    expect_error(OWN, r, r"declared input msd/gain\.txt: content changed", 2, False)


# -- shapes -------------------------------------------------------------------------------------

SHAPES = "shapes"
RHS = "return np.column_stack([x[:, 1], self.acceleration(t, x, p)])"
OUT = "return np.column_stack([x[:, 0], self.acceleration(t, x, p)])"
SHAPE_CASES = [
    ("rhs (n, 1)", RHS, "return np.column_stack([x[:, 1]])",
     r"rhs returned shape \(1, 1\), expected shape \(1, 2\)"),
    ("rhs scalar", RHS, "return 0.0",
     r"rhs returned a scalar 0\.0 \(shape \(\)\), expected shape \(1, 2\)"),
    ("rhs (n, 3)", RHS, "return np.column_stack([x, x[:, :1]])",
     r"rhs returned shape \(1, 3\), expected shape \(1, 2\)"),
    ("rhs transposed", RHS, "return np.vstack([x[:, 1], self.acceleration(t, x, p)])",
     r"rhs returned shape \(2, 1\), expected shape \(1, 2\).*transposed"),
    ("rhs list", RHS, "return [x[:, 1], self.acceleration(t, x, p)]",
     r"rhs returned a list of 2 items.*expected shape \(1, 2\).*column_stack"),
    ("rhs text", RHS, "return x.astype(str)", r"rhs returned text, expected real numbers"),
    ("output (n, 1)", OUT, "return x[:, :1]",
     r"output returned shape \(1, 1\), expected shape \(1, 2\)"),
    ("output transposed", OUT, "return np.vstack([x[:, 0], x[:, 1]])",
     r"output returned shape \(2, 1\), expected shape \(1, 2\)"),
]  # fmt: skip


@pytest.mark.parametrize(("case", "old", "new", "said"), SHAPE_CASES,
                         ids=[c[0] for c in SHAPE_CASES])  # fmt: skip
def test_wrong_shapes_stop_with_the_function_and_both_shapes(tmp_path, case, old, new, said):
    study = _own(tmp_path / "om")
    _edit(study.parent / "msd" / "dynamics.py", old, new)
    db = tmp_path / "om.db"
    r = _run(study, "--store", db)
    expect_error(SHAPES, r, r"msd\.dynamics\.MassSpringDamper\." + said, 2)
    expect(SHAPES, not db.exists() or _count(db) == 0, "trials were stored")


def test_some_trials_misbehave_only_they_fail_with_the_reason(tmp_path):
    study = _own(tmp_path / "om")
    _edit(study.parent / "msd" / "dynamics.py", RHS,
          "out = np.column_stack([x[:, 1], self.acceleration(t, x, p)])\n"
          "        return out[:, :1] if np.any(p[:, 0] > 1.4) else out")  # fmt: skip
    db = tmp_path / "om.db"
    r = _run(study, "--store", db, "--batch-size", 16)
    with Store.open(db) as st:
        t = st.load()
    heavy = t.X[:, 0] > 1.4
    msgs = {t.message(i) for i in np.flatnonzero(t.status == 1)}
    ok = (
        r.code == 0
        and heavy.any()
        and np.array_equal(t.status == 1, heavy)
        and msgs == {"ModelOutputError: msd.dynamics.MassSpringDamper.rhs returned shape (1, 1), "
                     "expected shape (1, 2) (one row per trial, one column per state: x, v)"}
    )  # fmt: skip
    expect(SHAPES, ok, f"{msgs} {r.err}", r)


def test_a_criterion_function_of_the_wrong_shape(tmp_path):
    study = _own(tmp_path / "om")
    write(
        study.parent / "mycrit.py",
        "import numpy as np\n\ndef peak(sim, meas, t):\n"
        "    return np.abs(sim - meas[None]).max(axis=1)\n",
    )  # fmt: skip  (n, 1), not (n,)
    _edit(study, "[identification]\n", '[[criteria]]\nname = "x_peak"\n\n[identification]\n')
    study.write_text(study.read_text() + '\n[identification.criteria.x_peak]\nchannel = "x"\n'
                     'use = "mycrit:peak"\n')  # fmt: skip
    r = _run(study, "--store", tmp_path / "om.db")
    expect_error(SHAPES, r, r"criterion x_peak \(mycrit:peak\) returned shape \(1, 1\), "
                 r"expected shape \(1,\)", 2)  # fmt: skip


# -- blame --------------------------------------------------------------------------------------

BLAME = "blame"


def test_a_nan_model_is_said_to_be_one(tmp_path):
    study = _own(tmp_path / "om")
    _edit(study.parent / "msd" / "dynamics.py", OUT, "return np.full((len(x), 2), np.nan)")
    r = _run(study, "--store", tmp_path / "om.db")
    expect_error(BLAME, r, r"the model's output 'x' is not a finite number at the reference "
                 r"vector .* so the noise floor of x_rms cannot be computed", 2)  # fmt: skip
    expect(BLAME, "limit: expected a finite number" not in r.err, r.err)


def test_ui_given_a_folder_says_so(tmp_path):
    folder = tmp_path / "runs"
    folder.mkdir()
    (folder / "a.db").write_bytes(b"")
    r = cli("ui", folder)
    expect_error(BLAME, r, r"runs is a folder, not a study store; point to the \.db file "
                 r"\(this folder holds a\.db\)", 2)  # fmt: skip


MALFORMED = [{"a": 1}, "zz", True, [["x"]]]


def test_ui_callbacks_take_malformed_values_without_a_traceback(tmp_path):
    pytest.importorskip("dash")
    from dash._utils import split_callback_id

    from vectorid.views.ui.app import create_app

    from ..analysis_helpers import make_store

    db = make_store(tmp_path, trials=128)
    app, ctx = create_app(db, executor="serial")
    buf = io.StringIO()
    handler = logging.StreamHandler(buf)
    logger = logging.getLogger()
    logger.addHandler(handler)
    old = logger.level
    logger.setLevel(logging.INFO)
    client = app.server.test_client()
    try:
        for out, cb in app.callback_map.items():
            if "callback" not in cb:
                continue  # a clientside callback: no server code
            deps = [("inputs", d) for d in cb["inputs"]] + [("state", d) for d in cb["state"]]
            for which, (_, dep) in enumerate(deps):
                before, lines = buf.tell(), 0
                for bad in MALFORMED:
                    vals = [bad if k == which else None for k in range(len(deps))]
                    body = {
                        "output": out,
                        "outputs": split_callback_id(out),
                        "changedPropIds": [f"{dep['id']}.{dep['property']}"],
                    }
                    for kind in ("inputs", "state"):
                        body[kind] = [{"id": d["id"], "property": d["property"], "value": v}
                                      for (k, d), v in zip(deps, vals) if k == kind]  # fmt: skip
                    mark = buf.tell()
                    client.post("/_dash-update-component", data=json.dumps(body),
                                content_type="application/json")  # fmt: skip
                    lines = max(lines, len(buf.getvalue()[mark:].strip().splitlines()))
                log = buf.getvalue()[before:]
                expect(
                    BLAME,
                    "Traceback" not in log and lines <= 1,
                    f"{out[:60]} <- {dep['id']}.{dep['property']}: {log[-1500:]}",
                )
    finally:
        logger.removeHandler(handler)
        logger.setLevel(old)
        ctx.jobs.shutdown()


# -- two writers on one sequential store --------------------------------------------------------

WRITERS = "two writers"
SEQ_MODEL = """
import os
import time

import numpy as np


def evaluate(X):
    time.sleep(float(os.environ.get("SEQ_SLEEP", "0.0005")) * len(X))
    return np.column_stack([np.sum((X - 0.3) ** 2, axis=1), np.sum((X - 0.7) ** 2, axis=1)])
"""
SEQ_STUDY = """
[study]
name = "seq"
model = "seqm:evaluate"
trials = 128
seed = 3
sampler = "sequential"
budget = 1200
population = 60

[[variables]]
name = "x0"
low = 0.0
high = 1.0

[[variables]]
name = "x1"
low = 0.0
high = 1.0

[[criteria]]
name = "f1"
limit = 0.02

[[criteria]]
name = "f2"
"""


def _seq(folder: Path) -> Path:
    write(folder / "seqm.py", SEQ_MODEL)
    return write(folder / "seq.toml", SEQ_STUDY)


def _proc(*args: object) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "vectorid.cli", *map(str, args)],
        env={**os.environ, "SEQ_SLEEP": "0.02"},  # a run of seconds: the two overlap
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


@pytest.mark.slow
@pytest.mark.parametrize("start", ["together", "second while the first runs"])
def test_two_processes_on_one_sequential_store(tmp_path, start):
    study = _seq(tmp_path / "s")
    ref = tmp_path / "ref.db"
    expect(WRITERS, _run(study, "--store", ref).code == 0, "reference run")
    db = tmp_path / "two.db"
    run = ("run", study, "--store", db, "--quiet", "--executor", "serial")
    a = _proc(*run)
    if start != "together":
        t0 = time.monotonic()
        while time.monotonic() - t0 < 60 and (not db.exists() or _blocks(db) == 0):
            time.sleep(0.05)
    b = _proc(*run)
    (_, ea), (_, eb) = a.communicate(timeout=300), b.communicate(timeout=300)
    codes = sorted([a.returncode, b.returncode])
    told = [e for e, c in ((ea, a.returncode), (eb, b.returncode)) if c == 3]
    ok = codes == [0, 3] and len(told) == 1 and "is being written by another process" in told[0]
    expect(WRITERS, ok and "Traceback" not in ea + eb, f"{codes}\n{ea[-600:]}\n{eb[-600:]}")
    r = _run(db)  # the one that was told runs again: nothing is left to compute
    expect(WRITERS, r.code == 0, r.err, r)
    ids, X, F = _values(db)
    rids, rX, rF = _values(ref)
    same = np.array_equal(ids, rids) and np.array_equal(X, rX) and np.array_equal(F, rF)
    expect(WRITERS, same and len(np.unique(ids)) == len(ids), "not the single run's trials")
    expect(WRITERS, cli("verify", db).code == 0, "not sound")


def _blocks(db: Path) -> int:
    try:
        con = sqlite3.connect(f"file:{db}?mode=ro", uri=True, timeout=1)
        try:
            return int(con.execute("SELECT COUNT(*) FROM blocks").fetchone()[0])
        finally:
            con.close()
    except sqlite3.Error:
        return 0


# -- a study edited between runs ----------------------------------------------------------------

EDITS = "study edits"
STUDY_EDITS = [
    # (case, old, new, taken?, what the answer names)
    ("sampler switched", 'sampler = "sequential"\nbudget = 1200\npopulation = 60\n',
     'sampler = "sobol"\n', False,
     r"study\.sampler: 'sequential' \(store\) -> 'sobol' \(file\).*changes the trials"),
    ("budget raised", "budget = 1200", "budget = 1500", True, r"study\.budget"),
    ("population raised", "population = 60", "population = 90", True, r"study\.population"),
    ("seed changed", "seed = 3", "seed = 4", False, r"study\.seed: 3 \(store\) -> 4 \(file\)"),
    ("limit tightened", "limit = 0.02", "limit = 0.015", True, r"criteria\.f1\.limit"),
]  # fmt: skip


@pytest.mark.parametrize(("case", "old", "new", "taken", "said"), STUDY_EDITS,
                         ids=[e[0] for e in STUDY_EDITS])  # fmt: skip
def test_a_sequential_study_edited_between_runs(tmp_path, case, old, new, taken, said):
    study = _seq(tmp_path / "s")
    db = tmp_path / "s.db"
    expect(EDITS, _run(study, "--store", db).code == 0, "first run")
    before = _values(db)
    _edit(study, old, new)
    r = _run(study, "--store", db)
    if not taken:
        expect_error(EDITS, r, said, 2, False)
        after = _values(db)
        expect(EDITS, all(np.array_equal(x, y) for x, y in zip(before, after)), "store changed")
        return
    expect(EDITS, r.code == 0 and re.search(said, r.err) is not None, r.err, r)
    ids, X, F = _values(db)
    kept = np.array_equal(ids[: len(before[0])], before[0]) and np.array_equal(
        X[: len(before[0])], before[1]
    )
    expect(EDITS, kept and len(np.unique(ids)) == len(ids), "stored trials changed or repeated")
    expect(EDITS, cli("verify", db).code == 0, "not sound after the edit")


# -- --timeout with a slow model of your own ----------------------------------------------------

TIMEOUT = "own timeout"


@pytest.mark.slow
def test_timeout_with_a_slow_model_of_your_own(tmp_path):
    study = _own(tmp_path / "om", trials=8)
    _edit(study.parent / "msd" / "dynamics.py", "import numpy as np\n",
          "import time\n\nimport numpy as np\n")  # fmt: skip
    _edit(study.parent / "msd" / "dynamics.py", RHS,
          "if np.any(p[:, 0] > 1.4):\n            time.sleep(0.002)  # heavy masses are slow\n"
          "        " + RHS)  # fmt: skip
    db = tmp_path / "om.db"
    r = cli("run", study, "--store", db, "--quiet", "--executor", "processes", "--workers", 2,
            "--batch-size", 2, "--timeout", 0.5)  # fmt: skip
    with Store.open(db) as st:
        t = st.load()
    heavy = t.X[:, 0] > 1.4
    msgs = [t.message(i) for i in np.flatnonzero(t.status == 1)]
    ok = (
        r.code == 0
        and heavy.any()
        and np.array_equal(t.status == 1, heavy)
        and all(m.startswith("timed out after") and "0.5 s per trial" in m for m in msgs)
        and np.isfinite(t.F[~heavy]).all()
    )
    expect(TIMEOUT, ok, f"{r.err[-500:]} heavy {np.flatnonzero(heavy)} {msgs}", r)


# -- records of a model of your own ------------------------------------------------------------

CSV = "own csv"


def _csv_case(folder: Path, case: str) -> Path:
    study = _own(folder)
    rec = folder / "run1.csv"
    text = rec.read_text()
    if case == "unit off by 1000 (mm stated as m)":
        _edit(study, 'units = { x = "mm"', 'units = { x = "m"')
    elif case == "unknown unit":
        _edit(study, 'units = { x = "mm"', 'units = { x = "furlong"')
    elif case == "missing column":
        rec.write_text(text.replace("t,x_mm,a", "t,x_m,a"))
    elif case == "time going backwards":
        lines = text.splitlines()
        lines[10], lines[11] = lines[11], lines[10]
        rec.write_text("\n".join(lines) + "\n")
    elif case == "time in ms stated as s":
        out = []
        for line in text.splitlines():
            if line[:1].isdigit():
                t, rest = line.split(",", 1)
                line = f"{float(t) * 1000:.1f},{rest}"
            out.append(line)
        rec.write_text("\n".join(out) + "\n")
        _edit(study, "window = [0.0, 6.0]", "")
    return study


CSV_CASES = [
    ("unit off by 1000 (mm stated as m)",
     r"data\[0\]\.units\.x: record 'run1': x read in 'm' has an RMS of .* 1\.0\de\+03× the "
     r"model's at the reference vector .* units x = 'mm' would make them agree"),
    ("unknown unit", r"data\[0\]\.units\.x: column 'x_mm' is in 'furlong'.*knows no conversion"),
    ("missing column", r"data\[0\]\.columns\.x: run1\.csv has no column 'x_mm'"),
    ("time going backwards", r"data\[0\]\.file: run1\.csv: time 't' does not increase at line"),
    ("time in ms stated as s",
     r"data\[0\]\.time_unit: run1\.csv: the samples of 't' are 100 s apart .* time_unit = 'ms' "
     r"would make them 0\.1 s apart"),
]  # fmt: skip


@pytest.mark.parametrize(("case", "said"), CSV_CASES, ids=[c[0] for c in CSV_CASES])
def test_own_model_records_that_cannot_be_what_they_say(tmp_path, case, said):
    study = _csv_case(tmp_path / "om", case)
    db = tmp_path / "om.db"
    r = _run(study, "--store", db)
    expect_error(CSV, r, r"identification\." + said, 2)
    expect(CSV, not db.exists(), "a store was left")


# -- repair killed inside its transaction -------------------------------------------------------

REPAIR = "repair tx"


def _damage_three(path: Path) -> None:
    con = sqlite3.connect(path)
    with con:
        blocks = [b for (b,) in con.execute("SELECT block FROM blocks ORDER BY block")]
        for b in (blocks[1], blocks[4], blocks[7]):
            f = con.execute("SELECT f FROM blocks WHERE block = ?", (b,)).fetchone()[0]
            bad = bytearray(f)
            bad[len(bad) // 2] ^= 0x5A
            con.execute("UPDATE blocks SET f = ? WHERE block = ?", (bytes(bad), b))
    con.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    con.close()


def _write_locked(path: Path) -> bool:
    """Whether another connection holds the store's write lock (an open write transaction)."""
    con = sqlite3.connect(path, timeout=0)
    try:
        con.execute("BEGIN IMMEDIATE")
        con.rollback()
        return False
    except sqlite3.OperationalError as exc:
        return "locked" in str(exc)
    finally:
        con.close()


def test_repair_killed_inside_its_transaction(tmp_path):
    study = write_user_study(tmp_path / "s", trials=160)
    ref = tmp_path / "ref.db"
    with Study.create(load_study(study), ref) as st:
        st.run(executor="serial", batch_size=16)
    ref_values = _values(ref)
    path = tmp_path / "r.db"
    shutil.copy(ref, path)
    _damage_three(path)
    mark = tmp_path / "inside.txt"
    env = {
        **os.environ,
        "VECTORID_TEST_REPAIR_TX_PAUSE": "30",
        "VECTORID_TEST_REPAIR_MARK": str(mark),
    }
    p = subprocess.Popen([sys.executable, "-m", "vectorid.cli", "repair", str(path), "--quiet",
                          "--executor", "serial"], env=env, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)  # fmt: skip
    t0 = time.monotonic()
    while not mark.exists() and p.poll() is None and time.monotonic() - t0 < 120:
        time.sleep(0.02)
    inside = mark.exists() and _write_locked(path)  # shown: the transaction is open
    p.send_signal(signal.SIGKILL)
    p.communicate()
    expect(REPAIR, inside, f"the kill did not land inside the transaction: {p.returncode}")
    v = cli("verify", path)
    old = v.code == 1 and "DAMAGED" in v.out and "3 damaged" in v.out
    expect(REPAIR, old and _count(path) == 160, f"not the old store after the kill: {v.out}", v)
    r = cli("repair", path, "--quiet", "--executor", "serial")
    v = cli("verify", path)
    expect(REPAIR, r.code == 0 and v.code == 0 and "sound" in v.out, r.err + v.out, r)
    got = _values(path)
    expect(REPAIR, all(np.array_equal(x, y) for x, y in zip(got, ref_values)), "not the reference")


# -- the sequential sampler on Dask -------------------------------------------------------------

DASK = "seq on dask"


@pytest.mark.slow
def test_the_sequential_sampler_on_dask_stores_the_serial_runs_trials(tmp_path):
    pytest.importorskip("distributed")
    study = _seq(tmp_path / "s")
    ref = tmp_path / "ref.db"
    expect(DASK, _run(study, "--store", ref).code == 0, "reference run")
    db = tmp_path / "dask.db"
    r = cli("run", study, "--store", db, "--quiet", "--executor", "dask", "--workers", 2)
    expect(DASK, r.code == 0, r.err, r)
    got, want = _values(db), _values(ref)
    same = all(np.array_equal(x, y) for x, y in zip(got, want))
    expect(DASK, same, f"{len(got[0])} trials on Dask, {len(want[0])} serial")
    expect(DASK, cli("verify", db).code == 0, "not sound")


# -- what docs/store.md promises, on the paths no other case takes ------------------------------

PROMISES = "store promises"


def _edited_user_study(tmp_path: Path, trials: int = 64) -> tuple[Path, Path]:
    """A user study run once, then its model edited."""
    study = write_user_study(tmp_path / "s", trials=trials)
    db = tmp_path / "s.db"
    with Study.create(load_study(study), db) as st:
        st.run(executor="serial", batch_size=16)
    model = study.parent / "usermodel.py"
    model.write_text(model.read_text() + "\nEDITED = True\n")
    return study, db


@pytest.mark.parametrize(
    "verb",
    [
        ("section", "--trial", 3, "--param", "x1", "--points", 5),
        ("robustness", "--trial", 3, "--points", 8),
    ],
    ids=["section", "robustness"],
)
def test_extra_runs_are_checked_too(tmp_path, verb):
    _, db = _edited_user_study(tmp_path)
    held = _values(db)
    with Store.open(db) as st:
        blocks = st.count_all_blocks()
    r = cli(verb[0], db, *verb[1:])
    expect_error(PROMISES, r, r"model code usermodel\.py: content changed.*--accept-changes", 2,
                 False)  # fmt: skip
    with Store.open(db) as st:
        same = st.count_all_blocks() == blocks
    expect(PROMISES, same and all(np.array_equal(a, b) for a, b in zip(held, _values(db))),
           "trials were added")  # fmt: skip


def test_a_refined_box_adds_a_stage_whose_trials_are_checked(tmp_path):
    _, db = _edited_user_study(tmp_path)
    r = cli("refine", db, "--apply")  # a new stage, no trial yet
    expect(PROMISES, r.code == 0 and _count(db) == 64, r.err, r)
    r = _run(db, "--trials", 128)
    expect_error(PROMISES, r, r"model code usermodel\.py: content changed", 2, False)
    expect(PROMISES, _count(db) == 64, "trials were added to the refined stage")


def test_a_repair_recomputes_only_from_the_same_model(tmp_path):
    _, db = _edited_user_study(tmp_path, trials=160)
    _damage_three(db)
    r = cli("repair", db, "--quiet", "--executor", "serial")
    expect_error(PROMISES, r, r"model code usermodel\.py: content changed", 2, False)
    v = cli("verify", db)
    expect(PROMISES, v.code == 1 and "3 damaged" in v.out, f"not left as it was: {v.out}", v)


def test_the_inline_executor_refuses_a_timeout(tmp_path):
    study = write_user_study(tmp_path / "s", trials=16)
    r = cli("run", study, "--executor", "inline", "--timeout", 1, "--quiet")
    expect_error(PROMISES, r, r"executor 'inline' runs the model in this process and cannot "
                 r"stop a trial", 2)  # fmt: skip


@pytest.mark.slow
def test_a_dask_worker_with_other_model_code_is_refused(tmp_path):
    """A worker whose import path finds another copy of the model (its own checkout) is
    refused before any trial; run on Dask with this machine's code, it runs."""
    pytest.importorskip("distributed")
    study = write_user_study(tmp_path / "s", trials=32)
    lib = tmp_path / "lib"  # the model lives on the import path, not beside the study
    shutil.move(
        study.parent / "usermodel.py", lib / "usermodel.py"
    ) if lib.mkdir() is None else None
    other = tmp_path / "other"
    other.mkdir()
    (other / "usermodel.py").write_text((lib / "usermodel.py").read_text() + "\n# other copy\n")
    env = {**os.environ, "PYTHONPATH": str(lib)}
    wenv = {**os.environ, "PYTHONPATH": str(other)}
    port = 8786 + os.getpid() % 1000
    sched = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--port",
                              str(port), "--no-dashboard"], env=env, stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL)  # fmt: skip
    worker = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker",
                               f"tcp://127.0.0.1:{port}", "--nworkers", "1", "--nthreads", "1",
                               "--no-dashboard"], env=wenv, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)  # fmt: skip
    try:
        time.sleep(8)
        address = f"tcp://127.0.0.1:{port}"
        argv = [sys.executable, "-m", "vectorid.cli", "run", str(study), "--quiet",
                "--store", str(tmp_path / "d.db"), "--scheduler", address]  # fmt: skip
        r = subprocess.run(argv, env=env, capture_output=True, text=True, timeout=300)
        ok = r.returncode == 2 and "has other model code than this machine" in r.stderr
        expect(PROMISES, ok and "Traceback" not in r.stderr, r.stderr[-1500:])
    finally:
        for p in (worker, sched):
            p.send_signal(signal.SIGTERM)
            p.wait(timeout=30)
