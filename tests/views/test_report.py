"""The HTML report: self-contained, every applicable figure, and it renders in headless
Chromium with no console error (screenshot kept under test-artifacts/, not in git)."""

import json
import re
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("plotly", reason="the report needs the plot extra (plotly)")

from tests.analysis_helpers import make_store
from vectorid import Study
from vectorid.analysis import parse_limits
from vectorid.analysis.refine import propose_refine
from vectorid.views.report import write_report
from vectorid.workflows.extra import apply_refine, run_robustness, run_section

ARTIFACTS = Path(__file__).resolve().parents[2] / "test-artifacts"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMEDRIVER = shutil.which("chromedriver")


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    folder = tmp_path_factory.mktemp("rep")
    path = make_store(folder, problem="binh-korn", trials=1024)
    with Study.open(path, write=True) as st:
        a = st.analysis({"f1": 60.0})
        apply_refine(st.store, propose_refine(a, st.store.stages()))
        st.run(trials=1536, executor="serial")
        a = st.analysis({"f1": 60.0})
        tid = int(a.trials.id[a.pareto][0])
        run_section(st.store, tid, "x1", points=15)
        run_robustness(st.store, tid, radius=0.01, points=16, analysis=a)
        res = write_report(
            st.store, folder / "report.html", limits=parse_limits(["f1<=60"]), max_points=500
        )
    return res, a, tid


def test_report_contents(report):
    res, a, tid = report
    text = res.path.read_text(encoding="utf-8")
    assert res.size == len(text.encode())
    # plotly.js embedded exactly once, nothing fetched from the network
    assert text.count("Plotly.newPlot") == 1 and text.count('<script src="http') == 0
    import plotly.offline

    assert text.count(plotly.offline.get_plotlyjs()[:2000]) == 1
    assert not re.search(r"<script[^>]+src=", text)
    assert f"N = <b>{a.n}</b>" in text and f"ND = <b>{a.n_feasible}</b>" in text
    assert f"NP = <b>{a.n_pareto}</b>" in text and "f1 &lt;= 60" in text
    for heading in (
        "Study definition",
        "Test tables",
        "Chosen vector",
        "Criterion vs criterion",
        "Criterion vs parameter",
        "Histograms",
        "Double tuning proposal",
        "Correlation among near-optimal vectors",
        "Sensitivity",
        "Sections (type II)",
        "Robustness of chosen vectors",
        "Stages and refine history",
    ):
        assert f">{heading}" in text, heading
    payloads = re.findall(r'<script type="application/json" id="fig\d+-json">(.*?)</script>', text)
    assert len(payloads) == len(res.figures) >= 10
    figs = [json.loads(p) for p in payloads]
    titles = [f["layout"]["title"]["text"] for f in figs]
    assert any(t.startswith("Double tuning: x") for t in titles)  # stage comparison
    assert any(t.startswith("Section through trial") for t in titles)
    # thinned point clouds say so, in the legend and in the report's notes
    assert res.notes and all("thinned for display" in n for n in res.notes)
    assert "Thinning</h2>" in text
    for heading in ("Parallel coordinates", "History"):
        assert f">{heading}" in text, heading
    # point clouds in SVG (every figure drawn at load, few WebGL contexts)
    kinds = {t["type"] for f in figs for t in f["data"]}
    assert "scattergl" not in kinds and "parcoords" not in kinds  # parallel: SVG lines
    gl = {"splom", "parcoords", "scatter3d", "scattergl"}
    assert sum(any(t["type"] in gl for t in f["data"]) for f in figs) <= 2  # the matrix, 3-D
    # every figure laid out to print: an A4 page's width, no font under 11 px
    assert all(f["layout"]["width"] == 700 and f["layout"]["height"] <= 1000 for f in figs)
    assert any(t.startswith("Double tuning: ranges per parameter") for t in titles)
    # wide tables scroll in their container
    assert text.count('<div class="scroll"><table>') >= 5
    # identifiability: a verdict per variable, and where each limit in force came from
    from vectorid.analysis import identifiability

    assert ">Identifiability</h2>" in text and "Criteria constraints and their sources" in text
    assert "this analysis (--limit)" in text  # f1 <= 60 was given to this report only
    for v in identifiability(a):
        assert f"<b>{v.name}</b>" in text and v.verdict in text
        if not v.identified:  # the chosen-vector table shows its range, not a value
            assert v.value_text() in text.replace("&#x27;", "'")


def _driver(tmpdir):
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for arg in (
        "--headless=new",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--no-first-run",
        "--enable-unsafe-swiftshader",
        f"--user-data-dir={tmpdir}",
        "--window-size=1300,1000",
    ):
        opts.add_argument(arg)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(CHROMEDRIVER), options=opts)


def _render_and_check(res, name: str) -> Path:
    """Open the report in headless Chromium, plot every figure, check each drew marks and
    the console has no error; save a full-page screenshot as test-artifacts/NAME."""
    ARTIFACTS.mkdir(exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        d = _driver(tmp)
        try:
            d.get(res.path.resolve().as_uri())
            # every figure draws at load, without scrolling (so printing shows them all)
            deadline = time.time() + 90
            n = len(res.figures)
            while time.time() < deadline:
                done = d.execute_script(
                    "return document.querySelectorAll('div.fig[data-state=plotted]').length"
                )
                if done == n:
                    break
                time.sleep(0.2)
            assert done == n
            # and each WebGL figure has its picture for print (the others print as drawn)
            deadline = time.time() + 90
            while time.time() < deadline:
                if d.execute_script("return window.vectoridPrintReady === true"):
                    break
                time.sleep(0.2)
            assert d.execute_script(
                "return document.querySelectorAll('img.raster').length === "
                "document.querySelectorAll('div.fig.gl').length"
            )
            # every figure drew something: an SVG with plot content, and WebGL canvases
            # with non-zero size for the point clouds
            drawn = d.execute_script(
                """return Array.from(document.querySelectorAll('div.fig')).map(function(div){
                  var svg = div.querySelectorAll('.main-svg').length;
                  var gl = Array.from(div.querySelectorAll('canvas')).filter(
                      function(c){return c.width > 0 && c.height > 0;}).length;
                  var marks = div.querySelectorAll('.point, .bars path, .heatmaplayer image,'
                      + ' .scatterlayer path, .boxlayer path').length;
                  return [svg, gl, marks, !!div._fullData && div._fullData.length];
                });"""
            )
            for i, (svg, gl, marks, traces) in enumerate(drawn):
                assert svg > 0 and traces, f"figure {i} ({res.figures[i]}) not drawn"
                assert gl > 0 or marks > 0, f"figure {i} ({res.figures[i]}) has no marks"
            errors = [e for e in d.get_log("browser") if e["level"] == "SEVERE"]
            assert errors == []
            # printed to PDF (what a browser's print does), every figure is on the pages
            import base64

            pdf = base64.b64decode(d.execute_cdp_cmd("Page.printToPDF", {})["data"])
            assert pdf[:5] == b"%PDF-"
            (ARTIFACTS / name.replace(".png", ".pdf")).write_bytes(pdf)
            assert len(pdf) > 50_000 * min(n, 10)
            height = d.execute_script("return document.body.scrollHeight")
            d.set_window_size(1300, min(int(height), 16000))
            time.sleep(1.0)
            shot = ARTIFACTS / name
            d.save_screenshot(str(shot))
        finally:
            d.quit()
    return shot


@pytest.mark.slow
@pytest.mark.skipif(
    CHROMIUM is None or CHROMEDRIVER is None,
    reason="headless Chromium not installed (apt-get install chromium chromium-driver)",
)
def test_report_renders_in_headless_chromium(report):
    pytest.importorskip("selenium", reason="pip install selenium to drive Chromium")
    res, _, _ = report
    shot = _render_and_check(res, "report.png")
    png = shot.read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 50_000
    w, h = np.frombuffer(png[16:24], dtype=">u4")
    assert w >= 1200 and h > 2000


# -- the report of an identification study --------------------------------------------------


@pytest.fixture(scope="module")
def ident_report(tmp_path_factory):
    from vectorid.cli import main

    out = tmp_path_factory.mktemp("ident")
    assert main(["demo", "--out", str(out), "--trials", "128", "--quiet"]) == 0
    db = out / "g12-step2-controlled.db"
    with Study.open(db) as st:
        res = write_report(st.store, out / "ident.html", max_envelope=12)
        a = st.analysis()
    return res, a, out


def _figures_of(res):
    text = res.path.read_text(encoding="utf-8")
    payloads = re.findall(r'<script type="application/json" id="fig\d+-json">(.*?)</script>', text)
    return text, [json.loads(p) for p in payloads]


def test_identification_section(ident_report):
    from vectorid.analysis.choice import best_per_criterion, suggest_choice

    res, a, _ = ident_report
    text, figs = _figures_of(res)
    assert ">Identification</h2>" in text
    by_title = {f["layout"]["title"]["text"]: f for f in figs}
    drop = "controlled"
    traj = by_title[f"Trajectories on drop {drop}: flight, best per criterion"]
    names = [t["name"] for t in traj["data"] if t.get("showlegend") is not False]
    best = best_per_criterion(a)
    pure = [a.crit_names[j] for j in a.pure]
    for i in {best[c] for c in pure}:
        assert sum(f"(№{i})" in n for n in names) == 1, i
    assert names[0] == "flight" and names[-1] == "nominal"
    assert not any(n.startswith("best roll_abs") for n in names)  # pseudo: not drawn
    fig3 = by_title[f"3-D trajectories on drop {drop}: flight, worst, best"]
    assert [t["type"] for t in fig3["data"]] == ["scatter3d"] * 3
    assert fig3["data"][2]["name"] == f"best: suggested (№{suggest_choice(a)})"
    for ch, comps in (("euler", ["roll", "pitch", "yaw"]), ("velocity", ["north", "east", "down"])):
        f = by_title[f"{ch} on drop {drop}: flight, suggested vector, Pareto envelope"]
        assert [ann["text"] for ann in f["layout"]["annotations"]] == comps
        named = {t.get("name") for t in f["data"]}
        assert {"flight", "model envelope (min–max)", f"suggested №{suggest_choice(a)}"} <= named
        unit = "deg" if ch == "euler" else "m/s"
        assert f["layout"]["yaxis"]["title"]["text"] == f"{comps[0]}, {unit}"
    spectra = by_title[f"Power spectra of the Euler angles on drop {drop}"]
    assert {t["name"] for t in spectra["data"]} == {
        "flight",
        f"suggested №{suggest_choice(a)}",
        "nominal",
    }
    assert a.n_pareto >= 1 and f"envelope over {min(12, a.n_pareto)} trials of the Pareto" in text


def test_identification_section_degrades_without_the_data(ident_report, tmp_path):
    """When the study's data files are not reachable from the store's location the report
    says so in the section instead of failing."""
    _, _, out = ident_report
    data, away = out / "data", out / "data-away"
    data.rename(away)
    try:
        with Study.open(out / "g12-step2-controlled.db") as st:
            res = write_report(st.store, tmp_path / "nodata.html")
    finally:
        away.rename(data)
    text, figs = _figures_of(res)
    assert ">Identification</h2>" in text
    assert "flight data of this study could not be loaded" in text and "not found" in text
    assert not any("Trajectories on drop" in f["layout"]["title"]["text"] for f in figs)
    assert ">Histograms</h2>" in text  # the rest of the report is there


@pytest.mark.slow
@pytest.mark.skipif(
    CHROMIUM is None or CHROMEDRIVER is None,
    reason="headless Chromium not installed (apt-get install chromium chromium-driver)",
)
def test_identification_report_renders_in_headless_chromium(ident_report):
    pytest.importorskip("selenium", reason="pip install selenium to drive Chromium")
    res, _, _ = ident_report
    shot = _render_and_check(res, "report-identification.png")
    assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_ui_chosen_trial_flies_against_the_flight_and_nominal_is_the_models(ident_report):
    """On the demo's step 2 (it shares this module's demo run): the UI's chosen-trial view
    simulates the trial and two overlays against the measured flight with the RMS per channel
    component, and "nominal" is the model's value (0.45 for x6), as `vectorid demo` prints."""
    pytest.importorskip("dash", reason="the UI needs the ui extra (dash)")
    from vectorid.views.ui import callbacks as cb
    from vectorid.views.ui.data import StoreCache
    from vectorid.views.ui.jobs import JobManager

    _, a, out = ident_report
    path = out / "g12-step2-controlled.db"
    ctx = cb.UIContext(cache=StoreCache(path), jobs=JobManager(path))
    ids = [int(i) for i in a.trials.id[:3]]
    v = cb.trial_view(ctx, str(ids[0]), None, None, None, f"{ids[1]}, {ids[2]}")
    assert v["identification"] is not None and len(v["rms"]) == 3
    assert [r["trial"] for r in v["rms"]] == [f"trial {i}" for i in ids]
    row = v["rms"][0]
    assert row["position.north RMS [m]"] >= 0 and "euler.yaw RMS [deg]" in row
    nominal = {p["name"]: p["nominal"] for p in v["params"]}
    assert nominal["x6"] == 0.45
    meaning = {p["name"]: p["meaning"] for p in v["params"]}
    assert "C_D" in meaning["x6"]
    with pytest.raises(Exception, match="at most two"):
        cb.trial_view(ctx, str(ids[0]), None, None, None, "2, 3, 4")
