"""Wind: a horizontal profile versus altitude plus optional seeded Dryden turbulence.

Conventions
-----------
- Components are in the local north-east-down (NED) frame, m/s: ``north`` is the velocity of the
  air towards north, ``east`` towards east (the air's velocity, "u/v" of a sounding).
- A meteorological direction is the direction the wind blows FROM, degrees clockwise from north:
  a 10 m/s wind from 270° (westerly) has north = 0, east = +10 m/s.
- Between profile levels the components are interpolated linearly in altitude; outside the
  profile the end values are held (constant extrapolation).
- Turbulence (:class:`DrydenTurbulence`) is generated as a time series of gust velocities that the
  whole batch sees, reproducible from a seed (see that class for the forms and the frame).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

__all__ = ["DrydenTurbulence", "Wind", "WindProfile", "calm"]

FT = 0.3048  # m per ft


@dataclass(frozen=True)
class WindProfile:
    """Horizontal wind components versus altitude.

    Parameters
    ----------
    altitude : array_like, shape (K,)
        Geometric altitude above mean sea level, m, strictly increasing.
    north, east : array_like, shape (K,)
        Velocity of the air towards north and towards east, m/s.
    """

    altitude: NDArray[np.float64]
    north: NDArray[np.float64]
    east: NDArray[np.float64]

    def __post_init__(self) -> None:
        h = np.atleast_1d(np.asarray(self.altitude, dtype=float))
        n = np.atleast_1d(np.asarray(self.north, dtype=float))
        e = np.atleast_1d(np.asarray(self.east, dtype=float))
        if h.ndim != 1 or h.size < 1 or n.shape != h.shape or e.shape != h.shape:
            raise ValueError(
                "altitude, north and east must be 1-D arrays of the same length >= 1, got shapes "
                f"{h.shape}, {n.shape}, {e.shape}"
            )
        if not (np.all(np.isfinite(h)) and np.all(np.isfinite(n)) and np.all(np.isfinite(e))):
            raise ValueError("wind profile contains NaN or inf; drop or fill those levels first")
        if h.size > 1 and np.any(np.diff(h) <= 0):
            raise ValueError(
                "altitude must be strictly increasing (sort the levels and drop duplicates), got "
                f"{h[:5]}..."
            )
        object.__setattr__(self, "altitude", h)
        object.__setattr__(self, "north", n)
        object.__setattr__(self, "east", e)

    @classmethod
    def from_speed_direction(
        cls, altitude: ArrayLike, speed: ArrayLike, direction_deg: ArrayLike
    ) -> WindProfile:
        """Profile from wind speed (m/s) and meteorological direction the wind blows FROM (deg)."""
        s = np.asarray(speed, dtype=float)
        d = np.deg2rad(np.asarray(direction_deg, dtype=float))
        if np.any(s < 0):
            raise ValueError("wind speed must be >= 0 m/s; a negative speed is a direction error")
        return cls(altitude, -s * np.cos(d), -s * np.sin(d))

    @classmethod
    def constant(cls, north: float = 0.0, east: float = 0.0) -> WindProfile:
        """The same wind at every altitude."""
        return cls(np.array([0.0]), np.array([north]), np.array([east]))

    def __call__(self, h: ArrayLike) -> NDArray[np.float64]:
        """Wind (north, east) in m/s at altitudes ``h`` (m), shape ``h.shape + (2,)``."""
        h = np.asarray(h, dtype=float)
        n = np.interp(h, self.altitude, self.north)
        e = np.interp(h, self.altitude, self.east)
        return np.stack([n, e], axis=-1)

    def speed_direction(self, h: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Speed (m/s) and meteorological FROM direction (deg in [0, 360)) at altitudes ``h``."""
        ne = self(h)
        speed = np.hypot(ne[..., 0], ne[..., 1])
        direction = np.rad2deg(np.arctan2(-ne[..., 1], -ne[..., 0])) % 360.0
        return speed, direction


def calm() -> WindProfile:
    """Calm air (zero wind at every altitude)."""
    return WindProfile.constant(0.0, 0.0)


def dryden_scales(h: ArrayLike, w20: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Dryden turbulence intensities and scale lengths versus altitude.

    MIL-F-8785C §3.7.3 / MIL-HDBK-1797 low-altitude model (h < 1000 ft)::

        L_w = h,  L_u = L_v = h / (0.177 + 0.000823 h)^1.2      (ft)
        σ_w = 0.1 W20,  σ_u = σ_v = σ_w / (0.177 + 0.000823 h)^0.4

    For h >= 2000 ft: L_u = L_v = L_w = 1750 ft and σ_u = σ_v = σ_w equal to the 1000-ft value
    (a continuous simplification of the exceedance-probability table of the medium/high-altitude
    model); between 1000 and 2000 ft the values are interpolated linearly, as MIL-HDBK-1797 asks.
    Altitude is floored at 10 ft.

    Parameters
    ----------
    h : array_like
        Altitude above ground, m.
    w20 : float
        Wind speed at 20 ft (6.1 m) above ground, m/s (MIL-F-8785C: 15 kn light, 30 kn moderate,
        45 kn severe).

    Returns
    -------
    sigma : ndarray, shape h.shape + (3,)
        σ_u, σ_v, σ_w in m/s.
    length : ndarray, shape h.shape + (3,)
        L_u, L_v, L_w in m.
    """
    h_ft = np.maximum(np.asarray(h, dtype=float) / FT, 10.0)

    def low(hf: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        c = 0.177 + 0.000823 * hf
        sw = 0.1 * w20 * np.ones_like(hf)
        su = sw / c**0.4
        lw = hf
        lu = hf / c**1.2
        return np.stack([su, su, sw], -1), np.stack([lu, lu, lw], -1) * FT

    s_lo, l_lo = low(np.minimum(h_ft, 1000.0))
    s_1000, _ = low(np.array(1000.0))
    s_hi = np.broadcast_to(s_1000, s_lo.shape)
    l_hi = np.full(l_lo.shape, 1750.0 * FT)
    w = np.clip((h_ft - 1000.0) / 1000.0, 0.0, 1.0)[..., None]
    return (1 - w) * s_lo + w * s_hi, (1 - w) * l_lo + w * l_hi


@njit(cache=True)
def _dryden_filter(noise, sigma, length, v_ref, dt):  # pragma: no cover - compiled
    """Integrate the Dryden shaping filters driven by unit white noise (Euler-Maruyama)."""
    n = noise.shape[0]
    out = np.zeros((n, 3))
    xu = 0.0
    x1v = 0.0
    x2v = 0.0
    x1w = 0.0
    x2w = 0.0
    sq3 = np.sqrt(3.0)
    for k in range(n):
        # u: H(s) = σ sqrt(2L/(πV)) / (1 + τ s), τ = L/V; white-noise intensity π
        # gives output variance σ² (exact OU update).
        tau = length[k, 0] / v_ref
        a = np.exp(-dt / tau)
        xu = a * xu + sigma[k, 0] * np.sqrt(1.0 - a * a) * noise[k, 0]
        out[k, 0] = xu
        # v and w: H(s) = σ sqrt(L/(πV)) (1 + √3 τ s) / (1 + τ s)², intensity π.
        for c in range(1, 3):
            tau = length[k, c] / v_ref
            gain = sigma[k, c] * np.sqrt(tau / np.pi)
            w_in = np.sqrt(np.pi / dt) * noise[k, c]
            if c == 1:
                x1, x2 = x1v, x2v
            else:
                x1, x2 = x1w, x2w
            # τ² x1'' + 2 τ x1' + x1 = w ; y = gain (x1 + √3 τ x1'); semi-implicit Euler.
            x2 = (x2 + dt * (w_in - x1) / (tau * tau)) / (1.0 + 2.0 * dt / tau)
            x1 = x1 + dt * x2
            out[k, c] = gain * (x1 + sq3 * tau * x2)
            if c == 1:
                x1v, x2v = x1, x2
            else:
                x1w, x2w = x1, x2
    return out


@dataclass(frozen=True)
class DrydenTurbulence:
    """Seeded Dryden turbulence (MIL-F-8785C / MIL-HDBK-1797 forms) as a gust time series.

    The gusts are generated once per simulation as a time series on a grid of step ``dt`` along a
    reference descent h_ref(t) = h0 - v_ref t (h0 is the initial altitude of the simulation),
    with the spatial frequencies turned into temporal ones by the reference airspeed ``v_ref``
    (Taylor's frozen-turbulence hypothesis). Every trial of a batch sees the same realisation;
    the same seed gives the same series.

    Frame: u is along the mean horizontal wind at h_ref(t) (north if calm), v is 90° to its
    right (clockwise seen from above), w is down. The series is returned in NED.

    Parameters
    ----------
    w20 : float
        Wind speed at 20 ft above ground, m/s (sets σ_w = 0.1 W20).
    seed : int or numpy.random.Generator
        Seed or generator for the white noise; required (no global random state).
    v_ref : float
        Reference airspeed for Taylor's hypothesis, m/s (about the descent rate for a parachute).
    dt : float
        Time step of the generated series, s.
    ground_altitude : float
        Altitude of the ground above mean sea level, m (the Dryden forms use height above ground).
    """

    w20: float
    seed: int | np.random.Generator
    v_ref: float = 9.0
    dt: float = 0.02
    ground_altitude: float = 0.0

    def __post_init__(self) -> None:
        if not (np.isfinite(self.w20) and self.w20 >= 0):
            raise ValueError(f"w20 must be a wind speed >= 0 m/s, got {self.w20!r}")
        if not (np.isfinite(self.v_ref) and self.v_ref > 0):
            raise ValueError(f"v_ref must be > 0 m/s, got {self.v_ref!r}")
        if not (np.isfinite(self.dt) and self.dt > 0):
            raise ValueError(f"dt must be > 0 s, got {self.dt!r}")

    def series(
        self, t_final: float, h0: float, profile: WindProfile | None = None
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Gust velocities in NED along the reference descent.

        Returns
        -------
        t : ndarray, shape (T,)
            Times, s, from 0 with step ``dt`` covering ``t_final``.
        gust : ndarray, shape (T, 3)
            Gust velocity of the air (north, east, down), m/s.
        """
        n = int(np.ceil(t_final / self.dt)) + 2
        t = np.arange(n) * self.dt
        rng = (
            self.seed
            if isinstance(self.seed, np.random.Generator)
            else np.random.default_rng(self.seed)
        )
        noise = rng.standard_normal((n, 3))
        h_ref = np.maximum(h0 - self.v_ref * t, self.ground_altitude)
        sigma, length = dryden_scales(h_ref - self.ground_altitude, self.w20)
        uvw = _dryden_filter(
            noise,
            np.ascontiguousarray(sigma),
            np.ascontiguousarray(length),
            float(self.v_ref),
            float(self.dt),
        )
        if profile is None:
            heading = np.zeros(n)
        else:
            ne = profile(h_ref)
            heading = np.arctan2(ne[:, 1], ne[:, 0])  # direction the air moves TO
        c, s = np.cos(heading), np.sin(heading)
        gust = np.empty((n, 3))
        gust[:, 0] = c * uvw[:, 0] - s * uvw[:, 1]
        gust[:, 1] = s * uvw[:, 0] + c * uvw[:, 1]
        gust[:, 2] = uvw[:, 2]
        return t, gust


@dataclass(frozen=True)
class Wind:
    """A wind field: a profile versus altitude plus optional turbulence.

    Parameters
    ----------
    profile : WindProfile
        Mean horizontal wind versus altitude.
    turbulence : DrydenTurbulence or None
        Optional seeded gusts added to the profile.
    """

    profile: WindProfile
    turbulence: DrydenTurbulence | None = None
