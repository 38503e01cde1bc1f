"""Benchmark: every figure for 1e5 trials and 6 criteria, and the HTML report.

Usage::

    .venv/bin/python benchmarks/report.py [--trials 100000] [--criteria 6] [--params 15]
                                          [--max-points 3000]

A synthetic store is written (criteria from a cheap closed form, no model run), then:

1. every figure of :mod:`vectorid.views.figures` is built and serialised (``to_json``) as
   the report does it (SVG point clouds, float32, each set thinned to ``--max-points`` and the
   infeasible bulk as a density), and again with every point (``max_points=None``);
2. baseline, measured in the same run: the point-cloud figures built the plain way
   (``go.Scatter`` SVG traces with float64 data, every point, one trace per class, the
   matrix as a grid of k(k−1)/2 subplots);
3. :func:`vectorid.views.report.write_report` on the store (goals at 1e5 trials: written in
   <= 10 s, <= 8 MB), with its size and figure count; the CPU, its vector ISA and the load
   average are printed (the machine may be shared).

Ratios are ours / baseline (time and embedded JSON size).
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path

import numpy as np

import _machine


def synthetic_store(path: Path, n: int, k: int, p: int, seed: int = 0):
    from vectorid.problem import Criterion, FunctionalConstraint
    from vectorid.sampling import PointSequence
    from vectorid.space import Continuous, Space
    from vectorid.spec import StudySpec
    from vectorid.store import Store

    space = Space([Continuous(f"c{j + 1}", 0.2, 2.0, nominal=1.0) for j in range(p)])
    crit = [Criterion(f"f{i + 1}", "min", "pure" if i < 4 else "pseudo") for i in range(k)]
    spec = StudySpec(
        name="bench",
        model="dtlz2-3",
        space=space,
        criteria=crit,
        constraints=[FunctionalConstraint("g", high=1.8)],
        trials=n,
    )
    store = Store.create(path, spec)
    X = space.scale(PointSequence(p, "sobol").points(0, n))
    rng = np.random.default_rng(seed)
    U = (X - 0.2) / 1.8
    F = np.empty((n, k))
    for i in range(k):
        w = np.roll(np.linspace(1.0, 0.1, p), i)
        F[:, i] = (U * w).sum(axis=1) / w.sum() + 0.6 * (U[:, i % p] - 0.5) ** 2 * (i % 2 * 2 - 1)
    F += 0.01 * rng.standard_normal(F.shape)
    G = U[:, :1] + U[:, 1:2]
    status = np.zeros(n, np.int8)
    status[rng.choice(n, n // 200, replace=False)] = 1
    F[status == 1] = np.nan
    G[status == 1] = np.nan
    for s in range(0, n, 8192):
        e = min(n, s + 8192)
        store.write_batch(0, s, X[s:e], F[s:e], G[s:e], status[s:e], np.zeros(e - s), {})
    store.close()
    limits = {f"f{i + 1}": float(np.nanquantile(F[:, i], 0.7)) for i in range(k)}
    return limits


def _timed(fn):
    t0 = time.perf_counter()
    fig = fn()
    payload = fig.to_json()
    return time.perf_counter() - t0, len(payload)


def baseline_figures(a, names):
    """The plain way: SVG go.Scatter, float64, every point."""
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    from vectorid.analysis.classes import CLASS_COLOURS, point_classes

    pc = point_classes(a)
    F = a.trials.F
    X = a.trials.X

    def pair():
        fig = go.Figure()
        for c, m in pc.items():
            fig.add_trace(
                go.Scatter(x=F[m, 0], y=F[m, 1], mode="markers", marker_color=CLASS_COLOURS[c])
            )
        return fig

    def matrix():
        k = len(names)
        fig = make_subplots(rows=k - 1, cols=k - 1)
        for r in range(1, k):
            for c in range(r):
                for cl, m in pc.items():
                    fig.add_trace(
                        go.Scatter(
                            x=F[m, c], y=F[m, r], mode="markers", marker_color=CLASS_COLOURS[cl]
                        ),
                        row=r,
                        col=c + 1,
                    )
        return fig

    def vs_params():
        p = X.shape[1]
        cols = 4
        fig = make_subplots(rows=math.ceil(p / cols), cols=cols)
        for j in range(p):
            for cl, m in pc.items():
                fig.add_trace(
                    go.Scatter(
                        x=X[m, j], y=F[m, 0], mode="markers", marker_color=CLASS_COLOURS[cl]
                    ),
                    row=j // cols + 1,
                    col=j % cols + 1,
                )
        return fig

    return {"pair": pair, "matrix": matrix, "vs_params": vs_params}


def our_figures(a, stages, max_points):
    from vectorid.analysis.correlation import correlation_of
    from vectorid.analysis.histograms import histograms
    from vectorid.analysis.refine import propose_refine
    from vectorid.analysis.sensitivity import sensitivity
    from vectorid.views import figures as fg

    per_panel = None if max_points is None else max(200, max_points // len(a.spec.space))
    return {
        "pair": lambda: fg.scatter_figure(a, "f1", "f2", max_points=max_points, gl=False),
        "matrix": lambda: fg.scatter_matrix_figure(a, max_points=max_points),
        "vs_params": lambda: fg.criterion_vs_parameter_figure(
            a, "f1", max_points=per_panel, gl=False
        ),
        "parallel": lambda: fg.parallel_figure(a, lines=max_points),
        "histograms": lambda: fg.histograms_figure(histograms(a)),
        "refine": lambda: fg.refine_figure(propose_refine(a, stages), a),
        "correlation": lambda: fg.correlation_figure(correlation_of(a, "feasible")),
        "sensitivity": lambda: fg.sensitivity_figure(sensitivity(a)),
    }


def printed_pdf(html: Path) -> tuple[int, float]:
    """Bytes of the report printed to PDF by headless Chromium (as a browser's print does,
    after every figure has drawn its picture for print), and the seconds it took."""
    import base64
    import shutil

    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    for flag in (
        "--headless=new --no-sandbox --disable-gpu --disable-dev-shm-usage --no-first-run "
        "--window-size=1300,1000 --enable-unsafe-swiftshader"
    ).split():
        opts.add_argument(flag)
    profile = tempfile.mkdtemp(prefix="vectorid-bench-report-")
    opts.add_argument(f"--user-data-dir={profile}")
    opts.binary_location = shutil.which("chromium") or "/usr/bin/chromium"
    drv = webdriver.Chrome(
        service=Service(shutil.which("chromedriver") or "/usr/bin/chromedriver"), options=opts
    )
    try:
        t0 = time.perf_counter()
        drv.get(html.resolve().as_uri())
        deadline = time.monotonic() + 300
        while not drv.execute_script("return window.vectoridPrintReady === true"):
            if time.monotonic() > deadline:
                raise RuntimeError("the report's figures did not finish drawing")
            time.sleep(0.2)
        pdf = base64.b64decode(drv.execute_cdp_cmd("Page.printToPDF", {})["data"])
        return len(pdf), time.perf_counter() - t0
    finally:
        drv.quit()
        shutil.rmtree(profile, ignore_errors=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=100_000)
    ap.add_argument("--criteria", type=int, default=6)
    ap.add_argument("--params", type=int, default=15)
    ap.add_argument("--max-points", type=int, default=3_000)
    ap.add_argument(
        "--pdf", action="store_true", help="also print the report to PDF in headless Chromium"
    )
    args = ap.parse_args()
    print(_machine.describe())

    from vectorid.analysis import Analysis
    from vectorid.store import Store
    from vectorid.views.report import write_report

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.db"
        t0 = time.perf_counter()
        limits = synthetic_store(path, args.trials, args.criteria, args.params)
        print(
            f"synthetic store: {args.trials} trials, {args.criteria} criteria, "
            f"{args.params} parameters ({time.perf_counter() - t0:.1f} s)"
        )
        store = Store.open(path)
        t0 = time.perf_counter()
        a = Analysis.of_store(store, limits)
        stages = store.stages()
        print(
            f"load + analysis: {time.perf_counter() - t0:.2f} s; N={a.n} ND={a.n_feasible} "
            f"NP={a.n_pareto}"
        )

        print(
            f"\n{'figure':<14}{'ours (report)':>22}{'ours (all points)':>22}"
            f"{'baseline go.Scatter':>24}{'time ratio':>12}{'size ratio':>12}"
        )
        import plotly.graph_objects as go

        go.Figure(go.Scattergl(x=[0.0], y=[0.0])).to_json()  # warm up plotly's validators
        go.Figure(go.Scatter(x=[0.0], y=[0.0])).to_json()
        ours = our_figures(a, stages, args.max_points)
        full = our_figures(a, stages, None)
        base = baseline_figures(a, a.crit_names)
        tot_ours = tot_base = 0.0
        for name in ours:
            t1, s1 = _timed(ours[name])
            t2, s2 = _timed(full[name])
            row = f"{name:<14}{t1:>9.2f} s {s1 / 1e6:>7.2f} MB{t2:>9.2f} s {s2 / 1e6:>7.2f} MB"
            if name in base:
                t3, s3 = _timed(base[name])
                tot_ours += t1
                tot_base += t3
                row += f"{t3:>11.2f} s {s3 / 1e6:>8.2f} MB{t1 / t3:>12.3f}{s1 / s3:>12.3f}"
            print(row)
        print(
            f"point-cloud figures, ours (report settings) / baseline time: "
            f"{tot_ours / tot_base:.3f}"
        )

        out = Path(tmp) / "report.html"
        res = write_report(store, out, limits=limits, max_points=args.max_points)
        print(
            f"\nreport: {res.seconds:.1f} s (goal <= 10 s), {res.size / 1e6:.1f} MB "
            f"(goal <= 8 MB), {len(res.figures)} figures, {len(res.notes)} thinned; "
            f"machine now: {_machine.describe()}"
        )
        if args.pdf:
            size, secs = printed_pdf(out)
            print(
                f"printed to PDF by headless Chromium (every figure as its print picture): "
                f"{size / 1e6:.1f} MB (goal <= 10 MB), {secs:.1f} s to draw and print"
            )
        store.close()


if __name__ == "__main__":
    main()
