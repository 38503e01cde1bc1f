"""A second altimeter in the log (GPS heights beside the barometer): the warm-day height ratio,
how far the two disagree beyond a scale factor, and how much of the barometer's fast variation
the GPS shares."""

from __future__ import annotations

import numpy as np

from vectorid.descent.bounds import fast_variation

__all__: list[str] = []


def _height_ratio(flight, t0: float, t1: float) -> float | None:
    """GPS over barometric height gain over [t0, t1] (least squares), when the log has GPS
    heights (``gps_altitude``, a TeleMega log) with at least 20 fixes there; else None."""
    got = _height_ratio_se(flight, t0, t1)
    return None if got is None else got[0]


def _height_ratio_se(flight, t0: float, t1: float) -> tuple[float, float] | None:
    """:func:`_height_ratio` and its standard error: the least-squares slope's, with the
    residuals' variance inflated by their lag-1 autocorrelation ρ (fixes a second apart are not
    independent: n_eff = n (1 - ρ) / (1 + ρ))."""
    if "gps_altitude" not in flight.channels:
        return None
    g = flight["gps_altitude"]
    a = flight["altitude"]
    sel = (g.t >= max(t0, a.t[0])) & (g.t <= min(t1, a.t[-1]))
    if sel.sum() < 20:
        return None
    gps = g.values[sel, 0]
    baro = a.at(g.t[sel])[:, 0]
    A = np.stack([baro, np.ones_like(baro)], axis=1)
    coef, *_ = np.linalg.lstsq(A, gps, rcond=None)
    k = float(coef[0])
    if not 0.8 < k < 1.25:
        return None
    r = gps - A @ coef
    n = r.size
    rho = float(np.corrcoef(r[:-1], r[1:])[0, 1]) if n > 3 and np.std(r) > 0 else 0.0
    rho = min(max(rho, 0.0), 0.95)
    n_eff = max(3.0, n * (1 - rho) / (1 + rho))
    s2 = float(np.sum(r**2)) / max(n - 2, 1)
    sxx = float(np.sum((baro - baro.mean()) ** 2))
    se = float(np.sqrt(s2 / sxx * n / n_eff)) if sxx > 0 else 0.0
    return k, se


def _sensor_disagreement(channels, t0: float, t1: float) -> float | None:
    """RMS (m) of the GPS heights about the best line through the barometric heights at the
    GPS fixes in [t0, t1]: how far the log's two altimeters disagree beyond a scale factor."""
    g, a = channels["gps_altitude"], channels["altitude"]
    sel = (g.t >= max(t0, a.t[0])) & (g.t <= min(t1, a.t[-1]))
    if sel.sum() < 10:
        return None
    gps = g.values[sel, 0]
    baro = a.at(g.t[sel])[:, 0]
    A = np.stack([baro, np.ones_like(baro)], axis=1)
    coef, *_ = np.linalg.lstsq(A, gps, rcond=None)
    return float(np.sqrt(np.mean((A @ coef - gps) ** 2)))


def _fast_error(channels, t0: float, t1: float) -> dict[str, float] | None:
    """:func:`~vectorid.descent.fast_variation` of the barometric heights against
    the log's GPS heights over [t0, t1], as ``{"baro_m", "gps_m", "correlation", "span_s"}``."""
    if "gps_altitude" not in channels:
        return None
    a, g = channels["altitude"], channels["gps_altitude"]
    fv = fast_variation(a.t, a.values[:, 0], g.t, g.values[:, 0], t0, t1)
    if fv is None:
        return None
    return {"baro_m": fv.rms, "gps_m": fv.rms_ref, "correlation": fv.correlation, "span_s": fv.span}
