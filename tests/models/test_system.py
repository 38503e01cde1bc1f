"""SystemModel: a user's batch ODE model (vectorid.models.system) and finding it by name."""

from __future__ import annotations

import sys
import textwrap

import numpy as np
import pytest

from vectorid import models
from vectorid.models import Channel, Parameter, SystemModel


class Decay(SystemModel):
    name = "decay"
    parameters = (Parameter("k", 1.0, 0.1, 5.0, "1/s", "decay rate"),)
    states = (Channel("y", "m", "level", default=1.0),)

    def rhs(self, t, x, p):
        return -p[:, :1] * x


class Blows(Decay):
    def rhs(self, t, x, p):
        return np.where(p[:, :1] > 3.0, x * 1e200, -p[:, :1] * x)


def test_rk4_matches_the_exact_solution_batchwise():
    res = Decay().simulate([[0.5], [2.0]], t_final=2.0, dt=0.01, output_dt=0.5, initial={"y": 3.0})
    exact = 3.0 * np.exp(-np.outer([0.5, 2.0], res.t))
    np.testing.assert_allclose(res["y"], exact, rtol=1e-8)
    assert res.outputs.shape == (2, 5, 1) and res.ok.all()
    # a trial's result does not depend on its batch
    one = Decay().simulate([[2.0]], t_final=2.0, dt=0.01, output_dt=0.5, initial={"y": 3.0})
    np.testing.assert_array_equal(one["y"][0], res["y"][1])


def test_a_failing_trial_is_marked_and_the_others_go_on():
    res = Blows().simulate([[1.0], [4.0], [np.nan]], t_final=1.0, dt=0.1)
    assert res.status.tolist() == [0, 1, 3]
    assert np.isnan(res.outputs[1:]).all() and np.isfinite(res.outputs[0]).all()
    assert "NaN or inf" in res.messages[1] and "t = " in res.messages[1]


def test_bad_arguments_say_what_to_do():
    m = Decay()
    with pytest.raises(ValueError, match=r"shape \(n, 1\)"):
        m.simulate([[1.0, 2.0]], t_final=1.0, dt=0.1)
    with pytest.raises(ValueError, match="not a state.*states: y"):
        m.simulate([[1.0]], t_final=1.0, dt=0.1, initial={"z": 1.0})
    with pytest.raises(ValueError, match="whole number of steps"):
        m.simulate([[1.0]], t_final=1.05, dt=0.1)
    with pytest.raises(KeyError, match="available: y"):
        m.simulate([[1.0]], t_final=1.0, dt=0.1)["z"]


def test_outputs_other_than_the_states_need_output():
    class NoOutput(Decay):
        outputs = (Channel("rate", "m/s"),)

    with pytest.raises(NotImplementedError, match="implement output"):
        NoOutput().simulate([[1.0]], t_final=1.0, dt=0.1)


def test_models_get_by_import_path_register_and_entry_point(tmp_path, monkeypatch):
    (tmp_path / "mydyn.py").write_text(
        textwrap.dedent(
            """
            from vectorid.models import Channel, Parameter, SystemModel

            class Lag(SystemModel):
                parameters = (Parameter("tau", 1.0, 0.5, 2.0, "s"),)
                states = (Channel("y", "-", default=0.0),)

                def __init__(self, gain=1.0):
                    self.gain = gain

                def rhs(self, t, x, p):
                    return (self.gain - x) / p[:, :1]
            """
        ),
        encoding="utf-8",
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    m = models.get("mydyn:Lag", gain=2.0)
    assert isinstance(m, SystemModel) and m.gain == 2.0 and m.name == "Lag"
    models.register("lag-test", "mydyn:Lag")
    try:
        assert "lag-test" in models.available()
        assert models.get("lag-test").parameter_names == ("tau",)
    finally:
        models._REGISTRY.pop("lag-test")

    class EP:
        name, value = "lag-ep", "mydyn:Lag"

    monkeypatch.setattr(
        "importlib.metadata.entry_points",
        lambda group=None: [EP] if group == "vectorid.models" else [],
    )
    assert "lag-ep" in models.available()
    assert type(models.get("lag-ep")).__name__ == "Lag"
    with pytest.raises(KeyError, match="import path 'package.module:ClassName'"):
        models.get("no-such-model")
    with pytest.raises(TypeError, match="not a model class"):
        models.get("numpy:ndarray")
    sys.modules.pop("mydyn", None)
