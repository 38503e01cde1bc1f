"""The numbers behind each figure: class counts, decimation, limit lines, histogram totals,
section values, and the identification views on synthetic arrays."""

import numpy as np
import pytest

pytest.importorskip("plotly", reason="figures need the plot extra (plotly)")

from tests.analysis_helpers import make_store
from vectorid import Study
from vectorid.analysis.correlation import correlation, parameter_spread
from vectorid.analysis.histograms import histograms
from vectorid.analysis.refine import propose_refine
from vectorid.analysis.sensitivity import sensitivity
from vectorid.errors import StudyDefinitionError
from vectorid.views import figures as fg
from vectorid.workflows.extra import run_robustness, run_section


@pytest.fixture(scope="module")
def user(tmp_path_factory, request):
    """The user-model study of tests/conftest.py (has failed trials)."""
    from tests.conftest import write_user_study
    from vectorid.spec import load_study

    folder = tmp_path_factory.mktemp("fig")
    toml = write_user_study(folder, trials=256)
    path = folder / "u.db"
    with Study.create(load_study(toml), path) as st:
        st.run(executor="serial")
    with Study.open(path) as st:
        yield st.analysis({"f1": 0.8}), path


def _by_class(fig):
    return {tr.meta["class"]: tr for tr in fig.data if tr.meta and "class" in tr.meta}


def test_scatter_counts_per_colour_class(user):
    a, _ = user
    assert a.n_failed > 0 and 0 < a.n_pareto < a.n_feasible < a.n
    fig = fg.scatter_figure(a, "f1", "f2")
    tr = _by_class(fig)
    assert tr["infeasible"].meta["count"] + a.n_failed == a.n - a.n_feasible
    assert len(tr["infeasible"].x) == a.n - a.n_feasible - a.n_failed
    assert len(tr["feasible"].x) == a.n_feasible - a.n_pareto
    assert len(tr["pareto"].x) == a.n_pareto
    assert tr["pareto"].marker.color == "#2ca02c" and tr["infeasible"].marker.color == "#d62728"
    assert tr["feasible"].marker.color == "#1f77b4" and tr["pareto"].type == "scattergl"
    # the Pareto trace holds exactly the Pareto trials' criteria and ids
    ids = set(np.asarray(tr["pareto"].customdata).tolist())
    assert ids == set(a.trials.id[a.pareto].tolist())
    # criteria constraints drawn as lines: f1 <= 0.8 (vertical), f2 <= 1.0 (horizontal)
    lines = [s for s in fig.layout.shapes if s.type == "line"]
    assert any(s.x0 == 0.8 == s.x1 for s in lines) and any(s.y0 == 1.0 == s.y1 for s in lines)
    assert "drawn" not in tr["feasible"].name  # nothing thinned: no fraction in the legend


def test_thinning_is_per_set_and_labelled_and_infeasible_becomes_a_density(user):
    a, _ = user
    budget = 20
    fig = fg.scatter_figure(a, "f1", "f2", max_points=budget)
    tr = _by_class(fig)
    feas = a.n_feasible - a.n_pareto
    assert feas > budget
    # D beyond the budget (where its points would overplot): a density of every one of them,
    # in D's colours; the Pareto set keeps points (open rings: what lies under them shows)
    d = tr["feasible"]
    assert d.type == "heatmap" and d.meta["drawn_as"] == "density"
    assert int(np.asarray(d.customdata).sum()) == feas and "as a density" in d.name
    assert tr["pareto"].meta["shown"] == min(a.n_pareto, budget)
    assert tr["pareto"].marker.symbol == "circle-open"
    if a.n_pareto > budget:
        assert f"{budget} drawn" in tr["pareto"].name
    # the legend's sets add up to N, and the title says so
    counts = {k: t.meta["count"] for k, t in tr.items()}
    assert counts["feasible"] + counts["pareto"] == a.n_feasible
    assert sum(counts.values()) + a.n_failed == a.n
    assert f"ND {a.n_feasible:,} (in D, not Pareto {feas:,} + NP {a.n_pareto:,})" in (
        fig.layout.title.text
    )
    # infeasible trials beyond the budget: a 2-D histogram of every one of them
    inf = tr["infeasible"]
    assert inf.type == "heatmap" and inf.meta["drawn_as"] == "density"
    assert int(np.asarray(inf.customdata).sum()) == a.n - a.n_feasible - a.n_failed
    # a selection is drawn in the set colours, on top
    sel = np.zeros(a.n, bool)
    sel[np.flatnonzero(a.pareto)[:2]] = True
    fig = fg.scatter_figure(a, "f1", "f2", max_points=budget, selected=sel)
    drawn = [t for t in fig.data if (t.meta or {}).get("class") == "selected"]
    assert [t.marker.color for t in drawn] == ["#2ca02c"] and len(drawn[0].x) == 2


def test_matrix_and_vs_params(user):
    a, _ = user
    m = fg.scatter_matrix_figure(a)
    tr = _by_class(m)
    assert [t.type for t in tr.values()] == ["splom"] * 3
    assert len(tr["pareto"].dimensions) == 2
    assert len(tr["pareto"].dimensions[0].values) == a.n_pareto
    assert any(s.x0 == 0.8 for s in m.layout.shapes)
    v = fg.criterion_vs_parameter_figure(a, "f1", max_points=30)
    assert len(v.data) == 3 * 3  # three sets in each of three panels
    assert {t.xaxis for t in v.data} == {"x", "x2", "x3"}
    feas = a.n_feasible - a.n_pareto
    assert v.data[1].meta["shown"] == feas  # as points, or beyond 30 as a density of all
    assert v.data[1].meta["drawn_as"] == ("density" if feas > 30 else "points")
    with pytest.raises(StudyDefinitionError, match="unknown"):
        fg.scatter_figure(a, "f1", "nope")
    # grids of any size stay inside the figure (15 panels: 4 rows, float residue clipped)
    from vectorid.views.clouds import grid_layout

    for n in (1, 2, 5, 12, 15, 33):
        lay, axes = grid_layout(n, 4, [str(i) for i in range(n)])
        for key, ax in lay.items():
            if key != "annotations":
                assert 0.0 <= ax["domain"][0] < ax["domain"][1] <= 1.0, (n, key)
        assert len(axes) == n
    raw = fg.scatter_figure(a, "f1", "f2", max_points=30, raw=True)
    assert isinstance(raw, dict) and raw["data"][1]["x"]["dtype"] == "f4"


def test_matrix_for_eight_criteria(tmp_path):
    path = make_store(tmp_path, problem="dtlz2-5", trials=256)
    with Study.open(path) as st:
        a = st.analysis()
    if len(a.crit_names) < 5:
        pytest.skip("dtlz2-5 has fewer criteria than expected")
    m = fg.scatter_matrix_figure(a, names=a.crit_names + a.spec.space.names[:3])
    assert len(m.data[0].dimensions) == len(a.crit_names) + 3 >= 8


def test_histogram_figure_totals(user):
    a, _ = user
    hs = histograms(a, bins=7)
    fig = fg.histograms_figure(hs)
    feas = [t for t in fig.data if t.meta["class"] == "feasible"]
    par = [t for t in fig.data if t.meta["class"] == "pareto"]
    assert len(feas) == len(par) == 3
    assert all(t.meta["total"] == a.n_feasible for t in feas)
    assert all(t.meta["total"] == a.n_pareto for t in par)
    # each set on its own scale: the step heights are shares of the set, summing to 100 %
    for t in feas + par:
        assert np.isclose(np.asarray(t.y)[::2].sum(), 100.0)
        counts = np.asarray(t.customdata)[::2, 0]
        assert counts.sum() == t.meta["total"]
    s = fg.stage_histograms_figure(hs[:1])
    assert sum(s.data[0].y) == a.n


def test_section_refine_robustness_figures(user, tmp_path):
    import shutil

    a, path = user
    copy = tmp_path / "u.db"
    shutil.copy(path, copy)
    with Study.open(copy, write=True) as st:
        tid = int(a.trials.id[a.pareto][0])
        sec = run_section(st.store, tid, "x1", points=9, value_range=(0.0, 0.85))
        chk = run_robustness(st.store, tid, radius=0.01, points=8, analysis=a)
    fig = fg.section_figure(sec, a.bounds)
    lines = [t for t in fig.data if t.mode == "lines+markers"]
    assert len(lines) == 2
    np.testing.assert_allclose(np.asarray(lines[0].y, float), sec.F[:, 0])
    np.testing.assert_allclose(np.asarray(lines[0].x, float), sec.values)
    marker = next(t for t in fig.data if t.mode == "markers")
    assert marker.y[0] == pytest.approx(sec.f0[0])
    r = fg.refine_figure(propose_refine(a), a)
    assert [t.name for t in r.data[:2]] == ["current box", "proposed box"]
    rb = fg.robustness_figure([chk])
    assert len(rb.data) == 4 and chk.verdict in rb.layout.title.text


def test_correlation_spread_sensitivity_figures(user):
    a, _ = user
    rng = np.random.default_rng(0)
    x = rng.standard_normal(500)
    corr = correlation(np.column_stack([x, x, rng.standard_normal(500)]), ["a", "b", "c"])
    fig = fg.correlation_figure(corr)
    np.testing.assert_allclose(np.asarray(fig.data[0].z, float), corr.matrix)
    assert fig.data[0].text[0][1] == "1.00" and fig.data[0].text[0][2] == ""
    sp = parameter_spread(
        np.array([[1.0, 2.0]]), ["p", "q"], np.array([2.0, np.nan]), np.zeros(2), np.full(2, 4.0)
    )
    s = fg.spread_figure(sp)
    np.testing.assert_allclose(np.asarray(s.data[0].y, float), [0.5, 0.5])
    assert list(s.data[0].x) == ["p", "q [box]"]
    # with verdicts: D's and the Pareto set's ranges on the same scale, the verdict under the
    # name, and a hollow marker where the value is not an estimate
    from vectorid.analysis.identifiability import ParameterVerdict

    vs = [
        ParameterVerdict("p", "identified", (0.8, 1.2), (0.9, 1.1), (0.0, 4.0)),
        ParameterVerdict("q", "not identified", (0.4, 3.6), None, (0.0, 4.0)),
    ]
    s = fg.spread_figure(sp, verdicts=vs)
    band, pareto, line = s.data
    assert list(line.x) == ["p<br>identified", "q [box]<br>not identified"]
    np.testing.assert_allclose(np.asarray(band.y[:2], float), [0.4, 0.6])  # / nominal 2
    np.testing.assert_allclose(np.asarray(band.y[3:5], float), [0.1, 0.9])  # position in box
    assert len(pareto.y) == 3 and list(line.marker.symbol) == ["circle", "circle-open"]
    sens = sensitivity(a)
    f = fg.sensitivity_figure(sens)
    np.testing.assert_allclose(np.asarray(f.data[1].x, float), sens.ks)


def _synthetic_flight(seed=0, n=600):
    t = np.linspace(0, 120, n)
    rng = np.random.default_rng(seed)
    pos = np.column_stack([20 * np.sin(t / 15), 3 * t, 1500 - 5 * t])
    euler = {
        "roll": 0.1 * np.sin(2 * np.pi * 0.4 * t),
        "pitch": 0.05 * np.sin(2 * np.pi * 0.7 * t),
        "yaw": 0.01 * t + 0.02 * rng.standard_normal(n),
    }
    return t, pos, euler


def test_identification_views_on_synthetic_data():
    t, pos, euler = _synthetic_flight()
    runs = {"best f1": pos + 10.0, "nominal": pos * 1.05}
    tr = fg.trajectory_figure(pos, runs)
    assert len(tr.data) == 6
    np.testing.assert_allclose(np.asarray(tr.data[0].x, float), pos[:, 1])
    t3 = fg.trajectory3d_figure(pos, runs)
    assert [d.type for d in t3.data] == ["scatter3d"] * 3
    np.testing.assert_allclose(np.asarray(t3.data[1].z, float), pos[:, 2] + 10)
    sims = [(t, {k: v * s for k, v in euler.items()}) for s in (0.8, 1.0, 1.3)]
    ch = fg.channels_figure(t, euler, sims, labels=["a", "b", "c"], units={"roll": "rad"})
    band_lo = next(d for d in ch.data if d.name == "model envelope (min–max)")
    np.testing.assert_allclose(
        np.asarray(band_lo.y, float), euler["roll"] * np.where(euler["roll"] >= 0, 0.8, 1.3)
    )
    sp = fg.spectra_figure(t, euler, {"model": sims[0]}, nperseg=256)
    roll = sp.data[0]
    f = np.asarray(roll.x, float)
    assert abs(f[np.argmax(np.asarray(roll.y, float))] - 0.4) < 0.05
    with pytest.raises(ValueError, match="north, east, up"):
        fg.trajectory_figure(pos[:, :2])


def test_channels_figure_highlighted_runs_and_bands():
    t, _, euler = _synthetic_flight()
    sims = [(t, {k: v * s for k, v in euler.items()}) for s in (0.8, 1.0, 1.3)]
    bands = {"pitch": (euler["pitch"] - 0.02, euler["pitch"] + 0.02)}
    ch = fg.channels_figure(t, euler, sims, labels=["a", "b", "c"], show_runs=[1], bands=bands)
    names = [d.name for d in ch.data]
    # only the highlighted run is drawn (once per panel), bold; the envelope still uses all
    assert names.count("b") == 3 and "a" not in names and "c" not in names
    assert all(d.line.width == 2 for d in ch.data if d.name == "b")
    lo = next(d for d in ch.data if d.name == "model envelope (min–max)")
    np.testing.assert_allclose(
        np.asarray(lo.y, float), euler["roll"] * np.where(euler["roll"] >= 0, 0.8, 1.3)
    )
    drop = [d for d in ch.data if d.name == "drop-out envelope"]
    assert len(drop) == 2 and {d.yaxis for d in drop} == {"y2"}  # the pitch panel only
    assert [d.showlegend for d in drop] == [True, False]
    np.testing.assert_allclose(np.asarray(drop[1].y, float), euler["pitch"] + 0.02)
    none = fg.channels_figure(t, euler, sims, show_runs=False)
    assert not {"run 1", "run 2", "run 3"} & {d.name for d in none.data}


def test_history_stage_lines_stay_on_the_trials_axis():
    """A stage that starts after 32 trials is a dashed line at 32 whose label sits at
    log10(32) (plotly.js reads annotation positions on log axes in decades): the axis ends
    at the last trial count, not at 1e32."""
    from vectorid.views.history import History, history_figure

    n = np.array([1, 10, 32, 100, 160])
    h = History(n, n // 2, n // 4, [(1, 0), (2, 32)])
    fig = history_figure(h)
    assert len(fig.data) == 4 and list(fig.data[3].x) == [32, 32]
    assert list(fig.data[3].y) == [1, 160]
    (ann,) = fig.layout.annotations
    assert ann.text == "stage 2" and ann.x == pytest.approx(np.log10(32))
    assert not fig.layout.shapes


def test_density_from_kept_cells_equals_histogram2d():
    """A density counted from each point's kept grid cell (the browser UI) equals
    np.histogram2d's over the same span, edges and non-finite values included."""
    from vectorid.views.clouds import data_span, density_grid, density_of_cells, grid_cells

    rng = np.random.default_rng(3)
    x, y = rng.normal(size=5000), rng.uniform(0, 2, 5000)
    x[:5], y[5:10] = np.nan, np.inf
    x[10], y[11] = x[np.isfinite(x)].max(), 2.0  # points on the last edges
    span = data_span(x, y)
    cells = grid_cells(x, y, 40, span)
    for m in (np.ones(5000, bool), rng.uniform(size=5000) < 0.3):
        want = density_grid(x[m], y[m], 40, span=span)
        got = density_of_cells(cells, m, 40, span)
        for w, g in zip(want, got):
            assert np.array_equal(w, g)
