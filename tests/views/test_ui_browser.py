"""The browser UI in a real headless Chromium driven by Selenium: open a study, change a
constraint and see ND change (and a malformed one get a message), select a trial and see its
details, start a short refine stage and see the trial count grow, save the constraints with
the study and find them in force after a reload. Screenshots are kept under test-artifacts/
(git-ignored).

The server is the real ``vectorid ui`` command on 127.0.0.1 and a free port, stopped at the
end; every wait is bounded.
"""

from __future__ import annotations

import csv
import io
import json
import time
import urllib.error
import urllib.parse
import urllib.request

import numpy as np
import pytest

from tests.analysis_helpers import make_store
from tests.views.browser import (  # skips this module without dash, selenium or Chromium
    ARTIFACTS,
    WAIT,
    ActionChains,
    By,
    Keys,
    NoSuchElementException,
    StaleElementReferenceException,
    TimeoutException,
    WebDriverWait,
    by_id,
    chrome,
    serve,
    tab,
    text_of,
    type_into,
    until,
)
from vectorid import Study


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    folder = tmp_path_factory.mktemp("uibrowser")
    store = make_store(folder, "binh-korn", trials=512)
    with serve(store, folder) as url:
        yield url, store


@pytest.fixture(scope="module")
def browser(server):
    with chrome(server[0]) as drv:
        yield drv


_text, _until, _type, _by_id, _tab = text_of, until, type_into, by_id, tab


def _limit_input(drv, name: str):
    return drv.find_element(By.ID, f"vid-limit-{name}")


def _limit(name: str):
    return lambda d: _limit_input(d, name)


def _bound_input(drv, name: str, side: str):
    """The low or high field of a functional constraint."""
    return drv.find_element(By.ID, f"vid-{side}-{name}")


def _analysis(store, limits=None, roles=None):
    with Study.open(store) as st:
        return st.analysis(limits, roles)


def test_requests_cannot_reach_files_or_tracebacks(server):
    url, store = server
    # unknown paths get the app's page (Dash routes every path to it) or 404, never a file
    secrets = {"etc/passwd": "root:", "README.md": "# vectorid", "pyproject.toml": "[project]"}
    for path in (
        "../../etc/passwd",
        "%2e%2e/%2e%2e/etc/passwd",
        "static/../../README.md",
        "assets/pyproject.toml",
        "_dash-component-suites/../../pyproject.toml",
    ):
        try:
            with urllib.request.urlopen(url + path, timeout=10) as r:
                body = r.read().decode(errors="replace")
        except urllib.error.HTTPError as exc:
            assert exc.code in (400, 404), path
            continue
        assert not any(s in body for s in secrets.values()), path
    bad = urllib.request.Request(
        url + "_dash-update-component",
        data=b'{"output": "counts.children", "inputs": [{"id": "nope"}]}',
        headers={"Content-Type": "application/json"},
    )
    with pytest.raises(urllib.error.HTTPError) as err:
        urllib.request.urlopen(bad, timeout=10)
    body = err.value.read().decode(errors="replace")
    assert err.value.code >= 400 and "Traceback" not in body and 'File "' not in body


def test_constraint_changes_nd(browser, server):
    url, store = server
    drv = browser
    a0 = _analysis(store)
    _until(drv, lambda d: _text(d, "#count-nd") == str(a0.n_feasible), "the initial ND")
    assert _text(drv, "#count-n") == str(a0.n)
    _until(
        drv,
        lambda d: d.find_elements(By.CSS_SELECTOR, "#scatter .scatterlayer, #scatter canvas"),
        "the plot",
    )
    a1 = _analysis(store, {"f1": 20.0})
    assert a1.n_feasible != a0.n_feasible
    _type(drv, _limit("f1"), "20")
    _until(drv, lambda d: _text(d, "#count-nd") == str(a1.n_feasible), "ND under f1 <= 20")
    assert _text(drv, "#count-np") == str(a1.n_pareto)
    # the test table's f1 column now marks trials above 20 in red; the first rows are best
    _until(drv, lambda d: "f1 <= 20" in _text(d, "#in-force"), "the constraints in force")
    drv.save_screenshot(str(ARTIFACTS / "ui_constraint.png"))
    # malformed text: a visible message, the input marked, the counts keep the study's limit
    _type(drv, _limit("f1"), "twenty")
    _until(drv, lambda d: "expected a number" in _text(d, "#messages"), "the input message")
    assert _limit_input(drv, "f1").find_elements(
        By.XPATH, "ancestor-or-self::*[contains(concat(' ', @class, ' '), ' invalid ')]"
    )
    _until(drv, lambda d: _text(d, "#count-nd") == str(a0.n_feasible), "ND back at the study's")
    drv.save_screenshot(str(ARTIFACTS / "ui_bad_input.png"))
    _type(drv, _limit("f1"), "")
    _until(drv, lambda d: _text(d, "#messages") == "", "the message to clear")


def test_box_select_sets_two_constraints(browser, server):
    url, store = server
    drv = browser
    drag = drv.find_element(By.CSS_SELECTOR, "#scatter .nsewdrag")
    w, h = drag.size["width"], drag.size["height"]
    ActionChains(drv).move_to_element_with_offset(
        drag, -w // 5, -h // 5
    ).click_and_hold().move_by_offset(w // 10, h // 10).move_by_offset(
        w // 4, h // 4
    ).release().perform()
    _until(drv, lambda d: "box on f2 vs f1" in _text(d, "#sel-text"), "the box selection")
    drv.find_element(By.ID, "box-limits").click()
    _until(drv, lambda d: _limit_input(d, "f1").get_attribute("value"), "the f1 constraint")
    _until(drv, lambda d: _limit_input(d, "f2").get_attribute("value"), "the f2 constraint")
    f1 = float(_limit_input(drv, "f1").get_attribute("value"))
    f2 = float(_limit_input(drv, "f2").get_attribute("value"))
    a = _analysis(store, {"f1": f1, "f2": f2})
    _until(drv, lambda d: _text(d, "#count-nd") == str(a.n_feasible), "ND under the box limits")
    assert "set from the box" in _text(drv, "#box-msg")
    drv.save_screenshot(str(ARTIFACTS / "ui_box.png"))
    for name in ("f1", "f2"):
        _type(drv, _limit(name), "")
    drv.find_element(By.ID, "clear-sel").click()
    a0 = _analysis(store)
    _until(drv, lambda d: _text(d, "#count-nd") == str(a0.n_feasible), "the study's ND again")


def test_select_trial_shows_details(browser, server):
    url, store = server
    drv = browser
    a = _analysis(store)
    tid = int(a.trials.id[a.pareto][3])
    _type(drv, _by_id("trial-id"), str(tid))
    _tab(drv, "Chosen trial")
    _until(
        drv, lambda d: _text(d, "#trial-summary").startswith(f"trial {tid}: Pareto"), "the trial"
    )
    row = int((a.trials.id == tid).nonzero()[0][0])
    x1 = f"{a.trials.X[row, 0]:.6g}"
    _until(drv, lambda d: x1 in _text(d, "#trial-params"), "the parameter table")
    assert "Not an identification study" in _text(drv, "#trial-ident")
    # a section through it runs in the background and appears when done
    _type(drv, _by_id("sec-points"), "7")
    drv.find_element(By.ID, "sec-run").click()
    _until(drv, lambda d: "started: section" in _text(d, "#job-msg"), "the section job")
    _until(
        drv, lambda d: f"Section through trial {tid}" in _text(d, "#trial-results"), "the section"
    )
    # the section is in the store a moment before the job process reports back
    _until(drv, lambda d: _text(d, "#job-text").startswith("done"), "the job to finish")
    drv.save_screenshot(str(ARTIFACTS / "ui_trial.png"))
    # an unknown id is a message, not an error page
    _type(drv, _by_id("trial-id"), "987654")
    _until(drv, lambda d: "no sample trial has id 987654" in _text(d, "#trial-msg"), "the message")
    _type(drv, _by_id("trial-id"), str(tid))
    _until(drv, lambda d: _text(d, "#trial-msg") == "", "the message to clear")


def test_refine_stage_grows_the_study(browser, server):
    url, store = server
    drv = browser
    n0 = _analysis(store).n
    _tab(drv, "Refine & continue")
    _until(drv, lambda d: "volume ratio" in _text(d, "#ref-summary"), "the proposal")
    _type(drv, _by_id("ref-n"), "256")
    drv.find_element(By.ID, "ref-apply").click()
    _until(drv, lambda d: "started" in _text(d, "#job-msg"), "the job to start")
    # a second job while one runs gets a visible message
    drv.find_element(By.ID, "ref-continue").click()
    _until(drv, lambda d: "already running" in _text(d, "#job-msg"), "the busy message")
    _until(drv, lambda d: _text(d, "#count-n") == str(n0 + 256), "the trial count to grow")
    _until(drv, lambda d: _text(d, "#job-text").startswith("done"), "the job to finish")
    _until(drv, lambda d: "already running" not in _text(d, "#job-msg"), "the busy message to go")
    drv.save_screenshot(str(ARTIFACTS / "ui_refine.png"))
    _tab(drv, "Study overview")
    _until(drv, lambda d: "refine basis=feasible" in _text(d, "#ov-stages"), "the new stage")
    drv.save_screenshot(str(ARTIFACTS / "ui_overview.png"))
    with Study.open(store) as st:
        stages = [s for s in st.store.stages() if s.kind == "sample"]
        assert len(stages) == 2 and st.store.count(stages[1].stage) == 256


def test_saved_constraints_are_in_force_after_reload(browser, server):
    url, store = server
    drv = browser
    _tab(drv, "Test tables & plots")
    a0 = _analysis(store)
    _until(drv, lambda d: _text(d, "#count-n") == str(a0.n), "the tables tab")
    # a criteria constraint and a functional bound, typed
    a1 = _analysis(store, {"f1": 30.0, "g1": (None, 20.0), "g2": (7.7, None)})
    assert a1.n_feasible != a0.n_feasible and a1.n_functional != a0.n_functional
    a_f1 = _analysis(store, {"f1": 30.0})
    _type(drv, _limit("f1"), "30")
    # let the page settle before the next field: a re-render racing the typing could drop it
    _until(drv, lambda d: _text(d, "#count-nd") == str(a_f1.n_feasible), "ND under f1 <= 30")
    for attempt in range(3):
        _type(drv, lambda d: _bound_input(d, "g1", "high"), "20")
        try:
            WebDriverWait(
                drv,
                WAIT / 3,
                poll_frequency=0.2,
                ignored_exceptions=(StaleElementReferenceException, NoSuchElementException),
            ).until(lambda d: _text(d, "#count-nd") == str(a1.n_feasible))
            break
        except TimeoutException:
            if attempt == 2:
                raise AssertionError("timed out waiting for ND under the new bounds") from None
    _until(drv, lambda d: "g1 <= 20" in _text(d, "#in-force"), "the bounds in force")
    # a malformed bound is marked and named, and nothing is saved while it is
    _type(drv, lambda d: _bound_input(d, "g2", "low"), "seven")
    _until(drv, lambda d: "low bound of g2" in _text(d, "#messages"), "the bound's message")
    _until(  # re-found on every poll: Dash may re-render the field meanwhile
        drv,
        lambda d: _bound_input(d, "g2", "low").find_elements(
            By.XPATH, "ancestor-or-self::*[contains(concat(' ', @class, ' '), ' invalid ')]"
        ),
        "the malformed bound marked invalid",
    )
    drv.find_element(By.ID, "save-limits").click()
    _until(drv, lambda d: "outlined in red" in _text(d, "#job-msg"), "the refusal to save")
    _type(drv, lambda d: _bound_input(d, "g2", "low"), "7.7")
    _until(drv, lambda d: _text(d, "#messages") == "", "the message to clear")
    # save: a short background job
    drv.find_element(By.ID, "save-limits").click()
    _until(drv, lambda d: "started: saving" in _text(d, "#job-msg"), "the save job")
    _until(drv, lambda d: "saved with the study" in _text(d, "#job-text"), "the save to finish")
    assert _text(drv, "#job-text").startswith("done")
    with Study.open(store) as st:
        assert st.store.spec.criteria[0].limit == 30.0
        assert st.store.spec.constraints[0].high == 20.0
    _tab(drv, "Study overview")
    _until(drv, lambda d: "30" in _text(d, "#ov-criteria"), "the saved limit in the overview")
    assert "20" in _text(drv, "#ov-constraints")
    # a reload starts from the saved constraints: same fields, same ND (and the same tab,
    # kept in the URL)
    drv.refresh()
    _until(drv, lambda d: "tab=overview" in d.current_url, "the tab kept in the URL")
    _tab(drv, "Test tables & plots")
    _until(drv, lambda d: _limit_input(d, "f1").get_attribute("value") == "30", "f1 after reload")
    assert _bound_input(drv, "g1", "high").get_attribute("value") == "20"
    _until(drv, lambda d: _text(d, "#count-nd") == str(a1.n_feasible), "ND after the reload")
    assert "f1 <= 30" in _text(drv, "#in-force")
    drv.save_screenshot(str(ARTIFACTS / "ui_saved.png"))


def test_trial_table_sorts_filters_and_downloads_all_rows(browser, server):
    url, store = server
    drv = browser
    a = _analysis(store)
    _tab(drv, "Trial table")
    # the note is first drawn before the saved constraints are applied: wait for its count
    want = f"{a.n_pareto:,} trials in the pareto set"
    _until(drv, lambda d: want in _text(d, "#tab-note"), f"the table's note: {want}")
    # all trials, sorted by f1 ascending on the server: the first row is the true minimum
    drv.find_element(By.CSS_SELECTOR, "#tab-set input[value='all']").click()
    _until(drv, lambda d: f"{a.n:,} trials in the all set" in _text(d, "#tab-note"), "all set")
    head = drv.find_element(
        By.CSS_SELECTOR, "#vid-table th.dash-header.column-3 .column-header--sort"
    )
    head.click()
    ok = a.trials.F[:, 0][a.ok]
    first = f"{ok.min():.5g}"
    _until(
        drv,
        lambda d: (
            d.find_element(By.CSS_SELECTOR, "#vid-table td[data-dash-column='f1']").text == first
        ),
        "the smallest f1 first",
    )
    # a filter typed in the f2 header cell: resolved over every trial
    cell = drv.find_element(By.CSS_SELECTOR, "#vid-table th.dash-filter.column-4 input")
    cell.click()
    cell.send_keys("< 20", Keys.ENTER)
    want = int((a.trials.F[:, 1] < 20).sum())
    _until(
        drv,
        lambda d: f"{want:,} trials in the all set after the filter" in _text(d, "#tab-note"),
        "the filter",
    )
    drv.save_screenshot(str(ARTIFACTS / "ui_table.png"))
    href = drv.find_element(By.ID, "tab-csv").get_attribute("href")
    with urllib.request.urlopen(href, timeout=30) as r:
        lines = r.read().decode().strip().splitlines()
    assert len(lines) == 2 + want and lines[0].startswith("id,set,stage,f1,f2")
    drv.find_element(By.CSS_SELECTOR, "#tab-set input[value='pareto']").click()


def _live_ranges(drv, axis: str):
    """The brushes the page draws on one axis of the parallel coordinates, [[lo, hi], ...]."""
    return drv.execute_script(
        "return [...document.querySelectorAll('#par-graph .vid-axis[data-name=\"' + "
        "arguments[0] + '\"] .vid-brush')].map(b => [Number(b.dataset.lo), "
        "Number(b.dataset.hi)]);",
        axis,
    )


def _lines(drv) -> dict[str, int]:
    """What the page last drew on its parallel-coordinates canvas: lines, and how many
    of them lie within the brushes (all without a brush)."""
    d = drv.execute_script(
        "const c = document.querySelector('#par-graph canvas.vid-lines');"
        "return c ? Object.assign({}, c.dataset) : {};"
    )
    return {k: int(d.get(k, -1)) for k in ("lines", "selected")}


def _brush(drv, axis: str, top: float, bottom: float) -> None:
    """Drag along axis ``axis`` from ``top`` to ``bottom`` (fractions of its height from
    its top)."""
    for attempt in range(3):  # the page may lay its axes out again as it settles: find anew
        b = drv.find_element(By.CSS_SELECTOR, f"#par-graph .vid-hit[data-name='{axis}']")
        try:
            h = b.size["height"]
            ActionChains(drv).move_to_element_with_offset(
                b, 0, int(-h / 2 + top * h)
            ).click_and_hold().move_by_offset(0, 5).move_to_element_with_offset(
                b, 0, int(-h / 2 + bottom * h)
            ).release().perform()
            return
        except StaleElementReferenceException:
            ActionChains(drv).release().perform()
            if attempt == 2:
                raise
            time.sleep(0.5)


def test_parallel_brushes_select_and_one_action_makes_a_constraint(browser, server):
    """Two-sided brushes, two on one axis, are a selection (counted, exported with the D and
    Pareto flags); the button makes the f1 brushes f1's Φ** (their upper edge)."""
    url, store = server
    drv = browser
    _tab(drv, "Test tables & plots")
    prev = _limit_input(drv, "f1").get_attribute("value")
    nd0 = _text(drv, "#count-nd")
    _tab(drv, "Parallel coordinates & history")
    _until(drv, lambda d: d.find_elements(By.CSS_SELECTOR, "#par-graph .vid-hit"), "the axes")
    _until(drv, lambda d: _lines(d)["lines"] > 0, "the lines drawn")
    _brush(drv, "f1", 0.30, 0.55)  # f1: a band in the middle, neither end of the axis
    _until(drv, lambda d: len(_live_ranges(d, "f1")) == 1, "the first brush")
    _brush(drv, "f1", 0.75, 0.90)  # a second band on the same axis
    _until(drv, lambda d: len(_live_ranges(d, "f1")) == 2, "the second brush")
    rs = _live_ranges(drv, "f1")
    a = _analysis(store)
    f1 = a.trials.F[:, 0]
    sel = np.zeros(a.n, bool)
    for lo, hi in rs:
        assert f1.min() < lo < hi < f1.max()  # both edges kept, nothing snapped to an end
        sel |= (f1 >= lo) & (f1 <= hi)
    n, nd, npar = int(sel.sum()), int((sel & a.feasible).sum()), int((sel & a.pareto).sum())
    want = f"selected {n:,} trials: {nd:,} in D, of which {npar:,} Pareto"
    _until(drv, lambda d: _text(d, "#vid-sel") == want, "the selection's counts")
    assert _text(drv, "#count-nd") == nd0  # a brush is a selection, not a constraint
    # the page draws the lines itself (a 2D canvas, in a Web Worker): every line sent, those
    # outside the brushes greyed; no WebGL anywhere in the parallel coordinates
    _until(drv, lambda d: 0 < _lines(d)["selected"] < _lines(d)["lines"], "lines redrawn")
    assert drv.execute_script(
        "return [...document.querySelectorAll('#par-graph canvas')].map(c => c.className);"
    ) == ["vid-lines"]
    drv.save_screenshot(str(ARTIFACTS / "ui_parallel.png"))
    # the selection as CSV: every selected trial once, with its D and Pareto flags
    href = drv.find_element(By.ID, "sel-csv").get_attribute("href")
    with urllib.request.urlopen(href, timeout=30) as r:
        rows = list(csv.reader(io.StringIO(r.read().decode())))
    head, body = rows[0], rows[2:]
    assert head[-2:] == ["in_D", "pareto"] and len(body) == n
    ids = {int(r[0]): (int(r[-2]), int(r[-1])) for r in body}
    rows_of = {int(i): k for k, i in enumerate(a.trials.id)}
    assert all(
        (int(a.feasible[rows_of[i]]), int(a.pareto[rows_of[i]])) == f for i, f in ids.items()
    )
    assert sum(f[0] for f in ids.values()) == nd and sum(f[1] for f in ids.values()) == npar
    # one explicit action: the f1 brushes become f1's criteria constraint (upper edge)
    drv.find_element(By.ID, "par-to-limits").click()
    _until(drv, lambda d: "f1 <=" in _text(d, "#par-msg"), "the message")
    lim = float(_text(drv, "#par-msg").split("f1 <= ")[1].split(",")[0])
    assert lim == pytest.approx(max(hi for _, hi in rs), rel=1e-4)
    want = _analysis(store, {"f1": lim})
    _until(drv, lambda d: _text(d, "#count-nd") == str(want.n_feasible), "ND under the limit")
    assert _text(drv, "#count-np") == str(want.n_pareto)
    _until(drv, lambda d: "(this session)" in _text(d, "#vid-force-f1"), "the constraint chip")
    drv.find_element(By.ID, "par-clear").click()
    _until(drv, lambda d: _text(d, "#vid-sel") == "", "the selection cleared")
    _tab(drv, "Test tables & plots")
    _until(drv, lambda d: _limit_input(d, "f1").get_attribute("value") == f"{lim:.5g}", "field")
    _type(drv, _limit("f1"), prev)
    _until(drv, lambda d: _text(d, "#count-nd") == nd0, "ND back")


def test_the_url_holds_the_view_and_opens_it_again(browser, server):
    """Limits, a role, the tab, the axes, the chosen trial and a selection in the URL; a
    fresh page at that URL shows the same view and counts."""
    url, store = server
    drv = browser
    _tab(drv, "Test tables & plots")
    prev = _limit_input(drv, "f1").get_attribute("value")
    _type(drv, _limit("f1"), "35")
    want = _analysis(store, {"f1": 35.0}, {"f2": "pseudo"})
    drv.find_element(By.CSS_SELECTOR, "#vid-role-f2 input[value='pseudo']").click()
    _until(drv, lambda d: _text(d, "#count-np") == str(want.n_pareto), "NP with f2 pseudo")
    _type(drv, by_id("trial-id"), "17")
    _tab(drv, "Trial table")
    _until(drv, lambda d: "tab=table" in d.current_url, "the tab in the URL")
    shared = drv.current_url
    assert "lim.f1=35" in shared and "role.f2=pseudo" in shared and "trial=17" in shared
    with chrome(shared) as other:
        _until(other, lambda d: _text(d, "#count-nd") == str(want.n_feasible), "ND")
        assert _text(other, "#count-np") == str(want.n_pareto)
        assert other.find_element(By.ID, "trial-id").get_attribute("value") == "17"
        assert other.find_element(By.CSS_SELECTOR, ".tab--selected").text.strip() == "Trial table"
        _tab(other, "Test tables & plots")
        _until(other, lambda d: _limit_input(d, "f1").get_attribute("value") == "35", "f1")
        assert other.find_element(
            By.CSS_SELECTOR, "#vid-role-f2 input[value='pseudo']"
        ).is_selected()
        # a selection and the parallel axes' view travel too
        sel = {"kind": "ranges", "ranges": {"x1": [[1.0, 2.0]]}}
        a = _analysis(store, {"f1": 35.0}, {"f2": "pseudo"})
        x1 = a.trials.X[:, 0]
        n = int(((x1 >= 1) & (x1 <= 2)).sum())
        q = urllib.parse.quote(json.dumps(sel))
        other.get(shared.split("#")[0] + "#sel=" + q + "&tab=parallel&hide=g2&colour=x2")
        _until(other, lambda d: _text(d, "#vid-sel").startswith(f"selected {n:,} trials"), "sel")
        _until(other, lambda d: d.find_elements(By.CSS_SELECTOR, "#par-graph .vid-hit"), "axes")
        assert "x2" in _text(other, "#par-colour")
        shown = other.execute_script(
            "return [...document.querySelectorAll('#par-shown input')]"
            ".filter(i => i.checked).map(i => i.value);"
        )
        assert "g2" not in shown and "g1" in shown
        assert not other.find_elements(By.CSS_SELECTOR, "#par-graph .vid-axis[data-name='g2']")
        assert _live_ranges(other, "x1") == [[1.0, 2.0]]
    _tab(drv, "Test tables & plots")
    drv.find_element(By.CSS_SELECTOR, "#vid-role-f2 input[value='pure']").click()
    _type(drv, _limit("f1"), prev)
    _until(drv, lambda d: "lim.f1" not in d.current_url, "the URL back at the study's limit")


def test_histogram_rows_drawn_one_by_one_share_the_legend(browser, tmp_path):
    # The histogram grid is one graph per row of four panels (each drawn in a task of its
    # own): every row is drawn from the same answer with every parameter's panel, and a set
    # hidden in the first row's legend is hidden in every row.
    # osyczka-kundu: six parameters, two rows; this module's browser, another server
    store = make_store(tmp_path, "osyczka-kundu", trials=256)
    a = _analysis(store)
    drv = browser
    n = len(a.spec.space)
    rows = -(-n // 4)
    assert rows >= 2
    with serve(store, tmp_path) as url:
        drv.get(url)
        _rows_and_legend(drv, a, n, rows)


def _rows_and_legend(drv, a, n, rows):
    js_rows = """
    return Array.from(document.querySelectorAll('.vid-hist .js-plotly-plot')).map(g => [
      g._fullLayout && g._fullLayout.meta ? g._fullLayout.meta.rev : null,
      g._fullLayout && g._fullLayout.meta ? g._fullLayout.meta.nd : null,
      (g.data || []).filter(t => t.legendgroup === 'pareto').map(t => t.visible === undefined
        || t.visible === true ? 'shown' : String(t.visible))]);
    """

    def drawn(d):
        r = d.execute_script(js_rows)
        return len(r) == rows and len({x[0] for x in r}) == 1 and r[0][0] is not None and r

    got = _until(drv, drawn, "every row of the histogram grid")
    assert all(x[1] == a.n_feasible for x in got)
    assert sum(len(x[2]) for x in got) == n  # one Pareto trace per parameter's panel

    def pareto_entry(d):
        entries = d.find_elements(By.CSS_SELECTOR, "#hist-graph .legend .traces")
        return next(e for e in entries if e.text.startswith("Pareto"))

    pareto_entry(drv).click()
    _until(
        drv,
        lambda d: all(v == "legendonly" for x in d.execute_script(js_rows) for v in x[2]),
        "the Pareto set hidden in every row",
    )
    pareto_entry(drv).click()
    _until(
        drv,
        lambda d: all(v == "shown" for x in d.execute_script(js_rows) for v in x[2]),
        "the Pareto set shown again in every row",
    )
    # a click on a step of the second row selects that bin's trials, as on the first row
    area = drv.find_element(By.CSS_SELECTOR, "#hist-graph-2 .nsewdrag")
    ActionChains(drv).move_to_element(area).pause(0.3).click().perform()
    _until(drv, lambda d: "trials" in _text(d, "#vid-sel"), "a bin of the second row selected")
    logs = [e for e in drv.get_log("browser") if e.get("level") == "SEVERE"]
    assert not logs, logs
