"""Wind profile conventions, Dryden turbulence statistics and reproducibility."""

import numpy as np
import pytest

from vectorid.models.integrate import Environment, env_at
from vectorid.models.wind import (
    DrydenTurbulence,
    Wind,
    WindProfile,
    _dryden_filter,
    calm,
    dryden_scales,
)


def test_profile_interpolates_linearly_and_holds_ends():
    w = WindProfile([100.0, 300.0], [2.0, 6.0], [-1.0, 1.0])
    np.testing.assert_allclose(w(200.0), [4.0, 0.0])
    np.testing.assert_allclose(w(np.array([0.0, 1e4])), [[2.0, -1.0], [6.0, 1.0]])


def test_meteorological_direction_is_where_the_wind_comes_from():
    # a westerly (from 270°) blows towards the east
    w = WindProfile.from_speed_direction([0.0], [10.0], [270.0])
    np.testing.assert_allclose(w(0.0), [0.0, 10.0], atol=1e-12)
    # a northerly (from 0°) blows towards the south
    w = WindProfile.from_speed_direction([0.0], [5.0], [0.0])
    np.testing.assert_allclose(w(0.0), [-5.0, 0.0], atol=1e-12)
    s, d = WindProfile.from_speed_direction([0.0, 1.0], [3.0, 4.0], [45.0, 200.0]).speed_direction(
        np.array([0.0, 1.0])
    )
    np.testing.assert_allclose(s, [3.0, 4.0])
    np.testing.assert_allclose(d, [45.0, 200.0])


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"altitude": [0.0, 0.0], "north": [1, 2], "east": [1, 2]}, "strictly increasing"),
        ({"altitude": [0.0, 1.0], "north": [1], "east": [1, 2]}, "same length"),
        ({"altitude": [0.0], "north": [np.nan], "east": [1]}, "NaN"),
    ],
)
def test_profile_validation(kwargs, match):
    with pytest.raises(ValueError, match=match):
        WindProfile(**kwargs)


def test_dryden_low_altitude_forms():
    w20 = 10.0
    sigma, length = dryden_scales(np.array([100.0 * 0.3048, 2500.0 * 0.3048]), w20)
    c = 0.177 + 0.000823 * 100.0
    assert sigma[0, 2] == pytest.approx(1.0)  # σ_w = 0.1 W20
    assert sigma[0, 0] == pytest.approx(1.0 / c**0.4)
    assert length[0, 2] == pytest.approx(100.0 * 0.3048)  # L_w = h
    assert length[0, 0] == pytest.approx(100.0 / c**1.2 * 0.3048)
    # above 2000 ft: isotropic, L = 1750 ft
    np.testing.assert_allclose(length[1], 1750.0 * 0.3048)
    np.testing.assert_allclose(sigma[1], sigma[1, 2])


def test_dryden_filter_has_the_specified_variance():
    n = 200_000
    sigma, length = dryden_scales(np.full(n, 60.0), 8.0)  # L ~ 60-190 m, τ ~ 7-21 s
    out = _dryden_filter(np.random.default_rng(0).standard_normal((n, 3)), sigma, length, 9.0, 0.05)
    # 10 000 s of record is ~500-1400 correlation times: a few percent of sampling error
    np.testing.assert_allclose(out.std(axis=0), sigma[0], rtol=0.08)
    # the u-gust is an Ornstein-Uhlenbeck process: autocorrelation exp(-V dt / L)
    lag = 20
    rho = np.corrcoef(out[:-lag, 0], out[lag:, 0])[0, 1]
    assert rho == pytest.approx(np.exp(-9.0 * lag * 0.05 / length[0, 0]), abs=0.03)


def test_turbulence_is_reproducible_from_its_seed():
    prof = WindProfile.constant(0.0, 5.0)
    a = DrydenTurbulence(7.0, seed=42).series(30.0, 500.0, prof)
    b = DrydenTurbulence(7.0, seed=42).series(30.0, 500.0, prof)
    c = DrydenTurbulence(7.0, seed=43).series(30.0, 500.0, prof)
    np.testing.assert_array_equal(a[1], b[1])
    assert not np.allclose(a[1], c[1])
    assert a[0][0] == 0.0 and a[0][-1] >= 30.0


def test_turbulence_u_axis_follows_the_mean_wind():
    # wind towards east: the large along-wind (u) gust lands in the east component
    n_e = DrydenTurbulence(10.0, seed=1, v_ref=1.0).series(
        400.0, 1000.0, WindProfile.constant(0, 5)
    )
    n_n = DrydenTurbulence(10.0, seed=1, v_ref=1.0).series(
        400.0, 1000.0, WindProfile.constant(5, 0)
    )
    np.testing.assert_allclose(n_e[1][:, 1], n_n[1][:, 0], atol=1e-12)
    np.testing.assert_allclose(n_e[1][:, 0], -n_n[1][:, 1], atol=1e-12)


def test_environment_tables_are_read_back_by_env_at():
    wind = Wind(WindProfile([0.0, 1000.0], [0.0, 10.0], [4.0, 4.0]))
    env = Environment.build(wind=wind, h_min=-100.0, h_max=2000.0, dh=1.0)
    rho, g, wn, we, wd = env_at(env.atm, env.gust, 0.0, 500.5)
    assert wn == pytest.approx(5.005)
    assert we == pytest.approx(4.0)
    assert wd == 0.0
    from vectorid.models.atmosphere import density, gravity

    assert rho == pytest.approx(density(500.5), rel=1e-8)
    assert g == pytest.approx(gravity(500.5), rel=1e-12)
    # outside the table: held constant
    assert env_at(env.atm, env.gust, 0.0, 5e3)[2] == pytest.approx(10.0)
    calm_env = Environment.build(wind=calm())
    assert env_at(calm_env.atm, calm_env.gust, 3.0, 100.0)[2:] == (0.0, 0.0, 0.0)


def test_environment_adds_gusts_in_time():
    turb = DrydenTurbulence(7.0, seed=5, dt=0.1)
    wind = Wind(WindProfile.constant(1.0, 2.0), turb)
    env = Environment.build(wind=wind, t_final=20.0, h0=800.0)
    t, g = turb.series(20.0, 800.0, wind.profile)
    _, _, wn, we, wd = env_at(env.atm, env.gust, 0.35, 300.0)
    gi = np.array([np.interp(0.35, t, g[:, k]) for k in range(3)])
    np.testing.assert_allclose([wn, we, wd], [1.0 + gi[0], 2.0 + gi[1], gi[2]], rtol=1e-12)
