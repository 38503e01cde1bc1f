"""International Standard Atmosphere (ISO 2533:1975 / U.S. Standard Atmosphere 1976) and gravity.

All functions are vectorised over altitude (numpy arrays or scalars) and cover the geopotential
layers from -5 km to 51 km (troposphere, tropopause, lower and upper stratosphere, stratopause).

Altitude arguments are *geometric* altitude above mean sea level in metres unless a function says
otherwise; :func:`geopotential_altitude` and :func:`geometric_altitude` convert between the two
with the Earth radius r0 = 6 356 766 m of the U.S. Standard Atmosphere 1976.

Atmosphere objects (:class:`ISA`, :class:`UniformAtmosphere`) are what a model's ``simulate``
accepts as ``atmosphere=``; they only need ``density(h)`` and ``gravity(h)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "G0",
    "ISA",
    "P0",
    "RHO0",
    "R_AIR",
    "T0",
    "UniformAtmosphere",
    "density",
    "geometric_altitude",
    "geopotential_altitude",
    "gravity",
    "pressure",
    "temperature",
]

#: Standard gravity, m/s² (ISO 2533).
G0 = 9.80665
#: Specific gas constant of dry air, J/(kg K) (R* / M0 = 8.31432 / 0.0289644, US 1976).
R_AIR = 287.05287
#: Sea-level temperature, K.
T0 = 288.15
#: Sea-level pressure, Pa.
P0 = 101_325.0
#: Sea-level density, kg/m³.
RHO0 = P0 / (R_AIR * T0)
#: Effective Earth radius used for geopotential altitude, m (US Standard Atmosphere 1976).
R_EARTH = 6_356_766.0

# Layer bases: geopotential altitude (m), lapse rate (K/m).
_H_BASE = np.array([-5_000.0, 11_000.0, 20_000.0, 32_000.0, 47_000.0, 51_000.0])
_LAPSE = np.array([-0.0065, 0.0, 0.001, 0.0028, 0.0, -0.0028])


def _layer_tables() -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    t_base = np.empty(_H_BASE.size)
    p_base = np.empty(_H_BASE.size)
    # Start from sea level and go down to -5 km for the first base.
    t_base[0] = T0 + _LAPSE[0] * (_H_BASE[0] - 0.0)
    p_base[0] = P0 * (t_base[0] / T0) ** (-G0 / (R_AIR * _LAPSE[0]))
    for i in range(1, _H_BASE.size):
        dh = _H_BASE[i] - _H_BASE[i - 1]
        lapse = _LAPSE[i - 1]
        t_base[i] = t_base[i - 1] + lapse * dh
        if lapse == 0.0:
            p_base[i] = p_base[i - 1] * np.exp(-G0 * dh / (R_AIR * t_base[i - 1]))
        else:
            p_base[i] = p_base[i - 1] * (t_base[i] / t_base[i - 1]) ** (-G0 / (R_AIR * lapse))
    return t_base, p_base


_T_BASE, _P_BASE = _layer_tables()


def geopotential_altitude(h: ArrayLike) -> NDArray[np.float64]:
    """Geopotential altitude H = r0 h / (r0 + h), m, from geometric altitude ``h`` in m."""
    h = np.asarray(h, dtype=float)
    return R_EARTH * h / (R_EARTH + h)


def geometric_altitude(h_geopotential: ArrayLike) -> NDArray[np.float64]:
    """Geometric altitude h = r0 H / (r0 - H), m, from geopotential altitude ``H`` in m."""
    H = np.asarray(h_geopotential, dtype=float)
    return R_EARTH * H / (R_EARTH - H)


def _check_range(H: NDArray[np.float64]) -> None:
    if np.any(H < _H_BASE[0] - 1e-9) or np.any(H > 71_000.0):
        raise ValueError(
            f"ISA altitude out of range: expected geopotential altitude in [-5000, 71000] m, got "
            f"[{np.nanmin(H):.1f}, {np.nanmax(H):.1f}] m. Clip the altitude or use another model."
        )


def _state(h: ArrayLike, geopotential: bool) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    h = np.asarray(h, dtype=float)
    H = h if geopotential else geopotential_altitude(h)
    _check_range(H)
    i = np.clip(np.searchsorted(_H_BASE, H, side="right") - 1, 0, _H_BASE.size - 1)
    lapse = _LAPSE[i]
    dH = H - _H_BASE[i]
    T = _T_BASE[i] + lapse * dH
    with np.errstate(divide="ignore", invalid="ignore"):
        p_grad = _P_BASE[i] * (T / _T_BASE[i]) ** (-G0 / (R_AIR * np.where(lapse == 0, 1, lapse)))
    p_iso = _P_BASE[i] * np.exp(-G0 * dH / (R_AIR * _T_BASE[i]))
    p = np.where(lapse == 0.0, p_iso, p_grad)
    return T, p


def temperature(h: ArrayLike, *, geopotential: bool = False) -> NDArray[np.float64]:
    """ISA temperature in K at altitude ``h`` (m, geometric unless ``geopotential=True``)."""
    return _state(h, geopotential)[0]


def pressure(h: ArrayLike, *, geopotential: bool = False) -> NDArray[np.float64]:
    """ISA static pressure in Pa at altitude ``h`` (m, geometric unless ``geopotential=True``)."""
    return _state(h, geopotential)[1]


def density(h: ArrayLike, *, geopotential: bool = False) -> NDArray[np.float64]:
    """ISA density in kg/m³ at altitude ``h`` (m, geometric unless ``geopotential=True``)."""
    T, p = _state(h, geopotential)
    return p / (R_AIR * T)


def gravity(h: ArrayLike) -> NDArray[np.float64]:
    """Gravitational acceleration g0 (r0 / (r0 + h))² in m/s² at geometric altitude ``h`` (m)."""
    h = np.asarray(h, dtype=float)
    return G0 * (R_EARTH / (R_EARTH + h)) ** 2


@dataclass(frozen=True)
class ISA:
    """ISA atmosphere with an optional temperature offset (hot/cold day).

    Parameters
    ----------
    temperature_offset : float
        ΔT added to the ISA temperature at every altitude, K; pressure keeps its ISA value
        (the usual "ISA + ΔT" convention), so density becomes p / (R (T + ΔT)).
    """

    temperature_offset: float = 0.0

    def density(self, h: ArrayLike) -> NDArray[np.float64]:
        """Density in kg/m³ at geometric altitude ``h`` in m."""
        T, p = _state(h, False)
        return p / (R_AIR * (T + self.temperature_offset))

    def gravity(self, h: ArrayLike) -> NDArray[np.float64]:
        """Gravity in m/s² at geometric altitude ``h`` in m (inverse-square law)."""
        return gravity(h)


@dataclass(frozen=True)
class UniformAtmosphere:
    """Constant density and gravity at every altitude (for tests, wind tunnels, energy checks).

    Parameters
    ----------
    rho : float
        Air density, kg/m³.
    g : float
        Gravitational acceleration, m/s².
    """

    rho: float = RHO0
    g: float = G0

    def __post_init__(self) -> None:
        if not (np.isfinite(self.rho) and self.rho >= 0.0):
            raise ValueError(f"rho must be a finite density >= 0 kg/m³, got {self.rho!r}")
        if not (np.isfinite(self.g) and self.g >= 0.0):
            raise ValueError(f"g must be a finite acceleration >= 0 m/s², got {self.g!r}")

    def density(self, h: ArrayLike) -> NDArray[np.float64]:
        """Density in kg/m³ (the same at every altitude ``h``)."""
        return np.full(np.shape(h), float(self.rho))

    def gravity(self, h: ArrayLike) -> NDArray[np.float64]:
        """Gravity in m/s² (the same at every altitude ``h``)."""
        return np.full(np.shape(h), float(self.g))
