import os
import sqlite3
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from vectorid import StoreError, StoreLockedError, load_study
from vectorid.store import SCHEMA_VERSION, Store


@pytest.fixture
def spec(user_study):
    return load_study(user_study)


def batch(n, p=3, k=2, q=1, seed=0):
    rng = np.random.default_rng(seed)
    return (
        rng.random((n, p)),
        rng.random((n, k)),
        rng.random((n, q)),
        np.zeros(n, np.int8),
        np.full(n, 0.01),
    )


def test_create_holds_definition_schema_and_wal(tmp_path, spec):
    path = tmp_path / "s.db"
    with Store.create(path, spec) as st:
        assert st.spec == spec
        assert [s.stage for s in st.stages()] == [0]
        assert st.stages()[0].space == spec.space
    con = sqlite3.connect(path)
    assert con.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    assert con.execute("PRAGMA user_version").fetchone()[0] == SCHEMA_VERSION
    con.close()
    # the store alone is enough: reopen, definition back
    with Store.open(path) as st:
        assert st.spec == spec
        assert st.meta()["schema_version"] == str(SCHEMA_VERSION)


def test_create_refuses_existing(tmp_path, spec):
    Store.create(tmp_path / "s.db", spec).close()
    with pytest.raises(StoreError, match="exists already"):
        Store.create(tmp_path / "s.db", spec)


def test_write_load_roundtrip_and_exactly_once(tmp_path, spec):
    with Store.create(tmp_path / "s.db", spec) as st:
        X, F, G, S, W = batch(10)
        S[3] = 1
        F[3] = np.nan
        assert st.write_batch(0, 20, X, F, G, S, W, {3: "boom"}) == 10
        assert st.write_batch(0, 0, *batch(5, seed=1)) == 5
        # overlapping range: not stored again
        assert st.write_batch(0, 25, *batch(10, seed=2)) == 0
        assert st.write_batch(0, 4, *batch(2, seed=3)) == 0
        t = st.load()
        assert len(t) == 15
        np.testing.assert_array_equal(t.seq, list(range(5)) + list(range(20, 30)))
        np.testing.assert_array_equal(t.id, t.seq + 1)
        np.testing.assert_array_equal(t.X[5:], X)
        np.testing.assert_array_equal(t.G[5:], G)
        assert t.status[8] == 1 and t.message(8) == "boom" and t.message(0) == ""
        assert st.missing(0, 0, 40) == [(5, 20), (30, 40)]
        assert st.count() == 15


def test_stages_continue_the_sequence(tmp_path, spec):
    with Store.create(tmp_path / "s.db", spec) as st:
        st.write_batch(0, 0, *batch(64))
        narrow = spec.space.with_bounds({"x1": (0.2, 0.4)})
        s1 = st.add_stage(narrow, note="refined")
        assert s1.stage == 1 and s1.start_seq == 64 and s1.space == narrow
        assert st.sequence_end() == 64


def test_open_errors(tmp_path, spec):
    with pytest.raises(StoreError, match="no study store"):
        Store.open(tmp_path / "missing.db")
    foreign = tmp_path / "foreign.db"
    con = sqlite3.connect(foreign)
    con.execute("create table t(x)")
    con.commit()
    con.close()
    with pytest.raises(StoreError, match="not a vectorid store"):
        Store.open(foreign)
    junk = tmp_path / "junk.db"
    junk.write_bytes(b"this is not a database at all" * 100)
    with pytest.raises(StoreError, match="not a vectorid store"):
        Store.open(junk)


def test_truncated_store_is_reported_not_crashing(tmp_path, spec):
    path = tmp_path / "s.db"
    with Store.create(path, spec) as st:
        for i in range(20):
            st.write_batch(0, i * 100, *batch(100, seed=i))
    # checkpoint the WAL into the main file, then cut the file in half
    con = sqlite3.connect(path)
    con.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    con.close()
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(StoreError):
        with Store.open(path) as st:
            st.load()


def test_read_only_store_can_be_read_not_written(tmp_path, spec):
    path = tmp_path / "ro" / "s.db"
    with Store.create(path, spec) as st:
        st.write_batch(0, 0, *batch(8))
    os.chmod(path, 0o444)
    os.chmod(path.parent, 0o555)
    try:
        if os.access(path, os.W_OK):
            pytest.skip("running as a user that ignores permissions")
        with pytest.raises(StoreError, match="read-only"):
            Store.open(path, write=True)
    finally:
        os.chmod(path.parent, 0o755)
        os.chmod(path, 0o644)


def test_second_writer_gets_clear_error(tmp_path, spec):
    path = tmp_path / "s.db"
    Store.create(path, spec).close()
    holder = subprocess.Popen(
        [
            sys.executable,
            "-c",
            textwrap.dedent(f"""
            import sys, time
            from vectorid.store import Store
            st = Store.open({str(path)!r}, write=True)
            print("locked", flush=True)
            time.sleep(30)
        """),
        ],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert holder.stdout.readline().strip() == "locked"
        with pytest.raises(StoreLockedError, match=r"being written by another process \(pid"):
            Store.open(path, write=True)
        # readers are never blocked
        with Store.open(path) as st:
            assert st.count() == 0
    finally:
        holder.kill()
        holder.wait()
    # a killed writer leaves no stale lock
    Store.open(path, write=True).close()
