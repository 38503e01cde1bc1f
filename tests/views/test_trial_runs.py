"""The numbers behind the identification views (vectorid.views.trial_runs), on the
reduced two-step demo: picks are the stored optima, recomputed criteria equal the stored
ones (the whole chain store -> spec -> data -> simulation -> arrays the figures draw), the
drop-out envelope is the one the drop-out functional measures, and the spectra are the
ones the figure draws."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from vectorid.analysis import Analysis
from vectorid.analysis.choice import suggest_choice
from vectorid.analysis.signals import power_spectrum
from vectorid.cli import main
from vectorid.identify import Identification, eigenfrequencies, get_criterion, trial_trajectories
from vectorid.identify.spectral import resample_uniform
from vectorid.spec import load_study
from vectorid.store import Store
from vectorid.views import trial_runs as vd

STEP2 = "g12-step2-controlled.db"


@pytest.fixture(scope="module")
def demo(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("views-demo")
    assert main(["demo", "--out", str(out), "--trials", "128", "--quiet"]) == 0
    return out


@pytest.fixture(scope="module")
def study(demo):
    with Store.open(demo / STEP2) as st:
        spec, trials = st.spec, st.load()
    a = Analysis(spec, trials)
    ident = Identification.from_spec(spec)
    return spec, a, ident


def test_best_per_pure_criterion_is_the_stored_argmin(study):
    spec, a, _ = study
    picks = vd.pick_trials(a, max_envelope=7)
    pure = [a.crit_names[j] for j in a.pure]
    assert set(picks.best) == set(pure) and len(pure) == 4
    rows = np.flatnonzero(a.feasible)
    for j in a.pure:
        col = a.trials.F[rows, j]
        assert picks.best[a.crit_names[j]] == a.trials.id[rows[np.nanargmin(col)]]
    assert picks.chosen == suggest_choice(a)
    assert vd.pick_trials(a, [int(a.trials.id[5])]).chosen == a.trials.id[5]
    # the envelope: at most max_envelope Pareto trials, sorted by the first pure criterion
    pareto_ids = set(a.trials.id[a.pareto].tolist())
    assert picks.envelope_set == "Pareto" and 1 <= len(picks.envelope) <= 7
    assert set(picks.envelope) <= pareto_ids
    assert len(picks.envelope) == min(7, len(pareto_ids))
    f0 = a.trials.F[vd.rows_of(a, picks.envelope), a.pure[0]]
    assert np.all(np.diff(f0) >= 0)
    # the worst trial is a successful trial outside the Pareto set
    assert picks.worst is not None and picks.worst not in pareto_ids
    assert a.ok[vd.rows_of(a, [picks.worst])[0]]
    ids = picks.ids()
    assert len(ids) == len(set(ids)) and ids[0] == picks.chosen


def test_worst_trial_on_constructed_criteria():
    F = np.array([[0.0, 5.0], [1.0, 1.0], [0.9, 4.0], [2.0, np.nan], [0.2, 0.9]])
    a = SimpleNamespace(
        ok=np.array([True, True, True, True, False]),
        trials=SimpleNamespace(F=F, id=np.array([10, 11, 12, 13, 14])),
        pure=[0, 1],
        senses=["min", "max"],
        crit_names=["f", "g"],
    )
    # over the successful finite rows 10..12: f -> 0, 1, .9; -g -> 0, 1, .25 (sums 0, 2, 1.15)
    assert vd.worst_trial(a) == 11
    a.senses = ["min", "min"]  # g -> 1, 0, .75 (sums 1, 1, 1.65)
    assert vd.worst_trial(a) == 12
    a.pure = [1]  # only g counts
    assert vd.worst_trial(a) == 10
    a.ok[:] = False
    assert vd.worst_trial(a) is None


def test_recomputed_criteria_equal_the_stored_ones(study):
    """Simulating stored trials again and applying the library criteria to the arrays the
    figures draw gives back the stored criteria: the chain is the identification's."""
    spec, a, ident = study
    picks = vd.pick_trials(a, max_envelope=3)
    rng = np.random.default_rng(3)
    ok_rows = np.flatnonzero(a.ok)
    rows = np.unique(np.concatenate([vd.rows_of(a, picks.ids()), rng.choice(ok_rows, 4)]))
    runs = vd.simulate_trials(ident, a.trials.X[rows], labels=[f"r{r}" for r in rows])
    assert runs.ok.all() and runs.X.shape == (len(rows), len(spec.space))
    for j, c in enumerate(ident.criteria):
        cdef = get_criterion(c.use)
        got = cdef.fn(runs.simulated[cdef.channel], runs.measured[cdef.channel], runs.grid)
        np.testing.assert_allclose(got, a.trials.F[rows, j], rtol=1e-7, err_msg=c.name)
    # the trajectories (north, east, up) are the same positions, only the axis flipped
    flight, model = runs.trajectories()
    flip = np.array([1.0, 1.0, -1.0])
    for name in ("pos_h_abs", "pos_v_abs"):
        j = spec.criterion_names.index(name)
        got = get_criterion(name).fn(model * flip, flight * flip, runs.grid)
        np.testing.assert_allclose(got, a.trials.F[rows, j], rtol=1e-7)
    assert flight[-1, 2] < flight[0, 2] - 100  # up is up: the parachute descends
    # one trial of the batch equals trial_trajectories (the UI's single-trial path)
    f1, m1 = trial_trajectories(spec, a.trials.X[rows[0]])
    np.testing.assert_allclose(f1, flight)
    np.testing.assert_allclose(m1, model[0], rtol=1e-10, atol=1e-9)


def test_channel_histories_degrees_alignment_and_failed_trials(study):
    _, a, ident = study
    bad = np.array([50.0, -10.0, 5.0, 100.0])  # far outside the box: the simulation fails
    X = np.vstack([a.trials.X[np.flatnonzero(a.ok)[:2]], bad])
    runs = vd.simulate_trials(ident, X, labels=["a", "b", "bad"])
    assert runs.ok.tolist() == [True, True, False]
    h = runs.channel_histories("euler")
    assert h.unit == "deg" and h.labels == ["a", "b"] and h.failed == ["bad"]
    assert list(h.flight) == ["roll", "pitch", "yaw"] and h.bands == {}
    rad = runs.channel_histories("euler", [0], degrees=False)
    np.testing.assert_allclose(h.flight["yaw"], np.degrees(rad.flight["yaw"]))
    # simulated angles are drawn as measured + wrap(sim - measured): within π of the flight
    sim = rad.runs[0][1]
    for c in ("roll", "pitch", "yaw"):
        assert np.all(np.abs(sim[c] - rad.flight[c]) <= np.pi + 1e-12)
    np.testing.assert_allclose(
        np.cos(sim["yaw"]), np.cos(runs.simulated["euler"][0, :, 2]), atol=1e-12
    )
    v = runs.channel_histories("velocity")
    assert v.unit == "m/s" and np.array_equal(v.flight["down"], runs.measured["velocity"][:, 2])
    flight, sims = runs.euler_series()
    assert set(sims) == {"a", "b"}
    with pytest.raises(KeyError, match="no simulated 'altitude'"):
        runs.channel_histories("altitude")
    with pytest.raises(ValueError, match="expected 3 labels"):
        vd.simulate_trials(ident, X, labels=["a"])
    with pytest.raises(KeyError, match="has no 'altitude' channel"):
        vd.simulate_trials(ident, X, channels=["altitude"])


def test_dropout_envelope_is_the_one_the_functional_measures(demo, study):
    """With drop-out functionals defined, the envelope of channel_histories is
    measurement ± band, and a run's largest excursion beyond it is the functional's value."""
    _, a, _ = study
    text = (demo / "step2.toml").read_text(encoding="utf-8")
    extra = (
        '[[constraints]]\nname = "out_vz"\nhigh = 0.0\n\n'
        '[[constraints]]\nname = "out_att"\nhigh = 0.0\n\n'
    )
    text = text.replace("[identification]\n", extra + "[identification]\n", 1)
    text += (
        '\n[identification.dropout.out_vz]\nchannel = "velocity"\ncomponents = ["down"]\n'
        "band = 0.6\n"
        '\n[identification.dropout.out_att]\nchannel = "euler"\n'
        'components = ["roll", "pitch"]\nband = [0.03, 0.05]\n'
    )
    path = demo / "step2-dropout.toml"
    path.write_text(text, encoding="utf-8")
    spec = load_study(path)
    ident = Identification.from_spec(spec)
    X = a.trials.X[np.flatnonzero(a.ok)[:6]]
    runs = vd.simulate_trials(ident, X)
    _, G = ident.evaluate(X)
    assert G.shape == (6, 2)
    bands = vd.dropout_bands(ident, ident.drops[0])
    assert set(bands) == {"velocity", "euler"}
    assert np.isnan(bands["velocity"][:, :2]).all() and np.all(bands["velocity"][:, 2] == 0.6)
    np.testing.assert_array_equal(bands["euler"][0], [0.03, 0.05, np.nan])
    for j, (ch, comps) in enumerate((("velocity", ["down"]), ("euler", ["roll", "pitch"]))):
        h = runs.channel_histories(ch, degrees=False)
        assert sorted(h.bands) == sorted(comps)
        exc = np.zeros(len(h.runs))
        for c in comps:
            lo, hi = h.bands[c]
            k = runs.components[ch].index(c)
            np.testing.assert_allclose(hi - h.flight[c], bands[ch][:, k])
            np.testing.assert_allclose(h.flight[c] - lo, hi - h.flight[c])
            for r, (_, vals) in enumerate(h.runs):
                exc[r] = max(exc[r], np.max(np.maximum(vals[c] - hi, lo - vals[c])))
        np.testing.assert_allclose(np.maximum(exc, 0.0), G[:, j], rtol=1e-9, atol=1e-12)
    assert (G[:, 0] > 0).any()  # the bands are tight enough to be crossed: the test bites
    # in degrees the envelope scales with the values
    hd = runs.channel_histories("euler")
    np.testing.assert_allclose(hd.bands["roll"][1] - hd.flight["roll"], np.degrees(0.03))


def test_euler_spectra_are_what_the_figure_draws(study):
    pytest.importorskip("plotly")
    from vectorid.views.figures import spectra_figure

    _, a, ident = study
    rows = np.flatnonzero(a.ok)[:2]
    runs = vd.simulate_trials(ident, a.trials.X[rows], labels=["p", "q"])
    spec_ = runs.spectra()
    assert set(spec_) == {"flight", "p", "q"}
    f, p = spec_["flight"]
    assert p.shape == (len(f), 3) and np.all(p >= 0)
    # Welch on the comparison grid: the Nyquist frequency is 1 / (2 output_dt)
    assert f[-1] == pytest.approx(0.5 / ident.output_dt)
    # the measured roll's dominant frequency agrees with the spectral module's eigenfrequency
    # (an independent Welch + parabolic refinement) within one frequency bin
    t, x, fs = resample_uniform(runs.t, runs.measured["euler"][:, 0])
    ef = eigenfrequencies(x, fs, fmin=f[1])[0]
    k = 1 + int(np.argmax(p[1:, 0]))
    assert abs(f[k] - ef) <= f[1] - f[0]
    # the figure draws exactly these spectra (zero frequency left out on the log axis)
    flight, sims = runs.euler_series()
    fig = spectra_figure(runs.t, flight, sims)
    traces = {(tr.name, tr.xaxis): tr for tr in fig.data}
    for lab, (ff, pp) in spec_.items():
        for c, ax in enumerate(("x", "x2", "x3")):
            tr = traces[(lab, ax)]
            np.testing.assert_allclose(tr.x, ff[1:])
            np.testing.assert_allclose(tr.y, pp[1:, c])
    # power_spectrum of the flight's raw arrays gives the same flight spectrum
    f2, p2 = power_spectrum(runs.t, runs.measured["euler"])
    np.testing.assert_allclose(p2, p)


def test_nominal_vector_uses_study_nominal_then_model(study):
    spec, _, ident = study
    nom = vd.nominal_vector(spec, ident)
    study_nom = spec.space.nominal
    assert np.isfinite(nom).all() and np.isnan(study_nom).any()  # x15 has no study nominal
    has = np.isfinite(study_nom)
    np.testing.assert_array_equal(nom[has], study_nom[has])
    np.testing.assert_array_equal(nom[~has], ident.base[np.array(ident.columns)[~has]])
