"""The descent model's drag-area conventions and the detectors that read a descent's altitude:
apogee, touchdown, trigger heights, changes of drag area, the monotone-rate bound. Synthetic
descents with seeded noise (known answers) and the real logs of the shared data (skipped when
absent)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from vectorid.descent import (
    INCH,
    RocketDescent,
    RocketDescentCdS,
    crossing_time,
    detect_apogee,
    detect_rate_change,
    detect_touchdown,
    monotone_rate_bound,
)
from vectorid.identify import load_csv, load_telemega
from vectorid.models.atmosphere import ISA
from vectorid.models.base import InitialState
from vectorid.models.controls import ControlSchedule

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data"
TELEMEGA = DATA / "prometheus-2022" / "2022-06-24-serial-6583-flight-0003-TeleMega.csv"
RP = DATA / "rocketpy-descents"


# -- the model: conventions ---------------------------------------------------------------------


def test_conventions_give_the_drag_area_under_each_canopy():
    adds = RocketDescentCdS(mass=10.0, drag_convention="adds")
    repl = RocketDescentCdS(mass=10.0, drag_convention="replaces")
    X = np.array([[0.5, 4.0]])
    assert adds.drag_area(X, main=0.0)[0] == pytest.approx(0.5)
    assert repl.drag_area(X, main=0.0)[0] == pytest.approx(0.5)
    assert adds.drag_area(X, main=1.0)[0] == pytest.approx(4.5)
    assert repl.drag_area(X, main=1.0)[0] == pytest.approx(4.0)
    assert repl.drag_area(X, main=0.5)[0] == pytest.approx(0.25 + 2.0)  # inflating


def test_unknown_convention_is_refused():
    with pytest.raises(ValueError, match="'adds'.*'replaces'"):
        RocketDescentCdS(mass=10.0, drag_convention="sum")


@pytest.mark.parametrize("convention", ["adds", "replaces"])
def test_simulated_steady_rate_follows_the_drag_area_of_the_convention(convention):
    m = RocketDescentCdS(mass=12.0, drag_convention=convention)
    X = np.array([[0.4, 3.0]])
    ctrl = ControlSchedule(np.array([0.0]), np.array([[1.0]]), ("main",), "previous")
    res = m.simulate(X, t_final=60.0, dt=0.05, inputs=ctrl, output_dt=1.0)
    h = -res.position[0, :, 2]
    v = -(h[-1] - h[-2])
    area = 3.4 if convention == "adds" else 3.0
    rho = float(ISA().density(h[-1]))
    assert v == pytest.approx(np.sqrt(2 * 12.0 * 9.80665 / (rho * area)), rel=5e-3)


def test_drag_area_model_is_the_coefficient_model_on_unit_areas():
    cd = RocketDescent(mass=16.0, drogue_diameter=24 * INCH, main_diameter=72 * INCH)
    cds = RocketDescentCdS(mass=16.0)
    Xcd = np.array([[1.6, 2.2]])
    Xcds = Xcd * np.array([[cd.drogue_area, cd.main_area]])
    ctrl = ControlSchedule(np.array([0.0, 10.0]), np.array([[0.0], [1.0]]), ("main",), "linear")
    a = cd.simulate(Xcd, t_final=20.0, dt=0.05, inputs=ctrl, output_dt=0.5)
    b = cds.simulate(Xcds, t_final=20.0, dt=0.05, inputs=ctrl, output_dt=0.5)
    np.testing.assert_allclose(a.position, b.position, rtol=1e-12, atol=1e-9)


# -- synthetic descents -------------------------------------------------------------------------


def _descent(
    rng,
    *,
    rate=6.0,
    h0=300.0,
    after=10.0,
    noise=0.5,
    dt=0.05,
    drift=0.0,
    irregular=False,
    ground=-2.0,
):
    """An altitude log: a climb to apogee, a fall that settles to ``rate``, then ``after``
    seconds on the ground (with ``drift`` m/s); white noise of ``noise`` m. Returns t, h and
    the true touchdown time."""
    t_apo = 5.0
    t_land = t_apo + 3.0 + (h0 - ground) / rate  # roughly; exact below
    t = np.arange(0.0, t_land + 40.0, dt)
    if irregular:
        t = np.sort(t + rng.uniform(-0.4 * dt, 0.4 * dt, t.size))
    h = np.empty_like(t)
    up = t <= t_apo
    h[up] = h0 - 4.9 * (t[up] - t_apo) ** 2
    # after apogee: velocity relaxes to -rate with time constant 1.5 s
    s = t[~up] - t_apo
    tau = 1.5
    h[~up] = h0 - rate * (s - tau * (1 - np.exp(-s / tau)))
    k = np.flatnonzero(h <= ground)
    i = int(k[k > np.argmax(up is False)][0]) if k.size else t.size
    # exact crossing of the ground level
    td = np.interp(ground, [h[i], h[i - 1]], [t[i], t[i - 1]])
    on = t >= td
    h[on] = ground + drift * (t[on] - td)
    cut = t <= td + after
    t, h = t[cut], h[cut]
    return t, h + rng.normal(0.0, noise, t.size), float(td)


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize(
    "kw",
    [
        {"rate": 6.0, "noise": 0.5},
        {"rate": 20.0, "noise": 3.0, "after": 2.5},
        {"rate": 4.0, "noise": 0.3, "after": 2.0, "dt": 0.01},
        {"rate": 25.0, "noise": 1.0, "drift": 1.5, "after": 3.0},
        {"rate": 8.0, "noise": 1.0, "irregular": True, "dt": 0.1},
    ],
)
def test_touchdown_of_noisy_synthetic_descents(seed, kw):
    rng = np.random.default_rng(100 + seed)
    t, h, truth = _descent(rng, **kw)
    td = detect_touchdown(t, h)
    assert td is not None
    # within a few samples and a fraction of the noise-over-rate time
    tol = 0.15 + 2 * kw.get("dt", 0.05) + 2 * kw["noise"] / kw["rate"]
    assert abs(td.time - truth) < tol, (td, truth)
    assert td.rate == pytest.approx(-kw["rate"], rel=0.15)
    assert abs(td.ground - (-2.0)) < 1.0 + 2 * kw["noise"] + kw.get("drift", 0.0) * 3
    assert td.after == pytest.approx(t[-1] - td.time)


@pytest.mark.parametrize("seed", range(4))
def test_a_log_that_ends_in_the_air_has_no_touchdown(seed):
    rng = np.random.default_rng(seed)
    t, h, truth = _descent(rng, rate=20.0, noise=2.0)
    air = t < truth - 3.0
    assert detect_touchdown(t[air], h[air]) is None


def test_touchdown_before_the_ground_is_never_earlier_than_the_descent():
    # a pause in the air (a slow phase at 2 m/s) is not a touchdown: the speed does not stay
    # settled to the end of the data
    t = np.arange(0.0, 120.0, 0.05)
    h = np.interp(t, [0, 5, 40, 60, 100, 120], [0, 1000, 300, 260, 0, 0])
    td = detect_touchdown(t, h, after=5.0)
    assert td is not None and td.time == pytest.approx(100.0, abs=0.3)


def test_apogee_ignores_a_short_spike():
    t = np.arange(0.0, 60.0, 0.01)
    h = 2000.0 - 5.0 * (t - 20.0) ** 2
    h[(t > 25.0) & (t < 25.2)] = 2500.0  # an ejection-charge pressure spike
    ta, ha = detect_apogee(t, h)
    assert ta == pytest.approx(20.0, abs=0.05) and ha == pytest.approx(2000.0, abs=1.0)


def test_crossing_time_of_a_trigger_height():
    t = np.arange(0.0, 100.0, 0.1)
    h = np.where(t < 10, 50.0 * t, 500.0 - 10.0 * (t - 10.0))
    assert crossing_time(t, h, 300.0) == pytest.approx(30.0, abs=0.05)
    assert crossing_time(t, h, -500.0) is None  # never reached


def test_rate_change_finds_a_main_opening_and_its_drag_area_ratio():
    rng = np.random.default_rng(3)
    m = RocketDescentCdS(mass=15.0, drag_convention="replaces")
    ctrl = ControlSchedule(np.array([0.0, 60.0, 61.0]), np.array([[0.0], [0.0], [1.0]]),
                           ("main",), "linear")  # fmt: skip
    from vectorid.models.base import InitialState

    res = m.simulate(np.array([[0.5, 5.0]]), t_final=100.0, dt=0.05, inputs=ctrl,
                     output_dt=0.05, initial=InitialState(altitude=2500.0))  # fmt: skip
    t = res.t
    h = -res.position[0, :, 2] + rng.normal(0, 1.0, t.size)
    rc = detect_rate_change(t, h, 5.0, 95.0)
    assert rc is not None
    assert rc.time == pytest.approx(61.0, abs=1.5)
    assert rc.drag_area_ratio == pytest.approx(10.0, rel=0.2)
    # a steady descent has none
    assert detect_rate_change(t, h, 5.0, 55.0) is None


def _steady_descent(t, cds=0.5, mass=12.0, h0=3000.0):
    m = RocketDescentCdS(mass=mass, initial_speed="steady")
    res = m.simulate(
        np.array([[cds, 0.0]]), t_final=float(t[-1]), dt=0.05, output_dt=0.05,
        initial=InitialState(altitude=h0, velocity=(0.0, 0.0, 99.0)),
    )  # fmt: skip
    return np.interp(t, res.t, -res.position[0, :, 2])


def test_steady_start_ignores_the_initial_vertical_speed():
    t = np.arange(0.0, 20.0, 0.05)
    h = _steady_descent(t)  # 99 m/s in the initial state: ignored
    rho = float(ISA().density(3000.0))
    v0 = np.sqrt(2 * 12.0 * 9.80665 / (rho * 0.5))
    assert (h[0] - h[1]) / 0.05 == pytest.approx(v0, rel=5e-3)
    with pytest.raises(ValueError, match="'data'.*'steady'"):
        RocketDescentCdS(initial_speed="fast")


@pytest.mark.parametrize("sigma", [0.3, 2.0])
def test_monotone_rate_bound_of_a_constant_drag_descent_is_its_noise(sigma):
    rng = np.random.default_rng(int(10 * sigma))
    t = np.arange(0.0, 120.0, 0.1)
    grid = np.arange(0.0, 119.0, 0.5)
    h = _steady_descent(t) + rng.normal(0, sigma, t.size)
    b = monotone_rate_bound(t, h, grid)
    # the truth is one of the curves: the bound is below the noise on the grid, and the
    # best curve follows only a little of it (one rate per 0.5 s)
    noise = np.sqrt(np.mean((np.interp(grid, t, h) - np.interp(grid, t, _steady_descent(t))) ** 2))
    assert 0.7 * noise < b.rms <= noise + 1e-9
    assert b.rate_first > b.rate_last > 0


def test_monotone_rate_bound_sees_vertical_air_motion():
    # a 1.5 m/s updraft for 20 s in the middle of a steady descent: the descent rate dips
    # and comes back, which no constant drag area in still air does
    t = np.arange(0.0, 120.0, 0.1)
    w = np.where((t > 50) & (t < 70), 1.5, 0.0)
    h = _steady_descent(t) + np.cumsum(w) * 0.1
    b = monotone_rate_bound(t, h, np.arange(0.0, 119.0, 0.5))
    assert b.rms > 2.0
    with pytest.raises(ValueError, match="at least 3"):
        monotone_rate_bound(t, h, [1.0, 2.0])


def test_detectors_refuse_bad_series():
    with pytest.raises(ValueError, match="strictly increasing"):
        detect_touchdown([0, 1, 1, 2, 3, 4], [5, 4, 3, 2, 1, 0])
    with pytest.raises(ValueError, match="finite"):
        detect_apogee([0, 1, 2, 3, 4, 5], [0, 1, np.nan, 1, 0, 0])
    with pytest.raises(ValueError, match="at least 5"):
        detect_apogee([0, 1], [0, 1])


# -- the real logs ------------------------------------------------------------------------------

#: flight -> (file, mapping, landing time the flight's README quotes from phases.py, or None
#: when the log ends in the air)
REAL = {
    "EPFL_Bella_Lui": (
        "EPFL_Bella_Lui/bella_lui_flight_data_filtered.csv",
        {"time": "time aprox (s)", "time_unit": "s", "altitude": {"column": "z (m)", "unit": "m"}},
        35.25,
    ),
    "NDRT_2020": (
        "NDRT_2020/ndrt_2020_flight_data.csv",
        {
            "time": "Time (s)",
            "time_unit": "s",
            "altitude": {"column": "Altitude (Ft-AGL)", "unit": "ft"},
        },
        85.84,
    ),
    "camoes": (
        "camoes/flight_data.csv",
        {
            "time": "ts",
            "time_unit": "s",
            "altitude": {"column": "filtered_altitude_AGL", "unit": "m"},
        },
        139.93,
    ),
    "genesis": (
        "genesis/flight_data_faraday.csv",
        {
            "time": "ts",
            "time_unit": "s",
            "altitude": {"column": "filtered_altitude_AGL", "unit": "m"},
        },
        176.09,
    ),
    "lince": (
        "lince/main_data.csv",
        {
            "time": "ts",
            "time_unit": "s",
            "altitude": {"column": "filtered_altitude_AGL", "unit": "m"},
        },
        431.67,
    ),
    "valkyrie": (
        "valkyrie/flightInfo_merged.csv",
        {"time": "time", "time_unit": "s", "altitude": {"column": "altitude", "unit": "m"}},
        123.39,
    ),
    "hedy": (
        "hedy/cats_tust/filteredDataInfo.csv",
        {
            "time": "ts",
            "time_unit": "s",
            "altitude": {"column": "filteredAltitudeAGL", "unit": "m"},
        },
        None,
    ),
    "andromeda": (
        "andromeda/flight_data.csv",
        {
            "time": "t(s)",
            "time_unit": "s",
            "altitude": {"column": "alt(m)", "unit": "m"},
            "last_line": 1138,
        },
        None,
    ),
    "juno3": (
        "juno3/cots_GNSS.csv",
        {
            "time": "time",
            "time_unit": "s",
            "altitude": {"column": "ALT", "unit": "ft"},
            "first_line": 46,
            "max_gap": 4.0,
        },
        None,
    ),
}


@pytest.mark.parametrize("flight", sorted(REAL))
def test_touchdown_of_the_real_logs(flight):
    rel, mapping, landing = REAL[flight]
    path = RP / rel
    if not path.exists():
        pytest.skip(f"shared flight data not found at {path}")
    a = load_csv(path, mapping)["altitude"]
    td = detect_touchdown(a.t, a.values[:, 0])
    if landing is None:
        assert td is None
        return
    # phases.py (the data README) marks the landing where a 1 s running median moves by less
    # than 1.5 m/s, which trails the kink by up to a second; ours is the kink itself
    assert td is not None
    assert landing - 1.0 < td.time < landing + 0.7, td


@pytest.mark.skipif(not TELEMEGA.exists(), reason=f"shared flight data not found at {TELEMEGA}")
def test_telemega_touchdown_comes_long_before_the_landed_state():
    fd = load_telemega(TELEMEGA)
    a = fd["altitude"]
    td = detect_touchdown(a.t, a.values[:, 0], after=fd.events["apogee"])
    assert td is not None
    assert 222.5 < td.time < 224.5
    assert fd.events["landed"] - td.time > 12.0  # the issue: about 14 s on the ground
    assert -td.rate == pytest.approx(6.4, abs=0.5)
