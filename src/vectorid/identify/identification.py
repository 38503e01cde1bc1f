"""Identification → Problem: a model, one or several drops and adequacy criteria become a PSI
:class:`~vectorid.problem.Problem`, so run, store, tables and Pareto work unchanged.

For each trial α of a batch and each drop, the model is simulated from the drop's measured
state at the window start, with the drop's wind profile and control history, on the output
grid ``t0, t0 + output_dt, ...`` of the window; every adequacy criterion Φ_l(α) of the
library (:data:`vectorid.identify.criteria.CRITERIA`) compares the simulated channel with the
measurement interpolated onto that grid. A criterion over several drops is the weighted mean
of its per-drop values. With ``wind_realisations = M > 1`` every drop is simulated under M
seeded realisations of its wind profile (:class:`vectorid.identify.WindUncertainty`) and the
criteria are the expectation (mean) over them (seed 000 §V). "Drop-out" constraints (seed 001
Fig. 2) are functionals: the mean over realisations and the worst drop.

The ``[identification]`` table of a study file
----------------------------------------------
(For a model of your own, a :class:`~vectorid.models.SystemModel`, the table holds
``[[identification.data]]`` records instead of drops: see :mod:`vectorid.identify.system`.)
::

    [study]
    name = "g12-uncontrolled"
    model = "parachute6dof"          # the model (registry name); identification.model overrides
    trials = 2048

    [[variables]]                    # design variables: model parameters by name
    name = "x6"
    low = 0.0
    high = 0.6

    [[variables]]                    # reserved: offset (s) of the window start t0 from the
    name = "window_start"            # drop's window (window_end: of tf; window_start.<drop>:
    low = -1.0                       # one drop). Trials are grouped by t0 rounded to
    high = 5.0                       # window_step; integral criteria become time-means.

    [[criteria]]                     # study columns: a library name, or a name defined below
    name = "pos_h_abs"
    [[criteria]]
    name = "yaw_sq"
    role = "pseudo"

    [[constraints]]                  # drop-out constraint: 0 when the channel stays in its band
    name = "out_vz"
    high = 0.0

    [identification]
    dt = 0.05                        # integration step, s
    output_dt = 0.5                  # output (comparison) grid, s
    wind_realisations = 4            # M >= 1: expectation over M seeded wind realisations
    seed = 7                         # seed of the wind realisations
    init_span = 1.0                  # s of data fitted (linear) for the initial state
    parameters = { x13 = 0.6 }       # fixed values of model parameters (others stay nominal)
    model_options = { payload_mass = 700.0 }
    atmosphere = { temperature_offset = 0.0 }        # ISA + ΔT (K)
    wind_uncertainty = { sigma_speed = 1.0, sigma_direction_deg = 10.0,
                         correlation_length_m = 300.0 }   # (one line in TOML)

    [[identification.drops]]
    name = "drop1"
    file = "drop1.csv"               # relative to the study file's folder
    format = "csv"                   # optional: csv | parquet | telemega | ulog (by extension)
    mapping = { ... }                # column/unit mapping for csv/parquet (see the loaders)
    wind = "wind1.csv"               # optional wind profile (sounding .txt or dropsonde .csv)
    window = ["canopy", "landing-5"] # times in s or event names, with optional +/- offset in s
    weight = 1.0
    inputs = { main = 1.0 }          # optional: constant inputs, or {event="main", before=0,
                                     #   after=1, ramp=1.0}; a "controls" channel whose
                                     #   components are model inputs is used as the schedule
    origin_altitude = 1394.0         # optional: altitude of the NED origin, m (default: data)

    [identification.criteria.alt_drogue]   # optional: a study criterion defined from the library
    use = "alt_abs"
    drops = ["drogue"]               # only these drops (default: all, weighted mean)

    [identification.dropout.out_vz]  # a drop-out functional for [[constraints]] out_vz
    channel = "velocity"
    components = ["down"]            # optional subset of the channel's components
    band = 3.0                       # half-width of the envelope around the measurement
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

import vectorid.identify.criteria as lib
from vectorid import models
from vectorid.errors import StudyDefinitionError, suggest
from vectorid.identify.drops import Drop, _check_keys, _err, _positive, build_drop
from vectorid.identify.noise.statements import parse_discrepancy, parse_noise
from vectorid.identify.system import SystemIdentification, resolve_model
from vectorid.identify.windprofiles import WindUncertainty
from vectorid.models.atmosphere import ISA
from vectorid.models.base import Model, SimulationResult
from vectorid.models.system import SystemModel
from vectorid.models.wind import WindProfile
from vectorid.problem import Criterion, FunctionalConstraint, Problem
from vectorid.timesteps import check_time_steps

__all__ = [
    "INTEGRAL_CRITERIA",
    "WINDOW_VARIABLES",
    "Drop",
    "DropoutDef",
    "IdentCriterion",
    "Identification",
    "parameter_meanings",
    "problem_from_spec",
    "sim_channel",
    "window_variable",
]

#: Reserved design-variable names: offsets (s) of the comparison window's start t0 and end tf
#: from the drop's ``window``; ``window_start.<drop>`` / ``window_end.<drop>`` move one drop's.
WINDOW_VARIABLES = ("window_start", "window_end")

#: Library criteria that are integrals ∫ ... dt over the window. With window variables they
#: are divided by the trial's window length (time-means), so that windows of different
#: lengths compare; indices (maxima, averages, frequencies, final miss) are left as they are.
INTEGRAL_CRITERIA = frozenset(
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
        "speed_profile",
        "heading_profile",
        "control_response",
        "alt_abs",
        "alt_sq",
        "vz_abs",
    }
)


def window_variable(name: str) -> tuple[str, str | None] | None:
    """``(kind, drop)`` of a window variable name (drop None: every drop), else None."""
    for base in WINDOW_VARIABLES:
        if name == base:
            return base, None
        if name.startswith(base + ".") and len(name) > len(base) + 1:
            return base, name[len(base) + 1 :]
    return None


if "rocket-descent" not in models.available():
    models.register("rocket-descent", "vectorid.descent.model:RocketDescent")

_TABLE_KEYS = {
    "model": "model registry name (default: study.model)",
    "drops": "array of tables [[identification.drops]]",
    "criteria": "table of criterion definitions by study criterion name",
    "dropout": "table of drop-out functionals by constraint name",
    "parameters": "fixed values of model parameters",
    "model_options": "options passed to the model constructor",
    "atmosphere": "{ temperature_offset = K } (ISA + ΔT)",
    "dt": "integration step, s",
    "output_dt": "comparison grid step, s",
    "wind_realisations": "number M of wind realisations (>= 1)",
    "wind_uncertainty": "{ sigma_speed, sigma_direction_deg, correlation_length_m }",
    "seed": "seed of the wind realisations",
    "init_span": "seconds of data fitted for the initial state",
    "window_step": "rounding step of window_start offsets, s (default output_dt)",
    "noise": 'measurement noise per channel, or "estimate" (vectorid.identify.noise)',
    "limits": '"noise": every criterion without a number gets its noise floor',
    "noise_quantile": "per-criterion quantile of the noise floor (default: joint coverage)",
    "noise_coverage": "joint coverage of the noise floors (default 0.95)",
    "noise_draws": "Monte Carlo draws of the noise floor (default 2000)",
    "noise_seed": "seed of the noise-floor draws (default 0)",
    "discrepancy": "model-discrepancy allowance: noise keys or criterion names",
}
_CRIT_KEYS = {"use", "drops", "operator"}
_DROPOUT_KEYS = {"channel", "components", "band", "drops"}


# -- criteria -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class IdentCriterion:
    """A study criterion computed from the library.

    Attributes
    ----------
    name : str
        Study column name.
    use : str
        Library name (``CRITERIA`` key).
    drops : tuple of str or None
        Drops it is computed on (None: all, weighted mean).
    operator : str or None
        Comparison operator ℜ passed to the library (None: the criterion's own).
    """

    name: str
    use: str
    drops: tuple[str, ...] | None = None
    operator: str | None = None


@dataclass(frozen=True)
class DropoutDef:
    """A drop-out functional: how far outside ``band`` around the measurement ``channel`` goes
    (0 when it stays inside; see :func:`vectorid.identify.dropout`)."""

    name: str
    channel: str
    band: float | tuple[float, ...]
    components: tuple[str, ...] | None = None
    drops: tuple[str, ...] | None = None


def sim_channel(res: SimulationResult, channel: str, origin_alt: float) -> NDArray[np.float64]:
    """Simulated channel (n, T, m) in the data's conventions (NED relative to the origin): the
    arrays the criteria compare with the measured channel (``position`` relative to the origin
    at ``origin_alt`` m above sea level, ``altitude`` above it, other channels as simulated).
    ``res`` may be in the model's frame (``res.origin_altitude`` 0: down = -altitude above sea
    level) or already relative to an origin (:meth:`Identification.simulate`)."""
    shift = origin_alt - float(getattr(res, "origin_altitude", 0.0))
    if channel == "position":
        pos = np.array(res.position)
        pos[..., 2] += shift
        return pos
    if channel == "velocity":
        return res.velocity
    if channel == "euler":
        return res.euler
    if channel == "rates":
        return res.rates
    if channel == "altitude":
        return (-res.position[..., 2] - shift)[..., None]
    if channel in res.channels:
        return res[channel][..., None]
    raise KeyError(channel)


class Identification:
    """Model + drops + adequacy criteria, evaluated as a batch model ``X -> (F, G)``.

    Parameters
    ----------
    model : str or Model
        Registry name (``vectorid.models.available()``) or a model instance.
    drops : sequence of Drop
    variables : sequence of str
        Model parameter names, in the column order of ``X``.
    criteria : sequence of IdentCriterion
    dropouts : sequence of DropoutDef
    fixed : mapping, optional
        Values of model parameters that are not design variables (others stay nominal).
    dt, output_dt : float
        Integration step and comparison grid step, s.
    wind_realisations : int
        M >= 1; with M > 1 the criteria are the mean over M seeded wind realisations.
    wind_uncertainty : mapping, optional
        Arguments of :class:`vectorid.identify.WindUncertainty` (without ``seed``).
    seed : int
    atmosphere : ISA or None
    """

    def __init__(
        self,
        model: str | Model,
        drops: Sequence[Drop],
        variables: Sequence[str],
        criteria: Sequence[IdentCriterion],
        dropouts: Sequence[DropoutDef] = (),
        *,
        fixed: Mapping[str, float] | None = None,
        dt: float = 0.05,
        output_dt: float = 0.5,
        wind_realisations: int = 1,
        wind_uncertainty: Mapping[str, Any] | None = None,
        seed: int = 0,
        atmosphere: ISA | None = None,
        window_step: float | None = None,
    ) -> None:
        self.model = models.get(model) if isinstance(model, str) else model
        self.drops = list(drops)
        if not self.drops:
            raise _err(
                "drops",
                "an identification needs at least one drop, got none",
                "add a [[identification.drops]] table",
            )
        names = [d.name for d in self.drops]
        for n in names:
            if names.count(n) > 1:
                raise _err("drops", f"drop name {n!r} is used twice", "give each drop a name")
        pnames = list(self.model.parameter_names)
        #: (column of X, "window_start" | "window_end", drop name or None for all drops)
        self.window_vars: list[tuple[int, str, str | None]] = []
        model_cols = []
        for j, v in enumerate(variables):
            w = window_variable(v)
            if w is not None:
                self._check_drops(f"variables.{v}", None if w[1] is None else (w[1],))
                for _, kind, dn in self.window_vars:
                    if kind == w[0] and (dn is None or w[1] is None or dn == w[1]):
                        raise _err(
                            "variables",
                            f"{v!r} moves a window end that another variable already moves",
                            f"keep one {w[0]} variable per drop",
                        )
                self.window_vars.append((j, w[0], w[1]))
                continue
            if v not in pnames:
                raise _err(
                    "variables",
                    f"variable {v!r} is not a parameter of model {self.model.name!r}",
                    suggest(v, [*pnames, *WINDOW_VARIABLES])
                    + " (design variables map to model parameters by name; window_start and "
                    "window_end move the comparison window)",
                )
            model_cols.append(j)
        self.variables = list(variables)
        self.model_columns = model_cols
        self.columns = [pnames.index(variables[j]) for j in model_cols]
        self.base = self.model.nominal.copy()
        for k, v in dict(fixed or {}).items():
            if k not in pnames:
                raise _err("parameters", f"unknown model parameter {k!r}", suggest(k, pnames))
            if k in self.variables:
                raise _err(
                    f"parameters.{k}",
                    f"{k!r} is both a design variable and a fixed parameter",
                    "remove it from one of them",
                )
            self.base[pnames.index(k)] = float(v)
        self.criteria = list(criteria)
        if not self.criteria:
            raise _err("criteria", "no criteria", "add [[criteria]] with library names")
        self.defs = []
        for c in self.criteria:
            key = c.use if c.operator is None else f"{c.use}:{c.operator}"
            try:
                self.defs.append(lib.get_criterion(key))
            except lib.CriterionError as exc:
                raise _err(
                    f"criteria.{c.name}",
                    f"{key!r} is not a criterion of the library ({exc})",
                    "use a name of vectorid.identify.CRITERIA, or define the study criterion "
                    "under [identification.criteria.NAME] with use = ... (and operator = ... "
                    "for an index)",
                ) from None
            self._check_drops(f"criteria.{c.name}.drops", c.drops)
        self.dropouts = list(dropouts)
        for d in self.dropouts:
            self._check_drops(f"dropout.{d.name}.drops", d.drops)
        self.dt = _positive("dt", dt)
        self.output_dt = _positive("output_dt", output_dt)
        check_time_steps(self.dt, self.output_dt, where="identification")
        self.window_step = (
            self.output_dt if window_step is None else _positive("window_step", window_step)
        )
        m = int(wind_realisations)
        if m < 1:
            raise _err(
                "wind_realisations",
                f"expected an integer >= 1, got {wind_realisations!r}",
                "use 1 for the measured profile only",
            )
        if m == 1 and wind_uncertainty:
            raise _err(
                "wind_uncertainty",
                "has no effect with wind_realisations = 1 (the measured profile only)",
                "set wind_realisations = 4 (or more) to fly the model in perturbed winds, "
                "or remove wind_uncertainty",
            )
        self.wind_realisations = m
        self.seed = int(seed)
        self.atmosphere = atmosphere
        self.winds: dict[str, list[WindProfile | None]] = {}
        for i, d in enumerate(self.drops):
            if m == 1 or d.wind is None:
                self.winds[d.name] = [d.wind]
                continue
            wu = WindUncertainty(**dict(wind_uncertainty or {}), seed=self.seed + 1009 * i)
            self.winds[d.name] = list(wu.realisations(d.wind, m))
        for d in self.drops:
            for c in self._channels_for(d.name):
                if c not in d.flight.channels:
                    raise _err(
                        "criteria",
                        f"drop {d.name!r} has no {c!r} channel for the criteria that use it",
                        f"map a {c!r} column in its loader mapping, or restrict those criteria "
                        "to other drops with drops = [...]",
                    )

    def _check_drops(self, where: str, drops: tuple[str, ...] | None) -> None:
        names = [d.name for d in self.drops]
        for n in drops or ():
            if n not in names:
                raise _err(where, f"unknown drop {n!r}", suggest(n, names))

    def _channels_for(self, drop: str) -> set[str]:
        out = set()
        for c, cdef in zip(self.criteria, self.defs):
            if c.drops is None or drop in c.drops:
                out.add(cdef.channel)
        for d in self.dropouts:
            if d.drops is None or drop in d.drops:
                out.add(d.channel)
        return out

    # -- simulation ----------------------------------------------------------------------------

    def parameters(self, X: NDArray) -> NDArray[np.float64]:
        """Full model parameter vectors (n, p_model) from design vectors X (n, p)."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        P = np.tile(self.base, (X.shape[0], 1))
        P[:, self.columns] = X[:, self.model_columns]
        return P

    def window_offsets(
        self, X: NDArray, drop: str | Drop
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Start and end offsets (s) of each trial's window on one drop, (n,) each (0 where
        no window variable applies)."""
        d = self.drop(drop) if isinstance(drop, str) else drop
        X = np.atleast_2d(np.asarray(X, dtype=float))
        s, e = np.zeros(X.shape[0]), np.zeros(X.shape[0])
        for j, kind, dn in self.window_vars:
            if dn is None or dn == d.name:
                (s if kind == "window_start" else e)[:] = X[:, j]
        return s, e

    def trial_windows(
        self, X: NDArray, drop: str | Drop
    ) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.int64], NDArray[np.bool_]]:
        """Each trial's comparison window on one drop.

        The start offset is rounded to a multiple of ``window_step`` (default ``output_dt``),
        so trials with equal rounded starts share one simulation; the end is floored to the
        trial's output grid ``t0, t0 + output_dt, ...``.

        Returns
        -------
        k : (n,) int
            Start index: ``t0 = drop.t0 + k * window_step``.
        t0 : (n,) float
            Window start, s (absolute).
        steps : (n,) int
            Number of output steps in the window: ``tf = t0 + steps * output_dt``.
        valid : (n,) bool
            False where the window leaves the data, holds fewer than two steps, or the
            offsets are not finite (those trials get NaN criteria).
        """
        d = self.drop(drop) if isinstance(drop, str) else drop
        s, e = self.window_offsets(X, d)
        finite = np.isfinite(s) & np.isfinite(e)
        k = np.where(finite, np.rint(np.where(finite, s, 0.0) / self.window_step), 0).astype(
            np.int64
        )
        t0 = d.t0 + k * self.window_step
        t1 = d.t1 + np.where(finite, e, 0.0)
        steps = np.floor((t1 - t0) / self.output_dt + 1e-9)
        steps = np.where(finite, steps, 0).astype(np.int64)
        lo, hi = d.data_span()
        tol = 1e-9 * max(1.0, abs(hi))
        valid = finite & (steps >= 2) & (t0 >= lo - tol)
        valid &= t0 + steps * self.output_dt <= hi + tol
        return k, t0, steps, valid

    def simulate(
        self,
        X: NDArray,
        drop: str | Drop,
        wind: WindProfile | str | None = "measured",
        *,
        frame: str = "origin",
    ) -> SimulationResult:
        """Simulate design vectors X (n, p) over one drop's window.

        Parameters
        ----------
        X : (n, p) float
            Design vectors, columns as the study's variables.
        drop : str or Drop
            The drop (or its name).
        wind : ``"measured"``, WindProfile or None
            The drop's measured profile (default), another profile, or calm air (None).
        frame : {"origin", "sea level"}
            ``"origin"`` (default): ``position`` is north, east, down relative to the drop's
            origin, in the frame of its data (``res.origin_altitude`` is the origin's
            altitude), so ``res.position`` compares with ``drop.measured("position")``
            directly. ``"sea level"``: the model's own frame (down = -altitude above sea
            level, ``res.origin_altitude`` 0), as this method returned before.

        Returns
        -------
        SimulationResult
            On the output grid ``t = 0, output_dt, ...`` s from the window start.
        """
        if frame not in ("origin", "sea level"):
            raise _err(
                "simulate", f"expected frame 'origin' or 'sea level', got {frame!r}",
                "use 'origin' to compare with the drop's data",
            )  # fmt: skip
        d = self.drop(drop) if isinstance(drop, str) else drop
        w = d.wind if isinstance(wind, str) and wind == "measured" else wind
        res = self.model.simulate(
            self.parameters(X),
            t_final=d.duration,
            dt=self.dt,
            inputs=d.inputs,
            wind=w,
            output_dt=self.output_dt,
            initial=d.initial,
            atmosphere=self.atmosphere,
        )
        if frame == "origin":
            res.outputs[:, :, 2] += d.origin_altitude  # position (a view) follows
            res.origin_altitude = float(d.origin_altitude)
        return res

    def drop(self, name: str) -> Drop:
        for d in self.drops:
            if d.name == name:
                return d
        raise _err("drops", f"unknown drop {name!r}", suggest(name, [d.name for d in self.drops]))

    def evaluate(self, X: NDArray) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Criteria (n, k) and drop-out functionals (n, q) of the batch X (n, p).

        A trial whose simulation fails gets NaN (stored as a failed trial). With window
        variables every trial is compared over its own window (criteria that are integrals
        become time-means over it, see :data:`INTEGRAL_CRITERIA`); trials whose rounded
        window starts are equal are simulated together, one batch per start and wind."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        n = X.shape[0]
        if not n:
            return np.empty((0, len(self.criteria))), np.empty((0, len(self.dropouts)))
        k, q = len(self.criteria), len(self.dropouts)
        F_sum = np.zeros((n, k))
        F_w = np.zeros(k)
        G = np.full((n, q), -np.inf)
        G_seen = np.zeros(q, dtype=bool)
        P = self.parameters(X)
        for d in self.drops:
            crit = [j for j, c in enumerate(self.criteria) if c.drops is None or d.name in c.drops]
            outs = [j for j, o in enumerate(self.dropouts) if o.drops is None or d.name in o.drops]
            if not crit and not outs:
                continue
            winds = self.winds[d.name]
            if not self.window_vars:
                Fd, Gd = np.zeros((n, len(crit))), np.zeros((n, len(outs)))
                steps = np.full(n, len(d.grid) - 1)
                for w in winds:
                    res = self.simulate(X, d, wind=w)
                    f, g = self._compare(d, res, d.grid, steps, crit, outs, mean=False)
                    Fd += f
                    Gd += g
            else:
                Fd, Gd = np.full((n, len(crit)), np.nan), np.full((n, len(outs)), np.nan)
                kk, t0s, steps, valid = self.trial_windows(X, d)
                for ks in np.unique(kk[valid]):
                    rows = np.flatnonzero(valid & (kk == ks))
                    t0 = float(t0s[rows[0]])
                    n_out = int(steps[rows].max())
                    grid = t0 + self.output_dt * np.arange(n_out + 1)
                    try:
                        initial, inputs = d.start(t0, n_out * self.output_dt)
                    except ValueError:  # too few samples for the initial state: failed trials
                        continue
                    f_sum = np.zeros((rows.size, len(crit)))
                    g_sum = np.zeros((rows.size, len(outs)))
                    for w in winds:
                        res = self.model.simulate(
                            P[rows],
                            t_final=n_out * self.output_dt,
                            dt=self.dt,
                            inputs=inputs,
                            wind=w,
                            output_dt=self.output_dt,
                            initial=initial,
                            atmosphere=self.atmosphere,
                        )
                        f, g = self._compare(d, res, grid, steps[rows], crit, outs, mean=True)
                        f_sum += f
                        g_sum += g
                    Fd[rows], Gd[rows] = f_sum, g_sum
            Fd /= len(winds)
            Gd /= len(winds)
            F_sum[:, crit] += d.weight * Fd
            F_w[crit] += d.weight
            for jj, j in enumerate(outs):
                G[:, j] = np.fmax(G[:, j], Gd[:, jj]) if G_seen[j] else Gd[:, jj]
                G_seen[j] = True
        F = F_sum / np.where(F_w > 0, F_w, 1.0)
        for j in np.flatnonzero(F_w == 0):
            F[:, j] = np.nan
        return F, G

    def _compare(
        self,
        d: Drop,
        res: SimulationResult,
        grid: NDArray[np.float64],
        steps: NDArray[np.int64],
        crit: Sequence[int],
        outs: Sequence[int],
        *,
        mean: bool,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Criteria (n, len(crit)) and drop-outs (n, len(outs)) of one simulated batch on
        ``grid``; row i is compared over ``grid[: steps[i] + 1]``. ``mean``: integral criteria
        divided by the window length (time-means)."""
        n = res.status.shape[0]
        ok = res.status == 0
        F = np.full((n, len(crit)), np.nan)
        Gd = np.full((n, len(outs)), np.nan)
        sims: dict[str, NDArray] = {}
        meas: dict[str, NDArray] = {}

        def channel(ch: str) -> tuple[NDArray, NDArray]:
            if ch not in sims:
                sims[ch] = sim_channel(res, ch, d.origin_altitude)
                meas[ch] = d.flight[ch].at(grid)
            return sims[ch], meas[ch]

        for L in np.unique(steps[ok]):
            rows = np.flatnonzero(ok & (steps == L))
            t = grid[: L + 1]
            for jj, j in enumerate(crit):
                cdef = self.defs[j]
                s, m_ = channel(cdef.channel)
                v = cdef.fn(s[rows, : L + 1], m_[: L + 1], t)
                if (
                    mean
                    and self.criteria[j].operator is None
                    and (self.criteria[j].use in INTEGRAL_CRITERIA)
                ):
                    v = v / (t[-1] - t[0])
                F[rows, jj] = v
            for jj, j in enumerate(outs):
                o = self.dropouts[j]
                s, m_ = channel(o.channel)
                s, m_ = s[rows, : L + 1], m_[: L + 1]
                if o.components:
                    comps = d.flight[o.channel].components
                    idx = [comps.index(c) for c in o.components]
                    s, m_ = s[..., idx], m_[:, idx]
                Gd[rows, jj] = lib.dropout(s, m_, o.band, angular=o.channel == "euler")
        return F, Gd

    __call__ = evaluate

    def problem(
        self,
        criteria: Sequence[Criterion] | None = None,
        constraints: Sequence[FunctionalConstraint] | None = None,
    ) -> Problem:
        """The PSI Problem: this identification as its batch model.

        ``criteria`` default to pure ``min`` criteria named like the identification's; every
        drop-out gets the constraint ``<= 0`` unless ``constraints`` says otherwise.
        """
        if criteria is None:
            criteria = [Criterion(c.name) for c in self.criteria]
        if constraints is None:
            constraints = [FunctionalConstraint(d.name, high=0.0) for d in self.dropouts]
        names = [c.name for c in criteria]
        if names != [c.name for c in self.criteria]:
            raise _err(
                "criteria",
                f"study criteria {names} differ from the identification's",
                "keep them in the same order",
            )
        return Problem(self.evaluate, criteria, constraints)

    # -- construction from a study file --------------------------------------------------------

    @classmethod
    def from_table(
        cls,
        table: Mapping[str, Any],
        *,
        variables: Sequence[str],
        criteria: Sequence[str],
        constraints: Sequence[str] = (),
        base_dir: str | Path | None = None,
        default_model: str | None = None,
        flights: Mapping[str, Any] | None = None,
        window_bounds: Mapping[str, tuple[float, float]] | None = None,
    ) -> Identification:
        """Build from the ``[identification]`` table (see the module docstring).

        ``criteria`` and ``constraints`` are the study's column names, in order; a criterion
        not defined under ``[identification.criteria]`` is the library criterion of that name.
        ``flights`` (drop name -> FlightData) replaces drop files in the Python API.
        ``window_bounds`` (window variable name -> (low, high), s) says how far window
        variables may move each drop's window, so that enough data is kept around it.
        """
        _check_keys("(table)", table, {**_TABLE_KEYS, "data": ""})
        model = resolve_model(table, default_model, base_dir)
        if isinstance(model, SystemModel):  # a model of your own: records, not drops
            return SystemIdentification.from_table(  # type: ignore[return-value]
                table,
                model,
                variables=variables,
                criteria=criteria,
                constraints=constraints,
                base_dir=base_dir,
            )
        if "data" in table:
            raise _err(
                "data",
                "[[identification.data]] records are for models of your own (SystemModel); "
                f"{model.name!r} is a flight model",
                "give its flight data as [[identification.drops]]",
            )
        _check_noise(table, criteria)
        base = Path(base_dir) if base_dir is not None else Path.cwd()
        output_dt = _positive("output_dt", table.get("output_dt", 0.5))
        dt = _positive("dt", table.get("dt", 0.05))
        init_span = _positive("init_span", table.get("init_span", 1.0))
        drops_t = table.get("drops")
        if not isinstance(drops_t, Sequence) or isinstance(drops_t, str) or not drops_t:
            raise _err(
                "drops",
                f"expected at least one [[identification.drops]], got {drops_t!r}",
                'add [[identification.drops]] with file = "..." and window = [..]',
            )
        flights = dict(flights or {})
        bounds = dict(window_bounds or {})
        for v in variables:
            if window_variable(v) is not None and v not in bounds:
                raise _err(
                    "variables",
                    f"window variable {v!r} has no bounds",
                    "pass window_bounds = {name: (low, high)} (from_spec does it)",
                )
        drops = []
        for i, dt_ in enumerate(drops_t):
            name = dt_.get("name", f"drop{i + 1}") if isinstance(dt_, Mapping) else None
            ext = [0.0, 0.0]
            for v, (lo, hi) in bounds.items():
                w = window_variable(v)
                if w is None or (w[1] is not None and w[1] != name):
                    continue
                if w[0] == "window_start":
                    ext[0] = min(ext[0], float(lo))
                else:
                    ext[1] = max(ext[1], float(hi))
            drops.append(
                build_drop(
                    dt_,
                    i,
                    base,
                    model,
                    output_dt=output_dt,
                    init_span=init_span,
                    flight=flights.get(name),
                    extend=(ext[0], ext[1]),
                )
            )
        ctab = table.get("criteria", {})
        _check_keys("criteria", ctab, set(criteria))
        icrit = []
        for name in criteria:
            spec = ctab.get(name, {})
            _check_keys(f"criteria.{name}", spec, _CRIT_KEYS)
            drops_sel = spec.get("drops")
            icrit.append(
                IdentCriterion(
                    name,
                    str(spec.get("use", name)),
                    None if drops_sel is None else tuple(str(s) for s in drops_sel),
                    spec.get("operator"),
                )
            )
        otab = table.get("dropout", {})
        _check_keys("dropout", otab, set(constraints))
        outs = []
        for name in constraints:
            if name not in otab:
                raise _err(
                    f"dropout.{name}",
                    f"constraint {name!r} has no drop-out definition",
                    f'add [identification.dropout.{name}] with channel = "velocity", band = 3.0',
                )
            spec = otab[name]
            _check_keys(f"dropout.{name}", spec, _DROPOUT_KEYS)
            if "channel" not in spec or "band" not in spec:
                raise _err(
                    f"dropout.{name}",
                    "needs channel and band",
                    'e.g. channel = "velocity", band = 3.0',
                )
            band = spec["band"]
            band = tuple(float(b) for b in band) if isinstance(band, Sequence) else float(band)
            comps = spec.get("components")
            drops_sel = spec.get("drops")
            outs.append(
                DropoutDef(
                    name,
                    str(spec["channel"]),
                    band,
                    None if comps is None else tuple(str(c) for c in comps),
                    None if drops_sel is None else tuple(str(s) for s in drops_sel),
                )
            )
        atm = table.get("atmosphere")
        atmosphere = None
        if atm is not None:
            _check_keys("atmosphere", atm, {"temperature_offset"})
            atmosphere = ISA(float(atm.get("temperature_offset", 0.0)))
        return cls(
            model,
            drops,
            variables,
            icrit,
            outs,
            fixed=table.get("parameters"),
            dt=dt,
            output_dt=output_dt,
            wind_realisations=table.get("wind_realisations", 1),
            wind_uncertainty=table.get("wind_uncertainty"),
            seed=table.get("seed", 0),
            atmosphere=atmosphere,
            window_step=table.get("window_step"),
        )

    @classmethod
    def from_spec(cls, spec) -> Identification:
        """Build from a :class:`~vectorid.spec.StudySpec` with an ``[identification]`` table."""
        table = spec.extra.get("identification")
        if table is None:
            raise StudyDefinitionError(
                "identification",
                "the study has no [identification] table",
                "add one (see vectorid.identify.identification)",
            )
        model = spec.model if isinstance(spec.model, str) else None
        bounds = {}
        for v in spec.space:
            if window_variable(v.name) is not None:
                if getattr(v, "kind", "") == "choice":
                    raise _err(
                        f"variables.{v.name}",
                        "a window variable must be continuous or integer (an offset in s)",
                        f"give {v.name} low and high",
                    )
                bounds[v.name] = (float(v.low), float(v.high))
        return cls.from_table(
            table,
            variables=spec.space.names,
            criteria=spec.criterion_names,
            constraints=spec.constraint_names,
            base_dir=spec.base_dir,
            default_model=model,
            window_bounds=bounds,
        )


def _check_noise(table: Mapping[str, Any], criteria: Sequence[str]) -> None:
    """Validate the noise statements early (their use is in :mod:`vectorid.identify.noise`)."""
    if table.get("noise") is not None:
        parse_noise(table["noise"], "noise")
    for i, d in enumerate(table.get("drops") or ()):
        if isinstance(d, Mapping) and d.get("noise") is not None:
            parse_noise(d["noise"], f"drops[{i}].noise")
    parse_discrepancy(table.get("discrepancy"), criteria)
    if table.get("limits") not in (None, "noise"):
        raise _err(
            "limits",
            f'expected "noise", got {table["limits"]!r}',
            'write limits = "noise", or give each [[criteria]] its own limit',
        )


def parameter_meanings(spec) -> dict[str, str]:
    """What each design variable of an identification study is: the model parameter's
    meaning (e.g. ``x6`` -> "C_D base value (eq. 11)"); window variables are described too.

    The identification builder's ``meanings`` hook (:func:`vectorid.builders.variable_meanings`):
    the analysis reads it through the registry, so it never imports this package."""
    table = spec.extra.get("identification", {})
    name = table.get("model", spec.model) if isinstance(table, Mapping) else spec.model
    out: dict[str, str] = {}
    try:
        if isinstance(name, str) and ":" in name:  # a model of your own beside the study
            model = resolve_model(table, spec.model, spec.base_dir)
        else:
            model = models.get(name) if isinstance(name, str) else None
    except Exception:  # not a registered model: no meanings
        model = None
    params = {p.name: p for p in getattr(model, "parameters", ())}
    for v in spec.space:
        if v.name in params and params[v.name].meaning:
            out[v.name] = params[v.name].meaning
        elif window_variable(v.name) is not None:
            out[v.name] = "offset of the comparison window's " + (
                "start, s" if v.name.startswith("window_start") else "end, s"
            )
    return out


def problem_from_spec(spec) -> Problem:
    """The Problem of a study with an ``[identification]`` table (used by
    :meth:`vectorid.spec.StudySpec.problem`)."""
    ident = Identification.from_spec(spec)
    return Problem(ident.evaluate, spec.criteria, spec.constraints)


def trial_trajectories(
    spec, x: NDArray, drop: str | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Measured and simulated trajectories of one design vector over one drop's window.

    Parameters
    ----------
    spec : StudySpec
        An identification study (with an ``[identification]`` table).
    x : (p,) float
        Design vector, columns as the study's variables.
    drop : str, optional
        Drop name (default: the first drop).

    Returns
    -------
    flight, model : (T, 3) float
        North, east, up positions in metres relative to the data's origin, on the
        identification's output grid: the measurement and the simulation of ``x``.
        A drop with altitude only (no position channel) gives zeros for north and east.
    """
    ident = Identification.from_spec(spec)
    d = ident.drop(drop) if drop is not None else ident.drops[0]
    X = np.atleast_2d(np.asarray(x, dtype=float))
    grid = d.grid
    if ident.window_vars:  # the trial's own window
        _, t0, steps, valid = ident.trial_windows(X, d)
        if not valid[0]:
            raise _err(
                "variables",
                f"the trial's window leaves the data of drop {d.name!r}",
                "pick a trial whose window_start / window_end lie in the study's box",
            )
        grid = float(t0[0]) + ident.output_dt * np.arange(int(steps[0]) + 1)
        initial, inputs = d.start(float(t0[0]), int(steps[0]) * ident.output_dt)
        res = ident.model.simulate(
            ident.parameters(X),
            t_final=int(steps[0]) * ident.output_dt,
            dt=ident.dt,
            inputs=inputs,
            wind=d.wind,
            output_dt=ident.output_dt,
            initial=initial,
            atmosphere=ident.atmosphere,
        )
    else:
        res = ident.simulate(X, d)
    n = min(len(grid), res.position.shape[1])
    if "position" in d.flight.channels:
        meas = d.measured("position", grid)[:n]
        sim = sim_channel(res, "position", d.origin_altitude)[0, :n]
        flip = np.array([1.0, 1.0, -1.0])
        return meas * flip, sim * flip
    meas_h = d.measured("altitude", grid)[:n, 0]
    sim_h = sim_channel(res, "altitude", d.origin_altitude)[0, :n, 0]
    zeros = np.zeros(n)
    return np.column_stack([zeros, zeros, meas_h]), np.column_stack([zeros, zeros, sim_h])
