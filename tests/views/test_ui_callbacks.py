"""The browser UI's callbacks as plain functions (no browser): counts, tables, selection,
box-to-constraints, the chosen trial, refine, overview, input validation, the trial cache
and the background jobs."""

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
from vectorid.store.sqlite import Store
from vectorid.views.ui import callbacks as cb
from vectorid.views.ui.data import StoreCache, parse_constraints, parse_number, parse_trial_id
from vectorid.views.ui.jobs import JobBusy, JobManager, run_job

PURE2 = ["pure", "pure"]


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
    red = {st["if"]["row_index"] for st in styles if st["if"]["column_id"] == "c1_v"}
    assert red == {i for i in range(len(data)) if not t.feasible[i]} and red


def test_empty_d_is_diagnosed(ctx):
    s = cb.summary_view(ctx, ["0.001", "0.001"], PURE2)
    assert s["counts"]["nd"] == 0
    assert any("empty" in m for m in s["messages"])


def test_set_table_lists_pareto_first(ctx, bk):
    s = cb.summary_view(ctx, ["50", ""], PURE2)
    a = _direct(bk, {"f1": 50.0})
    rows = s["sets"]["data"]
    n_par = min(a.n_pareto, ctx.set_rows)
    assert [r["set"] for r in rows[:n_par]] == ["Pareto"] * n_par
    assert {r["id"] for r in rows[:n_par]} <= set(a.trials.id[a.pareto].tolist())
    assert all(r["set"] == "feasible" for r in rows[n_par:])


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
    sel = [t for t in fig.data if (t.meta or {}).get("class") == "selected"]
    assert len(sel) == 1 and len(sel[0].x) == want.sum()  # max_points 300 > selection
    assert f"{int(want.sum())} trials" in text
    # drawn points are decimated to max_points, the selection still counts every trial
    drawn = sum(
        len(t.x)
        for t in fig.data
        if (t.meta or {}).get("class") in ("infeasible", "feasible", "pareto")
    )
    assert drawn <= ctx.max_points


def test_lasso_and_histogram_selection(ctx, bk):
    spec = cb.selection_from_event(
        ctx, "scatter", {"points": [{"customdata": 3}, {"customdata": 17}]}, x="f1", y="f2"
    )
    a = _direct(bk)
    assert set(a.trials.id[cb.selection_mask(ctx, a, spec)]) == {3, 17}
    click = {"points": [{"curveNumber": 2, "pointNumber": 4}]}  # panel 1 (x2), feasible
    spec = cb.selection_from_event(ctx, "hist", click, limit_texts=["", ""], roles=PURE2)
    assert spec["param"] == "x2" and spec["class"] == "feasible"
    m = cb.selection_mask(ctx, a, spec)
    x2 = a.trials.X[:, 1]
    assert np.array_equal(m, a.feasible & (x2 >= spec["lo"]) & (x2 < spec["hi"]))
    fig = cb.panel_view(ctx, ["", ""], PURE2, "histograms", None, spec, None)
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
    fig = cb.panel_view(ctx, ["", ""], PURE2, "cvp", "f1", spec, "5")
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


# -- chosen trial ---------------------------------------------------------------------------------


def test_trial_view(ctx, bk):
    a = _direct(bk, {"f1": 40.0})
    tid = int(a.trials.id[a.pareto][0])
    v = cb.trial_view(ctx, str(tid), ["40", ""], PURE2)
    assert v["summary"].startswith(f"trial {tid}: Pareto")
    row = int(np.flatnonzero(a.trials.id == tid)[0])
    assert [p["value"] for p in v["params"]] == [float(f"{x:.6g}") for x in a.trials.X[row]]
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
    assert cb._overrides(ctx, a, stages, args, rows) == {}  # unedited rows are no override
    rows[1] = dict(rows[1], new_low=0.5, new_high=2.0)
    assert cb._overrides(ctx, a, stages, args, rows) == {"x2": (0.5, 2.0)}
    rows[1] = dict(rows[1], new_low="2", new_high="1")
    with pytest.raises(StudyDefinitionError, match="low < high"):
        cb._overrides(ctx, a, stages, args, rows)
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
        out = cb.start_job(c, "continue", trials="64")
        assert out.startswith("started")
        with pytest.raises(JobBusy, match="already running"):
            cb.start_job(c, "section", trial="5", param="x1", points="5")
        deadline = time.monotonic() + 60
        while c.jobs.status().running and time.monotonic() < deadline:
            time.sleep(0.2)
        st = cb.job_view(c)
        assert st["state"] == "done", st
        assert st["progress"] == 1.0 and "64 trials computed" in st["message"]
        assert len(c.cache.trials()) == 128
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
