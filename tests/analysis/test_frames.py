"""The notebook API of an Analysis: named columns, pandas frames with the set flags, the
constraints in force with their sources, and the verdicts as a frame."""

from __future__ import annotations

import sys

import numpy as np
import pandas as pd
import pytest

from vectorid import Analysis, StudySpec, Trials


def make(limit_source: str = "", cons=({"name": "g", "high": 1.0, "unit": "m"},)):
    """Seven trials over (a, feasible): a variable named like a flag column on purpose."""
    F = np.array([[1, 5], [2, 2], [3, 1], [2, 3], [np.nan, np.nan], [0.5, 9], [4, 4]], float)
    G = np.array([[0], [0], [0], [0], [np.nan], [2], [0]], float)
    crit = [
        {"name": "f1", "unit": "m/s"},
        {"name": "f2", "limit": 4.5, "unit": "s",
         **({"limit_source": limit_source} if limit_source else {})},
    ]  # fmt: skip
    spec = StudySpec.from_dict(
        {
            "study": {"name": "t", "model": "binh-korn"},
            "variables": [
                {"name": "a", "low": 0.0, "high": 1.0, "unit": "kg"},
                {"name": "feasible", "low": 0.0, "high": 1.0},
            ],
            "criteria": crit,
            "constraints": list(cons),
        }
    )
    n = len(F)
    status = np.array([0, 0, 0, 0, 1, 0, 0], np.int8)
    X = np.column_stack([np.linspace(0.05, 0.95, n), np.linspace(0.9, 0.1, n)])
    t = Trials(np.arange(1, n + 1), np.arange(n), np.zeros(n, int), status, X, F, G,
               np.full(n, 0.01), {(0, 4): "model raised ValueError: boom"})  # fmt: skip
    return spec, t


def test_columns_hold_the_trials_and_the_flags_of_the_analysis():
    spec, t = make()
    a = Analysis(spec, t)
    cols = a.columns()
    assert list(cols) == [
        "id", "seq", "stage", "status", "message", "wall_time",
        "a", "parameter:feasible", "f1", "f2", "g",
        "functional_ok", "feasible", "pareto",
    ]  # fmt: skip
    np.testing.assert_array_equal(cols["feasible"], a.feasible)
    np.testing.assert_array_equal(cols["pareto"], a.pareto)
    np.testing.assert_array_equal(cols["parameter:feasible"], t.X[:, 1])
    assert cols["status"].tolist()[3:5] == ["ok", "failed"]
    assert cols["message"][4] == "model raised ValueError: boom" and cols["message"][0] == ""
    # the flags follow the limits given to the analysis
    b = Analysis(spec, t, limits={"f2": None, "g": (None, 5.0)})
    assert b.columns()["feasible"].sum() == b.n_feasible == 6


def test_to_frame_has_flags_units_and_the_constraints():
    spec, t = make()
    a = Analysis(spec, t, limits={"f1": 3.0})
    df = a.to_frame()
    assert isinstance(df, pd.DataFrame) and len(df) == a.n
    assert df["feasible"].dtype == bool and df["pareto"].sum() == a.n_pareto
    np.testing.assert_array_equal(df.loc[df["pareto"], "id"], t.id[a.pareto])
    np.testing.assert_allclose(df.loc[df["feasible"], ["f1", "f2"]], t.F[a.feasible])
    assert df.attrs["units"] == {"wall_time": "s", "a": "kg", "f1": "m/s", "f2": "s", "g": "m"}
    assert df.attrs["constraints"] == a.constraints_in_force()


def test_constraints_in_force_say_where_each_limit_came_from():
    spec, t = make(limit_source="noise")
    rows = Analysis(spec, t).constraints_in_force()
    assert [(r["name"], r["bound"], r["value"], r["unit"], r["source"]) for r in rows] == [
        ("g", "<=", 1.0, "m", "study"),
        ("f2", "<=", 4.5, "s", "noise"),
    ]
    rows = Analysis(spec, t, limits={"f1": 3.0, "g": (-1.0, 1.0)}).constraints_in_force()
    got = {(r["name"], r["bound"]): r["source"] for r in rows}
    assert got == {("g", ">="): "analysis", ("g", "<="): "study", ("f2", "<="): "noise",
                   ("f1", "<="): "analysis"}  # fmt: skip
    spec, t = make()  # a number in the study file is the expert's
    rows = Analysis(spec, t, limits={"f2": 4.0}).constraints_in_force()
    assert [r["source"] for r in rows if r["name"] == "f2"] == ["analysis"]
    assert [r["source"] for r in Analysis(spec, t).constraints_in_force()] == ["study", "expert"]


def test_verdicts_frame_is_the_verdicts():
    spec, t = make()
    a = Analysis(spec, t)
    verdicts = a.verdicts()
    vf = a.verdicts_frame()
    assert list(vf.index) == ["a", "feasible"] == [v.name for v in verdicts]
    for v in verdicts:
        row = vf.loc[v.name]
        assert row["verdict"] == v.verdict and row["n_feasible"] == v.n_feasible == a.n_feasible
        assert (row["feasible_low"], row["feasible_high"]) == v.feasible
        assert (row["box_low"], row["box_high"]) == v.box
    assert vf.loc["a", "unit"] == "kg"
    vc = a.verdict_columns()
    assert vc["name"].tolist() == ["a", "feasible"]
    np.testing.assert_array_equal(vc["feasible_low"], vf["feasible_low"].to_numpy())
    assert vc["verdict"].tolist() == vf["verdict"].tolist()
    # thresholds reach the verdicts
    loose = a.verdicts_frame(identified=1.0, weak=1.0, min_feasible=1)
    assert set(loose["verdict"]) <= {"identified", "weak"}


def test_frames_without_pandas_say_how_to_install_it(monkeypatch):
    spec, t = make()
    a = Analysis(spec, t)
    monkeypatch.setitem(sys.modules, "pandas", None)  # import pandas raises ImportError
    with pytest.raises(ImportError, match=r"pip install .*\[pandas\]"):
        a.to_frame()
    assert a.columns()["feasible"].dtype == bool  # the arrays need nothing more
