"""Point-mass descent under a drogue and a main parachute (a rocket's recovery), for identification.

A small batch model (registered as ``"rocket-descent"`` when :mod:`vectorid.identify` is
imported) for the real-descent example: the rocket after burn-out hangs under its parachutes as a
point mass. The parachutes are round canopies of known nominal diameters; the design variables
are their drag coefficients (referred to the nominal area π D²/4):

.. math::

    m \\dot{\\mathbf v} = m \\mathbf g
        - \\tfrac12 \\rho(h) \\lVert \\mathbf v_a \\rVert \\mathbf v_a\\,
          \\bigl(C_{D,d} S_d + u_{main}\\, C_{D,m} S_m + C_{D,b} S_b\\bigr),
    \\qquad \\mathbf v_a = \\mathbf v - \\mathbf w(h, t),

in NED (m, m/s), with ``u_main`` in [0, 1] the main parachute's deployment state, an input
channel (0 stowed, 1 fully inflated; a ramp between models the inflation). ``C_{D,b} S_b`` is an
optional fixed drag area of the body (default 0: the body's drag is lumped into the drogue's
coefficient, which is then an *effective* coefficient).

The drag areas' convention (``drag_convention``) says what a main parachute's drag area means:

- ``"adds"`` (the equation above): the drogue stays attached after the main opens (the usual
  dual-deploy rigging) and keeps its drag, so under the main the drag area is the sum
  C_D,d S_d + C_D,m S_m; the main's own drag area is what the main adds.
- ``"replaces"``: under the main the drag area is the main's alone,
  (1 - u_main) C_D,d S_d + u_main C_D,m S_m (+ C_D,b S_b). This is the convention of RocketPy,
  whose stated parachute ``cd_s`` is the whole drag area of the phase that parachute opens; a
  main's drag area in it includes whatever the drogue still adds.

The two identify the same total drag area under the main; they differ in what is called the
main's. :class:`RocketDescent` takes drag coefficients referred to the canopies' nominal areas
π D²/4 (``cd_drogue``, ``cd_main``); :class:`RocketDescentCdS` (``"rocket-descent-cds"``) takes
the drag areas themselves (``cds_drogue``, ``cds_main``, m²), for a rocket whose recovery is
stated as C_D S.

Outputs are the 15 base channels (Euler angles, body rates, angle of attack and sideslip are 0:
a point mass has no attitude) plus ``drag_area`` (m²).

The data side of a descent (:func:`detect_apogee`, :func:`detect_touchdown`,
:func:`crossing_time`, :func:`detect_rate_change`, :func:`monotone_rate_bound`,
:func:`fast_variation`) reads an altitude series: where the descent starts, where it ends on
the ground, when it passes a trigger height, where its drag area changes, how close any
constant-drag descent can come, how much of its fast variation a second altimeter shares.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

from vectorid.models.base import BASE_CHANNELS, Channel, InitialState, Model, Parameter
from vectorid.models.integrate import STATUS_REJECTED, allocate_outputs, env_at, rk4_trial

__all__ = [
    "DRAG_CONVENTIONS",
    "INCH",
    "INITIAL_SPEEDS",
    "FastVariation",
    "RateBound",
    "RateChange",
    "RocketDescent",
    "RocketDescentCdS",
    "Touchdown",
    "crossing_time",
    "detect_apogee",
    "detect_rate_change",
    "detect_touchdown",
    "fast_variation",
    "monotone_rate_bound",
]

INCH = 0.0254

#: What a main parachute's drag area means (see the module docstring).
DRAG_CONVENTIONS = ("adds", "replaces")
#: Where the simulated descent starts its velocity (see :class:`RocketDescent`).
INITIAL_SPEEDS = ("data", "steady")

# Per-trial constants vector P (_REPL: 1 when the main replaces the drogue, 0 when it adds).
_MASS, _SD, _SM, _CDD, _CDM, _CDAB, _REPL = range(7)
_NP = 7
_NS = 6


@njit(cache=True, inline="always")
def _rhs(t, x, P, u, atm, gust, dx):  # pragma: no cover - compiled
    rho, g, wn, we, wd = env_at(atm, gust, t, -x[2])
    van = x[3] - wn
    vae = x[4] - we
    vad = x[5] - wd
    va = np.sqrt(van * van + vae * vae + vad * vad)
    f = u[0]
    if f < 0.0:
        f = 0.0
    elif f > 1.0:
        f = 1.0
    cda = (1.0 - P[_REPL] * f) * P[_CDD] * P[_SD] + f * P[_CDM] * P[_SM] + P[_CDAB]
    k = 0.5 * rho * va * cda / P[_MASS]
    dx[0] = x[3]
    dx[1] = x[4]
    dx[2] = x[5]
    dx[3] = -k * van
    dx[4] = -k * vae
    dx[5] = g - k * vad


@njit(cache=True)
def _observe(t, x, P, u, atm, gust, y):  # pragma: no cover - compiled
    rho, g, wn, we, wd = env_at(atm, gust, t, -x[2])
    for j in range(6):
        y[j] = x[j]
    for j in range(6, 12):
        y[j] = 0.0
    van = x[3] - wn
    vae = x[4] - we
    vad = x[5] - wd
    y[12] = np.sqrt(van * van + vae * vae + vad * vad)
    y[13] = 0.0
    y[14] = 0.0
    f = min(max(u[0], 0.0), 1.0)
    y[15] = (1.0 - P[_REPL] * f) * P[_CDD] * P[_SD] + f * P[_CDM] * P[_SM] + P[_CDAB]


@njit(parallel=True, cache=True)
def _kernel(
    x0, p, ctrl_t, ctrl_v, ctrl_mode, atm, gust, dt, n_steps, stride, x_max, y, status, t_fail
):  # pragma: no cover - compiled
    for i in prange(x0.shape[0]):
        if status[i] != 0:
            continue
        status[i], t_fail[i] = rk4_trial(
            _rhs,
            _observe,
            x0[i],
            p[i],
            ctrl_t,
            ctrl_v,
            ctrl_mode,
            atm,
            gust,
            dt,
            n_steps,
            stride,
            x_max,
            y[i],
        )


def _check_positive(name: str, v: float) -> None:
    if not (np.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be a finite number > 0, got {v!r}")


class RocketDescent(Model):
    """Point mass under a drogue and a main round parachute (see the module docstring).

    Parameters
    ----------
    mass : float
        Descending mass, kg (default 16.881 kg: the Prometheus rocket of the shared data,
        13.9 kg dry without motor plus the 2.981 kg motor casing after burn-out).
    drogue_diameter, main_diameter : float
        Nominal canopy diameters, m (default 24 in and 72 in).
    body_drag_area : float
        Fixed drag area of the body C_D S, m² (default 0: lumped into the drogue).
    drag_convention : {"adds", "replaces"}
        Whether the main's drag adds to the drogue's (default: the drogue stays attached) or
        replaces it once the main is out (RocketPy's convention); see the module docstring.
    initial_speed : {"data", "steady"}
        The velocity the simulation starts from: the initial state's (default: fitted to the
        data at the window start) or, ``"steady"``, each trial's own steady descent rate
        sqrt(2 m g / (ρ C_D S)) with the horizontal velocity of the wind (drifting with it).
        A canopy some seconds after it opened descends at its steady rate (the speed's time
        constant is v / 2g, about 1.4 s at 27 m/s); a slope fitted over a few seconds of a
        barometric height whose error is correlated over seconds is not (the TeleMega's
        drogue phase: 25-32 m/s from 2-s lines at successive starts).

    Notes
    -----
    Parameters: ``cd_drogue`` (nominal 1.6) and ``cd_main`` (nominal 2.2), drag coefficients
    referred to the nominal areas. Input: ``main`` (0 stowed, 1 inflated). Steady descent rate
    under a drag area S_e: sqrt(2 m g / (ρ S_e)).
    """

    name = "rocket-descent"
    #: First compilation in an empty numba cache, s (benchmarks/startup.py --compile: 8.9 CPU s
    #: with imports; 23 s wall at load 8-11).
    compile_seconds = 7.0
    parameters = (
        Parameter("cd_drogue", 1.6, 0.5, 3.5, "-", "drogue drag coefficient on π D_d²/4"),
        Parameter("cd_main", 2.2, 0.8, 4.5, "-", "main drag coefficient on π D_m²/4"),
    )
    inputs = (Channel("main", "-", "main parachute state: 0 stowed, 1 fully inflated", 0.0),)
    outputs = (*BASE_CHANNELS, Channel("drag_area", "m²", "total drag area C_D S"))
    presets: ClassVar[dict[str, NDArray[np.float64]]] = {}

    def __init__(
        self,
        *,
        mass: float = 13.9 + 2.981,
        drogue_diameter: float = 24 * INCH,
        main_diameter: float = 72 * INCH,
        body_drag_area: float = 0.0,
        drag_convention: str = "adds",
        initial_speed: str = "data",
    ) -> None:
        for name, v in (
            ("mass", mass),
            ("drogue_diameter", drogue_diameter),
            ("main_diameter", main_diameter),
        ):
            _check_positive(name, v)
        self._set_common(mass, body_drag_area, drag_convention, initial_speed)
        self.drogue_area = float(np.pi * drogue_diameter**2 / 4)
        self.main_area = float(np.pi * main_diameter**2 / 4)

    def _set_common(
        self, mass: float, body_drag_area: float, drag_convention: str, initial_speed: str
    ) -> None:
        _check_positive("mass", mass)
        if initial_speed not in INITIAL_SPEEDS:
            raise ValueError(
                f"initial_speed must be 'data' (the initial state's velocity) or 'steady' (each "
                f"trial's own steady descent rate, drifting with the wind), got {initial_speed!r}"
            )
        self.initial_speed = initial_speed
        if not (np.isfinite(body_drag_area) and body_drag_area >= 0):
            raise ValueError(f"body_drag_area must be >= 0 m², got {body_drag_area!r}")
        if drag_convention not in DRAG_CONVENTIONS:
            raise ValueError(
                f"drag_convention must be 'adds' (the main's drag adds to the drogue's) or "
                f"'replaces' (the main's drag area is the whole drag area under it), got "
                f"{drag_convention!r}"
            )
        self.mass = float(mass)
        self.body_drag_area = float(body_drag_area)
        self.drag_convention = drag_convention

    def constants(self, X: NDArray[np.float64]) -> NDArray[np.float64]:
        """Per-trial constants (n, 7): mass, areas, coefficients, body drag area, convention."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        P = np.empty((X.shape[0], _NP))
        P[:, _MASS] = self.mass
        P[:, _SD] = self.drogue_area
        P[:, _SM] = self.main_area
        P[:, _CDD] = X[:, 0]
        P[:, _CDM] = X[:, 1]
        P[:, _CDAB] = self.body_drag_area
        P[:, _REPL] = 1.0 if self.drag_convention == "replaces" else 0.0
        return P

    def drag_area(self, X, main: float = 0.0) -> NDArray[np.float64]:
        """Total drag area C_D S (m²) per trial with the main in state ``main`` (0 to 1)."""
        P = self.constants(X)
        f = min(max(float(main), 0.0), 1.0)
        return (
            (1.0 - P[:, _REPL] * f) * P[:, _CDD] * P[:, _SD]
            + f * P[:, _CDM] * P[:, _SM]
            + P[:, _CDAB]
        )

    def steady_descent_rate(self, X, rho: float, g: float = 9.80665, main: float = 0.0):
        """Steady descent rate sqrt(2 m g / (ρ S_e)), m/s, per trial (S_e: total drag area)."""
        cda = self.drag_area(X, main)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.sqrt(2 * self.mass * g / (rho * cda))

    def altitude_range(self, initial: InitialState, t_final: float) -> tuple[float, float]:
        return max(-4_900.0, min(-500.0, initial.altitude - 8_000.0)), initial.altitude + 1_000.0

    def _check_parameters(self, X: NDArray[np.float64]) -> NDArray[np.int64]:
        bad = (X[:, 0] < 0) | (X[:, 1] < 0)
        return np.where(bad, STATUS_REJECTED, 0).astype(np.int64)

    def _simulate(self, X, status, t_fail, *, dt, n_steps, stride, controls, env, initial):
        P = self.constants(X)
        n = X.shape[0]
        x0 = np.zeros((n, _NS))
        x0[:, 0] = initial.north
        x0[:, 1] = initial.east
        x0[:, 2] = -initial.altitude
        if initial.velocity is None or self.initial_speed == "steady":
            h = initial.altitude
            i = int(np.clip(round((h - env.atm[0, 0]) / env.atm[0, 1]), 0, env.atm[0, 2] - 1)) + 1
            rho, g, wn, we, wd = env.atm[i, :5]
            u0 = float(controls(np.array(0.0))[0])
            x0[:, 3] = wn
            x0[:, 4] = we
            x0[:, 5] = wd + self.steady_descent_rate(X, rho, g, min(max(u0, 0.0), 1.0))
        else:
            x0[:, 3:6] = np.asarray(initial.velocity)
        x_max = np.full(_NS, np.inf)
        x_max[0:3] = 1e7
        x_max[3:6] = 1_000.0
        y = allocate_outputs(n, n_steps, stride, len(self.outputs))
        _kernel(
            np.ascontiguousarray(x0),
            P,
            controls.times,
            controls.values,
            controls.mode,
            env.atm,
            env.gust,
            float(dt),
            int(n_steps),
            int(stride),
            x_max,
            y,
            status,
            t_fail,
        )
        return y


class RocketDescentCdS(RocketDescent):
    """:class:`RocketDescent` with the drag areas themselves as parameters (m²).

    Parameters
    ----------
    mass : float
        Descending mass, kg (default 16.881 kg, the Prometheus rocket as in
        :class:`RocketDescent`; state the rocket's own: the steady descent rate scales with
        sqrt(m)).
    body_drag_area : float
        Fixed drag area of the body C_D S, m² (default 0).
    drag_convention : {"adds", "replaces"}
        What the main's drag area means (see the module docstring); default ``"adds"``.
    initial_speed : {"data", "steady"}
        As in :class:`RocketDescent`.

    Notes
    -----
    Parameters: ``cds_drogue`` and ``cds_main``, m². With a canopy of nominal diameter D its
    drag coefficient is C_D = C_D S / (π D² / 4).
    """

    name = "rocket-descent-cds"
    parameters = (
        Parameter("cds_drogue", 0.5, 0.01, 5.0, "m²", "drogue drag area C_D,d S_d"),
        Parameter(
            "cds_main", 5.0, 0.1, 50.0, "m²", "main drag area C_D,m S_m (see drag_convention)"
        ),
    )

    def __init__(
        self,
        *,
        mass: float = 13.9 + 2.981,
        body_drag_area: float = 0.0,
        drag_convention: str = "adds",
        initial_speed: str = "data",
    ) -> None:
        self._set_common(mass, body_drag_area, drag_convention, initial_speed)
        self.drogue_area = 1.0
        self.main_area = 1.0


# -- the data side: apogee, touchdown, trigger heights, noise -------------------------------------


def _series(t, h, what: str = "altitude") -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    t = np.asarray(t, dtype=float).ravel()
    h = np.asarray(h, dtype=float).ravel()
    if t.shape != h.shape:
        raise ValueError(f"{what}: t and h differ in length ({t.size} and {h.size})")
    if t.size < 5:
        raise ValueError(f"{what}: needs at least 5 samples, got {t.size}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(h))):
        raise ValueError(f"{what}: t and h must be finite (drop missing samples first)")
    if np.any(np.diff(t) <= 0):
        raise ValueError(f"{what}: t must be strictly increasing")
    return t, h


def _uniform(t, h, dt_max: float = 1.0):
    """The series on a uniform grid at its median sample interval (clipped to [0.01, dt_max] s)."""
    dt = float(np.clip(np.median(np.diff(t)), 0.01, dt_max))
    n = int(np.floor((t[-1] - t[0]) / dt + 1e-9)) + 1
    g = t[0] + dt * np.arange(n)
    return g, np.interp(g, t, h), dt


def _running_median(x: NDArray, n: int) -> NDArray:
    from scipy.ndimage import median_filter

    n = max(1, int(n)) | 1
    return median_filter(x, size=n, mode="nearest") if n > 1 else x.copy()


def _rate(s: NDArray, dt: float, half: int) -> NDArray:
    """Rate of change (per s) of ``s`` by differences over ±``half`` samples (one-sided at the
    ends)."""
    n = s.size
    idx = np.arange(n)
    lo = np.clip(idx - half, 0, n - 1)
    hi = np.clip(idx + half, 0, n - 1)
    span = (hi - lo) * dt
    return np.where(span > 0, (s[hi] - s[lo]) / np.where(span > 0, span, 1.0), 0.0)


def detect_apogee(t, h, *, smooth: float = 1.0) -> tuple[float, float]:
    """Apogee of an altitude series: the maximum of its running median.

    Parameters
    ----------
    t, h : array_like
        Times (s, strictly increasing) and altitudes (m).
    smooth : float
        Width of the running median, s (ejection spikes shorter than half of it are ignored).

    Returns
    -------
    time, altitude : float
        s and m.
    """
    t, h = _series(t, h)
    g, hg, dt = _uniform(t, h)
    s = _running_median(hg, round(smooth / dt))
    i = int(np.argmax(s))
    # a running median flattens the top of the curve: the vertex of a parabola through it
    near = np.abs(g - g[i]) <= smooth
    if near.sum() >= 5:
        c = np.polyfit(g[near] - g[i], s[near], 2)
        if c[0] < 0:
            tv = -c[1] / (2 * c[0])
            if abs(tv) <= smooth:
                return float(g[i] + tv), float(s[i])
    return float(g[i]), float(s[i])


def crossing_time(t, h, level: float, *, after: float | None = None, smooth: float = 1.0):
    """First time after ``after`` (default: the apogee) at which the altitude, smoothed by a
    running median of ``smooth`` s, comes down through ``level`` (m). None if it never does.
    """
    t, h = _series(t, h)
    if after is None:
        after = detect_apogee(t, h, smooth=smooth)[0]
    g, hg, dt = _uniform(t, h)
    s = _running_median(hg, round(smooth / dt))
    sel = np.flatnonzero(g >= after)
    if sel.size < 2:
        return None
    below = np.flatnonzero(s[sel] <= level)
    if below.size == 0:
        return None
    k = int(sel[below[0]])
    if k == sel[0]:
        return float(g[k])
    h0, h1 = s[k - 1], s[k]
    frac = 0.0 if h0 == h1 else (h0 - level) / (h0 - h1)
    return float(g[k - 1] + frac * dt)


@dataclass(frozen=True)
class RateBound:
    """The closest a descent whose rate never increases comes to an altitude series.

    Attributes
    ----------
    rms : float
        Smallest altitude RMS (m) over the comparison grid of any such descent.
    rate_first, rate_last : float
        Its descent rates at the start and the end, m/s.
    """

    rms: float
    rate_first: float
    rate_last: float


def monotone_rate_bound(t, h, grid) -> RateBound:
    """A lower bound of the altitude RMS of any constant-drag descent in still air.

    A point mass of constant drag area falling in still air at (or above) its steady rate
    slows down as the air thickens: its descent rate never increases (in pressure height as
    well, in any atmosphere without an inversion steeper than about 20 K/km). The altitude
    curve of *any* such descent, whatever its drag area, mass, atmosphere and initial state,
    is therefore one of h₀ − ∫v dt with v non-increasing, and none comes closer to the data
    than the best of those: the least-squares fit (``scipy.optimize.lsq_linear``) of h₀ and
    a rate that is constant between grid points and never increases, to the data sampled on
    the comparison grid (as the criteria sample them). A residual above it is the
    identification's; the bound itself is what the data hold that no such descent follows
    (measurement error slower than the grid, vertical air motion, a drag area that changes).

    Parameters
    ----------
    t, h : array_like
        Times (s) and altitudes (m) covering the grid.
    grid : array_like
        Comparison grid, s (increasing, at least 3 points).

    Returns
    -------
    RateBound
    """
    from scipy.optimize import lsq_linear

    t, h = _series(t, h)
    grid = np.asarray(grid, dtype=float)
    if grid.size < 3 or np.any(np.diff(grid) <= 0):
        raise ValueError("monotone_rate_bound: the grid needs at least 3 increasing points")
    y = np.interp(grid, t, h)
    n = grid.size - 1  # one rate per interval
    step = np.diff(grid)
    # rate of interval i = r_last + sum of the non-negative decrements after it
    # r_i = r_last + sum_{j > i} e_j, e_j = r_{j-1} - r_j >= 0: columns r_last, e_1..e_{n-1}
    B = np.triu(np.ones((n, n)), k=1)
    B[:, 0] = 1.0
    drop = np.zeros((grid.size, n))  # altitude lost by grid point k: sum_{i<k} step_i r_i
    drop[1:] = np.tril(np.ones((n, n))) * step[None, :]
    A = np.hstack([np.ones((grid.size, 1)), -drop @ B])
    lb = np.r_[-np.inf, -np.inf, np.zeros(n - 1)]
    fit = lsq_linear(A, y, bounds=(lb, np.full(n + 1, np.inf)), method="bvls")
    rate = B @ fit.x[1:]
    res = A @ fit.x - y
    return RateBound(float(np.sqrt(np.mean(res**2))), float(rate[0]), float(rate[-1]))


@dataclass(frozen=True)
class FastVariation:
    """How much of one altimeter's fast variation another altimeter of the same flight shares.

    Attributes
    ----------
    rms, rms_ref : float
        RMS (m) of each series about its own local quadratic trend.
    correlation : float
        Correlation of the two residuals (at the reference's sample times).
    span : float
        Width of the local trend, s.
    """

    rms: float
    rms_ref: float
    correlation: float
    span: float


def fast_variation(t, h, t_ref, h_ref, t0: float, t1: float, span: float = 20.0):
    """Compare the variation of two altitude series faster than ``span`` s over [t0, t1].

    Each series is put on a 0.1-s grid and its local quadratic trend (Savitzky–Golay over
    ``span`` s) is removed; the residuals are read at the reference's sample times (the
    first and last ``span``/2 s left out, where the trends are extrapolated). Real motion
    faster than the trend shows in both; the error of one instrument only in its own (a
    barometer against the GPS heights of the same log).

    Parameters
    ----------
    t, h : array_like
        The series examined (e.g. barometric heights), s and m.
    t_ref, h_ref : array_like
        The reference (e.g. GPS heights), s and m.
    t0, t1 : float
        s.
    span : float
        s.

    Returns
    -------
    FastVariation or None
        None when [t0, t1] is shorter than 3 ``span`` or holds fewer than 10 reference
        samples.
    """
    from scipy.signal import savgol_filter

    t, h = _series(t, h)
    t_ref, h_ref = _series(t_ref, h_ref, "reference altitude")
    lo, hi = max(t0, t[0], t_ref[0]), min(t1, t[-1], t_ref[-1])
    if hi - lo < 3 * span:
        return None
    step = 0.1
    grid = np.arange(lo, hi + 1e-9, step)
    n = round(span / step) | 1
    at = t_ref[(t_ref >= lo + span / 2) & (t_ref <= hi - span / 2)]
    if at.size < 10:
        return None
    out = []
    for tt, hh in ((t, h), (t_ref, h_ref)):
        y = np.interp(grid, tt, hh)
        out.append(np.interp(at, grid, y - savgol_filter(y, n, 2)))
    a, b = out
    return FastVariation(
        float(np.sqrt(np.mean(a**2))),
        float(np.sqrt(np.mean(b**2))),
        float(np.corrcoef(a, b)[0, 1]),
        float(span),
    )


@dataclass(frozen=True)
class Touchdown:
    """Where a descent ends on the ground, read from the altitude alone.

    Attributes
    ----------
    time : float
        Touchdown, s: where the descent line meets the ground level (a continuous two-segment
        fit, descending then level, around the settling).
    ground : float
        Altitude the data read on the ground, m.
    rate : float
        Descent rate just before touchdown, m/s (the fit's slope).
    settled : float
        Time from which the vertical speed stays settled to the end of the data, s.
    after : float
        Seconds of data after touchdown.
    """

    time: float
    ground: float
    rate: float
    settled: float
    after: float


def detect_touchdown(
    t,
    h,
    *,
    after: float | None = None,
    smooth: float = 1.0,
    settle_speed: float = 1.0,
    settle_fraction: float = 0.25,
    hold: float = 1.0,
    fit_span: float = 8.0,
) -> Touchdown | None:
    """Touchdown of a descent from its altitude series: where altitude and vertical speed
    settle, not where a logger's state machine says "landed" (often many seconds later).

    The altitude is put on a uniform grid and smoothed by a running median of ``smooth`` s;
    its vertical speed is the difference over ±``smooth`` s. The descent has *settled* at the
    first time after ``after`` from which the speed stays below
    ``max(settle_speed, settle_fraction × descent rate)`` to the end of the data (the descent
    rate is the median over the 5 s before), with at least ``hold`` s of data left and a
    descent rate above twice ``settle_speed`` before it. A continuous two-segment line
    (descending, then level) fitted to the raw samples from ``fit_span`` s before to 3 s
    after that time places the touchdown where the two meet.

    Parameters
    ----------
    t, h : array_like
        Times (s, strictly increasing) and altitudes (m) of the whole log or its descent.
    after : float, optional
        Search from this time, s (default: the apogee).
    smooth, settle_speed, settle_fraction, hold, fit_span : float
        As above (s, m/s, -, s, s).

    Returns
    -------
    Touchdown or None
        None when the data end before the descent settles (a log that stops in the air, or
        one that stops less than about ``smooth + hold`` s after touchdown).
    """
    t, h = _series(t, h)
    if after is None:
        after = detect_apogee(t, h, smooth=smooth)[0]
    g, hg, dt = _uniform(t, h)
    s = _running_median(hg, round(smooth / dt))
    v = _rate(s, dt, max(1, round(smooth / dt)))
    start = int(np.searchsorted(g, after))
    if g.size - start < 3:
        return None
    speed = np.abs(v)
    # largest speed from each sample to the end of the data
    tail_max = np.maximum.accumulate(speed[::-1])[::-1]
    w = max(1, round(5.0 / dt))
    gap = max(1, round(smooth / dt))
    found = None
    for i in range(start + gap, g.size):
        if g[-1] - g[i] < hold:
            break
        before = -v[max(start, i - gap - w) : i - gap]
        if before.size == 0:
            continue
        rate = float(np.median(before))
        if rate < 2 * settle_speed:
            continue
        if tail_max[i] < max(settle_speed, settle_fraction * rate):
            found = i
            break
    if found is None:
        return None
    t_set = float(g[found])
    sel = (t >= t_set - fit_span) & (t <= min(t_set + 3.0, t[-1]))
    ts, hs = t[sel], h[sel]
    if ts.size < 5:
        return None
    # continuous hinge h = g0 + r * min(t - tau, 0): linear in (g0, r) for each tau
    cand = ts[(ts > ts[0] + 0.5) & (ts <= t_set)]
    if cand.size == 0:
        return None
    best = (np.inf, float(t_set), 0.0, 0.0)
    for tau in cand:
        A = np.stack([np.ones_like(ts), np.minimum(ts - tau, 0.0)], axis=1)
        coef, *_ = np.linalg.lstsq(A, hs, rcond=None)
        sse = float(np.sum((A @ coef - hs) ** 2))
        if sse < best[0]:
            best = (sse, float(tau), float(coef[0]), float(coef[1]))
    _, tau, ground, slope = best
    return Touchdown(time=tau, ground=ground, rate=slope, settled=t_set, after=float(t[-1] - tau))


@dataclass(frozen=True)
class RateChange:
    """A change of drag area during a descent (a canopy opening, or losing one), read from the
    altitude alone.

    Attributes
    ----------
    time : float
        Where the descent rate, scaled to one density, steps from one level to the other, s.
    altitude : float
        Altitude of the data there, m.
    rate_before, rate_after : float
        Steady descent rates (m/s, positive down) before and after, both scaled to the density
        at ``altitude``.
    """

    time: float
    altitude: float
    rate_before: float
    rate_after: float

    @property
    def drag_area_ratio(self) -> float:
        """Drag area after the change over the drag area before, (v_before / v_after)² (the
        steady descent rate at one density scales with 1/sqrt(C_D S))."""
        return (self.rate_before / self.rate_after) ** 2


def detect_rate_change(
    t,
    h,
    t0: float,
    t1: float,
    *,
    origin_altitude: float = 0.0,
    margin: float = 2.0,
    min_ratio: float = 1.2,
) -> RateChange | None:
    """The largest change of drag area between ``t0`` and ``t1`` (s).

    The altitude is smoothed (running median of 1 s on a grid of at least 0.1 s), its descent
    rate v (differences over ±1 s) is scaled to sea-level density, v sqrt(ρ(h) / ρ(0)) in ISA
    air (constant for a constant drag area), and split into two constant levels where that
    fits best (least squares; the split at least ``margin`` s from the ends).

    Parameters
    ----------
    t, h : array_like
        Times (s) and altitudes (m above ``origin_altitude``).
    t0, t1 : float
        Span searched, s.
    origin_altitude : float
        Altitude of the data's zero above mean sea level, m (for the density).
    margin : float
        s.
    min_ratio : float
        Smallest drag-area ratio (larger over smaller) reported as a change.

    Returns
    -------
    RateChange or None
        None when the drag areas of the two levels differ by less than ``min_ratio``, or the
        span is too short.
    """
    from vectorid.models.atmosphere import ISA

    t, h = _series(t, h)
    sel = (t >= t0) & (t <= t1)
    if sel.sum() < 10 or t1 - t0 < 3 * margin:
        return None
    g, hg, dt = _uniform(t[sel], h[sel], dt_max=1.0)
    if dt < 0.1:
        g2 = np.arange(g[0], g[-1], 0.1)
        hg, g, dt = np.interp(g2, g, hg), g2, 0.1
    s = _running_median(hg, round(1.0 / dt))
    v = -_rate(s, dt, max(1, round(1.0 / dt)))
    isa = ISA()
    rho = isa.density(origin_altitude + s)
    rho0 = float(isa.density(0.0))
    veq = v * np.sqrt(rho / rho0)
    n = veq.size
    m = max(2, round(margin / dt))
    if n < 2 * m + 2:
        return None
    c1 = np.cumsum(veq)
    c2 = np.cumsum(veq**2)
    k = np.arange(m, n - m)  # split before index k
    n1, n2 = k.astype(float), (n - k).astype(float)
    s1, s2 = c1[k - 1], c1[-1] - c1[k - 1]
    q1, q2 = c2[k - 1], c2[-1] - c2[k - 1]
    sse = (q1 - s1**2 / n1) + (q2 - s2**2 / n2)
    j = int(np.argmin(sse))
    kb = int(k[j])
    a, b = s1[j] / n1[j], s2[j] / n2[j]
    if min(a, b) <= 0 or max(a, b) ** 2 < min_ratio * min(a, b) ** 2:
        return None
    scale = float(np.sqrt(rho0 / rho[kb]))
    return RateChange(
        time=float(g[kb]), altitude=float(s[kb]), rate_before=a * scale, rate_after=b * scale
    )
