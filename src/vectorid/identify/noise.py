"""Measurement noise and the criteria constraints it implies (noise floors).

In the PSI method the criteria constraints Φ** say how close the model must come to the
measurements. Where the measurement noise is known, the closest a *perfect* model can come is
known too: the value a criterion takes when the model is exact and only the noise differs —
its **noise floor**. A limit at the floor (at a stated quantile) keeps in the feasible set D
every parameter vector that the data cannot tell from the truth, and no more; a
**discrepancy** allowance adds what the expert grants the model for what it does not
represent (gusts, actuator lag, ...), in the spirit of history matching's implausibility
cut-off.

The study file
--------------
::

    [identification]
    noise = { position_h = 1.5, position_v = 3.0, velocity = 0.15, euler_deg = 0.5,
              rates = 0.01 }                 # one σ per channel key (one line in TOML)
    # noise = "estimate"                    # σ of each channel from its high-frequency residual
    limits = "noise"                        # every criterion without a number gets its floor
    # noise_quantile = 0.99                 # per-criterion quantile (default: joint coverage)
    # noise_coverage = 0.95                 # joint coverage of the floors (default 0.95)
    # noise_draws = 2000                    # Monte Carlo draws (default 2000)
    # noise_seed = 0
    discrepancy = { position_h = 20.0 }     # model-discrepancy allowance (see below)

    [[criteria]]
    name = "pos_h_abs"
    limit = "noise"                         # this criterion only (instead of limits = "noise")

    [[identification.drops]]
    noise = { position_v = 5.0 }            # per drop: overrides the study-level keys

Noise keys (values in the key's unit; a number is the σ of white noise, a table
``{ sigma = 1.5, correlation_time = 20.0, white = 0.2 }`` is a first-order Gauss–Markov
error of σ ``sigma`` and correlation time ``correlation_time`` s plus white noise of σ
``white``): ``position_h`` (m, north and east each), ``position_v`` (m, down),
``position`` (m, all three), ``velocity`` / ``velocity_h`` / ``velocity_v`` (m/s),
``euler`` (rad) or ``euler_deg`` (deg), ``rates`` (rad/s) or ``rates_deg`` (deg/s),
``altitude`` (m).

The floor (:func:`noise_floor`): a seeded Monte Carlo of the twin experiment the noise
statement describes, through the study's own criterion functions on the drop's own sample
times and comparison grid. For each draw: noise is drawn at every sample of each channel
(white, or Gauss–Markov with the exact discretisation for uneven steps), the "truth" is the
model's own trajectory from the drop's initial state, the measurement is truth + noise
interpolated onto the comparison grid as the real data are, the initial state is re-fitted
to the noisy data by the same least-squares lines as the identification's (so a noisy
start is part of the floor), and the "perfect model" is flown from that fitted state. The
propagation of the initial-state error is linearised (central differences over the twelve
initial-state components, 25 simulations per drop and wind realisation instead of one per
draw: the model takes one initial state per batch); :func:`noise_floor` with
``linear=False`` flies each draw, and the test suite checks that both agree. With
``wind_realisations = M > 1`` the truth flies in the measured profile and the model in each
realisation, so the floor of the expectation criterion includes the wind uncertainty.

Quantile (:meth:`NoiseFloor.limits`): with ``noise_quantile`` unset, one per-criterion
quantile level q is found such that all constrained criteria are below their q-quantiles
together in ``noise_coverage`` (95 %) of the draws — a joint Monte Carlo rather than Šidák's
q = 0.95^(1/K), because the criteria share the same noise (``pos_h_abs`` and ``pos_h_sq`` are
almost the same statistic) and Šidák, which assumes independence, would over-cover. The
limit's note states q, the coverage, the draws and the allowance.

Discrepancy allowance (same keys and units as the noise, or a criterion name in the
criterion's unit): a channel allowance δ is a bound on the model's deviation from the truth
in that channel (the horizontal distance for ``*_h`` keys, each axis otherwise), converted
per criterion by the triangle inequality: ∫|e + d| ≤ ∫|e| + δ·T for the absolute-residual
criteria (δ in time-mean form with window variables), (√∫e² + δ√T)² for the squared ones
(Minkowski), + δ for the final miss; applied draw by draw before the quantile. Criteria that
no channel bound limits (frequencies, rate extremes, indices) take an allowance only under
their own name. A criterion-name allowance is added to the limit.

The estimator (``noise = "estimate"``, :func:`estimate_sigma`): σ̂ = 1.4826 MAD(Δ³y) / √20,
the robust spread of the third differences of each component, scaled by Var(Δ³n) =
C(6, 3) σ² = 20σ² for white noise n; on unevenly spaced samples (a logger that writes rows at
jittered times) the third divided differences, each divided by the norm of its weights, which
have variance σ² whatever the steps. The third difference removes a smooth signal (it leaves
s'''·Δt³) and the MAD (recomputed without the differences beyond 5 σ̂) ignores spikes;
differences across a gap (a step over twice the median) are left out. Only the channels the
drop's criteria and its initial-state fit read are estimated. It sees the *white* part of
the noise: a correlated error slower than the sampling (a GPS position error of 20 s
correlation time) is indistinguishable from motion and is estimated as its small
high-frequency share (:func:`highfreq_sigma` gives it); state such errors explicitly, or
grant them as discrepancy.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vectorid.errors import StudyDefinitionError, suggest

__all__ = [
    "DISCREPANCY_RULES",
    "NOISE_KEYS",
    "ComponentNoise",
    "NoiseFloor",
    "NoiseModel",
    "estimate_correlated",
    "estimate_noise",
    "estimate_sigma",
    "highfreq_sigma",
    "noise_floor",
    "noise_limits",
    "parse_discrepancy",
    "parse_noise",
    "resolve_noise_limits",
]

_DEG = math.pi / 180.0

#: Noise keys: key -> (channel, component indices, factor to SI, unit of the key).
NOISE_KEYS: dict[str, tuple[str, tuple[int, ...], float, str]] = {
    "position": ("position", (0, 1, 2), 1.0, "m"),
    "position_h": ("position", (0, 1), 1.0, "m"),
    "position_v": ("position", (2,), 1.0, "m"),
    "velocity": ("velocity", (0, 1, 2), 1.0, "m/s"),
    "velocity_h": ("velocity", (0, 1), 1.0, "m/s"),
    "velocity_v": ("velocity", (2,), 1.0, "m/s"),
    "euler": ("euler", (0, 1, 2), 1.0, "rad"),
    "euler_deg": ("euler", (0, 1, 2), _DEG, "deg"),
    "rates": ("rates", (0, 1, 2), 1.0, "rad/s"),
    "rates_deg": ("rates", (0, 1, 2), _DEG, "deg/s"),
    "altitude": ("altitude", (0,), 1.0, "m"),
}
#: Which noise key a channel's components are reported under (for notes and estimates).
_REPORT_KEYS = {
    "position": ("position_h", "position_h", "position_v"),
    "velocity": ("velocity_h", "velocity_h", "velocity_v"),
    "euler": ("euler", "euler", "euler"),
    "rates": ("rates", "rates", "rates"),
    "altitude": ("altitude",),
}

#: How a channel allowance δ bounds each library criterion: name -> (channel, components,
#: kind) with kind "abs" (∫|e| grows by at most δ·T), "sq" ((√∫e² + δ√T)²) or "point" (+ δ).
#: The horizontal criteria take the horizontal distance (``*_h`` keys); the others one axis.
DISCREPANCY_RULES: dict[str, tuple[str, tuple[int, ...], str]] = {
    "pos_h_abs": ("position", (0, 1), "abs"),
    "pos_h_sq": ("position", (0, 1), "sq"),
    "pos_v_abs": ("position", (2,), "abs"),
    "pos_v_sq": ("position", (2,), "sq"),
    "vel_h_abs": ("velocity", (0, 1), "abs"),
    "vel_v_abs": ("velocity", (2,), "abs"),
    "speed_profile": ("velocity", (0, 1), "abs"),
    "roll_abs": ("euler", (0,), "abs"),
    "pitch_abs": ("euler", (1,), "abs"),
    "yaw_abs": ("euler", (2,), "abs"),
    "yaw_sq": ("euler", (2,), "sq"),
    "alt_abs": ("altitude", (0,), "abs"),
    "alt_sq": ("altitude", (0,), "sq"),
    "landing_error": ("position", (0, 1), "point"),
}

#: Library criteria that depend on the residual sim − meas only: evaluated for all draws in
#: one call as crit(sim − noise, truth). The others are evaluated draw by draw.
_RESIDUAL_ONLY = frozenset(
    {
        "pos_h_abs",
        "pos_h_sq",
        "pos_v_abs",
        "pos_v_sq",
        "vel_h_abs",
        "vel_v_abs",
        "roll_abs",
        "pitch_abs",
        "yaw_abs",
        "yaw_sq",
        "alt_abs",
        "alt_sq",
        "vz_abs",
        "landing_error",
    }
)


def _err(field_: str, problem: str, fix: str = "") -> StudyDefinitionError:
    return StudyDefinitionError(f"identification.{field_}", problem, fix)


# -- the noise statement ------------------------------------------------------------------------


@dataclass(frozen=True)
class ComponentNoise:
    """The noise of one channel component, in SI units of the channel.

    Attributes
    ----------
    sigma : float
        Standard deviation of the correlated part (white when ``correlation_time`` is 0).
    correlation_time : float
        s; > 0: a first-order Gauss–Markov process (autocorrelation exp(-|Δt|/τ)).
    white : float
        Standard deviation of an added white part.
    """

    sigma: float
    correlation_time: float = 0.0
    white: float = 0.0

    @property
    def total(self) -> float:
        """Standard deviation of the whole error."""
        return math.hypot(self.sigma, self.white)

    def draw(self, t: NDArray[np.float64], n: int, rng: np.random.Generator) -> NDArray:
        """``n`` seeded realisations at the sample times ``t`` (T,), shape (n, T)."""
        T = t.size
        if self.correlation_time > 0 and self.sigma > 0:
            a = np.exp(-np.diff(t) / self.correlation_time)
            out = np.empty((n, T))
            out[:, 0] = rng.normal(0.0, self.sigma, n)
            xi = rng.normal(0.0, 1.0, (n, T - 1))
            b = self.sigma * np.sqrt(1.0 - a * a)
            for k in range(1, T):
                out[:, k] = a[k - 1] * out[:, k - 1] + b[k - 1] * xi[:, k - 1]
        else:
            out = rng.normal(0.0, self.sigma, (n, T)) if self.sigma > 0 else np.zeros((n, T))
        if self.white > 0:
            out += rng.normal(0.0, self.white, (n, T))
        return out

    def describe(self, factor: float = 1.0, unit: str = "") -> str:
        u = f" {unit}" if unit else ""
        if self.correlation_time > 0:
            text = f"{self.sigma / factor:.3g}{u} (τ {self.correlation_time:.3g} s)"
            if self.white > 0:
                text += f" + {self.white / factor:.3g}{u} white"
            return text
        return f"{self.total / factor:.3g}{u}"


@dataclass
class NoiseModel:
    """Stated or estimated noise of a drop's channels: channel -> one entry per component
    (None where nothing is stated)."""

    channels: dict[str, list[ComponentNoise | None]] = field(default_factory=dict)
    estimated: bool = False

    def component(self, channel: str, j: int) -> ComponentNoise | None:
        comps = self.channels.get(channel)
        return None if comps is None or j >= len(comps) else comps[j]

    def merged(self, other: NoiseModel) -> NoiseModel:
        """This model with ``other``'s stated components replacing its own."""
        out = {k: list(v) for k, v in self.channels.items()}
        for ch, comps in other.channels.items():
            cur = out.setdefault(ch, [None] * len(comps))
            cur += [None] * (len(comps) - len(cur))
            for j, c in enumerate(comps):
                if c is not None:
                    cur[j] = c
        return NoiseModel(out, self.estimated or other.estimated)

    def describe(self) -> str:
        """One line: the noise by key in the key's unit."""
        parts = []
        for ch, keys in _REPORT_KEYS.items():
            comps = self.channels.get(ch)
            if not comps:
                continue
            seen: dict[str, str] = {}
            for j, key in enumerate(keys):
                c = comps[j] if j < len(comps) else None
                if c is None:
                    continue
                factor, unit = (_DEG, "deg") if ch == "euler" else (1.0, NOISE_KEYS[key][3])
                if ch == "rates":
                    unit = "rad/s"
                label = "euler" if ch == "euler" else key
                seen.setdefault(label, c.describe(factor, unit))
            parts += [f"{k} {v}" for k, v in seen.items()]
        for ch, comps in self.channels.items():
            if ch not in _REPORT_KEYS and any(c is not None for c in comps):
                c = next(c for c in comps if c is not None)
                parts.append(f"{ch} {c.describe()}")
        head = "estimated " if self.estimated else ""
        return head + (", ".join(parts) if parts else "none")


def _component(where: str, value: Any, factor: float) -> ComponentNoise:
    if isinstance(value, Mapping):
        bad = [k for k in value if k not in ("sigma", "correlation_time", "white")]
        if bad:
            raise _err(
                f"{where}.{bad[0]}",
                f"unknown key {bad[0]!r}",
                suggest(bad[0], ["sigma", "correlation_time", "white"]),
            )
        sigma = _nonneg(f"{where}.sigma", value.get("sigma", 0.0))
        tau = _nonneg(f"{where}.correlation_time", value.get("correlation_time", 0.0))
        white = _nonneg(f"{where}.white", value.get("white", 0.0))
        if sigma == 0 and white == 0:
            raise _err(where, "sigma and white are both 0", "state the noise's σ")
        return ComponentNoise(sigma * factor, tau, white * factor)
    return ComponentNoise(_nonneg(where, value) * factor)


def _nonneg(where: str, value: Any) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    if isinstance(value, bool) or not (v >= 0 and math.isfinite(v)):
        raise _err(where, f"expected a number >= 0, got {value!r}", "e.g. 1.5")
    return v


def parse_noise(value: Any, where: str = "noise") -> NoiseModel | str:
    """A noise statement from the study file: a table of noise keys, or ``"estimate"``.

    Returns
    -------
    NoiseModel or "estimate"

    Raises
    ------
    StudyDefinitionError
        Unknown key (with the nearest valid one), negative or non-numeric σ.
    """
    if isinstance(value, str):
        if value != "estimate":
            raise _err(
                where,
                f'expected a table of σ per channel or "estimate", got {value!r}',
                'write noise = { position_h = 1.5, ... } or noise = "estimate"',
            )
        return "estimate"
    if not isinstance(value, Mapping):
        raise _err(
            where,
            f"expected a table of σ per channel, got {value!r}",
            "write noise = { position_h = 1.5, position_v = 3.0, velocity = 0.15 }",
        )
    out: dict[str, list[ComponentNoise | None]] = {}
    for key, v in value.items():
        if key not in NOISE_KEYS:
            raise _err(
                f"{where}.{key}",
                f"unknown noise key {key!r}",
                suggest(key, list(NOISE_KEYS)) + f" (keys: {', '.join(NOISE_KEYS)})",
            )
        ch, comps, factor, _ = NOISE_KEYS[key]
        c = _component(f"{where}.{key}", v, factor)
        cur = out.setdefault(ch, [None] * (max(comps) + 1))
        cur += [None] * (max(comps) + 1 - len(cur))
        for j in comps:
            cur[j] = c
    return NoiseModel(out)


def parse_discrepancy(value: Any, criteria: Sequence[str], where: str = "discrepancy") -> dict:
    """A discrepancy table: noise keys (channel allowances, SI after conversion) and criterion
    names (allowances in the criterion's unit). Returns ``{"channels": {channel: [δ per
    component]}, "criteria": {name: δ}}``."""
    if value is None:
        return {"channels": {}, "criteria": {}}
    if not isinstance(value, Mapping):
        raise _err(
            where, f"expected a table, got {value!r}", "write discrepancy = { position_h = 20.0 }"
        )
    chans: dict[str, list[float]] = {}
    crits: dict[str, float] = {}
    for key, v in value.items():
        if key in NOISE_KEYS:
            ch, comps, factor, _ = NOISE_KEYS[key]
            d = _nonneg(f"{where}.{key}", v) * factor
            cur = chans.setdefault(ch, [0.0] * (max(comps) + 1))
            cur += [0.0] * (max(comps) + 1 - len(cur))
            for j in comps:
                cur[j] = d
        elif key in criteria:
            crits[key] = _nonneg(f"{where}.{key}", v)
        else:
            raise _err(
                f"{where}.{key}",
                f"{key!r} is neither a noise key nor a criterion of the study",
                suggest(key, [*NOISE_KEYS, *criteria]),
            )
    return {"channels": chans, "criteria": crits}


# -- the estimator --------------------------------------------------------------------------------

_ORDER = 3
_MAD = 1.482602218505602  # 1 / Φ⁻¹(3/4): MAD -> σ for a normal distribution
#: Steps within this share of the median step count as regular (jittered time stamps).


def estimate_sigma(t: ArrayLike, y: ArrayLike, order: int = _ORDER) -> NDArray[np.float64]:
    """Standard deviation of the white measurement noise of each column of ``y``.

    σ̂ = 1.4826 · MAD(d), d the k-th differences (default k = 3) of consecutive samples,
    each divided by the norm of its weights: on evenly spaced samples d = Δᵏy / √C(2k, k)
    (the k-th difference of white noise has variance C(2k, k) σ²); on uneven ones the k-th
    divided difference Σⱼ wⱼ yⱼ, wⱼ = 1 / Πₗ≠ⱼ (tⱼ − tₗ), over ‖w‖, which has variance σ²
    for white noise whatever the steps (loggers whose rows come at jittered times). A
    smooth signal contributes s⁽ᵏ⁾Δtᵏ / k! · (k!/‖w‖Δtᵏ), negligible at the sampling rates of
    flight logs; the MAD, recomputed without the differences beyond 5 σ̂, ignores spikes.
    Differences that span a step outside [0.5, 2] × the
    median step (a gap, or two rows almost at one time) are left out. A correlated error
    slower than the sampling contributes only its high-frequency share
    (:func:`highfreq_sigma`).

    Parameters
    ----------
    t : (T,) float
        Sample times, s, increasing.
    y : (T,) or (T, m) float
        Samples.
    order : int
        k, the order of the differences.

    Returns
    -------
    (m,) float
        σ̂ per column, unit of ``y``; NaN when fewer than 10 differences are usable.
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    if y.ndim == 1:
        y = y[:, None]
    k = int(order)
    if t.size < k + 10:
        return np.full(y.shape[1], np.nan)
    dt = np.diff(t)
    med = float(np.median(dt))
    even = (dt >= 0.5 * med) & (dt <= 2.0 * med)
    # a k-th difference at i uses samples i..i+k: all k steps must be usable
    n = t.size - k
    ok = np.ones(n, dtype=bool)
    for j in range(k):
        ok &= even[j : j + n]
    if ok.sum() < 10:
        return np.full(y.shape[1], np.nan)
    # divided-difference weights w_j = 1 / prod_{l != j} (t_{i+j} - t_{i+l}), in units of the
    # median step (so that they stay of order one)
    tau = np.stack([t[j : j + n] for j in range(k + 1)]) / med  # (k+1, n)
    w = np.ones((k + 1, n))
    for j in range(k + 1):
        for m in range(k + 1):
            if m != j:
                w[j] /= tau[j] - tau[m]
    w /= np.sqrt(np.sum(w * w, axis=0))
    d = np.einsum("jn,jnc->nc", w, np.stack([y[j : j + n] for j in range(k + 1)]))[ok]
    out = np.empty(d.shape[1])
    for c in range(d.shape[1]):
        x = d[:, c]
        dev = np.abs(x - np.median(x))
        s0 = _MAD * np.median(dev)
        # one reweighting step: differences beyond 5 σ (spikes, each spoiling k + 1 of them)
        # are left out; for normal noise this trims nothing that matters (P < 1e-6)
        keep = dev <= 5.0 * s0 if s0 > 0 else np.ones(x.size, dtype=bool)
        x = x[keep]
        out[c] = _MAD * np.median(np.abs(x - np.median(x)))
    return out


def estimate_correlated(t: ArrayLike, y: ArrayLike, max_lag: float = 5.0) -> ComponentNoise | None:
    """White plus first-order Gauss–Markov noise of one series, from the variances of its
    third differences at increasing lags.

    On a uniform grid at the median step Δ, the third difference at lag k,
    y(t + 3kΔ) − 3y(t + 2kΔ) + 3y(t + kΔ) − y(t), removes a signal up to a quadratic (a
    descent that slows down) and has, for white noise of σ_w plus a Gauss–Markov error of σ_c
    and correlation time τ (ρ_j = exp(−jkΔ/τ)), the variance

        V(k) = 20 σ_w² + σ_c² (20 − 30 ρ_1 + 12 ρ_2 − 2 ρ_3).

    The robust variances (1.4826 MAD)² at lags Δ … ``max_lag`` are fitted by that curve
    (least squares on their logarithms, ``scipy.optimize.least_squares``). White noise gives
    a flat curve; an error correlated over a few samples (a logger's filter, a barometer whose
    static port feels the flow as the body swings) a curve that rises to its plateau over
    about τ — what the lag-1 differences of :func:`estimate_sigma` cannot see. Errors slower
    than ``max_lag`` are seen only in part, and real motion whose third derivative is large
    over 3 ``max_lag`` is counted as noise.

    Parameters
    ----------
    t, y : (T,) array_like
        Sample times (s, increasing) and values.
    max_lag : float
        Longest lag, s.

    Returns
    -------
    ComponentNoise or None
        ``ComponentNoise(σ_c, τ, σ_w)`` with τ between half a step and ``max_lag`` / 3 (a
        curve still rising at ``max_lag`` is given τ = ``max_lag`` / 3: an error slower than
        the lags is seen only in part); white noise only (``ComponentNoise(√(V(1)/20))``)
        when the fitted σ_c is under 0.3 σ_w or τ under half a step; None when the series
        holds fewer than 4 ``max_lag`` s or 4 lags.
    """
    from scipy.optimize import least_squares

    t = np.asarray(t, dtype=float).ravel()
    y = np.asarray(y, dtype=float).ravel()
    if t.size < 20 or t[-1] - t[0] < 4 * max_lag:
        return None
    step = float(np.median(np.diff(t)))
    K = int(max_lag / step + 1e-9)
    if K < 4:
        return None
    grid = np.arange(t[0], t[-1] + 1e-9, step)
    yg = np.interp(grid, t, y)
    lags = np.arange(1, K + 1)
    V = np.empty(K)
    n = yg.size
    for i, k in enumerate(lags):
        if n <= 3 * k + 10:
            return None
        d = yg[3 * k :] - 3 * yg[2 * k : n - k] + 3 * yg[k : n - 2 * k] - yg[: n - 3 * k]
        V[i] = (_MAD * np.median(np.abs(d - np.median(d)))) ** 2
    if not np.all(V > 0):
        return None

    def model(p):
        sw, sc, tau = np.exp(p)
        rho = np.exp(-lags * step / tau)
        return 20 * sw**2 + sc**2 * (20 - 30 * rho + 12 * rho**2 - 2 * rho**3)

    # τ at most max_lag / 3, so that the curve reaches its plateau within the lags; the σ's
    # within 1e-4 .. 1e2 of the scale
    v0 = float(V[0])
    scale = math.sqrt(float(V.max()) / 20)
    lo = np.log([1e-4 * scale, 1e-4 * scale, 0.5 * step])
    hi = np.log([1e2 * scale, 1e2 * scale, max_lag / 3])
    best = None
    for tau0 in (step, max_lag / 10, max_lag / 3.5):
        p0 = np.clip(np.log([math.sqrt(v0 / 20), scale, tau0]), lo + 1e-9, hi - 1e-9)
        fit = least_squares(lambda p: np.log(model(p)) - np.log(V), p0, bounds=(lo, hi))
        if best is None or fit.cost < best.cost:
            best = fit
    sw, sc, tau = (float(v) for v in np.exp(best.x))
    if sc < 0.3 * sw or tau < 0.55 * step:
        return ComponentNoise(math.sqrt(v0 / 20))
    return ComponentNoise(sc, tau, sw)


def highfreq_sigma(noise: ComponentNoise, dt: float, order: int = _ORDER) -> float:
    """What :func:`estimate_sigma` sees of ``noise`` sampled every ``dt`` s: the σ of white
    noise whose k-th differences have the same variance (exact for stationary noise)."""
    k = int(order)
    c = np.array([(-1) ** (k - i) * math.comb(k, i) for i in range(k + 1)], dtype=float)
    var = noise.white**2 * float(c @ c)
    if noise.correlation_time > 0:
        a = math.exp(-dt / noise.correlation_time)
        lag = np.abs(np.subtract.outer(np.arange(k + 1), np.arange(k + 1)))
        var += noise.sigma**2 * float(c @ (a**lag) @ c)
    else:
        var += noise.sigma**2 * float(c @ c)
    return math.sqrt(var / math.comb(2 * k, k))


def estimate_noise(flight, channels: Sequence[str] | None = None) -> NoiseModel:
    """White-noise σ of each component of a flight's channels (:func:`estimate_sigma`).

    ``flight`` is a :class:`~vectorid.identify.FlightData` (e.g. a drop's windowed data);
    ``channels`` default to all. A yaw that wraps is unwrapped first. Components whose
    estimate is not available (too few regularly spaced samples) stay unstated (None)."""
    out: dict[str, list[ComponentNoise | None]] = {}
    for name in channels or list(flight.channels):
        if name not in flight.channels:
            continue
        c = flight.channels[name]
        v = np.array(c.values)
        if name == "euler" and v.shape[1] >= 3:
            v[:, 2] = np.unwrap(v[:, 2])
        s = estimate_sigma(c.t, v)
        out[name] = [ComponentNoise(float(x)) if np.isfinite(x) else None for x in s]
    return NoiseModel(out, estimated=True)


# -- the floor ------------------------------------------------------------------------------------

#: Initial-state components and the steps of the central differences of the linearisation.
_STATE = (
    ("altitude", None, 1.0),
    ("north", None, 1.0),
    ("east", None, 1.0),
    ("velocity", 0, 0.1),
    ("velocity", 1, 0.1),
    ("velocity", 2, 0.1),
    ("euler", 0, 0.01),
    ("euler", 1, 0.01),
    ("euler", 2, 0.01),
    ("rates", 0, 0.01),
    ("rates", 1, 0.01),
    ("rates", 2, 0.01),
)


def _state_vector(s) -> NDArray[np.float64]:
    v = [s.altitude, s.north, s.east]
    v += list(s.velocity if s.velocity is not None else (0.0, 0.0, 0.0))
    v += list(s.euler) + list(s.rates)
    return np.array(v, dtype=float)


def _shift(s, delta: NDArray[np.float64]):
    """InitialState ``s`` moved by ``delta`` (12,) (order of ``_STATE``)."""
    vel = None if s.velocity is None else tuple(np.add(s.velocity, delta[3:6]))
    return replace(
        s,
        altitude=s.altitude + delta[0],
        north=s.north + delta[1],
        east=s.east + delta[2],
        velocity=vel,
        euler=tuple(np.add(s.euler, delta[6:9])),
        rates=tuple(np.add(s.rates, delta[9:12])),
    )


@dataclass
class NoiseFloor:
    """Criteria of a perfect model under the stated noise, draw by draw.

    Attributes
    ----------
    names : list of str
        The identification's criteria (columns of ``samples``).
    units : list of str
    samples : (draws, k) float
        Criterion values of the perfect model (discrepancy allowances of channels included).
    allowance : dict
        Criterion name -> allowance added to its limit (criterion-name discrepancy).
    notes : dict
        Criterion name -> what its floor includes (noise, discrepancy).
    draws, seed : int
    noise : dict
        Drop name -> the noise used, in words.
    """

    names: list[str]
    units: list[str]
    samples: NDArray[np.float64]
    allowance: dict[str, float]
    notes: dict[str, str]
    draws: int
    seed: int
    noise: dict[str, str]

    def quantile_level(self, names: Sequence[str], coverage: float = 0.95) -> float:
        """The per-criterion quantile level q at which all ``names`` are below their
        q-quantiles together in ``coverage`` of the draws (joint Monte Carlo)."""
        cols = [self.names.index(n) for n in names]
        S = self.samples[:, cols]
        if not len(cols):
            return float(coverage)
        lo, hi = float(coverage), 1.0

        def joint(q: float) -> float:
            lim = np.quantile(S, q, axis=0)
            return float(np.mean(np.all(S <= lim, axis=1)))

        if joint(lo) >= coverage:
            return lo
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            if joint(mid) >= coverage:
                hi = mid
            else:
                lo = mid
        return hi

    def limits(
        self,
        names: Sequence[str],
        *,
        quantile: float | None = None,
        coverage: float = 0.95,
    ) -> dict[str, tuple[float, str]]:
        """Limit and note of each of ``names``: the floor at ``quantile`` (default: the
        joint-coverage level of :meth:`quantile_level`) plus its allowance."""
        names = list(names)
        if quantile is None:
            q = self.quantile_level(names, coverage)
            how = f"q={q:.4g}, joint {coverage:.0%} over {len(names)} criteria"
        else:
            q = float(quantile)
            how = f"q={q:.4g}"
        out = {}
        for n in names:
            j = self.names.index(n)
            v = float(np.quantile(self.samples[:, j], q))
            extra = self.allowance.get(n, 0.0)
            note = f"noise floor {how}, {self.draws} draws"
            if self.notes.get(n):
                note += f"; {self.notes[n]}"
            if extra:
                u = f" {self.units[j]}" if self.units[j] else ""
                note += f" + {extra:.4g}{u} discrepancy"
            out[n] = (v + extra, note)
        return out


def _sim_channels(res, channels, origin_alt):
    from vectorid.identify.identification import _sim_channel

    return {ch: _sim_channel(res, ch, origin_alt) for ch in channels}


def _criterion_unit(ident, j: int) -> str:
    c = ident.criteria[j]
    u = ident.defs[j].unit
    if ident.window_vars and c.operator is None:
        from vectorid.identify.identification import INTEGRAL_CRITERIA

        if c.use in INTEGRAL_CRITERIA:
            return _time_mean_unit(u)
    return u


def _time_mean_unit(u: str) -> str:
    if u.endswith("·s"):
        return u[:-2]
    if u == "m" or u == "rad":  # ∫ m/s dt, ∫ rad/s dt
        return u + "/s"
    return f"{u}/s"


def noise_floor(
    ident,
    noise: NoiseModel | Mapping[str, NoiseModel] | str,
    *,
    draws: int = 2000,
    seed: int = 0,
    params: Mapping[str, float] | NDArray | None = None,
    discrepancy: Mapping[str, Any] | None = None,
    criteria: Sequence[str] | None = None,
    linear: bool = True,
) -> NoiseFloor:
    """Monte Carlo of the criteria of a perfect model under measurement noise.

    Parameters
    ----------
    ident : Identification
        The identification (model, drops, criteria, grid, winds).
    noise : NoiseModel, mapping drop name -> NoiseModel, or "estimate"
        The noise of each drop's channels (``"estimate"``: :func:`estimate_noise` on each
        drop's windowed data).
    draws, seed : int
        Monte Carlo draws and their seed.
    params : mapping or (p_model,) array, optional
        The "truth" flown by the model (default: the identification's base vector, i.e.
        nominal values and fixed parameters). The floor depends on it only through the
        propagation of the initial-state error and, for indices, through the signal.
    discrepancy : mapping, optional
        Parsed by :func:`parse_discrepancy` (or a raw table).
    criteria : sequence of str, optional
        Criteria to compute (default all); the others are NaN.
    linear : bool
        Linearised propagation of the initial-state error (default) or one simulation per
        draw.

    Raises
    ------
    StudyDefinitionError
        When a criterion reads a channel component without stated noise, or a channel
        allowance does not bound a criterion (say it under the criterion's name).
    """
    from vectorid.identify.identification import INTEGRAL_CRITERIA

    names = [c.name for c in ident.criteria]
    want = set(names if criteria is None else criteria)
    for n in want:
        if n not in names:
            raise _err("criteria", f"unknown criterion {n!r}", suggest(n, names))
    disc = (
        discrepancy
        if isinstance(discrepancy, Mapping) and "channels" in discrepancy
        else parse_discrepancy(discrepancy, names)
    )
    rng = np.random.default_rng(seed)
    if isinstance(params, Mapping):
        P = ident.base.copy()
        pn = list(ident.model.parameter_names)
        for k, v in params.items():
            if k in pn:
                P[pn.index(k)] = float(v)
    elif params is None:
        P = ident.base.copy()
    else:
        P = np.asarray(params, dtype=float).copy()
    k_all = len(names)
    total = np.zeros((draws, k_all))
    weight = np.zeros(k_all)
    notes: dict[str, str] = {}
    used_noise: dict[str, str] = {}
    for d in ident.drops:
        crit = [
            j
            for j, c in enumerate(ident.criteria)
            if (c.drops is None or d.name in c.drops) and c.name in want
        ]
        if not crit:
            continue
        nm = noise.get(d.name) if isinstance(noise, Mapping) else noise
        if isinstance(nm, str) or nm is None:
            if nm not in (None, "estimate"):
                raise _err("noise", f"unknown noise statement {nm!r}", 'use "estimate"')
            if nm is None:
                raise _err(
                    "noise",
                    f"no noise is stated for drop {d.name!r}",
                    'add noise = { ... } or noise = "estimate" under [identification]',
                )
            nm = estimate_noise(d.flight, _needed_channels(ident, d))
        used_noise[d.name] = nm.describe()
        chans = sorted({ident.defs[j].channel for j in crit})
        # every component a criterion reads must have a stated noise
        for j in crit:
            ch = ident.defs[j].channel
            m = d.flight[ch].m
            missing = [i for i in range(m) if nm.component(ch, i) is None]
            if missing:
                keys = sorted(
                    {k for k, v in NOISE_KEYS.items() if v[0] == ch and set(v[1]) & set(missing)}
                )
                raise _err(
                    "noise",
                    f"criterion {names[j]!r} reads channel {ch!r} of drop {d.name!r}, whose "
                    f"components {[d.flight[ch].components[i] for i in missing]} have no "
                    "stated noise",
                    f'add {" or ".join(keys) or ch} to noise = {{ ... }}, or noise = "estimate"',
                )
        grid = d.grid
        t0, span = float(grid[0]), float(d.init_span)
        noisy = [c for c in d.flight.channels if c in nm.channels]
        # the samples that matter: the two around each grid point (Channel.at interpolates
        # linearly) and those the initial-state fit reads; white noise is independent and a
        # Gauss-Markov process sampled on a subset of its times is still exactly Markov
        idx: dict[str, tuple[NDArray, NDArray, NDArray]] = {}
        need: dict[str, NDArray] = {}
        for ch in noisy:
            c = d.flight[ch]
            i = np.clip(np.searchsorted(c.t, grid, side="right") - 1, 0, max(c.t.size - 2, 0))
            j = np.minimum(i + 1, c.t.size - 1)
            reach = max(span, 3.0) if ch in ("position", "altitude") else span
            fit = np.flatnonzero((c.t >= t0 - 1e-9) & (c.t <= t0 + reach + 1e-9))
            need[ch] = np.unique(np.concatenate([i, j, fit]))
            idx[ch] = (i, j, fit)
        samples: dict[str, NDArray] = {}
        for ch in noisy:
            c = d.flight[ch]
            tt = c.t[need[ch]]
            arr = np.zeros((draws, tt.size, c.m))
            for k in range(c.m):
                cn = nm.component(ch, k)
                if cn is not None:
                    arr[:, :, k] = cn.draw(tt, draws, rng)
            samples[ch] = arr
        # ... interpolated onto the comparison grid as Channel.at does
        on_grid: dict[str, NDArray] = {}
        for ch in chans:
            c = d.flight[ch]
            if ch not in samples:
                on_grid[ch] = np.zeros((draws, grid.size, c.m))
                continue
            i, j, _ = idx[ch]
            dt_ = c.t[j] - c.t[i]
            w = np.where(dt_ > 0, (grid - c.t[i]) / np.where(dt_ > 0, dt_, 1.0), 0.0)
            pi, pj = np.searchsorted(need[ch], i), np.searchsorted(need[ch], j)
            arr = samples[ch]
            on_grid[ch] = (1 - w)[None, :, None] * arr[:, pi] + w[None, :, None] * arr[:, pj]
        # initial-state error: the identification's own fit applied to the noise alone
        fit_in = {
            ch: (d.flight[ch], idx[ch][2], np.searchsorted(need[ch], idx[ch][2]))
            for ch in _FIT_CHANNELS
            if ch in samples and idx[ch][2].size
        }
        for ch in _FIT_CHANNELS:  # noiseless channels the fit reads (zeros)
            if ch in d.flight.channels and ch not in fit_in:
                c = d.flight[ch]
                sel = np.flatnonzero((c.t >= t0 - 1e-9) & (c.t <= t0 + max(span, 3.0) + 1e-9))
                if sel.size:
                    fit_in[ch] = (c, sel, None)
        delta = _fit_errors(fit_in, samples, draws, t0, span)
        # ... plus the fit's own error on the truth's curved start (a line through a
        # transient or an oscillation is not its tangent): the same for every draw
        delta += _fit_bias(ident, P, d, t0, span)
        # the truth and the perfect model, per wind realisation
        winds = ident.winds[d.name]
        truth_res = _simulate(ident, P, d, d.wind, d.initial)
        truth = _sim_channels(truth_res, chans, d.origin_altitude)
        values = np.zeros((draws, len(crit)))
        for w in winds:
            if linear:
                base_res = truth_res if w is d.wind else _simulate(ident, P, d, w, d.initial)
                base = _sim_channels(base_res, chans, d.origin_altitude)
                jac = _jacobian(ident, P, d, w, chans)
                sims = {
                    ch: base[ch][0][None]
                    + (delta @ jac[ch].reshape(len(jac[ch]), -1)).reshape(draws, *jac[ch].shape[1:])
                    for ch in chans
                }
            else:
                sims = {ch: np.empty((draws, *truth[ch].shape[1:])) for ch in chans}
                for r in range(draws):
                    res = _simulate(ident, P, d, w, _shift(d.initial, delta[r]))
                    got = _sim_channels(res, chans, d.origin_altitude)
                    for ch in chans:
                        sims[ch][r] = got[ch][0]
            for jj, j in enumerate(crit):
                cdef, c = ident.defs[j], ident.criteria[j]
                ch = cdef.channel
                tr = truth[ch][0]
                if c.operator is None and c.use in _RESIDUAL_ONLY:
                    v = cdef.fn(sims[ch] - on_grid[ch], tr, grid)
                else:
                    v = _per_draw(cdef, c, sims[ch], tr[None] + on_grid[ch], grid)
                values[:, jj] += v
        values /= len(winds)
        L = float(grid[-1] - grid[0])
        mean_form = bool(ident.window_vars)
        for jj, j in enumerate(crit):
            c = ident.criteria[j]
            if mean_form and c.operator is None and c.use in INTEGRAL_CRITERIA:
                values[:, jj] /= L
            values[:, jj] = _allow(values[:, jj], c, d, disc, 1.0 if mean_form else L, notes)
        for jj, j in enumerate(crit):
            total[:, j] += d.weight * values[:, jj]
            weight[j] += d.weight
    samples_all = np.full((draws, k_all), np.nan)
    for j in range(k_all):
        if weight[j] > 0:
            samples_all[:, j] = total[:, j] / weight[j]
    units = [_criterion_unit(ident, j) for j in range(k_all)]
    allowance = {n: float(v) for n, v in disc["criteria"].items() if n in want}
    return NoiseFloor(
        names, units, samples_all, allowance, notes, int(draws), int(seed), used_noise
    )


_FIT_CHANNELS = ("position", "velocity", "euler", "rates", "altitude")


def _needed_channels(ident, d) -> list[str]:
    """The channels of drop ``d`` whose noise the floor uses: those its criteria read and
    those the initial-state fit reads (an estimate of the others would only lengthen notes)."""
    read = {
        ident.defs[j].channel
        for j, c in enumerate(ident.criteria)
        if c.drops is None or d.name in c.drops
    }
    return [ch for ch in d.flight.channels if ch in read or ch in _FIT_CHANNELS]


def _index_form(use: str, operator: str | None):
    """(index function, operator) of a criterion that compares one index Φ of the simulated
    signal with the same index of the measured one (seed 000 eq. 11: the spectral peaks
    ``peak_*``, and ``index:operator`` criteria), else None."""
    from vectorid.identify import criteria as cr

    idx = cr.INDICES.get(use)
    if idx is None and use.startswith("peak_"):
        idx = cr._spectral_defs(use)[0]
    if idx is None or (operator is None and not use.startswith("peak_")):
        return None
    return idx.fn, cr.OPERATORS["absdiff" if operator is None else operator]


def _per_draw(cdef, c, sims: NDArray, meas: NDArray, grid: NDArray) -> NDArray:
    """One criterion for every draw: ``sims`` and ``meas`` (draws, T, m), each draw's
    simulation against its own measurement. An index criterion takes two batched calls
    (the index of every simulation, the index of every measurement), checked against the
    criterion itself on three draws; any other is evaluated draw by draw."""

    def direct(r: int) -> float:
        return float(cdef.fn(sims[r][None], meas[r], grid)[0])

    form = _index_form(c.use, c.operator)
    if form is not None:
        index, op = form
        v = np.asarray(op(index(sims, grid), index(meas, grid)), dtype=float)
        check = [direct(r) for r in range(min(3, len(v)))]
        if np.allclose(check, v[: len(check)], rtol=1e-9, atol=1e-12, equal_nan=True):
            return v
    return np.array([direct(r) for r in range(sims.shape[0])])


def _fit_state(fit_in, values: Mapping[str, NDArray], t0: float, span: float):
    """The identification's initial-state fit (:func:`vectorid.identify.drops._initial_state`)
    on noise alone: ``values[ch]`` (n_fit, m) at the fit samples (zeros where absent)."""
    from vectorid.identify.drops import _initial_state
    from vectorid.identify.flight import Channel, FlightData

    chans = {}
    for ch, (c, sel, _) in fit_in.items():
        v = values.get(ch)
        v = np.zeros((sel.size, c.m)) if v is None else v
        chans[ch] = Channel(ch, c.t[sel], v, c.components, c.unit)
    return _state_vector(_initial_state(FlightData("noise", chans), t0, span, 0.0, None, "noise"))


def _fit_errors(fit_in, samples, draws: int, t0: float, span: float) -> NDArray:
    """Initial-state errors (draws, 12) of the noise draws.

    The fit is linear in the data, so its operator is read once by unit probes (one fit per
    fitted sample and component) and applied to every draw; three draws are checked against
    the fit itself, and a fit that is not linear falls back to one fit per draw."""
    if not fit_in or not any(pos is not None for _, _, pos in fit_in.values()):
        return np.zeros((draws, len(_STATE)))
    zero = _fit_state(fit_in, {}, t0, span)
    delta = np.zeros((draws, len(_STATE)))
    ops = {}
    for ch, (c, sel, pos) in fit_in.items():
        if pos is None:
            continue
        W = np.zeros((sel.size, c.m, len(_STATE)))
        for k in range(sel.size):
            for j in range(c.m):
                e = np.zeros((sel.size, c.m))
                e[k, j] = 1.0
                W[k, j] = _fit_state(fit_in, {ch: e}, t0, span) - zero
        ops[ch] = W
        delta += np.einsum("nkj,kjs->ns", samples[ch][:, pos], W)

    def direct(r: int) -> NDArray:
        vals = {ch: samples[ch][r][pos] for ch, (_, _, pos) in fit_in.items() if pos is not None}
        return _fit_state(fit_in, vals, t0, span) - zero

    scale = 1e-9 * (1.0 + float(np.abs(delta).max()))
    if all(np.allclose(direct(r), delta[r], rtol=1e-6, atol=scale) for r in range(min(3, draws))):
        return delta
    return np.stack([direct(r) for r in range(draws)])


def _fit_bias(ident, P, d, t0: float, span: float) -> NDArray:
    """Initial state fitted to the noiseless truth's samples minus the truth's own state,
    (12,): the truth flown at a fine output step over the fit span and read at the drop's
    sample times."""
    from vectorid.identify.drops import _initial_state
    from vectorid.identify.flight import Channel, FlightData

    chans_fit = [c for c in _FIT_CHANNELS if c in d.flight.channels]
    if not chans_fit:
        return np.zeros(len(_STATE))
    reach = max(span, 3.0)
    n = math.ceil(min(reach + 2 * ident.dt, d.duration) / ident.dt - 1e-9)
    res = ident.model.simulate(
        P[None, :],
        t_final=n * ident.dt,
        dt=ident.dt,
        inputs=d.inputs,
        wind=d.wind,
        output_dt=ident.dt,
        initial=d.initial,
        atmosphere=ident.atmosphere,
    )
    if res.status[0] != 0:
        return np.zeros(len(_STATE))
    sim = _sim_channels(res, chans_fit, d.origin_altitude)
    chans = {}
    for ch in chans_fit:
        c = d.flight[ch]
        sel = (c.t >= t0 - 1e-9) & (c.t <= t0 + reach + 1e-9) & (c.t <= t0 + res.t[-1] + 1e-9)
        if not sel.any():
            continue
        tt = c.t[sel]
        y = sim[ch][0]
        vals = np.column_stack([np.interp(tt - t0, res.t, y[:, j]) for j in range(y.shape[1])])
        chans[ch] = Channel(ch, tt, vals, c.components, c.unit)
    try:
        fitted = _initial_state(
            FlightData("truth", chans), t0, span, d.origin_altitude, d.wind, "noise floor"
        )
    except Exception:  # the fit needs channels the truth does not give: no bias term
        return np.zeros(len(_STATE))
    return _state_vector(fitted) - _state_vector(d.initial)


def _simulate(ident, P, d, wind, initial):
    res = ident.model.simulate(
        P[None, :],
        t_final=d.duration,
        dt=ident.dt,
        inputs=d.inputs,
        wind=wind,
        output_dt=ident.output_dt,
        initial=initial,
        atmosphere=ident.atmosphere,
    )
    if res.status[0] != 0:
        raise _err(
            "noise",
            f"the model failed on drop {d.name!r} with the reference parameters "
            f"({res.messages[0]}), so the noise floor cannot be computed",
            "give noise_floor(..., params=...) a vector that flies",
        )
    return res


def _jacobian(ident, P, d, wind, chans) -> dict[str, NDArray]:
    """d(channel trajectory)/d(initial state) by central differences, (12, T, m) each."""
    out = {ch: [] for ch in chans}
    for s, (_, _, h) in enumerate(_STATE):
        e = np.zeros(len(_STATE))
        e[s] = h
        plus = _sim_channels(
            _simulate(ident, P, d, wind, _shift(d.initial, e)), chans, d.origin_altitude
        )
        minus = _sim_channels(
            _simulate(ident, P, d, wind, _shift(d.initial, -e)), chans, d.origin_altitude
        )
        for ch in chans:
            out[ch].append((plus[ch][0] - minus[ch][0]) / (2 * h))
    return {ch: np.stack(v) for ch, v in out.items()}


def _allow(v: NDArray, c, d, disc: Mapping[str, Any], L: float, notes: dict[str, str]) -> NDArray:
    """Per-draw criterion values of one drop plus the channel allowance that bounds it."""
    chans = disc["channels"]
    if not chans:
        return v
    rule = DISCREPANCY_RULES.get(c.use) if c.operator is None else None
    if rule is None:
        from vectorid.identify.criteria import get_criterion

        key = c.use if c.operator is None else f"{c.use}:{c.operator}"
        ch = get_criterion(key).channel
        if ch in chans and any(chans[ch]) and c.name not in disc["criteria"]:
            raise _err(
                "discrepancy",
                f"a {ch} allowance does not bound criterion {c.name!r} ({key}: not a residual "
                "integral)",
                f"give its allowance in its own unit: discrepancy = {{ {c.name} = ... }}",
            )
        return v
    ch, comps, kind = rule
    per = chans.get(ch)
    if not per:
        return v
    delta = max(per[i] if i < len(per) else 0.0 for i in comps)
    if delta <= 0:
        return v
    if kind == "abs":
        out = v + delta * L
    elif kind == "sq":
        out = (np.sqrt(np.maximum(v, 0.0)) + delta * math.sqrt(L)) ** 2
    else:
        out = v + delta
    key, factor, unit = _ALLOWANCE_LABEL.get((ch, comps), (ch, 1.0, ""))
    notes[c.name] = f"discrepancy {key} {delta / factor:.3g} {unit}".rstrip()
    return out


_ALLOWANCE_LABEL = {
    ("position", (0, 1)): ("position_h", 1.0, "m"),
    ("position", (2,)): ("position_v", 1.0, "m"),
    ("velocity", (0, 1)): ("velocity_h", 1.0, "m/s"),
    ("velocity", (2,)): ("velocity_v", 1.0, "m/s"),
    ("euler", (0,)): ("euler_deg", _DEG, "deg"),
    ("euler", (1,)): ("euler_deg", _DEG, "deg"),
    ("euler", (2,)): ("euler_deg", _DEG, "deg"),
    ("altitude", (0,)): ("altitude", 1.0, "m"),
}


# -- from the study file ------------------------------------------------------------------------


def _noise_settings(spec) -> dict[str, Any]:
    table = spec.extra.get("identification", {})
    return {
        "noise": table.get("noise"),
        "limits": table.get("limits"),
        "quantile": table.get("noise_quantile"),
        "coverage": table.get("noise_coverage", 0.95),
        "draws": table.get("noise_draws", 2000),
        "seed": table.get("noise_seed", 0),
        "discrepancy": table.get("discrepancy"),
    }


def noise_limits(
    spec, *, ident=None, params: Mapping[str, float] | None = None
) -> dict[str, tuple[float, str]]:
    """The noise-floor limits of an identification study: criterion name -> (limit, note).

    Which criteria: those with ``limit = "noise"``, and with ``[identification] limits =
    "noise"`` every pure and pseudo criterion that has no number of its own. The noise,
    quantile, coverage, draws, seed and discrepancy come from the ``[identification]``
    table (see the module docstring). ``params``: the reference vector (default: the
    variables' nominal values, else the middle of their box)."""
    from vectorid.identify.identification import Identification

    s = _noise_settings(spec)
    if s["limits"] not in (None, "noise"):
        raise _err(
            "limits",
            f'expected "noise", got {s["limits"]!r}',
            'write limits = "noise", or set numbers in each [[criteria]] limit',
        )
    targets = [
        c.name
        for c in spec.criteria
        if (c.limit is None and c.limit_source == "noise")
        or (s["limits"] == "noise" and c.limit is None)
    ]
    if not targets:
        table = spec.extra["identification"]
        unused = [k for k in ("noise_quantile", "noise_coverage", "noise_draws", "noise_seed")
                  if k in table]  # fmt: skip
        if unused and _own_model(spec):  # a setting that changes nothing is an error
            raise _err(
                unused[0],
                f"{unused[0]} shapes noise-floor limits, but no criterion is limited by the "
                "noise",
                f'add limits = "noise" (or limit = "noise" to a criterion), or remove {unused[0]}',
            )
        return {}
    if ident is None:
        ident = Identification.from_spec(spec)
    from vectorid.identify.system import SystemIdentification

    if isinstance(ident, SystemIdentification):  # a model of your own
        from vectorid.identify import system

        _check_settings(s)
        return system.noise_limits(spec, ident, targets, s)
    if s["noise"] is None and not any(
        "noise" in dt
        for dt in spec.extra["identification"].get("drops", [])
        if isinstance(dt, Mapping)
    ):
        raise _err(
            "noise",
            f"criteria {targets} are limited by the noise, but no noise is stated",
            'add noise = { position_h = 1.5, ... } or noise = "estimate" under [identification]',
        )
    ident = ident if ident is not None else Identification.from_spec(spec)
    noise = _drop_noise(spec, ident, s["noise"])
    disc = _drop_discrepancy(spec, s["discrepancy"])
    _check_settings(s)
    q, cov, draws = s["quantile"], s["coverage"], s["draws"]
    ref = _reference(spec, ident, params)
    floor = noise_floor(
        ident,
        noise,
        draws=draws,
        seed=int(s["seed"]),
        params=ref,
        discrepancy=disc,
        criteria=targets,
    )
    out = floor.limits(targets, quantile=q, coverage=float(cov))
    # The stated noise is in the study file; an estimated one is only here, so say it.
    est = "; ".join(f"{k}: {v}" for k, v in floor.noise.items() if v.startswith("estimated"))
    return {n: (v, f"{note} ({est})" if est else note) for n, (v, note) in out.items()}


def _check_settings(s: Mapping[str, Any]) -> None:
    q = s["quantile"]
    if q is not None and not (isinstance(q, int | float) and 0 < q < 1):
        raise _err("noise_quantile", f"expected a number in (0, 1), got {q!r}", "e.g. 0.99")
    cov = s["coverage"]
    if not (isinstance(cov, int | float) and 0 < cov < 1):
        raise _err("noise_coverage", f"expected a number in (0, 1), got {cov!r}", "e.g. 0.95")
    draws = s["draws"]
    if not (isinstance(draws, int) and draws >= 100):
        raise _err("noise_draws", f"expected an integer >= 100, got {draws!r}", "e.g. 2000")


def _reference(spec, ident, params) -> dict[str, float]:
    ref = {}
    for v in spec.space:
        if v.name in ident.model.parameter_names:
            if v.nominal is not None:
                ref[v.name] = float(v.nominal)
            elif hasattr(v, "low"):
                ref[v.name] = 0.5 * (float(v.low) + float(v.high))
    ref.update(dict(params or {}))
    return ref


def _drop_noise(spec, ident, study_noise) -> dict[str, NoiseModel | str]:
    tables = spec.extra["identification"].get("drops", [])
    base = None if study_noise is None else parse_noise(study_noise, "noise")
    out: dict[str, NoiseModel | str] = {}
    for i, d in enumerate(ident.drops):
        t = tables[i] if i < len(tables) and isinstance(tables[i], Mapping) else {}
        own = t.get("noise")
        if own is None:
            if base is None:
                raise _err(
                    f"drops[{i}].noise",
                    f"drop {d.name!r} has no stated noise and the study states none",
                    'add noise = { ... } (or "estimate") to the drop or to [identification]',
                )
            out[d.name] = base
            continue
        mine = parse_noise(own, f"drops[{i}].noise")
        if isinstance(mine, str) or base is None or isinstance(base, str):
            if isinstance(base, str) and not isinstance(mine, str):
                out[d.name] = estimate_noise(d.flight, _needed_channels(ident, d)).merged(mine)
            else:
                out[d.name] = mine
        else:
            out[d.name] = base.merged(mine)
    for name, nm in out.items():
        if isinstance(nm, str):
            d = ident.drop(name)
            out[name] = estimate_noise(d.flight, _needed_channels(ident, d))
    return out


def _drop_discrepancy(spec, value) -> dict:
    return parse_discrepancy(value, spec.criterion_names)


def resolve_noise_limits(spec, *, ident=None, params: Mapping[str, float] | None = None):
    """``spec`` with its noise-floor limits computed (``limit_source = "noise"`` and a note on
    each), and with each identification criterion's unit filled from the library where the
    study gives none. A spec without an ``[identification]`` table, or without noise limits,
    comes back unchanged (units filled)."""
    if "identification" not in spec.extra:
        return spec
    from vectorid.identify.identification import Identification
    from vectorid.identify.system import SystemIdentification

    if ident is None and _own_model(spec):
        ident = Identification.from_spec(spec)
    limits = noise_limits(spec, ident=ident, params=params)
    if isinstance(ident, SystemIdentification):
        units = ident.units()
    else:
        units = _library_units(spec)
    crit = []
    for c in spec.criteria:
        new = c
        if not c.unit and units.get(c.name):
            new = replace(new, unit=units[c.name])
        if c.name in limits:
            v, note = limits[c.name]
            new = replace(new, limit=v, limit_source="noise", limit_note=note)
        crit.append(new)
    return replace(spec, criteria=tuple(crit))


def _own_model(spec) -> bool:
    """Whether the study's identification names a model of your own (a SystemModel)."""
    from vectorid.identify.system import resolve_model
    from vectorid.models.system import SystemModel

    table = spec.extra.get("identification")
    default = spec.model if isinstance(spec.model, str) else None
    try:
        return isinstance(resolve_model(table, default, spec.base_dir), SystemModel)
    except StudyDefinitionError:  # the identification itself says what is wrong
        return False


def _library_units(spec) -> dict[str, str]:
    from vectorid.identify.criteria import get_criterion
    from vectorid.identify.identification import INTEGRAL_CRITERIA, window_variable

    table = spec.extra.get("identification", {})
    ctab = table.get("criteria", {}) if isinstance(table.get("criteria", {}), Mapping) else {}
    mean_form = any(window_variable(n) is not None for n in spec.space.names)
    out = {}
    for c in spec.criteria:
        t = ctab.get(c.name, {}) if isinstance(ctab.get(c.name, {}), Mapping) else {}
        use, op = str(t.get("use", c.name)), t.get("operator")
        try:
            u = get_criterion(use if op is None else f"{use}:{op}").unit
        except Exception:  # not a library criterion: leave it
            continue
        if mean_form and op is None and use in INTEGRAL_CRITERIA:
            u = _time_mean_unit(u)
        out[c.name] = u
    return out
