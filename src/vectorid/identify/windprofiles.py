"""Wind profiles from soundings and dropsondes, and a seeded wind-uncertainty model.

Loaders return :class:`vectorid.models.WindProfile` (altitude above mean sea level in m, wind
components towards north and east in m/s). Directions in the files are meteorological: the
direction the wind blows FROM, degrees clockwise from north.

:class:`WindUncertainty` draws seeded realisations of a profile, so that a criterion can be the
mathematical expectation over M realisations of an imperfectly known wind (seed 000, section V:
"inaccurate wind in our case").
"""

from __future__ import annotations

import csv
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from vectorid.errors import suggest
from vectorid.identify.flight import FlightDataError
from vectorid.models.wind import WindProfile

__all__ = [
    "MAX_PLAUSIBLE_WIND",
    "WindUncertainty",
    "load_dropsonde_csv",
    "load_wyoming",
]

KNOT = 1852.0 / 3600.0  # m/s
FT = 0.3048  # m

#: Largest wind speed accepted in a profile, m/s (the strongest jet-stream cores are ~110 m/s).
MAX_PLAUSIBLE_WIND = 120.0

_SPEED_UNITS = {"m/s": 1.0, "knot": KNOT, "kn": KNOT, "kt": KNOT, "km/h": 1 / 3.6, "mph": 0.44704}
_LENGTH_UNITS = {"m": 1.0, "ft": FT, "km": 1000.0}


def _finish(
    source: str, h: NDArray[np.float64], north: NDArray[np.float64], east: NDArray[np.float64]
) -> WindProfile:
    """Sort, merge duplicated altitudes (first kept), check plausibility, build the profile."""
    if h.size == 0:
        raise FlightDataError(f"{source}: no level with altitude and wind")
    order = np.argsort(h, kind="stable")
    h, north, east = h[order], north[order], east[order]
    keep = np.concatenate([[True], np.diff(h) > 0])
    h, north, east = h[keep], north[keep], east[keep]
    speed = np.hypot(north, east)
    if np.max(speed) > MAX_PLAUSIBLE_WIND:
        k = int(np.argmax(speed))
        raise FlightDataError(
            f"{source}: wind speed {speed[k]:.4g} m/s at {h[k]:.6g} m is implausible (> "
            f"{MAX_PLAUSIBLE_WIND:g} m/s); is the speed unit right (knots vs m/s, km/h)?"
        )
    return WindProfile(h, north, east)


def load_wyoming(path: str | os.PathLike[str]) -> WindProfile:
    """Wind profile from a University of Wyoming sounding (text list format).

    The table has the header ``PRES HGHT TEMP DWPT ... DRCT SKNT ...`` and a units line
    (``hPa m C C % g/kg deg knot ...``) between dashed lines, then fixed-width (7 characters)
    columns; an HTML page (``<PRE>`` blocks) or the station information after the table are
    ignored. Levels without a height, direction or speed (blank cells) are skipped; repeated
    levels keep the first occurrence. A cell that is not a number, a direction outside
    [0, 360] deg or a negative speed is refused with its line and column; so is a sounding cut
    short (an HTML ``<PRE>`` block never closed, or a last level shorter than the table's
    lines), never read as a shorter profile.

    Parameters
    ----------
    path : path-like
        The sounding text.

    Returns
    -------
    WindProfile
        Altitude = ``HGHT`` (m above mean sea level), speed ``SKNT`` (knots) -> m/s, direction
        ``DRCT`` (deg, FROM) -> components towards north and east.
    """
    p = Path(path)
    try:
        raw = p.read_bytes()
    except FileNotFoundError:
        raise FlightDataError(f"no such file: {p}") from None
    except OSError as exc:
        raise FlightDataError(f"{p}: cannot read the sounding ({exc.strerror})") from None
    text = raw.decode("utf-8-sig", errors="replace")
    lines = text.splitlines()
    head = next((i for i, s in enumerate(lines) if "HGHT" in s.split() and "PRES" in s), None)
    if head is None:
        raise FlightDataError(
            f"{p}: not a University of Wyoming sounding: no header line with PRES and HGHT; "
            "for other profiles use load_dropsonde_csv"
        )
    names = lines[head].split()
    for need in ("HGHT", "DRCT"):
        if need not in names:
            raise FlightDataError(
                f"{p}: the sounding has no {need} column (columns: {' '.join(names)})"
            )
    speed_col = "SKNT" if "SKNT" in names else ("SPED" if "SPED" in names else None)
    if speed_col is None:
        raise FlightDataError(
            f"{p}: the sounding has no wind speed column SKNT (knots) or SPED (m/s); columns: "
            f"{' '.join(names)}"
        )
    units_line = lines[head + 1].split() if head + 1 < len(lines) else []
    factor = KNOT if speed_col == "SKNT" else 1.0
    if len(units_line) == len(names):
        u = units_line[names.index(speed_col)].lower()
        factor = {"knot": KNOT, "kt": KNOT, "m/s": 1.0}.get(u, factor)
    # fixed-width columns: each header name is right-aligned in a 7-character field
    hline = lines[head]
    ends = []
    pos = 0
    for n in names:
        j = hline.index(n, pos)
        ends.append(j + len(n))
        pos = j + len(n)
    starts = [0, *ends[:-1]]
    ih, idr, isp = names.index("HGHT"), names.index("DRCT"), names.index(speed_col)
    k = head + 2
    while k < len(lines) and lines[k].strip().startswith("-"):
        k += 1
    # The table runs until a line without a digit, an HTML tag or the station information.
    table: list[tuple[int, str]] = []
    for number, line in enumerate(lines[k:], start=k + 1):
        txt = line.rstrip()
        if not txt or txt.lstrip().startswith("-"):
            continue
        if txt.lstrip().startswith("<") or not any(ch.isdigit() for ch in txt):
            break
        if "Station" in txt or "station" in txt:
            break
        table.append((number, txt))
    if not table:
        raise FlightDataError(f"{p}: the sounding's table holds no level (after line {k})")
    if "<PRE>" in text.upper() and "</PRE>" not in text.upper():
        raise FlightDataError(
            f"{p}: the sounding is cut short: its HTML <PRE> block is never closed (last level "
            f"on line {table[-1][0]}); download or copy the whole sounding again"
        )
    # A padded table (every level as wide as the header) whose last level is shorter was cut
    # off in the middle of that line.
    width = len(hline.rstrip())
    full = sum(len(t) >= width for _, t in table)
    last_no, last = table[-1]
    if len(table) > 2 and full >= 0.9 * (len(table) - 1) and len(last) < width:
        raise FlightDataError(
            f"{p}: the sounding is cut short: its last level (line {last_no}) ends at character "
            f"{len(last)}, the table's lines are {width} wide; download or copy the whole "
            "sounding again"
        )
    h, d, s = [], [], []
    for number, txt in table:
        values = []
        for i, name in enumerate(names):
            cell = txt[starts[i] : ends[i]].strip()
            if not cell:
                values.append(math.nan)
                continue
            try:
                values.append(float(cell))
            except ValueError:
                raise FlightDataError(
                    f"{p}: line {number}, column {name} (characters {starts[i] + 1}-{ends[i]}): "
                    f"cannot read {cell!r} as a number; fix or remove that cell (a blank cell "
                    "means 'not measured')"
                ) from None
            if not math.isfinite(values[-1]):
                values[-1] = math.nan
        if len(txt) > ends[-1] and txt[ends[-1] :].strip():
            raise FlightDataError(
                f"{p}: line {number} has text after the last column {names[-1]} "
                f"({txt[ends[-1] :].strip()!r}); the table's columns are fixed-width"
            )
        hv, dv, sv = values[ih], values[idr], values[isp]
        if math.isfinite(dv) and not 0 <= dv <= 360:
            raise FlightDataError(
                f"{p}: line {number}, column DRCT: wind direction {dv:g} deg is outside [0, 360]"
            )
        if math.isfinite(sv) and sv < 0:
            raise FlightDataError(
                f"{p}: line {number}, column {speed_col}: wind speed {sv:g} is negative"
            )
        if math.isfinite(hv) and math.isfinite(dv) and math.isfinite(sv):
            h.append(hv)
            d.append(dv)
            s.append(sv)
    if not h:
        raise FlightDataError(f"{p}: no level of the sounding has height, direction and speed")
    hh, dd, ss = np.array(h), np.array(d), np.array(s) * factor
    rad = np.deg2rad(dd)
    return _finish(str(p), hh, -ss * np.cos(rad), -ss * np.sin(rad))


def load_dropsonde_csv(
    path: str | os.PathLike[str],
    *,
    altitude: str = "altitude",
    speed: str | None = "speed",
    direction: str | None = "direction",
    u: str | None = None,
    v: str | None = None,
    altitude_unit: str = "m",
    speed_unit: str = "m/s",
    direction_unit: str = "deg",
    altitude_offset: float = 0.0,
    delimiter: str | None = None,
) -> WindProfile:
    """Wind profile from a dropsonde-style CSV: altitude and either speed/direction or u/v.

    Parameters
    ----------
    path : path-like
        CSV with a header line (a leading ``#`` is ignored); delimiter detected unless given.
    altitude : str
        Column of altitude (above mean sea level, or add ``altitude_offset``).
    speed, direction : str
        Columns of wind speed and meteorological direction (FROM, clockwise from north).
    u, v : str, optional
        Columns of the eastward (u) and northward (v) wind components; when both are given they
        are used instead of speed/direction.
    altitude_unit : {"m", "ft", "km"}
    speed_unit : {"m/s", "knot", "kn", "kt", "km/h", "mph"}
        Unit of speed or of u/v.
    direction_unit : {"deg", "rad"}
    altitude_offset : float
        Added to the altitudes after conversion, m (e.g. the ground altitude for heights above
        ground).

    Returns
    -------
    WindProfile

    Raises
    ------
    FlightDataError
        Missing columns (with the ones present), bad numbers, units that do not fit the values
        (directions beyond 360 deg, or within 2π when in "deg"; speeds over 120 m/s).
    """
    p = Path(path)
    if speed_unit not in _SPEED_UNITS:
        raise FlightDataError(
            f"unknown speed_unit {speed_unit!r}; {suggest(speed_unit, _SPEED_UNITS)}"
        )
    if altitude_unit not in _LENGTH_UNITS:
        raise FlightDataError(
            f"unknown altitude_unit {altitude_unit!r}; {suggest(altitude_unit, _LENGTH_UNITS)}"
        )
    if direction_unit not in ("deg", "rad"):
        raise FlightDataError(f"direction_unit must be 'deg' or 'rad', got {direction_unit!r}")
    try:
        text = p.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise FlightDataError(f"no such file: {p}") from None
    numbered = [(i + 1, ln) for i, ln in enumerate(text.splitlines()) if ln.strip()]
    lines = [ln for _, ln in numbered]
    line_no = [n for n, _ in numbered]
    if len(lines) < 2:
        raise FlightDataError(f"{p}: expected a header line and at least one level")
    head = lines[0].lstrip().lstrip("#")
    if delimiter is None:
        try:
            delimiter = csv.Sniffer().sniff(head, delimiters=",;\t ").delimiter
        except csv.Error:
            delimiter = ","
    names = [c.strip() for c in next(csv.reader([head], delimiter=delimiter))]
    rows = [
        [c.strip() for c in r]
        for r in csv.reader(lines[1:], delimiter=delimiter, skipinitialspace=True)
    ]
    use_uv = u is not None or v is not None
    if use_uv and (u is None or v is None):
        raise FlightDataError("give both u (eastward) and v (northward) columns, or neither")
    wanted = [altitude, *((u, v) if use_uv else (speed, direction))]
    for c in wanted:
        if c is None or c not in names:
            raise FlightDataError(f"{p}: column {c!r} is not in the file; {suggest(str(c), names)}")

    def col(name: str) -> NDArray[np.float64]:
        j = names.index(name)
        out = np.empty(len(rows))
        for i, r in enumerate(rows):
            if len(r) != len(names):
                cut = " (the file is cut short?)" if i == len(rows) - 1 else ""
                raise FlightDataError(
                    f"{p}: line {line_no[i + 1]} has {len(r)} fields, the header {len(names)}{cut}"
                )
            txt = r[j]
            if txt == "" or txt.lower() in ("nan", "na", "-"):
                out[i] = np.nan
                continue
            try:
                out[i] = float(txt)
            except ValueError:
                raise FlightDataError(
                    f"{p}: line {line_no[i + 1]}, column {j + 1} ({name!r}): cannot read "
                    f"{txt!r} as a number"
                ) from None
        return out

    h = col(altitude) * _LENGTH_UNITS[altitude_unit] + float(altitude_offset)
    f = _SPEED_UNITS[speed_unit]
    if use_uv:
        east, north = col(str(u)) * f, col(str(v)) * f
    else:
        s = col(str(speed)) * f
        d = col(str(direction))
        ok_d = d[np.isfinite(d)]
        if direction_unit == "deg":
            out_of_range = np.flatnonzero(np.isfinite(d) & ((d < 0) | (d > 360)))
            if out_of_range.size:
                i = int(out_of_range[0])
                raise FlightDataError(
                    f"{p}: line {line_no[i + 1]}, column {direction!r}: direction {d[i]:.6g} "
                    "deg is outside [0, 360]"
                )
            if ok_d.size >= 5 and np.max(ok_d) <= 2 * math.pi and np.ptp(ok_d) > 0:
                raise FlightDataError(
                    f"{p}: all {ok_d.size} directions lie in [0, 2π] ({ok_d.min():.3g} to "
                    f"{ok_d.max():.3g}): they look like radians given as degrees; set "
                    "direction_unit='rad'"
                )
            rad = np.deg2rad(d)
        else:
            if ok_d.size and (np.any(ok_d < -1e-9) or np.any(ok_d > 2 * math.pi + 1e-6)):
                raise FlightDataError(
                    f"{p}: directions in rad must be in [0, 2π], got up to {ok_d.max():.4g}: "
                    "degrees given as radians? set direction_unit='deg'"
                )
            rad = d
        negative = np.flatnonzero(np.isfinite(s) & (s < 0))
        if negative.size:
            i = int(negative[0])
            raise FlightDataError(
                f"{p}: line {line_no[i + 1]}, column {speed!r}: wind speed {s[i] / f:.6g} is "
                "negative (a speed is >= 0)"
            )
        north, east = -s * np.cos(rad), -s * np.sin(rad)
    ok = np.isfinite(h) & np.isfinite(north) & np.isfinite(east)
    return _finish(str(p), h[ok], north[ok], east[ok])


@dataclass
class WindUncertainty:
    """Seeded random perturbations of a wind profile (imperfectly known wind).

    Each realisation adds to the profile's speed and direction two independent zero-mean
    Gaussian processes of altitude with exponential correlation
    ``corr(Δh) = exp(-|Δh| / correlation_length_m)`` (a first-order Gauss–Markov process,
    generated exactly level by level)::

        speed'(h) = max(speed(h) + σ_s · a(h), 0),   direction'(h) = direction(h) + σ_d · b(h)

    with ``a``, ``b`` of unit variance. The realisations are evaluated at the profile's levels
    plus a uniform grid of step ``correlation_length_m / 4`` over the altitude range (the
    profile's, extended to ``altitude_range`` when given), so that the perturbations vary with
    altitude even for a profile of few levels.

    Parameters
    ----------
    sigma_speed : float
        Standard deviation of the speed perturbation, m/s (>= 0).
    sigma_direction_deg : float
        Standard deviation of the direction perturbation, deg (>= 0).
    correlation_length_m : float
        Altitude over which the perturbations decorrelate to 1/e, m (> 0).
    seed : int
        Seed; realisation k comes from the k-th child of ``numpy.random.SeedSequence(seed)``, so
        the first k realisations do not depend on how many are asked for.
    altitude_range : (float, float), optional
        Altitudes (m above MSL) the realisations must cover (e.g. from the flight), added to the
        profile's range.

    Notes
    -----
    The speed is clipped at 0, which biases the mean speed upwards where the speed is smaller
    than about 2 σ_s; elsewhere mean and standard deviation are those stated.
    """

    sigma_speed: float
    sigma_direction_deg: float
    correlation_length_m: float
    seed: int
    altitude_range: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        for name in ("sigma_speed", "sigma_direction_deg"):
            val = getattr(self, name)
            if not (math.isfinite(val) and val >= 0):
                raise FlightDataError(f"{name} must be a finite standard deviation >= 0, got {val}")
        if not (math.isfinite(self.correlation_length_m) and self.correlation_length_m > 0):
            raise FlightDataError(
                f"correlation_length_m must be > 0 m, got {self.correlation_length_m}"
            )
        if isinstance(self.seed, bool) or not isinstance(self.seed, int | np.integer):
            raise FlightDataError(
                f"seed must be an integer (reproducible realisations), got {self.seed!r}"
            )
        if self.altitude_range is not None:
            lo, hi = (float(x) for x in self.altitude_range)
            if not (math.isfinite(lo) and math.isfinite(hi) and hi >= lo):
                raise FlightDataError(
                    f"altitude_range must be (low, high) in m with high >= low, got "
                    f"{self.altitude_range}"
                )

    def grid(self, profile: WindProfile) -> NDArray[np.float64]:
        """Altitudes (m) at which the realisations of ``profile`` are given."""
        lo, hi = float(profile.altitude[0]), float(profile.altitude[-1])
        if self.altitude_range is not None:
            lo, hi = min(lo, self.altitude_range[0]), max(hi, self.altitude_range[1])
        step = self.correlation_length_m / 4
        n = min(int(np.ceil((hi - lo) / step)) + 1, 4000) if hi > lo else 1
        g = np.linspace(lo, hi, n) if n > 1 else np.array([lo])
        return np.unique(np.concatenate([g, profile.altitude]))

    def _process(self, h: NDArray[np.float64], rng: np.random.Generator) -> NDArray[np.float64]:
        z = rng.standard_normal((h.size, 2))
        x = np.empty((h.size, 2))
        x[0] = z[0]
        rho = np.exp(-np.diff(h) / self.correlation_length_m)
        for k in range(1, h.size):
            x[k] = rho[k - 1] * x[k - 1] + math.sqrt(1 - rho[k - 1] ** 2) * z[k]
        return x

    def realisations(self, profile: WindProfile, m: int) -> list[WindProfile]:
        """``m`` seeded random realisations of ``profile`` (see the class docstring).

        Parameters
        ----------
        profile : WindProfile
            The nominal (measured) profile.
        m : int
            Number of realisations, >= 1.

        Returns
        -------
        list of WindProfile
            Same seed and profile give the same realisations.
        """
        if isinstance(m, bool) or not isinstance(m, int | np.integer) or m < 1:
            raise FlightDataError(f"m must be an integer >= 1 (number of realisations), got {m!r}")
        h = self.grid(profile)
        speed, direction = profile.speed_direction(h)
        children = np.random.SeedSequence(int(self.seed)).spawn(int(m))
        out = []
        for child in children:
            x = self._process(h, np.random.default_rng(child))
            s = np.maximum(speed + self.sigma_speed * x[:, 0], 0.0)
            d = np.deg2rad(direction + self.sigma_direction_deg * x[:, 1])
            out.append(WindProfile(h, -s * np.cos(d), -s * np.sin(d)))
        return out
