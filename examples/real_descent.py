"""Identify the drogue and main parachute drag coefficients of a real rocket descent.

Usage::

    python examples/real_descent.py PATH/TO/2022-06-24-serial-6583-flight-0003-TeleMega.csv \\
        [--trials 1024] [--out real-descent] [--json]

The flight: the Prometheus sounding rocket (Spaceport America, 2022-06-24), TeleMega log of
the shared data (``../shared/data/prometheus-2022/``). After burn-out the rocket (13.9 kg dry
without motor + 2.981 kg motor casing = 16.881 kg) descends under a 24-in drogue (nominal C_D
1.6) from apogee, then under the 72-in main (nominal C_D 2.2, deployed at 1500 ft above ground)
with the drogue still attached: the main's drag *adds* to the drogue's (``convention =
"adds"``).

This is ``vectorid descent`` (:func:`vectorid.descent.identify_descent`) on that
log: the drogue phase runs from 17 s after the log's ``drogue`` event (the deployment
transient: the drag area the GPS descent rate implies is 14 % low before, see
``examples/telemega_drogue.py``) to 1 s before its ``main`` event, the main phase from 6 s
after ``main`` to 1 s before the touchdown read from the data (the altitude and the vertical
speed settle; the logger's ``landed`` state comes 14 s later). Each phase identifies its
canopy's drag area C_D S (m²) by PSI on the point-mass model in ISA air, started at each
trial's steady descent rate, with criteria constraints from the noise-floor machinery (the
altitude noise estimated from the phase's data, plus a stated discrepancy allowance) and the
identifiability verdict of the shared machinery, and reports C_D = C_D S / (π D² / 4). The
barometric heights are pressure-altitude differences; on this hot day they under-read
geometric heights by T_ISA / T (the log's GPS heights show it), so the drag areas identified in
ISA air are high by about that ratio: the script reports them as identified and corrected by
the GPS/baro height ratio.

The drogue phase does not reach the 5 m altitude RMS asked of it, and its verdict says why: no
descent whose rate never increases (a constant drag area in still air, in any atmosphere)
comes within 5.3 m of its barometric heights, which carry about 5 m RMS of pressure error at
periods of a second that the log's GPS heights do not share.

``--json`` prints ``{"flight", "phases": [{"name", "cd", "pareto": [lo, hi], "alt_rms_m",
"vz_rms_ms", "cd_corrected", ...}], "touchdown", ...}``. A missing or unreadable file gives one
line on standard error and exit status 2.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from vectorid.descent import INCH, Canopy, DescentPlan, DescentResult, identify_descent
from vectorid.errors import VectoridError

MASS = 13.9 + 2.981  # kg after burn-out (data README)
DROGUE = Canopy(diameter=24 * INCH, cd=1.6)
MAIN = Canopy(diameter=72 * INCH, cd=2.2)
#: s from the drogue event to the drogue window: the drag area the GPS descent rate implies
#: is 14 % below its later level for the first 17 s (examples/telemega_drogue.py)
DROGUE_SETTLE = 17.0


def plan(path: str | Path, trials: int = 1024, seed: int = 1) -> DescentPlan:
    """The descent identification of the Prometheus log."""
    return DescentPlan(
        file=Path(path),
        format="telemega",
        mass=MASS,
        drogue=DROGUE,
        main=MAIN,
        convention="adds",
        drogue_settle=DROGUE_SETTLE,
        trials=trials,
        seed=seed,
        name="prometheus",
    )


def identify(path: str | Path, out: str | Path, trials: int = 1024) -> DescentResult:
    """Run the identification; the phases' stores go to ``out``."""
    p = Path(path)
    if not p.is_file():
        raise VectoridError(
            f"no such file: {p} (the Prometheus TeleMega CSV: RocketPy's data/rockets/prometheus/"
            ", github.com/RocketPy-Team/RocketPy; fetch it with `python scripts/fetch_data.py "
            "prometheus-2022`, which writes ../shared/data/prometheus-2022)"
        )
    return identify_descent(plan(p, trials), out)


def report(r: DescentResult) -> str:
    """The figures as a person reads them."""
    lines = [r.format_text(), ""]
    k = r.phases[0].height_ratio
    lines.append(
        f"{'':<7} {'C_D':>6} {'Pareto':>15} {'corrected':>10} {'nominal':>8} "
        f"{'alt RMS':>8} {'vz RMS':>9} {'floor':>7} {'bound':>7}"
    )
    for p, nominal in zip(r.phases, (DROGUE.cd, MAIN.cd)):
        if p.cd is None:
            rng = p.to_dict()["feasible"]
            what = "-" if rng is None else f"C_D in [{rng[0]:.3f}, {rng[1]:.3f}]"
            lines.append(f"{p.name:<7} {what}  ({p.status})")
            continue
        lo, hi = p.to_dict()["pareto"]
        corr = "-" if k is None else f"{p.cd / k:.3f}"
        lines.append(
            f"{p.name:<7} {p.cd:>6.3f} {f'[{lo:.3f}, {hi:.3f}]':>15} {corr:>10} {nominal:>8.2f} "
            f"{p.alt_rms_m:>6.2f} m {p.vz_rms_ms:>5.2f} m/s {p.limits.floor_alt_rms:>5.2f} m "
            f"{p.rate_bound['rms_m']:>5.2f} m"
        )
    lines.append(
        "(floor: the altitude RMS a perfect model leaves under the estimated noise, at the "
        "limits' quantile; bound: the least any descent whose rate never increases leaves)"
    )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("path", help="the TeleMega CSV of the Prometheus flight")
    ap.add_argument("--trials", type=int, default=1024, help="trials per phase (default 1024)")
    ap.add_argument("--out", default="real-descent", help="folder of the stores")
    ap.add_argument("--json", action="store_true", help="print the result as JSON")
    args = ap.parse_args(argv)
    try:
        r = identify(args.path, args.out, args.trials)
    except (VectoridError, ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.json:
        out = r.to_dict()
        json.dump(out, sys.stdout, indent=2, default=_json_default)
        sys.stdout.write("\n")
    else:
        print(report(r))
    return 0


def _json_default(o):
    v = float(o)
    return v if math.isfinite(v) else None


if __name__ == "__main__":
    sys.exit(main())
