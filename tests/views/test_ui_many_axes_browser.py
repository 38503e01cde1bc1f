"""A 33-gain, 8-criterion study in the browser UI (real headless Chromium, 1,500 px wide):
the parallel coordinates stay legible with every one of their 41 axes shown — no two axis
titles overlap, nor any two of their labels, and every title says its unit or that none is
given —, the axes shown at first are the criteria and the gains D depends on most, and
limits that a stage relaxed as the last resort are named so wherever they appear."""

from __future__ import annotations

import re

import pytest

from tests.views.browser import ARTIFACTS, By, chrome, serve, tab, text_of, until
from tests.views.many_axes import CRITERIA, GAINS, many_axes_store
from vectorid import Study

_BOXES = """
const host = document.querySelector('#par-graph');
const box = e => { const r = e.getBoundingClientRect();
  return {x0: r.left, x1: r.right, y0: r.top, y1: r.bottom}; };
const titles = [...host.querySelectorAll('.vid-title')].map(g => Object.assign(box(g), {
  name: g.dataset.name, text: g.querySelector('text').textContent,
  tip: (g.querySelector('title') || {}).textContent || ''}));
const labels = [...host.querySelectorAll('svg text')].map(t => Object.assign(box(t),
  {text: t.textContent}));
return {titles: titles, labels: labels, width: host.getBoundingClientRect().width};
"""


def _overlaps(boxes: list[dict]) -> list[tuple[str, str]]:
    out = []
    for i, a in enumerate(boxes):
        for b in boxes[i + 1 :]:
            if min(a["x1"], b["x1"]) - max(a["x0"], b["x0"]) > 0.5 and (
                min(a["y1"], b["y1"]) - max(a["y0"], b["y0"]) > 0.5
            ):
                out.append((a["text"], b["text"]))
    return out


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    folder = tmp_path_factory.mktemp("ui33")
    store = many_axes_store(folder)
    with serve(store, folder) as url:
        yield url, store


def _axes(drv, want: int) -> dict:
    until(drv, lambda d: len(d.execute_script(_BOXES)["titles"]) == want, f"{want} axes")
    return drv.execute_script(_BOXES)


def _check_legible(got: dict) -> None:
    assert not _overlaps(got["titles"]), _overlaps(got["titles"])
    assert not _overlaps(got["labels"]), _overlaps(got["labels"])[:5]
    for t in got["titles"]:  # "name [unit]", "name [-]" or "name [no unit given]"
        assert re.fullmatch(re.escape(t["name"]) + r"\s*\[[^\]]+\]", t["text"]), t["text"]
        assert t["tip"].startswith(t["text"]), t  # the hover repeats it, with the kind


def test_41_axes_legible_and_relaxed_limits_named(server):
    url, store = server
    with Study.open(store) as st:
        a = st.analysis()
        units = {v.name: v.unit for v in st.spec.space} | dict(CRITERIA)
    with chrome(url + "#tab=parallel", size="1500,1000") as drv:
        # at first: the 8 criteria and the 8 gains D depends on most (16 axes, across)
        got = _axes(drv, 16)
        names = [t["name"] for t in got["titles"]]
        assert names[:8] == [c for c, _ in CRITERIA] and set(names[8:]) <= set(GAINS)
        _check_legible(got)
        for t in got["titles"]:
            u = units[t["name"]]
            assert t["text"].endswith(f"[{u}]" if u else "[no unit given]"), t["text"]
        drv.save_screenshot(str(ARTIFACTS / "ui_parallel_33_default.png"))
        # every axis: 41 of them on 1,500 px, still no overlap, still a unit each
        tab(drv, "Test tables & plots")
        drv.get(url + "#tab=parallel&hide=")
        got = _axes(drv, 41)
        assert got["width"] <= 1500
        _check_legible(got)
        drv.save_screenshot(str(ARTIFACTS / "ui_parallel_33_all.png"))
        # the relaxed limits: said on the first screen and on each card, never a stand-in
        tab(drv, "Test tables & plots")
        until(drv, lambda d: "relaxed x" in text_of(d, "#vid-relaxed"), "the relaxation")
        for c, _ in CRITERIA:
            src = text_of(drv, f"#vid-source-{c}")
            assert src.startswith("relaxed x") and "last resort" in src, src
            assert "stand-in" not in src
        chips = drv.find_elements(By.CSS_SELECTOR, "#vid-verdicts .vchip")
        assert len(chips) == 33
    assert a.n == 4000
