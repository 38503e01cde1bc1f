"""Fuzz table, round two: what a resume, a repair and a user's model could slip past.

One input kind per item of issue 24, each counted in the printed table:

``inputs``      a model module, a module it imports, a command's script or a data file edited
                between two runs, through every path into a store (study file, store, Python,
                browser-UI job): refused with the difference named and the two ways out, or
                taken with ``--accept-changes`` and recorded in the store's history;
``repair``      ``vectorid repair`` killed with ``kill -9`` at random moments: the store is the
                old one or the repaired one, never one ``verify`` calls sound with trials
                missing; a store with planned trials missing is never "sound";
``timeouts``    ``--timeout`` per trial, for the serial and process executors: the slow trial
                fails "timed out after X s" with its time, the others are stored;
``model-errors`` errors a retry recovered from (raised on the first call, wrong row count)
                are counted and reported, and the values equal a clean run's;
``wal``         the disk footprint (store + write-ahead log) during a run stays within 2x the
                final store;
``time-steps``  ``dt``/``output_dt`` combinations no model can run: one ``error:`` line
                naming the field and a valid value, exit 2, for ``run`` and ``step``.
"""

from __future__ import annotations

import os
import random
import shutil
import signal
import sqlite3
import subprocess
import sys
import threading
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

from vectorid import Study, load_study
from vectorid.builders import register_problem_builder
from vectorid.problem import Problem
from vectorid.store import Store
from vectorid.store.inputs import InputsChangedError, history

from ..conftest import write_user_study
from ._harness import cli, expect, expect_error, write

HELPER_MODEL = """
import numpy as np

from helpers import SCALE


def evaluate(X):
    return np.column_stack([X[:, 0] * SCALE, X[:, 1] + X[:, 2]]), X[:, :1]
"""


def _project(tmp_path: Path, trials: int = 32) -> Path:
    """A user study whose model imports a module of the user's project (helpers.py)."""
    folder = tmp_path / "p"
    study = write_user_study(folder, trials=trials)
    write(folder / "helpers.py", "SCALE = 2.0\n")
    write(folder / "pmodel.py", HELPER_MODEL)
    text = study.read_text().replace("usermodel:evaluate", "pmodel:evaluate")
    return write(study, text)


def _ran(study: Path, store: Path, trials: int | None = None) -> None:
    r = cli("run", study, "--store", store, "--executor", "serial", "--quiet", "--batch-size", 8)
    assert r.code == 0, r.err


def _count(store: Path) -> int:
    with Store.open(store) as st:
        return st.count_sample()


# -- item 1: inputs ----------------------------------------------------------------------------

INPUTS = "inputs"
EDITS = [
    ("model module", "pmodel.py", "* SCALE", "* SCALE * 1.01", "model code pmodel.py"),
    ("imported module", "helpers.py", "2.0", "2.02", "model code helpers.py"),
]


@pytest.mark.parametrize("path_in", ["store", "study file", "python"])
@pytest.mark.parametrize(("what", "file", "old", "new", "named"), EDITS, ids=[e[0] for e in EDITS])
def test_edited_model_code_is_refused_on_every_path(tmp_path, path_in, what, file, old, new, named):
    study = _project(tmp_path)
    store = tmp_path / "p.db"
    _ran(study, store)
    f = study.parent / file
    f.write_text(f.read_text().replace(old, new))
    if path_in == "python":
        with Study.open(store, write=True) as st:
            try:
                st.run(trials=64, executor="serial")
            except InputsChangedError as exc:
                ok = named in str(exc) and "--accept-changes" in str(exc)
            else:
                ok = False
        expect(INPUTS, ok and _count(store) == 32, "Study.run added trials on changed code")
        return
    target = store if path_in == "store" else study
    r = cli("run", target, "--store", store, "--trials", 64, "--quiet", "--executor", "serial")
    expect_error(INPUTS, r, rf"{named}: content changed.*new store.*--accept-changes", 2, False)
    expect(INPUTS, _count(store) == 32, "trials were added")
    expect(INPUTS, cli("verify", store).code == 0, "the store is no longer sound")


def test_accept_changes_records_the_change_and_info_shows_it(tmp_path):
    study = _project(tmp_path)
    store = tmp_path / "p.db"
    _ran(study, store)
    (study.parent / "helpers.py").write_text("SCALE = 3.0\n")
    r = cli("run", store, "--trials", 48, "--quiet", "--executor", "serial", "--accept-changes")
    expect(INPUTS, r.code == 0 and "accepted and recorded" in r.out, r.err, r)
    with Store.open(store) as st:
        h = history(st)
    ok = len(h) == 1 and h[0]["what"] == "model code helpers.py" and h[0]["old"] != h[0]["new"]
    expect(INPUTS, ok and _count(store) == 48, f"history {h}")
    info = cli("info", store)
    expect(INPUTS, "history" in info.out and "model code helpers.py: sha256" in info.out, info.out)
    # accepted once: the next run goes on without a word
    r = cli("run", store, "--trials", 56, "--quiet", "--executor", "serial")
    expect(INPUTS, r.code == 0 and "accepted" not in r.out + r.err, r.err, r)


def test_command_models_script_is_hashed(tmp_path):
    folder = tmp_path / "c"
    write(
        folder / "sim.py",
        "import json, sys\n"
        "x = json.load(open(sys.argv[1]))\n"
        'print(json.dumps({"f1": x["x1"] + x["x2"], "f2": x["x3"]}))\n',
    )
    study = write_user_study(folder, trials=8)
    text = study.read_text().replace(
        'model = "usermodel:evaluate"',
        f'model = "cmd"\ncommand = ["{sys.executable}", "sim.py", "{{input}}"]',
    )
    text = text.replace('[[constraints]]\nname = "g"\nhigh = 1.5\n', "")
    write(study, text)
    store = tmp_path / "c.db"
    r = cli("run", study, "--store", store, "--quiet", "--executor", "serial")
    if r.code != 0:
        pytest.skip(f"command model not runnable here: {r.err[-300:]}")
    (folder / "sim.py").write_text((folder / "sim.py").read_text() + "# edited\n")
    r = cli("run", store, "--trials", 16, "--quiet", "--executor", "serial")
    expect_error(INPUTS, r, r"model code sim\.py: content changed", 2, False)


def _coef_files(spec):
    return {"coef-r2.file": Path(spec.base_dir) / spec.extra["coef-r2"]["file"]}


def _coef_problem(spec):
    a = float(_coef_files(spec)["coef-r2.file"].read_text())

    def model(X):
        return X[:, :2] * a, X[:, :1]

    return Problem(model, spec.criteria, spec.constraints)


@pytest.mark.parametrize("path_in", ["store", "study file"])
def test_edited_data_file_is_refused_through_the_store_too(tmp_path, path_in):
    register_problem_builder("coef-r2", _coef_problem, table=True, data_files=_coef_files)
    folder = tmp_path / "s"
    study = write_user_study(folder, trials=16)
    write(folder / "coef.txt", "2.0")
    study = write(folder / "c.toml", study.read_text() + '\n[coef-r2]\nfile = "coef.txt"\n')
    store = tmp_path / "d.db"
    with Study.create(load_study(study), store) as st:
        st.run(executor="serial")
    (folder / "coef.txt").write_text("2.1")
    target = store if path_in == "store" else study
    r = cli("run", target, "--store", store, "--trials", 32, "--quiet", "--executor", "serial")
    expect_error(INPUTS, r, r"coef-r2\.file.*(content changed|content differs)", 2, False)
    expect(INPUTS, _count(store) == 16, "trials were added on changed data")
    r = cli(
        "run",
        target,
        "--store",
        store,
        "--trials",
        32,
        "--quiet",
        "--executor",
        "serial",
        "--accept-changes",
    )
    with Store.open(store) as st:
        h = history(st)
    ok = r.code == 0 and any("coef-r2.file" in e["what"] for e in h) and _count(store) == 32
    expect(INPUTS, ok, f"{r.err} {h}", r)


def test_old_store_without_code_hashes_records_them_once(tmp_path):
    study = _project(tmp_path)
    store = tmp_path / "p.db"
    _ran(study, store)
    con = sqlite3.connect(store)
    with con:
        con.execute("DELETE FROM meta WHERE key = 'code_files'")
    con.close()
    r1 = cli("run", store, "--trials", 40, "--quiet", "--executor", "serial")
    r2 = cli("run", store, "--trials", 48, "--quiet", "--executor", "serial")
    said = (r1.out + r1.err).count("recorded no model-code hashes")
    again = (r2.out + r2.err).count("recorded no model-code hashes")
    expect(INPUTS, r1.code == r2.code == 0 and said >= 1 and again == 0, r1.err + r2.err, r1)
    (study.parent / "helpers.py").write_text("SCALE = 5.0\n")
    r = cli("run", store, "--trials", 56, "--quiet", "--executor", "serial")
    expect_error(INPUTS, r, r"helpers\.py", 2, False)


def test_ui_job_path_is_checked(tmp_path):
    from vectorid.views.ui.jobs import run_job

    study = _project(tmp_path)
    store = tmp_path / "p.db"
    _ran(study, store)
    (study.parent / "helpers.py").write_text("SCALE = 4.0\n")
    try:
        text = run_job("continue", str(store), {"trials": 32, "executor": "serial"})
    except InputsChangedError as exc:
        text = str(exc)
    expect(INPUTS, "helpers.py" in text and _count(store) == 32, text)


# -- item 2: repair killed at any moment; verify counts the plan -------------------------------

REPAIR = "repair"


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


def _values(path: Path) -> tuple[np.ndarray, np.ndarray]:
    with Store.open(path) as st, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = st.load()
        order = np.argsort(t.id)
        return t.id[order], np.nan_to_num(t.F[order], nan=-1.0)


def _vectorid(*args: object, env: dict | None = None, **kw) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "vectorid.cli", *map(str, args)],
        env={**os.environ, **(env or {})},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        **kw,
    )


@pytest.mark.slow
def test_repair_killed_at_random_moments_leaves_old_or_repaired_store(tmp_path):
    study = write_user_study(tmp_path / "s", trials=320)
    ref = tmp_path / "ref.db"
    with Study.create(load_study(study), ref) as st:
        st.run(executor="serial", batch_size=32)
    ids, values = _values(ref)
    path = tmp_path / "r.db"
    shutil.copy(ref, path)
    _damage_three(path)
    env = {"VECTORID_TEST_REPAIR_PAUSE": "0.3", "VECTORID_TEST_SLEEP": "0.05"}
    # how long a whole repair takes here (start-up included), to kill it inside that span
    timed = tmp_path / "timed.db"
    shutil.copy(path, timed)
    t0 = time.perf_counter()
    p = _vectorid("repair", timed, "--quiet", "--executor", "serial", env=env)
    p.communicate()
    span = time.perf_counter() - t0
    rng = random.Random(24)
    seen = {"old": 0, "repaired": 0}
    for attempt in range(6):
        delay = rng.uniform(0.05, 1.0) * span
        p = _vectorid("repair", path, "--quiet", "--executor", "serial", env=env)
        time.sleep(delay)
        p.send_signal(signal.SIGKILL)
        p.communicate()
        v = cli("verify", path)
        old = v.code == 1 and "DAMAGED" in v.out and "3 damaged" in v.out
        repaired = v.code == 0 and "verdict    sound" in v.out
        expect(REPAIR, old or repaired, f"after kill {attempt} at {delay:.2f} s: {v.out}", v)
        expect(REPAIR, _count(path) == 320, f"trials missing after a killed repair: {v.out}")
        seen["old" if old else "repaired"] += 1
        if repaired:  # start again from the damaged store
            for suffix in ("", "-wal", "-shm"):
                Path(f"{path}{suffix}").unlink(missing_ok=True)
            shutil.copy(ref, path)
            _damage_three(path)
    expect(REPAIR, seen["old"] >= 1, f"no kill landed inside a repair ({span:.2f} s): {seen}")
    r = cli("repair", path, "--quiet", "--executor", "serial")
    expect(REPAIR, r.code == 0, r.err, r)
    v = cli("verify", path)
    expect(REPAIR, v.code == 0 and "sound" in v.out, v.out, v)
    got_ids, got = _values(path)
    expect(
        REPAIR, np.array_equal(got_ids, ids) and np.array_equal(got, values), "not the reference"
    )
    r = cli("run", path, "--quiet", "--executor", "serial")
    expect(REPAIR, r.code == 0 and "0 trials computed" in r.out, r.out, r)


def test_verify_never_calls_a_store_with_missing_planned_trials_sound(tmp_path):
    study = write_user_study(tmp_path / "s", trials=128)
    path = tmp_path / "m.db"
    with Study.create(load_study(study), path) as st:
        st.run(executor="serial", batch_size=16)
    con = sqlite3.connect(path)
    with con:  # what a killed repair of the old kind left: three batches gone
        con.execute("DELETE FROM blocks WHERE block IN (2, 5, 7)")
    con.close()
    v = cli("verify", path)
    expect(
        REPAIR,
        v.code == 1
        and "48 of the 128 planned trials are missing" in v.out
        and f"vectorid run {path}" in v.out,
        v.out,
        v,
    )
    r = cli("repair", path, "--quiet")
    expect(REPAIR, r.code == 0 and "48 planned trials are missing" in r.out, r.out, r)
    info = cli("info", path)
    expect(REPAIR, "MISSING    48 planned trials" in info.out, info.out, info)
    r = cli("run", path, "--quiet", "--executor", "serial")
    expect(REPAIR, r.code == 0 and cli("verify", path).code == 0, r.err, r)


# -- item 3: --timeout per trial ----------------------------------------------------------------

TIMEOUTS = "timeouts"
SLEEPY = """
import time

import numpy as np


def one(x):
    time.sleep(0.6 if x[0] > 0.75 else 0.0)
    return np.array([x[0], x[1]]), np.array([x[2]])
"""


@pytest.mark.parametrize(
    "executor", ["serial", "processes", pytest.param("dask", marks=pytest.mark.slow)]
)
@pytest.mark.parametrize("batch", [1, 4])
def test_timeout_is_per_trial(tmp_path, executor, batch):
    folder = tmp_path / "t"
    study = write_user_study(folder, trials=16)
    write(folder / "sleepy.py", SLEEPY)
    write(
        study,
        study.read_text()
        .replace("usermodel:evaluate", "sleepy:one")
        .replace("batch = true", "batch = false"),
    )
    store = tmp_path / "t.db"
    r = cli(
        "run",
        study,
        "--store",
        store,
        "--quiet",
        "--executor",
        executor,
        "--workers",
        2,
        "--batch-size",
        batch,
        "--timeout",
        0.25,
    )
    expect(TIMEOUTS, r.code == 0, r.err, r)
    with Store.open(store) as st:
        t = st.load()
    slow = t.X[:, 0] > 0.75
    failed = t.status == 1
    msgs = [t.message(i) for i in np.flatnonzero(failed)]
    ok = (
        slow.any()
        and np.array_equal(failed, slow)
        and all(m.startswith("timed out after") and "0.25 s per trial" in m for m in msgs)
        and np.all(t.wall[slow] >= 0.25)
    )
    expect(TIMEOUTS, ok, f"slow {np.flatnonzero(slow)} failed {np.flatnonzero(failed)} {msgs}")


def test_timeout_help_says_it_exactly():
    r = cli("run", "--help")
    text = " ".join(r.out.split())
    expect(
        TIMEOUTS,
        "a batch of N trials may run N x SECONDS" in text and "timed out after X s" in text,
        r.out,
    )


# -- item 4: model errors a retry recovered from ------------------------------------------------

ERRORS = "model-errors"
FLAKY = """
import numpy as np

CALLS = [0]


def evaluate(X):
    CALLS[0] += 1
    if MODE == "first" and CALLS[0] == 1:
        raise ValueError("not warmed up yet")
    f = np.column_stack([X[:, 0] ** 2 + X[:, 1], (1 - X[:, 0]) ** 2 + X[:, 2]])
    g = (X[:, 0] + X[:, 1])[:, None]
    if MODE == "rows" and len(X) == 16 and CALLS[0] % 3 == 1:
        return f[:-1], g[:-1]
    return f, g
"""


@pytest.mark.parametrize(
    ("mode", "said"),
    [
        (
            "first",
            r"\d+ batch(es)? raised ValueError: not warmed up yet.*re-run trial by trial: 0 lost",
        ),
        ("rows", r"\d+ batch(es)? returned 15 rows for 16 trials; re-run trial by trial: 0 lost"),
    ],
)
@pytest.mark.parametrize("executor", ["serial", "processes"])
def test_recovered_model_errors_are_reported(tmp_path, mode, said, executor):
    folder = tmp_path / "f"
    study = write_user_study(folder, trials=64)
    write(folder / "flaky.py", f"MODE = {mode!r}\n" + FLAKY)
    write(study, study.read_text().replace("usermodel:evaluate", "flaky:evaluate"))
    clean = tmp_path / "clean.db"
    with Study.create(load_study(write_user_study(tmp_path / "c", trials=64)), clean) as st:
        st.run(executor="serial", batch_size=16)
    store = tmp_path / "f.db"
    r = cli(
        "run",
        study,
        "--store",
        store,
        "--quiet",
        "--executor",
        executor,
        "--workers",
        2,
        "--batch-size",
        16,
    )
    import re

    expect(ERRORS, r.code == 0 and re.search(said, r.out) is not None, r.out, r)
    info = cli("info", store)
    expect(ERRORS, re.search("model error: " + said, info.out) is not None, info.out, info)
    # the values are right: those of a clean model (which raises for x1 > 0.9, this one not)
    a, b = _values(clean)[1], _values(store)[1]
    keep = a[:, 0] != -1
    expect(ERRORS, np.allclose(a[keep], b[keep]), "values differ from a clean run")


# -- item 5: disk footprint during a run --------------------------------------------------------

WAL = "wal"


def test_disk_footprint_stays_within_twice_the_store(tmp_path):
    study = write_user_study(tmp_path / "w", trials=4000)
    path = tmp_path / "w.db"
    peak = [0]
    stop = threading.Event()

    def footprint() -> int:
        return sum(
            os.path.getsize(f"{path}{s}")
            for s in ("", "-wal", "-shm")
            if os.path.exists(f"{path}{s}")
        )

    def sample() -> None:
        while not stop.is_set():
            peak[0] = max(peak[0], footprint())
            time.sleep(0.002)

    th = threading.Thread(target=sample, daemon=True)
    with Study.create(load_study(study), path) as st:
        th.start()
        st.run(executor="serial", batch_size=16)
        stop.set()
        th.join()
    final = os.path.getsize(path)
    expect(WAL, peak[0] <= 2 * final, f"peak {peak[0]} B, final store {final} B")


# -- item 6: dt / output_dt ---------------------------------------------------------------------

STEPS = "time-steps"
STEP_CASES = [
    (
        "output_dt = 0.07",
        "dt = 0.05",
        r"identification\.output_dt: output_dt = 0\.07 s is not a "
        r"whole multiple of dt = 0\.05 s — use 0\.05 or 0\.1",
    ),
    (
        "output_dt = 0.01",
        "dt = 0.05",
        r"identification\.output_dt: output_dt = 0\.01 s is not a "
        r"whole multiple of dt = 0\.05 s — use 0\.05 \(or dt = 0\.01\)",
    ),
    (
        "output_dt = 0.5",
        "dt = 0.3",
        r"output_dt = 0\.5 s is not a whole multiple of dt = 0\.3 s "
        r"— use 0\.3 or 0\.6",
    ),
    ("output_dt = -1", "dt = 0.05", r"identification\.output_dt: expected a positive number"),
    ("output_dt = 0.5", "dt = 0", r"identification\.dt: expected a positive number"),
]


@pytest.fixture(scope="module")
def ident_study(tmp_path_factory) -> Path:
    from vectorid.demos.g12 import _copy_data, identification_toml

    out = tmp_path_factory.mktemp("ident")
    truth = _copy_data(out)
    return write(out / "step1.toml", identification_toml(1, trials=8, truth=truth))


@pytest.mark.parametrize("verb", ["run", "step"])
@pytest.mark.parametrize(
    ("out_dt", "dt", "said"), STEP_CASES, ids=[c[0] + c[1] for c in STEP_CASES]
)
def test_time_steps_are_one_line_errors(ident_study, tmp_path, verb, out_dt, dt, said):
    text = ident_study.read_text()
    table = text.index("[identification]")
    head, rest = text[: table + len("[identification]")], text[table + len("[identification]") :]
    rest = "\n".join(
        ln for ln in rest.splitlines() if not ln.strip().startswith(("dt ", "dt=", "output_dt"))
    )
    bad = write(ident_study.parent / f"bad-{verb}.toml", f"{head}\n{out_dt}\n{dt}\n{rest}")
    args = ("--store", tmp_path / "x.db", "--quiet") if verb == "run" else ()
    r = cli(verb, bad, *args)
    expect_error(STEPS, r, said, 2)
    expect(STEPS, not (tmp_path / "x.db").exists(), "a store was created")


def test_valid_steps_still_load(ident_study):
    spec = load_study(ident_study)
    expect(STEPS, "identification" in spec.extra, "the demo study does not load")


def test_time_step_messages_for_every_reader():
    from vectorid.errors import StudyDefinitionError
    from vectorid.timesteps import check_time_steps

    cases = [
        ((0.05, 0.1), None),
        ((0.05, 0.1, 1.0), None),
        ((0.05, 0.1, 1.05), r"t_final = 1\.05 s is not a whole number of output_dt = 0\.1 s"),
        ((0.1, 0.3), None),
        ((0.02, 0.05), r"use 0\.04 or 0\.06"),
    ]
    for args, said in cases:
        try:
            check_time_steps(*args[:2], t_final=args[2] if len(args) > 2 else None)
        except StudyDefinitionError as exc:
            import re

            expect(STEPS, said is not None and re.search(said, str(exc)) is not None, str(exc))
        else:
            expect(STEPS, said is None, f"{args} accepted")
