"""The browser UI's callbacks as plain functions (no browser): counts, tables, selection,
box-to-constraints, functional-constraint bounds, the chosen trial, refine, overview, input
validation, the trial cache, the background jobs and saving the constraints with the
study."""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("plotly", reason="the UI needs plotly")

from tests.analysis_helpers import make_store
from tests.conftest import write_user_study
from vectorid import Study
from vectorid.analysis import Analysis
from vectorid.analysis.sections import load_sections
from vectorid.errors import StudyDefinitionError
from vectorid.spec import load_study
from vectorid.store import Store
from vectorid.views.ui import callbacks as cb
from vectorid.views.ui.data import (
    StoreCache,
    bounds_text,
    limits_text,
    parse_constraints,
    parse_number,
    parse_trial_id,
)
from vectorid.views.ui.jobs import JobBusy, JobManager, run_job

PURE2 = ["pure", "pure"]


def _fig(d):
    """A figure the UI sends as a plain dict (base64 arrays), as a go.Figure to inspect."""
    import plotly.graph_objects as go

    return go.Figure(d)


def _arr(v):
    """An array of a figure: plain, or plotly.js's base64 typed-array spec."""
    import base64

    if isinstance(v, dict) and "bdata" in v:
        dt = {"f4": np.float32, "i4": np.int32, "i1": np.int8, "u1": np.uint8}[v["dtype"]]
        return np.frombuffer(base64.b64decode(v["bdata"]), dtype=dt)
    return np.asarray(v)


STUDY_G = [["", "25"], ["7.7", ""]]  # binh-korn's own functional bounds as the fields show them


def _ctx(path: Path, executor: str = "serial") -> cb.UIContext:
    cache = StoreCache(path)
    jobs = JobManager(path, executor=executor, progress_of=lambda: cache.version()[0])
    return cb.UIContext(cache=cache, jobs=jobs, max_points=300, panel_points=100)


@pytest.fixture(scope="module")
def bk(tmp_path_factory) -> Path:
    return make_store(tmp_path_factory.mktemp("uicb"), "binh-korn", trials=512)


@pytest.fixture(scope="module")
def bkmax(tmp_path_factory) -> Path:
    return make_store(tmp_path_factory.mktemp("uicbmax"), "binh-korn-max", trials=256)


@pytest.fixture
def ctx(bk):
    c = _ctx(bk)
    yield c
    c.jobs.shutdown()


def _direct(path: Path, limits=None, roles=None) -> Analysis:
    with Study.open(path) as st:
        return st.analysis(limits, roles)


# -- parsing --------------------------------------------------------------------------------------


def test_parse_number_accepts_numbers_and_rejects_text():
    assert parse_number(" 40.5 ", "f") == 40.5
    assert parse_number(3, "f") == 3.0
    assert parse_number("", "f") is None and parse_number(None, "f") is None
    assert parse_number("inf", "f") is None  # removes the bound, as --limit 'f1<=inf'
    for bad in ("abc", "1,5", "nan", "x" * 100, True):
        with pytest.raises(StudyDefinitionError, match="expected a number|NaN"):
            parse_number(bad, "constraint on f1")
    with pytest.raises(StudyDefinitionError, match="empty"):
        parse_number("", "points", allow_empty=False)


def test_parse_trial_id():
    assert parse_trial_id("110") == 110 and parse_trial_id(7.0) == 7
    for bad in ("abc", "1.5", "0", "-3", "", None, "9" * 30, "__import__('os')"):
        with pytest.raises(StudyDefinitionError):
            parse_trial_id(bad)


def test_parse_constraints_keeps_study_limit_for_bad_field(bk):
    spec = Store.open(bk).spec
    c = parse_constraints(spec, ["oops", "20"], PURE2)
    assert c.limits == {"f2": 20.0} and set(c.errors) == {"f1"}
    assert "expected a number" in c.messages[0] and "ignored" in c.messages[0]
    with pytest.raises(StudyDefinitionError, match="pure"):
        parse_constraints(spec, ["", ""], ["pure", "exec"])
    with pytest.raises(StudyDefinitionError, match="expected 2 fields"):
        parse_constraints(spec, ["1"], PURE2)


def test_parse_constraints_functional_bounds(bk):
    spec = Store.open(bk).spec
    c = parse_constraints(spec, ["", ""], PURE2, [["", "20"], ["7.7", ""]])
    assert c.functional == {"g1": (None, 20.0), "g2": (7.7, None)} and not c.errors
    assert c.overrides == {"f1": None, "f2": None, "g1": (None, 20.0), "g2": (7.7, None)}
    # bad text: that side keeps the study's bound, with a message naming the field
    c = parse_constraints(spec, ["", ""], PURE2, [["-1", "lots"], ["", ""]])
    assert c.functional == {"g1": (-1.0, 25.0), "g2": (None, None)}
    assert set(c.errors) == {"g1.high"} and "'lots'" in c.messages[0]
    assert "high bound of g1" in c.messages[0] and "ignored" in c.messages[0]
    # low > high: both fields marked, one message, the study's pair kept
    c = parse_constraints(spec, ["", ""], PURE2, [["30", "20"], ["", ""]])
    assert set(c.errors) == {"g1.low", "g1.high"} and len(c.messages) == 1
    assert "low <= high" in c.messages[0] and c.functional["g1"] == (None, 25.0)
    # None keeps the study's bounds; a wrong shape is an error
    assert parse_constraints(spec, ["", ""], PURE2).functional == {}
    with pytest.raises(StudyDefinitionError, match="expected 2 pairs"):
        parse_constraints(spec, ["", ""], PURE2, [["", ""]])
    assert bounds_text(spec) == [("", "25"), ("7.7", "")]


# -- counts and tables ----------------------------------------------------------------------------


def test_summary_counts_match_analysis(ctx, bk):
    for texts, roles, limits, rd in (
        (["", ""], PURE2, {"f1": None, "f2": None}, None),
        (["20", "30"], PURE2, {"f1": 20.0, "f2": 30.0}, None),
        (["40", ""], ["pure", "pseudo"], {"f1": 40.0}, {"f2": "pseudo"}),
    ):
        s = cb.summary_view(ctx, texts, roles)
        a = _direct(bk, limits, rd)
        assert s["counts"] == {
            "n": a.n,
            "nd": a.n_feasible,
            "np": a.n_pareto,
            "failed": a.n_failed,
            "functional": a.n_functional,
        }
    # the constraint tightens: ND falls
    wide = cb.summary_view(ctx, ["", ""], PURE2)["counts"]["nd"]
    tight = cb.summary_view(ctx, ["10", ""], PURE2)["counts"]["nd"]
    assert 0 < tight < wide


def test_summary_bad_text_is_a_message_not_an_error(ctx, bk):
    s = cb.summary_view(ctx, ["twenty", "30"], PURE2)
    assert s["invalid"] == [True, False]
    assert any("'twenty'" in m for m in s["messages"])
    assert s["counts"]["nd"] == _direct(bk, {"f2": 30.0}).n_feasible


def test_test_tables_best_first_with_infeasible_marked(ctx, bk):
    s = cb.summary_view(ctx, ["15", ""], PURE2)
    a = _direct(bk, {"f1": 15.0})
    data, styles = s["table"]["data"], s["table"]["styles"]
    assert len(data) == ctx.table_rows
    t = a.test_table("f2")
    assert [r["c1_id"] for r in data] == [int(i) for i in t.ids[: len(data)]]
    v = [r["c1_v"] for r in data]
    assert v == sorted(v)
    red, blue = set(), set()
    for st in styles:
        if st["if"]["column_id"] == "c1_v":
            (red if st["color"] == "#d62728" else blue).update(st["if"]["row_index"])
    assert red == {i for i in range(len(data)) if not t.feasible[i]} and red
    assert blue == set(range(len(data))) - red
    blue0 = set()  # f1's best trials meet f1 <= 15: feasible rows are blue
    for st in styles:
        if st["if"]["column_id"] == "c0_v" and st["color"] == "#1f77b4":
            blue0.update(st["if"]["row_index"])
    t0 = a.test_table("f1")
    assert blue0 == {i for i in range(len(data)) if t0.feasible[i]} and blue0


def test_functional_bounds_update_counts_and_tables(ctx, bk):
    base = cb.summary_view(ctx, ["", ""], PURE2, STUDY_G)
    assert base["counts"] == cb.summary_view(ctx, ["", ""], PURE2)["counts"]
    s = cb.summary_view(ctx, ["40", ""], PURE2, [["", "10"], ["7.7", ""]])
    a = _direct(bk, {"f1": 40.0, "g1": (None, 10.0), "g2": (7.7, None)})
    assert s["counts"] == {
        "n": a.n,
        "nd": a.n_feasible,
        "np": a.n_pareto,
        "failed": a.n_failed,
        "functional": a.n_functional,
    }
    assert a.n_functional < base["counts"]["functional"]
    assert s["invalid_functional"] == [[False, False], [False, False]]
    assert "g1 <= 10" in s["in_force"]
    # the test tables list only the trials meeting the new functional bounds, best first
    t = a.test_table("f1")
    rows = s["table"]["data"]
    assert [r["c0_id"] for r in rows if "c0_id" in r] == [int(i) for i in t.ids[: len(rows)]]
    g1 = dict(zip(a.trials.id.tolist(), a.trials.G[:, 0]))
    assert all(g1[r["c0_id"]] <= 10 for r in rows if "c0_id" in r)
    # back to the study's bounds: the cached tables of the study are used again
    assert cb.summary_view(ctx, ["", ""], PURE2, STUDY_G)["table"] == base["table"]
    # bad text: marked, a message, the study's bound used meanwhile
    s = cb.summary_view(ctx, ["", ""], PURE2, [["", "ten"], ["7.7", ""]])
    assert s["invalid_functional"] == [[False, True], [False, False]]
    assert any("'ten'" in m for m in s["messages"])
    assert s["counts"] == base["counts"]


def test_functional_bounds_reach_every_view(ctx, bk):
    g = [["", "10"], ["7.7", ""]]
    a = _direct(bk, {"g1": (None, 10.0)})
    fig, _ = cb.scatter_view(ctx, ["", ""], PURE2, "f1", "f2", None, None, functional=g)
    fig = _fig(fig)
    green = [t for t in fig.data if (t.meta or {}).get("class") == "pareto"]
    assert sum(len(_arr(t.x)) for t in green) == a.n_pareto
    tid = int(a.trials.id[np.flatnonzero(a.trials.G[:, 0] > 10)[0]])
    v = cb.trial_view(ctx, str(tid), ["", ""], PURE2, g)
    assert v["summary"].startswith(f"trial {tid}: infeasible")
    assert [r["meets"] for r in v["criteria"] if r["name"] == "g1"] == ["no"]
    r = cb.refine_view(ctx, ["", ""], PURE2, "feasible", "0.05", "0.1", g)
    assert f"of {a.n_feasible} feasible trials" in r["summary"]


def test_empty_d_is_diagnosed(ctx):
    s = cb.summary_view(ctx, ["0.001", "0.001"], PURE2)
    assert s["counts"]["nd"] == 0
    assert any("empty" in m for m in s["messages"])


def test_trial_table_sorts_filters_and_pages_over_all_trials(ctx, bk):
    a = _direct(bk, {"f1": 50.0})
    # sorted by f2 over the whole feasible set (not only the rows shown)
    p = cb.table_page(
        ctx,
        ["50", ""],
        PURE2,
        None,
        "feasible",
        None,
        0,
        5,
        "",
        [{"column_id": "f2", "direction": "asc"}],
    )
    f2 = a.trials.F[a.feasible, 1]
    assert p["total"] == a.n_feasible and len(p["data"]) == 5
    assert p["data"][0]["f2"] == float(f"{f2.min():.5g}")
    assert [r["f2"] for r in p["data"]] == sorted(r["f2"] for r in p["data"])
    # descending, second page
    p2 = cb.table_page(
        ctx,
        ["50", ""],
        PURE2,
        None,
        "feasible",
        None,
        1,
        5,
        "",
        [{"column_id": "f2", "direction": "desc"}],
    )
    want = np.sort(f2)[::-1][5:10]
    assert [r["f2"] for r in p2["data"]] == [float(f"{v:.5g}") for v in want]
    # a filter typed in a header cell, resolved over every trial of the set
    p3 = cb.table_page(
        ctx, ["50", ""], PURE2, None, "all", None, 0, 25, "{x1} s< 1 && {f1} >= 10", []
    )
    X, F = a.trials.X, a.trials.F
    with np.errstate(invalid="ignore"):
        assert p3["total"] == int(((X[:, 0] < 1) & (F[:, 0] >= 10)).sum()) > 0
    # default order: Pareto first; rows carry their set for the colours
    p4 = cb.table_page(ctx, ["50", ""], PURE2, None, "feasible", None, 0, 500, "", [])
    sets = [r["set"] for r in p4["data"]]
    assert sets[: a.n_pareto] == ["Pareto"] * a.n_pareto
    assert set(sets[a.n_pareto :]) <= {"feasible"}
    with pytest.raises(StudyDefinitionError, match="cannot read"):
        cb.table_page(ctx, ["", ""], PURE2, None, "all", None, 0, 5, "{x1} ~~ 3", [])
    # the CSV holds every filtered row at full precision, with a units line
    text = "".join(
        cb.csv_rows(
            ctx,
            ["50", ""],
            PURE2,
            None,
            "feasible",
            None,
            "",
            [{"column_id": "f2", "direction": "asc"}],
        )
    )
    lines = text.strip().splitlines()
    assert lines[0].startswith("id,set,stage,f1,f2") and len(lines) == 2 + a.n_feasible
    assert float(lines[2].split(",")[4]) == f2.min()


def test_parallel_brushes_are_two_sided_selections_made_constraints_on_request(ctx, bk):
    p = cb.parallel_view(ctx, ["40", ""], PURE2)
    names = [ax["name"] for ax in p["axes"]]
    assert sorted(names) == sorted(["f1", "f2", "g1", "g2", "x1", "x2"])
    assert names[:4] == ["f1", "f2", "g1", "g2"]  # criteria, functionals, then the gains
    assert p["ranges"] == {}  # constraints are not brushes here: they are marked as limits
    by = {ax["name"]: ax for ax in p["axes"]}
    assert by["f1"]["limit"] == ["<=", 40.0] and by["f2"]["limit"] is None
    assert by["g1"]["limit"][0] == "in"
    # every title says its unit (binh-korn gives none: it says so), the hover its kind
    assert all(ax["title"] == f"{ax['name']} [no unit given]" for ax in p["axes"])
    assert by["f1"]["tip"].startswith("f1 [no unit given] — criterion (min, pure)")
    # the lines go to the page's own canvas: float32 per axis, thinned per set
    lines = p["lines"]
    shown = sum(p["shown"].values())
    assert set(lines["values"]) == set(names) and lines["mode"] == "set"
    assert all(len(_arr(v)) == shown for v in lines["values"].values())
    assert sorted(set(_arr(lines["color"]).tolist())) <= [0, 1, 2]
    # two ranges on f2 (both edges kept, not snapped to an end) and one on x1: a selection
    sel = {"kind": "ranges", "ranges": {"f2": [[5.0, 12.0], [20.0, 30.0]], "x1": [[1, 2]]}}
    a = _direct(bk, {"f1": 40.0})
    m = cb.selection_mask(ctx, a, sel)
    f2, x1 = a.trials.F[:, 1], a.trials.X[:, 0]
    want = (((f2 >= 5) & (f2 <= 12)) | ((f2 >= 20) & (f2 <= 30))) & (x1 >= 1) & (x1 <= 2)
    assert np.array_equal(m, want) and 0 < m.sum() < a.n
    c = cb.selection_counts_view(ctx, ["40", ""], PURE2, None, sel)
    assert (c["n"], c["nd"], c["np"]) == (
        int(want.sum()),
        int((want & a.feasible).sum()),
        int((want & a.pareto).sum()),
    )
    # the brushes are drawn where they were made, on any axis, in the order left by the user
    p = cb.parallel_view(ctx, ["40", ""], PURE2, None, sel, {"order": ["x1", "f2"]})
    assert [ax["name"] for ax in p["axes"]][:3] == ["x1", "f2", "f1"]
    assert p["ranges"]["f2"] == [[5.0, 12.0], [20.0, 30.0]]
    p = cb.parallel_view(ctx, ["40", ""], PURE2, None, None, None, colour="x2", hidden=["g1"])
    by = {ax["name"]: ax for ax in p["axes"]}
    assert by["g1"]["hidden"] and not by["f1"]["hidden"]
    assert p["lines"]["mode"] == "column" and p["colour"]["name"] == "x2"
    # one explicit action makes them constraints: f2 (min) gets the upper edge of its
    # brushes, a functional both edges; a parameter stays a selection
    sel["ranges"]["g1"] = [[0.0, 10.0]]
    t, lo, hi, msg = cb.brushes_to_limits(ctx, sel, ["40", ""], ["", "7.7"], ["25", ""])
    assert t == ["40", "30"] and (lo[0], hi[0]) == ("0", "10") and "f2 <= 30" in msg
    assert (lo[1], hi[1]) == ("7.7", "")
    c = cb.counts_view(ctx, t, PURE2, [[lo[0], hi[0]], [lo[1], hi[1]]])
    d = _direct(bk, {"f1": 40.0, "f2": 30.0, "g1": (0.0, 10.0)})
    assert (c["nd"], c["np"]) == (d.n_feasible, d.n_pareto)
    with pytest.raises(StudyDefinitionError, match="no criterion or functional axis"):
        cb.brushes_to_limits(ctx, {"kind": "ranges", "ranges": {"x1": [1, 2]}}, t, lo, hi)
    with pytest.raises(StudyDefinitionError, match="expected a range"):
        cb.selection_mask(ctx, a, {"kind": "ranges", "ranges": {"x1": [["a", 2]]}})


def test_a_tightened_constraint_narrows_the_memoised_analysis(bk):
    """Tightening a limit is computed from the last D (and keeps its Pareto set when every
    Pareto trial stays); the result equals a fresh analysis every time."""
    cache = StoreCache(bk)
    roles = {"f1": "pure", "f2": "pure"}
    steps = [{"f1": None}, {"f1": 80.0}, {"f1": 40.0}, {"f1": 40.0, "f2": 30.0}]
    steps += [{"f1": 40.0, "f2": 5.0}, {"f1": 100.0}]
    from vectorid.views.ui.data import Constraints

    for limits in steps:
        got = cache.analysis(Constraints(dict(limits), roles, {}))
        want = _direct(bk, {k: v for k, v in limits.items()})
        assert np.array_equal(got.feasible, want.feasible), limits
        assert np.array_equal(got.pareto, want.pareto), limits
    # every step but the first: f1 <= 100 loosens f1 <= 40 but narrows the first (no limit)
    assert cache.narrowed == 5
    b = Analysis(cache.spec, cache.trials(), {"f1": 40.0})
    assert b.narrowed({"f1": 50.0}) is None  # looser: not a narrowing
    assert b.narrowed({"f1": 40.0}, {"f2": "pseudo"}) is None  # other roles


def test_a_loosened_constraint_widens_the_memoised_analysis(bk):
    """Loosening a limit beyond every memoised D is computed from the largest memoised D it
    holds (the trials between the old and new bounds checked), equal to a fresh analysis."""
    from vectorid.views.ui.data import Constraints

    cache = StoreCache(bk)
    roles = {"f1": "pure", "f2": "pure"}
    for limits in ({"f1": 40.0, "f2": 20.0}, {"f1": 80.0, "f2": 20.0}, {"f1": 100.0, "f2": None}):
        got = cache.analysis(Constraints(dict(limits), roles, {}))
        want = _direct(bk, limits)
        assert np.array_equal(got.feasible, want.feasible), limits
        assert np.array_equal(got.pareto, want.pareto), limits
        assert got.n_feasible > 0
    assert (cache.widened, cache.narrowed) == (2, 0)


def test_history_counts_grow_with_the_trials(ctx, bk):
    fig = _fig(cb.history_view(ctx, ["40", ""], PURE2))
    n, nd, npar = (np.asarray(t.y, float) for t in fig.data[:3])
    x = np.asarray(fig.data[0].x)
    a = _direct(bk, {"f1": 40.0})
    assert x[-1] == a.n and nd[-1] == a.n_feasible and npar[-1] == a.n_pareto
    assert np.all(np.diff(nd[np.isfinite(nd)]) >= 0)
    order = np.argsort(a.trials.id)
    k = len(x) // 2
    assert nd[k] == a.feasible[order][: int(x[k])].sum() or not np.isfinite(nd[k])


def test_history_pareto_counts_equal_a_scan_of_each_prefix(bk):
    # history() carries the last prefix's Pareto set forward instead of scanning every
    # prefix again: NP(n) must still be the Pareto set of the first n trials of D.
    from vectorid.analysis.pareto import pareto_mask
    from vectorid.views.history import history

    for limits, roles in (({"f1": 40.0}, None), (None, None), ({"f2": 20.0}, {"f2": "pseudo"})):
        a = _direct(bk, limits, roles)
        h = history(a, points=25)
        order = np.lexsort((a.trials.seq, a.trials.stage))
        F = a.trials.F[order][:, a.pure]
        feas = a.feasible[order]
        senses = [a.senses[i] for i in a.pure]
        want = [
            int(pareto_mask(F[: int(n)][feas[: int(n)]], senses).sum())
            if feas[: int(n)].any()
            else 0
            for n in h.n
        ]
        assert list(h.np_) == want and want[-1] == a.n_pareto > 0


# -- plots, selection, box to constraints ---------------------------------------------------------


def test_box_selection_covers_all_trials_not_only_drawn(ctx, bk):
    ev = {"range": {"x": [0.0, 30.0], "y": [10.0, 25.0]}, "points": []}
    spec = cb.selection_from_event(ctx, "scatter", ev, x="f1", y="f2")
    assert spec["kind"] == "box"
    a = _direct(bk)
    F = a.trials.F
    want = (F[:, 0] >= 0) & (F[:, 0] <= 30) & (F[:, 1] >= 10) & (F[:, 1] <= 25)
    assert np.array_equal(cb.selection_mask(ctx, a, spec), want) and want.sum() > 0
    fig, text = cb.scatter_view(ctx, ["", ""], PURE2, "f1", "f2", spec, None)
    fig = _fig(fig)
    sel = [t for t in fig.data if (t.meta or {}).get("class") == "selected"]
    assert sum(len(_arr(t.x)) for t in sel) == want.sum()  # max_points 300 > selection
    # the selection keeps the set colours
    assert {t.marker.color for t in sel} <= {"#d62728", "#1f77b4", "#2ca02c"}
    assert f"{int(want.sum())} trials" in text
    # drawn points are decimated to max_points, the selection still counts every trial
    for t in fig.data:
        if (t.meta or {}).get("class") in ("feasible", "pareto"):
            assert len(_arr(t.x)) <= ctx.max_points


def test_lasso_and_histogram_selection(ctx, bk):
    spec = cb.selection_from_event(
        ctx, "scatter", {"points": [{"customdata": 3}, {"customdata": 17}]}, x="f1", y="f2"
    )
    a = _direct(bk)
    assert set(a.trials.id[cb.selection_mask(ctx, a, spec)]) == {3, 17}
    click = {"points": [{"customdata": [12, 1, 1, 2]}]}  # count, panel 1 (x2), feasible, bin 2
    spec = cb.selection_from_event(ctx, "hist", click, limit_texts=["", ""], roles=PURE2)
    assert spec["param"] == "x2" and spec["class"] == "feasible"
    m = cb.selection_mask(ctx, a, spec)
    x2 = a.trials.X[:, 1]
    assert np.array_equal(m, a.feasible & (x2 >= spec["lo"]) & (x2 < spec["hi"]))
    fig = _fig(cb.panel_view(ctx, ["", ""], PURE2, "histograms", None, spec, None))
    outlined = [t for t in fig.data if (t.meta or {}).get("class") == "selected"]
    assert sum(t.meta["total"] for t in outlined) == len(a.spec.space) * int(m.sum())
    assert cb.selection_from_event(ctx, "hist", None) is None
    with pytest.raises(StudyDefinitionError):
        cb.selection_from_event(
            ctx, "scatter", {"range": {"x": [0, 1], "y": [0, 1]}}, x="rm -rf", y="f2"
        )


def test_cvp_box_selection_maps_panel_to_parameter(ctx, bk):
    ev = {"range": {"x2": [0.5, 1.5], "y2": [0, 30]}}
    spec = cb.selection_from_event(ctx, "cvp", ev, y="f1")
    assert spec["x"] == "x2" and spec["y"] == "f1"
    fig = _fig(cb.panel_view(ctx, ["", ""], PURE2, "cvp", "f1", spec, "5"))
    assert sum(1 for t in fig.data if (t.meta or {}).get("class") == "chosen") == 2


def test_box_to_limits_sets_worse_side(ctx, bkmax):
    box = cb.selection_from_event(
        ctx, "scatter", {"range": {"x": [3.0, 12.0], "y": [5, 9]}}, x="f1", y="f2"
    )
    texts, msg = cb.box_to_limits(ctx, box, ["", ""])
    assert texts == ["12", "9"] and "f1 <= 12" in msg
    c2 = _ctx(bkmax)
    box = {"kind": "box", "x": "f1", "y": "neg_f2", "xr": [12.0, 3.0], "yr": [-30, -10]}
    texts, msg = cb.box_to_limits(c2, box, ["", ""])
    assert texts == ["12", "-30"] and "neg_f2 >= -30" in msg  # max criterion: lower edge
    with pytest.raises(StudyDefinitionError, match="no box"):
        cb.box_to_limits(ctx, None, ["", ""])
    with pytest.raises(StudyDefinitionError, match="no box"):
        cb.box_to_limits(ctx, {"kind": "ids", "ids": [1]}, ["", ""])
    box = {"kind": "box", "x": "x1", "y": "x2", "xr": [0, 1], "yr": [0, 1]}
    with pytest.raises(StudyDefinitionError, match="neither"):
        cb.box_to_limits(ctx, box, ["", ""])


@pytest.mark.parametrize("n", [1, 4, 5, 10])
def test_histogram_rows_hold_the_grid_panel_by_panel(n):
    # The page draws the histogram grid one row of 4 panels at a time: the rows together
    # hold every trace (same bins, same heights, the panel's index in the customdata), every
    # chosen-trial line on its panel, every panel title; the first row the title and legend.
    from vectorid.analysis.histograms import Histogram
    from vectorid.views import clouds

    rng = np.random.default_rng(n)
    hists = []
    for j in range(n):
        edges = np.linspace(j, j + 1, 9)
        every = rng.integers(5, 50, 8)
        feas = every // 2
        hists.append(Histogram(f"x{j + 1}", edges, every, feas, feas // 3, j, j + 1.0, None))
    fig = clouds.histograms_figure(
        hists, selection=[h.pareto for h in hists], chosen=[j + 0.5 for j in range(n)], raw=True
    )
    fig["layout"]["meta"] = {"nd": 7, "rev": 3}
    rows = cb.histogram_rows(fig)
    assert len(rows) == -(-n // 4)
    assert sum(len(r["data"]) for r in rows) == len(fig["data"])
    flat = [t for r in rows for t in r["data"]]
    for t, u in zip(fig["data"], flat, strict=True):  # the same traces, in the same order
        assert _arr(t["y"]).tolist() == _arr(u["y"]).tolist() and t["name"] == u["name"]
        assert t["customdata"] == u["customdata"]
    for r, row in enumerate(rows):
        lay = row["layout"]
        panels = range(4 * r, min(n, 4 * r + 4))
        axes = {k for k in lay if k.startswith(("xaxis", "yaxis"))}
        assert len(axes) == 2 * len(panels)
        for t in row["data"]:  # every trace on an axis of its row, at its panel's place
            i = t["customdata"][0][1]
            assert i in panels
            k = "" if i == 4 * r else str(i - 4 * r + 1)
            assert (t["xaxis"], t["yaxis"]) == (f"x{k}", f"y{k}")
            assert (
                lay[f"xaxis{k}"]["domain"]
                == fig["layout"][f"xaxis{'' if i == 0 else i + 1}"]["domain"]
            )
        assert [a["text"] for a in lay["annotations"]] == [f"x{i + 1}" for i in panels]
        assert [sh["x0"] for sh in lay["shapes"]] == [i + 0.5 for i in panels]
        assert all(
            f"{sh['yref'].split()[0]}" in {f"y{a[5:]}" for a in axes} for sh in lay["shapes"]
        )
        assert lay["meta"] == {"nd": 7, "rev": 3}
        assert ("title" in lay) == (r == 0) and sum(t["showlegend"] for t in row["data"]) == (
            3 + 1 if r == 0 else 0
        )


# -- chosen trial ---------------------------------------------------------------------------------


def test_trial_view(ctx, bk):
    a = _direct(bk, {"f1": 40.0})
    tid = int(a.trials.id[a.pareto][0])
    v = cb.trial_view(ctx, str(tid), ["40", ""], PURE2)
    assert v["summary"].startswith(f"trial {tid}: Pareto")
    row = int(np.flatnonzero(a.trials.id == tid)[0])
    assert [p["value"] for p in v["params"]] == [float(f"{x:.5g}") for x in a.trials.X[row]]
    assert v["criteria"][0]["meets"] == "yes" and v["criteria"][0]["bound"] == 40.0
    assert v["identification"] is None and "Not an identification" in v["identification_note"]
    with pytest.raises(StudyDefinitionError, match="no sample trial has id 999999"):
        cb.trial_view(ctx, "999999", ["", ""], PURE2)
    with pytest.raises(StudyDefinitionError, match="whole number"):
        cb.trial_view(ctx, "abc", ["", ""], PURE2)


# -- refine and overview --------------------------------------------------------------------------


def test_refine_view_and_edited_rows(ctx, bk):
    v = cb.refine_view(ctx, ["40", ""], PURE2, "feasible", "0.05", "0.1")
    rows = v["rows"]
    assert [r["name"] for r in rows] == ["x1", "x2"]
    a = ctx.cache.analysis(parse_constraints(ctx.spec, ["40", ""], PURE2))
    _, _, stages = ctx.cache.state()
    args = {"basis": "feasible", "quantile": 0.05, "margin": 0.1}
    from vectorid.views.ui.refine import _overrides

    assert _overrides(ctx, a, stages, args, rows) == {}  # unedited rows are no override
    rows[1] = dict(rows[1], new_low=0.5, new_high=2.0)
    assert _overrides(ctx, a, stages, args, rows) == {"x2": (0.5, 2.0)}
    rows[1] = dict(rows[1], new_low="2", new_high="1")
    with pytest.raises(StudyDefinitionError, match="low < high"):
        _overrides(ctx, a, stages, args, rows)
    with pytest.raises(StudyDefinitionError, match="quantile"):
        cb.refine_view(ctx, ["", ""], PURE2, "feasible", "lots", "0.1")


def test_overview_failures_and_timing(tmp_path):
    study = write_user_study(tmp_path / "u", trials=128)
    path = tmp_path / "u.db"
    with Study.create(load_study(study), path) as st:
        st.run(executor="serial")
    c = _ctx(path)
    v = cb.overview_view(c)
    t = Store.open(path).load()
    assert v["n_failed"] == int((t.status != 0).sum()) > 0
    assert sum(f["count"] for f in v["failures"]) == v["n_failed"]
    assert any("diverge" in f["reason"] for f in v["failures"])
    assert v["stages"][0]["trials"] == 128 and v["runs"][0]["outcome"] == "completed"
    assert "128 sample trials" in v["timing"]


# -- cache and jobs -------------------------------------------------------------------------------


def test_cache_reloads_only_when_store_changes(tmp_path):
    path = make_store(tmp_path, "binh-korn", trials=128)
    cache = StoreCache(path)
    cache.analysis()
    cache.analysis()
    assert cache.loads == 1 and len(cache.trials()) == 128
    with Study.open(path, write=True) as st:
        st.run(trials=192, executor="serial")
    assert len(cache.trials()) == 192 and cache.loads == 2


def test_start_job_rejects_bad_values_before_starting(ctx):
    bad = [
        ("section", {"trial": "5", "param": "x9", "points": "21"}, "unknown parameter"),
        ("section", {"trial": "5", "param": "x1", "points": "many"}, "expected a number"),
        ("section", {"trial": "5", "param": "x1", "points": "21", "lo": "1"}, "one end"),
        ("section", {"trial": "99999", "param": "x1", "points": "21"}, "no sample trial"),
        ("robustness", {"trial": "5", "radius": "5", "points": "32"}, "radius"),
        ("continue", {"trials": "-4"}, "whole number"),
        ("shell", {}, "unknown job"),
    ]
    for kind, values, match in bad:
        with pytest.raises(StudyDefinitionError, match=match):
            cb.start_job(ctx, kind, **values)
    assert ctx.jobs.status().state == "idle"


def test_limits_to_save_follows_the_cli_rule(ctx, bkmax):
    out = cb.limits_to_save(ctx, ["30", ""], PURE2, [["", "20"], ["7.7", ""]])
    assert out["criteria"] == {"f1": 30.0, "f2": None}
    assert out["constraints"] == {"g1": [None, 20.0], "g2": [7.7, None]}
    assert out["text"] == "g1 <= 20, g2 >= 7.7, f1 <= 30"
    c2 = _ctx(bkmax)
    out = cb.limits_to_save(c2, ["", "-20"], PURE2)  # max criterion: its lower bound
    assert out["criteria"] == {"f1": None, "neg_f2": -20.0}
    with pytest.raises(StudyDefinitionError, match="outlined in red"):
        cb.limits_to_save(ctx, ["thirty", ""], PURE2)
    with pytest.raises(StudyDefinitionError, match="outlined in red"):
        cb.limits_to_save(ctx, ["", ""], PURE2, [["", "x"], ["", ""]])
    assert ctx.jobs.status().state == "idle"


def test_saving_limits_updates_study_overview_and_reload(tmp_path):
    path = make_store(tmp_path, "binh-korn", trials=64)
    c = _ctx(path)
    texts, g = ["30", ""], [["", "20"], ["7.7", ""]]
    nd = cb.summary_view(c, texts, PURE2, g)["counts"]["nd"]
    v0 = c.cache.version()

    def wait():
        deadline = time.monotonic() + 60
        while c.jobs.status().running and time.monotonic() < deadline:
            time.sleep(0.2)
        return cb.job_view(c)

    holder = Store.open(path, write=True)  # a running stage holds the writer lock
    try:
        note = cb.job_action(c, "limits", limit_texts=texts, roles=PURE2, functional=g)
        assert note["text"].startswith("started: saving the constraints in force")
        assert note["busy"] is None
        st = wait()
        assert st["state"] == "error" and "being written by another process" in st["text"]
    finally:
        holder.close()
    assert Store.open(path).spec.criteria[0].limit is None  # nothing saved
    try:
        note = cb.job_action(c, "limits", limit_texts=texts, roles=PURE2, functional=g)
        st = wait()
        assert st["state"] == "done", st
        assert "saved with the study: g1 <= 20, g2 >= 7.7, f1 <= 30" in st["text"]
    finally:
        c.jobs.shutdown()
    spec = Store.open(path).spec
    assert [cr.limit for cr in spec.criteria] == [30.0, None]
    assert [(k.low, k.high) for k in spec.constraints] == [(None, 20.0), (7.7, None)]
    # the UI sees the new definition (the trials are not read again) ...
    assert c.cache.version() != v0 and c.cache.version()[:3] == v0[:3]
    ov = cb.overview_view(c)
    assert c.cache.loads == 1
    assert [r["limit"] for r in ov["criteria"]] == [30.0, None]
    assert [(r["low"], r["high"]) for r in ov["constraints"]] == [(None, 20.0), (7.7, None)]
    # ... and a reload starts from the saved bounds, with the same ND
    assert limits_text(c.spec) == texts and [list(p) for p in bounds_text(c.spec)] == g
    assert cb.summary_view(c, limits_text(c.spec), PURE2, bounds_text(c.spec))["counts"]["nd"] == nd
    assert cb.summary_view(c, None, None)["counts"]["nd"] == nd  # the study's defaults


def test_the_server_filters_without_loading_numba(bk):
    # vectorid ui asks for the numpy Pareto engine: counts after typed limits (narrowed and
    # loosened), the history's prefixes and the test tables never load numba's ~120 MB.
    import subprocess
    import sys

    pytest.importorskip("dash", reason="the UI needs the ui extra (dash)")
    code = f"""
import sys
from vectorid.views.ui import callbacks as cb
from vectorid.views.ui.app import create_app
app, c = create_app({str(bk)!r})
try:
    for f1 in ("40", "20", "60", "", "10"):
        cb.counts_view(c, [f1, ""], ["pure", "pure"])
        cb.summary_view(c, [f1, ""], ["pure", "pure"])
    cb.history_view(c, ["30", ""], ["pure", "pure"])
    app.layout()  # a page load: the parallel axes ranked by KS without scipy.stats (~22 MB)
    print(cb.counts_view(c, ["", ""], ["pure", "pure"])["np"])
finally:
    c.jobs.shutdown()
assert "numba" not in sys.modules, "the UI server loaded numba"
assert "scipy.stats" not in sys.modules, "the UI server loaded scipy.stats"
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:]
    assert int(out.stdout.split()[-1]) == _direct(bk).n_pareto


def test_page_reload_starts_from_the_saved_limits(tmp_path):
    pytest.importorskip("dash", reason="the UI needs the ui extra (dash)")
    from vectorid.views.ui.app import create_app

    path = make_store(tmp_path, "binh-korn", trials=64)
    app, c = create_app(path)

    def fields(node, out):
        i = getattr(node, "id", None)
        for kind, prefix in (
            ("limit", "vid-limit-"),
            ("con-low", "vid-low-"),
            ("con-high", "vid-high-"),
        ):
            if isinstance(i, str) and i.startswith(prefix):
                out[(kind, i[len(prefix) :])] = node.value
        kids = getattr(node, "children", None)
        for k in kids if isinstance(kids, list | tuple) else [kids]:
            if hasattr(k, "to_plotly_json"):
                fields(k, out)
        return out

    try:
        before = fields(app.layout(), {})
        assert before[("limit", "f1")] == "" and before[("con-high", "g1")] == "25"
        run_job(
            "limits",
            str(path),
            {"criteria": {"f1": 12.5}, "constraints": {"g1": [1.0, 20.0]}, "text": ""},
        )
        after = fields(app.layout(), {})
        assert after[("limit", "f1")] == "12.5" and after[("limit", "f2")] == ""
        assert after[("con-low", "g1")] == "1" and after[("con-high", "g1")] == "20"
        assert after[("con-low", "g2")] == "7.7"
    finally:
        c.jobs.shutdown()


def test_run_job_in_process_stores_a_section(tmp_path):
    path = make_store(tmp_path, "binh-korn", trials=64)
    msg = run_job("section", str(path), {"trial": 5, "param": "x1", "points": 7})
    assert "section through trial 5 along x1" in msg
    with Store.open(path) as st:
        (sec,) = load_sections(st)
    assert sec.trial == 5 and len(sec.values) >= 7


def test_job_manager_runs_one_job_at_a_time(tmp_path):
    path = make_store(tmp_path, "binh-korn", trials=64)
    c = _ctx(path)
    try:
        out = cb.start_job(c, "continue", trials="200000")
        assert out.startswith("started")
        with pytest.raises(JobBusy, match="already running"):
            cb.start_job(c, "section", trial="5", param="x1", points="5")
        # through the button: a note that lasts while the running job runs
        busy = cb.job_action(c, "section", trial="5", param="x1", points="5")
        assert busy["busy"] == c.jobs.status().id and "already running" in busy["text"]
        assert cb.job_message(c, busy) == busy["text"]  # still running (2e5 serial trials)
        bad = cb.job_action(c, "section", trial="5", param="x9", points="5")
        assert bad["busy"] is None and "unknown parameter" in bad["text"]
        deadline = time.monotonic() + 120
        while c.jobs.status().running and time.monotonic() < deadline:
            time.sleep(0.2)
        assert cb.job_message(c, busy) == ""  # cleared once that job finished
        assert cb.job_message(c, bad) == bad["text"]  # other messages stay
        assert cb.job_message(c, None) == ""
        st = cb.job_view(c)
        assert st["state"] == "done", st
        assert st["progress"] == 1.0 and "200000 trials computed" in st["message"]
        assert len(c.cache.trials()) == 200064
    finally:
        c.jobs.shutdown()


def test_job_error_is_reported(tmp_path):
    path = make_store(tmp_path, "binh-korn", trials=32)
    c = _ctx(path)
    holder = Store.open(path, write=True)  # another writer holds the lock
    try:
        c.jobs.start("continue", {"trials": 8}, "blocked run")
        deadline = time.monotonic() + 60
        while c.jobs.status().running and time.monotonic() < deadline:
            time.sleep(0.2)
        st = c.jobs.status()
        assert st.state == "error" and "being written by another process" in st.message
    finally:
        holder.close()
        c.jobs.shutdown()
    assert not math.isnan(len(c.cache.trials()))


def test_serve_warns_off_localhost(bk, monkeypatch, capsys):
    dash = pytest.importorskip("dash", reason="the UI needs the ui extra (dash)")
    from vectorid.views.ui import serve

    calls = []
    monkeypatch.setattr(dash.Dash, "run", lambda self, **kw: calls.append(kw))
    serve(str(bk), host="0.0.0.0", port=8999)
    assert "warning: serving on 0.0.0.0" in capsys.readouterr().err
    serve(str(bk))
    assert "warning" not in capsys.readouterr().err
    assert [c["host"] for c in calls] == ["0.0.0.0", "127.0.0.1"]
    assert all(c["debug"] is False for c in calls)


# -- identifiability verdicts, limit sources, drops -----------------------------------------------


def _sourced_store(tmp_path: Path) -> Path:
    """binh-korn with limits saved as a noise floor (f1) and a quantile stand-in (f2)."""
    path = make_store(tmp_path, "binh-korn", trials=512)
    with Store.open(path, write=True) as st:
        st.set_limits(
            {"f1": 40.0, "f2": 30.0},
            sources={"f1": ("noise", "noise floor q=0.99 + 2 m"), "f2": ("quantile", "q=0.1")},
        )
    return path


def test_verdicts_follow_the_constraints_in_force(tmp_path):
    from vectorid.analysis.identifiability import identifiability
    from vectorid.views.ui.verdicts import span, verdicts_of

    path = _sourced_store(tmp_path)
    c = _ctx(path)
    stages = Store.open(path).stages()
    got = {}
    for f1 in ("40", "20"):
        a = _direct(path, {"f1": float(f1)})
        want = identifiability(a, stages=stages)
        v = cb.identifiability_view(c, [f1, "30"], PURE2)
        rows = v["rows"]
        assert [r["name"] for r in rows] == ["x1", "x2"]
        assert [r["verdict"] for r in rows] == [w.verdict for w in want]
        assert [r["feasible"] for r in rows] == [span(w.feasible) for w in want]
        assert [r["pareto"] for r in rows] == [span(w.pareto) for w in want]
        assert [r["constrained_by"] for r in rows] == [
            ", ".join(w.constrained_by) or "-" for w in want
        ]
        assert [r["ranges"]["feasible"] for r in rows] == [list(w.feasible) for w in want]
        got[f1] = rows
        assert cb.summary_view(c, [f1, "30"], PURE2)["verdicts"] == v["line"]  # the explorer's
        # the refine view and the chosen trial show the same verdicts
        ref = cb.refine_view(c, [f1, "30"], PURE2, "feasible", "0.05", "0.1")
        assert [r["identifiability"] for r in ref["rows"]] == [w.verdict for w in want]
        assert [r["verdict"] for r in ref["verdicts"]] == [w.verdict for w in want]
        tid = int(a.trials.id[a.feasible][0])
        row = int(np.flatnonzero(a.trials.id == tid)[0])
        tv = cb.trial_view(c, str(tid), [f1, "30"], PURE2)
        for p, w, x in zip(tv["params"], want, a.trials.X[row]):
            assert p["verdict"] == w.verdict
            if w.identified:
                assert p["shown"].startswith(f"{x:.5g}")
            else:  # never a lone value: the range and the verdict come first
                assert p["shown"].startswith(("feasible [", "box [")), p["shown"]
                assert f"({w.verdict})" in p["shown"]
        # memoised per analysis
        a_ui = c.cache.analysis(parse_constraints(c.spec, [f1, "30"], PURE2))
        assert verdicts_of(c, a_ui) is verdicts_of(c, a_ui)
    # a tighter f1 narrows what D allows of x1
    lo40, hi40 = got["40"][0]["ranges"]["feasible"]
    lo20, hi20 = got["20"][0]["ranges"]["feasible"]
    assert hi20 - lo20 < hi40 - lo40
    c.jobs.shutdown()


def test_chosen_text_shows_a_value_only_where_identified():
    from vectorid.analysis.identifiability import ParameterVerdict
    from vectorid.views.ui.verdicts import chosen_text, verdict_groups, verdict_line

    ok = ParameterVerdict("x6", "identified", (0.47705, 0.61797), (0.5, 0.6), (0.2, 1.0))
    weak = ParameterVerdict("x8", "weak", (0.8, 1.2), None, (0.75, 1.5), unit="m")
    empty = ParameterVerdict("x9", "not identified", None, None, (0.0, 1.0))
    assert chosen_text(ok, 0.553861) == "0.55386 (feasible [0.47705, 0.61797])"
    assert chosen_text(weak, 1.0225) == (
        "feasible [0.8, 1.2] m (weak); this trial 1.0225, one value the data allow"
    )
    assert chosen_text(empty, None) == "box [0, 1] (not identified)"
    assert verdict_line([ok, weak, empty]) == (
        "identified: x6 [0.47705, 0.61797]; weak: x8 [0.8, 1.2]; not identified: x9 [0, 1]"
    )
    groups = verdict_groups([ok, weak, empty])
    assert [g["verdict"] for g in groups] == ["identified", "weak", "not identified"]
    assert groups[1]["items"][0]["range"] == "[0.8, 1.2]" and groups[1]["items"][0]["unit"] == "m"
    assert groups[2]["items"][0]["range"] == "none in D (box [0, 1])"
    thin = ParameterVerdict("x8", "weak", (0.8, 1.2), None, (0.75, 1.5), n_feasible=6,
                            thin=True, n_needed=20)  # fmt: skip
    assert verdict_line([thin]).endswith(
        "thin: D holds 6 trials, fewer than the 20 needed to show its spread (run more "
        'trials, or sampler = "sequential")'
    )


def test_limit_sources_and_saving_keeps_them(tmp_path):
    path = _sourced_store(tmp_path)
    c = _ctx(path)
    t0 = limits_text(c.spec)
    assert t0 == ["40", "30"]

    def sources(texts):
        return {s["name"]: s for s in cb.summary_view(c, texts, PURE2)["sources"]}

    s = sources(t0)
    assert (s["f1"]["kind"], s["f1"]["text"]) == ("noise", "noise floor q=0.99 + 2 m")
    assert (s["f2"]["kind"], s["f2"]["text"]) == ("quantile", "quantile stand-in: q=0.1")
    assert s["f1"]["bound"] == "<= 40"
    s = sources(["20", "30"])  # typed in this page
    assert s["f1"]["kind"] == "session" and s["f2"]["kind"] == "quantile"
    assert s["f1"]["text"] == "this session: replaces the saved <= 40 (noise floor)"
    s = sources(["", "30"])  # removed in this page
    assert s["f1"]["kind"] == "session" and s["f1"]["label"] == "no limit (this session)"
    s = sources(["twenty", "30"])  # not a number: the study's limit stays in force
    assert s["f1"]["kind"] == "noise"
    # the chosen trial's criteria say the same
    tv = cb.trial_view(c, "5", ["20", "30"], PURE2)
    assert [r["limit source"] for r in tv["criteria"][:2]] == [
        "this session: replaces the saved <= 40 (noise floor)",
        "quantile stand-in: q=0.1",
    ]
    # saving: an unchanged limit keeps its source and note, a changed one is the expert's
    params = cb.limits_to_save(c, ["20", "30"], PURE2)
    assert params["sources"] == {
        "f1": ["expert", "set in the browser UI"],
        "f2": ["quantile", "q=0.1"],
    }
    run_job("limits", str(path), params)
    saved = {cr.name: cr for cr in Store.open(path).spec.criteria}
    assert (saved["f1"].limit, saved["f1"].source, saved["f1"].limit_note) == (
        20.0,
        "expert",
        "set in the browser UI",
    )
    assert (saved["f2"].limit, saved["f2"].source, saved["f2"].limit_note) == (
        30.0,
        "quantile",
        "q=0.1",
    )
    # after a reload the page starts from them (the page's layout reads the store first)
    c.cache.state()
    s = sources(limits_text(c.spec))
    assert (s["f1"]["kind"], s["f1"]["text"]) == ("expert", "expert: set in the browser UI")
    assert s["f2"]["text"] == "quantile stand-in: q=0.1"
    ov = {r["name"]: r for r in cb.overview_view(c)["criteria"]}
    assert ov["f2"]["limit source"] == "quantile stand-in: q=0.1"
    c.jobs.shutdown()


@pytest.mark.filterwarnings("ignore:(?s).*DataTable will be removed:DeprecationWarning")
def test_flight_view_flies_the_chosen_drop(tmp_path):
    """A study of two drops (a rocket descent under drogue, then main): the chosen trial is
    flown over the drop the user picks, altitude against the barometer."""
    from tests.identify.test_identification import _study
    from vectorid.views.ui.trial import drop_names

    spec = _study(tmp_path, trials=32)
    path = tmp_path / "two-drops.db"
    with Study.create(spec, path) as st:
        st.run(trials=32, executor="serial")
    c = _ctx(path)
    assert drop_names(c.spec) == ["drogue", "main"]
    first = cb.trial_view(c, "3", None, None)
    assert first["drops"] == ["drogue", "main"] and first["identification_note"].startswith(
        "drop 1 of 2"
    )
    v = cb.trial_view(c, "3", None, None, None, None, "main")
    assert v["identification"].layout.title.text == "Drop main: flight vs trial 3"
    assert v["identification_note"] == "drop 2 of 2 (main)"
    assert v["rms"][0]["altitude.altitude RMS [m]"] > 0
    assert v["rms"][0] != first["rms"][0]
    with pytest.raises(StudyDefinitionError, match="no drop named 'mian'.*main"):
        cb.trial_view(c, "3", None, None, None, None, "mian")
    c.jobs.shutdown()
    # the page offers the drops (the list is hidden for a study of one drop)
    pytest.importorskip("dash", reason="the UI needs the ui extra (dash)")
    from vectorid.views.ui.pages.detail import trial_layout

    def find(node, id_):
        if getattr(node, "id", None) == id_:
            return node
        kids = getattr(node, "children", None)
        for k in kids if isinstance(kids, list | tuple) else [kids]:
            hit = find(k, id_) if hasattr(k, "to_plotly_json") else None
            if hit is not None:
                return hit
        return None

    page = trial_layout(c)
    drop = find(page, "trial-drop")
    assert [o["value"] for o in drop.options] == ["drogue", "main"] and drop.value == "drogue"
    assert find(page, "trial-drop-label").style == {}


def test_the_first_rows_of_a_test_table_are_those_of_the_full_sort(bk):
    """``top`` rows found by partial selection equal the stable full sort's first rows,
    ties and all; min and max stay the whole table's."""
    a = _direct(bk)
    a.trials.F[::7, 0] = np.round(a.trials.F[::7, 0])  # many ties
    for name in a.crit_names:
        full = a.test_table(name)
        for top in (0, 1, 5, 50, len(full.ids) + 3):
            t = a.test_table(name, top=top)
            assert np.array_equal(t.ids, full.ids[:top]) and (t.min, t.max) == (full.min, full.max)


def test_histograms_counted_over_d_alone_match_the_plain_ones(ctx):
    """The explorer's histograms (every-trial counts kept, D and Pareto counted over their
    own rows) equal analysis.histograms under several constraint sets."""
    from vectorid.analysis.histograms import histograms
    from vectorid.views.ui.context import analysis_of
    from vectorid.views.ui.explore import fast_histograms

    for texts in (["40", ""], ["20", "30"], ["", ""]):
        a, _ = analysis_of(ctx, texts, PURE2)
        fast, plain = fast_histograms(ctx, a, min_trials=0), histograms(a)
        assert [h.param for h in fast] == [h.param for h in plain]
        for f, p in zip(fast, plain):
            assert np.array_equal(f.edges, p.edges) and f.n_outside == p.n_outside
            for k in ("all", "feasible", "pareto"):
                assert np.array_equal(getattr(f, k), getattr(p, k)), (f.param, k)
        assert sum(fast[0].feasible) == a.n_feasible > 0 or not texts[0]


def test_verdict_table_is_one_element_with_every_text_escaped():
    """The verdict table goes to the page as one element holding its markup (a 33-row table
    built cell by cell was ~600 Dash components, 1.2-2.8 s of the Refine tab's first draw):
    one row per variable with its id and verdict, every text escaped."""
    from vectorid.views.ui.pages.common import verdict_table

    row = {
        "name": "k<1>",
        "unit": "m/s",
        "meaning": 'gain "a" & <b>b</b>',
        "verdict": "weak",
        "reason": "D spans 40 % <of> the box",
        "suggestion": "",
        "ranges": {"box": (0.0, 2.0), "feasible": (0.5, 1.3), "pareto": (0.9, 1.0)},
        "feasible": "[0.5, 1.3]",
        "pareto": "[0.9, 1]",
        "box": "[0, 2]",
        "constrained_by": "f1",
    }
    el = verdict_table([row, dict(row, name="k2", verdict="identified")], "vid-verdict")
    markup = el.to_plotly_json()["props"]["data-html"]
    assert markup.count("<tr id=") == 2 and 'data-verdict="identified"' in markup
    assert "gain &quot;a&quot; &amp; &lt;b&gt;b&lt;/b&gt;" in markup and "<b>b</b>" not in markup
    assert "k&lt;1&gt;" in markup and "&lt;of&gt;" in markup
    assert 'class="rb-feasible" style="left: 25.00%; width: max(2px, 40.00%)' in markup


def test_the_server_limits_blas_to_one_thread():
    """``vectorid ui`` sets every loaded OpenBLAS to one thread (its requests run in
    threads); read back through the library's own getter, in a process of its own."""
    import subprocess
    import sys

    code = """
import ctypes, numpy as np
from vectorid.views.ui.data import limit_blas_threads
libs = {l.split()[-1] for l in open("/proc/self/maps") if "openblas" in l.lower()}
if not libs:
    print("none"); raise SystemExit
lib = ctypes.CDLL(sorted(libs)[0])
get = next(getattr(lib, n) for n in ("scipy_openblas_get_num_threads64_",
    "scipy_openblas_get_num_threads", "openblas_get_num_threads64_", "openblas_get_num_threads")
    if hasattr(lib, n))
before = get()
done = limit_blas_threads(1)
print(before, get(), len(done))
"""
    env = {**__import__("os").environ, "OPENBLAS_NUM_THREADS": "2"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert out.returncode == 0, out.stderr[-2000:]
    if out.stdout.strip() == "none":
        pytest.skip("no OpenBLAS loaded by numpy here")
    before, after, n = map(int, out.stdout.split())
    assert (before, after) == (2, 1) and n >= 1
