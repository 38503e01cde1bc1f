"""Adequacy criteria against hand-computed values on tiny signals."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vectorid.identify import CRITERIA, OPERATORS, dropout, evaluate_criteria
from vectorid.identify.criteria import (
    INDICES,
    CriterionError,
    get_criterion,
    integrate,
    wrap_angle,
)

T3 = np.array([0.0, 1.0, 2.0])  # trapezoid weights 0.5, 1, 0.5
T5 = np.arange(5.0)  # weights 0.5, 1, 1, 1, 0.5


def one(name: str, sim: np.ndarray, meas: np.ndarray, t: np.ndarray) -> float:
    d = CRITERIA[name]
    return float(evaluate_criteria([name], {d.channel: sim[None]}, {d.channel: meas}, t)[0, 0])


def test_table_one_and_seed_names_are_registered():
    table1 = [
        "pos_h_abs", "pos_h_sq", "pos_v_abs", "vel_h_abs", "vel_v_abs", "roll_abs",
        "pitch_abs", "yaw_abs", "yaw_sq", "yaw_rate_max", "yaw_rate_min", "yaw_rate_avg",
        "freq_roll", "freq_pitch", "freq_yaw",
    ]  # fmt: skip
    others = ["speed_profile", "heading_profile", "control_response", "alt_abs", "alt_sq",
              "vz_abs"]  # fmt: skip
    for k, name in enumerate(table1, start=1):
        assert name in CRITERIA
        assert CRITERIA[name].meaning.startswith(f"{k}:")
    for name in others:
        assert name in CRITERIA
    assert set(OPERATORS) >= {"absdiff", "ratio", "relerr"}


def test_integrate_is_trapezoid():
    assert integrate(np.array([[1.0, 2.0, 4.0]]), T3)[0] == pytest.approx(0.5 + 2 + 2)
    t = np.array([0.0, 1.0, 3.0])  # non-uniform
    assert integrate(np.array([2.0, 2.0, 2.0]), t) == pytest.approx(6.0)


def test_position_criteria():
    meas = np.zeros((3, 3))
    sim = np.array([[3.0, 4.0, 1.0], [0.0, 0.0, -2.0], [3.0, 0.0, 0.0]])
    # horizontal distances 5, 0, 3; down residuals 1, -2, 0
    assert one("pos_h_abs", sim, meas, T3) == pytest.approx(0.5 * 5 + 0 + 0.5 * 3)
    assert one("pos_h_sq", sim, meas, T3) == pytest.approx(0.5 * 25 + 0 + 0.5 * 9)
    assert one("pos_v_abs", sim, meas, T3) == pytest.approx(0.5 * 1 + 2 + 0)
    assert one("pos_v_sq", sim, meas, T3) == pytest.approx(0.5 * 1 + 4 + 0)
    assert one("landing_error", sim, meas, T3) == pytest.approx(3.0)
    assert INDICES["drift"].fn(sim[None], T3)[0] == pytest.approx(4.0)


def test_velocity_criteria():
    meas = np.tile([1.0, 0.0, 5.0], (3, 1))
    sim = np.array([[1.0, 0.0, 5.0], [0.0, 1.0, 6.0], [-1.0, 0.0, 5.0]])
    # horizontal vector residuals 0, sqrt(2), 2; vertical 0, 1, 0
    assert one("vel_h_abs", sim, meas, T3) == pytest.approx(math.sqrt(2) + 0.5 * 2)
    assert one("vel_v_abs", sim, meas, T3) == pytest.approx(1.0)
    assert one("speed_profile", sim, meas, T3) == pytest.approx(0.0, abs=1e-12)
    # courses 0, pi/2, pi against 0
    assert one("heading_profile", sim, meas, T3) == pytest.approx(math.pi / 2 + 0.5 * math.pi)
    slow = sim * 0.1  # speeds 0.1: speed residual 0.9 each
    assert one("speed_profile", slow, meas, T3) == pytest.approx(2 * 0.9)


def test_heading_ignores_samples_without_measured_motion():
    meas = np.array([[0.0, 0.0, 5.0], [1.0, 0.0, 5.0], [1.0, 0.0, 5.0]])
    sim = np.array([[0.0, 1.0, 5.0], [0.0, 1.0, 5.0], [1.0, 0.0, 5.0]])
    # first sample has no measured course; the second differs by pi/2
    assert one("heading_profile", sim, meas, T3) == pytest.approx(math.pi / 2)


def test_euler_residuals_wrap():
    meas = np.zeros((3, 3))
    meas[:, 2] = [3.1, -3.1, 0.0]
    sim = np.zeros((3, 3))
    sim[:, 0] = [0.1, 0.2, -0.1]
    sim[:, 1] = [0.0, 0.0, 0.4]
    sim[:, 2] = [-3.1, 3.1, 0.0]
    d = 2 * math.pi - 6.2  # |wrap(-6.2)| = |wrap(6.2)|
    assert one("roll_abs", sim, meas, T3) == pytest.approx(0.05 + 0.2 + 0.05)
    assert one("pitch_abs", sim, meas, T3) == pytest.approx(0.2)
    assert one("yaw_abs", sim, meas, T3) == pytest.approx(0.5 * d + d)
    assert one("yaw_sq", sim, meas, T3) == pytest.approx(1.5 * d * d)
    assert wrap_angle(math.pi) == pytest.approx(math.pi)
    assert wrap_angle(-math.pi) == pytest.approx(math.pi)


def test_yaw_rate_criteria_and_control_response():
    meas = np.zeros((5, 3))
    meas[:, 2] = [0.0, 1.0, 3.0, 4.0, 4.0]  # gradient 1, 1.5, 1.5, 0.5, 0
    sim = np.zeros((5, 3))
    sim[:, 2] = 0.5 * T5  # rate 0.5 everywhere
    assert one("yaw_rate_max", sim, meas, T5) == pytest.approx(1.0)
    assert one("yaw_rate_min", sim, meas, T5) == pytest.approx(0.5)
    # average of the measured rate: (0.5*1 + 1.5 + 1.5 + 0.5 + 0.5*0) / 4 = 1
    assert one("yaw_rate_avg", sim, meas, T5) == pytest.approx(0.5)
    # |0.5 - rate| = 0.5, 1, 1, 0, 0.5 -> 0.25 + 1 + 1 + 0 + 0.25
    assert one("control_response", sim, meas, T5) == pytest.approx(2.5)


def test_yaw_rate_unwraps():
    t = np.linspace(0.0, 10.0, 101)
    yaw = wrap_angle(1.0 * t)  # turning at 1 rad/s, wrapped
    meas = np.zeros((101, 3))
    meas[:, 2] = yaw
    sim = meas.copy()
    sim[:, 2] = wrap_angle(0.8 * t)
    assert one("yaw_rate_avg", sim, meas, t) == pytest.approx(0.2, abs=1e-9)
    assert one("yaw_rate_max", sim, meas, t) == pytest.approx(0.2, abs=1e-9)


def test_altitude_criteria():
    meas = np.array([[10.0], [8.0], [6.0]])
    sim = np.array([[10.0], [9.0], [6.0]])
    assert one("alt_abs", sim, meas, T3) == pytest.approx(1.0)
    assert one("alt_sq", sim, meas, T3) == pytest.approx(1.0)
    # gradients: measured -2, -2, -2; simulated -1, -2, -3
    assert one("vz_abs", sim, meas, T3) == pytest.approx(0.5 + 0 + 0.5)
    assert INDICES["descent_rate_avg"].fn(meas[None], T3)[0] == pytest.approx(2.0)


@pytest.mark.parametrize(("name", "col"), [("freq_roll", 0), ("freq_pitch", 1), ("freq_yaw", 2)])
def test_frequency_criteria(name, col):
    t = np.arange(0.0, 120.0, 0.1)
    meas = np.zeros((t.size, 3))
    sim = np.zeros((t.size, 3))
    meas[:, col] = 0.2 * np.sin(2 * np.pi * 0.5 * t)
    sim[:, col] = 0.2 * np.sin(2 * np.pi * 0.7 * t)
    if col == 2:  # a turning descent: oscillation on top of a steady turn
        meas[:, col] += 0.3 * t
        sim[:, col] += 0.1 * t
        meas[:, col] = wrap_angle(meas[:, col])
        sim[:, col] = wrap_angle(sim[:, col])
    assert one(name, sim, meas, t) == pytest.approx(0.2, abs=0.01)
    assert one(name, meas, meas, t) == pytest.approx(0.0, abs=1e-9)


def test_operators():
    a = np.array([1.0, 3.0])
    assert OPERATORS["absdiff"](a, 2.0) == pytest.approx([1.0, 1.0])
    assert OPERATORS["ratio"](a, 2.0) == pytest.approx([0.5, 1.5])
    assert OPERATORS["relerr"](a, 2.0) == pytest.approx([0.5, 0.5])
    assert OPERATORS["logratio"](a, 2.0) == pytest.approx([math.log(2), math.log(1.5)])
    with pytest.raises(CriterionError, match="absdiff"):
        OPERATORS["relerr"](a, 0.0)


def test_index_operator_criteria():
    meas = np.zeros((5, 3))
    meas[:, 2] = [0.0, 1.0, 3.0, 4.0, 4.0]  # max rate 1.5
    sim = np.zeros((5, 3))
    sim[:, 2] = 0.5 * T5
    out = evaluate_criteria(
        ["yaw_rate_max:ratio", "yaw_rate_max:relerr", "yaw_rate_max"],
        {"euler": sim[None]},
        {"euler": meas},
        T5,
    )
    assert out[0] == pytest.approx([0.5 / 1.5, 1.0 / 1.5, 1.0])
    assert get_criterion("yaw_rate_max:ratio").unit == "1"
    with pytest.raises(CriterionError, match="unknown operator"):
        get_criterion("yaw_rate_max:ratoi")
    with pytest.raises(CriterionError, match="did you mean 'pos_h_abs'"):
        get_criterion("pos_habs")


def test_evaluate_batch_nan_rows_and_shapes():
    meas = {"altitude": np.array([10.0, 8.0, 6.0]), "position": np.zeros((3, 3))}
    alt = np.array([[10.0, 9.0, 6.0], [np.nan, 8.0, 6.0], [10.0, 8.0, 6.0]])  # (n, T)
    pos = np.zeros((3, 3, 3))
    pos[0, 1, 0] = 2.0
    out = evaluate_criteria(["alt_abs", "pos_h_abs"], {"altitude": alt, "position": pos}, meas, T3)
    assert out.shape == (3, 2)
    assert out[0] == pytest.approx([1.0, 2.0])
    assert math.isnan(out[1, 0]) and out[1, 1] == 0.0
    assert out[2] == pytest.approx([0.0, 0.0])


def test_evaluate_errors():
    meas = {"altitude": np.array([10.0, 8.0, 6.0])}
    sim = {"altitude": np.zeros((2, 3))}
    with pytest.raises(CriterionError, match="needs measured channel 'position'"):
        evaluate_criteria(["pos_h_abs"], sim, meas, T3)
    with pytest.raises(CriterionError, match=r"expected shape \(n, 3, 1\)"):
        evaluate_criteria(["alt_abs"], {"altitude": np.zeros((2, 4))}, meas, T3)
    with pytest.raises(CriterionError, match="NaN"):
        evaluate_criteria(["alt_abs"], sim, {"altitude": np.array([1.0, np.nan, 2.0])}, T3)
    with pytest.raises(CriterionError, match="strictly increasing"):
        evaluate_criteria(["alt_abs"], sim, meas, np.array([0.0, 0.0, 1.0]))


def test_channel_override():
    meas = {"baro": np.array([10.0, 8.0, 6.0])}
    sim = {"baro": np.array([[10.0, 9.0, 6.0]])}
    out = evaluate_criteria(["alt_abs"], sim, meas, T3, channels={"alt_abs": "baro"})
    assert out[0, 0] == pytest.approx(1.0)


def test_dropout():
    meas = np.zeros(3)
    sim = np.array([[0.5, 0.5, 0.5], [0.0, 1.7, 0.0], [-2.5, 0.0, 0.0], [0.0, np.nan, 0.0]])
    out = dropout(sim, meas, 1.0)
    assert out[:3] == pytest.approx([0.0, 0.7, 1.5])
    assert math.isnan(out[3])
    band = np.array([[1.0], [2.0], [1.0]])  # per grid point
    assert dropout(sim[:3], meas, band) == pytest.approx([0.0, 0.0, 1.5])
    # per column, and angles wrapped
    m2 = np.zeros((3, 2))
    s2 = np.zeros((1, 3, 2))
    s2[0, 1] = [0.5, 2 * math.pi - 0.1]
    assert dropout(s2, m2, [0.2, 0.2], angular=True) == pytest.approx([0.3])
    with pytest.raises(CriterionError, match=">= 0"):
        dropout(sim, meas, -1.0)
    with pytest.raises(CriterionError, match="band"):
        dropout(sim, meas, np.ones(5))


@pytest.mark.parametrize("name", ["speed_profile", "heading_profile", "control_response"])
def test_profile_criteria_take_one_measurement_per_simulation(name):
    # the noise floor's draws: simulation r against measurement r in one call, the same as
    # one call per pair
    c = get_criterion(name)
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 20.0, 101)
    S = rng.normal(2.0, 1.0, (5, t.size, 3))
    M = rng.normal(2.0, 1.0, (5, t.size, 3))
    one_each = np.array([c.fn(S[r : r + 1], M[r], t)[0] for r in range(5)])
    np.testing.assert_allclose(c.fn(S, M, t), one_each, rtol=1e-12)
    # one measurement against every simulation, as before
    single = [c.fn(S[r : r + 1], M[0], t)[0] for r in range(5)]
    np.testing.assert_allclose(c.fn(S, M[0], t), single, rtol=1e-12)
