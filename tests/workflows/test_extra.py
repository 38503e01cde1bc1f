"""Extra runs (sections, robustness checks, refined stages) are written by vectorid.workflows.extra
alone: analysis/ only reads."""

import ast
from pathlib import Path

import numpy as np
import pytest

from tests.analysis_helpers import make_store
from vectorid import Study
from vectorid.analysis.refine import propose_refine
from vectorid.errors import StoreError
from vectorid.workflows.extra import apply_refine, evaluate_and_store, run_section

ANALYSIS = Path(__file__).resolve().parents[2] / "src" / "vectorid" / "analysis"


def test_analysis_never_writes_the_store():
    writers = {"write_batch", "add_stage", "set_limits", "evaluate", "problem"}
    for f in ANALYSIS.glob("*.py"):
        tree = ast.parse(f.read_text())
        called = {
            n.func.attr
            for n in ast.walk(tree)
            if isinstance(n, ast.Call) and isinstance(n.func, ast.Attribute)
        }
        assert not (called & writers), f"{f.name} calls {sorted(called & writers)}"


def test_evaluate_and_store_refuses_a_read_only_store(tmp_path):
    path = make_store(tmp_path, trials=16)
    with Study.open(path) as st:
        with pytest.raises(StoreError, match="read-only"):
            evaluate_and_store(st.store, 0, np.zeros((1, 2)))


def test_refined_stage_then_section_append_without_touching_the_sample(tmp_path):
    path = make_store(tmp_path, trials=64)
    with Study.open(path, write=True) as st:
        before = st.store.load()
        stage = apply_refine(st.store, propose_refine(st.analysis(), st.store.stages()))
        assert stage.kind == "sample" and stage.start_seq == 64
        sec = run_section(st.store, int(before.id[0]), "x1", points=5)
        after = st.store.load()
    np.testing.assert_array_equal(after.id, before.id)
    assert len(sec.values) >= 5 and sec.stage > stage.stage
