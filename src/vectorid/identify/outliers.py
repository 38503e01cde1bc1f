"""Single-sample spikes in a measured series: found, reported with their times, left out.

A spike is a sample that departs from the running median of its neighbours (5 samples; at the
ends, the quadratic through the next inner samples) by more than ``k`` times the channel's own
local noise (the robust σ of its second differences over 25 samples, 1.4826 × their median
/ sqrt(6): relative to the channel's scatter there, so a noisy stretch's excursions stay and
a quiet one's glitch does not) and by more than an absolute floor. A real motion moves the
neighbours with it; a corrupt sample, a radio glitch or a last row written half-way does not.
Runs of up to two samples are caught; longer disturbances (an ejection's pressure pulse over a
second) are not spikes and stay in the data, where the phase windows and the settling times
deal with them.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from vectorid.errors import VectoridWarning
from vectorid.identify.flight import FlightChannel, FlightData, FlightDataError

__all__ = ["SPIKE_FLOORS", "SPIKE_POLICIES", "Spikes", "drop_spikes", "find_spikes"]


@dataclass(frozen=True)
class Spikes:
    """Samples of a series found to be spikes.

    Attributes
    ----------
    index : ndarray of int
        Their indices in the series.
    times : ndarray
        Their times, s.
    values : ndarray
        Their values (the series' unit).
    expected : ndarray
        The running median there (what the neighbours say).
    """

    index: NDArray[np.int64]
    times: NDArray[np.float64]
    values: NDArray[np.float64]
    expected: NDArray[np.float64]

    def __len__(self) -> int:
        return int(self.index.size)

    def describe(self, what: str, unit: str, limit: int = 5) -> str:
        """One line: ``what`` has N spikes at t = ... (value against the neighbours')."""
        items = [
            f"{t:.2f} s ({v:.4g} {unit}, neighbours {e:.4g} {unit})"
            for t, v, e in zip(self.times[:limit], self.values[:limit], self.expected[:limit])
        ]
        more = f" and {len(self) - limit} more" if len(self) > limit else ""
        s = "" if len(self) == 1 else "s"
        return f"{what}: {len(self)} single-sample spike{s} at {', '.join(items)}{more}"


def find_spikes(t, x, *, k: float = 10.0, floor: float = 0.0, window: int = 5) -> Spikes:
    """Spikes of the series ``x(t)`` (see the module docstring).

    Parameters
    ----------
    t, x : array_like
        Times (s) and values; ``x`` of shape (n,) or (n, m) (a sample is a spike when any
        column is).
    k : float
        Threshold in robust standard deviations of the departures from the running median.
    floor : float
        Smallest departure counted, in the unit of ``x`` (e.g. 10 m for a height: a barometer's
        own noise is never a spike); 0: the series' range (1st to 99th
        percentile), so that only a glitch far outside what the channel does is one.
    window : int
        Samples of the running median (odd, >= 3).

    Returns
    -------
    Spikes
    """
    from scipy.ndimage import median_filter

    t = np.asarray(t, dtype=float).ravel()
    x = np.asarray(x, dtype=float)
    x2 = x[:, None] if x.ndim == 1 else x
    n = x2.shape[0]
    empty = np.zeros(0)
    if n < window + 2:
        return Spikes(np.zeros(0, dtype=np.int64), empty, empty, empty)
    window = max(3, int(window) | 1)
    bad = np.zeros(n, dtype=bool)
    med = np.empty_like(x2)
    for j in range(x2.shape[1]):
        col = x2[:, j]
        finite = np.isfinite(col)
        m = median_filter(np.where(finite, col, np.nanmedian(col)), size=window, mode="nearest")
        # at the ends the window is one-sided, and a trend would make the end samples depart
        # from a median: the quadratic through the next six inner samples, extrapolated
        h = window // 2
        for lo, ends in ((h, range(h)), (n - h - 6, range(n - h, n))):
            ti, xi = t[lo : lo + 6], col[lo : lo + 6]
            ok = np.isfinite(xi)
            if ok.sum() >= 4:
                c = np.polyfit(ti[ok] - ti[0], xi[ok], 2)
                for i in ends:
                    m[i] = np.polyval(c, t[i] - ti[0])
        med[:, j] = m
        r = col - m
        with np.errstate(invalid="ignore", over="ignore"):
            a = np.where(np.isfinite(r), np.abs(r), np.nan)
            fin = a[np.isfinite(a)]
            if fin.size == 0:
                bad |= ~finite
                continue
            # the local noise: the robust σ of the second differences over `span` samples,
            # / sqrt(6) per sample (white noise of σ gives second differences of σ sqrt(6)); a
            # spike moves three second differences, the median of `span` not at all, and a
            # trend or a slowly changing rate gives none, so the channel's own noise decides:
            # a 12-m excursion of a barometer whose samples scatter by ±8 m after an ejection
            # is its noise, a 12-m jump of a quiet one is a spike
            span = min(n, 25) | 1
            cf = np.where(finite, col, m)
            d2 = np.abs(cf[2:] - 2.0 * cf[1:-1] + cf[:-2])
            d2 = np.where(np.isfinite(d2), d2, np.inf)
            d2 = np.concatenate([d2[:1], d2, d2[-1:]])  # sample i: the difference centred on it
            local = median_filter(d2, size=span, mode="nearest")
            # at the ends, the median of the first (last) `span` differences, not of a window
            # padded with the end value (a corrupt last row would set its own threshold)
            hs = span // 2
            local[:hs] = np.median(d2[:span])
            local[n - hs :] = np.median(d2[-span:])
            scale = 1.4826 * local / np.sqrt(6.0)
            spread = float(np.percentile(col[finite], 99) - np.percentile(col[finite], 1))
            thr = np.maximum(k * scale, floor if floor > 0 else spread)
            bad |= ~finite
            if np.any(thr > 0):
                bad |= (a > thr) & (thr > 0)
    idx = np.flatnonzero(bad).astype(np.int64)
    if idx.size == 0:
        return Spikes(idx, empty, empty, empty)
    # a spike is at most two samples: a longer run is a real change (or a step) and stays
    runs = np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1)
    idx = np.concatenate([r for r in runs if r.size <= 2] or [np.zeros(0, dtype=np.int64)])
    with np.errstate(invalid="ignore", over="ignore"):
        dev = np.abs(np.nan_to_num(x2[idx] - med[idx], nan=np.inf))
    c = np.argmax(dev, axis=1) if idx.size else np.zeros(0, dtype=np.int64)
    rows = np.arange(idx.size)
    return Spikes(idx, t[idx], x2[idx][rows, c], med[idx][rows, c])


#: Smallest departure counted as a spike, by channel (its SI unit); other channels: none.
SPIKE_FLOORS = {"altitude": 10.0, "gps_altitude": 10.0, "position": 10.0, "velocity": 5.0}
SPIKE_POLICIES = ("drop", "note", "keep", "strict")


def drop_spikes(fd, source: str = "", policy: str = "drop"):
    """The flight with the single-sample spikes of every channel left out (:func:`find_spikes`).

    Each channel's spikes are named with their times in ``fd.notes`` and in a
    :class:`~vectorid.errors.VectoridWarning`. ``policy``: ``"drop"`` (default) leaves them
    out, ``"keep"`` keeps the data as they are, ``"note"`` leaves them out with the note only
    (no warning: for a caller that reports the notes itself), ``"strict"`` raises
    :class:`~vectorid.identify.flight.FlightDataError` naming them.
    """
    if policy not in SPIKE_POLICIES:
        raise FlightDataError(
            f"{source}: spikes = {policy!r}; expected one of {', '.join(SPIKE_POLICIES)}"
        )
    if policy == "keep":
        return fd
    pre = f"{source}: " if source else ""
    channels = dict(fd.channels)
    notes = list(fd.notes)
    for name, ch in fd.channels.items():
        if ch.t.size < 8:
            continue
        floor = SPIKE_FLOORS.get(name, 0.0)
        values = np.asarray(ch.values, dtype=float)
        period = {"rad": 2.0 * np.pi, "deg": 360.0}.get(ch.unit)
        if period is not None and np.isfinite(values).all():
            # an angle that wraps (a heading through 360° -> 0°) is continuous, not a spike
            values = np.unwrap(values, axis=0, period=period)
        sp = find_spikes(ch.t, values, floor=floor)
        if floor == 0.0 and len(sp):
            # a channel without a length or speed floor (angles, rates, controls, ...): its
            # first and last samples stay (an oscillation's edge is not a glitch); inside, a
            # spike must still be as far from its neighbours as the channel's whole range
            inner = (sp.index > 0) & (sp.index < ch.t.size - 1)
            sp = Spikes(sp.index[inner], sp.times[inner], sp.values[inner], sp.expected[inner])
        if not len(sp):
            continue
        text = sp.describe(f"channel {name!r}", ch.unit)
        if policy == "strict":
            raise FlightDataError(
                f"{pre}{text}; the data were asked to be used as they are (strict): fix or cut "
                "those samples, or let them be left out"
            )
        keep = np.ones(ch.t.size, dtype=bool)
        keep[sp.index] = False
        channels[name] = FlightChannel(ch.name, ch.t[keep], ch.values[keep], ch.components, ch.unit)
        notes.append(f"{text}: left out")
        if policy == "drop":
            warnings.warn(f"{pre}{text}: left out", VectoridWarning, stacklevel=3)
    return FlightData(fd.name, channels, dict(fd.events), fd.origin, notes)
