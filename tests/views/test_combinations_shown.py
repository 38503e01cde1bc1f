"""The combinations of gains D pins down (issue 34) where people read them (issue 36): the UI's
verdict panel on the first screen (the explorer's summary callback, as a plain function) and
the report's identifiability section, on a study where only x1 + x2 is determined."""

from __future__ import annotations

from html.parser import HTMLParser

import pytest

pytest.importorskip("dash", reason="the UI needs the ui extra (dash)")

from tests.analysis.test_combinations import CENTRE, _sum_spec
from vectorid import Study
from vectorid.store import Store
from vectorid.views.report import build_report
from vectorid.views.ui import callbacks as cb
from vectorid.views.ui.data import StoreCache
from vectorid.views.ui.jobs import JobManager
from vectorid.views.ui.pages.common import verdict_panel, verdict_panel_html


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    path = tmp_path_factory.mktemp("combos") / "s.db"
    with Study.create(_sum_spec(), path) as st:
        st.run(executor="inline", progress=False)
    return path


class _Elements(HTMLParser):
    """The panel's markup read back: per element with an id, its tag, attributes and text,
    and the ids inside each ``<details>``."""

    def __init__(self, markup: str) -> None:
        super().__init__()
        self.by_id: dict[str, dict] = {}
        self.open: list[dict] = []
        self.folded: list[list[str]] = []
        self.summaries: list[str] = []
        self.feed(markup)

    def handle_starttag(self, tag, attrs):
        el = {"tag": tag, **dict(attrs), "text": ""}
        if tag == "details":
            self.folded.append([])
        elif "id" in el:
            self.by_id[el["id"]] = el
            if self.folded and any(o["tag"] == "details" for o in self.open):
                self.folded[-1].append(el["id"])
        self.open.append(el)

    def handle_endtag(self, tag):
        while self.open and self.open.pop()["tag"] != tag:
            pass

    def handle_data(self, data):
        for el in self.open:
            el["text"] += data
        if self.open and self.open[-1]["tag"] == "summary":
            self.summaries.append(data)


def test_the_verdict_panel_shows_the_combination_d_pins_down(store):
    cache = StoreCache(store)
    ctx = cb.UIContext(cache=cache, jobs=JobManager(store, executor="serial"))
    try:
        s = cb.summary_view(ctx, None, None)
        combos = s["combinations"]
        assert [c["verdict"] for c in combos] == ["identified"]
        assert "z(x1)" in combos[0]["text"] and "z(x2)" in combos[0]["text"]
        assert "z(x3)" not in combos[0]["text"]
        lo, hi = (float(v) for v in combos[0]["range"].strip("[]").split(","))
        assert lo < hi and 0 < combos[0]["width"] < 0.25
        panel = verdict_panel(s["verdict_groups"], nd=s["nd"], combinations=combos)
        # one element holding the escaped markup (the page puts it in place)
        assert panel.className == "vid-html"
        markup = getattr(panel, "data-html")
        assert markup == verdict_panel_html(s["verdict_groups"], nd=s["nd"], combinations=combos)
        chip = _Elements(markup).by_id["vid-combo-1"]
        assert chip["class"] == "vchip v-identified" and chip["data-verdict"] == "identified"
        assert chip["text"].startswith("c1 ") and combos[0]["range"] in chip["text"]
        # hover: the reading in the gains' own units, x1 + x2 (in either order) in metres
        # around the centre the criterion asks for
        units = chip["title"].split("in the gains' units: ")[1].split(";")[0]
        assert units.startswith(("x1 + 1·x2 in [", "x2 + 1·x1 in [")) and units.endswith("] m")
        ulo, uhi = (float(v) for v in units.split("[")[1].split("]")[0].split(","))
        assert ulo < CENTRE < uhi and uhi - ulo < 0.25
        # a tighter limit leaves D with one member: no combination shown, none invented
        s2 = cb.summary_view(ctx, ["1e-12"], ["pure"])
        assert s2["nd"] < 2 and s2["combinations"] == []
    finally:
        ctx.jobs.shutdown()


def test_the_report_shows_the_combinations_with_their_loadings(store):
    with Store.open(store) as st:
        html, _ = build_report(st)
    head = html.index("What D pins down")
    table = html.index("<h3>Combinations of gains D pins down</h3>")
    assert head < table  # at a glance first, then the table with loadings and units
    glance = html[head:table]
    assert "combinations (1 identified, 0 weak" in glance and "<b>c1</b>" in glance
    assert "z(x1)" in glance and "z(x2)" in glance
    assert "in the gains&#x27; units" in html[table:] or "in the gains' units" in html[table:]


def test_the_panel_folds_the_wider_weak_combinations_away():
    items = [
        {"text": f"+1.00 z(x{k})", "range": "[0, 0.5]", "width": 0.3, "verdict": v, "why": "",
         "own_units": f"x{k} in [0, 0.5]"}
        for k, v in enumerate(["identified"] * 5 + ["weak"] * 3, 1)
    ]  # fmt: skip
    got = _Elements(verdict_panel_html([], nd=100, combinations=items))
    combos = [i for i in got.by_id if i.startswith("vid-combo-")]
    assert len(got.folded) == 1 and got.summaries == ["3 more weak"]
    shown = [i for i in combos if i not in got.folded[0]]
    assert shown == [f"vid-combo-{k}" for k in range(1, 6)]  # every identified one
    assert got.folded[0] == ["vid-combo-6", "vid-combo-7", "vid-combo-8"]
    few = _Elements(verdict_panel_html([], nd=100, combinations=items[4:7]))  # 1 id., 2 weak
    assert not few.folded and len([i for i in few.by_id if i.startswith("vid-combo-")]) == 3


def test_the_panel_escapes_what_it_shows():
    """Names, meanings and reasons reach the page as text, never as markup."""
    groups = [
        {
            "verdict": "weak",
            "items": [
                {"name": "k<b>", "range": "[0, 1]", "unit": "m/s", "meaning": 'a "quoted" <i>',
                 "share": 0.5, "why": "x & y", "ranges": {"box": [0, 2], "feasible": [0, 1],
                                                          "pareto": None}}
            ],
        }
    ]  # fmt: skip
    markup = verdict_panel_html(groups, nd=10, relaxed="limits relaxed x1.5 <now>")
    assert "<i>" not in markup and "k<b>" not in markup and "<now>" not in markup
    got = _Elements(markup)
    chip = got.by_id["vid-vchip-k_b_"]
    assert chip["text"] == "k<b> [0, 1] m/s" and chip["data-verdict"] == "weak"
    assert chip["title"] == 'a "quoted" <i>; x & y'
    assert got.by_id["vid-relaxed"]["text"] == "limits relaxed x1.5 <now>"
