"""Rigid 6-DoF parafoil-payload model (vectorid.models.parafoil6dof)."""

from __future__ import annotations

import numba as nb
import numpy as np
import pytest

from vectorid import models
from vectorid.models import flap_deflections
from vectorid.models._parafoil_core import NWORK, parafoil_rhs, rhs_reference
from vectorid.models.atmosphere import UniformAtmosphere
from vectorid.models.parafoil_aero import GAIN_NAMES

LD_RANGE = (2.4, 3.5)  # published glide ratios of cargo parafoils, see docs/models_parafoil.md
AIRSPEED_RANGE = (10.0, 20.0)


@nb.njit(cache=True)
def rk4_states(k, x0, rho, g, dt, n_steps):
    """States of the rigid model integrated with RK4 in calm uniform air (test helper)."""
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
        parafoil_rhs(k, x, rho, g, 0.0, 0.0, 0.0, 0.0, 0.0, True, k1, work)
        for i in range(n):
            xt[i] = x[i] + 0.5 * dt * k1[i]
        parafoil_rhs(k, xt, rho, g, 0.0, 0.0, 0.0, 0.0, 0.0, True, k2, work)
        for i in range(n):
            xt[i] = x[i] + 0.5 * dt * k2[i]
        parafoil_rhs(k, xt, rho, g, 0.0, 0.0, 0.0, 0.0, 0.0, True, k3, work)
        for i in range(n):
            xt[i] = x[i] + dt * k3[i]
        parafoil_rhs(k, xt, rho, g, 0.0, 0.0, 0.0, 0.0, 0.0, True, k4, work)
        for i in range(n):
            x[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        out[s + 1] = x
    return out


@pytest.fixture(scope="module")
def model() -> models.Model:
    return models.get("parafoil6dof")


def test_registry_and_metadata(model):
    assert type(model).__name__ == "Parafoil6DoF"
    assert model.parameter_names == GAIN_NAMES
    assert model.parameter_names == models.get("parafoil8dof").parameter_names
    assert model.output_names == tuple(c.name for c in models.BASE_CHANNELS)
    assert model.input_names == ("flap_left", "flap_right")


def test_mass_matrix_is_the_locked_block_of_the_8dof_one(model):
    gains = np.stack([model.nominal, np.full(33, 0.2), np.full(33, 2.0)])
    a6 = model.mass_matrix(gains, 1.1)
    a8 = models.get("parafoil8dof").mass_matrix(gains, 1.1, 0.0, 0.0)
    assert np.allclose(a6, a8[:, :6, :6])


def test_kernel_matches_numpy_reference(model):
    rng = np.random.default_rng(11)
    k = model.constants(model.nominal[None])[0]
    work = np.zeros(NWORK)
    for _ in range(5):
        x = np.concatenate([[0.0, 0.0, -900.0], rng.normal(0, 0.3, 3), [13.0, 0.3, 4.2],
                            rng.normal(0, 0.2, 3)])  # fmt: skip
        wind = rng.normal(0.0, 3.0, 3)
        dx = np.zeros(12)
        assert parafoil_rhs(k, x, 1.05, 9.8, *wind, 0.4, 0.0, True, dx, work)
        ref = rhs_reference(0.0, x, k, 1.05, 9.8, wind, 0.4, 0.0, True)
        assert np.allclose(dx, ref, rtol=1e-10, atol=1e-10)


@pytest.mark.slow
def test_energy_conserved_without_aerodynamics():
    model = models.get("parafoil6dof", aerodynamics=False)
    k = model.constants(model.nominal[None])[0]
    rng = np.random.default_rng(2)
    x0 = np.concatenate([[0.0, 0.0, -1000.0], rng.normal(0, 0.1, 3), [13.0, 0.5, 4.0],
                         rng.normal(0, 0.1, 3)])  # fmt: skip
    e0 = model.mechanical_energy(model.nominal[None], x0[None], 1.1, 9.8)[0]
    errs = []
    for dt in (0.04, 0.02, 0.01):
        states = rk4_states(k, x0, 1.1, 9.8, dt, round(5.0 / dt))[:: round(0.2 / dt)]
        e = model.mechanical_energy(
            np.repeat(model.nominal[None], len(states), 0), states, 1.1, 9.8
        )
        errs.append(float(np.max(np.abs(e - e0))))
    kinetic = 0.5 * 945.0 * 13.6**2
    assert errs[1] < 1e-2 * kinetic, errs
    ratios = np.array(errs[:-1]) / np.array(errs[1:])
    assert np.all(ratios > 10.0), ratios  # energy error falls at least as fast as dt^4
    # global error of the state: RK4 is fourth order, about 16x smaller per halving of dt
    fine = rk4_states(k, x0, 1.1, 9.8, 0.00125, 1600)[-1]  # 2 s: before the
    # unpowered canopy topples over (with aerodynamics off the tumble is chaotic)
    state_errs = [
        np.abs(rk4_states(k, x0, 1.1, 9.8, dt, round(2.0 / dt))[-1] - fine).max()
        for dt in (0.04, 0.02, 0.01)
    ]
    ratios = np.array(state_errs[:-1]) / np.array(state_errs[1:])
    assert np.all((ratios > 12.0) & (ratios < 20.0)), ratios


def test_nominal_glide_and_turn_direction(model):
    res = model.simulate(model.nominal[None], t_final=60.0, dt=0.02, output_dt=1.0,
                         atmosphere=UniformAtmosphere(1.225))  # fmt: skip
    assert res.status[0] == 0
    v = res.velocity[0, -1]
    assert LD_RANGE[0] <= np.hypot(v[0], v[1]) / v[2] <= LD_RANGE[1]
    assert AIRSPEED_RANGE[0] <= res.airspeed[0, -1] <= AIRSPEED_RANGE[1]
    assert np.ptp(res.velocity[0], axis=0).max() < 0.05
    sched = flap_deflections([0.0, 5.0, 7.0, 40.0], [0.0, 0.0, 0.3, 0.3], [0.0] * 4)
    left = model.simulate(model.nominal[None], t_final=40.0, dt=0.02, inputs=sched)
    assert left.status[0] == 0
    assert left.euler[0, -1, 2] < -np.radians(30.0)


def test_pathological_trials_flagged(model):
    nom = model.nominal
    bad = nom.copy()
    bad[GAIN_NAMES.index("kA_star")] = -10.0
    res = model.simulate(np.stack([nom, bad, nom]), t_final=5.0, dt=0.02)
    assert res.status.tolist() == [0, 4, 0]
    assert np.array_equal(res.outputs[0], res.outputs[2])
    assert np.all(np.isnan(res.outputs[1]))
