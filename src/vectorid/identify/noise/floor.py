"""The noise floor: a seeded Monte Carlo of the criteria a *perfect* model takes under the
stated measurement noise (:func:`noise_floor` for flight drops, :func:`record_noise_floor` for
the records of a model of your own), and its quantiles (:class:`NoiseFloor`). See
:mod:`vectorid.identify.noise` for the twin experiment it flies.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vectorid._hints import waiting
from vectorid.errors import StudyDefinitionError, VectoridNote, plural, suggest
from vectorid.identify.criteria import INDICES, OPERATORS, get_criterion, spectral_defs
from vectorid.identify.drops import fit_initial_state
from vectorid.identify.flight import FlightChannel, FlightData
from vectorid.identify.identification import INTEGRAL_CRITERIA, sim_channel
from vectorid.identify.noise.estimate import estimate_noise, estimate_sigma
from vectorid.identify.noise.statements import (
    DISCREPANCY_RULES,
    NOISE_KEYS,
    ComponentNoise,
    NoiseModel,
    allowance_label,
    parse_discrepancy,
)
from vectorid.identify.system import (
    Record,
    SystemIdentification,
    at_reference,
    parse_record_noise,
)

__all__ = [
    "NoiseFloor",
    "needed_channels",
    "noise_floor",
    "record_noise_floor",
    "time_mean_unit",
]


def _err(field_: str, problem: str, fix: str = "") -> StudyDefinitionError:
    return StudyDefinitionError(f"identification.{field_}", problem, fix)


#: Library criteria that depend on the residual sim − meas only: evaluated for all draws in
#: one call as crit(sim − noise, truth). The others are evaluated draw by draw. They are the
#: integral criteria but the three profiles (speed, heading, turn rate: functions of each
#: signal, not of their difference), plus the final miss.
_PROFILES = frozenset({"speed_profile", "heading_profile", "control_response"})
_RESIDUAL_ONLY = (INTEGRAL_CRITERIA - _PROFILES) | {"landing_error"}

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
            how = f"q={q:.4g}, joint {coverage:.0%} over {plural(len(names), 'criterion')}"
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
    return {ch: sim_channel(res, ch, origin_alt) for ch in channels}


def _criterion_unit(ident, j: int) -> str:
    c = ident.criteria[j]
    u = ident.defs[j].unit
    if ident.window_vars and c.operator is None and c.use in INTEGRAL_CRITERIA:
        return time_mean_unit(u)
    return u


def time_mean_unit(u: str) -> str:
    """The unit of an integral criterion read as a time-mean (divided by the window length):
    ``"m·s"`` -> ``"m"``, ``"m"`` -> ``"m/s"``."""
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
    # seconds on a quiet machine, minutes on a busy one: said when it lasts (signs of life)
    with waiting(f"computing the noise floors ({draws} draws of the twin experiment)", after=5.0):
        return _noise_floor(ident, noise, draws=draws, seed=seed, params=params,
                            discrepancy=discrepancy, criteria=criteria, linear=linear)  # fmt: skip


def _noise_floor(ident, noise, *, draws, seed, params, discrepancy, criteria, linear):
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
            nm = estimate_noise(d.flight, needed_channels(ident, d))
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
        # the samples that matter: the two around each grid point (FlightChannel.at interpolates
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
        # ... interpolated onto the comparison grid as FlightChannel.at does
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
            g = arr[:, pi]
            g *= (1 - w)[None, :, None]
            g += w[None, :, None] * arr[:, pj]
            on_grid[ch] = g
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
                if w is winds[0]:
                    _say_unfitted_start(d, jac, on_grid)
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

#: How far off an unrecorded start is taken to be when it is said to matter: attitude, rad
#: (about 3°), and body rates, rad/s.
UNFITTED_START = {"euler": 0.05, "rates": 0.05}


def _say_unfitted_start(d, jac: Mapping[str, NDArray], on_grid: Mapping[str, NDArray]) -> None:
    """A note when drop ``d`` records no attitude or no body rates, so that its fitted start
    assumes a level attitude or no rotation (:func:`~vectorid.identify.drops.fit_initial_state`),
    and the channels the criteria read depend on that assumption by more than their noise: the
    floor flies the truth from the fitted start, so it leaves this error out and D at the
    limits it sets can miss a truth that started otherwise."""
    missing = [s for s in UNFITTED_START if s not in d.flight.channels]
    if not missing:
        return
    rows = [i for i, (name, _, _) in enumerate(_STATE) if name in missing]
    worst = None
    for ch, J in jac.items():
        if ch not in on_grid:
            continue
        noise = float(np.median(np.std(on_grid[ch], axis=0))) if on_grid[ch].size else 0.0
        shift = max(float(np.max(np.abs(J[i]))) * UNFITTED_START[_STATE[i][0]] for i in rows)
        if shift > max(noise, 1e-12) and (worst is None or shift / max(noise, 1e-12) > worst[0]):
            worst = (shift / max(noise, 1e-12), ch, shift, noise)
    if worst is None:
        return
    _, ch, shift, noise = worst
    unit = str(getattr(d.flight.channels.get(ch), "unit", "") or "")
    unit = f" {unit}" if unit else ""
    labels = {"euler": "attitude (euler)", "rates": "body rates (rates)"}
    assumed = {"euler": "a level attitude", "rates": "no rotation"}
    units = {"euler": "rad", "rates": "rad/s"}
    what = " and ".join(labels[m] for m in missing)
    off = " / ".join(f"{UNFITTED_START[m]:g} {units[m]}" for m in missing)
    warnings.warn(
        VectoridNote(
            f"drop {d.name!r} records no {what}: its fitted start assumes "
            f"{' and '.join(assumed[m] for m in missing)}, and a start {off} off moves the "
            f"simulated {ch} by up to {shift:.3g}{unit} (its noise: {noise:.3g}{unit}); the "
            "noise floor leaves this error out, so D at its limits can miss a truth that "
            "started otherwise — record attitude and rates, or allow for it with a "
            "discrepancy allowance on the criteria that read this drop"
        ),
        stacklevel=4,
    )


def needed_channels(ident, d) -> list[str]:
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
    idx = INDICES.get(use)
    if idx is None and use.startswith("peak_"):
        idx = spectral_defs(use)[0]
    if idx is None or (operator is None and not use.startswith("peak_")):
        return None
    return idx.fn, OPERATORS["absdiff" if operator is None else operator]


def _per_draw(cdef, c, sims: NDArray, meas: NDArray, grid: NDArray) -> NDArray:
    """One criterion for every draw: ``sims`` and ``meas`` (draws, T, m), each draw's
    simulation against its own measurement. An index criterion takes two batched calls
    (the index of every simulation, the index of every measurement), checked against the
    criterion itself on three draws; any other is evaluated draw by draw."""

    def direct(r: int) -> float:
        return float(cdef.fn(sims[r][None], meas[r], grid)[0])

    def checked(v: NDArray) -> bool:
        check = [direct(r) for r in range(min(3, len(v)))]
        return np.allclose(check, v[: len(check)], rtol=1e-9, atol=1e-12, equal_nan=True)

    form = _index_form(c.use, c.operator)
    if form is not None:
        index, op = form
        v = np.asarray(op(index(sims, grid), index(meas, grid)), dtype=float)
        if checked(v):
            return v
    # a criterion that takes one measurement per simulation (the profile criteria: the
    # measurement as (draws, T, m)) in one call; any other answers wrongly or raises here,
    # and is evaluated draw by draw below, where a real error is raised
    try:
        v = np.asarray(cdef.fn(sims, meas, grid), dtype=float)
        if v.shape == (sims.shape[0],) and checked(v):
            return v
    except Exception:  # the draw-by-draw path below decides
        pass
    return np.array([direct(r) for r in range(sims.shape[0])])


def _fit_state(fit_in, values: Mapping[str, NDArray], t0: float, span: float):
    """The identification's initial-state fit (:func:`vectorid.identify.drops._initial_state`)
    on noise alone: ``values[ch]`` (n_fit, m) at the fit samples (zeros where absent)."""
    chans = {}
    for ch, (c, sel, _) in fit_in.items():
        v = values.get(ch)
        v = np.zeros((sel.size, c.m)) if v is None else v
        chans[ch] = FlightChannel(ch, c.t[sel], v, c.components, c.unit)
    return _state_vector(
        fit_initial_state(FlightData("noise", chans), t0, span, 0.0, None, "noise")
    )


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
        chans[ch] = FlightChannel(ch, tt, vals, c.components, c.unit)
    try:
        fitted = fit_initial_state(
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
    key, factor, unit = allowance_label(ch, comps)
    notes[c.name] = f"discrepancy {key} {delta / factor:.3g} {unit}".rstrip()
    return out


# -- a model of your own: records with stated initial states ----------------------------------


def _interp_matrix(grid: NDArray, t: NDArray) -> NDArray:
    """W (T, N) with W @ y = np.interp(grid, t, y) for every y sampled at t."""
    W = np.zeros((grid.size, t.size))
    j = np.clip(np.searchsorted(t, grid, side="right") - 1, 0, t.size - 2)
    w = np.clip((grid - t[j]) / (t[j + 1] - t[j]), 0.0, 1.0)
    rows = np.arange(grid.size)
    W[rows, j] = 1.0 - w
    W[rows, j + 1] += w
    return W


def _record_noise(spec, ident: SystemIdentification, i: int, rec: Record):
    """The noise of each output channel of record ``i``: channel -> (ComponentNoise, words)."""
    table = spec.extra["identification"]
    study = table.get("noise")
    tables = table.get("data", [])
    own = tables[i].get("noise") if i < len(tables) and isinstance(tables[i], Mapping) else None
    out: dict[str, tuple[Any, str]] = {}
    for value, src in ((study, "noise"), (own, f"data[{i}].noise")):
        if value is None:
            continue
        parsed = parse_record_noise(value, ident.model, src)
        if parsed == "estimate":
            for ch, y in rec.values.items():
                s = float(estimate_sigma(rec.t, y[:, None])[0])
                out[ch] = (ComponentNoise(s), f"{ch} estimated σ {s:.3g} {ident.model.unit_of(ch)}")
        else:
            for ch, c in parsed.items():
                out[ch] = (c, f"{ch} {c.describe(1.0, ident.model.unit_of(ch))}")
    return out


def record_noise_floor(
    spec, ident: SystemIdentification, targets: Sequence[str], *, draws: int = 2000, seed: int = 0
) -> tuple[NoiseFloor, list[str]]:
    """The noise floor of the criteria ``targets`` of a model of your own, and the noise used,
    in words (one entry per record and channel).

    The truth is the model at the reference vector (the variables' nominal values, else the
    middle of their box), flown from each record's stated initial state; noise is drawn at
    every sample time of the record, interpolated onto the comparison grid as the real data
    are, and the perfect model is compared with it by each criterion's own function (see
    :mod:`vectorid.identify.system`). The initial state is stated, not fitted, so the floor
    holds no initial-state error.

    Raises
    ------
    StudyDefinitionError
        A target reads a channel without stated noise, or the model fails at the reference.
    """
    draws, seed = int(draws), int(seed)
    ref = np.array(
        [
            float(v.nominal) if v.nominal is not None else 0.5 * (float(v.low) + float(v.high))
            for v in spec.space
        ]
    )
    rng = np.random.default_rng(seed)
    names = ident.criterion_names
    S = np.zeros((draws, len(names)))
    W = np.zeros(len(names))
    described: list[str] = []
    for i, rec in enumerate(ident.records):
        noise = _record_noise(spec, ident, i, rec)
        described += [f"{rec.name}: {d}" for _, d in noise.values()]
        needed = [
            j for j, c in enumerate(ident.criteria) if c.name in targets and ident.applies(c, rec)
        ]
        for j in needed:
            c = ident.criteria[j]
            if c.channel not in noise:
                raise _err(
                    "noise",
                    f"criterion {c.name!r} is limited by the noise, but no noise is stated for "
                    f"its channel {c.channel!r} (record {rec.name!r})",
                    f"add {c.channel} = σ (in {ident.model.unit_of(c.channel)}) to "
                    f'noise = {{ ... }} under [identification], or noise = "estimate", or give '
                    f"{c.name} a number",
                )
        if not needed:
            continue
        # the truth on the record's sample times and on the comparison grid
        named = dict(zip(ident.variables, ref.tolist()))
        with at_reference(f"the model {type(ident.model).__name__}", named):
            fine = ident.model.simulate(
                ident.parameters(ref[None, :]),
                t_final=rec.duration,
                dt=ident.dt,
                output_dt=ident.dt,
                initial=rec.initial,
            )
        if not fine.ok[0]:
            raise _err(
                "noise",
                f"the model fails at the reference vector "
                f"{dict(zip(ident.variables, ref.tolist()))}: "
                f"{fine.messages[0]}",
                "give the variables nominal values where the model runs",
            )
        for ch in dict.fromkeys(ident.criteria[j].channel for j in needed):
            bad = ~np.isfinite(fine[ch][0])
            if bad.any():  # the states ran, the output did not: say so, not "a limit is NaN"
                at = float(fine.t[np.argmax(bad)])
                raise _err(
                    "noise",
                    f"the model's output {ch!r} is not a finite number at the reference vector "
                    f"{dict(zip(ident.variables, ref.tolist()))} (NaN or inf at {int(bad.sum())} "
                    f"of {bad.size} times, first at t = {at:g} s of record {rec.name!r}), so "
                    "the noise floor of "
                    + ", ".join(
                        ident.criteria[j].name for j in needed if ident.criteria[j].channel == ch
                    )
                    + " cannot be computed",
                    f"check {type(ident.model).__name__}.output(t, x, p) for {ch!r} (the states "
                    "stay finite there), or give the variables nominal values where it runs",
                )
        tf = rec.t0 + fine.t
        inside = (rec.t >= rec.t0 - 1e-9) & (rec.t <= rec.t0 + rec.duration + 1e-9)
        ts = rec.t[inside]
        Wm = _interp_matrix(rec.grid, ts)
        for j in needed:
            c = ident.criteria[j]
            truth_s = np.interp(ts, tf, fine[c.channel][0])
            truth_g = np.interp(rec.grid, tf, fine[c.channel][0])
            comp = noise[c.channel][0]
            meas = (truth_s[None, :] + comp.draw(ts, draws, rng)) @ Wm.T  # (draws, T)
            if c.builtin:  # residual kinds are symmetric: the draws as the batch
                v = c.fn(meas[:, :, None], truth_g[:, None], rec.grid)
            else:
                sim = truth_g[None, :, None]
                with at_reference(f"criterion {c.name} ({c.use})", named):
                    v = np.array([c.value(c.fn(sim, m[:, None], rec.grid), 1)[0] for m in meas])
            S[:, j] += rec.weight * v
            W[j] += rec.weight
    S = S / np.where(W > 0, W, 1.0)
    for j, c in enumerate(ident.criteria):
        if c.name in targets and not np.all(np.isfinite(S[:, j])):
            raise _err(
                f"criteria.{c.name}",
                f"criterion {c.name!r} ({c.use}) is not a finite number on the noise-floor "
                "draws (the model at the reference vector compared with itself plus the stated "
                f"noise): {int(np.sum(~np.isfinite(S[:, j])))} of {draws} draws are NaN or inf",
                "make the criterion's function return finite numbers for finite inputs, or "
                "give it a number as its limit",
            )
    floor = NoiseFloor(
        names=names,
        units=[c.unit for c in ident.criteria],
        samples=S,
        allowance={},
        notes={},
        draws=draws,
        seed=seed,
        noise={},
    )
    return floor, described
