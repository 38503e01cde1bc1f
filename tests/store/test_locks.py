"""The writer lock holds no descriptor once nothing of this process uses the store (a remount
read-only, an unmount, thousands of stores in one process all work)."""

from __future__ import annotations

import os

from vectorid import Study, load_study
from vectorid.store import Store


def _fds() -> int:
    return len(os.listdir("/proc/self/fd"))


def test_no_descriptor_left_open(tmp_path, user_study):
    spec = load_study(user_study)
    before = _fds()
    for i in range(30):
        path = tmp_path / f"s{i}.db"
        Study.create(spec, path).close()
        with Store.open(path, write=True), Store.open(path):
            pass
        with Store.open(path):
            pass
    assert _fds() <= before + 1


def test_reader_open_while_writer_closes_keeps_working(tmp_path, user_study):
    spec = load_study(user_study)
    path = tmp_path / "s.db"
    with Study.create(spec, path) as st:
        st.run(trials=32, executor="serial")
    reader = Store.open(path)
    with Store.open(path, write=True) as writer:
        writer.set_target(40)
    assert len(reader.load()) == 32  # the reader's connection outlived the writer's lock
    reader.close()
