"""Identifiability verdicts on known answers, and the `vectorid identifiability` verb."""

from __future__ import annotations

import json
import textwrap

import pytest

from vectorid import Study
from vectorid.analysis import identifiability, verdicts_json
from vectorid.cli import main
from vectorid.spec import load_study

# x1 is pinned by f1 (|x1 - 0.4| <= 0.1 under f1 <= 1: 20 % of its box), x3 only loosely by
# f2 ((x3 - 0.5)^2 <= 0.09: 60 %), x4 by f3 against the box's low edge (x4 <= 0.1), and no
# criterion depends on x2.
MODEL = """
import numpy as np


def evaluate(X):
    f1 = 100.0 * (X[:, 0] - 0.4) ** 2
    f2 = (X[:, 2] - 0.5) ** 2
    f3 = X[:, 3]
    return np.column_stack([f1, f2, f3])
"""

STUDY = """
[study]
name = "known"
model = "knownmodel:evaluate"
trials = 4096
seed = 1

[[variables]]
name = "x1"
low = 0.0
high = 1.0

[[variables]]
name = "x2"
low = 0.0
high = 1.0
unit = "m"

[[variables]]
name = "x3"
low = 0.0
high = 1.0

[[variables]]
name = "x4"
low = 0.0
high = 1.0

[[criteria]]
name = "f1"
limit = 1.0

[[criteria]]
name = "f2"
limit = 0.09
role = "pseudo"

[[criteria]]
name = "f3"
limit = 0.1
role = "pseudo"
"""


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    folder = tmp_path_factory.mktemp("known")
    (folder / "knownmodel.py").write_text(textwrap.dedent(MODEL), encoding="utf-8")
    (folder / "known.toml").write_text(STUDY, encoding="utf-8")
    path = folder / "known.db"
    with Study.create(load_study(folder / "known.toml"), path) as st:
        st.run(executor="serial")
    return path


def _verdicts(store, **kw):
    with Study.open(store) as st:
        a = st.analysis(kw.pop("limits", None))
        return {v.name: v for v in identifiability(a, **kw)}


def test_known_answers(store):
    v = _verdicts(store, meanings={"x1": "the pinned one"})
    assert v["x1"].verdict == "identified"
    assert v["x1"].constrained_by == ["f1"]
    lo, hi = v["x1"].feasible
    assert 0.29 < lo < 0.31 and 0.49 < hi < 0.51
    assert v["x1"].label() == "x1 (the pinned one)"
    # no criterion depends on x2: D covers its box, nothing cuts it
    assert v["x2"].verdict == "not identified" and v["x2"].constrained_by == []
    assert v["x2"].width > 0.95 and "add a criterion sensitive to x2" in v["x2"].suggestion
    # loosely determined: weak, cut by f2
    assert v["x3"].verdict == "weak" and v["x3"].constrained_by == ["f2"]
    # narrow but against the box's edge: the data may allow values beyond it
    assert v["x4"].verdict == "weak" and "low edge" in v["x4"].reason
    assert "widen the box of x4" in v["x4"].suggestion


def test_value_text_never_shows_a_value_for_what_is_not_identified(store):
    v = _verdicts(store)
    assert v["x1"].value_text(0.4012).startswith("0.4012 (feasible [0.3")
    text = v["x2"].value_text(0.77)
    assert "0.77" not in text and text.endswith("(not identified)") and " m " in text + " "


def test_without_limits_or_with_an_empty_set(store):
    v = _verdicts(store, limits={"f1": None, "f2": None, "f3": None})
    assert all(x.verdict == "not identified" for x in v.values())
    assert "no criteria constraint is in force" in v["x1"].reason
    v = _verdicts(store, limits={"f1": -1.0})
    assert all(x.verdict == "not identified" and x.feasible is None for x in v.values())
    assert "D is empty" in v["x1"].reason


def test_thresholds_and_reference_box(store):
    v = _verdicts(store, identified=0.1, weak=0.5)
    assert v["x1"].verdict == "weak" and v["x3"].verdict == "not identified"
    # judged against a wider box it was first given (an earlier step's), x3 is identified
    v = _verdicts(store, reference={"x3": (-3.0, 3.0)})
    assert v["x3"].verdict == "identified" and v["x3"].box == (-3.0, 3.0)


def test_cli_identifiability(store, capsys):
    assert main(["identifiability", str(store), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    rows = {p["name"]: p for p in doc["parameters"]}
    assert set(rows) == {"x1", "x2", "x3", "x4"}
    for p in rows.values():
        assert {"name", "verdict", "feasible", "pareto", "box", "constrained_by"} <= set(p)
    assert rows["x1"]["verdict"] == "identified" and rows["x1"]["constrained_by"] == ["f1"]
    assert rows["x2"]["box"] == [0.0, 1.0]
    assert main(["identifiability", str(store), "--limit", "f1<=25"]) == 0
    out = capsys.readouterr().out
    # f1 <= 25 lets x1 spread over 90 % of its box, and the header says the bound is this run's
    assert "x1\n  verdict      not identified" in out and "f1 <= 25   (--limit)" in out
    assert main(["identifiability", str(store), "--identified", "0.9", "--weak", "0.1"]) == 2
    assert "--identified/--weak" in capsys.readouterr().err


def test_verdicts_json_shape(store):
    with Study.open(store) as st:
        doc = verdicts_json(identifiability(st.analysis()))
    assert json.loads(json.dumps(doc))["parameters"][0]["name"] == "x1"


def test_ranges_in_one_pass_equal_the_ranges_column_by_column():
    """The ranges per variable over a set of trials (computed for every variable at once)
    are those of each column's finite values, NaN where a column has none."""
    import numpy as np

    from vectorid.analysis.identifiability import _col_ranges

    rng = np.random.default_rng(3)
    X = rng.normal(size=(500, 4))
    X[rng.random(500) < 0.1, 1] = np.nan
    X[:7, 2] = np.inf
    X[:, 3] = np.nan
    for mask in (rng.random(500) < 0.3, np.zeros(500, bool), np.ones(500, bool)):
        lo, hi = _col_ranges(np.ascontiguousarray(X.T), mask)
        for j in range(4):
            col = X[mask, j]
            col = col[np.isfinite(col)]
            if col.size:
                assert (lo[j], hi[j]) == (col.min(), col.max())
            else:
                assert np.isnan(lo[j]) and np.isnan(hi[j])


def test_constraints_that_cut_a_range_follow_the_rule_and_columns_change_nothing(store):
    """ "cut by" lists exactly the constraints without which a variable's range would widen
    by more than a quarter of D's width and 2 % of the box (checked here the long way, one
    set of trials per constraint), under several constraint sets; handing the transposed
    trials in gives the same verdicts."""
    import numpy as np

    with Study.open(store) as st:
        for limits in (None, {"f1": 4.0}, {"f2": 0.2, "f3": 0.5}, {"f1": 0.5, "f3": 0.05}):
            a = st.analysis(limits)
            vs = identifiability(a)
            X = a.trials.X
            masks = {(b.name, b.side): a._bound_mask(b.name, b.side) for b in a.active_bounds()}
            for j, v in enumerate(vs):
                W = v.box[1] - v.box[0]
                wD = v.feasible[1] - v.feasible[0]
                cut = []
                for key in masks:
                    m = a.ok.copy()
                    for other, mk in masks.items():
                        if other != key:
                            m &= mk
                    col = X[m, j]
                    if np.ptp(col) - wD > max(0.25 * wD, 0.02 * W) and key[0] not in cut:
                        cut.append(key[0])
                assert v.constrained_by == cut, (limits, v.name)
            cols = np.ascontiguousarray(X.T)
            assert [w.to_dict() for w in identifiability(a, columns=cols)] == [
                w.to_dict() for w in vs
            ]


def test_a_thin_feasible_set_is_said_and_never_identified(store, capsys):
    # f1 <= 0.01 pins x1 to |x1 - 0.4| <= 0.01: with f2 and f3, a handful of the 4096 trials
    v = _verdicts(store, limits={"f1": 0.01})
    nd = v["x1"].n_feasible
    assert 0 < nd < 10 and v["x1"].thin and v["x1"].n_needed == 10  # max(10, 2p + 1), p = 4
    assert v["x1"].width <= 0.25  # narrow, yet from too few members to show a spread
    assert v["x1"].verdict == "weak"
    assert f"D holds only {nd} trials, fewer than the 10 needed" in v["x1"].reason
    assert 'sampler = "sequential"' in v["x1"].suggestion and "--trials" in v["x1"].suggestion
    assert all(x.thin for x in v.values())
    # enough members: not thin; a larger threshold makes the same set thin
    v = _verdicts(store)
    assert not v["x1"].thin and v["x1"].n_feasible >= 10
    assert _verdicts(store, min_feasible=10**6)["x1"].verdict == "weak"
    assert main(["identifiability", str(store), "--limit", "f1<=0.01"]) == 0
    out = capsys.readouterr().out
    assert f"thin: D holds {nd} trials, fewer than the 10" in out
    assert main(["identifiability", str(store), "--limit", "f1<=0.01", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert all(p["thin"] and p["n_needed"] == 10 for p in doc["parameters"])
