"""Why no constant-drag descent comes within 5 m of the Prometheus drogue phase: the figures.

Usage::

    python examples/telemega_drogue.py [PATH/TO/...TeleMega.csv] [--json]

The drogue phase of the Prometheus TeleMega log (``../shared/data/prometheus-2022/``) leaves an
altitude RMS of 12-18 m to the point mass of one constant drag area (``vectorid descent``,
``examples/real_descent.py``), where the issue asked for 5 m. This script measures, from the
log alone, what that residual is made of:

1. **The barometer's own error.** The white plus Gauss–Markov noise of the barometric heights
   (:func:`vectorid.identify.noise.estimate_correlated`), and how much of their variation
   faster than 20 s the same log's GPS heights share
   (:func:`vectorid.descent.fast_variation`): real motion shows in both.
2. **What no constant drag area can follow.** The smallest altitude RMS of any descent whose
   rate never increases (:func:`vectorid.descent.monotone_rate_bound`: a constant
   drag area in still air, in any atmosphere), against the barometric and the GPS heights, for
   windows starting 5 to 20 s after the drogue event.
3. **The deployment transient.** The drag area the GPS descent rate implies in 5-s windows
   (2 m g / (ρ v²), ρ of ISA at the barometric height over the day's T/T_ISA), and the
   descent rate of the 2-s lines the identification would start from.
4. **The day's atmosphere**, from the log: GPS height against log pressure (hypsometric
   equation, T = -(g/R) dz/d ln p, a temperature linear in height), its lapse rate and
   T/T_ISA.
5. **Constant-drag fits.** The point mass of :class:`~vectorid.descent.RocketDescentCdS`
   at its steady rate, over a scan of drag areas with the best constant altitude offset: in
   ISA against the barometric heights, and in the log's atmosphere against the barometric
   and the GPS heights; and how far the GPS descent rate strays from the best constant-drag
   one in 10-s windows (vertical air motion, or a drag area that changes).

``--json`` prints the figures as one object.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from vectorid.descent import RocketDescentCdS, fast_variation, monotone_rate_bound
from vectorid.identify import load_telemega
from vectorid.identify.noise import estimate_correlated
from vectorid.models.atmosphere import G0, ISA, R_AIR
from vectorid.models.base import InitialState

HERE = Path(__file__).resolve().parent
DEFAULT_LOG = (
    HERE.parent.parent
    / "shared"
    / "data"
    / "prometheus-2022"
    / "2022-06-24-serial-6583-flight-0003-TeleMega.csv"
)
MASS = 13.9 + 2.981  # kg after burn-out (data README)
STARTS = (5.0, 10.0, 17.0, 20.0)  # s after the drogue event
START = 17.0  # the window of the fits: after the deployment transient (item 3 shows it)


def _pressure_altitude(p):
    """ISA pressure altitude of pressure ``p`` (Pa), m (troposphere)."""
    return 44_330.8 * (1.0 - (np.asarray(p, dtype=float) / 101_325.0) ** 0.190263)


class LogAtmosphere:
    """The day's atmosphere from a log's GPS heights z (m) and pressures p (Pa): z = c0 + c1 L
    + c2 L², L = ln p (hypsometric: T = -(g/R) dz/dL, linear in L); density p / (R T)."""

    def __init__(self, z, p):
        self.c2, self.c1, self.c0 = np.polyfit(np.log(p), z, 2)
        self.fit_rms = float(np.sqrt(np.mean((np.polyval([self.c2, self.c1, self.c0],
                                                          np.log(p)) - z) ** 2)))  # fmt: skip

    def log_pressure(self, z):
        # the root of c2 L² + c1 L + (c0 - z) = 0 on the branch where z falls as L grows
        disc = self.c1**2 - 4 * self.c2 * (self.c0 - np.asarray(z, dtype=float))
        return (-self.c1 - np.sqrt(disc)) / (2 * self.c2)

    def temperature(self, z):
        return -(G0 / R_AIR) * (self.c1 + 2 * self.c2 * self.log_pressure(z))

    def density(self, z):
        return np.exp(self.log_pressure(z)) / (R_AIR * self.temperature(z))

    def gravity(self, z):
        return ISA().gravity(z)


def _steady_fits(atm, h0, t, grid, target, at, cds):
    """RMS (m) of each drag area of ``cds`` against ``target`` at times ``at``, with the best
    constant offset; the descent starts at altitude ``h0`` (m above sea level) at grid[0] at
    its steady rate. ``target`` maps the simulated geometric altitude to the compared one."""
    m = RocketDescentCdS(mass=MASS, initial_speed="steady")
    X = np.column_stack([cds, np.zeros_like(cds)])
    res = m.simulate(X, t_final=float(grid[-1] - grid[0]), dt=0.05, output_dt=0.5,
                     initial=InitialState(altitude=h0), atmosphere=atm)  # fmt: skip
    z = -res.position[:, :, 2]
    sim = np.stack([np.interp(at - grid[0], res.t, target(zi)) for zi in z])
    e = sim - t[None, :]
    e -= e.mean(axis=1, keepdims=True)
    return np.sqrt(np.mean(e**2, axis=1)), res


def figures(path: str | Path) -> dict:
    """Every figure of the module docstring, as a dict (units in the keys)."""
    f = load_telemega(path)
    a, gps, pr = f["altitude"], f["gps_altitude"], f["pressure"]
    t_d, t_m = f.events["drogue"], f.events["main"]
    pad = float(_pressure_altitude(np.median(pr.values[:20, 0])))
    end = t_m - 1.0
    out: dict = {"drogue_event_s": t_d, "main_event_s": t_m, "window_end_s": end}

    # 1. the barometer's own error
    sel = (a.t >= t_d + 5.0) & (a.t <= end)
    cn = estimate_correlated(a.t[sel], a.values[sel, 0])
    fv = fast_variation(a.t, a.values[:, 0], gps.t, gps.values[:, 0], t_d + 5.0, end)
    out["baro_noise"] = {"sigma_m": cn.sigma, "correlation_time_s": cn.correlation_time,
                         "white_m": cn.white}  # fmt: skip
    out["fast_variation_20s"] = {"baro_m": fv.rms, "gps_m": fv.rms_ref,
                                 "correlation": fv.correlation}  # fmt: skip

    # 2. the monotone-rate bound, by window start
    bounds = []
    for s in STARTS:
        grid = np.arange(t_d + s, end, 0.5)
        gsel = (gps.t >= grid[0]) & (gps.t <= grid[-1])
        bounds.append({
            "start_after_drogue_s": s,
            "baro_m": monotone_rate_bound(a.t, a.values[:, 0], grid).rms,
            "gps_m": monotone_rate_bound(gps.t, gps.values[:, 0], gps.t[gsel]).rms,
        })  # fmt: skip
    out["monotone_rate_bound"] = bounds

    # 4. the day's atmosphere (before 3: the density of the drag areas uses it)
    gsel = (gps.t >= t_d + 5.0) & (gps.t <= end)
    p_at = pr.at(gps.t[gsel])[:, 0]
    atm = LogAtmosphere(gps.values[gsel, 0], p_at)
    z_top, z_bot = float(gps.values[gsel, 0].max()), float(gps.values[gsel, 0].min())
    T_top, T_bot = float(atm.temperature(z_top)), float(atm.temperature(z_bot))
    # ISA's temperature at the same pressure: 288.15 K - 6.5 K/km x pressure altitude
    ratio = [T / (288.15 - 0.0065 * float(_pressure_altitude(np.exp(atm.log_pressure(z)))))
             for T, z in ((T_top, z_top), (T_bot, z_bot))]  # fmt: skip
    out["atmosphere"] = {
        "gps_altitude_top_m": z_top, "gps_altitude_bottom_m": z_bot,
        "temperature_top_K": T_top, "temperature_bottom_K": T_bot,
        "lapse_rate_K_per_km": 1000 * (T_bot - T_top) / (z_top - z_bot),
        "T_over_T_ISA_top": ratio[0], "T_over_T_ISA_bottom": ratio[1],
        "hypsometric_fit_rms_m": atm.fit_rms,
    }  # fmt: skip

    # 3. the deployment transient: drag area from the GPS rate in 5-s windows; 2-s lines
    areas = []
    for w0 in np.arange(t_d + 7.0, t_d + 52.0, 5.0):
        s = (gps.t >= w0) & (gps.t < w0 + 5.0 + 1e-9)
        v = -np.polyfit(gps.t[s], gps.values[s, 0], 1)[0]
        z = float(np.mean(gps.values[s, 0]))
        areas.append({"from_s": float(w0), "gps_rate_ms": float(v),
                      "drag_area_m2": float(2 * MASS * G0 / (atm.density(z) * v * v))})  # fmt: skip
    out["gps_drag_area_5s"] = areas
    lines = []
    for s in np.arange(5.0, 20.5, 1.0):
        m = (a.t >= t_d + s) & (a.t <= t_d + s + 2.0)
        lines.append(float(-np.polyfit(a.t[m], a.values[m, 0], 1)[0]))
    out["initial_rate_2s_lines_ms"] = [min(lines), max(lines)]

    # 5. constant-drag fits from START s after the drogue event
    grid = np.arange(t_d + START, end, 0.5)
    baro = np.interp(grid, a.t, a.values[:, 0])
    cds = np.arange(0.40, 0.62, 0.0005)
    h0 = pad + float(baro[0])
    r_isa, _ = _steady_fits(ISA(), h0, baro, grid, lambda z: z - pad, grid, cds)
    # in the log's atmosphere: start at the GPS height of the first pressure; compare the
    # pressure the model's height implies, as a barometric height
    z0 = float(np.polyval([atm.c2, atm.c1, atm.c0], math.log(pr.at([grid[0]])[0, 0])))

    def to_baro(z):
        return _pressure_altitude(np.exp(atm.log_pressure(z))) - pad

    r_log, _ = _steady_fits(atm, z0, baro, grid, to_baro, grid, cds)
    gs = (gps.t >= grid[0]) & (gps.t <= grid[-1])
    r_gps, res = _steady_fits(atm, z0, gps.values[gs, 0], grid, lambda z: z, gps.t[gs], cds)
    i = int(np.argmin(r_gps))
    e = np.interp(gps.t[gs] - grid[0], res.t, -res.position[i, :, 2]) - gps.values[gs, 0]
    e -= e.mean()
    out["constant_drag_fits"] = {
        "start_after_drogue_s": START,
        "isa_vs_baro_m": float(r_isa.min()), "isa_vs_baro_cds_m2": float(cds[np.argmin(r_isa)]),
        "log_atmosphere_vs_baro_m": float(r_log.min()),
        "log_atmosphere_vs_gps_m": float(r_gps[i]), "log_atmosphere_cds_m2": float(cds[i]),
        "log_atmosphere_vs_gps_max_m": float(np.abs(e).max()),
        "altitude_loss_m": float(baro[0] - baro[-1]),
    }  # fmt: skip
    # how the GPS descent rate strays from the best constant-drag one (10-s windows)
    z = -res.position[i, :, 2]
    dv = []
    for w0 in np.arange(grid[0], grid[-1] - 10.0 + 1e-9, 10.0):
        s = (gps.t >= w0) & (gps.t < w0 + 10.0)
        v_gps = -np.polyfit(gps.t[s], gps.values[s, 0], 1)[0]
        k = (res.t + grid[0] >= w0) & (res.t + grid[0] < w0 + 10.0)
        v_mod = -np.polyfit(res.t[k], z[k], 1)[0]
        dv.append(float(v_gps - v_mod))
    out["gps_rate_minus_constant_drag_10s_ms"] = dv
    return out


def report(d: dict) -> str:
    """The figures as a person reads them."""
    n, fv, at = d["baro_noise"], d["fast_variation_20s"], d["atmosphere"]
    cf = d["constant_drag_fits"]
    lines = [
        f"drogue phase of the Prometheus TeleMega log: drogue at {d['drogue_event_s']:.2f} s, "
        f"window end {d['window_end_s']:.2f} s",
        "",
        "1. the barometer's own error",
        f"   noise of the barometric heights: {n['sigma_m']:.2f} m correlated over "
        f"{n['correlation_time_s']:.2f} s + {n['white_m']:.2g} m white",
        f"   variation faster than 20 s: barometer {fv['baro_m']:.2f} m RMS, GPS "
        f"{fv['gps_m']:.2f} m RMS, correlation {fv['correlation']:+.2f}",
        "",
        "2. the closest any descent with a rate that never increases comes (RMS, m)",
        "   start after drogue   barometric   GPS",
    ]
    for b in d["monotone_rate_bound"]:
        lines.append(f"   {b['start_after_drogue_s']:>6.0f} s          {b['baro_m']:>8.2f}"
                     f"   {b['gps_m']:>6.2f}")  # fmt: skip
    lines += ["", "3. drag area from the GPS descent rate, 5-s windows (m²)"]
    lines.append("   " + "  ".join(
        f"{x['from_s'] - d['drogue_event_s']:.0f}s:{x['drag_area_m2']:.3f}"
        for x in d["gps_drag_area_5s"]))  # fmt: skip
    lo, hi = d["initial_rate_2s_lines_ms"]
    lines.append(f"   2-s lines of the barometric heights, 5-20 s after the drogue event: "
                 f"{lo:.1f} to {hi:.1f} m/s")  # fmt: skip
    lines += [
        "",
        "4. the day's atmosphere (GPS height against log pressure)",
        f"   T {at['temperature_top_K']:.1f} K at {at['gps_altitude_top_m']:.0f} m, "
        f"{at['temperature_bottom_K']:.1f} K at {at['gps_altitude_bottom_m']:.0f} m: lapse "
        f"{at['lapse_rate_K_per_km']:.1f} K/km (ISA 6.5); T/T_ISA {at['T_over_T_ISA_top']:.3f} "
        f"to {at['T_over_T_ISA_bottom']:.3f}",
        "",
        f"5. best constant drag area from {cf['start_after_drogue_s']:.0f} s after the drogue "
        "event (steady start, best constant offset)",
        f"   ISA, barometric heights:               {cf['isa_vs_baro_m']:.2f} m RMS "
        f"(C_D S {cf['isa_vs_baro_cds_m2']:.3f} m²)",
        f"   log's atmosphere, barometric heights:  {cf['log_atmosphere_vs_baro_m']:.2f} m RMS",
        f"   log's atmosphere, GPS heights:         {cf['log_atmosphere_vs_gps_m']:.2f} m RMS, "
        f"{cf['log_atmosphere_vs_gps_max_m']:.1f} m at most over the "
        f"{cf['altitude_loss_m']:.0f} m descended (C_D S {cf['log_atmosphere_cds_m2']:.3f} m²)",
        "   GPS descent rate minus the constant-drag one, 10-s windows (m/s): "
        + " ".join(f"{v:+.2f}" for v in d["gps_rate_minus_constant_drag_10s_ms"]),
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("path", nargs="?", default=str(DEFAULT_LOG), help="the TeleMega CSV")
    ap.add_argument("--json", action="store_true", help="print the figures as JSON")
    args = ap.parse_args(argv)
    if not Path(args.path).is_file():
        print(
            f"error: no such file: {args.path} (the Prometheus TeleMega CSV: RocketPy's "
            "data/rockets/prometheus/, github.com/RocketPy-Team/RocketPy; fetch it with `python "
            "scripts/fetch_data.py prometheus-2022`, which writes ../shared/data/prometheus-2022)",
            file=sys.stderr,
        )
        return 2
    d = figures(args.path)
    if args.json:
        json.dump(d, sys.stdout, indent=2)
        print()
    else:
        print(report(d))
    return 0


if __name__ == "__main__":
    sys.exit(main())
