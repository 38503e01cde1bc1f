"""Control schedules: interpolation, hold, validation."""

import numpy as np
import pytest

from vectorid.models.controls import ControlSchedule, flap_deflections, riser_commands


def test_linear_and_zero_order_hold():
    lin = ControlSchedule([0.0, 10.0], [[0.0], [1.0]], ("a",))
    zoh = ControlSchedule([0.0, 10.0], [[0.0], [1.0]], ("a",), interpolation="previous")
    t = np.array([-1.0, 0.0, 2.5, 9.999, 10.0, 50.0])
    np.testing.assert_allclose(lin(t)[:, 0], [0.0, 0.0, 0.25, 0.9999, 1.0, 1.0])
    np.testing.assert_array_equal(zoh(t)[:, 0], [0.0, 0.0, 0.0, 0.0, 1.0, 1.0])


def test_many_knots_binary_search_matches_numpy_interp():
    rng = np.random.default_rng(0)
    tk = np.cumsum(rng.uniform(0.1, 1.0, 200))
    vk = rng.normal(size=(200, 2))
    s = ControlSchedule(tk, vk, ("a", "b"))
    t = rng.uniform(tk[0] - 1, tk[-1] + 1, 1000)
    expected = np.stack([np.interp(t, tk, vk[:, j]) for j in range(2)], axis=1)
    np.testing.assert_allclose(s(t), expected, rtol=1e-12, atol=1e-12)


def test_reorder_fills_missing_channels_and_rejects_unknown():
    s = ControlSchedule([0.0, 1.0], [[0.5], [0.0]], ("riser2",))
    r = s.reorder(("riser1", "riser2", "riser3", "riser4"), (1.0, 1.0, 1.0, 1.0))
    np.testing.assert_array_equal(r.values, [[1.0, 0.5, 1.0, 1.0], [1.0, 0.0, 1.0, 1.0]])
    with pytest.raises(ValueError, match="not inputs of this model"):
        s.reorder(("flap_left", "flap_right"), (0.0, 0.0))


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (([0.0, 0.0], [[1.0], [2.0]], ("a",)), "strictly increasing"),
        (([0.0, 1.0], [[1.0, 2.0]], ("a",)), "values must have shape"),
        (([0.0], [[np.nan]], ("a",)), "finite"),
    ],
)
def test_schedule_validation(args, match):
    with pytest.raises(ValueError, match=match):
        ControlSchedule(*args)


def test_builders():
    r = riser_commands([0.0, 5.0], [[1, 1, 1, 1], [0, 1, 1, 1]])
    assert r.channels == ("riser1", "riser2", "riser3", "riser4")
    assert r(np.array(4.99))[0] == 1.0 and r(np.array(5.0))[0] == 0.0
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        riser_commands([0.0], [[2, 1, 1, 1]])
    f = flap_deflections([0.0, 2.0], [0.0, 1.0], [0.0, 0.5])
    np.testing.assert_allclose(f(np.array(1.0)), [0.5, 0.25])
