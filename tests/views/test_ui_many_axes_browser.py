"""A 33-gain, 8-criterion study in the browser UI (real headless Chromium, 1,500 px wide):
the parallel coordinates stay legible with every one of their 41 axes shown — no two axis
titles overlap, nor any two of their labels, and every title says its unit or that none is
given —, the axes shown at first are the criteria and the gains D depends on most, and
limits that a stage relaxed as the last resort are named so wherever they appear."""

from __future__ import annotations

import re

import numpy as np
import pytest

from tests.views.browser import (
    ARTIFACTS,
    ActionChains,
    By,
    chrome,
    serve,
    tab,
    text_of,
    type_into,
    until,
)
from tests.views.many_axes import CRITERIA, GAIN_UNITS, GAINS, many_axes_store
from vectorid import Study

_BOXES = """
const host = document.querySelector('#par-graph');
if (!host) return {titles: [], labels: [], width: 0};  // the page not yet laid out
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


#: The gains' panel titles: ``name [unit]``, or the name alone if dimensionless or unitless.
SHORT = [f"{g} [{u}]" if u and u != "-" else g for g, u in zip(GAINS, GAIN_UNITS)]

#: Each row of the refine view's histograms: its place on screen, the answer it shows, its
#: panels' titles and the totals of its first panel's sets (all, in D, Pareto).
_ROWS = """
return [...document.querySelectorAll('#ref-hist .vid-lazy-row')].map(el => {
  const r = el.getBoundingClientRect(), fl = el._fullLayout, fd = el._fullData || [];
  const tot = c => { const t = fd.find(t => t.meta && t.meta.class === c);
    return t ? t.meta.total : null; };
  return {id: el.id, top: r.top, bottom: r.bottom, rev: el.dataset.rev || null,
    titles: fl ? fl.annotations.map(a => a.text) : [],
    all: tot('all'), nd: tot('feasible'), np: tot('pareto'),
    rects: fl ? fl.shapes.filter(s => s.type === 'rect').length : 0};
});
"""


def test_refine_histograms_drawn_when_scrolled_to(server):
    """The refine view's 33 histograms (nine rows): the rows on screen are drawn at once,
    those below the fold only when scrolled to, each with its panels' titles, both boxes and
    the sets' totals of the constraints in force; a limit typed on the explorer reaches them
    too, when the tab is shown again."""
    url, store = server
    with Study.open(store) as st:
        a = st.analysis()
    win = 1000
    with chrome(url + "#tab=refine", size=f"1500,{win}") as drv:
        until(drv, lambda d: "volume ratio" in text_of(d, "#ref-summary"), "the proposal")
        until(drv, lambda d: d.execute_script("return window.vid.lazyIdle();"), "rows on screen")
        # the verdict table (one element holding its markup): a row per gain, with its verdict
        until(
            drv,
            lambda d: len(d.find_elements(By.CSS_SELECTOR, "#ref-verdicts tr[data-verdict]")) == 33,
            "the 33 verdict rows",
        )
        rows = drv.execute_script(_ROWS)
        assert [r["id"] for r in rows] == ["ref-graph"] + [f"ref-graph-{k}" for k in range(2, 10)]
        height = drv.execute_script("return window.innerHeight;")
        for r in rows:  # drawn if on screen (or within 300 px of it), else not yet
            assert (r["rev"] is not None) == (r["top"] < height + 300), (r, height)
        assert rows[-1]["rev"] is None  # the last row is far below the proposal's table
        drv.execute_script("document.getElementById('ref-graph-9').scrollIntoView();")
        until(drv, lambda d: d.execute_script(_ROWS)[-1]["rev"] is not None, "the last row")
        last = drv.execute_script(_ROWS)[-1]
        assert last["titles"] == [SHORT[-1]]
        assert last["rects"] == 2  # the current and the proposed box
        assert (last["all"], last["nd"], last["np"]) == (a.n, a.n_feasible, a.n_pareto)
        drv.save_screenshot(str(ARTIFACTS / "ui_refine_33_scrolled.png"))
        # every row, scrolled through: 33 panels in all, in the variables' order
        for k in range(1, 9):
            rid = "ref-graph" if k == 1 else f"ref-graph-{k}"
            drv.execute_script(f"document.getElementById('{rid}').scrollIntoView();")
            until(drv, lambda d, k=k: d.execute_script(_ROWS)[k - 1]["rev"] is not None, rid)
        titles = [t for r in drv.execute_script(_ROWS) for t in r["titles"]]
        assert titles == SHORT, titles
        # a tighter limit typed on the explorer (D's median of pos_h): the rows follow once
        # the tab is shown again
        half = f"{np.median(a.trials.F[a.feasible, 0]):.6g}"
        drv.execute_script("window.scrollTo(0, 0);")
        tab(drv, "Test tables & plots")
        type_into(drv, lambda d: d.find_element(By.ID, "vid-limit-pos_h"), half)
        nd0 = f"{a.n_feasible:,}"
        until(drv, lambda d: text_of(d, "#count-nd") not in ("", nd0), "new counts")
        nd = int(text_of(drv, "#count-nd").replace(",", ""))
        assert 0 < nd < a.n_feasible
        tab(drv, "Refine & continue")
        drv.execute_script("window.scrollTo(0, document.body.scrollHeight);")
        until(drv, lambda d: d.execute_script(_ROWS)[-1]["nd"] == nd, "the last row, redrawn")
        assert drv.execute_script(_ROWS)[-1]["all"] == a.n
        errors = [e for e in drv.get_log("browser") if e["level"] == "SEVERE"]
        assert not errors, errors


#: Each row of the explorer's histogram grid: its place, the answer drawn (``data-rev``), the
#: ND its figure was drawn for and its panels' titles.
_HIST_ROWS = """
return [...document.querySelectorAll('.vid-hist > [id]')].map(el => {
  const r = el.getBoundingClientRect(), gd = el.querySelector('.js-plotly-plot');
  const fl = gd && gd._fullLayout, m = fl && fl.meta;
  return {id: el.id, top: r.top, rev: el.dataset.rev || null, nd: m ? m.nd : null,
    titles: m ? fl.annotations.map(a => a.text) : []};
});
"""


#: The offset (px) from the centre of a row's first panel to the second vertex of its first
#: trace (all trials: a step's corner, where a click picks that bin).
_VERTEX = """
const gd = document.querySelector('#' + arguments[0] + ' .js-plotly-plot');
const t = gd._fullData[0], xa = gd._fullLayout.xaxis, ya = gd._fullLayout.yaxis;
const box = gd.querySelector('.nsewdrag').getBoundingClientRect(), g = gd.getBoundingClientRect();
const px = g.left + xa._offset + xa.l2p(t.x[1]), py = g.top + ya._offset + ya.l2p(t.y[1]);
return [Math.round(px - (box.left + box.width / 2)), Math.round(py - (box.top + box.height / 2))];
"""


def test_explorer_histograms_drawn_when_scrolled_to(server):
    """The explorer's 33 histograms (nine rows, each a Dash graph): the rows below the fold
    are drawn only when scrolled to, with every panel, and a click on a step of the last
    row selects that bin's trials as on the first row."""
    url, store = server
    with Study.open(store) as st:
        a = st.analysis()
    with chrome(url, size="1500,1000") as drv:
        until(drv, lambda d: [r for r in d.execute_script(_HIST_ROWS) if r["rev"]], "a row drawn")
        until(drv, lambda d: d.execute_script("return window.vid.lazyIdle();"), "rows on screen")
        rows = drv.execute_script(_HIST_ROWS)
        assert len(rows) == 9
        height = drv.execute_script("return window.innerHeight;")
        for r in rows:
            assert (r["rev"] is not None) == (r["top"] < height + 300), (r, height)
        assert rows[-1]["rev"] is None
        for k in range(len(rows)):  # scrolled through: every panel, in the gains' order
            drv.execute_script(f"document.getElementById('{rows[k]['id']}').scrollIntoView();")
            until(drv, lambda d, k=k: d.execute_script(_HIST_ROWS)[k]["rev"], rows[k]["id"])
        rows = drv.execute_script(_HIST_ROWS)
        assert [t for r in rows for t in r["titles"]] == SHORT
        assert {r["nd"] for r in rows} == {a.n_feasible} and len({r["rev"] for r in rows}) == 1
        area = drv.find_element(By.CSS_SELECTOR, "#hist-graph-9 .nsewdrag")
        dx, dy = drv.execute_script(_VERTEX, "hist-graph-9")
        ActionChains(drv).move_to_element_with_offset(area, dx, dy).pause(0.3).click().perform()
        until(drv, lambda d: "trials" in text_of(d, "#vid-sel"), "a bin of the last row selected")
        errors = [e for e in drv.get_log("browser") if e["level"] == "SEVERE"]
        assert not errors, errors


#: The explorer's verdict panel as the page shows it: each chip's id, verdict, text, hover,
#: group and place; the groups' headings; how many elements the panel's markup sits in.
_PANEL = """
const host = document.getElementById('vid-verdicts');
if (!host) return {chips: []};  // the page not yet laid out
const chip = el => ({id: el.id, verdict: el.dataset.verdict, text: el.textContent.trim(),
  tip: el.title, group: el.closest('.vgroup').querySelector('.vgroup-name').textContent,
  folded: !!el.closest('details'), top: el.getBoundingClientRect().top});
return {holders: host.querySelectorAll('.vid-html').length,
  chips: [...host.querySelectorAll('[id^="vid-vchip-"]')].map(chip),
  combos: [...host.querySelectorAll('[id^="vid-combo-"]')].map(chip),
  heads: [...host.querySelectorAll('.vgroup-name')].map(e => e.textContent),
  bars: host.querySelectorAll('.vchip .rangebar').length, height: window.innerHeight};
"""


def test_verdict_panel_shows_what_d_pins_down_on_the_first_screen(server):
    """The explorer's first screen on the 33-gain store: every gain under its verdict with
    D's range and unit and a range bar, hovered with why; the combinations D pins down with
    their ranges and widths (none here: no combination is invented); all as the analysis of
    the store has them, from one element holding the panel's escaped markup."""
    from vectorid.analysis.combinations import identifiable_combinations
    from vectorid.analysis.identifiability import identifiability
    from vectorid.views.ui.verdicts import combination_items, span

    url, store = server
    with Study.open(store) as st:
        a = st.analysis()
        vs = {v.name: v for v in identifiability(a, stages=st.store.stages())}
        combos = combination_items(identifiable_combinations(a))
        units = {v.name: v.unit for v in st.spec.space}
    assert len(vs) == 33
    with chrome(url) as drv:
        until(drv, lambda d: len(d.execute_script(_PANEL)["chips"]) == 33, "33 verdict chips")
        got = drv.execute_script(_PANEL)
    assert got["holders"] == 1 and got["bars"] == 33
    counts = {}
    for c in got["chips"]:
        v = vs[c["id"].removeprefix("vid-vchip-")]
        assert c["verdict"] == v.verdict and c["group"].startswith(v.verdict + " ("), c
        rng = span(v.feasible) if v.feasible is not None else f"none in D (box {span(v.box)})"
        unit = units[v.name] if units[v.name] not in ("", "-") else ""
        assert c["text"] == f"{v.name} {rng}" + (f" {unit}" if unit else ""), c
        assert v.reason in c["tip"], c
        counts[v.verdict] = counts.get(v.verdict, 0) + 1
    for verdict, n in counts.items():  # each group's heading counts its chips
        assert f"{verdict} ({n})" in got["heads"]
    n_id = sum(c["verdict"] == "identified" for c in combos)
    heading = f"combinations ({n_id} identified, {len(combos) - n_id} weak)"
    assert (heading in got["heads"]) == bool(combos)  # none shown where D pins none down
    assert [c["id"] for c in got["combos"]] == [f"vid-combo-{k}" for k in range(1, len(combos) + 1)]
    for c, want in zip(got["combos"], combos):
        assert c["verdict"] == want["verdict"] and want["range"] in c["text"], (c, want)
        assert f"width {100 * want['width']:.0f} %" in c["text"]
        assert c["tip"].startswith(f"in the gains' units: {want['own_units']}")
    # the gains' chips are on the first screen (the combinations may run below it)
    assert max(c["top"] for c in got["chips"]) < got["height"]
