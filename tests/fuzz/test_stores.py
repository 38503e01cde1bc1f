"""Fuzz table: damaged, foreign, old and shared stores.

A reference store (2000 trials of the user model in 16 batches) is damaged in one way per
row; then every verb must either say which batch is damaged (and leave exactly its trials
out, every other trial equal to the reference) or refuse with one ``error:`` line naming the
fix. ``vectorid repair`` must then give back the reference store, trial for trial.
"""

from __future__ import annotations

import csv
import io
import os
import random
import shutil
import sqlite3
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from vectorid import Study, load_study
from vectorid.store import Store

from ..conftest import write_user_study
from ._harness import cli, expect, expect_error

KIND = "stores"
TRIALS = 2000
BATCH = 125


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> tuple[Path, dict[int, list[str]]]:
    """The reference store and its export rows by trial id (wall time left out)."""
    folder = tmp_path_factory.mktemp("ref")
    study = write_user_study(folder / "s", trials=TRIALS)
    path = folder / "ref.db"
    with Study.create(load_study(study), path) as st:
        st.run(executor="serial", batch_size=BATCH)
    return path, export_rows(path)


def export_rows(path: Path) -> dict[int, list[str]]:
    r = cli("export", path)
    assert r.code == 0, r.err
    rows = list(csv.reader(io.StringIO(r.out)))
    head = rows[0]
    # the Pareto flag depends on which other trials are there; the rest of a row does not
    keep = [i for i, n in enumerate(head) if n not in ("wall_time", "pareto")]
    return {int(row[0]): [row[i] for i in keep] for row in rows[1:]}


def copy(reference, tmp_path: Path, name: str = "d.db") -> Path:
    dst = tmp_path / name
    shutil.copy(reference[0], dst)
    return dst


def flip_inside_blob(path: Path, block: int, column: str, nbytes: int = 1) -> None:
    """Flip bytes in the middle of one stored array, found in the file itself."""
    con = sqlite3.connect(path)
    con.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    blob, wall = con.execute(
        f"SELECT {column}, wall FROM blocks WHERE block = ?", (block,)
    ).fetchone()
    con.close()
    data = bytearray(path.read_bytes())
    # a status array (mostly zeros) is found with the wall times stored right after it
    needle = blob + wall[:64] if column == "status" else blob[:64]
    pos = data.find(needle)
    assert pos >= 0 and data.find(needle, pos + 1) < 0, "blob not found once in the file"
    off = pos + max(0, min(len(blob), 64) // 2 - 1)
    for i in range(nbytes):
        data[off + i] ^= 0x5A
    path.write_bytes(bytes(data))


def sql(path: Path, *statements: str) -> None:
    con = sqlite3.connect(path)
    for s in statements:
        con.execute(s)
    con.commit()
    con.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    con.close()


def block_ids(block: int) -> set[int]:
    start = (block - 1) * BATCH
    return set(range(start + 1, start + BATCH + 1))


def assert_subset_of_reference(kind: str, path: Path, reference, missing: set[int]) -> None:
    """The store reads as the reference minus ``missing`` trial ids, row for row."""
    rows = export_rows(path)
    ref = reference[1]
    ok = set(rows) == set(ref) - missing and all(rows[i] == ref[i] for i in rows)
    expect(kind, ok, f"{len(rows)} rows; missing ids {sorted(set(ref) - set(rows))[:5]}...")


VERBS = [
    ("info",),
    ("table", "--top", "3"),
    ("pareto", "--json"),
    ("export",),
    ("correlation",),
    ("sensitivity",),
]

BLOB_CASES = [
    (3, "x"),
    (5, "f"),
    (7, "g"),
    (9, "status"),
    (11, "wall"),
    (16, "f"),
    (1, "x"),
]


@pytest.mark.parametrize(("block", "column"), BLOB_CASES, ids=[f"{b}-{c}" for b, c in BLOB_CASES])
def test_byte_flipped_inside_a_blob_is_found_by_every_verb(reference, tmp_path, block, column):
    path = copy(reference, tmp_path)
    flip_inside_blob(path, block, column)
    lo, hi = min(block_ids(block)), max(block_ids(block))
    for verb in VERBS:
        r = cli(verb[0], path, *verb[1:])
        said = f"batch {block} (stage 0, trials {lo}–{hi}" in r.err and "damaged" in r.err
        expect(KIND, r.code == 0 and said, f"{verb}: exit {r.code}, stderr {r.err[-400:]}", r)
    r = cli("pareto", path, "--json")
    import json

    n = json.loads(r.out)["n"]
    expect(KIND, n == TRIALS - BATCH, f"pareto counts {n}", r)
    assert_subset_of_reference(KIND, path, reference, block_ids(block))
    r = cli("verify", path)
    expect(KIND, r.code == 1 and f"batch {block} " in r.out, r.out, r)
    r = cli("repair", path, "--executor", "serial", "--quiet")
    expect(KIND, r.code == 0 and f"recomputed {BATCH} trials" in r.out, r.out + r.err, r)
    assert_subset_of_reference(KIND, path, reference, set())
    expect(KIND, cli("verify", path).code == 0)


HEADER_CASES = [
    ("n off by one", "UPDATE blocks SET n = n + 1 WHERE block = 4", 4, "bytes, expected"),
    ("seq moved", "UPDATE blocks SET seq_start = seq_start + 1 WHERE block = 4", 4, "header"),
    ("stage unknown", "UPDATE blocks SET stage = 7 WHERE block = 4", 4, "stage 7"),
    ("blob cut", "UPDATE blocks SET f = substr(f, 1, 10) WHERE block = 4", 4, "criteria"),
    ("blob text", "UPDATE blocks SET g = 'oops' WHERE block = 4", 4, "functionals"),
    ("blob null", "UPDATE blocks SET x = zeroblob(0) WHERE block = 4", 4, "parameters"),
    ("checksum text", "UPDATE blocks SET checksum = 'crc32:zz' WHERE block = 4", 4, "checksum"),
    ("checksum null", "UPDATE blocks SET checksum = NULL WHERE block = 4", None, ""),
]


@pytest.mark.parametrize(("case", "statement", "block", "match"), HEADER_CASES)
def test_damaged_batch_records(reference, tmp_path, case, statement, block, match):
    path = copy(reference, tmp_path)
    sql(path, statement)
    r = cli("info", path)
    if block is None:  # a batch without checksum reads as unverified, with its numbers sound
        expect(KIND, r.code == 0, r.err, r)
        assert_subset_of_reference(KIND, path, reference, set())
        return
    said = f"batch {block} " in r.err and match in r.err
    expect(KIND, r.code == 0 and said, r.err[-600:], r)
    assert_subset_of_reference(KIND, path, reference, block_ids(block))
    r = cli("repair", path, "--executor", "serial", "--quiet")
    expect(KIND, r.code == 0, r.err, r)
    assert_subset_of_reference(KIND, path, reference, set())


DEFINITION_CASES = [
    ("study not json", "UPDATE meta SET value = '{' WHERE key = 'study'", "checksum"),
    (
        "study digit changed",
        "UPDATE meta SET value = replace(value, '\"limit\": 1.0', '\"limit\": 9.0') "
        "WHERE key = 'study'",
        "checksum",
    ),
    ("study missing", "DELETE FROM meta WHERE key = 'study'", "no study definition"),
    ("study invalid", "UPDATE meta SET value = '{\"study\": 1}' WHERE key = 'study'", "checksum"),
    (
        "study not json, no checksum",
        (
            "UPDATE meta SET value = '{' WHERE key = 'study'",
            "DELETE FROM meta WHERE key = 'study_checksum'",
        ),
        "not JSON",
    ),
    (
        "study invalid, no checksum",
        (
            "UPDATE meta SET value = '{\"study\": 1}' WHERE key = 'study'",
            "DELETE FROM meta WHERE key = 'study_checksum'",
        ),
        "invalid",
    ),
    ("stage box", "UPDATE stages SET box = replace(box, '1.0', '2.0')", "stage 0"),
    ("stage box text", "UPDATE stages SET box = 'x'", "stage 0"),
    ("table failures dropped", "DROP TABLE failures", "failures missing"),
    ("table runs dropped", "DROP TABLE runs", "runs missing"),
    ("table stages dropped", "DROP TABLE stages", "stages missing"),
    ("table meta dropped", "DROP TABLE meta", "meta missing"),
    ("table blocks dropped", "DROP TABLE blocks", "blocks missing"),
]


@pytest.mark.parametrize(("case", "statement", "match"), DEFINITION_CASES)
def test_damaged_definition_or_tables_refused_by_every_verb(
    reference, tmp_path, case, statement, match
):
    path = copy(reference, tmp_path)
    sql(path, *([statement] if isinstance(statement, str) else statement))
    for verb in (*VERBS, ("run",), ("report", "--out", tmp_path / "r.html")):
        r = cli(verb[0], path, *verb[1:])
        expect_error(KIND, r, f"damaged.*{match}|{match}.*damaged")
    assert not (tmp_path / "r.html").exists()
    r = cli("verify", path)
    expect(KIND, r.code == 1 and "DAMAGED" in r.out, r.out + r.err, r)


@pytest.mark.parametrize(
    "statement",
    [
        "UPDATE meta SET value = '{' WHERE key = 'study'",
        "UPDATE meta SET value = replace(value, '\"limit\": 1.0', '\"limit\": 9.0') "
        "WHERE key = 'study'",
    ],
    ids=["not json", "digit"],
)
def test_repair_writes_the_definition_back_from_the_study_file(reference, tmp_path, statement):
    path = copy(reference, tmp_path)
    sql(path, statement)
    study = reference[0].parent / "s" / "user.toml"
    r = cli("repair", path, "--study", study, "--quiet")
    expect(KIND, r.code == 0 and "written back" in r.out, r.out + r.err, r)
    assert_subset_of_reference(KIND, path, reference, set())
    other = tmp_path / "other.toml"
    other.write_text(study.read_text().replace("high = 0.5", "high = 0.6"))
    sql(path, statement)
    expect_error(KIND, cli("repair", path, "--study", other, "--quiet"), "stage 0")


FILE_CASES = [
    ("half", lambda b: b[: len(b) // 2], "not a vectorid store|damaged"),
    ("header only", lambda b: b[:100], "not a vectorid store|damaged"),
    ("empty", lambda b: b"", "not a vectorid store|damaged|no study store"),
    ("zeros", lambda b: bytes(len(b)), "not a vectorid store|damaged"),
    ("text", lambda b: b"hello\n" * 100, "not a vectorid store|TOML"),
    ("first page zeroed", lambda b: bytes(4096) + b[4096:], "not a vectorid store|damaged"),
]


@pytest.mark.parametrize(("case", "cut", "match"), FILE_CASES, ids=[c[0] for c in FILE_CASES])
def test_damaged_files_refused_and_left_untouched(reference, tmp_path, case, cut, match):
    path = tmp_path / "f.db"
    path.write_bytes(cut(reference[0].read_bytes()))
    before = path.read_bytes()
    for verb in (*VERBS, ("run",), ("verify",)):
        r = cli(verb[0], path, *verb[1:])
        code = 1 if verb[0] == "verify" and r.code == 1 else 2
        expect_error(KIND, r, match, code=code) if code == 2 else expect(KIND, True)
    assert path.read_bytes() == before


def test_foreign_sqlite_file(tmp_path):
    path = tmp_path / "foreign.db"
    con = sqlite3.connect(path)
    con.execute("create table t(x)")
    con.commit()
    con.close()
    for verb in VERBS:
        expect_error(KIND, cli(verb[0], path, *verb[1:]), "not a vectorid store")


def test_store_path_is_a_folder_or_missing(tmp_path):
    expect_error(KIND, cli("info", tmp_path), "folder")
    expect_error(KIND, cli("pareto", tmp_path / "none.db"), "no store")
    expect_error(KIND, cli("verify", tmp_path / "none.db"), "no study store")


@pytest.mark.parametrize("seed", range(12))
def test_random_4k_overwrite_is_never_read_as_numbers(reference, tmp_path, seed):
    """4 KiB of random bytes somewhere in the middle of the file: every verb warns or
    refuses, what it reads equals the reference, and repair restores the reference."""
    path = copy(reference, tmp_path)
    rng = random.Random(seed)
    size = path.stat().st_size
    off = size // 2 + rng.randrange(-size // 4, size // 4)
    with open(path, "r+b") as fh:
        fh.seek(off)
        fh.write(rng.randbytes(4096))
    r = cli("export", path)
    if r.code == 0:
        rows = list(csv.reader(io.StringIO(r.out)))
        keep = [i for i, n in enumerate(rows[0]) if n not in ("wall_time", "pareto")]
        got = {int(row[0]): [row[i] for i in keep] for row in rows[1:]}
        same = all(got[i] == reference[1].get(i) for i in got)
        lost = len(reference[1]) - len(got)
        warned = lost == 0 or "damaged" in r.err
        expect(KIND, same and warned, f"lost {lost}, warned {warned}", r)
    else:
        expect_error(KIND, r, "damaged|not a vectorid store")
    r = cli("repair", path, "--executor", "serial", "--quiet")
    if r.code == 0:
        assert_subset_of_reference(KIND, path, reference, set())
    else:  # the definition itself was hit: repair says it cannot, in one line
        expect_error(KIND, r, "damaged|not a vectorid store")


def _downgrade_to_schema_1(path: Path) -> None:
    sql(
        path,
        "ALTER TABLE blocks DROP COLUMN checksum",
        "DELETE FROM meta WHERE key IN ('study_checksum', 'data_files', 'writer')",
        "DELETE FROM meta WHERE key LIKE 'stage_checksum:%'",
        "UPDATE meta SET value = '1' WHERE key = 'schema_version'",
        "PRAGMA user_version = 1",
    )


def test_schema_1_store_opens_and_is_upgraded_by_a_run(reference, tmp_path):
    path = copy(reference, tmp_path)
    _downgrade_to_schema_1(path)
    r = cli("info", path)
    expect(KIND, r.code == 0 and "schema 1" in r.err and "no checksum" in r.err, r.err, r)
    assert_subset_of_reference(KIND, path, reference, set())
    r = cli("run", path, "--executor", "serial", "--quiet")
    expect(KIND, r.code == 0 and "upgraded from schema 1 to 3" in r.err, r.err, r)
    r = cli("verify", path)
    expect(KIND, r.code == 0 and "16 verified" in r.out, r.out, r)


def test_schema_1_store_with_a_bad_status_byte(reference, tmp_path):
    path = copy(reference, tmp_path)
    _downgrade_to_schema_1(path)
    con = sqlite3.connect(path)
    status = bytearray(con.execute("SELECT status FROM blocks WHERE block = 2").fetchone()[0])
    status[5] = 7
    con.execute("UPDATE blocks SET status = ? WHERE block = 2", (bytes(status),))
    con.commit()
    con.close()
    r = cli("info", path)
    expect(KIND, r.code == 0 and "batch 2 " in r.err and "status codes" in r.err, r.err, r)
    assert_subset_of_reference(KIND, path, reference, block_ids(2))


def test_store_of_a_newer_schema_is_refused(reference, tmp_path):
    path = copy(reference, tmp_path)
    sql(path, "PRAGMA user_version = 99")
    expect_error(KIND, cli("info", path), "newer than this vectorid")


# -- one writer per store, whatever names it ---------------------------------------------------

HOLDER = """
import sys, time
from vectorid.store import Store
st = Store.open(sys.argv[1], write=True)
print("holding", flush=True)
time.sleep(float(sys.argv[2]))
st.close()
"""


@pytest.mark.parametrize("alias", ["symlink", "hardlink", "relative", "dotted"])
def test_one_writer_through_any_name(reference, tmp_path, alias, monkeypatch):
    path = copy(reference, tmp_path)
    other = tmp_path / "sub"
    other.mkdir()
    if alias == "symlink":
        name = other / "alias.db"
        name.symlink_to(path)
    elif alias == "hardlink":
        name = other / "hard.db"
        os.link(path, name)
    elif alias == "relative":
        monkeypatch.chdir(other)
        name = Path("..") / path.name
    else:
        name = other / ".." / path.name
    holder = subprocess.Popen(
        [sys.executable, "-c", HOLDER, str(path), "20"], stdout=subprocess.PIPE, text=True
    )
    try:
        assert holder.stdout.readline().strip() == "holding"
        r = cli("run", name, "--executor", "serial", "--quiet", "--trials", TRIALS + 10)
        expect_error(KIND, r, r"being written by another process \(pid", code=3)
    finally:
        holder.kill()
        holder.wait()
    r = cli("run", name, "--executor", "serial", "--quiet", "--trials", TRIALS + 10)
    expect(KIND, r.code == 0 and "10 trials computed" in r.out, r.err, r)


def test_two_writers_in_one_process_refused(reference, tmp_path):
    path = copy(reference, tmp_path)
    alias = tmp_path / "alias.db"
    alias.symlink_to(path)
    with Store.open(path, write=True):
        r = cli("run", alias, "--executor", "serial", "--quiet")
    expect_error(KIND, r, "already open for writing in this process", code=3)


# -- readers while a run appends ---------------------------------------------------------------

SLOW_MODEL = """
import time
import numpy as np

def evaluate(X):
    time.sleep(0.01)
    return np.column_stack([X[:, 0], X[:, 1]]), X[:, :1] + X[:, 1:2]
"""


def test_readers_see_one_snapshot_while_a_run_appends(tmp_path):
    """Loads (and the UI's summary) during a run with unordered batches: every load is one
    consistent snapshot (ids unique, ascending within a stage, arrays of equal length)."""
    folder = tmp_path / "s"
    study = write_user_study(folder, trials=6000)
    (folder / "slow.py").write_text(textwrap.dedent(SLOW_MODEL))
    text = study.read_text().replace("usermodel:evaluate", "slow:evaluate")
    study.write_text(text)
    store = tmp_path / "w.db"
    run = subprocess.Popen(
        [
            *(sys.executable, "-m", "vectorid.cli", "run", str(study), "--store", str(store)),
            *("--workers", "2", "--batch-size", "16", "--quiet"),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    try:
        deadline = time.time() + 60
        while not store.exists() and time.time() < deadline:
            time.sleep(0.1)
        checked = 0
        ui = None
        try:
            from vectorid.views.ui import callbacks as cb
            from vectorid.views.ui.data import StoreCache
            from vectorid.views.ui.jobs import JobManager

            time.sleep(1.0)
            cache = StoreCache(store)
            ui = cb.UIContext(
                cache=cache,
                jobs=JobManager(store, executor="serial", progress_of=lambda: 0),
                max_points=300,
                panel_points=100,
            )
        except ImportError:
            pass
        while run.poll() is None and checked < 40:
            with Store.open(store) as st:
                t = st.load()
            n = len(t)
            consistent = (
                len(np.unique(t.id)) == n
                and t.X.shape[0] == t.F.shape[0] == t.G.shape[0] == t.status.shape[0] == n
                and np.all(np.diff(t.seq) > 0)
            )
            expect(KIND, bool(consistent), f"inconsistent load of {n} trials")
            if ui is not None:
                try:
                    view = cb.summary_view(ui, ["", ""], ["pure", "pure"], None)
                    ok = view["counts"]["n"] >= n
                except Exception as exc:
                    ok = False
                    view = repr(exc)
                expect(KIND, ok, f"UI summary during the run: {view}")
                ui.cache._refresh()
            checked += 1
        assert checked >= 5, "the run ended before the readers could look"
    finally:
        run.kill()
        run.wait()
        if ui is not None:
            ui.jobs.shutdown()
