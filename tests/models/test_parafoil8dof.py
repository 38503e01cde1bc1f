"""8-DoF parafoil-payload model (vectorid.models.parafoil8dof): equations, physics and batch API."""

from __future__ import annotations

import numba as nb
import numpy as np
import pytest

from vectorid import models
from vectorid.models import InitialState, flap_deflections
from vectorid.models._parafoil_core import NWORK, parafoil_rhs, rhs_reference
from vectorid.models.atmosphere import UniformAtmosphere
from vectorid.models.parafoil_aero import GAIN_NAMES, ParafoilGeometry, build_properties

# Published ranges used by the glide tests (sources in docs/models_parafoil.md):
# glide ratio of ram-air cargo parafoils about 2.5-3.5 (the seed's Set-0 polar caps the canopy
# alone at L/D = 2.67), airspeed 10-20 m/s for wing loadings of 1.5-3 lb/ft^2.
LD_RANGE = (2.4, 3.5)
AIRSPEED_RANGE = (10.0, 20.0)


@nb.njit(cache=True)
def rk4_states(k, x0, rho, g, dt, n_steps, rigid):
    """States of one trial integrated with RK4 in calm uniform air (test helper)."""
    n = x0.shape[0]
    x = x0.copy()
    work = np.zeros(NWORK)
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    xt = np.empty(n)
    out = np.empty((n_steps + 1, n))
    out[0] = x
    for s in range(n_steps):
        parafoil_rhs(k, x, rho, g, 0.0, 0.0, 0.0, 0.0, 0.0, rigid, k1, work)
        for i in range(n):
            xt[i] = x[i] + 0.5 * dt * k1[i]
        parafoil_rhs(k, xt, rho, g, 0.0, 0.0, 0.0, 0.0, 0.0, rigid, k2, work)
        for i in range(n):
            xt[i] = x[i] + 0.5 * dt * k2[i]
        parafoil_rhs(k, xt, rho, g, 0.0, 0.0, 0.0, 0.0, 0.0, rigid, k3, work)
        for i in range(n):
            xt[i] = x[i] + dt * k3[i]
        parafoil_rhs(k, xt, rho, g, 0.0, 0.0, 0.0, 0.0, 0.0, rigid, k4, work)
        for i in range(n):
            x[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        out[s + 1] = x
    return out


def disturbed_state(rigid: bool, seed: int = 1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = np.zeros(12 if rigid else 16)
    x[2] = -1000.0
    x[3:6] = rng.normal(0.0, 0.1, 3)
    vo = 6 if rigid else 8
    if not rigid:
        x[6:8] = rng.normal(0.0, 0.1, 2)
        x[14:16] = rng.normal(0.0, 0.1, 2)
    x[vo : vo + 3] = (13.0, 0.5, 4.0)
    x[vo + 3 : vo + 6] = rng.normal(0.0, 0.1, 3)
    return x


def energy_errors(model: models.Model, rigid: bool) -> list[float]:
    """Largest energy change over 5 s of RK4 at dt = 0.04, 0.02, 0.01, 0.005 s."""
    k = model.constants(model.nominal[None])[0]
    x0 = disturbed_state(rigid)
    rho, g = 1.1, 9.8
    e0 = model.mechanical_energy(model.nominal[None], x0[None], rho, g)[0]
    errs = []
    for dt in (0.04, 0.02, 0.01, 0.005):
        n = round(5.0 / dt)
        states = rk4_states(k, x0, rho, g, dt, n, rigid)[:: round(0.2 / dt)]
        e = model.mechanical_energy(np.repeat(model.nominal[None], len(states), 0), states, rho, g)
        errs.append(float(np.max(np.abs(e - e0))))
    return errs


@pytest.fixture(scope="module")
def model() -> models.Model:
    return models.get("parafoil8dof")


def test_registry_and_metadata(model):
    assert type(model).__name__ == "Parafoil8DoF"
    assert model.parameter_names == GAIN_NAMES
    assert model.nominal.shape == (33,)
    assert model.bounds.shape == (33, 2)
    assert model.input_names == ("flap_left", "flap_right")
    assert model.output_names[:15] == tuple(c.name for c in models.BASE_CHANNELS)
    assert "payload_psi" in model.output_names and "rel_pitch" in model.output_names
    assert np.all((model.bounds[:, 0] <= model.nominal) & (model.nominal <= model.bounds[:, 1]))


def test_kernel_matches_numpy_reference(model):
    rng = np.random.default_rng(7)
    gains = model.bounds[:, 0] + rng.random((5, 33)) * np.diff(model.bounds, axis=1)[:, 0]
    k = model.constants(gains)
    work = np.zeros(NWORK)
    for i in range(5):
        x = disturbed_state(False, seed=i)
        x[6:8] = rng.normal(0.0, 0.5, 2)
        wind = rng.normal(0.0, 3.0, 3)
        dx = np.zeros(16)
        assert parafoil_rhs(k[i], x, 1.0, 9.79, *wind, 0.3, 0.1, False, dx, work)
        ref = rhs_reference(0.0, x, k[i], 1.0, 9.79, wind, 0.3, 0.1, False)
        assert np.allclose(dx, ref, rtol=1e-10, atol=1e-10)


@pytest.mark.slow
def test_energy_conserved_without_aerodynamics_and_damping():
    model = models.get("parafoil8dof", aerodynamics=False, joint_damping=(0.0, 0.0),
                       joint_stiffness=(3000.0, 2000.0))  # fmt: skip
    errs = energy_errors(model, rigid=False)
    kinetic = 0.5 * (model.geometry.payload_mass + model.geometry.canopy_mass) * 13.6**2
    assert errs[1] < 1e-2 * kinetic, errs  # dt = 0.02 s: under 1 % of the kinetic energy
    ratios = np.array(errs[:-1]) / np.array(errs[1:])
    assert np.all(ratios > 10.0), ratios  # energy error falls at least as fast as dt^4
    # global error of the state: RK4 is fourth order, about 16x smaller per halving of dt
    k = model.constants(model.nominal[None])[0]
    x0 = disturbed_state(False)
    fine = rk4_states(k, x0, 1.1, 9.8, 0.00125, 1600, False)[-1]  # 2 s: before the
    # unpowered canopy topples over (with aerodynamics off the tumble is chaotic)
    state_errs = [
        np.abs(rk4_states(k, x0, 1.1, 9.8, dt, round(2.0 / dt), False)[-1] - fine).max()
        for dt in (0.04, 0.02, 0.01)
    ]
    ratios = np.array(state_errs[:-1]) / np.array(state_errs[1:])
    assert np.all((ratios > 12.0) & (ratios < 20.0)), ratios


def test_nominal_steady_glide_in_published_range(model):
    res = model.simulate(model.nominal[None], t_final=60.0, dt=0.02, output_dt=1.0,
                         atmosphere=UniformAtmosphere(1.225))  # fmt: skip
    assert res.status[0] == 0
    v = res.velocity[0, -1]
    glide = np.hypot(v[0], v[1]) / v[2]
    assert LD_RANGE[0] <= glide <= LD_RANGE[1]
    assert AIRSPEED_RANGE[0] <= res.airspeed[0, -1] <= AIRSPEED_RANGE[1]
    # the trim is a steady state: nothing moves over the minute
    assert np.ptp(res.velocity[0], axis=0).max() < 0.05
    assert np.abs(res.rates[0]).max() < 1e-3
    assert np.abs(res.euler[0, :, [0, 2]]).max() < 1e-9  # no spurious roll/yaw
    # the payload hangs nearly plumb below the confluence point
    assert abs(res["payload_theta"][0, -1]) < np.radians(5.0)


def _turn(model, left, right, t_final=40.0):
    sched = flap_deflections([0.0, 5.0, 7.0, t_final], [0.0, 0.0, left, left],
                             [0.0, 0.0, right, right])  # fmt: skip
    return model.simulate(model.nominal[None], t_final=t_final, dt=0.02, output_dt=0.5,
                          inputs=sched)  # fmt: skip


def test_left_flap_turns_left_right_flap_right(model):
    left = _turn(model, 0.3, 0.0)
    right = _turn(model, 0.0, 0.3)
    assert left.status[0] == 0 and right.status[0] == 0
    dpsi_l = left.euler[0, -1, 2] - left.euler[0, 0, 2]
    dpsi_r = right.euler[0, -1, 2] - right.euler[0, 0, 2]
    assert dpsi_l < -np.radians(30.0)  # heading decreases: left turn (NED, psi clockwise)
    assert dpsi_r > np.radians(30.0)
    assert dpsi_l == pytest.approx(-dpsi_r, rel=1e-6)  # mirror symmetry
    assert left.position[0, -1, 1] < 0.0 < right.position[0, -1, 1]  # drifts west / east
    # the payload follows the canopy through the turn (joint twist stays small)
    assert np.abs(left["rel_yaw"][0]).max() < np.radians(10.0)


def test_stiff_joint_approaches_rigid_6dof():
    stiff = models.get("parafoil8dof", joint_stiffness=(1e6, 1e5), joint_damping=(4e4, 4e3))
    rigid = models.get("parafoil6dof")
    sched = flap_deflections([0.0, 10.0, 12.0, 60.0], [0.0, 0.0, 0.3, 0.3], [0.0, 0.0, 0.1, 0.1])
    kw = dict(t_final=60.0, dt=0.01, output_dt=1.0, inputs=sched)
    r8 = stiff.simulate(stiff.nominal[None], **kw)
    r6 = rigid.simulate(rigid.nominal[None], **kw)
    assert r8.status[0] == 0 and r6.status[0] == 0
    dist = np.linalg.norm(r6.position[0, -1] - r6.position[0, 0])
    assert np.linalg.norm(r8.position[0] - r6.position[0], axis=1).max() < 0.005 * dist
    stiff_dev = np.abs(r8.euler[0] - r6.euler[0]).max()
    assert stiff_dev < np.radians(0.5)
    assert np.abs(r8["rel_pitch"][0]).max() < np.radians(0.5)
    # the default (free-pitch) joint is measurably different: the extra degrees of freedom act
    free = models.get("parafoil8dof").simulate(stiff.nominal[None], **kw)
    assert np.abs(free.euler[0] - r6.euler[0]).max() > 5.0 * stiff_dev


def test_pathological_trials_flagged_good_ones_unaffected(model):
    nom = model.nominal
    bad_nan = nom.copy()
    bad_nan[3] = np.nan
    bad_mass = nom.copy()
    bad_mass[GAIN_NAMES.index("kC")] = -5.0  # negative apparent mass: A not positive definite
    tuck = nom.copy()
    tuck[GAIN_NAMES.index("Cm0")] = 2.0  # strongly nose-down canopy with little drag: tucks
    tuck[GAIN_NAMES.index("CD0")] = 0.2
    turn = nom.copy()
    turn[GAIN_NAMES.index("CnDanom")] = 1.5
    sched = flap_deflections([0.0, 2.0], [0.0, 0.2], [0.0, 0.0])
    batch = np.stack([nom, bad_nan, turn, bad_mass, tuck, nom])
    kw = dict(t_final=30.0, dt=0.02, output_dt=0.5, inputs=sched)
    res = model.simulate(batch, **kw)
    assert res.status.tolist()[:4] == [0, 3, 0, 4]
    assert res.status[4] in (1, 2)  # runaway (attitude limit) or NaN
    assert res.status[5] == 0
    assert np.isfinite(res.t_fail[4]) and res.t_fail[4] < 30.0
    assert np.all(np.isnan(res.outputs[1])) and np.all(np.isnan(res.outputs[3]))
    for i in (0, 2, 5):
        alone = model.simulate(batch[i : i + 1], **kw)
        assert np.array_equal(alone.outputs[0], res.outputs[i])


def test_initial_state_trim_and_position(model):
    x0, ok = model.initial_state(model.nominal[None], InitialState(altitude=800.0, north=5.0))
    assert ok[0]
    k = build_properties(model.nominal[None])[0]
    from vectorid.models.atmosphere import density, gravity

    dx = rhs_reference(0.0, x0[0], k, float(density(800.0 + x0[0, 2] + 800.0)),
                       float(gravity(800.0)), np.zeros(3), 0.0, 0.0)  # fmt: skip
    res = model.simulate(model.nominal[None], t_final=1.0, dt=0.02,
                         initial=InitialState(altitude=800.0, north=5.0))  # fmt: skip
    assert np.allclose(res.position[0, 0], (5.0, 0.0, -800.0))
    assert np.abs(dx[8:]).max() < 1e-2  # near-equilibrium (density at trim vs here)


def test_wind_drifts_with_the_air(model):
    from vectorid.models import WindProfile

    calm = model.simulate(model.nominal[None], t_final=20.0, dt=0.02, output_dt=1.0)
    windy = model.simulate(model.nominal[None], t_final=20.0, dt=0.02, output_dt=1.0,
                           wind=WindProfile.constant(north=0.0, east=5.0))  # fmt: skip
    assert windy.status[0] == 0
    drift = windy.position[0, -1] - calm.position[0, -1]
    assert drift[1] == pytest.approx(5.0 * 20.0, rel=0.02)
    assert np.allclose(windy.airspeed[0], calm.airspeed[0], rtol=2e-3)


def test_bad_options_raise():
    with pytest.raises(ValueError, match="ParafoilGeometry or a table"):
        models.get("parafoil8dof", geometry=90.0)
    with pytest.raises(ValueError, match="joint_stiffness"):
        models.get("parafoil8dof", joint_stiffness=(1.0, 2.0, 3.0))
    with pytest.raises(ValueError, match="payload_mass"):
        models.get("parafoil8dof", geometry=ParafoilGeometry(payload_mass=-1.0))


@pytest.mark.parametrize("name", ["parafoil8dof", "parafoil6dof"])
def test_reference_rhs_with_solve_ivp_reproduces_the_batch_kernel(name):
    from scipy.integrate import solve_ivp

    from vectorid.models import WindProfile

    model = models.get(name)
    sched = flap_deflections([0.0, 2.0, 3.0, 10.0], [0.0, 0.0, 0.4, 0.4], [0.0, 0.0, 0.1, 0.1])
    kw = dict(inputs=sched, wind=WindProfile([0.0, 2000.0], [2.0, 6.0], [-1.0, 3.0]))
    f, x0 = model.reference_rhs(model.nominal, t_final=10.0, **kw)
    res = model.simulate(model.nominal[None], t_final=10.0, dt=0.01, output_dt=1.0, **kw)
    sol = solve_ivp(f, (0.0, 10.0), x0, t_eval=res.t, rtol=1e-9, atol=1e-9)
    assert sol.status == 0
    vo = 6 if name == "parafoil6dof" else 8
    assert np.allclose(sol.y[3:6].T, res.euler[0], atol=1e-5)
    assert np.allclose(sol.y[vo + 3 : vo + 6].T, res.rates[0], atol=1e-5)
    assert abs(res.euler[0, -1, 2]) > np.radians(5.0)  # the flap input did turn it


def test_fixed_size_ldlt_solves_match_numpy_and_refuse_indefinite_matrices():
    from vectorid.models._parafoil_core import _solve6, _solve8

    rng = np.random.default_rng(3)
    for n, solve in ((8, _solve8), (6, _solve6)):
        for _ in range(20):
            q = rng.normal(size=(n, n))
            a = q @ q.T + 1e-3 * np.eye(n)
            b = rng.normal(size=n)
            x = b.copy()
            assert solve(a.copy(), x)
            np.testing.assert_allclose(a @ x, b, rtol=1e-8, atol=1e-8 * np.abs(b).max())
        indefinite = np.eye(n)
        indefinite[n - 1, n - 1] = -1.0
        assert not solve(indefinite, np.ones(n))
