"""Adequacy criteria: how close simulated channels are to the measured ones (batch first).

Every criterion compares a batch of simulated signals with one measurement on a common time grid:
``fn(sim, meas, t) -> (n,)`` with ``sim`` of shape (n, T, m), ``meas`` (T, m) and ``t`` (T,) in s.
The registry :data:`CRITERIA` holds the 15 criteria of Table I of seed 001 (under the names of
seed 000's study files) and a few more; :data:`INDICES` holds scalar indices Φ of one signal that
combine with the operators ℜ of seed 000 eq. (11) (:data:`OPERATORS`) into criteria named
``"index:operator"`` (e.g. ``"yaw_rate_max:ratio"``).

Residual sums are integrals over the window (trapezoidal rule on the given grid), not plain sums
over samples: ``Σ_k |r_k|`` of the seed equals ``∫|r| dt / dt`` on a uniform grid, so the two
differ by a constant factor there (same Pareto set, same ranking), but the integral does not
change with the sampling rate and stays meaningful on non-uniform grids and when drops logged at
different rates are averaged. Units are therefore channel unit × s (m·s, rad·s, m²·s, ...).

Angle residuals (Euler angles, course) are wrapped to (-π, π] before use, so a yaw of 359° against
1° is a residual of 2°, not 358°. Yaw rates are the time derivative of the unwrapped yaw
(``numpy.gradient`` on the grid, second order), not the body rate r.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vectorid.errors import VectoridError, suggest
from vectorid.identify.spectral import (
    eigenfrequencies,
    resample_uniform,
    spectral_peak,
    spectrum_distance,
)

__all__ = [
    "CRITERIA",
    "DEFAULT_SPECTRAL_BAND",
    "HEADING_MIN_SPEED",
    "INDICES",
    "MIN_COLUMNS",
    "OPERATORS",
    "CriterionDef",
    "CriterionError",
    "IndexDef",
    "dropout",
    "evaluate_criteria",
    "get_criterion",
    "integrate",
    "make_index_criterion",
    "spectral_defs",
    "wrap_angle",
]

#: Below this measured horizontal speed (m/s) the course is undefined and ``heading_profile``
#: ignores the sample.
HEADING_MIN_SPEED = 0.5


class CriterionError(VectoridError, ValueError):
    """A criterion name, operator or the arrays given to a criterion are invalid."""


Array = NDArray[np.float64]


@dataclass(frozen=True)
class CriterionDef:
    """An adequacy criterion: simulated batch vs one measurement of a channel.

    Parameters
    ----------
    name : str
        Registry name, e.g. ``"pos_h_abs"``.
    channel : str
        Channel it reads (standard names: position, velocity, euler, rates, altitude, controls).
    meaning : str
        Formula and physical meaning, one line.
    unit : str
        Unit of the criterion value.
    fn : callable
        ``fn(sim (n, T, m), meas (T, m), t (T,)) -> (n,)``; smaller is closer.
    """

    name: str
    channel: str
    meaning: str
    unit: str
    fn: Callable[[Array, Array, Array], Array]


@dataclass(frozen=True)
class IndexDef:
    """A scalar index Φ of one signal (seed 000 eq. 11), computed batch-wise.

    ``fn(x (n, T, m), t (T,)) -> (n,)``; the measurement is passed as a batch of one.
    """

    name: str
    channel: str
    meaning: str
    unit: str
    fn: Callable[[Array, Array], Array]


# --------------------------------------------------------------------------- helpers


def wrap_angle(a: ArrayLike) -> Array:
    """Angles wrapped to (-π, π], rad."""
    a = np.asarray(a, dtype=float)
    return np.pi - np.mod(np.pi - a, 2 * np.pi)


def _weights(t: Array) -> Array:
    """Trapezoidal weights w with ∫ f dt ≈ Σ w_k f_k."""
    dt = np.diff(t)
    w = np.zeros(t.size)
    w[:-1] += dt / 2
    w[1:] += dt / 2
    return w


def integrate(f: ArrayLike, t: ArrayLike) -> Array:
    """∫ f dt along the last axis of ``f`` (..., T) by the trapezoidal rule, -> (...)."""
    f = np.asarray(f, dtype=float)
    return f @ _weights(np.asarray(t, dtype=float))


def _yaw_rate(x: Array, t: Array) -> Array:
    """dψ/dt of the unwrapped yaw (column 2 of the Euler angles), (n, T)."""
    psi = np.unwrap(x[:, :, 2], axis=1)
    return np.gradient(psi, t, axis=1)


def _hnorm(d: Array) -> Array:
    return np.hypot(d[:, :, 0], d[:, :, 1])


def _need_cols(name: str, x: Array, m: int) -> None:
    if x.shape[-1] < m:
        raise CriterionError(
            f"criterion {name!r} needs at least {m} columns in its channel, got {x.shape[-1]}"
        )


# --------------------------------------------------------------------------- residual criteria


def _resid(sim: Array, meas: Array, cols: slice | int, angular: bool = False) -> Array:
    d = sim[:, :, cols] - meas[None, :, cols]
    return wrap_angle(d) if angular else d


def _pos_h_abs(sim: Array, meas: Array, t: Array) -> Array:
    return integrate(_hnorm(_resid(sim, meas, slice(0, 2))), t)


def _pos_h_sq(sim: Array, meas: Array, t: Array) -> Array:
    return integrate(_hnorm(_resid(sim, meas, slice(0, 2))) ** 2, t)


def _col_abs(col: int, angular: bool = False, power: int = 1) -> Callable[..., Array]:
    def fn(sim: Array, meas: Array, t: Array) -> Array:
        return integrate(np.abs(_resid(sim, meas, col, angular)) ** power, t)

    return fn


def _yaw_rate_index(kind: str) -> Callable[[Array, Array], Array]:
    def fn(x: Array, t: Array) -> Array:
        r = _yaw_rate(x, t)
        if kind == "max":
            return r.max(axis=1)
        if kind == "min":
            return r.min(axis=1)
        return integrate(r, t) / (t[-1] - t[0])

    return fn


def _freq_index(col: int, unwrap: bool = False) -> Callable[[Array, Array], Array]:
    def fn(x: Array, t: Array) -> Array:
        s = x[:, :, col]
        if unwrap:
            s = np.unwrap(s, axis=1)
        _, su, fs = resample_uniform(t, s)
        return eigenfrequencies(su, fs)[:, 0]

    return fn


def _descent_rate_avg(x: Array, t: Array) -> Array:
    return (x[:, 0, 0] - x[:, -1, 0]) / (t[-1] - t[0])


def _speed_avg(x: Array, t: Array) -> Array:
    return integrate(np.hypot(x[:, :, 0], x[:, :, 1]), t) / (t[-1] - t[0])


def _drift(x: Array, t: Array) -> Array:
    return np.hypot(x[:, -1, 0] - x[:, 0, 0], x[:, -1, 1] - x[:, 0, 1])


def _index_absdiff(index: Callable[[Array, Array], Array]) -> Callable[..., Array]:
    def fn(sim: Array, meas: Array, t: Array) -> Array:
        return np.abs(index(sim, t) - index(meas[None], t)[0])

    return fn


def _paired(meas: Array) -> Array:
    """``meas`` as (1, T, m) for one measurement against every simulation, or as given when
    it is (n, T, m): one measurement per simulation (the noise floor's draws)."""
    return meas if meas.ndim == 3 else meas[None]


def _speed_profile(sim: Array, meas: Array, t: Array) -> Array:
    return integrate(np.abs(_hnorm(sim) - _hnorm(_paired(meas))), t)


def _heading_profile(sim: Array, meas: Array, t: Array) -> Array:
    m = _paired(meas)
    chi = np.arctan2(sim[:, :, 1], sim[:, :, 0])
    chi_m = np.arctan2(m[:, :, 1], m[:, :, 0])
    mask = (_hnorm(m) >= HEADING_MIN_SPEED).astype(float)
    return integrate(np.abs(wrap_angle(chi - chi_m)) * mask, t)


def _control_response(sim: Array, meas: Array, t: Array) -> Array:
    return integrate(np.abs(_yaw_rate(sim, t) - _yaw_rate(_paired(meas), t)), t)


def _vz_abs(sim: Array, meas: Array, t: Array) -> Array:
    vs = np.gradient(sim[:, :, 0], t, axis=1)
    vm = np.gradient(meas[:, 0], t)
    return integrate(np.abs(vs - vm[None]), t)


def _landing_error(sim: Array, meas: Array, t: Array) -> Array:
    return np.hypot(sim[:, -1, 0] - meas[-1, 0], sim[:, -1, 1] - meas[-1, 1])


INDICES: dict[str, IndexDef] = {
    d.name: d
    for d in [
        IndexDef("yaw_rate_max", "euler", "max over the window of dψ/dt", "rad/s",
                 _yaw_rate_index("max")),
        IndexDef("yaw_rate_min", "euler", "min over the window of dψ/dt", "rad/s",
                 _yaw_rate_index("min")),
        IndexDef("yaw_rate_avg", "euler", "time average of dψ/dt = ∫ψ' dt / (tf - t0)", "rad/s",
                 _yaw_rate_index("avg")),
        IndexDef("freq_roll", "euler", "dominant frequency of roll φ (Welch PSD peak)", "Hz",
                 _freq_index(0)),
        IndexDef("freq_pitch", "euler", "dominant frequency of pitch θ (Welch PSD peak)", "Hz",
                 _freq_index(1)),
        IndexDef("freq_yaw", "euler",
                 "dominant frequency of unwrapped, linearly detrended yaw ψ (Welch PSD peak)",
                 "Hz", _freq_index(2, unwrap=True)),
        IndexDef("descent_rate_avg", "altitude", "(h(t0) - h(tf)) / (tf - t0)", "m/s",
                 _descent_rate_avg),
        IndexDef("speed_avg", "velocity", "time average of horizontal speed |v_h|", "m/s",
                 _speed_avg),
        IndexDef("drift", "position", "horizontal distance between start and end points", "m",
                 _drift),
    ]
}  # fmt: skip


# --------------------------------------------------------------------------- spectral criteria
# Seed 000 §VII: "three criteria relating to the adequacy of the natural eigenvalues (power
# spectrum) for all channels (roll, pitch and yaw)". Two forms on each channel, from the robust
# estimates of vectorid.identify.spectral (Hann-windowed Welch segments, linear detrending,
# zero padding): the peak frequency inside a band, and the distance between the spectral
# shapes (band-power shares) inside it. Roll, pitch and yaw read the body rates p, q, r (free of
# the turns' ramps); phi, theta, psi the Euler angles (yaw unwrapped). A band is given as a
# suffix of the name: "peak_yaw@0.25-1.5" searches 0.25-1.5 Hz.

#: Band (Hz) of the spectral criteria when the name gives none: 0.05 Hz (below it a drop's
#: window holds too few cycles) up to the Nyquist frequency of the comparison grid.
DEFAULT_SPECTRAL_BAND = (0.05, None)

_SPECTRAL_CHANNELS = {
    "roll": ("rates", 0, False, "body roll rate p"),
    "pitch": ("rates", 1, False, "body pitch rate q"),
    "yaw": ("rates", 2, False, "body yaw rate r"),
    "phi": ("euler", 0, False, "roll angle φ"),
    "theta": ("euler", 1, False, "pitch angle θ"),
    "psi": ("euler", 2, True, "unwrapped yaw angle ψ"),
}


def _parse_band(name: str) -> tuple[str, tuple[float, float | None] | None]:
    """``"base@lo-hi"`` -> (base, (lo, hi)); a name without ``@`` -> (name, None)."""
    if "@" not in name:
        return name, None
    base, _, spec = name.partition("@")
    parts = spec.split("-")
    try:
        if len(parts) != 2:
            raise ValueError
        lo, hi = float(parts[0]), float(parts[1])
    except ValueError:
        raise CriterionError(
            f"criterion {name!r}: the band after '@' must be 'low-high' in Hz, e.g. "
            f"'{base}@0.25-1.5'"
        ) from None
    if not (0 <= lo < hi):
        raise CriterionError(f"criterion {name!r}: the band needs 0 <= low < high Hz")
    return base, (lo, hi)


def _signal(x: Array, t: Array, col: int, unwrap: bool) -> tuple[Array, float]:
    s = x[:, :, col]
    if unwrap:
        s = np.unwrap(s, axis=1)
    _, su, fs = resample_uniform(t, s)
    return su, fs


def _band_for(band: tuple[float, float | None] | None, fs: float) -> tuple[float, float]:
    lo, hi = band if band is not None else DEFAULT_SPECTRAL_BAND
    nyq = fs / 2
    hi = nyq if hi is None else min(float(hi), nyq)
    if not lo < hi:
        raise CriterionError(
            f"spectral band [{lo:g}, {hi:g}] Hz is empty at a comparison rate of {fs:g} Hz "
            f"(Nyquist {nyq:g} Hz); lower the band or the output_dt"
        )
    return float(lo), float(hi)


def _peak_index(kind: str, band=None) -> Callable[[Array, Array], Array]:
    _, col, unwrap, _ = _SPECTRAL_CHANNELS[kind]

    def fn(x: Array, t: Array) -> Array:
        s, fs = _signal(x, t, col, unwrap)
        return spectral_peak(s, fs, band=_band_for(band, fs), whiten=True)

    return fn


def _shape_criterion(kind: str, band=None) -> Callable[[Array, Array, Array], Array]:
    _, col, unwrap, _ = _SPECTRAL_CHANNELS[kind]

    def fn(sim: Array, meas: Array, t: Array) -> Array:
        s, fs = _signal(sim, t, col, unwrap)
        m, _ = _signal(meas[None], t, col, unwrap)
        return spectrum_distance(s, m[0], fs, band=_band_for(band, fs))

    return fn


def spectral_defs(name: str) -> tuple[IndexDef | None, CriterionDef | None]:
    """The index and criterion of a spectral name (with an optional band), or (None, None)."""
    base, band = _parse_band(name)
    form, _, kind = base.partition("_")
    if form not in ("peak", "band") or kind not in _SPECTRAL_CHANNELS:
        return None, None
    channel, _, _, what = _SPECTRAL_CHANNELS[kind]
    where = "in the band {:g}-{:g} Hz".format(*band) if band else "above 0.05 Hz (default band)"
    if form == "peak":
        idx = IndexDef(name, channel, f"peak frequency of the {what} spectrum {where}", "Hz",
                       _peak_index(kind, band))  # fmt: skip
        meaning = f"|f_peak - f̂_peak| of the {what} (whitened Welch PSD peak {where})"
        crit = CriterionDef(name, channel, meaning, "Hz", _index_absdiff(idx.fn))
        return idx, crit
    crit = CriterionDef(name, channel,
                        f"spectral shape distance of the {what} {where}: mean |Δ ln share| over "
                        "6 log-spaced sub-bands", "1", _shape_criterion(kind, band))  # fmt: skip
    return None, crit


CRITERIA: dict[str, CriterionDef] = {
    d.name: d
    for d in [
        # Table I of seed 001, criteria 1-15
        CriterionDef("pos_h_abs", "position", "1: ∫ |P_H - P̂_H| dt, horizontal distance", "m·s",
                     _pos_h_abs),
        CriterionDef("pos_h_sq", "position", "2: ∫ |P_H - P̂_H|² dt", "m²·s", _pos_h_sq),
        CriterionDef("pos_v_abs", "position", "3: ∫ |P_V - P̂_V| dt (down component)", "m·s",
                     _col_abs(2)),
        CriterionDef("vel_h_abs", "velocity", "4: ∫ |V_H - V̂_H| dt, horizontal vector", "m",
                     lambda s, m, t: integrate(_hnorm(_resid(s, m, slice(0, 2))), t)),
        CriterionDef("vel_v_abs", "velocity", "5: ∫ |V_V - V̂_V| dt (down component)", "m",
                     _col_abs(2)),
        CriterionDef("roll_abs", "euler", "6: ∫ |wrap(φ - φ̂)| dt", "rad·s", _col_abs(0, True)),
        CriterionDef("pitch_abs", "euler", "7: ∫ |wrap(θ - θ̂)| dt", "rad·s", _col_abs(1, True)),
        CriterionDef("yaw_abs", "euler", "8: ∫ |wrap(ψ - ψ̂)| dt", "rad·s", _col_abs(2, True)),
        CriterionDef("yaw_sq", "euler", "9: ∫ wrap(ψ - ψ̂)² dt", "rad²·s",
                     _col_abs(2, True, power=2)),
        CriterionDef("yaw_rate_max", "euler", "10: |max ψ' - max ψ̂'|", "rad/s",
                     _index_absdiff(INDICES["yaw_rate_max"].fn)),
        CriterionDef("yaw_rate_min", "euler", "11: |min ψ' - min ψ̂'|", "rad/s",
                     _index_absdiff(INDICES["yaw_rate_min"].fn)),
        CriterionDef("yaw_rate_avg", "euler", "12: |avg ψ' - avg ψ̂'|", "rad/s",
                     _index_absdiff(INDICES["yaw_rate_avg"].fn)),
        CriterionDef("freq_roll", "euler", "13: |f_eig(φ) - f_eig(φ̂)| (Welch peak)", "Hz",
                     _index_absdiff(INDICES["freq_roll"].fn)),
        CriterionDef("freq_pitch", "euler", "14: |f_eig(θ) - f_eig(θ̂)| (Welch peak)", "Hz",
                     _index_absdiff(INDICES["freq_pitch"].fn)),
        CriterionDef("freq_yaw", "euler", "15: |f_eig(ψ) - f_eig(ψ̂)| (Welch peak)", "Hz",
                     _index_absdiff(INDICES["freq_yaw"].fn)),
        # others (seed 000 and this project)
        CriterionDef("pos_v_sq", "position", "∫ (P_V - P̂_V)² dt", "m²·s", _col_abs(2, power=2)),
        CriterionDef("speed_profile", "velocity", "∫ | |V_H| - |V̂_H| | dt, horizontal speed",
                     "m", _speed_profile),
        CriterionDef("heading_profile", "velocity",
                     "∫ |wrap(χ - χ̂)| dt, course χ = atan2(v_e, v_n), where |V̂_H| >= 0.5 m/s",
                     "rad·s", _heading_profile),
        CriterionDef("control_response", "euler",
                     "∫ |ψ' - ψ̂'| dt, turn-rate response (window it on the control actions)",
                     "rad", _control_response),
        CriterionDef("alt_abs", "altitude", "∫ |h - ĥ| dt", "m·s", _col_abs(0)),
        CriterionDef("alt_sq", "altitude", "∫ (h - ĥ)² dt", "m²·s", _col_abs(0, power=2)),
        CriterionDef("vz_abs", "altitude", "∫ |h' - ĥ'| dt, vertical speed from altitude", "m",
                     _vz_abs),
        CriterionDef("landing_error", "position", "|P_H(tf) - P̂_H(tf)|, final horizontal miss",
                     "m", _landing_error),
    ]
}  # fmt: skip

for _kind in _SPECTRAL_CHANNELS:
    _i, _c = spectral_defs(f"peak_{_kind}")
    INDICES[_i.name] = _i
    CRITERIA[_c.name] = _c
    CRITERIA[f"band_{_kind}"] = spectral_defs(f"band_{_kind}")[1]

#: Fewest components of a channel a library criterion reads (an own model's channels are
#: scalars: only a criterion on a one-component channel applies to one).
MIN_COLUMNS = {
    "position": 3,
    "velocity": 3,
    "euler": 3,
    "altitude": 1,
}


# --------------------------------------------------------------------------- operators


def _absdiff(phi_m: ArrayLike, phi_exp: ArrayLike) -> Array:
    return np.abs(np.asarray(phi_m, float) - np.asarray(phi_exp, float))


def _nonzero(phi_exp: ArrayLike, op: str) -> Array:
    b = np.asarray(phi_exp, float)
    if np.any(b == 0):
        raise CriterionError(
            f"operator {op!r} divides by the measured index, which is 0; use 'absdiff' for an "
            "index that can be zero"
        )
    return b


def _ratio(phi_m: ArrayLike, phi_exp: ArrayLike) -> Array:
    return np.asarray(phi_m, float) / _nonzero(phi_exp, "ratio")


def _relerr(phi_m: ArrayLike, phi_exp: ArrayLike) -> Array:
    b = _nonzero(phi_exp, "relerr")
    return np.abs(np.asarray(phi_m, float) - b) / np.abs(b)


def _logratio(phi_m: ArrayLike, phi_exp: ArrayLike) -> Array:
    b = _nonzero(phi_exp, "logratio")
    a = np.asarray(phi_m, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.abs(np.log(a / b))
    return np.where(a / b > 0, r, np.inf)


#: Operators ℜ(Φ^m, Φ^exp) of seed 000 eq. (11), batch-wise: (n,) and scalar -> (n,).
#: ``ratio`` is 1 at a perfect match (constrain it around 1 rather than minimise it);
#: ``logratio`` = |ln(Φ^m / Φ^exp)| is the symmetric, minimisable form of the ratio.
OPERATORS: dict[str, Callable[[ArrayLike, ArrayLike], Array]] = {
    "absdiff": _absdiff,
    "ratio": _ratio,
    "relerr": _relerr,
    "logratio": _logratio,
}


def make_index_criterion(index: str, operator: str = "absdiff") -> CriterionDef:
    """The criterion ℜ(Φ^m, Φ^exp) of index ``index`` with operator ``operator``.

    Its name is ``"index:operator"``; ``evaluate_criteria`` accepts such names directly.
    """
    if index not in INDICES and "@" in index and spectral_defs(index)[0] is not None:
        idx_def = spectral_defs(index)[0]
    elif index not in INDICES:
        raise CriterionError(f"unknown index {index!r}; {suggest(index, INDICES)}")
    else:
        idx_def = INDICES[index]
    if operator not in OPERATORS:
        raise CriterionError(f"unknown operator {operator!r}; {suggest(operator, OPERATORS)}")
    idx = idx_def
    op = OPERATORS[operator]

    def fn(sim: Array, meas: Array, t: Array) -> Array:
        return op(idx.fn(sim, t), idx.fn(meas[None], t)[0])

    unit = idx.unit if operator == "absdiff" else "1"
    return CriterionDef(f"{index}:{operator}", idx.channel, f"{operator}({idx.meaning})", unit, fn)


def get_criterion(name: str) -> CriterionDef:
    """A criterion by registry name or ``"index:operator"``."""
    if name in CRITERIA:
        return CRITERIA[name]
    if "@" in name and ":" not in name:
        crit = spectral_defs(name)[1]
        if crit is None:
            base = name.partition("@")[0]
            spectral = [c for c in CRITERIA if c.startswith(("peak_", "band_"))]
            raise CriterionError(
                f"unknown criterion {name!r}: a band suffix '@low-high' applies to the spectral "
                f"criteria only ({suggest(base, spectral)})"
            )
        return crit
    if ":" in name:
        index, operator = name.split(":", 1)
        return make_index_criterion(index, operator)
    raise CriterionError(
        f"unknown criterion {name!r}; {suggest(name, CRITERIA)}; or 'index:operator' with an "
        f"index in {sorted(INDICES)} and an operator in {sorted(OPERATORS)}"
    )


# --------------------------------------------------------------------------- evaluation


def _as_meas(key: str, x: ArrayLike, T: int) -> Array:
    a = np.asarray(x, dtype=float)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2 or a.shape[0] != T:
        raise CriterionError(
            f"measured {key!r}: expected shape ({T}, m) on the {T}-point grid, got {a.shape}"
        )
    if not np.all(np.isfinite(a)):
        k = int(np.flatnonzero(~np.all(np.isfinite(a), axis=1))[0])
        raise CriterionError(
            f"measured {key!r} has NaN/inf at grid point {k}; interpolate the measurement onto "
            "a grid inside its data (FlightData.sample)"
        )
    return a


def _as_sim(key: str, x: ArrayLike, T: int, m: int) -> Array:
    a = np.asarray(x, dtype=float)
    if a.ndim == 2 and m == 1:
        a = a[:, :, None]
    if a.ndim != 3 or a.shape[1] != T or a.shape[2] != m:
        raise CriterionError(
            f"simulated {key!r}: expected shape (n, {T}, {m}) to match the measurement, "
            f"got {a.shape}"
        )
    return a


def _as_grid(t: ArrayLike) -> Array:
    tt = np.asarray(t, dtype=float)
    if tt.ndim != 1 or tt.size < 2:
        raise CriterionError(f"expected a time grid of shape (T,) with T >= 2, got {tt.shape}")
    if not (np.all(np.isfinite(tt)) and np.all(np.diff(tt) > 0)):
        raise CriterionError("the time grid must be finite and strictly increasing (s)")
    return tt


def evaluate_criteria(
    names: Sequence[str],
    sim: Mapping[str, ArrayLike],
    meas: Mapping[str, ArrayLike],
    t: ArrayLike,
    *,
    channels: Mapping[str, str] | None = None,
) -> Array:
    """Evaluate criteria for a batch of simulations against one measurement.

    Parameters
    ----------
    names : sequence of str
        Criterion names from :data:`CRITERIA` or ``"index:operator"``.
    sim : mapping of str to array, shape (n, T, m) (or (n, T) for one column)
        Simulated channels on the grid ``t``.
    meas : mapping of str to array, shape (T, m) (or (T,))
        Measured channels on the same grid, finite.
    t : array_like, shape (T,)
        The common time grid, s, strictly increasing.
    channels : mapping of str to str, optional
        Per-criterion channel override (criterion name -> key in ``sim``/``meas``), e.g. to
        apply ``alt_abs`` to a channel stored under another name.

    Returns
    -------
    ndarray, shape (n, len(names))
        Criterion values; NaN where the trial's simulated channel contains NaN/inf (a failed
        trial).
    """
    tt = _as_grid(t)
    T = tt.size
    defs = [get_criterion(n) for n in names]
    over = dict(channels or {})
    n_trials: int | None = None
    cache: dict[str, tuple[Array, Array, NDArray[np.bool_]]] = {}
    cols = []
    for d in defs:
        key = over.get(d.name, d.channel)
        if key not in cache:
            if key not in meas:
                raise CriterionError(
                    f"criterion {d.name!r} needs measured channel {key!r}; {suggest(key, meas)}"
                )
            if key not in sim:
                raise CriterionError(
                    f"criterion {d.name!r} needs simulated channel {key!r}; {suggest(key, sim)}"
                )
            mm = _as_meas(key, meas[key], T)
            ss = _as_sim(key, sim[key], T, mm.shape[1])
            if n_trials is None:
                n_trials = ss.shape[0]
            elif ss.shape[0] != n_trials:
                raise CriterionError(
                    f"simulated {key!r} has {ss.shape[0]} trials, other channels {n_trials}"
                )
            ok = np.all(np.isfinite(ss), axis=(1, 2))
            cache[key] = (ss, mm, ok)
        ss, mm, ok = cache[key]
        need = MIN_COLUMNS.get(d.channel, 1)
        _need_cols(d.name, mm, need)
        col = np.full(ss.shape[0], np.nan)
        if np.any(ok):
            col[ok] = d.fn(ss[ok], mm, tt)
        cols.append(col)
    if not cols:
        return np.empty((0 if n_trials is None else n_trials, 0))
    return np.stack(cols, axis=1)


def dropout(
    sim: ArrayLike, meas: ArrayLike, band: float | ArrayLike, *, angular: bool = False
) -> Array:
    """Drop-out of seed 001 Fig. 2: how far a simulated channel leaves an envelope.

    The envelope is ``meas ± band`` at every grid point and column. The result is
    ``max(0, max_{t, j} (|sim - meas| - band))``: 0 when the trial stays inside, otherwise its
    largest excursion beyond the envelope (channel unit). Used as a functional constraint
    ``dropout <= 0``, it makes infeasible a trial that leaves the envelope even briefly, however
    small its integral criteria.

    Parameters
    ----------
    sim : array_like, shape (n, T, m) or (n, T)
        Simulated channel on the grid.
    meas : array_like, shape (T, m) or (T,)
        Measured channel on the same grid.
    band : float or array_like broadcastable to (T, m)
        Half-width of the envelope (>= 0): a scalar, one value per column (m,), or per grid
        point (T, m) (or (T, 1)).
    angular : bool
        Wrap differences to (-π, π] (for angles in rad).

    Returns
    -------
    ndarray, shape (n,)
        NaN for a trial with NaN/inf in ``sim``.
    """
    mm = np.asarray(meas, dtype=float)
    if mm.ndim == 1:
        mm = mm[:, None]
    if mm.ndim != 2:
        raise CriterionError(f"meas: expected shape (T, m), got {mm.shape}")
    T, m = mm.shape
    ss = _as_sim("dropout", sim, T, m)
    if not np.all(np.isfinite(mm)):
        raise CriterionError("meas contains NaN/inf; sample the measurement inside its data")
    b = np.asarray(band, dtype=float)
    try:
        bb = np.broadcast_to(b, (T, m))
    except ValueError:
        raise CriterionError(
            f"band: expected a scalar, shape ({m},) or ({T}, {m}) (or ({T}, 1)), got {b.shape}"
        ) from None
    if not (np.all(np.isfinite(bb)) and np.all(bb >= 0)):
        raise CriterionError("band must be finite and >= 0 (half-width of the envelope)")
    d = ss - mm[None]
    if angular:
        d = wrap_angle(d)
    ok = np.all(np.isfinite(ss), axis=(1, 2))
    out = np.full(ss.shape[0], np.nan)
    if np.any(ok):
        exc = (np.abs(d[ok]) - bb[None]).max(axis=(1, 2))
        out[ok] = np.maximum(exc, 0.0)
    return out
