"""Choosing the integration step for a stated accuracy (vectorid.models.choose_step)."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from vectorid import models
from vectorid.models.parachute6dof import Z_PAYLOAD

T_FINAL = 60.0


def _controlled():
    lengths = np.ones((3, 4))
    lengths[1, 0] = 0.0  # riser 1 pulled from 10 to 30 s
    inputs = models.riser_commands([0.0, 10.0, 30.0], lengths)
    wind = models.WindProfile([0.0, 3000.0], [3.0, 8.0], [0.0, 2.0])
    return {"inputs": inputs, "wind": wind}


@pytest.fixture(scope="module")
def parachute():
    return models.get("parachute6dof")


def test_the_reference_agrees_with_a_tight_tolerance_solver(parachute):
    """The reference (RK4 at a quarter of the smallest candidate) against solve_ivp at
    rtol 1e-10 on the model's plain-numpy right-hand side: a controlled, windy flight."""
    env = _controlled()
    x = parachute.nominal
    ref = parachute.simulate(x, t_final=T_FINAL, dt=0.0025, output_dt=1.0, **env)
    f, x0 = parachute.reference_rhs(x[None, :], t_final=T_FINAL, **env)
    grid = np.arange(0.0, T_FINAL + 0.5, 1.0)
    sol = solve_ivp(f, (0.0, T_FINAL), x0, method="DOP853", rtol=1e-10, atol=1e-10, t_eval=grid)
    assert sol.success
    # the states are the NED position of the canopy's origin O (m) and the 3-2-1 Euler angles
    # (rad); the output position is the payload's, Z_PAYLOAD below O on the body z axis
    phi, theta, psi = sol.y[3:6]
    body_z = np.stack(
        [
            np.cos(phi) * np.sin(theta) * np.cos(psi) + np.sin(phi) * np.sin(psi),
            np.cos(phi) * np.sin(theta) * np.sin(psi) - np.sin(phi) * np.cos(psi),
            np.cos(phi) * np.cos(theta),
        ]
    )
    payload = (sol.y[:3] + Z_PAYLOAD * body_z).T
    assert np.linalg.norm(payload[-1] - payload[0]) > 100.0  # it flew
    d = np.linalg.norm(ref.position[0] - payload, axis=-1)
    assert d.max() < 0.01  # far below any tolerance a study would state (0.1 m)


def test_errors_shrink_with_the_step_and_the_choice_meets_the_tolerance(parachute):
    rng = np.random.default_rng(3)
    lo, hi = parachute.bounds.T
    X = np.vstack([parachute.nominal, lo + (hi - lo) * rng.random((6, lo.size))])
    choice = models.choose_step(parachute, X, t_final=T_FINAL, tolerance=0.05, **_controlled())
    steps = list(choice.errors)
    errs = np.array([choice.errors[s] for s in steps])
    assert steps == sorted(steps, reverse=True)
    assert np.all(np.diff(errs) <= 1e-12 + 0.05 * errs[:-1])  # smaller step, smaller error
    assert choice.dt is not None and choice.errors[choice.dt] <= 0.05
    larger = [s for s in steps if s > choice.dt]
    assert all(choice.errors[s] > 0.05 for s in larger)
    assert choice.trials == 7 and choice.failed_in_reference == 0
    assert "chosen: dt = " in choice.summary()


def test_calm_flight_error_falls_as_the_fourth_power_of_the_step(parachute):
    """Smooth dynamics: RK4's global error ~ dt**4, so halving the step divides it by ~16."""
    choice = models.choose_step(
        parachute, parachute.nominal, t_final=T_FINAL, candidates=(0.5, 0.25), reference_dt=0.01
    )
    ratio = choice.errors[0.5] / choice.errors[0.25]
    assert 10.0 < ratio < 25.0


def test_bad_arguments_are_named(parachute):
    with pytest.raises(ValueError, match="tolerance"):
        models.choose_step(parachute, parachute.nominal, t_final=10.0, tolerance=0.0)
    with pytest.raises(ValueError, match="divides output_dt"):
        models.choose_step(parachute, parachute.nominal, t_final=10.0, candidates=(0.3,))
    with pytest.raises(ValueError, match="multiple of output_dt"):
        models.choose_step(parachute, parachute.nominal, t_final=10.5)
