"""Noise statements, the noise estimator and noise-floor criteria constraints."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from vectorid import Study
from vectorid.descent import RocketDescent
from vectorid.errors import StudyDefinitionError, VectoridNote
from vectorid.identify import Identification
from vectorid.identify.flight import FlightChannel, FlightData
from vectorid.identify.noise import (
    ComponentNoise,
    estimate_correlated,
    estimate_noise,
    estimate_sigma,
    highfreq_sigma,
    parse_discrepancy,
    parse_noise,
)
from vectorid.identify.noise.floor import NoiseFloor, noise_floor
from vectorid.identify.noise.resolve import resolve_noise_limits
from vectorid.models import ControlSchedule, InitialState
from vectorid.spec import StudySpec

ORIGIN = 1300.0
CD = {"cd_drogue": 1.7, "cd_main": 2.6}
SIGMA_H = 2.0  # m, white altitude noise of the twin barometer


# -- the estimator ------------------------------------------------------------------------------


def _smooth(t):
    return 900.0 - 6.0 * t + 3.0 * np.sin(0.7 * t) + 0.02 * t**2


def test_estimator_recovers_white_noise_on_a_moving_signal():
    rng = np.random.default_rng(1)
    t = np.arange(0.0, 120.0, 0.05)  # 20 Hz, two minutes
    for sigma in (0.1, 0.5, 2.0):
        y = np.column_stack([_smooth(t), np.cos(0.3 * t)]) + rng.normal(0, sigma, (t.size, 2))
        est = estimate_sigma(t, y)
        assert est.shape == (2,)
        np.testing.assert_allclose(est, sigma, rtol=0.06)


def test_estimator_ignores_spikes_and_uneven_steps():
    rng = np.random.default_rng(2)
    t = np.arange(0.0, 60.0, 0.1)
    t = np.delete(t, np.arange(50, 600, 97))  # holes: uneven steps are skipped
    y = _smooth(t) + rng.normal(0, 0.3, t.size)
    y[::53] += 40.0  # ejection-charge spikes
    assert estimate_sigma(t, y)[0] == pytest.approx(0.3, rel=0.12)


def test_estimator_on_jittered_sample_times():
    """Rows at jittered times (a logger interleaving packets): the divided differences
    normalised by their weights have variance σ² whatever the steps."""
    rng = np.random.default_rng(6)
    t = np.cumsum(rng.choice([0.03, 0.05, 0.07, 0.09, 0.1, 0.1, 0.1], 3000))
    for sigma in (0.2, 1.5):
        y = _smooth(t) + rng.normal(0, sigma, t.size)
        assert estimate_sigma(t, y)[0] == pytest.approx(sigma, rel=0.06)
    # evenly spaced: the third differences over sqrt(20), as documented
    t = np.arange(0.0, 100.0, 0.1)
    y = rng.normal(0, 1.0, t.size)
    d = np.diff(y, 3) / math.sqrt(20.0)
    want = 1.482602218505602 * np.median(np.abs(d - np.median(d)))
    assert estimate_sigma(t, y)[0] == pytest.approx(want, rel=1e-9)


def test_estimator_on_jittered_time_stamps():
    """A 2.5-Hz receiver whose fixes are stamped 0.38-0.42 s apart (the ETH flights): the
    divided differences normalised by their noise spread recover σ; on even steps they are
    the plain differences."""
    rng = np.random.default_rng(6)
    t = np.cumsum(rng.uniform(0.38, 0.42, 3000))
    for sigma in (0.05, 0.3, 1.0):
        y = np.column_stack([_smooth(t), 5.0 * t]) + rng.normal(0, sigma, (t.size, 2))
        np.testing.assert_allclose(estimate_sigma(t, y), sigma, rtol=0.06)
    even = np.arange(0.0, 300.0, 0.4)
    y = _smooth(even) + rng.normal(0, 0.3, even.size)
    want = (
        1.482602218505602
        * np.median(np.abs(np.diff(y, 3) - np.median(np.diff(y, 3))))
        / math.sqrt(20)
    )
    assert estimate_sigma(even, y)[0] == pytest.approx(want, rel=1e-9)


def test_estimator_on_coloured_noise_sees_its_high_frequency_share():
    """A Gauss-Markov error slower than the sampling is indistinguishable from motion: the
    estimator sees what highfreq_sigma predicts (the documented limitation), not its σ."""
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 2000.0, 0.25)
    cn = ComponentNoise(1.5, correlation_time=20.0, white=0.2)
    n = cn.draw(t, 4, rng)  # four records
    est = np.array([estimate_sigma(t, _smooth(t) * 0 + n[i])[0] for i in range(4)])
    want = highfreq_sigma(cn, 0.25)
    assert want < 0.25 * cn.total  # the correlated part is mostly invisible ...
    np.testing.assert_allclose(est, want, rtol=0.08)  # ... and the estimate is its share
    # white noise: the share is the whole σ
    assert highfreq_sigma(ComponentNoise(0.7), 0.25) == pytest.approx(0.7)


@pytest.mark.parametrize(
    ("sigma", "tau", "white"), [(4.0, 1.0, 1.5), (2.0, 0.5, 0.5), (1.0, 0.2, 1.0)]
)
def test_correlated_estimator_recovers_gauss_markov_and_white_parts(sigma, tau, white):
    """On a descent that slows down (a quadratic signal, which third differences remove):
    the σ of both parts and the correlation time, over five records."""
    rng = np.random.default_rng(7)
    t = np.arange(0.0, 200.0, 0.1)
    sig = 3000.0 - 27.0 * t + 0.01 * t**2
    cn = ComponentNoise(sigma, correlation_time=tau, white=white)
    est = [estimate_correlated(t, sig + cn.draw(t, 1, rng)[0]) for _ in range(5)]
    assert np.median([e.sigma for e in est]) == pytest.approx(sigma, rel=0.15)
    assert np.median([e.correlation_time for e in est]) == pytest.approx(tau, rel=0.3)
    assert np.median([e.white for e in est]) == pytest.approx(white, rel=0.2)


def test_correlated_estimator_on_white_noise_and_short_series():
    rng = np.random.default_rng(8)
    t = np.arange(0.0, 200.0, 0.1)
    e = estimate_correlated(t, 500.0 - 8.0 * t + rng.normal(0, 1.0, t.size))
    assert e.correlation_time == 0 and e.sigma == pytest.approx(1.0, rel=0.1)
    # the third differences see only a Gauss-Markov error's high-frequency share
    n = ComponentNoise(3.0, correlation_time=0.5).draw(t, 1, rng)[0]
    assert estimate_sigma(t, n)[0] < 0.6 * estimate_correlated(t, n).total
    assert estimate_correlated(t[:100], n[:100]) is None  # 10 s: fewer than 4 max_lag


def test_gauss_markov_draws_have_the_stated_spread_and_correlation():
    rng = np.random.default_rng(4)
    t = np.cumsum(rng.uniform(0.1, 0.4, 4000))  # uneven steps: exact discretisation
    n = ComponentNoise(2.0, correlation_time=5.0).draw(t, 200, rng)
    assert n.std() == pytest.approx(2.0, rel=0.03)
    lag = np.searchsorted(t, t[:-400] + 5.0)  # pairs ~5 s apart: correlation e^-1
    k = np.arange(t.size - 400)
    r = np.mean(n[:, k] * n[:, lag]) / 4.0
    assert r == pytest.approx(math.exp(-1.0), abs=0.05)


def test_estimate_noise_of_a_flight():
    rng = np.random.default_rng(5)
    t = np.arange(0.0, 60.0, 0.02)
    eul = np.column_stack([0.1 * np.sin(t), 0.05 * np.cos(0.5 * t), 0.2 * t % (2 * np.pi)])
    fl = FlightData(
        "f",
        {
            "euler": FlightChannel(
                "euler", t, eul + rng.normal(0, 0.005, eul.shape), ("r", "p", "y"), "rad"
            )
        },
    )
    nm = estimate_noise(fl)
    assert nm.estimated
    for j in range(3):  # the wrapped yaw is unwrapped first
        assert nm.component("euler", j).sigma == pytest.approx(0.005, rel=0.08)
    assert "estimated euler" in nm.describe()


# -- statements -----------------------------------------------------------------------------------


def test_parse_noise_keys_units_and_errors():
    nm = parse_noise(
        {
            "position_h": 1.5,
            "position_v": {"sigma": 2.5, "correlation_time": 20.0, "white": 0.2},
            "euler_deg": 0.5,
        }
    )
    assert nm.component("position", 0).sigma == 1.5 and nm.component("position", 1).sigma == 1.5
    assert nm.component("position", 2).correlation_time == 20.0
    assert nm.component("euler", 2).sigma == pytest.approx(math.radians(0.5))
    assert nm.component("velocity", 0) is None
    assert parse_noise("estimate") == "estimate"
    with pytest.raises(StudyDefinitionError, match="position_h"):
        parse_noise({"positon_h": 1.0})
    with pytest.raises(StudyDefinitionError, match=r"σ >= 0 in m/s, got -1.0"):
        parse_noise({"velocity": -1.0})  # the error names the unit the σ is stated in
    with pytest.raises(StudyDefinitionError, match=r"correlation time >= 0 in s"):
        parse_noise({"altitude": {"sigma": 1.0, "correlation_time": -3}})
    with pytest.raises(StudyDefinitionError, match=r"σ >= 0 in deg"):
        parse_noise({"euler_deg": -0.5})
    with pytest.raises(StudyDefinitionError, match="estimate"):
        parse_noise("guess")
    with pytest.raises(StudyDefinitionError, match="correlation_time"):
        parse_noise({"altitude": {"sigma": 1.0, "tau": 3.0}})


def test_parse_discrepancy_channels_and_criteria():
    d = parse_discrepancy({"position_h": 20.0, "euler_deg": 2.0, "alt_abs": 50.0}, ["alt_abs"])
    assert d["channels"]["position"][:2] == [20.0, 20.0]
    assert d["channels"]["euler"][0] == pytest.approx(math.radians(2.0))
    assert d["criteria"] == {"alt_abs": 50.0}
    with pytest.raises(StudyDefinitionError, match="neither a noise key nor a criterion"):
        parse_discrepancy({"pos_h": 1.0}, ["alt_abs"])


# -- the floor on a known answer -----------------------------------------------------------------


def _twin(seed: int, sigma: float = SIGMA_H) -> FlightData:
    """Rocket descent under its main, barometric height at 20 Hz with white noise."""
    m = RocketDescent()
    res = m.simulate(
        np.array([[CD["cd_drogue"], CD["cd_main"]]]),
        t_final=40.0,
        dt=0.01,
        output_dt=0.05,
        initial=InitialState(altitude=ORIGIN + 700.0, velocity=(0.0, 0.0, 9.0)),
        inputs=ControlSchedule(np.array([0.0]), np.array([[1.0]]), ("main",), "previous"),
    )
    h = -res.position[0, :, 2] - ORIGIN
    h = h + np.random.default_rng(seed).normal(0.0, sigma, h.size)
    return FlightData("twin", {"altitude": FlightChannel("altitude", res.t, h, ("h",), "m")})


TABLE = {
    "dt": 0.05,
    "output_dt": 0.25,
    "init_span": 2.0,
    "parameters": {"cd_drogue": CD["cd_drogue"]},
    "criteria": {"rate": {"use": "descent_rate_avg", "operator": "absdiff"}},
    "drops": [{"name": "d", "window": [2.0, 32.0], "origin_altitude": ORIGIN,
               "inputs": {"main": 1.0}}],
}  # fmt: skip


def _ident(seed: int) -> Identification:
    return Identification.from_table(
        TABLE,
        variables=["cd_main"],
        criteria=["alt_abs", "alt_sq", "vz_abs", "rate"],
        flights={"d": _twin(seed)},
        default_model="rocket-descent",
    )


def test_floor_matches_the_twin_experiment_it_describes():
    """The floor's Monte Carlo is the distribution of the truth's criteria over noise
    realisations: compared with 150 real twins (new data, new initial-state fit each)."""
    noise = parse_noise({"altitude": SIGMA_H})
    truth = np.array([[CD["cd_main"]]])
    twins = np.array([_ident(100 + s).evaluate(truth)[0][0] for s in range(150)])
    floor = noise_floor(_ident(0), noise, draws=3000, seed=1, params=CD)
    for j, name in enumerate(floor.names):
        for q in (0.5, 0.9):
            got, want = np.quantile(floor.samples[:, j], q), np.quantile(twins[:, j], q)
            assert got == pytest.approx(want, rel=0.15), (name, q)
    # the residual part alone has a closed form: E ∫ n² dt = σ² T (the floor is above it,
    # since the initial-state fit error adds a constant offset)
    T = 30.0
    assert np.mean(floor.samples[:, 1]) > SIGMA_H**2 * T
    assert np.mean(floor.samples[:, 1]) == pytest.approx(np.mean(twins[:, 1]), rel=0.15)


def test_linearised_propagation_agrees_with_flying_each_draw():
    ident, noise = _ident(0), parse_noise({"altitude": SIGMA_H})
    lin = noise_floor(ident, noise, draws=120, seed=3, params=CD)
    full = noise_floor(ident, noise, draws=120, seed=3, params=CD, linear=False)
    scale = np.median(full.samples, axis=0)  # the rate criterion crosses 0: absolute terms
    assert np.all(np.abs(lin.samples - full.samples) <= 0.05 * scale)
    np.testing.assert_allclose(np.median(lin.samples, 0), scale, rtol=0.01)


def test_missing_noise_for_a_read_channel_is_an_error():
    with pytest.raises(StudyDefinitionError, match="no stated noise.*altitude"):
        noise_floor(_ident(0), parse_noise({"position_h": 1.0}), draws=100)


def test_joint_quantile_level():
    rng = np.random.default_rng(0)
    indep = NoiseFloor(["a", "b", "c"], ["", "", ""], rng.uniform(size=(40000, 3)), {}, {},
                       40000, 0, {})  # fmt: skip
    assert indep.quantile_level(["a", "b", "c"]) == pytest.approx(0.95 ** (1 / 3), abs=0.002)
    col = rng.uniform(size=(40000, 1))
    same = NoiseFloor(["a", "b"], ["", ""], np.hstack([col, col]), {}, {}, 40000, 0, {})
    assert same.quantile_level(["a", "b"]) == pytest.approx(0.95, abs=0.002)
    lim = same.limits(["a"], quantile=0.5)
    assert lim["a"][0] == pytest.approx(0.5, abs=0.01) and "q=0.5" in lim["a"][1]
    # the note counts its criteria in the right number
    assert "joint 95% over 1 criterion," in same.limits(["a"])["a"][1]
    assert "joint 95% over 2 criteria," in same.limits(["a", "b"])["a"][1]


def test_discrepancy_allowance_by_criterion_kind():
    ident, noise = _ident(0), parse_noise({"altitude": SIGMA_H})
    base = noise_floor(ident, noise, draws=300, seed=2, params=CD)
    T = float(ident.drops[0].grid[-1] - ident.drops[0].grid[0])
    disc = noise_floor(
        ident,
        noise,
        draws=300,
        seed=2,
        params=CD,
        discrepancy={"altitude": 3.0, "vz_abs": 7.0, "rate": 0.2},
    )
    np.testing.assert_allclose(disc.samples[:, 0], base.samples[:, 0] + 3.0 * T)  # ∫|e|+δT
    np.testing.assert_allclose(  # Minkowski: (√∫e² + δ√T)²
        disc.samples[:, 1], (np.sqrt(base.samples[:, 1]) + 3.0 * math.sqrt(T)) ** 2
    )
    # vz_abs reads the altitude but a bound on it does not bound its derivative: named only
    np.testing.assert_allclose(disc.samples[:, 2], base.samples[:, 2])
    lim = disc.limits(["vz_abs", "rate"], quantile=0.9)
    assert lim["vz_abs"][0] == pytest.approx(np.quantile(base.samples[:, 2], 0.9) + 7.0)
    assert "7 m discrepancy" in lim["vz_abs"][1]
    assert "discrepancy altitude 3 m" in disc.notes["alt_abs"]
    with pytest.raises(StudyDefinitionError, match="does not bound criterion 'vz_abs'"):
        noise_floor(ident, noise, draws=100, discrepancy={"altitude": 3.0})


# -- from the study file to the store -------------------------------------------------------------


def _study(tmp_path, ident_extra: dict, criteria=None) -> StudySpec:
    f = _twin(7)
    c = f["altitude"]
    lines = ["t,height"] + [f"{t:.3f},{v:.4f}" for t, v in zip(c.t, c.values[:, 0])]
    (tmp_path / "drop.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
    data = {
        "study": {"name": "noisy", "model": "rocket-descent", "trials": 64, "seed": 1},
        "variables": [{"name": "cd_main", "low": 1.5, "high": 3.5}],
        "criteria": criteria or [{"name": "alt_abs"}, {"name": "vz_abs", "role": "pseudo"}],
        "identification": {
            "dt": 0.05,
            "output_dt": 0.25,
            "init_span": 2.0,
            "noise_draws": 500,
            "parameters": {"cd_drogue": CD["cd_drogue"]},
            "drops": [
                {
                    "name": "d",
                    "file": "drop.csv",
                    "mapping": {
                        "time": "t",
                        "time_unit": "s",
                        "altitude": {"column": "height", "unit": "m"},
                    },
                    "window": [2.0, 32.0],
                    "origin_altitude": ORIGIN,
                    "inputs": {"main": 1.0},
                }
            ],
            **ident_extra,
        },
    }
    return StudySpec.from_dict(data, base_dir=tmp_path)


def test_noise_limits_are_computed_at_creation_and_kept_with_their_source(tmp_path, capsys):
    spec = _study(tmp_path, {"noise": {"altitude": SIGMA_H}, "limits": "noise"})
    assert all(c.limit is None for c in spec.criteria)
    with Study.create(spec, tmp_path / "s.db") as st:
        st.run(executor="serial")
        held = st.spec
    for c in held.criteria:
        assert c.limit is not None and c.source == "noise"
        assert "noise floor q=" in c.limit_note and "joint 95%" in c.limit_note
        assert c.unit in ("m·s", "m")  # filled from the library
    # the truth is inside D under these limits (this draw), and info says where limits came from
    from vectorid.cli import main

    assert main(["info", str(tmp_path / "s.db")]) == 0
    out = capsys.readouterr().out
    assert "noise floor q=" in out and "(noise" in out
    assert main(["table", str(tmp_path / "s.db"), "--top", "2"]) == 0
    assert "noise floor" in capsys.readouterr().out
    # an expert's --save changes the source; saving it unchanged keeps it
    with Study.open(tmp_path / "s.db", write=True) as st:
        lim = st.spec.criteria[0].limit
        st.store.set_limits({"alt_abs": lim})
        assert st.spec.criteria[0].source == "noise"
        st.store.set_limits({"alt_abs": lim * 2})
        assert st.spec.criteria[0].source == "expert" and st.spec.criteria[0].limit_note == ""


def test_limit_noise_on_one_criterion_and_the_expert_keeps_his(tmp_path):
    spec = _study(
        tmp_path,
        {"noise": "estimate"},
        criteria=[{"name": "alt_abs", "limit": "noise"}, {"name": "vz_abs", "limit": 99.0}],
    )
    assert spec.criteria[0].source == "noise" and spec.criteria[0].limit is None
    out = resolve_noise_limits(spec)
    a, v = out.criteria
    assert a.source == "noise" and a.limit > 0 and "estimated altitude" in a.limit_note
    assert v.limit == 99.0 and v.source == "expert"
    # round trip through the study dict (the store keeps it this way)
    again = StudySpec.from_dict(out.to_dict(), base_dir=tmp_path)
    assert again.criteria == out.criteria


@pytest.mark.parametrize("per_criterion", [False, True])
def test_rerunning_the_study_file_keeps_or_recomputes_the_noise_limits(tmp_path, per_criterion):
    """The file says limits = "noise" (unresolved); the store holds the resolved floors. A
    re-run of the unchanged file keeps them; a changed noise statement recomputes them (taken,
    no trial changes); dropping the request drops them."""
    import warnings

    if per_criterion:
        crit = [{"name": "alt_abs", "limit": "noise"}, {"name": "vz_abs", "limit": "noise"}]
        extra = {"noise": {"altitude": SIGMA_H}}
    else:
        crit, extra = None, {"noise": {"altitude": SIGMA_H}, "limits": "noise"}
    store = tmp_path / "s.db"
    with Study.create(_study(tmp_path, extra, crit), store) as st:
        st.run(executor="serial")
        first = {c.name: c.limit for c in st.spec.criteria}
    assert all(v is not None for v in first.values())

    def rerun(extra, crit):
        with warnings.catch_warnings(record=True):
            warnings.simplefilter("always")
            with Study.create_or_open(_study(tmp_path, extra, crit), store) as st:
                return {c.name: (c.limit, c.source) for c in st.spec.criteria}

    same = rerun(extra, crit)
    assert {k: v[0] for k, v in same.items()} == first
    assert all(src == "noise" for _, src in same.values())
    louder = rerun({**extra, "noise": {"altitude": 3 * SIGMA_H}}, crit)
    assert all(louder[k][0] > first[k] for k in first)  # recomputed, larger floors
    if not per_criterion:
        gone = rerun({"noise": {"altitude": SIGMA_H}}, crit)
        assert all(v[0] is None for v in gone.values())
    with Study.open(store) as st:
        assert st.store.count() == 64  # nothing recomputed, nothing lost


def test_noise_statement_errors_name_the_fix(tmp_path):
    with pytest.raises(StudyDefinitionError, match="no noise is stated"):
        resolve_noise_limits(_study(tmp_path, {"limits": "noise"}))
    with pytest.raises(StudyDefinitionError, match="unknown noise key"):
        Identification.from_spec(_study(tmp_path, {"noise": {"alt": 1.0}}))
    with pytest.raises(StudyDefinitionError, match='expected "noise"'):
        Identification.from_spec(_study(tmp_path, {"noise": "estimate", "limits": "all"}))
    with pytest.raises(StudyDefinitionError, match='a number or "noise"'):
        StudySpec.from_dict(
            {"study": {"name": "x", "model": "binh-korn"}, "variables": [
                {"name": "x1", "low": 0, "high": 1}], "criteria": [{"name": "f1",
                "limit": "nois"}]})  # fmt: skip


def test_index_criteria_are_evaluated_in_two_batched_calls_with_the_same_values(monkeypatch):
    """The floor evaluates an index criterion (a spectral peak, an index:operator) as the index
    of every simulation against the index of every measurement: the same values as the
    criterion draw by draw; a criterion without that form, or whose check fails, goes draw
    by draw."""
    from types import SimpleNamespace

    from vectorid.identify.criteria import get_criterion
    from vectorid.identify.noise import floor as noise_mod

    rng = np.random.default_rng(4)
    t = np.arange(0.0, 60.0, 0.2)
    wave = np.stack([np.sin(2 * np.pi * f * t) for f in (0.12, 0.8, 0.45)], axis=-1)
    sims = wave[None] + rng.normal(0.0, 0.3, (40, t.size, 3))
    meas = wave[None] + rng.normal(0.0, 0.3, (40, t.size, 3))
    euler = np.cumsum(sims, axis=1) * 0.2
    euler_m = np.cumsum(meas, axis=1) * 0.2
    cases = [
        ("peak_roll@0.05-0.5", None, sims, meas),
        ("peak_yaw", None, sims, meas),
        ("yaw_rate_max:ratio", "ratio", euler, euler_m),
        ("speed_profile", None, sims, meas),  # not an index: draw by draw
    ]
    for name, op, s, m in cases:
        cdef = get_criterion(name)
        c = SimpleNamespace(use=name.split(":")[0], operator=op)
        want = np.array([cdef.fn(s[r][None], m[r], t)[0] for r in range(len(s))])
        got = noise_mod._per_draw(cdef, c, s, m, t)
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15, err_msg=name)
    assert noise_mod._index_form("speed_profile", None) is None
    assert noise_mod._index_form("peak_pitch@0.25-1.5", None) is not None
    # a wrong index form is caught by the check and the draws are evaluated one by one
    cdef = get_criterion("peak_roll@0.05-0.5")
    monkeypatch.setattr(
        noise_mod, "_index_form", lambda use, op: (lambda x, tt: x[:, 0, 0], np.subtract)
    )
    got = noise_mod._per_draw(cdef, SimpleNamespace(use="peak_roll", operator=None), sims, meas, t)
    want = np.array([cdef.fn(sims[r][None], meas[r], t)[0] for r in range(len(sims))])
    np.testing.assert_allclose(got, want)


def _parachute_floor(channels: tuple[str, ...]):
    """The noise floor of a 20-s parachute twin whose record keeps only ``channels``."""
    import dataclasses

    from vectorid import models
    from vectorid.identify.twins import twin_drop
    from vectorid.models import WindProfile

    wind = WindProfile.from_speed_direction([0.0, 3000.0], [4.0, 8.0], [250.0, 280.0])
    ini = InitialState(altitude=1600.0, velocity=(2.0, 1.0, 7.0), euler=(0.05, 0.0, 0.2))
    stated = {"position_h": 1.5, "position_v": 2.5, "velocity": 0.15, "euler_deg": 0.3,
              "rates": 0.01}  # fmt: skip
    fl = twin_drop(models.get("parachute6dof"), {}, initial=ini, duration=22.0, noise=stated,
                   seed=4, wind=wind, origin_altitude=1000.0)  # fmt: skip
    fl = dataclasses.replace(fl, channels={k: v for k, v in fl.channels.items() if k in channels})
    drop = {"name": "gps", "window": [1.0, 21.0], "origin_altitude": 1000.0}
    table = {"dt": 0.05, "output_dt": 0.25, "init_span": 1.0, "drops": [drop]}
    ident = Identification.from_table(
        table, variables=["x6"], criteria=["pos_h_abs", "vel_h_abs"], flights={"gps": fl},
        default_model="parachute6dof",
    )  # fmt: skip
    keep = {k: v for k, v in stated.items() if k.split("_")[0] in channels}
    return lambda: noise_floor(ident, parse_noise(keep), draws=200, seed=1)


def test_a_drop_without_attitude_says_the_floor_leaves_its_start_out():
    """A GPS-only record: the fitted start assumes a level, non-rotating canopy, an error
    the floor does not contain — said as a note with the size it has; with the IMU, silent."""
    with pytest.warns(VectoridNote, match=r"drop 'gps' records no attitude \(euler\) and body "
                      r"rates \(rates\): its fitted start assumes a level attitude and no "
                      r"rotation.*moves the simulated (position|velocity) by up to"):  # fmt: skip
        _parachute_floor(("position", "velocity"))()
    with warnings.catch_warnings():
        warnings.simplefilter("error", VectoridNote)
        _parachute_floor(("position", "velocity", "euler", "rates"))()
