"""Twin drops: the truth flown, sampled per sensor, with the stated noise, as study files."""

from __future__ import annotations

import numpy as np
import pytest

from vectorid import models
from vectorid.identify import Identification
from vectorid.identify.twins import twin_drop, write_twin, write_wind_csv
from vectorid.models import InitialState, WindProfile
from vectorid.spec import StudySpec

WIND = WindProfile.from_speed_direction([0.0, 3000.0], [4.0, 8.0], [250.0, 280.0])
INI = InitialState(altitude=1600.0, velocity=(2.0, 1.0, 7.0), euler=(0.05, 0.0, 0.2))


def test_twin_without_noise_is_the_model_and_rates_are_the_sensors():
    m = models.get("parachute6dof")
    exact = twin_drop(m, {"x6": 0.5}, initial=INI, duration=20.0, noise={}, seed=1, wind=WIND,
                      origin_altitude=1000.0)  # fmt: skip
    assert np.diff(exact["position"].t) == pytest.approx(0.25)
    assert np.diff(exact["euler"].t) == pytest.approx(0.02)
    x = m.nominal.copy()
    x[m.parameter_names.index("x6")] = 0.5
    res = m.simulate(x[None], t_final=20.0, dt=0.01, output_dt=0.25, wind=WIND, initial=INI)
    pos = np.array(res.position[0])
    pos[:, 2] += 1000.0
    np.testing.assert_allclose(exact["position"].values, pos, atol=1e-9)
    noisy = twin_drop(m, {"x6": 0.5}, initial=INI, duration=20.0, noise={"position_v": 2.0},
                      seed=1, wind=WIND, origin_altitude=1000.0)  # fmt: skip
    err = noisy["position"].values - exact["position"].values
    assert np.all(err[:, :2] == 0) and err[:, 2].std() == pytest.approx(2.0, rel=0.2)
    with pytest.raises(ValueError, match="not a multiple of dt"):
        twin_drop(m, {}, initial=INI, duration=5.0, noise={}, seed=1, rates={"euler": 30.0})


def test_written_twin_loads_as_a_study(tmp_path):
    m = models.get("parachute6dof")
    fl = twin_drop(m, {"x15": 1.2}, initial=INI, duration=25.0, noise={"velocity": 0.1}, seed=2,
                   wind=WIND, origin_altitude=1000.0,
                   commands=([0.0, 5.0, 15.0], [[1, 1, 1, 1], [0, 1, 1, 1], [1, 1, 1, 1]]),
                   command_delay=0.5)  # fmt: skip
    files = write_twin(fl, tmp_path, "drop")
    write_wind_csv(WIND, tmp_path / "wind.csv", np.arange(900.0, 2000.0, 100.0))
    data = {
        "study": {"name": "t", "model": "parachute6dof", "trials": 8},
        "variables": [{"name": "x15", "low": 0.5, "high": 2.0}],
        "criteria": [{"name": "vel_h_abs"}],
        "identification": {"dt": 0.05, "output_dt": 0.25, "drops": [{
            "name": "d", "files": files, "wind": "wind.csv", "wind_format": "dropsonde",
            "wind_options": {"altitude": "altitude_m", "u": "u_ms", "v": "v_ms"},
            "window": ["start+1", 24.0]}]},
    }  # fmt: skip
    ident = Identification.from_spec(StudySpec.from_dict(data, base_dir=tmp_path))
    d = ident.drops[0]
    assert set(d.flight.channels) >= {"position", "velocity", "euler", "rates", "controls"}
    assert d.inputs is not None  # the logged risers drive the model
    F, _ = ident.evaluate(np.array([[1.2], [0.6]]))
    assert F[0, 0] < F[1, 0]  # the truth's x15 fits better than a wrong one
