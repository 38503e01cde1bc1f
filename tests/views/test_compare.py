"""Two models side by side (``vectorid report A.db B.db``, the UI's Compare tab): the counts,
the common limits (the stated ones a relaxation started from), best values and trials meeting
each limit checked against the stores; bad input gets a one-line error."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from tests.views.many_axes import CRITERIA, many_axes_store
from vectorid import Study
from vectorid.views.compare import compare_stores, comparison_html, comparison_rows
from vectorid.views.labels import relaxed_of


@pytest.fixture(scope="module")
def two(tmp_path_factory):
    folder = tmp_path_factory.mktemp("compare")
    a = many_axes_store(folder, 1500, name="model_a")
    b = many_axes_store(folder, 1200, name="model_b", worse=1.6)
    return a, b


def test_the_comparison_is_the_stores(two):
    a_path, b_path = two
    c = compare_stores(a_path, b_path)
    assert c.criteria == [n for n, _ in CRITERIA] and c.only == {"a": [], "b": []}
    assert c.same_drop is None and "no flight data" in c.drop and not c.spectral
    with Study.open(a_path) as sa, Study.open(b_path) as sb:
        stated = {cr.name: relaxed_of(cr).stated for cr in sa.spec.criteria}
        # both stages relaxed their limits as the last resort: the common limits are the
        # stated ones, the same for both (B states A's)
        assert all(relaxed_of(cr) is not None for cr in sb.spec.criteria)
        for n in c.criteria:
            assert c.common[n][0] == pytest.approx(stated[n], rel=1e-3)
            assert "before the relaxation x" in c.common[n][1]
        lim = {n: c.common[n][0] for n in c.criteria}
        for side, st in ((c.a, sa), (c.b, sb)):
            own, common = st.analysis(), st.analysis(lim)
            assert (side.n, side.nd, side.np) == (own.n, own.n_feasible, own.n_pareto)
            assert (side.nd_common, side.np_common) == (common.n_feasible, common.n_pareto)
            assert side.relaxed is not None and side.relaxed > 1
            for j, n in enumerate(c.criteria):
                col = own.trials.F[own.ok, j]
                assert side.best[n] == pytest.approx(np.nanmin(col))
                assert side.meets[n] == int((col <= lim[n]).sum())
    # the poorer model meets fewer limits' worth of trials, and the table says which meets
    assert sum(c.b.meets.values()) < sum(c.a.meets.values())
    rows = comparison_rows(c)
    assert [r[0] for r in rows["criteria"]] == [
        f"{n} [{u or 'no unit given'}]" for n, u in CRITERIA
    ]
    for r, n in zip(rows["criteria"], c.criteria):
        for k, side in ((3, c.a), (6, c.b)):
            assert r[k] == ("meets" if side.best[n] <= lim[n] else "misses")
    html = comparison_html(c)
    assert "relaxed x" in html and "no flight data" in html


def test_report_and_ui_compare(two, tmp_path):
    a_path, b_path = two
    out = tmp_path / "cmp.html"
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "vectorid.cli",
            "report",
            str(a_path),
            str(b_path),
            "--out",
            str(out),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 0, r.stderr
    assert "comparison written to" in r.stdout and out.stat().st_size > 100_000
    text = out.read_text(encoding="utf-8")
    assert (
        "model_a" in text
        and "model_b" in text
        and "best value over the common limit" in text.lower()
    )
    # a store that is not there: one line, exit status 2
    r = subprocess.run(
        [sys.executable, "-m", "vectorid.cli", "report", str(a_path), str(tmp_path / "no.db"),
         "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=120,
    )  # fmt: skip
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1, r.stderr
    # the UI's Compare tab: the same tables, no peaks to wait for here
    from vectorid.views.ui import callbacks as cb
    from vectorid.views.ui.compare import compare_view, start_compare
    from vectorid.views.ui.data import StoreCache
    from vectorid.views.ui.jobs import JobManager

    ctx = cb.UIContext(cache=StoreCache(a_path), jobs=JobManager(a_path))
    start_compare(ctx, b_path)
    v = compare_view(ctx)
    assert not v["pending"] and v["rows"] == comparison_rows(compare_stores(a_path, b_path))
    assert v["heads"]["counts"] == ["", v["a"], v["b"]]
