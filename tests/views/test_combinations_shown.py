"""The combinations of gains D pins down (issue 34) where people read them (issue 36): the UI's
verdict panel on the first screen (the explorer's summary callback, as a plain function) and
the report's identifiability section, on a study where only x1 + x2 is determined."""

from __future__ import annotations

import pytest

pytest.importorskip("dash", reason="the UI needs the ui extra (dash)")

from tests.analysis.test_combinations import CENTRE, _sum_spec
from vectorid import Study
from vectorid.store import Store
from vectorid.views.report import build_report
from vectorid.views.ui import callbacks as cb
from vectorid.views.ui.data import StoreCache
from vectorid.views.ui.jobs import JobManager
from vectorid.views.ui.pages.common import verdict_panel


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    path = tmp_path_factory.mktemp("combos") / "s.db"
    with Study.create(_sum_spec(), path) as st:
        st.run(executor="inline", progress=False)
    return path


def _walk(node):
    yield node
    kids = getattr(node, "children", None)
    for k in kids if isinstance(kids, list) else [kids] if kids is not None else []:
        yield from _walk(k)


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
        chips = {getattr(n, "id", None): n for n in _walk(panel[-1])}
        chip = chips["vid-combo-1"]
        assert chip.className == "vchip v-identified"
        # hover: the reading in the gains' own units, x1 + x2 (in either order) in metres
        # around the centre the criterion asks for
        units = chip.title.split("in the gains' units: ")[1].split(";")[0]
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
    group = verdict_panel([], nd=100, combinations=items)[-1]
    shown = [c.id for c in group.children if getattr(c, "id", "").startswith("vid-combo-")]
    assert shown == [f"vid-combo-{k}" for k in range(1, 6)]  # every identified one
    folded = [c for c in group.children if type(c).__name__ == "Details"]
    assert len(folded) == 1 and folded[0].children[0].children == "3 more weak"
    assert [c.id for c in folded[0].children[1:]] == ["vid-combo-6", "vid-combo-7", "vid-combo-8"]
    few = verdict_panel([], nd=100, combinations=items[4:7])[-1]  # 1 identified, 2 weak
    assert not [c for c in few.children if type(c).__name__ == "Details"]
