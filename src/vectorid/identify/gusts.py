"""The discrepancy allowance for gusts a model flies as a uniform wind.

A model that flies each flight in one uniform wind (a design variable per flight) cannot follow
the gusts the air had: the canopy drifts with them, so its track departs from the model's by the
integral of the gust. :func:`gust_allowance` turns a gust model into a bound on that departure
over each flight, in the units of the noise keys (``position_h``, ``position_v``, m), to be
granted as ``discrepancy`` (:mod:`vectorid.identify.noise`).

The gust model (:class:`HeightGusts`) is a first-order process over height, as the ETH
Zürich parafoil simulator states it (:data:`ETH_GUSTS`, from the ``eth-parafoil`` data README):
on height steps dh, g_i = (1 + dh k) g_(i−1) + dh ζ, ζ ~ N(0, b) per component.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

__all__ = ["ETH_GUSTS", "HeightGusts", "gust_allowance"]


@dataclass(frozen=True)
class HeightGusts:
    """A first-order gust process over height (stationary; see the module docstring).

    Attributes
    ----------
    dh : float
        Height step, m.
    k : float
        Decay per metre, 1/m (negative: the process forgets; a = 1 + dh k).
    b : tuple of float
        Standard deviation of ζ per component (north, east, down), (m/s)/m.
    """

    dh: float
    k: float
    b: tuple[float, float, float]

    @property
    def sigma(self) -> np.ndarray:
        """Stationary standard deviation of each gust component, m/s: dh b / √(1 − a²)."""
        a = 1.0 + self.dh * self.k
        return np.array(self.b) * self.dh / np.sqrt(1.0 - a * a)


#: The ETH authors' gust model (data README of ``eth-parafoil``, their simulation's wind):
#: dh = 0.5 m, k_w = −0.00385 /m, b_w_xy = 8 x 0.0251, b_w_z = 2 x 0.0251 (m/s)/m.
ETH_GUSTS = HeightGusts(0.5, -0.00385, (8 * 0.0251, 8 * 0.0251, 2 * 0.0251))


def gust_allowance(
    durations: Mapping[str, float],
    gusts: HeightGusts,
    *,
    sink: float | Mapping[str, float],
    draws: int = 4000,
    seed: int = 0,
    quantile: float = 0.95,
    dt: float = 0.2,
) -> dict[str, dict[str, float]]:
    """The position deviation (m) that ``gusts`` cause over each flight when the model flies a
    uniform wind: per flight ``{"position_h": δ_h, "position_v": δ_v}``.

    A kinematic Monte Carlo: the canopy drifts with the air, so a wind departing from the
    model's by w(t) moves it by ∫ w dt. The gusts run over the height the flight descends at
    the sink rate; the model's uniform wind absorbs the mean horizontal gust over the flight,
    and its initial velocity (fitted to the data) the vertical gust at the start. δ is the
    ``quantile`` over draws of the time-mean |deviation| (the allowance's meaning: ∫|e| dt may
    grow by δ T).

    Parameters
    ----------
    durations : mapping
        Flight name -> duration of its comparison window, s.
    gusts : HeightGusts
        The gust model (e.g. :data:`ETH_GUSTS`).
    sink : float or mapping
        Sink rate, m/s (one for all flights, or per flight): sets the height a flight spans.
    draws, seed : int
        Monte Carlo draws and their seed.
    quantile : float
        Quantile of the time-mean deviation over the draws.
    dt : float
        Time step of the integration, s.
    """
    rng = np.random.default_rng(seed)
    a = 1.0 + gusts.dh * gusts.k
    sd = gusts.sigma
    out = {}
    for name, T in durations.items():
        vz = float(sink[name] if isinstance(sink, Mapping) else sink)
        t = np.arange(0.0, T + 1e-9, dt)
        n_lev = int(np.ceil(vz * T / gusts.dh)) + 2
        g = np.empty((draws, n_lev, 3))
        g[:, 0] = rng.normal(0.0, sd, (draws, 3))
        for i in range(1, n_lev):
            g[:, i] = a * g[:, i - 1] + gusts.dh * rng.normal(0.0, gusts.b, (draws, 3))
        h = vz * t / gusts.dh  # level coordinate along the descent
        lo = np.minimum(np.floor(h).astype(int), n_lev - 2)
        w = (h - lo)[None, :, None]
        gt = (1 - w) * g[:, lo] + w * g[:, lo + 1]  # (draws, T, 3)
        horiz = gt[:, :, :2] - gt[:, :, :2].mean(axis=1, keepdims=True)
        vert = gt[:, :, 2] - gt[:, :1, 2]
        dev_h = np.cumsum(horiz, axis=1) * dt
        dev_v = np.cumsum(vert, axis=1) * dt
        mean_h = np.linalg.norm(dev_h, axis=2).mean(axis=1)
        mean_v = np.abs(dev_v).mean(axis=1)
        out[name] = {
            "position_h": float(np.quantile(mean_h, quantile)),
            "position_v": float(np.quantile(mean_v, quantile)),
        }
    return out
