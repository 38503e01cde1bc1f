"""Problem builders registered by kind: the core asks the registry, never names a plug-in."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

from vectorid import Criterion, Problem, StudyDefinitionError, StudySpec
from vectorid.builders import (
    build_problem,
    data_files,
    kind_of,
    register_problem_builder,
    table_kinds,
)
from vectorid.space import Continuous

SRC = Path(__file__).parents[1] / "src" / "vectorid"


def spec(model="binh-korn", **extra):
    return StudySpec(
        name="t",
        model=model,
        space=[Continuous("x1", 0, 5), Continuous("x2", 0, 3)],
        criteria=(Criterion("f1"), Criterion("f2")),
        extra=extra,
    )


def test_kinds():
    assert kind_of(spec()) == "python"
    assert kind_of(spec("mymod:f")) == "python"
    assert kind_of(spec("cmd:python sim.py")) == "cmd"
    assert kind_of(spec("fmu:plant.fmu")) == "fmu"
    assert kind_of(spec(identification={"drops": []})) == "identification"
    assert "identification" in table_kinds()


def test_a_registered_kind_builds_its_problem_and_names_its_files(tmp_path):
    coeffs = tmp_path / "coeffs.txt"
    coeffs.write_text("2.0 3.0\n")

    def build(s):
        a, b = np.loadtxt(Path(s.model.partition(":")[2]))
        return Problem(lambda X: np.column_stack([a * X[:, 0], b * X[:, 1]]), s.criteria)

    register_problem_builder(
        "linear-test", build, data_files=lambda s: {"study.model": Path(s.model[12:])}
    )
    s = spec(f"linear-test:{coeffs}")
    assert kind_of(s) == "linear-test"
    res = build_problem(s).evaluate(np.array([[1.0, 1.0]]))
    np.testing.assert_array_equal(res.criteria, [[2.0, 3.0]])
    assert data_files(s) == {"study.model": coeffs}


def test_a_registered_table_is_accepted_by_the_parser():
    def build(s):
        return Problem(lambda X: X[:, :2], s.criteria)

    register_problem_builder("campaign-test", build, table=True)
    data = spec().to_dict()
    data["campaign-test"] = {"runs": 3}
    s = StudySpec.from_dict(data)
    assert kind_of(s) == "campaign-test"
    data["campaing-test"] = {}
    with pytest.raises(StudyDefinitionError, match="did you mean 'campaign-test'"):
        StudySpec.from_dict(data)


def test_bad_kind_names():
    with pytest.raises(ValueError, match="without ':'"):
        register_problem_builder("a:b", lambda s: None)


def test_the_core_never_imports_a_plug_in():
    """spec.py, problem.py and the store name neither identify nor external."""
    for path in (SRC / "spec.py", SRC / "problem.py", *(SRC / "store").glob("*.py")):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module:
                assert "identify" not in node.module and "external" not in node.module, path
            if isinstance(node, ast.Import):
                for alias in node.names:
                    assert "identify" not in alias.name and "external" not in alias.name, path


def test_identification_names_its_data_files(tmp_path):
    ident = {
        "drops": [
            {"name": "a", "file": "a.csv", "wind": "w.txt"},
            {"name": "b", "files": [{"file": "b1.csv"}, {"file": "/abs/b2.csv"}]},
        ]
    }
    s = StudySpec(
        name="t",
        model="parachute6dof",
        space=[Continuous("x6", 0, 0.6)],
        criteria=(Criterion("pos_h_abs"),),
        base_dir=str(tmp_path),
        extra={"identification": ident},
    )
    assert data_files(s) == {
        "identification.drops[0].file": tmp_path / "a.csv",
        "identification.drops[0].wind": tmp_path / "w.txt",
        "identification.drops[1].files[0].file": tmp_path / "b1.csv",
        "identification.drops[1].files[1].file": Path("/abs/b2.csv"),
    }
