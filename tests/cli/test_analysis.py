"""The analysis verbs: section, refine, robustness, report, correlation, sensitivity, hist,
plot (text, --json and errors exiting with 2)."""

import json

import numpy as np
import pytest

from tests.analysis_helpers import make_store
from vectorid import Study, analytic
from vectorid.cli import main


def run_cli(capsys, *args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def store(tmp_path):
    return make_store(tmp_path, trials=512)


def test_section_json_equals_direct_evaluation(store, capsys):
    code, out, err = run_cli(
        capsys, "section", store, "--trial", 110, "--param", "x1", "--points", 6, "--json"
    )
    assert code == 0, err
    doc = json.loads(out)
    X = np.array([[p["value"], 0.0] for p in doc["points"]])
    with Study.open(store) as st:
        t = st.store.load()
        X[:, 1] = t.X[t.id == 110][0, 1]
        assert st.store.stages()[-1].kind == "section" and len(t) == 512
    direct, _ = analytic.get("binh-korn").evaluate(X)
    got = np.array([[p["criteria"]["f1"], p["criteria"]["f2"]] for p in doc["points"]])
    np.testing.assert_allclose(got, direct)
    code, out, _ = run_cli(
        capsys,
        "section",
        store,
        "--trial",
        110,
        "--param",
        "x2",
        "--range",
        0.5,
        1.0,
        "--points",
        3,
    )
    assert code == 0
    lines = [ln for ln in out.splitlines()[2:] if ln.strip()]
    assert len(lines) in (3, 4)  # 3 grid points, plus the trial itself when in range
    assert float(lines[0].split()[0]) == 0.5 and float(lines[-1].split()[0]) == 1.0


def test_refine_apply_then_run_continues(store, capsys, tmp_path):
    fig = tmp_path / "refine.html"
    code, out, err = run_cli(capsys, "refine", store, "--limit", "f1<=30", "--out", fig)
    assert code == 0, err
    assert "not applied" in out and fig.exists()
    code, out, err = run_cli(
        capsys,
        "refine",
        store,
        "--limit",
        "f1<=30",
        "--pareto",
        "--apply",
        "--json",
        "--bound",
        "x2=0.5:2.5",
    )
    assert code == 0, err
    doc = json.loads(out)
    assert doc["basis"] == "pareto" and doc["applied_stage"] == 1 and doc["start_seq"] == 512
    assert doc["box"][1]["low"] == 0.5 and doc["box"][1]["high"] == 2.5
    code, out, err = run_cli(
        capsys, "run", store, "--trials", 640, "--executor", "serial", "--quiet"
    )
    assert code == 0 and "128 trials computed" in out
    with Study.open(store) as st:
        t = st.store.load()
    new = t.stage == 1
    assert new.sum() == 128 and t.X[new, 1].min() >= 0.5 and t.X[new, 1].max() <= 2.5
    code, out, _ = run_cli(capsys, "hist", store, "--param", "x2", "--by-stage", "--json")
    hs = json.loads(out)["histograms"]
    assert [h["stage"] for h in hs] == [0, 1] and sum(hs[1]["all"]) == 128


def test_robustness_text_and_json(store, capsys):
    code, out, err = run_cli(
        capsys, "robustness", store, "--trial", 110, "--trial", 300, "--points", 8, "--radius", 0.01
    )
    assert code == 0, err
    assert "MIN:" in out and "№110" in out and "verdict smooth" in out
    code, out, _ = run_cli(capsys, "robustness", store, "--trial", 7, "--points", 8, "--json")
    doc = json.loads(out)
    assert doc["checks"][0]["points"] == 9 and doc["chosen"]["rows"][0]["id"] == 7
    assert doc["checks"][0]["verdict"] == "smooth"


def test_report_correlation_sensitivity_plot(store, capsys, tmp_path):
    out_html = tmp_path / "r.html"
    code, out, err = run_cli(
        capsys,
        "report",
        store,
        "--limit",
        "f1<=60",
        "--out",
        out_html,
        "--chosen",
        110,
        "--max-points",
        200,
    )
    assert code == 0, err
    assert "report written" in out
    text = out_html.read_text()
    assert "№110" in text and "thinned for display" in text
    code, out, _ = run_cli(capsys, "correlation", store, "--set", "feasible", "--json")
    doc = json.loads(out)
    assert doc["names"] == ["x1", "x2"] and len(doc["matrix"]) == 2
    code, out, _ = run_cli(capsys, "correlation", store, "--limit", "f1<=60")
    assert code == 0 and "could be merged" in out
    code, out, _ = run_cli(capsys, "sensitivity", store, "--json")
    doc = json.loads(out)
    assert len(doc["ks"]) == 2 and doc["ranking"][0]["ks"] >= doc["ranking"][1]["ks"]
    for extra in (
        ["--x", "f1", "--y", "f2"],
        ["--matrix"],
        ["--vs-params", "f2"],
        ["--spread", 1, 2],
    ):
        f = tmp_path / "p.html"
        code, _, err = run_cli(capsys, "plot", store, *extra, "--out", f)
        assert code == 0, err
        assert f.stat().st_size > 1000


@pytest.mark.parametrize(
    "args, message",
    [
        (["section", "{s}", "--trial", "110", "--param", "x9"], "unknown variable"),
        (["section", "{s}", "--trial", "0", "--param", "x1"], "no stored trial"),
        (["section", "{s}", "--trial", "5", "--param", "x1", "--range", "2", "1"], "LO < HI"),
        (["refine", "{s}", "--bound", "x1=3"], "NAME=LO:HI"),
        (["refine", "{s}", "--limit", "f1<=-1"], "empty"),
        (["refine", "{s}", "--margin", "-1"], "margin"),
        (["robustness", "{s}", "--trial", "5", "--radius", "2"], "radius"),
        (["plot", "{s}", "--out", "x.html"], "exactly one"),
        (["plot", "{s}", "--x", "f1", "--y", "zz", "--out", "x.html"], "unknown"),
        (["correlation", "{s}", "--limit", "f1<=0.5"], "at least 3"),
        (["report", "{s}", "--out", "r.html", "--limit", "f9<=1"], "unknown"),
    ],
)
def test_errors_exit_2_with_a_fix(store, capsys, tmp_path, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    code, out, err = run_cli(capsys, *[a.format(s=store) for a in args])
    assert code == 2
    assert message in err and err.startswith("error: ")


def test_hist_text_labels_its_count_columns(store, capsys):
    code, out, err = run_cli(capsys, "hist", store, "--param", "x1", "--bins", 5)
    assert code == 0, err
    lines = out.splitlines()
    assert lines[0].startswith("x1: 512 trials,") and "feasible (in D)" in lines[0]
    header = lines[1].split()
    assert header[:3] == ["bin", "of", "x1"] and header[3:5] == ["feasible", "Pareto"]
    rows = [ln.split(")")[1].split()[:2] for ln in lines[2:7]]
    doc_code, doc, _ = run_cli(capsys, "hist", store, "--param", "x1", "--bins", 5, "--json")
    h = json.loads(doc)["histograms"][0]
    assert h["feasible_weighted"] is None and h["feasible_weighted_by"] is None  # a plain table
    assert [int(r[0]) for r in rows] == h["feasible"] and [int(r[1]) for r in rows] == h["pareto"]


def test_identifiability_combinations_text_and_json(tmp_path, capsys):
    """``--combinations``: the one combination D pins down (x1 + x2), in z and in metres."""
    from tests.analysis.test_combinations import CENTRE, HALF, _sum_spec

    path = tmp_path / "sum.db"
    with Study.create(_sum_spec(), path) as st:
        st.run(executor="inline", progress=False)
    code, out, _ = run_cli(capsys, "identifiability", path, "--combinations")
    assert code == 0
    assert "combinations D pins down" in out and "1 identified, 0 weak" in out
    line = next(s for s in out.splitlines() if "in the gains' units" in s)
    lo, hi = (float(v) for v in line.split("[")[1].split("]")[0].split(","))
    assert lo <= CENTRE - 0.9 * HALF and hi >= CENTRE + 0.9 * HALF and hi - lo < 3 * HALF
    code, out, _ = run_cli(capsys, "identifiability", path, "--combinations", "--json")
    doc = json.loads(out)
    (c,) = doc["combinations"]
    assert sorted(c["loadings"]) == ["x1", "x2"] and c["verdict"] == "identified"
    assert len(c["range"]) == 2 and 0 < c["width_fraction"] < 0.25
    assert "z = (x - low)/(high - low)" in doc["range_units"]
    code, out, _ = run_cli(capsys, "identifiability", path, "--json")
    assert "combinations" not in json.loads(out)
