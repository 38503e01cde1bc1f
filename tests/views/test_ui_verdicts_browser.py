"""Identifiability verdicts and the limits' sources in the browser UI, on the G-12 demo
(reduced: 128 trials per step), driven in a real headless Chromium through stable ids:
``vid-verdicts`` (the explorer's verdict panel, one chip per variable),
``vid-source-<criterion>`` (where each limit came from), ``vid-verdict-<parameter>`` (the
refine view's rows), ``vid-trial-param-<parameter>`` (the chosen trial's parameters),
``vid-force-<criterion>`` and ``par-verdicts`` (beside the parallel coordinates).

Checked against :func:`vectorid.analysis.identifiability.identifiability` on the store: the
verdicts are shown, a parameter that is not identified is shown as its range with its
verdict (never as a lone value), a tightened limit changes a verdict or a range everywhere,
and each limit says where it came from, through a save and a reload.
"""

from __future__ import annotations

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
from vectorid.analysis.identifiability import identifiability
from vectorid.views.ui.verdicts import span, verdict_line

STEP2 = "g12-step2-controlled.db"


@pytest.fixture(scope="module")
def demo_server(tmp_path_factory):
    from vectorid.cli import main

    out = tmp_path_factory.mktemp("uidemo")
    assert main(["demo", "--out", str(out), "--trials", "128", "--quiet"]) == 0
    with serve(out / STEP2, out) as url:
        yield url, out / STEP2


@pytest.fixture(scope="module")
def drv(demo_server):
    with chrome(demo_server[0]) as d:
        yield d


def _verdicts(store, limits=None):
    with Study.open(store) as st:
        a = st.analysis(limits)
        return a, identifiability(a, stages=st.store.stages())


def _attr(d, id_: str, name: str) -> str:
    els = d.find_elements(By.ID, id_)
    return (els[0].get_attribute(name) or "") if els else ""


def _check_rows(d, prefix: str, vs) -> None:
    """Every parameter's row shows its verdict and its feasible and Pareto ranges."""

    def shown(d, v) -> bool:
        row = d.find_element(By.ID, f"{prefix}-{v.name}")
        text = row.text
        return (
            row.get_attribute("data-verdict") == v.verdict
            and span(v.feasible) in text
            and span(v.pareto) in text
        )

    for v in vs:
        until(d, lambda d, v=v: shown(d, v), f"{v.name}: {v.verdict}, {span(v.feasible)}")


def _panel_shows(d, vs) -> bool:
    """The explorer's verdict panel: one chip per variable, under its verdict, holding the
    range of D (never a lone value)."""
    for v in vs:
        chip = d.find_elements(By.ID, f"vid-vchip-{v.name}")
        if not chip or chip[0].get_attribute("data-verdict") != v.verdict:
            return False
        if v.feasible is not None and span(v.feasible) not in chip[0].text:
            return False
    return True


def test_verdicts_ranges_and_sources(demo_server, drv):
    url, store = demo_server
    a, vs = _verdicts(store)
    by = {v.verdict for v in vs}
    assert "identified" in by and "not identified" in by  # the demo shows both kinds
    # -- the explorer: the verdict line, and each limit's source on its card --------------------
    until(drv, lambda d: _panel_shows(d, vs), "the verdict panel")
    with Study.open(store) as st:
        crit = st.spec.criteria
    for c in crit:
        assert c.source == "noise"  # the demo states its sensor noise
        src = _attr(drv, f"vid-source-{c.name}", "textContent")
        assert src == c.limit_note and src.startswith("noise floor q="), src
        assert "src-noise" in _attr(drv, f"vid-source-{c.name}", "class")
    drv.save_screenshot(str(ARTIFACTS / "ui_limit_sources.png"))
    # -- refine view: one row per parameter --------------------------------------------------
    tab(drv, "Refine & continue")
    _check_rows(drv, "vid-verdict", vs)
    open_ = [v for v in vs if not v.identified]
    row = drv.find_element(By.ID, f"vid-verdict-{open_[0].name}").text
    assert "not identified" in row and "to identify it" in row
    drv.save_screenshot(str(ARTIFACTS / "ui_verdicts_refine.png"))
    # -- chosen trial: a value only where identified ---------------------------------------
    tab(drv, "Chosen trial")
    tid = int(_attr(drv, "trial-id", "value"))
    until(drv, lambda d: text_of(d, "#trial-summary").startswith(f"trial {tid}:"), "the trial")
    _check_rows(drv, "vid-trial-param", vs)
    x = a.trials.X[int(np.flatnonzero(a.trials.id == tid)[0])]
    for v, xv in zip(vs, x):
        cell = drv.find_element(By.CSS_SELECTOR, f"#vid-trial-param-{v.name} td.shown").text
        if v.identified:
            assert cell.startswith(f"{xv:.5g}") and span(v.feasible) in cell, cell
        else:
            assert cell.startswith(f"feasible {span(v.feasible)}"), cell
            assert f"({v.verdict})" in cell, cell
    drv.save_screenshot(str(ARTIFACTS / "ui_verdicts_trial.png"))


def _tightened(store, a, vs):
    """A tighter limit on a pure criterion that changes a verdict or a feasible range."""
    for j, name in enumerate(a.crit_names):
        if a.roles[j] != "pure":
            continue
        col = a.trials.F[a.feasible, j]
        for q in (0.5, 0.3, 0.7):
            text = f"{np.quantile(col, q):.5g}"
            a2, vs2 = _verdicts(store, {name: float(text)})
            if a2.n_feasible and [(v.verdict, v.feasible) for v in vs2] != [
                (v.verdict, v.feasible) for v in vs
            ]:
                return name, text, a2, vs2
    raise AssertionError("no tighter limit changes a verdict or a range")


def test_tightened_limit_changes_verdicts_and_its_source_survives_a_save(demo_server, drv):
    url, store = demo_server
    a, vs = _verdicts(store)
    name, text, a2, vs2 = _tightened(store, a, vs)
    tab(drv, "Test tables & plots")
    type_into(drv, lambda d: d.find_element(By.ID, f"vid-limit-{name}"), text)
    until(drv, lambda d: text_of(d, "#count-nd") == str(a2.n_feasible), "ND under the limit")
    until(drv, lambda d: _panel_shows(d, vs2), "the new verdicts")
    with Study.open(store) as st:
        saved = {c.name: c for c in st.spec.criteria}[name]
    want = f"this session: replaces the saved <= {saved.limit:.5g} (noise floor)"
    until(drv, lambda d: _attr(d, f"vid-source-{name}", "textContent") == want, "the source")
    assert "src-session" in _attr(drv, f"vid-source-{name}", "class")
    drv.save_screenshot(str(ARTIFACTS / "ui_limit_this_session.png"))
    # beside the parallel coordinates: the limits in force (this one marked) and the verdicts
    tab(drv, "Parallel coordinates & history")
    until(
        drv,
        lambda d: text_of(d, f"#vid-force-{name}") == f"{name} <= {text} (this session)",
        "the changed limit beside the brushes",
    )
    assert "src-session" in _attr(drv, f"vid-force-{name}", "class")
    others = [c for c in a.crit_names if c != name]
    assert text_of(drv, f"#vid-force-{others[0]}").endswith("(noise floor)")
    until(drv, lambda d: text_of(d, "#par-verdicts") == verdict_line(vs2), "the verdicts there")
    drv.save_screenshot(str(ARTIFACTS / "ui_parallel_in_force.png"))
    # the refine view and the chosen trial follow
    tab(drv, "Refine & continue")
    _check_rows(drv, "vid-verdict", vs2)
    drv.save_screenshot(str(ARTIFACTS / "ui_verdicts_refine_tightened.png"))
    tab(drv, "Chosen trial")
    _check_rows(drv, "vid-trial-param", vs2)
    # save: the tightened limit is the expert's, set in the UI; the others stay noise floors
    tab(drv, "Test tables & plots")
    drv.find_element(By.ID, "save-limits").click()
    until(drv, lambda d: "saved with the study" in text_of(d, "#job-text"), "the save")
    with Study.open(store) as st:
        after = {c.name: c for c in st.spec.criteria}
    assert after[name].limit == float(text) and after[name].source == "expert"
    assert after[name].limit_note == "set in the browser UI"
    assert all(after[o].source == "noise" and after[o].limit_note for o in others)
    drv.refresh()
    until(
        drv,
        lambda d: _attr(d, f"vid-source-{name}", "textContent") == "expert: set in the browser UI",
        "the saved source after a reload",
    )
    assert _attr(drv, f"vid-source-{others[0]}", "textContent").startswith("noise floor q=")
    until(drv, lambda d: _panel_shows(d, vs2), "verdicts after reload")
