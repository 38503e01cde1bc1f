"""A sequential store in the browser UI (real headless Chromium) and in the HTML report: the
counts are the store's, the page says which sampler made the trials, how many generations and
evaluations, D's members and ESS, the histograms of D say they are importance-weighted, a
chosen trial shows its generation and weight, and the console holds no error."""

from __future__ import annotations

import re

import numpy as np
import pytest

from tests.views.browser import (  # skips this module without dash, selenium or Chromium
    ARTIFACTS,
    By,
    chrome,
    serve,
    tab,
    text_of,
    type_into,
    until,
)
from vectorid import Study
from vectorid.samplers.sequential import assess, generations
from vectorid.spec import load_study

STUDY = """
[study]
name = "binh-korn-sequential"
model = "binh-korn"
trials = 256
sampler = "sequential"
budget = 6000
population = 100
seed = 1

[[variables]]
name = "x1"
low = 0.0
high = 5.0

[[variables]]
name = "x2"
low = 0.0
high = 3.0

[[criteria]]
name = "f1"
limit = 2.0

[[criteria]]
name = "f2"
limit = 42.0

[[constraints]]
name = "g1"
high = 25.0

[[constraints]]
name = "g2"
low = 7.7
"""


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    folder = tmp_path_factory.mktemp("uiseq")
    (folder / "seq.toml").write_text(STUDY, encoding="utf-8")
    path = folder / "seq.db"
    with Study.create(load_study(folder / "seq.toml"), path) as st:
        s = st.run(executor="inline", progress=False)
    assert s.converged and s.generations > 2, s.describe()
    return folder, path


def test_report_of_a_sequential_store(store):
    from vectorid.views.report import write_report

    folder, path = store
    with Study.open(path) as st:
        res = write_report(st.store, folder / "seq.html", max_points=300)
        state = assess(st.store)
    text = res.path.read_text(encoding="utf-8")
    plain = re.sub(r"<[^>]+>", "", text)
    assert "Sampler: sequential" in plain
    assert f"in {len(state.counts)} generations" in plain
    assert f"{sum(state.counts):,} evaluations" in plain
    assert f"ESS {state.ess:.0f}" in plain and "D reached" in plain
    assert "importance-weighted" in plain
    # the histograms figure says D's density is weighted, the sensitivity figure too
    assert "D's density importance-weighted (sequential sampler)" in text
    assert "in D, importance-weighted" in text
    assert "KS statistic: D" in text and ", importance-weighted" in text


def test_ui_on_a_sequential_store(store):
    folder, path = store
    with Study.open(path) as st:
        a = st.analysis()
        state = assess(st.store)
        gens = generations(st.store)
    later = np.flatnonzero(a.feasible & (state.generation >= 2))
    assert len(later)
    row = int(later[0])
    tid, gen = int(a.trials.id[row]), int(state.generation[row])
    with serve(path, folder) as url, chrome(url) as drv:
        until(drv, lambda d: text_of(d, "#count-nd") == str(a.n_feasible), "the initial ND")
        assert text_of(drv, "#count-n") == str(a.n) and a.n == sum(state.counts)
        # the message line comes with the summary, a callback after the counts' own
        until(drv, lambda d: "sequential sampler:" in text_of(d, "#messages"), "the sampler line")
        msg = text_of(drv, "#messages")
        assert f"{sum(state.counts)} evaluations in {len(gens)} generations" in msg, msg
        assert f"D holds {int(state.members.sum())} members, ESS {state.ess:.0f}" in msg, msg
        assert "Histograms of D are importance-weighted" in msg, msg
        until(
            drv,
            lambda d: "in D, importance-weighted" in text_of(d, "#hist-graph"),
            "the weighted histograms' legend",
        )
        assert "D's density importance-weighted" in text_of(drv, "#hist-graph")
        # a constraint loosened in the page: more members, still weighted
        a2 = Study.open(path).analysis({"f1": 4.0})
        assert a2.n_feasible > a.n_feasible
        type_into(drv, lambda d: d.find_element(By.ID, "vid-limit-f1"), "4")
        until(drv, lambda d: text_of(d, "#count-nd") == str(a2.n_feasible), "ND under f1 <= 4")
        until(
            drv,
            lambda d: f"D holds {a2.n_feasible} members" in text_of(d, "#messages"),
            "the sampler line under the loosened limit",
        )
        type_into(drv, lambda d: d.find_element(By.ID, "vid-limit-f1"), "")
        # a chosen trial of a later generation: its generation and importance weight
        type_into(drv, lambda d: d.find_element(By.ID, "trial-id"), str(tid))
        tab(drv, "Chosen trial")
        until(
            drv,
            lambda d: f"generation {gen}, importance weight" in text_of(d, "#trial-summary"),
            "the trial's generation and weight",
        )
        drv.save_screenshot(str(ARTIFACTS / "ui_sequential.png"))
        errors = [e for e in drv.get_log("browser") if e["level"] == "SEVERE"]
        assert errors == [], errors
