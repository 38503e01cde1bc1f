"""Benchmark: latency of a criteria-constraint change in the browser UI on 1e5 trials.

Usage::

    .venv/bin/python benchmarks/ui.py [--trials 100000] [--criteria 6] [--params 15] [--changes 15]

A synthetic store is written (as in ``benchmarks/report.py``: criteria from a cheap closed
form, 0.5 % failed trials), then a sequence of constraint changes (each criterion's limit
drawn among its quantiles 0.3..0.95, seeded) is applied through the *same plain functions the
Dash callbacks call* (:mod:`vectorid.views.ui.callbacks`), and each response is serialised
with ``plotly.io.json.to_json_plotly`` as Dash does before sending it:

* ``counts+tables``: :func:`summary_view` (N/ND/NP, test tables, feasible/Pareto table);
* ``scatter``: :func:`scatter_view` (criterion vs criterion, decimated to 20,000 points);
* ``histograms``: :func:`panel_view` ``"histograms"`` (the lower panel shown by default);
* ``criterion vs param``: :func:`panel_view` ``"cvp"`` (only when that tab is open);
* ``visible update``: the first three together: what changes on screen after a constraint
  change with the default tabs (the goal: < 300 ms on 2 cores);
* ``all views``: all four.

Baselines measured in the same run, same changes:

* ``reload``: no trial cache, everything recomputed from the store on every change (a new
  :class:`StoreCache` per change: open, load, analyse);
* ``no decimation``: cached trials but every point drawn (``max_points=None``).

Times are medians (and 90th percentiles) over the changes after one warm-up change (numba
compilation is reported separately). ``ratio`` = baseline / ours (> 1: ours is faster).

With ``--browser`` the same store is also served by ``vectorid ui`` and driven in headless
Chromium: a new value is typed into the first criterion's constraint field and the time until
ND has changed and no component is loading any more (then two animation frames, so the plots
are drawn) is measured in the page. This includes the HTTP round trips, Dash's client, JSON
parsing and WebGL drawing (software rendering in headless Chromium, so pessimistic).
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def _synthetic_store():
    spec = importlib.util.spec_from_file_location(
        "bench_report", Path(__file__).with_name("report.py")
    )
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod.synthetic_store


def _changes(F: np.ndarray, n: int, seed: int = 0) -> list[list[str]]:
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        q = rng.uniform(0.3, 0.95, F.shape[1])
        out.append([f"{np.nanquantile(F[:, j], q[j]):.6g}" for j in range(F.shape[1])])
    return out


def _measure(ctx, texts, roles, x, y, *, cvp: bool) -> dict[str, float]:
    from plotly.io.json import to_json_plotly

    from vectorid.views.ui import callbacks as cb

    t = {}
    t0 = time.perf_counter()
    s = cb.summary_view(ctx, texts, roles)
    to_json_plotly(s)
    t1 = time.perf_counter()
    fig, _ = cb.scatter_view(ctx, texts, roles, x, y, None, None)
    to_json_plotly(fig)
    t2 = time.perf_counter()
    h = cb.panel_view(ctx, texts, roles, "histograms")
    to_json_plotly(h)
    t3 = time.perf_counter()
    t["counts+tables"] = t1 - t0
    t["scatter"] = t2 - t1
    t["histograms"] = t3 - t2
    t["visible update"] = t3 - t0
    if cvp:
        c = cb.panel_view(ctx, texts, roles, "cvp", x)
        to_json_plotly(c)
        t["criterion vs param"] = time.perf_counter() - t3
        t["all views"] = time.perf_counter() - t0
    return t


_WAIT_JS = """
const done = arguments[arguments.length - 1];
const prev = arguments[0];
function check() {
  const nd = document.getElementById('count-nd');
  const busy = document.querySelector('[data-dash-is-loading="true"]');
  const dt = performance.now() - window.__t0;
  if (nd && nd.textContent !== prev && !busy) {
    requestAnimationFrame(() => requestAnimationFrame(() => done(performance.now() - window.__t0)));
  } else if (dt > 30000) { done(-1); } else { requestAnimationFrame(check); }
}
check();
"""


def browser_latency(
    path: Path, changes: list[list[str]], name: str, panel: str | None = None
) -> list[float]:
    """End-to-end latency (s) of typing each change's first value, in headless Chromium,
    with the lower panel ``panel`` open (a tab label; default: the histograms)."""
    import shutil
    import signal
    import socket
    import subprocess
    import urllib.request

    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    with socket.socket() as so:
        so.bind(("127.0.0.1", 0))
        port = so.getsockname()[1]
    proc = subprocess.Popen(
        [sys.executable, "-m", "vectorid.cli", "ui", str(path), "--port", str(port)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    profile = tempfile.mkdtemp(prefix="vectorid-bench-chrome-")
    drv = None
    try:
        url = f"http://127.0.0.1:{port}/"
        deadline = time.monotonic() + 90
        while True:
            try:
                with urllib.request.urlopen(url, timeout=2):
                    break
            except OSError:
                if time.monotonic() > deadline:
                    raise RuntimeError("vectorid ui did not start") from None
                time.sleep(0.3)
        opts = webdriver.ChromeOptions()
        for flag in (
            "--headless=new --no-sandbox --disable-gpu --disable-dev-shm-usage "
            "--disable-background-networking --disable-component-update --disable-sync "
            "--no-first-run --window-size=1500,1400"
        ).split():
            opts.add_argument(flag)
        opts.add_argument(f"--user-data-dir={profile}")
        opts.binary_location = shutil.which("chromium") or "/usr/bin/chromium"
        drv = webdriver.Chrome(
            service=Service(shutil.which("chromedriver") or "/usr/bin/chromedriver"), options=opts
        )
        drv.set_script_timeout(60)
        drv.get(url)
        sel = f'input[id*=\'"name":"{name}"\'][id*=\'"type":"limit"\']'
        deadline = time.monotonic() + 60
        while not drv.find_elements(By.CSS_SELECTOR, "#count-nd"):
            if time.monotonic() > deadline:
                raise RuntimeError("the page did not load")
            time.sleep(0.2)
        time.sleep(3)  # first render of every view
        if panel:  # open another lower panel first
            for el in drv.find_elements(By.CSS_SELECTOR, ".tab"):
                if el.text.strip() == panel:
                    el.click()
            time.sleep(2)
        out = []
        for texts in changes:
            el = drv.find_element(By.CSS_SELECTOR, sel)
            prev = drv.find_element(By.ID, "count-nd").text
            el.click()
            el.send_keys(Keys.CONTROL, "a")
            el.send_keys(Keys.DELETE)
            el.send_keys(texts[0])
            drv.execute_script("window.__t0 = performance.now();")
            el.send_keys(Keys.ENTER)
            ms = drv.execute_async_script(_WAIT_JS, prev)
            out.append(ms / 1e3 if ms >= 0 else float("nan"))
        return out
    finally:
        if drv is not None:
            drv.quit()
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(15)
        except subprocess.TimeoutExpired:
            proc.kill()
        shutil.rmtree(profile, ignore_errors=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--trials", type=int, default=100_000)
    ap.add_argument("--criteria", type=int, default=6)
    ap.add_argument("--params", type=int, default=15)
    ap.add_argument("--changes", type=int, default=15)
    ap.add_argument("--browser", action="store_true", help="also measure in headless Chromium")
    args = ap.parse_args()

    from vectorid.views.ui import callbacks as cb
    from vectorid.views.ui.data import StoreCache
    from vectorid.views.ui.jobs import JobManager

    tmp = tempfile.TemporaryDirectory()
    path = Path(tmp.name) / "bench.db"
    t0 = time.perf_counter()
    _synthetic_store()(path, args.trials, args.criteria, args.params)
    print(
        f"store: {args.trials} trials, {args.criteria} criteria, {args.params} parameters "
        f"({time.perf_counter() - t0:.1f} s to write); cores: {os.cpu_count()}; "
        f"python {sys.version.split()[0]}"
    )

    def context(max_points, panel_points):
        cache = StoreCache(path)
        return cb.UIContext(
            cache=cache, jobs=JobManager(path), max_points=max_points, panel_points=panel_points
        )

    ours = context(20_000, 3_000)
    names = ours.spec.criterion_names
    roles = [c.role for c in ours.spec.criteria]
    x, y = names[0], names[1]
    t0 = time.perf_counter()
    ours.cache.analysis()
    print(f"first analysis (load + numba compile/cache): {time.perf_counter() - t0:.2f} s")
    F = ours.cache.trials().F
    changes = _changes(F, args.changes + 1)

    results: dict[str, list[dict[str, float]]] = {"ours": [], "reload": [], "no decimation": []}
    nodec = context(None, None)
    nodec.cache.analysis()
    for i, texts in enumerate(changes):
        r_ours = _measure(ours, texts, roles, x, y, cvp=True)
        fresh = context(20_000, 3_000)  # no cache: the store is read and analysed again
        r_reload = _measure(fresh, texts, roles, x, y, cvp=True)
        r_nodec = _measure(nodec, texts, roles, x, y, cvp=True)
        if i == 0:
            continue  # warm-up
        results["ours"].append(r_ours)
        results["reload"].append(r_reload)
        results["no decimation"].append(r_nodec)
    assert ours.cache.loads == 1, "the cached trials were reloaded although the store is unchanged"

    keys = list(results["ours"][0])
    med = {k: {v: statistics.median(r[v] for r in rs) for v in keys} for k, rs in results.items()}
    p90 = {
        k: {v: float(np.quantile([r[v] for r in rs], 0.9)) for v in keys}
        for k, rs in results.items()
    }
    print(f"\nconstraint change, {len(results['ours'])} changes: median (p90) in ms")
    print(
        f"{'view':<20} {'ours':>16} {'reload':>16} {'no decimation':>16} "
        f"{'ratio reload':>13} {'ratio no-dec':>13}"
    )
    for v in keys:
        cells = [f"{1e3 * med[k][v]:7.1f} ({1e3 * p90[k][v]:6.1f})" for k in results]
        r1 = med["reload"][v] / med["ours"][v]
        r2 = med["no decimation"][v] / med["ours"][v]
        print(f"{v:<20} {cells[0]:>16} {cells[1]:>16} {cells[2]:>16} {r1:13.2f} {r2:13.2f}")
    goal = med["ours"]["visible update"]
    print(
        f"\nvisible update (counts, test tables, scatter, histograms): {1e3 * goal:.0f} ms median "
        f"-> {'meets' if goal < 0.3 else 'MISSES'} the 300 ms goal"
    )
    if args.browser:
        print(f"\nin headless Chromium (typing a new {names[0]} limit until ND and the plots are ")
        print(f"updated), {len(changes) - 1} changes:")
        for panel in (None, "Feasible & Pareto trials"):
            lat = browser_latency(path, changes, names[0], panel)[1:]
            med, p90 = statistics.median(lat), float(np.quantile(lat, 0.9))
            print(
                f"  lower panel {panel or 'Histograms per parameter'!r:<28}: median "
                f"{1e3 * med:.0f} ms, p90 {1e3 * p90:.0f} ms"
            )


if __name__ == "__main__":
    main()
