"""Benchmark: latency of the browser UI on 1e5 and 1e6 trials, on the server and in the browser.

Usage::

    nice -n 5 .venv/bin/python benchmarks/ui.py [--trials 100000] [--criteria 6] [--params 12]
                                      [--changes 8] [--browser] [--browser-trials 100000 1000000]
                                      [--repeats 5] [--no-server] [--job-trials 0]

A synthetic store is written (as in ``benchmarks/report.py``: criteria from a cheap closed
form, 0.5 % failed trials, four criteria constraints saved with the study). Then:

**Server side** (always): a sequence of constraint changes (the first criterion's limit drawn
among its quantiles, seeded) goes through the *same plain functions the Dash callbacks call*
(:mod:`vectorid.views.ui.callbacks`), each response serialised with
``plotly.io.json.to_json_plotly`` as Dash does: ``counts`` (N/ND/NP alone), ``test tables``,
``scatter`` (criterion vs criterion), ``histograms``, ``criterion vs param``, ``parallel``,
and ``verdicts`` (the identifiability verdicts and the limits' sources under the new limit,
computed once per constraint set; the ``test tables`` request, which shows them in one line
on the explorer, reuses them).
Baselines in the same run, same changes: ``reload`` (no trial cache: the store is read and
analysed again on every change) and ``no thinning`` (every trial drawn as a point).
``ratio`` = baseline / ours (> 1: ours is faster).

**In the browser** (``--browser``): ``vectorid ui`` serves the store and headless Chromium
drives it (software WebGL, so pessimistic), each action ``--repeats`` times (default 5; median
and max printed, the verdict against the issue's goal on the max). Measured in the page, from
the action to the redrawn DOM (two animation frames after the last change):

* ``page load``: navigation start to the counts, the criterion plot and the histograms (every
  row of the grid on screen; a row below the fold is drawn when scrolled to) drawn (the
  first load, which fills the browser's cache, not counted);
* ``limit -> counts``: Enter in the first criterion's limit field (``#vid-limit-f1``) to
  N/ND/NP redrawn (``#vid-counts``);
* ``limit -> everything``: the same change to the criterion plot's title showing the new ND,
  every row of the histogram grid on screen drawn from the new answer with the new ND (its
  ``layout.meta``: the first row's legend among them when it is on screen), and nothing
  loading any more;
* ``brush -> counts``: releasing the mouse (``pointerup``) after a brush on an axis of the
  parallel coordinates (a band from a quarter of the axis to below its middle, one axis
  after the other, each on its own) to the selection's counts in the header (``#vid-sel``).
  The page draws the axes and brushes itself (SVG); the server does not redraw the
  parallel coordinates on a brush;
* ``brush -> lines redrawn``: the same mouse release to the page's last drawing of the
  parallel coordinates' lines (a 2D canvas in a Web Worker; grey outside the brushes);
* ``loosen -> counts`` and ``loosen -> everything``: the loosening case: the first
  criterion's limit typed tight (its 5 % quantile), then, once everything is drawn, loosened
  (a quantile from 30 to 60 %, seeded): Enter to N/ND/NP redrawn, and to everything redrawn
  (as ``limit -> everything``), both from the same key press; only the loosening is timed;
* ``first draw, <tab>``: each tab but the first clicked once after a fresh page load (its
  first draw; the first tab's is the page load): the click to the last callback answered
  and applied (nothing loading for 0.8 s after it), every histogram row on screen drawn
  (``vid.lazyIdle``; the rows below the fold are drawn when scrolled to) and, for the
  parallel coordinates, their lines drawn (the worker's canvas); ``--repeats`` page loads
  per tab;
* ``scroll -> last histogram row`` (explorer, after each page load) and ``scroll -> last
  Refine histogram row`` (after the Refine tab's first draw): the last row of the grid
  scrolled into view to it drawn with every row then on screen;
* ``longest task``: the longest main-thread task (``PerformanceObserver`` ``longtask``,
  recorded by the page itself) during page loads, typed limits and brushes;
* ``MB per page load``: bytes transferred (document, scripts, callback answers; compressed
  sizes) for the first load and for later ones (scripts from the browser's cache);
* ``server MB``: the server's resident memory at the end, and its ratio to the store's columns
  (ids, sequence, stage, status, parameters, criteria, functionals, wall times as loaded);
  and the same above an *idle server* (``vectorid ui`` on a 1,000-trial store after one page
  load: the interpreter, numpy, Dash and plotly; the server loads no numba), what the store and
  its views cost.

**A 33-variable sequential store** (``--seq33-trials``, default 4,000; 0 skips it): the
sequential sampler run on DTLZ2 with 8 criteria and 33 variables (``dtlz2-8-k26``, every
criterion's limit at its 30 % quantile over 4,096 Sobol points: D is not reached within
the budget and the store says so, with the relaxation factor, as the 33-gain stage stores
of the parafoil demo do), driven in the browser as above (goals at 4,000 trials: first draw
of any tab ≤ 1 s).

Each action starts when the page is quiet (no callback loading for 0.8 s), so one change's
requests do not overlap the next one's.

The CPU, its vector ISA and the load average (before and after) are printed: the machine may
be shared, and the figures are upper bounds when the load is high.
"""

from __future__ import annotations

import argparse
import importlib.util
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

import _machine


def _synthetic_store():
    spec = importlib.util.spec_from_file_location(
        "bench_report", Path(__file__).with_name("report.py")
    )
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod.synthetic_store


def make_store(path: Path, n: int, k: int, p: int) -> None:
    from vectorid.store import Store

    limits = _synthetic_store()(path, n, k, p)
    with Store.open(path, write=True) as st:  # four criteria constraints with the study
        st.set_limits({k: round(v * 0.85, 4) for k, v in list(limits.items())[:4]}, {})


def _changes(F: np.ndarray, n: int, seed: int = 0) -> list[str]:
    rng = np.random.default_rng(seed)
    q = rng.uniform(0.05, 0.5, n)
    return [f"{np.nanquantile(F[:, 0], qi):.5g}" for qi in q]


def _measure(ctx, texts, roles, *, cvp: bool) -> dict[str, float]:
    from plotly.io.json import to_json_plotly

    from vectorid.views.ui import callbacks as cb

    out = {}
    steps = [
        ("counts", lambda: cb.counts_view(ctx, texts, roles)),
        ("verdicts", lambda: cb.identifiability_view(ctx, texts, roles)),
        ("test tables", lambda: cb.summary_view(ctx, texts, roles)),
        ("scatter", lambda: cb.scatter_view(ctx, texts, roles, "f1", "f2", None, None)),
        ("histograms", lambda: cb.panel_view(ctx, texts, roles, "histograms")),
        ("parallel", lambda: cb.parallel_view(ctx, texts, roles)),
    ]
    if cvp:
        steps.append(("criterion vs param", lambda: cb.panel_view(ctx, texts, roles, "cvp", "f1")))
    for name, fn in steps:
        t0 = time.perf_counter()
        to_json_plotly(fn())
        out[name] = time.perf_counter() - t0
    out["visible update"] = out["counts"] + out["scatter"] + out["histograms"]
    return out


def server_side(path: Path, changes: int) -> None:
    from vectorid.views.ui import callbacks as cb
    from vectorid.views.ui.data import StoreCache
    from vectorid.views.ui.jobs import JobManager

    def context(max_points, panel_points):
        return cb.UIContext(
            cache=StoreCache(path),
            jobs=JobManager(path),
            max_points=max_points,
            panel_points=panel_points,
            parallel_lines=None if max_points is None else 1500,
        )

    ours = context(20_000, 3_000)
    names = ours.spec.criterion_names
    roles = [c.role for c in ours.spec.criteria]
    t0 = time.perf_counter()
    ours.cache.analysis()
    print(f"first analysis (load + numba compile/cache): {time.perf_counter() - t0:.2f} s")
    base = [c.limit for c in ours.spec.criteria]
    fields = [
        [v] + ["" if b is None else f"{b:.5g}" for b in base[1:]]
        for v in _changes(ours.cache.trials().F, changes + 1)
    ]
    nothin = context(None, None)
    nothin.cache.analysis()
    res: dict[str, list[dict[str, float]]] = {"ours": [], "reload": [], "no thinning": []}
    for i, texts in enumerate(fields):
        r1 = _measure(ours, texts, roles, cvp=True)
        r2 = _measure(context(20_000, 3_000), texts, roles, cvp=True)
        r3 = (
            _measure(nothin, texts, roles, cvp=True)
            if len(ours.cache.trials()) <= 200_000
            else None
        )
        if i == 0:
            continue
        res["ours"].append(r1)
        res["reload"].append(r2)
        if r3 is not None:
            res["no thinning"].append(r3)
    assert ours.cache.loads == 1, "the cached trials were reloaded although the store is unchanged"
    keys = list(res["ours"][0])
    cols = [k for k in res if res[k]]
    med = {k: {v: statistics.median(r[v] for r in res[k]) for v in keys} for k in cols}
    print(f"\nserver side, constraint change on {names[0]}, {len(res['ours'])} changes: median ms")
    print(
        f"{'view':<20}"
        + "".join(f"{k:>14}" for k in cols)
        + "".join(f"{'ratio ' + k:>20}" for k in cols[1:])
    )
    for v in keys:
        row = f"{v:<20}" + "".join(f"{1e3 * med[k][v]:14.1f}" for k in cols)
        row += "".join(f"{med[k][v] / med['ours'][v]:20.2f}" for k in cols[1:])
        print(row)


# -- in the browser ------------------------------------------------------------------------------

#: Every row of the histogram grid on screen (or within the 300 px the page draws ahead,
#: ``vid.lazyIdle``) drawn from one answer (``layout.meta.rev``), with ND ``nd`` when given
#: (a page without rows, an older one, passes). The page draws a row below the fold only
#: when it is scrolled to (``scroll -> last histogram row`` times that).
_HIST_DONE = """
function histDone(nd) {
  const near = g => { const r = g.getBoundingClientRect();
    return r.bottom > -300 && r.top < window.innerHeight + 300; };
  const gs = Array.from(document.querySelectorAll('.vid-hist .js-plotly-plot')).filter(near);
  if (!gs.length) return true;
  if (window.vid && window.vid.lazyIdle && !window.vid.lazyIdle()) return false;
  const meta = g => g._fullLayout && g._fullLayout.meta;
  const m0 = meta(gs[0]);
  return !!m0 && gs.every(g => meta(g) && meta(g).rev === m0.rev &&
    (nd === null || meta(g).nd === nd));
}
"""

_WAIT = """
const done = arguments[arguments.length - 1];
const prev = arguments[0], what = arguments[1];
function text(sel) { const e = document.querySelector(sel); return e ? e.textContent : null; }
function fmt(n) { return Number(n).toLocaleString('en-US'); }
function busy() { return document.querySelector('[data-dash-is-loading="true"]'); }
${HIST_DONE}
function check() {
  const dt = performance.now() - window.__t0;
  const nd = text('#count-nd');
  let ok;
  if (what === 'sel') {
    const s = text('#vid-sel') || '';
    ok = s !== '' && s !== prev;
  } else {  // new counts, or the counts' answer applied (the same ND: no text changes)
    ok = nd !== null && (nd !== prev || window.__countsDone !== null);
  }
  if (ok && what === 'all') {
    const title = text('#scatter .gtitle') || '';  // the rows on screen: their meta.nd
    ok = title.includes(fmt(nd)) && !busy() && histDone(Number(nd.replace(/,/g, '')));
  }
  if (ok) {
    requestAnimationFrame(() => requestAnimationFrame(() => done(performance.now() - window.__t0)));
  } else if (dt > 60000) { done(-1); } else { requestAnimationFrame(check); }
}
check();
"""
_WAIT = _WAIT.replace("${HIST_DONE}", _HIST_DONE)

_QUIET = """
const done = arguments[arguments.length - 1];
let since = performance.now();
const start = since;
function check() {
  const now = performance.now();
  if (document.querySelector('[data-dash-is-loading="true"]')) { since = now; }
  if (now - since > 800) { done(true); } else if (now - start > 60000) { done(false); }
  else { setTimeout(check, 50); }
}
check();
"""

_LOADED = """
const done = arguments[arguments.length - 1];
${HIST_DONE}
function check() {
  const ok = document.querySelector('#count-nd') &&
    document.querySelector('#scatter .gtitle') &&
    !document.querySelector('[data-dash-is-loading="true"]') && histDone(null);
  const t = performance.now();
  if (ok) { requestAnimationFrame(() => requestAnimationFrame(() => done(performance.now()))); }
  else if (t > 120000) { done(-1); } else { requestAnimationFrame(check); }
}
check();
"""

_LOADED = _LOADED.replace("${HIST_DONE}", _HIST_DONE)

#: Bytes transferred for the page so far (document and every resource: the scripts, the
#: callbacks' answers), as the browser counts them (compressed sizes; 0 from its cache).
_BYTES = """
const nav = performance.getEntriesByType('navigation')[0];
let b = nav ? nav.transferSize : 0;
for (const r of performance.getEntriesByType('resource')) b += r.transferSize || 0;
return b;
"""
_LONGEST = "return Math.max(0, ...(window.__vidLongTasks || []));"
#: When the page last drew the parallel coordinates' lines, since the mouse was released.
_DRAWN = """
const c = document.querySelector('#par-graph canvas.vid-lines');
if (!c || !c.dataset.at) return -1;
return Number(c.dataset.at) - window.__t0;
"""
_RESET_LONG = "window.__vidLongTasks = [];"

#: Sets ``window.__countsDone`` when the counts' callback has been answered and applied
#: (``#vid-counts`` no longer loading), so that a limit leaving ND as it was is timed too.
_WATCH_COUNTS = """
window.__countsDone = null;
if (window.__countsObs) window.__countsObs.disconnect();
const el = document.getElementById('vid-counts');
window.__countsObs = new MutationObserver(() => {
  if (el.getAttribute('data-dash-is-loading') !== 'true' && window.__countsDone === null &&
      window.__countsSeen) { window.__countsDone = performance.now(); }
  if (el.getAttribute('data-dash-is-loading') === 'true') { window.__countsSeen = true; }
});
window.__countsSeen = false;
window.__countsObs.observe(el, {attributes: true, attributeFilter: ['data-dash-is-loading']});
"""

#: After a click on a tab (``window.__t0``): the last moment a callback was loading or
#: (for the parallel coordinates) the page drew their lines, once nothing has loaded for
#: 0.8 s, since the click, ms; -1 after 60 s.
_TAB_DRAWN = """
const done = arguments[arguments.length - 1];
const lines = arguments[0];
let last = window.__t0;
function drawnAt() {  // rows on screen drawn (vid.lazyRows), and the lines when asked
  if (window.vid && window.vid.lazyIdle && !window.vid.lazyIdle()) return null;
  let at = window.__t0;
  for (const e of document.querySelectorAll('.vid-lazy-row[data-at], .vid-hist > [id][data-at]')) {
    at = Math.max(at, Number(e.dataset.at));
  }
  if (!lines) return at;
  const c = document.querySelector('#par-graph canvas.vid-lines');
  return c && Number(c.dataset.lines || 0) > 0 && c.dataset.at ?
    Math.max(at, Number(c.dataset.at)) : null;
}
function check() {
  const now = performance.now();
  if (document.querySelector('[data-dash-is-loading="true"]')) { last = now; }
  const at = drawnAt();
  if (at !== null && now - last > 800) {
    done(Math.max(last, at) - window.__t0);
  } else if (now - window.__t0 > 60000) { done(-1); } else { requestAnimationFrame(check); }
}
check();
"""

#: The last row of a lazily drawn grid (``arguments[0]``: the rows' CSS selector) scrolled
#: into view: ms to it drawn with every other row on screen (``vid.lazyIdle``); -1 after 60 s.
_SCROLL_LAST = """
const done = arguments[arguments.length - 1];
const rows = document.querySelectorAll(arguments[0]);
if (!rows.length || !window.vid.lazyIdle) { done(-2); return; }  // every row drawn at once
const last = rows[rows.length - 1], t0 = performance.now();
last.scrollIntoView();
function check() {
  if (window.vid.lazyIdle() && last.dataset.rev) {
    requestAnimationFrame(() => requestAnimationFrame(() => {
      const ms = performance.now() - t0; window.scrollTo(0, 0); done(ms); }));
  } else if (performance.now() - t0 > 60000) { done(-1); } else { requestAnimationFrame(check); }
}
requestAnimationFrame(check);
"""

#: After Enter in a limit field (``window.__t0``): [ms to the new N/ND/NP, ms to everything
#: redrawn] (as :data:`_WAIT`'s ``counts`` and ``all``), both from the same key press.
_WAIT_BOTH = """
const done = arguments[arguments.length - 1];
const prev = arguments[0];
function text(sel) { const e = document.querySelector(sel); return e ? e.textContent : null; }
function fmt(n) { return Number(n).toLocaleString('en-US'); }
function busy() { return document.querySelector('[data-dash-is-loading="true"]'); }
${HIST_DONE}
let counts = null;
function check() {
  const now = performance.now(), dt = now - window.__t0;
  const nd = text('#count-nd');
  if (counts === null && nd !== null && (nd !== prev || window.__countsDone !== null)) {
    counts = dt;
  }
  let ok = counts !== null;
  if (ok) {
    const title = text('#scatter .gtitle') || '';  // the rows on screen: their meta.nd
    ok = title.includes(fmt(nd)) && !busy() && histDone(Number(nd.replace(/,/g, '')));
  }
  if (ok) {
    requestAnimationFrame(() => requestAnimationFrame(
      () => done([counts, performance.now() - window.__t0])));
  } else if (dt > 60000) { done([counts === null ? -1 : counts, -1]); }
  else { requestAnimationFrame(check); }
}
check();
""".replace("${HIST_DONE}", _HIST_DONE)


def _driver():
    import shutil

    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    for flag in (
        "--headless=new --no-sandbox --disable-gpu --disable-dev-shm-usage "
        "--disable-background-networking --disable-component-update --disable-sync "
        "--no-first-run --window-size=1500,1000 --enable-unsafe-swiftshader"
    ).split():
        opts.add_argument(flag)
    profile = tempfile.mkdtemp(prefix="vectorid-bench-chrome-")
    opts.add_argument(f"--user-data-dir={profile}")
    opts.binary_location = shutil.which("chromium") or "/usr/bin/chromium"
    drv = webdriver.Chrome(
        service=Service(shutil.which("chromedriver") or "/usr/bin/chromedriver"), options=opts
    )
    drv.set_script_timeout(150)
    return drv, profile


def _rss_mb(pid: int) -> float:
    """Resident memory of a process (MB), from /proc (nan elsewhere)."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    except OSError:
        pass
    return float("nan")


def _click_tab(drv, prefix: str) -> None:
    from selenium.webdriver.common.by import By

    for el in drv.find_elements(By.CSS_SELECTOR, "#tabs > .tab"):
        if el.text.strip().startswith(prefix):
            el.click()
            return
    raise RuntimeError(f"no tab {prefix!r}")


def _type_limit(drv, value: str) -> str:
    """Type ``value`` into the first criterion's limit field and start the clock
    (``window.__t0``) just before Enter; returns ND as it was."""
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    el = drv.find_element(By.ID, "vid-limit-f1")
    prev = drv.find_element(By.ID, "count-nd").text
    el.click()
    el.send_keys(Keys.CONTROL, "a")
    el.send_keys(Keys.DELETE)
    el.send_keys(value)
    drv.execute_script(_WATCH_COUNTS)
    drv.execute_script("window.__t0 = performance.now();")
    el.send_keys(Keys.ENTER)
    return prev


def _loosen(F: np.ndarray, n: int, seed: int = 2) -> list[tuple[str, str]]:
    """``n`` loosening cases on the first criterion: (tight, loose) limits, its 5 % quantile
    then one from 30 to 60 % (seeded)."""
    rng = np.random.default_rng(seed)
    f = F[:, 0][np.isfinite(F[:, 0])]
    tight = f"{np.quantile(f, 0.05):.5g}"
    return [(tight, f"{np.quantile(f, q):.5g}") for q in rng.uniform(0.3, 0.6, n)]


def browser_latency(
    path: Path,
    changes: list[str],
    loads: int = 5,
    brushes: int = 5,
    shots: Path | None = None,
    loosen: list[tuple[str, str]] | None = None,
) -> dict[str, list[float]]:
    """Latencies (s) in headless Chromium: page loads, typed limits, the loosening case
    (``loosen``: pairs of tight then loose limits, the loosening timed), each tab's first
    draw, parallel brushes; and the main thread's longest task (ms) per kind of action, the
    bytes transferred per page load (MB) and the server's memory (MB).

    With ``shots``, a screenshot of every tab is saved there afterwards
    (``ui-<trials>-<tab>.png``)."""
    import shutil

    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    proc, url = _start_server(path)
    out: dict[str, list[float]] = {
        "page load": [],
        "limit -> counts": [],
        "limit -> everything": [],
        "loosen -> counts": [],
        "loosen -> everything": [],
        "scroll -> last histogram row": [],
        "brush -> counts": [],
        "brush -> lines redrawn": [],
        "longest task, page load (ms)": [],
        "longest task, limits (ms)": [],
        "longest task, brushes (ms)": [],
        "MB per page load, first": [],
        "MB per page load, cached": [],
        "server MB": [],
    }
    drv = profile = None
    try:
        drv, profile = _driver()
        for i in range(loads + 1):  # the first load fills the browser's cache
            drv.get(url)
            t = drv.execute_async_script(_LOADED)
            mb = drv.execute_script(_BYTES) / 1e6
            out["MB per page load, first" if i == 0 else "MB per page load, cached"].append(mb)
            drv.execute_async_script(_QUIET)
            out["longest task, page load (ms)"].append(drv.execute_script(_LONGEST))
            if i:
                out["page load"].append(t / 1e3 if t >= 0 else float("nan"))
                ms = drv.execute_async_script(_SCROLL_LAST, ".vid-hist > [id]")
                out["scroll -> last histogram row"].append(ms / 1e3 if ms >= 0 else float("nan"))
                drv.execute_async_script(_QUIET)
        time.sleep(1)
        drv.execute_script(_RESET_LONG)
        for k, value in enumerate(changes):
            what = "counts" if k % 2 == 0 else "all"
            prev = _type_limit(drv, value)
            ms = drv.execute_async_script(_WAIT, prev, what)
            key = "limit -> counts" if what == "counts" else "limit -> everything"
            out[key].append(ms / 1e3 if ms >= 0 else float("nan"))
            drv.execute_async_script(_QUIET)  # every view of this change drawn: no overlap
        for tight, loose in loosen or []:  # the loosening case: tight, then loose (timed)
            prev = _type_limit(drv, tight)
            drv.execute_async_script(_WAIT_BOTH, prev)
            drv.execute_async_script(_QUIET)
            prev = _type_limit(drv, loose)
            counts, every = drv.execute_async_script(_WAIT_BOTH, prev)
            out["loosen -> counts"].append(counts / 1e3 if counts >= 0 else float("nan"))
            out["loosen -> everything"].append(every / 1e3 if every >= 0 else float("nan"))
            drv.execute_async_script(_QUIET)
        out["longest task, limits (ms)"].append(drv.execute_script(_LONGEST))
        labels = [el.text.strip() for el in drv.find_elements(By.CSS_SELECTOR, "#tabs > .tab")]
        for label in labels[1:]:  # each tab's first draw, after a fresh page load
            key = f"first draw, {label}"
            out[key] = []
            for _ in range(loads):
                drv.get(url)
                drv.execute_async_script(_LOADED)
                drv.execute_async_script(_QUIET)
                drv.execute_script("window.__t0 = performance.now();")
                _click_tab(drv, label)
                ms = drv.execute_async_script(_TAB_DRAWN, label.startswith("Parallel"))
                out[key].append(ms / 1e3 if ms >= 0 else float("nan"))
                if label.startswith("Refine"):
                    ms = drv.execute_async_script(_SCROLL_LAST, "#ref-hist .vid-lazy-row")
                    out.setdefault("scroll -> last Refine histogram row", []).append(
                        ms / 1e3 if ms >= 0 else float("nan")
                    )
        _click_tab(drv, "Parallel")
        deadline = time.monotonic() + 120
        while not drv.find_elements(By.CSS_SELECTOR, "#par-graph .vid-hit"):
            if time.monotonic() > deadline:
                raise RuntimeError("the parallel coordinates did not draw")
            time.sleep(0.05)
        drv.execute_async_script(_QUIET)
        time.sleep(1)
        drv.execute_script(
            # pointerup: the page's brushes take the pointer (pointer capture, and
            # preventDefault on pointerdown, so no mouseup is ever dispatched)
            "document.addEventListener('pointerup', () => { window.__t0 = performance.now(); },"
            " true);"
        )
        drv.execute_script(_RESET_LONG)
        for k in range(brushes):  # one brush on each of the first criterion axes
            b = drv.find_elements(By.CSS_SELECTOR, "#par-graph .vid-hit")[k]
            h = b.size["height"]
            prev = drv.find_element(By.ID, "vid-sel").text
            # a band from a quarter of the axis to just below the middle
            ActionChains(drv).move_to_element_with_offset(b, 0, -(h // 4)).click_and_hold().pause(
                0.1
            ).move_by_offset(0, 30).pause(0.1).move_to_element_with_offset(b, 0, h // 10).pause(
                0.1
            ).release().perform()
            ms = drv.execute_async_script(_WAIT, prev, "sel")
            out["brush -> counts"].append(ms / 1e3 if ms >= 0 else float("nan"))
            drv.execute_async_script(_QUIET)
            drawn = drv.execute_script(_DRAWN)  # the last drawing of the lines since mouseup
            out["brush -> lines redrawn"].append(drawn / 1e3 if drawn >= 0 else float("nan"))
            out["longest task, brushes (ms)"].append(drv.execute_script(_LONGEST))
            drv.find_element(By.ID, "par-clear").click()  # the next brush starts afresh
            drv.execute_async_script(_QUIET)
            drv.execute_script(_RESET_LONG)
        out["server MB"].append(_rss_mb(proc.pid))
        if shots is not None:
            shots.mkdir(parents=True, exist_ok=True)
            n = drv.find_element(By.ID, "count-n").text.replace(",", "")
            labels = [el.text.strip() for el in drv.find_elements(By.CSS_SELECTOR, ".tab")]
            for label in labels:
                for el in drv.find_elements(By.CSS_SELECTOR, ".tab"):
                    if el.text.strip() == label:
                        el.click()
                        break
                time.sleep(1.0)
                drv.execute_async_script(_QUIET)
                slug = "".join(c if c.isalnum() else "-" for c in label.lower()).strip("-")
                drv.save_screenshot(str(shots / f"ui-{n}-{slug}.png"))
        return out
    finally:
        if drv is not None:
            drv.quit()
        _stop_server(proc)
        if profile:
            shutil.rmtree(profile, ignore_errors=True)


def _start_server(path: Path) -> tuple[Any, str]:
    """``vectorid ui PATH`` on a free port, once it answers: the process and its URL."""
    import socket
    import subprocess
    import urllib.request

    with socket.socket() as so:
        so.bind(("127.0.0.1", 0))
        port = so.getsockname()[1]
    proc = subprocess.Popen(
        [sys.executable, "-m", "vectorid.cli", "ui", str(path), "--port", str(port)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    url = f"http://127.0.0.1:{port}/"
    deadline = time.monotonic() + 300
    while True:
        try:
            with urllib.request.urlopen(url, timeout=5):
                return proc, url
        except OSError:
            if time.monotonic() > deadline or proc.poll() is not None:
                proc.kill()
                raise RuntimeError("vectorid ui did not start") from None
            time.sleep(0.3)


def _stop_server(proc: Any) -> None:
    import signal
    import subprocess

    proc.send_signal(signal.SIGINT)
    try:
        proc.wait(20)
    except subprocess.TimeoutExpired:
        proc.kill()


def idle_server_mb(folder: Path, criteria: int, params: int) -> float:
    """Resident memory (MB) of ``vectorid ui`` serving a 1,000-trial store after one page
    load in headless Chromium: the interpreter, numpy, Dash and
    plotly, what every server holds whatever the store."""
    import shutil

    p = folder / "idle.db"
    make_store(p, 1000, criteria, params)
    proc, url = _start_server(p)
    drv = profile = None
    try:
        drv, profile = _driver()
        drv.get(url)
        drv.execute_async_script(_LOADED)
        drv.execute_async_script(_QUIET)
        time.sleep(1.5)
        return _rss_mb(proc.pid)
    finally:
        if drv is not None:
            drv.quit()
        _stop_server(proc)
        if profile:
            shutil.rmtree(profile, ignore_errors=True)


def jobs_throughput(folder: Path, trials: int) -> None:
    """Trials per second of a run started from the UI (the job worker) against
    ``vectorid run`` with the same executor on the same study, and the latency of saving
    the constraints with the study."""
    import subprocess

    from vectorid import Study
    from vectorid.demos.g12 import study_toml
    from vectorid.spec import load_study
    from vectorid.views.ui import callbacks as cb
    from vectorid.views.ui.data import StoreCache
    from vectorid.views.ui.jobs import JobManager

    toml = folder / "jobs.toml"
    toml.write_text(study_toml("binh-korn", trials=64), encoding="utf-8")
    spec = load_study(toml)
    rates = {}
    for how in ("vectorid run", "UI job"):
        path = folder / f"jobs-{how.replace(' ', '-')}.db"
        with Study.create(spec, path) as st:
            st.run(executor="serial")
        t0 = time.perf_counter()
        if how == "vectorid run":
            subprocess.run(
                [
                    sys.executable,
                    "-m",
                    "vectorid.cli",
                    "run",
                    str(path),
                    "--trials",
                    str(64 + trials),
                    "--executor",
                    "serial",
                    "--quiet",
                ],
                check=True,
                capture_output=True,
            )
        else:
            cache = StoreCache(path)
            jobs = JobManager(path, executor="serial", progress_of=cache.count_sample)
            jobs.warm()
            time.sleep(3)  # the worker starts with the UI, before any button is pressed
            ctx = cb.UIContext(cache=cache, jobs=jobs)
            t0 = time.perf_counter()
            cb.start_job(ctx, "continue", trials=str(trials))
            while jobs.status().running:
                time.sleep(0.01)
            st = jobs.status()
            assert st.state == "done", st.message
        rates[how] = trials / (time.perf_counter() - t0)
        if how == "UI job":
            t0 = time.perf_counter()
            cb.start_job(ctx, "limits", limit_texts=["40", ""], roles=["pure", "pure"])
            while jobs.status().running:
                time.sleep(0.005)
            save = time.perf_counter() - t0
            jobs.shutdown()
    print(
        f"\njobs ({trials} binh-korn trials, serial executor, wall time including the "
        "process start of `vectorid run`):"
    )
    for how, r in rates.items():
        print(f"  {how:<14} {r:12,.0f} trials/s")
    print(f"  ratio UI job / vectorid run: {rates['UI job'] / rates['vectorid run']:.2f}")
    print(f"  saving the constraints with the study (UI job): {1e3 * save:.0f} ms")


#: Every tab's label but the first (whose first draw is the page load), for the goals.
TABS = [
    "Parallel coordinates & history",
    "Trial table",
    "Chosen trial",
    "Refine & continue",
    "Study overview",
]
#: The issues' goals (s, ms, MB): None where they set none. Issue 36: the first draw of any
#: tab <= 1 s at 4,000 trials and <= 2 s at 1e6; loosening a limit at 1e6 <= 0.3 s to the
#: counts and <= 1 s to everything.
GOALS = {
    4_000: {"page load": 1.0, **{f"first draw, {t}": 1.0 for t in TABS}},
    100_000: {"limit -> everything": 0.3, "brush -> counts": 0.3},
    1_000_000: {
        "page load": 2.0,
        **{f"first draw, {t}": 2.0 for t in TABS},
        "limit -> counts": 0.3,
        "limit -> everything": 1.0,
        "loosen -> counts": 0.3,
        "loosen -> everything": 1.0,
        "brush -> counts": 0.3,
        "longest task, page load (ms)": 200,
        "longest task, limits (ms)": 200,
        "longest task, brushes (ms)": 200,
        "MB per page load, first": 10.0,
    },
}


def sequential_store(path: Path, trials: int = 4000) -> str:
    """A 33-variable sequential store: the sequential sampler on DTLZ2 with 8 criteria
    (``dtlz2-8-k26``: 33 variables), every criterion's limit at its 30 % quantile over the
    first 4,096 Sobol points, ``trials`` evaluations (population 100, seed 1), run in this
    process. Returns the run's closing line (whether D was reached, the relaxation)."""
    from vectorid import Study, analytic
    from vectorid.demos.g12 import study_toml
    from vectorid.sampling import PointSequence
    from vectorid.spec import load_study
    from vectorid.workflows.extra import relax_study

    prob = analytic.get("dtlz2-8-k26")
    F, _ = prob.evaluate(PointSequence(prob.n_var, "sobol").points(0, 4096))
    limits = {name: float(f"{np.quantile(F[:, i], 0.3):.3g}") for i, (name, _) in
              enumerate(prob.criteria)}  # fmt: skip
    text = study_toml(prob.name, trials=256, limits=limits).replace(
        "[study]\n",
        f'[study]\nsampler = "sequential"\nbudget = {int(trials)}\npopulation = 100\n',
        1,
    )
    toml = path.with_suffix(".toml")
    toml.write_text(text, encoding="utf-8")
    with Study.create(load_study(toml), path) as st:
        summary = st.run(executor="inline", progress=False)
        relax = relax_study(st, limits)  # as a stage that did not reach D saves them
    said = summary.describe().splitlines()[1].split(";")[0]  # "D not reached after ..."
    return f"{said}; limits saved: {relax.describe()}"


def store_columns_mb(path: Path) -> float:
    """The store's trial columns in memory (MB): ids, sequence, stage, status, parameters,
    criteria, functionals and wall times as the UI loads them."""
    from vectorid.store import Store

    with Store.open(path) as st:
        t = st.load()
    arrays = (t.id, t.seq, t.stage, t.status, t.X, t.F, t.G, t.wall)
    return sum(a.nbytes for a in arrays) / 1e6


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--trials", type=int, default=100_000)
    ap.add_argument("--criteria", type=int, default=6)
    ap.add_argument("--params", type=int, default=12)
    ap.add_argument("--changes", type=int, default=8)
    ap.add_argument("--browser", action="store_true", help="also measure in headless Chromium")
    ap.add_argument(
        "--repeats", type=int, default=5, help="runs of each browser action (median, max)"
    )
    ap.add_argument("--no-server", action="store_true", help="skip the server-side table")
    ap.add_argument(
        "--job-trials", type=int, default=200_000, help="trials of the run jobs (0: skip them)"
    )
    ap.add_argument(
        "--browser-trials",
        type=int,
        nargs="+",
        default=[100_000, 1_000_000],
        help="store sizes driven in the browser (default 1e5 and 1e6)",
    )
    ap.add_argument(
        "--seq33-trials",
        type=int,
        default=4000,
        help="budget of the 33-variable sequential store driven in the browser (0: skip it)",
    )
    ap.add_argument(
        "--screenshots",
        type=Path,
        help="save a screenshot of every tab at each browser-driven size into this folder",
    )
    args = ap.parse_args()
    print(f"machine: {_machine.describe()}")
    tmp = tempfile.TemporaryDirectory()
    path = Path(tmp.name) / "bench.db"
    t0 = time.perf_counter()
    make_store(path, args.trials, args.criteria, args.params)
    print(
        f"store: {args.trials} trials, {args.criteria} criteria, {args.params} parameters "
        f"({time.perf_counter() - t0:.1f} s to write)"
    )
    if not args.no_server:
        server_side(path, args.changes)
    if args.job_trials:
        jobs_throughput(Path(tmp.name), args.job_trials)
    if not args.browser:
        return
    from vectorid.views.ui.data import StoreCache

    rows = []
    idle = idle_server_mb(Path(tmp.name), args.criteria, args.params)
    print(f"  idle server (1,000 trials, one page load): {idle:.0f} MB resident")
    sizes: list[tuple[int, str]] = []
    if args.seq33_trials:
        sizes.append((args.seq33_trials, "33-variable sequential"))
    sizes += [(n, "synthetic") for n in args.browser_trials]
    for n, kind in sizes:
        p = Path(tmp.name) / f"browser-{n}-{kind.split('-')[0]}.db"
        if kind == "synthetic":
            make_store(p, n, args.criteria, args.params)
        else:
            t0 = time.perf_counter()
            line = sequential_store(p, n)
            print(f"  {kind} store ({time.perf_counter() - t0:.1f} s to run): {line}")
        F = StoreCache(p).trials().F
        cols = store_columns_mb(p)
        lat = browser_latency(
            p,
            _changes(F, 2 * args.repeats, seed=1),
            args.repeats,
            args.repeats,
            args.screenshots,
            loosen=_loosen(F, args.repeats),
        )
        for key, vals in lat.items():
            vals = [v for v in vals if np.isfinite(v)]
            goal = GOALS.get(n, {}).get(key)
            med = statistics.median(vals) if vals else float("nan")
            rows.append((n, key, med, max(vals) if vals else float("nan"), len(vals), goal))
            if key == "server MB":
                g2 = 2.0 if kind == "synthetic" else None  # 4,000 trials: the idle server
                rows.append((n, "server MB / store columns MB", med / cols, med / cols, 1, g2))
                above = (med - idle) / cols
                rows.append((n, "(server - idle server) / columns", above, above, 1, g2))
        print(f"  measured {n:,} trials ({kind}); machine now: {_machine.describe()}")
    print("\nin headless Chromium (software WebGL), action to redrawn DOM, seconds (unless named):")
    print(f"{'trials':>10}  {'what':<44}{'median':>9}{'max':>9}{'n':>4}{'goal':>8}  verdict")
    for n, key, med, mx, cnt, goal in rows:
        verdict = "" if goal is None else ("meets" if mx <= goal else "MISSES")
        g = "" if goal is None else f"{goal:g}"
        print(f"{n:>10,}  {key:<44}{med:9.3f}{mx:9.3f}{cnt:4d}{g:>8}  {verdict}")
    print("(verdict on the max of the runs)")
    print(f"machine at the end: {_machine.describe()}")


if __name__ == "__main__":
    main()
