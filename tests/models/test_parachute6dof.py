"""Physics of the controllable circular parachute (seed 001): masses, energy, descent, controls.

Published reference used here: the G-12 cargo parachute's rated rate of descent, 28.5 ft/s
(8.69 m/s) at sea level (U.S. Army G-12D/E cargo parachute data, FM 4-20.116 / TM 10-1670
series). Our load (700 kg A-22 + 59 kg canopy) is the load at which the seed's identified drag
(Table 5) reproduces that rate, see docs/models.md; the band is ±10 %.
"""

import itertools

import numpy as np
import pytest
from scipy.stats import qmc

from vectorid import models
from vectorid.models import parachute6dof as pc
from vectorid.models import riser_commands
from vectorid.models.atmosphere import RHO0, UniformAtmosphere, density
from vectorid.models.base import InitialState
from vectorid.models.integrate import (
    LANE_WORK,
    LANES,
    STATUS_BAD_PARAMETER,
    STATUS_REJECTED,
    Environment,
)
from vectorid.models.wind import DrydenTurbulence, Wind, WindProfile

G12_RATED_DESCENT = 28.5 * 0.3048  # m/s at sea level


@pytest.fixture(scope="module")
def model():
    return models.get("parachute6dof")


def _box_samples(model, n_sobol=256):
    lo, hi = model.bounds.T
    corners = np.array(list(itertools.product(*zip(lo, hi))))
    sobol = qmc.scale(qmc.Sobol(len(lo), seed=7).random(n_sobol), lo, hi)
    return np.vstack([corners, sobol])


def test_parameters_follow_the_seed_tables(model):
    assert model.parameter_names == tuple(f"x{i}" for i in range(1, 16))
    # Table 3, widened only where Table 5's final vector lies outside it (x11, x13)
    widened = [10, 12]
    same = [i for i in range(15) if i not in widened]
    np.testing.assert_array_equal(model.bounds[same], pc.TABLE3[same])
    np.testing.assert_array_equal(model.bounds[10], [0.04, 0.13])
    np.testing.assert_array_equal(model.bounds[12], [0.0, 0.94])
    np.testing.assert_array_equal(model.domains["table3"], pc.TABLE3)  # as printed
    np.testing.assert_array_equal(model.bounds[5], [0.3, 1.0])  # Table 3 changed x6 only
    np.testing.assert_array_equal(model.domains["table2"][5], [0.0, 0.6])
    np.testing.assert_array_equal(model.bounds[14], [0.5, 2.0])
    np.testing.assert_array_equal(
        model.presets["table5"][:14],
        [1.03, 0.98, 1.31, 0.22, 0.00, 0.45, 1.00, 1.45, 0.21, 0.05, 0.04, 0.25, 0.94, 3.12],
    )
    np.testing.assert_array_equal(model.nominal, model.presets["table5"])


def test_compiled_rhs_equals_the_plain_numpy_equations(model):
    """The vectorised right-hand side, column by column, against the plain numpy equations."""
    wind = Wind(WindProfile([0, 2000], [3, -4], [1, 6]), DrydenTurbulence(7.0, seed=3))
    ctrl = riser_commands([0, 1], [[0.3, 1, 0.5, 1], [0, 0, 1, 1]], interpolation="linear")
    rng = np.random.default_rng(1)
    X = _box_samples(model, LANES)[-LANES:]
    P = model.constants(X)
    env = Environment.build(wind=wind, h_min=-4000, h_max=3000, t_final=10, h0=1000)
    for t in rng.uniform(0, 1, 3):
        S = np.empty((16, LANES))
        refs = []
        for i in range(LANES):
            f, x0 = model.reference_rhs(X[i], t_final=10, inputs=ctrl, wind=wind)
            s = x0 + rng.normal(scale=[0, 0, 5, 0.2, 0.2, 1, 1, 1, 1, 0.1, 0.1, 0.1, 0, 0, 0, 0])
            s[12:] = rng.uniform(0, 1, 4)
            if i == 0:
                s[12:] = 1.0  # one column at rest: the group still takes the controlled path
            S[:, i] = s
            refs.append(f)
        DX = np.empty((16, LANES))
        work = np.empty((LANE_WORK, LANES))
        pc._rhs(t, S, np.ascontiguousarray(P.T), ctrl(np.array(t)), env.atm, env.gust, DX, work)
        for i in range(LANES):
            np.testing.assert_allclose(DX[:, i], refs[i](t, S[:, i]), rtol=1e-12, atol=1e-12)


def test_compiled_rhs_at_rest_equals_the_plain_numpy_equations(model):
    """Risers lengthened and commanded so: the group skips the control factors."""
    X = _box_samples(model, LANES)[-LANES:]
    P = model.constants(X)
    env = Environment.build()
    rng = np.random.default_rng(2)
    S = np.empty((16, LANES))
    refs = []
    for i in range(LANES):
        f, x0 = model.reference_rhs(X[i], t_final=10)
        S[:, i] = x0 + rng.normal(scale=[0, 0, 5, 0.2, 0.2, 1, 1, 1, 1, 0.1, 0.1, 0.1, 0, 0, 0, 0])
        refs.append(f)
    DX = np.empty((16, LANES))
    pc._rhs(
        0.5,
        S,
        np.ascontiguousarray(P.T),
        np.ones(4),
        env.atm,
        env.gust,
        DX,
        np.empty((LANE_WORK, LANES)),
    )
    for i in range(LANES):
        np.testing.assert_allclose(DX[:, i], refs[i](0.5, S[:, i]), rtol=1e-12, atol=1e-12)


def test_mass_matrices_symmetric_and_total_positive_definite_over_the_box(model):
    X = _box_samples(model)
    for rho in (density(3000.0), RHO0):
        A = model.apparent_mass(X, rho)
        M = model.mass_matrix(X, rho)
        np.testing.assert_array_equal(A, np.swapaxes(A, 1, 2))
        np.testing.assert_array_equal(M, np.swapaxes(M, 1, 2))
        assert np.linalg.eigvalsh(M).min() > 0
        # eq. (6) structure: five distinct elements, α22 = α11, α55 = α44, α24 = -α15
        np.testing.assert_array_equal(A[:, 1, 1], A[:, 0, 0])
        np.testing.assert_array_equal(A[:, 4, 4], A[:, 3, 3])
        np.testing.assert_array_equal(A[:, 1, 3], -A[:, 0, 4])
    assert np.all(model._check_parameters(X) == 0)


def test_apparent_mass_definiteness_is_the_2x2_block_condition(model):
    """A alone is PD exactly where α11 α44 > α15² (and α33, α66 > 0) — not on the whole box.

    Table 2 allows x1 = 0 with x2 >= 0.8, where A is indefinite; the physical requirement is on
    the total mass matrix (previous test). At the seed's final values A is PSD (x5 = 0).
    """
    X = _box_samples(model)
    A = model.apparent_mass(X, RHO0)
    ev = np.linalg.eigvalsh(A)
    block = A[:, 0, 0] * A[:, 3, 3] - A[:, 0, 4] ** 2
    pd_expected = (block > 0) & (A[:, 2, 2] > 0) & (A[:, 5, 5] > 0) & (A[:, 0, 0] > 0)
    np.testing.assert_array_equal(ev.min(axis=1) > 0, pd_expected)
    assert (~pd_expected).any() and pd_expected.any()
    x = model.nominal.copy()
    assert np.linalg.eigvalsh(model.apparent_mass(x, RHO0)[0]).min() >= -1e-9
    x[4] = 0.005
    assert np.linalg.eigvalsh(model.apparent_mass(x, RHO0)[0]).min() > 0


def _swinging_flight(model, dt, t_final=20.0, out=1.0):
    atmo = UniformAtmosphere(rho=1.1, g=9.81)
    init = InitialState(velocity=(2.0, -1.0, 6.0), euler=(0.3, -0.2, 0.5), rates=(0.2, 0.1, 0.3))
    X = model.presets["table5"].copy()
    X[4] = 0.005
    return (
        model.simulate(X, t_final=t_final, dt=dt, output_dt=out, initial=init, atmosphere=atmo),
        X,
        atmo,
    )


def test_energy_conserved_without_aerodynamics_and_rk4_order():
    model = models.get("parachute6dof", aerodynamics=False)
    drift = []
    for dt in (0.02, 0.01):
        res, X, atmo = _swinging_flight(model, dt)
        assert res.status[0] == 0
        E = model.mechanical_energy(X[None, :], res, atmo.rho, atmo.g)[0]
        kinetic = E - E[0] + atmo.g * 759.0 * (res.position[0, :, 2] - res.position[0, 0, 2])
        drift.append(np.max(np.abs(E - E[0])))
        # free fall with a tumbling swing: kinetic energy grows by ~10^6 J, E stays put
        assert drift[-1] < 1e-6 * np.max(np.abs(kinetic)), (drift[-1], np.max(kinetic))
    assert drift[0] / drift[1] > 12  # the drift is RK4 truncation error, not a missing term
    # convergence order: final-state error vs a fine reference shrinks ~16x per halving of dt
    ref, _, _ = _swinging_flight(model, 0.02 / 16, t_final=10.0, out=10.0)
    errs = []
    for dt in (0.04, 0.02, 0.01):
        r, _, _ = _swinging_flight(model, dt, t_final=10.0, out=10.0)
        errs.append(np.max(np.abs(r.outputs[0, -1, :12] - ref.outputs[0, -1, :12])))
    ratios = np.array(errs[:-1]) / np.array(errs[1:])
    assert np.all((ratios > 12) & (ratios < 20)), ratios


def test_steady_descent_rate_matches_the_g12_rating(model):
    res = model.simulate(model.nominal, t_final=60.0, dt=0.02, output_dt=1.0)
    assert res.status[0] == 0
    vd = res.velocity[0, -10:, 2]
    h = -res.position[0, -10:, 2]
    v_sea_level = vd * np.sqrt(density(h) / RHO0)  # equivalent rate at sea level
    assert np.all(np.abs(v_sea_level / G12_RATED_DESCENT - 1) < 0.10), v_sea_level
    # steady: no residual oscillation and a vertical descent
    np.testing.assert_allclose(res.velocity[0, -10:, :2], 0.0, atol=1e-9)
    assert np.ptp(v_sea_level) < 0.01


def test_symmetric_risers_give_no_turn(model):
    init = InitialState(euler=(0.15, -0.1, 0.0), rates=(0.05, -0.05, 0.0))
    wind = WindProfile.from_speed_direction([0.0, 2000.0], [4.0, 8.0], [300.0, 250.0])
    for lengths in ([1, 1, 1, 1], [0, 0, 0, 0], [0, 1, 0, 1]):
        ctrl = riser_commands([0.0, 5.0], [[1, 1, 1, 1], lengths])
        res = model.simulate(
            model.nominal,
            t_final=60.0,
            dt=0.02,
            output_dt=1.0,
            inputs=ctrl,
            initial=init,
            wind=wind,
        )
        assert res.status[0] == 0
        # no yaw moment: the yaw rate stays zero to round-off
        np.testing.assert_allclose(res.rates[0, :, 2], 0.0, atol=1e-12)


def test_riser_actuation_gives_drift_towards_it_and_the_seed_yaw(model):
    # riser 1 (towards +x = north at ψ = 0) at t = 20 s, then riser 2 (towards +y = east) at 50 s
    seq = riser_commands([0, 20, 50], [[1, 1, 1, 1], [0, 1, 1, 1], [0, 0, 1, 1]])
    mirror = riser_commands([0, 20, 50], [[1, 1, 1, 1], [1, 0, 1, 1], [0, 0, 1, 1]])
    res = model.simulate(model.nominal, t_final=80.0, dt=0.02, output_dt=0.5, inputs=seq)
    alt = model.simulate(model.nominal, t_final=80.0, dt=0.02, output_dt=0.5, inputs=mirror)
    t = res.t
    psi = np.rad2deg(res.euler[0, :, 2])
    # one riser: drift north, no yaw (its neighbours are equal: sign(0) in eq. 14)
    k40, k50 = np.searchsorted(t, [40.0, 50.0])
    assert res.velocity[0, k40, 0] > 0.3 and abs(res.velocity[0, k40, 1]) < 1e-9
    np.testing.assert_allclose(psi[: k50 + 1], 0.0, atol=1e-9)
    # second, adjacent riser: 15-20° of yaw accrued during its 4.5-s transition
    k_end = np.searchsorted(t, 50.0 + pc.T_TRANSITION + 1.0)
    assert 15.0 <= psi[k_end] <= 20.0, psi[k_end]
    assert abs(psi[-1] - psi[k_end]) < 0.2 * abs(psi[k_end])
    # then the system glides between risers 1 and 2 (north-east in the body frame)
    v_body = res.velocity[0, -1, :2]
    heading_of_drift = np.rad2deg(np.arctan2(v_body[1], v_body[0])) - psi[-1]
    assert 20.0 < heading_of_drift < 70.0
    # mirrored sequence: mirrored yaw
    np.testing.assert_allclose(np.rad2deg(alt.euler[0, -1, 2]), -psi[-1], rtol=0.02)


def test_mixed_batch_isolates_bad_trials(model):
    good = _box_samples(model, 8)[-3:]
    nan = model.nominal.copy()
    nan[3] = np.nan
    blow = model.nominal.copy()
    blow[13] = -400.0  # strongly negative yaw damping: exponential spin-up
    reject = model.nominal.copy()
    reject[1] = 1e4  # coupling so large that the mass matrix is not positive definite
    X = np.vstack([good[0], nan, good[1], blow, reject, good[2]])
    init = InitialState(rates=(0.0, 0.0, 0.01))
    batch = model.simulate(X, t_final=30.0, dt=0.02, output_dt=1.0, initial=init)
    assert batch.status[1] == STATUS_BAD_PARAMETER
    assert batch.status[3] in (1, 2) and np.isfinite(batch.t_fail[3])
    assert batch.status[4] == STATUS_REJECTED
    assert np.all(np.isnan(batch.outputs[[1, 4]]))
    assert "NaN" in batch.messages[1] and "t =" in batch.messages[3]
    for row, x in zip((0, 2, 5), good):
        alone = model.simulate(x, t_final=30.0, dt=0.02, output_dt=1.0, initial=init)
        assert alone.status[0] == 0
        np.testing.assert_array_equal(alone.outputs[0], batch.outputs[row])


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"params": np.zeros((2, 14))}, r"shape \(n, 15\)"),
        ({"dt": 0.0}, "dt must be > 0"),
        ({"dt": -0.1}, "dt must be > 0"),
        ({"output_dt": 0.03}, "whole multiple of dt"),
        ({"t_final": 1.005}, "whole number of steps"),
        ({"output_dt": 0.6}, "multiple of output_dt"),
        (
            {
                "inputs": riser_commands([0.0], [[1, 1, 1, 1]]).reorder(
                    ("riser1", "riser2", "riser3", "riser4", "flap"), (1, 1, 1, 1, 0)
                )
            },
            "not inputs of this model",
        ),
    ],
)
def test_simulate_validation_messages(model, kwargs, match):
    args = {"params": model.nominal, "t_final": 1.0, "dt": 0.02, **kwargs}
    params = args.pop("params")
    with pytest.raises(ValueError, match=match):
        model.simulate(params, **args)
