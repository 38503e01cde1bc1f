"""The noise statement: what a study file says about its measurement noise and the
model-discrepancy allowance, parsed.

``noise = { position_h = 1.5, ... }`` becomes a :class:`NoiseModel` (one
:class:`ComponentNoise` per channel component, SI units), ``discrepancy = { ... }`` the
allowance table of :func:`parse_discrepancy`. The keys, their channels and units are
:data:`NOISE_KEYS`; how a channel allowance bounds each library criterion is
:data:`DISCREPANCY_RULES`. See :mod:`vectorid.identify.noise` for the study file.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vectorid.errors import StudyDefinitionError, suggest

__all__ = [
    "DISCREPANCY_RULES",
    "NOISE_KEYS",
    "ComponentNoise",
    "NoiseModel",
    "allowance_label",
    "parse_component",
    "parse_discrepancy",
    "parse_noise",
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


def parse_component(where: str, value: Any, factor: float = 1.0, unit: str = "") -> ComponentNoise:
    """One channel component's noise from the study file: a σ (white noise) or a table
    ``{ sigma, correlation_time, white }``, times ``factor`` (the key's unit to SI).

    ``where`` names the field in errors (``"noise.position_h"``), ``unit`` the unit the σ is
    stated in (the key's, or a model's output channel's), which the errors name."""
    if isinstance(value, Mapping):
        bad = [k for k in value if k not in ("sigma", "correlation_time", "white")]
        if bad:
            raise _err(
                f"{where}.{bad[0]}",
                f"unknown key {bad[0]!r}",
                suggest(bad[0], ["sigma", "correlation_time", "white"]),
            )
        sigma = _nonneg(f"{where}.sigma", value.get("sigma", 0.0), unit, "σ")
        tau = _nonneg(f"{where}.correlation_time", value.get("correlation_time", 0.0), "s",
                      "correlation time")  # fmt: skip
        white = _nonneg(f"{where}.white", value.get("white", 0.0), unit, "white-noise σ")
        if sigma == 0 and white == 0:
            raise _err(where, "sigma and white are both 0", f"state the noise's σ{_in(unit)}")
        return ComponentNoise(sigma * factor, tau, white * factor)
    return ComponentNoise(_nonneg(where, value, unit, "σ") * factor)


def _in(unit: str) -> str:
    return f" in {unit}" if unit and unit not in ("-", "1") else ""


def _nonneg(where: str, value: Any, unit: str = "", what: str = "number") -> float:
    """A number >= 0; the error names what it is and its unit (``σ in rad``)."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    if isinstance(value, bool) or not (v >= 0 and math.isfinite(v)):
        raise _err(
            where,
            f"expected a {what} >= 0{_in(unit)}, got {value!r}",
            f"e.g. 1.5 (in {unit})" if _in(unit) else "e.g. 1.5",
        )
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
        ch, comps, factor, unit = NOISE_KEYS[key]
        c = parse_component(f"{where}.{key}", v, factor, unit)
        cur = out.setdefault(ch, [None] * (max(comps) + 1))
        cur += [None] * (max(comps) + 1 - len(cur))
        for j in comps:
            cur[j] = c
    return NoiseModel(out)


def parse_discrepancy(
    value: Any, criteria: Sequence[str] | Mapping[str, str], where: str = "discrepancy"
) -> dict:
    """A discrepancy table: noise keys (channel allowances, SI after conversion) and criterion
    names (allowances in the criterion's unit; ``criteria`` may map each name to its unit, for
    the errors). Returns ``{"channels": {channel: [δ per component]}, "criteria": {name:
    δ}}``."""
    criteria_units = dict(criteria) if isinstance(criteria, Mapping) else {}
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
            ch, comps, factor, unit = NOISE_KEYS[key]
            d = _nonneg(f"{where}.{key}", v, unit, "allowance") * factor
            cur = chans.setdefault(ch, [0.0] * (max(comps) + 1))
            cur += [0.0] * (max(comps) + 1 - len(cur))
            for j in comps:
                cur[j] = d
        elif key in criteria:
            crits[key] = _nonneg(f"{where}.{key}", v, criteria_units.get(key, ""), "allowance")
        else:
            raise _err(
                f"{where}.{key}",
                f"{key!r} is neither a noise key nor a criterion of the study",
                suggest(key, [*NOISE_KEYS, *criteria]),
            )
    return {"channels": chans, "criteria": crits}


#: The noise key, factor from SI and unit an allowance on (channel, components) is stated in.
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


def allowance_label(channel: str, components: tuple[int, ...]) -> tuple[str, float, str]:
    """``(noise key, factor from SI, unit)`` an allowance on ``channel``'s ``components`` is
    stated in (``("position", (0, 1))`` -> ``("position_h", 1.0, "m")``); the channel itself,
    in SI, where no key names that set."""
    return _ALLOWANCE_LABEL.get((channel, tuple(components)), (channel, 1.0, ""))
