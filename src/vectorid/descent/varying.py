"""Is the drag area constant along a phase? The model of every phase is one constant drag area
in still ISA air; this module tests that against the data directly.

The phase is cut into sub-windows of at least ``span`` s (at least three); in each, the mean
descent rate v (the slope of a least-squares line through the heights) and the ISA density ρ
at its mid height give the drag area a steady descent implies, C_D S = 2 m g / (ρ v²). Its
uncertainty comes from the phase's altitude noise σ: a line over L s has a slope error of
about 2 σ / L at worst (σ correlated over the whole window), so C_D S is known to
2 × 2 σ / (L v) relatively. The sub-windows *disagree beyond the noise* when the largest and
the smallest differ by more than three of their combined uncertainties and by more than
:data:`MIN_SPREAD` (a temperature profile other than ISA's shifts the density by a few per cent
over a descent; that is not a changing canopy).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from vectorid.models.atmosphere import ISA

__all__ = ["MIN_SPREAD", "DragAlong", "drag_along"]

#: Smallest relative spread (max / min - 1) of the sub-windows' drag areas called a change.
MIN_SPREAD = 0.15


@dataclass(frozen=True)
class DragAlong:
    """The drag area of a phase's sub-windows.

    Attributes
    ----------
    windows : list of (float, float)
        Sub-windows, s.
    cds : list of float
        Drag area each implies, m².
    sigma : list of float
        Its uncertainty, m² (one σ).
    low, high : float
        Smallest and largest, m².
    varies : bool
        True when they disagree beyond the noise (see the module docstring).
    """

    windows: list[tuple[float, float]]
    cds: list[float]
    sigma: list[float]
    low: float
    high: float
    varies: bool

    def to_dict(self) -> dict:
        return asdict(self)


def drag_along(
    t,
    h,
    t0: float,
    t1: float,
    *,
    mass: float,
    origin: float,
    noise_sigma: float,
    span: float = 20.0,
    max_windows: int = 8,
) -> DragAlong | None:
    """The drag areas of the sub-windows of [t0, t1] (see the module docstring).

    Parameters
    ----------
    t, h : array_like
        Times (s) and heights above the origin (m).
    t0, t1 : float
        The phase's window, s.
    mass : float
        kg.
    origin : float
        Altitude of the heights' zero above sea level, m.
    noise_sigma : float
        The phase's altitude noise, m (its total σ).
    span : float
        Shortest sub-window, s.
    max_windows : int

    Returns
    -------
    DragAlong or None
        None when the window holds fewer than three sub-windows of ``span`` s, or a
        sub-window does not descend.
    """

    t = np.asarray(t, dtype=float)
    h = np.asarray(h, dtype=float)
    n = min(int((t1 - t0) // span), max_windows)
    if n < 3:
        return None
    L = (t1 - t0) / n
    isa = ISA()
    wins, vals, sig = [], [], []
    for i in range(n):
        a, b = t0 + i * L, t0 + (i + 1) * L
        sel = (t >= a) & (t <= b)
        if sel.sum() < 5:
            return None
        v = -float(np.polyfit(t[sel], h[sel], 1)[0])
        if v <= 0.5:
            return None
        z = origin + float(np.mean(h[sel]))
        rho, g = float(isa.density(z)), float(isa.gravity(z))
        cds = 2.0 * mass * g / (rho * v * v)
        sv = 2.0 * max(noise_sigma, 0.0) / L
        wins.append((float(a), float(b)))
        vals.append(cds)
        sig.append(cds * 2.0 * sv / v)
    lo, hi = int(np.argmin(vals)), int(np.argmax(vals))
    gap = vals[hi] - vals[lo]
    varies = gap > 3.0 * math.hypot(sig[lo], sig[hi]) and vals[hi] > (1 + MIN_SPREAD) * vals[lo]
    return DragAlong(wins, vals, sig, float(vals[lo]), float(vals[hi]), bool(varies))
