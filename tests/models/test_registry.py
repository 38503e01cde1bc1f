"""Model registry: names, lazy import, helpful errors; the shared model contract."""

import numpy as np
import pytest

from vectorid import models
from vectorid.models.base import BASE_CHANNELS, Model


def test_available_lists_the_three_models():
    assert set(models.available()) >= {"parachute6dof", "parafoil8dof", "parafoil6dof"}


def test_unknown_name_lists_the_known_ones():
    with pytest.raises(KeyError, match="available models: .*parachute6dof"):
        models.get("parachute7dof")


def test_missing_module_is_a_clear_import_error(monkeypatch):
    monkeypatch.setitem(models._REGISTRY, "ghost", "vectorid.models.ghost_model:Ghost")
    with pytest.raises(ImportError, match="does not exist"):
        models.get("ghost")
    monkeypatch.setitem(models._REGISTRY, "ghost2", "vectorid.models.base:NoSuchClass")
    with pytest.raises(ImportError, match="has no class NoSuchClass"):
        models.get("ghost2")


def test_get_passes_options_and_returns_a_model():
    m = models.get("parachute6dof", aerodynamics=False)
    assert isinstance(m, Model)
    assert m.aerodynamics is False


@pytest.mark.parametrize("name", sorted(models._REGISTRY))
def test_every_registered_model_follows_the_contract(name):
    try:
        m = models.get(name)
    except ImportError as exc:
        pytest.skip(f"{name} not available yet: {exc}")
    p = len(m.parameters)
    assert m.nominal.shape == (p,)
    assert m.bounds.shape == (p, 2)
    assert np.all(m.bounds[:, 0] <= m.bounds[:, 1])
    outside = [q.name for q in m.parameters if not q.low <= q.nominal <= q.high]
    assert not outside, f"nominal values outside their own box: {outside}"
    assert m.outputs[: len(BASE_CHANNELS)] == BASE_CHANNELS
    assert len(set(m.parameter_names)) == p
    res = m.simulate(np.tile(m.nominal, (2, 1)), t_final=1.0, dt=0.02, output_dt=0.5)
    assert res.t.shape == (3,)
    for arr in (res.position, res.velocity, res.euler, res.rates):
        assert arr.shape == (2, 3, 3)
    assert res.airspeed.shape == res.alpha.shape == res.beta.shape == (2, 3)
    np.testing.assert_array_equal(res.status, [0, 0])
    np.testing.assert_array_equal(res.outputs[0], res.outputs[1])
    assert res.position[0, 0, 2] == pytest.approx(-1000.0)  # default start at 1000 m
