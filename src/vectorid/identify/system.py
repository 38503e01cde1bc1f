"""Identification of your own model (a :class:`~vectorid.models.SystemModel`) from measured data.

When the ``[identification]`` table names a :class:`~vectorid.models.SystemModel` (by import
path, registered name or entry point), the study is built here instead of from flight drops:
each ``[[identification.data]]`` record is a CSV file of measured output channels, the model
is simulated from the record's stated initial state over its window, and each criterion
compares one output channel with its measurement on the comparison grid. Noise statements
per channel give the criteria their noise floors (``limits = "noise"``), as for the flight
models. ``docs/own-model.md`` is the tutorial.

The study file
--------------
::

    [study]
    name = "msd"
    model = "msd.dynamics:MassSpringDamper"   # import path (the study file's folder is on
    trials = 4096                             # the import path), registered name or entry point

    [[variables]]                             # model parameters by name
    name = "k"
    low = 50.0
    high = 200.0

    [[criteria]]                              # <channel>_<kind>: kind abs, sq, rms or max
    name = "x_rms"
    [[criteria]]
    name = "fit_a"                            # or defined below

    [identification]
    dt = 0.005                                # integration step, s
    output_dt = 0.02                          # comparison grid step, s
    noise = { x = 0.002, a = 0.05 }           # σ per output channel, in the model's unit
    limits = "noise"                          # every criterion without a number: noise floor
    # noise_coverage = 0.95, noise_quantile, noise_draws = 2000, noise_seed = 0
    # parameters = { m = 1.0 }                # fixed values of parameters (others nominal)
    # model_options = { ... }                 # constructor options of the model

    [identification.criteria.fit_a]
    channel = "a"
    use = "rms"                               # abs | sq | rms | max | "module:function"
    # data = ["run1"]                         # only these records (default: weighted mean)

    [[identification.data]]
    name = "run1"
    file = "run1.csv"                         # relative to the study file
    time = "t"                                # time column (default "t")
    time_unit = "s"                           # its unit: s | ms | us | ns | min (never guessed)
    columns = { x = "x_mm", a = "acc" }       # output channel -> column (default: same name)
    units = { x = "mm", a = "m/s^2" }         # unit of every column used: never guessed
    initial = { x = 0.05, v = 0.0 }           # state values at the window start
    window = [0.0, 8.0]                       # s (default: the whole record)
    # weight = 1.0, noise = { x = 0.001 }     # per record: overrides the study's noise

Criteria (residual r = simulated − measured channel on the comparison grid, t0..tf):
``abs`` ∫|r| dt (unit·s), ``sq`` ∫r² dt (unit²·s), ``rms`` √(∫r² dt / (tf − t0)) (unit),
``max`` max|r| (unit). A criterion of the flight library (:data:`vectorid.identify.CRITERIA`)
that reads a one-component channel applies to an output of that name (``alt_abs``,
``vz_abs`` on an ``altitude`` output, in m). A criterion of your own is
``use = "package.module:function"`` with ``function(sim (n, T, m), meas (T, m), t (T,)) -> (n,)``,
smaller is closer.

The noise floor of a criterion is a seeded Monte Carlo of the twin experiment the noise
statement describes: the model at the reference vector (the variables' nominal values, else
the middle of the box) is the truth, noise is drawn at every sample time of the record, the
noisy record is interpolated onto the comparison grid as the real data are, and the perfect
model is compared with it by the criterion's own function. The initial state is stated, not
fitted, so the floor holds no initial-state error. One quantile level for all constrained
criteria gives them joint coverage ``noise_coverage`` (see :mod:`vectorid.identify.noise`).
"""

from __future__ import annotations

import csv
import importlib
import math
import sys
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

import vectorid.identify.criteria as lib
from vectorid import models
from vectorid.errors import StudyDefinitionError, VectoridError, suggest
from vectorid.identify.loaders.common import UNITS
from vectorid.identify.noise.statements import parse_component
from vectorid.models.base import validate_time
from vectorid.models.system import SystemModel, SystemResult
from vectorid.problem import Criterion, Problem, checked_output, describe_exception

__all__ = [
    "KINDS",
    "Record",
    "SystemIdentification",
    "at_reference",
    "check_record_scales",
    "code_modules",
    "convert_unit",
    "read_record",
]

#: Table keys of ``[identification]`` for an own model (the flight keys do not apply).
_TABLE_KEYS = {
    "model": "model: import path 'package.module:Class', registered name or entry point",
    "data": "array of tables [[identification.data]]: the measured records",
    "criteria": "table of criterion definitions by study criterion name",
    "parameters": "fixed values of model parameters",
    "model_options": "options passed to the model constructor",
    "dt": "integration step, s",
    "output_dt": "comparison grid step, s",
    "noise": 'σ per output channel ({ x = 0.002 }) or "estimate"',
    "limits": '"noise": every criterion without a number gets its noise floor',
    "noise_quantile": "per-criterion quantile of the noise floor (default: joint coverage)",
    "noise_coverage": "joint coverage of the noise floors (default 0.95)",
    "noise_draws": "Monte Carlo draws of the noise floor (default 2000)",
    "noise_seed": "seed of the noise-floor draws (default 0)",
}
#: Keys of the flight identification that an own model cannot use, with the reason.
_FLIGHT_ONLY = {
    "drops": "flight drops are for the flight models; give records as [[identification.data]]",
    "dropout": "drop-out functionals are for the flight models",
    "atmosphere": "an own model has no atmosphere",
    "wind_realisations": "an own model has no wind",
    "wind_uncertainty": "an own model has no wind",
    "seed": "an own model has no wind realisations (noise_seed seeds the noise floor)",
    "init_span": "an own model's initial state is stated: initial = { state = value }",
    "window_step": "window variables are for the flight models",
    "discrepancy": "not implemented for own models: raise the criterion's limit by hand",
}
_DATA_KEYS = {
    "name": "record name",
    "file": "CSV file, relative to the study file",
    "time": "time column (default 't')",
    "time_unit": "unit of the time column: s, ms, us, ns or min (required)",
    "columns": "output channel -> CSV column (default: the channel's name)",
    "units": "unit of every column used, by output channel",
    "initial": "state values at the window start, by state name",
    "window": "[start, end] in s (default: the whole record)",
    "weight": "weight in the mean over records (default 1)",
    "noise": "this record's noise (overrides [identification] noise channel by channel)",
}
_CRIT_KEYS = {"channel", "use", "data"}

#: Built-in residual criteria: kind -> (meaning, unit pattern).
KINDS: dict[str, tuple[str, str]] = {
    "abs": ("∫ |y - ŷ| dt", "{u}·s"),
    "sq": ("∫ (y - ŷ)² dt", "{u}²·s"),
    "rms": ("√(∫ (y - ŷ)² dt / (tf - t0))", "{u}"),
    "max": ("max |y - ŷ|", "{u}"),
}

#: Unit conversions to the model's unit: (column unit, model unit) -> factor.
_CONVERSIONS = {
    ("mm", "m"): 1e-3,
    ("cm", "m"): 1e-2,
    ("km", "m"): 1e3,
    ("m", "mm"): 1e3,
    ("deg", "rad"): math.pi / 180,
    ("rad", "deg"): 180 / math.pi,
    ("deg/s", "rad/s"): math.pi / 180,
    ("mm/s", "m/s"): 1e-3,
    ("ms", "s"): 1e-3,
    ("g", "kg"): 1e-3,
}


def _err(field_: str, problem: str, fix: str = "") -> StudyDefinitionError:
    return StudyDefinitionError(f"identification.{field_}", problem, fix)


def _norm_unit(u: str) -> str:
    return u.strip().replace("²", "^2").replace("³", "^3").replace("**", "^").replace(" ", "")


def convert_unit(value_unit: str, model_unit: str) -> float | None:
    """Factor that converts values in ``value_unit`` to ``model_unit`` (None: not known)."""
    a, b = _norm_unit(value_unit), _norm_unit(model_unit)
    if a == b:
        return 1.0
    return _CONVERSIONS.get((a, b))


def _positive(where: str, value: Any) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    if isinstance(value, bool) or not (v > 0 and math.isfinite(v)):
        raise _err(where, f"expected a number > 0, got {value!r}", "e.g. 0.01")
    return v


def _check_keys(where: str, got: Any, valid: Mapping[str, str] | set[str]) -> None:
    if not isinstance(got, Mapping):
        raise _err(where, f"expected a table, got {got!r}", "write it as a TOML table")
    for key in got:
        if key not in valid:
            raise _err(f"{where}.{key}", f"unknown key {key!r}", suggest(key, list(valid)))


# -- records -----------------------------------------------------------------------------------


@dataclass
class Record:
    """One measured record, ready for comparison.

    Attributes
    ----------
    name : str
    t : (N,) float
        Sample times, s (increasing), inside the window.
    values : dict
        Output channel -> (N,) measured values, converted to the model's unit.
    t0, duration : float
        Window start (s, in the record's time) and simulated time (s): the window length
        floored to a multiple of ``output_dt``.
    grid : (T,) float
        Comparison grid ``t0, t0 + output_dt, ..., t0 + duration``, s.
    initial : dict
        Stated initial state values by state name.
    weight : float
    """

    name: str
    t: NDArray[np.float64]
    values: dict[str, NDArray[np.float64]]
    t0: float
    duration: float
    grid: NDArray[np.float64]
    initial: dict[str, float]
    weight: float = 1.0

    def measured(self, channel: str) -> NDArray[np.float64]:
        """The measured channel interpolated (linearly) onto the comparison grid, (T, 1)."""
        return np.interp(self.grid, self.t, self.values[channel])[:, None]


def read_record(
    path: str | Path, time: str, columns: Mapping[str, str], where: str = "data"
) -> tuple[NDArray[np.float64], dict[str, NDArray[np.float64]]]:
    """Read the time column and ``columns`` (channel -> column name) of a CSV file.

    Raises
    ------
    StudyDefinitionError
        Missing file or column, a value that is not a finite number, time not increasing.
    """
    path = Path(path)
    if not path.exists():
        raise _err(
            f"{where}.file", f"file {str(path)!r} not found", "paths are relative to the study file"
        )
    with path.open(newline="", encoding="utf-8") as fh:
        rows = list(csv.reader(line for line in fh if not line.lstrip().startswith("#")))
    if len(rows) < 3:
        raise _err(
            f"{where}.file",
            f"{path.name} has {max(len(rows) - 1, 0)} data rows",
            "a record needs a header and at least two rows",
        )
    header = [h.strip() for h in rows[0]]
    wanted = {"time": time, **dict(columns)}
    idx = {}
    for key, col in wanted.items():
        if col not in header:
            raise _err(
                f"{where}.{'time' if key == 'time' else 'columns.' + key}",
                f"{path.name} has no column {col!r} (columns: {', '.join(header)})",
                suggest(col, header),
            )
        idx[key] = header.index(col)
    out = {k: np.empty(len(rows) - 1) for k in wanted}
    for r, row in enumerate(rows[1:], start=2):
        for key, j in idx.items():
            text = row[j].strip() if j < len(row) else ""
            try:
                v = float(text)
            except ValueError:
                v = math.nan
            if not math.isfinite(v):
                raise _err(
                    f"{where}.file",
                    f"{path.name} line {r}, column {wanted[key]!r}: expected a finite number, "
                    f"got {text!r}",
                    "fill or remove the row (gaps are not interpolated silently)",
                )
            out[key][r - 2] = v
    t = out.pop("time")
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        raise _err(
            f"{where}.file",
            f"{path.name}: time {time!r} does not increase at line {bad[0] + 3} "
            f"({t[bad[0]]:g} then {t[bad[0] + 1]:g} s)",
            "sort the rows by time and remove repeated times",
        )
    return t, out


# -- the identification ------------------------------------------------------------------------


@dataclass(frozen=True)
class _Crit:
    name: str
    channel: str
    use: str
    fn: Callable[[NDArray, NDArray, NDArray], NDArray]
    unit: str
    data: tuple[str, ...] | None
    builtin: bool

    def value(self, out: Any, n: int) -> NDArray[np.float64]:
        """What the criterion's function returned for ``n`` trials, checked: (n,) real
        numbers, one per trial (an (n, 1) column or a scalar is never broadcast)."""
        return checked_output(
            f"criterion {self.name} ({self.use})",
            out,
            (n,),
            "one value per trial: f(sim (n, T, 1), meas (T, 1), t (T,)) -> (n,)",
        )


def _kind_fn(kind: str) -> Callable[[NDArray, NDArray, NDArray], NDArray]:
    def fn(sim: NDArray, meas: NDArray, t: NDArray) -> NDArray:
        r = sim - meas[None]  # (n, T, m)
        if kind == "max":
            return np.max(np.abs(r), axis=(1, 2))
        a = np.abs(r) if kind == "abs" else r * r
        v = lib.integrate(np.moveaxis(a, 1, -1), t).sum(axis=-1)  # (n,)
        if kind == "rms":
            return np.sqrt(v / (t[-1] - t[0]))
        return v

    fn.__name__ = f"residual_{kind}"
    return fn


def _user_fn(name: str, use: str) -> Callable[[NDArray, NDArray, NDArray], NDArray]:
    module_name, _, attr = use.partition(":")
    try:
        fn: Any = importlib.import_module(module_name)
        for part in attr.split("."):
            fn = getattr(fn, part)
    except (ImportError, AttributeError) as exc:
        raise _err(
            f"criteria.{name}.use",
            f"cannot import the criterion function {use!r}: {exc}",
            "put the module beside the study file or install it; the function takes "
            "(sim (n, T, m), meas (T, m), t (T,)) and returns (n,)",
        ) from None
    if not callable(fn):
        raise _err(f"criteria.{name}.use", f"{use!r} is not a function", "point to a function")
    return fn


class SystemIdentification:
    """An own model + measured records + residual criteria, as a batch model ``X -> (F, G)``.

    Build it with :meth:`from_table` (the study file's ``[identification]`` table, see the
    module docstring); :meth:`evaluate` is the Problem's model.
    """

    def __init__(
        self,
        model: SystemModel,
        records: Sequence[Record],
        variables: Sequence[str],
        criteria: Sequence[_Crit],
        *,
        fixed: Mapping[str, float] | None = None,
        dt: float,
        output_dt: float,
    ) -> None:
        self.model = model
        self.records = list(records)
        self.dt, self.output_dt = dt, output_dt
        pnames = list(model.parameter_names)
        for v in variables:
            if v not in pnames:
                raise StudyDefinitionError(
                    "variables",
                    f"variable {v!r} is not a parameter of model {model.name!r} "
                    f"(parameters: {', '.join(pnames)})",
                    suggest(v, pnames) + " (design variables map to model parameters by name)",
                )
        self.variables = list(variables)
        self.columns = [pnames.index(v) for v in variables]
        self.base = model.nominal.copy()
        for k, v in dict(fixed or {}).items():
            if k not in pnames:
                raise _err(f"parameters.{k}", f"unknown model parameter {k!r}", suggest(k, pnames))
            if k in self.variables:
                raise _err(
                    f"parameters.{k}",
                    f"{k!r} is both a design variable and a fixed parameter",
                    "remove it from one of them",
                )
            self.base[pnames.index(k)] = float(v)
        self.criteria = list(criteria)

    @property
    def criterion_names(self) -> list[str]:
        """The study's criteria, in column order."""
        return [c.name for c in self.criteria]

    def record(self, name: str) -> Record:
        """The record called ``name``."""
        for r in self.records:
            if r.name == name:
                return r
        raise _err(
            "data", f"unknown record {name!r}", suggest(name, [r.name for r in self.records])
        )

    def parameters(self, X: NDArray) -> NDArray[np.float64]:
        """Full model parameter vectors (n, p_model) from design vectors X (n, p)."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        P = np.tile(self.base, (X.shape[0], 1))
        P[:, self.columns] = X
        return P

    def simulate(
        self, X: NDArray, record: str | Record, output_dt: float | None = None
    ) -> SystemResult:
        """Simulate design vectors X (n, p) over one record's window (times from 0 at t0)."""
        r = self.record(record) if isinstance(record, str) else record
        return self.model.simulate(
            self.parameters(X),
            t_final=r.duration,
            dt=self.dt,
            output_dt=self.output_dt if output_dt is None else output_dt,
            initial=r.initial,
        )

    def applies(self, c: _Crit, r: Record) -> bool:
        return c.data is None or r.name in c.data

    def evaluate(self, X: NDArray) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Criteria (n, k) of the batch X (n, p): each the weighted mean over the records it
        applies to; NaN for a trial whose simulation failed (stored as failed)."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        n, k = X.shape[0], len(self.criteria)
        F = np.zeros((n, k))
        W = np.zeros(k)
        for r in self.records:
            res = self.simulate(X, r)
            ok = res.ok
            for j, c in enumerate(self.criteria):
                if not self.applies(c, r):
                    continue
                sim = res[c.channel][:, :, None]
                v = np.full(n, np.nan)
                if ok.any():
                    m = int(ok.sum())
                    v[ok] = c.value(c.fn(sim[ok], r.measured(c.channel), r.grid), m)
                F[:, j] += r.weight * v
                W[j] += r.weight
        return F / W, np.empty((n, 0))

    __call__ = evaluate

    def problem(self, criteria: Sequence[Criterion] | None = None) -> Problem:
        """The PSI Problem (pure ``min`` criteria named like the identification's by default)."""
        if criteria is None:
            criteria = [Criterion(c.name, unit=c.unit) for c in self.criteria]
        return Problem(self.evaluate, criteria, [])

    def units(self) -> dict[str, str]:
        """Criterion name -> unit ('' for a criterion of your own)."""
        return {c.name: c.unit for c in self.criteria}

    # -- construction ------------------------------------------------------------------------

    @classmethod
    def from_table(
        cls,
        table: Mapping[str, Any],
        model: SystemModel,
        *,
        variables: Sequence[str],
        criteria: Sequence[str],
        constraints: Sequence[str] = (),
        base_dir: str | Path | None = None,
    ) -> SystemIdentification:
        """Build from the ``[identification]`` table of a study whose model is ``model``."""
        for key in table:
            if key in _FLIGHT_ONLY:
                raise _err(
                    key,
                    f"{key!r} does not apply to model {model.name!r} (an own SystemModel): "
                    f"{_FLIGHT_ONLY[key]}",
                    f"remove {key}",
                )
        _check_keys("(table)", table, _TABLE_KEYS)
        if constraints:
            raise StudyDefinitionError(
                "constraints",
                f"functional constraints {list(constraints)} have no definition for an own "
                "model's identification",
                "remove [[constraints]] (limit criteria instead), or write a study with a "
                "model function of your own",
            )
        if table.get("limits") not in (None, "noise"):
            raise _err(
                "limits", f'expected "noise", got {table["limits"]!r}', 'write limits = "noise"'
            )
        base = Path(base_dir) if base_dir is not None else Path.cwd()
        dt = _positive("dt", table.get("dt", 0.01))
        output_dt = _positive("output_dt", table.get("output_dt", 0.1))
        try:
            validate_time(output_dt, dt, output_dt)
        except ValueError as exc:
            raise _err("output_dt", str(exc), "make output_dt a whole multiple of dt") from None
        for key in ("noise",):
            if table.get(key) is not None:
                parse_record_noise(table[key], model, key)
        recs_t = table.get("data")
        if not isinstance(recs_t, Sequence) or isinstance(recs_t, str) or not recs_t:
            raise _err(
                "data",
                f"expected at least one [[identification.data]] record, got {recs_t!r}",
                'add [[identification.data]] with file = "run1.csv", units = { ... }',
            )
        records = [_build_record(t, i, base, model, output_dt, dt) for i, t in enumerate(recs_t)]
        names = [r.name for r in records]
        for nm in names:
            if names.count(nm) > 1:
                raise _err("data", f"record name {nm!r} is used twice", "give each record a name")
        ctab = table.get("criteria", {})
        _check_keys("criteria", ctab, set(criteria))
        crits = [_build_criterion(name, ctab.get(name), model, records) for name in criteria]
        return cls(
            model,
            records,
            variables,
            crits,
            fixed=table.get("parameters"),
            dt=dt,
            output_dt=output_dt,
        )


def parse_record_noise(value: Any, model: SystemModel, where: str) -> dict[str, Any] | str:
    """A record's (or the study's) noise statement of a model of your own: output channel ->
    :class:`~vectorid.identify.noise.ComponentNoise` in the channel's unit, or ``"estimate"``."""
    if value == "estimate":
        return "estimate"
    if not isinstance(value, Mapping):
        raise _err(
            where,
            f'expected a table of σ per output channel or "estimate", got {value!r}',
            f"write {where} = {{ {model.output_names[0]} = 0.01 }} (in the channel's unit)",
        )
    out = {}
    for ch, v in value.items():
        if ch not in model.output_names:
            raise _err(
                f"{where}.{ch}",
                f"{ch!r} is not an output channel of model {model.name!r} "
                f"(outputs: {', '.join(model.output_names)})",
                suggest(ch, model.output_names),
            )
        out[ch] = parse_component(f"{where}.{ch}", v, 1.0, model.unit_of(ch))
    return out


def _build_record(
    t: Any, i: int, base: Path, model: SystemModel, output_dt: float, dt: float
) -> Record:
    where = f"data[{i}]"
    _check_keys(where, t, _DATA_KEYS)
    name = str(t.get("name", f"run{i + 1}"))
    if "file" not in t:
        raise _err(f"{where}.file", "missing file", 'add file = "run1.csv"')
    columns = t.get("columns", {})
    _check_keys(f"{where}.columns", columns, set(model.output_names))
    units = t.get("units")
    if not isinstance(units, Mapping) or not units:
        raise _err(
            f"{where}.units",
            f"the unit of each measured column must be stated, got {units!r}",
            "add units = { "
            + ", ".join(f'{c.name} = "{c.unit}"' for c in model.outputs)
            + " } (the channels the record measures; units are never guessed)",
        )
    _check_keys(f"{where}.units", units, set(model.output_names))
    for ch in columns:
        if ch not in units:
            raise _err(
                f"{where}.units.{ch}",
                f"column {columns[ch]!r} is mapped to {ch} but its unit is not stated",
                f'add {ch} = "{model.unit_of(ch)}" to units',
            )
    cols = {ch: str(columns.get(ch, ch)) for ch in units}
    path = Path(t["file"])
    path = path if path.is_absolute() else base / path
    time_col = str(t.get("time", "t"))
    time_unit = t.get("time_unit")
    if time_unit is None:
        raise _err(
            f"{where}.time_unit",
            f"the unit of the time column {time_col!r} is not stated",
            f'add time_unit = "s" ({", ".join(UNITS["time"])}; units are never guessed)',
        )
    if time_unit not in UNITS["time"]:
        raise _err(
            f"{where}.time_unit",
            f"unknown time unit {time_unit!r}",
            f"{suggest(str(time_unit), list(UNITS['time']))} (one of {', '.join(UNITS['time'])})",
        )
    tt, vals = read_record(path, time_col, cols, where)
    raw_step = float(np.median(np.diff(tt)))
    tt = tt * UNITS["time"][str(time_unit)]
    _check_time_step(where, path.name, time_col, str(time_unit), raw_step, output_dt)
    for ch, u in units.items():
        f = convert_unit(str(u), model.unit_of(ch))
        if f is None:
            raise _err(
                f"{where}.units.{ch}",
                f"column {cols[ch]!r} is in {u!r}, the model's {ch} in {model.unit_of(ch)!r}, "
                "and vectorid knows no conversion between them",
                f"convert the column to {model.unit_of(ch)} (units are never guessed)",
            )
        vals[ch] = vals[ch] * f
    window = t.get("window", [float(tt[0]), float(tt[-1])])
    if (
        not isinstance(window, Sequence)
        or isinstance(window, str)
        or len(window) != 2
        or not all(isinstance(w, int | float) and not isinstance(w, bool) for w in window)
    ):
        raise _err(
            f"{where}.window",
            f"expected [start, end] in s, got {window!r}",
            "e.g. window = [0.0, 8.0]",
        )
    t0, t1 = float(window[0]), float(window[1])
    if not (tt[0] - 1e-9 <= t0 < t1 <= tt[-1] + 1e-9):
        raise _err(
            f"{where}.window",
            f"window [{t0:g}, {t1:g}] s is not inside the record's time span "
            f"[{tt[0]:g}, {tt[-1]:g}] s",
            "choose a window the data cover",
        )
    n_out = math.floor((t1 - t0) / output_dt + 1e-9)
    if n_out < 2:
        raise _err(
            f"{where}.window",
            f"window [{t0:g}, {t1:g}] s is shorter than two output steps of {output_dt:g} s",
            "widen the window or reduce output_dt",
        )
    duration = n_out * output_dt
    try:
        validate_time(duration, dt, output_dt)
    except ValueError as exc:
        raise _err("dt", str(exc), "make output_dt a whole multiple of dt") from None
    initial = t.get("initial", {})
    _check_keys(f"{where}.initial", initial, set(model.state_names))
    try:
        model.initial_state(initial)
    except ValueError as exc:
        raise _err(f"{where}.initial", str(exc), "give finite numbers for states") from None
    weight = _positive(f"{where}.weight", t.get("weight", 1.0))
    if t.get("noise") is not None:
        parse_record_noise(t["noise"], model, f"{where}.noise")
    sel = (tt >= t0 - 1e-9) & (tt <= t0 + duration + 1e-9)
    keep = slice(max(int(np.argmax(sel)) - 1, 0), min(len(tt), int(np.flatnonzero(sel)[-1]) + 2))
    return Record(
        name,
        tt[keep],
        {k: v[keep] for k, v in vals.items()},
        t0,
        duration,
        t0 + output_dt * np.arange(n_out + 1),
        {k: float(v) for k, v in initial.items()},
        weight,
    )


@contextmanager
def at_reference(what: str, ref: Mapping[str, float]) -> Iterator[None]:
    """Run the user's model (or criterion) once at the reference vector ``ref`` before any
    trial (scales of the records, noise floors): what it raises is one line naming it, never
    a traceback; vectorid's own errors (a wrong shape) pass as they are."""
    try:
        yield
    except VectoridError:
        raise
    except Exception as exc:
        raise _err(
            "model",
            f"{what} raised at the reference vector {dict(ref)}: {describe_exception(exc)}",
            "fix it (vectorid runs it once there, before any trial, for the noise floors and "
            "the records' scales), or give the variables nominal values where it runs",
        ) from None


#: A record sampled this many comparison steps apart or more is read in the wrong time unit,
#: or compared on a grid its samples cannot fill (see :func:`_check_time_step`).
COARSE_STEPS = 100


def _check_time_step(
    where: str, name: str, column: str, unit: str, raw_step: float, output_dt: float
) -> None:
    """The record's samples (median step, in its stated time unit) are not orders of
    magnitude coarser than the comparison grid: a time column in ms stated as s reads 10 Hz
    samples as 100 s apart. Stops naming the unit that would fit."""
    step = raw_step * UNITS["time"][unit]
    if not step > COARSE_STEPS * output_dt:
        return
    fits = [u for u, f in UNITS["time"].items() if u != unit and raw_step * f <= 10 * output_dt]
    likely = max(fits, key=lambda u: UNITS["time"][u]) if fits else None
    said = (
        f"time_unit = {likely!r} would make them {raw_step * UNITS['time'][likely]:g} s apart"
        if likely
        else "no time unit makes them fit"
    )
    raise _err(
        f"{where}.time_unit",
        f"{name}: the samples of {column!r} are {step:g} s apart (median) with time_unit = "
        f"{unit!r}, {step / output_dt:.0f}× the comparison step output_dt = {output_dt:g} s; "
        f"{said}",
        "state the time column's unit (units are never guessed), or compare on a grid the "
        "samples fill (output_dt near their step)",
    )


#: A measured channel whose scale is this many times the model's at the reference vector (or
#: its inverse) was read in the wrong unit or from the wrong column (see
#: :func:`check_record_scales`).
SCALE_MISMATCH = 30.0


def check_record_scales(ident: SystemIdentification, ref: NDArray[np.float64], table: Any) -> None:
    """Each measured channel's scale (RMS over the window) against the model's at the
    reference vector ``ref`` (design vector, the noise floor's truth), floored by the
    channel's stated noise σ: a ratio beyond :data:`SCALE_MISMATCH` (a column in mm stated as
    m reads 1000×) stops, naming the unit that would make them agree when one does.

    Raises
    ------
    StudyDefinitionError
        At the record's unit of that channel (``identification.data[i].units.CH``).
    """
    tables = table.get("data", []) if isinstance(table, Mapping) else []
    named = dict(zip(ident.variables, ref.tolist()))
    for i, rec in enumerate(ident.records):
        with at_reference(f"the model {type(ident.model).__name__}", named):
            res = ident.simulate(ref[None, :], rec)
        if not res.ok[0]:
            continue  # the noise floor says why the model fails there
        sigma = _stated_sigmas(table, tables[i] if i < len(tables) else None)
        units = (tables[i].get("units") or {}) if i < len(tables) else {}
        for ch, y in rec.values.items():
            inside = (rec.t >= rec.t0 - 1e-9) & (rec.t <= rec.t0 + rec.duration + 1e-9)
            meas = float(np.sqrt(np.mean(y[inside] ** 2))) if inside.any() else 0.0
            sim_rms = float(np.sqrt(np.nanmean(res[ch][0] ** 2)))
            scale = max(sim_rms, sigma.get(ch, 0.0))
            if not (scale > 0 and meas > 0 and np.isfinite(scale) and np.isfinite(meas)):
                continue
            ratio = meas / scale
            if 1 / SCALE_MISMATCH <= ratio <= SCALE_MISMATCH:
                continue
            stated = str(units.get(ch, ""))
            model_unit = ident.model.unit_of(ch)
            f_stated = convert_unit(stated, model_unit) or 1.0
            likely = [
                u
                for (u, m), f in _CONVERSIONS.items()
                if _norm_unit(m) == _norm_unit(model_unit)
                and u != _norm_unit(stated)
                and 1 / 3 <= ratio * f / f_stated <= 3
            ]
            if _norm_unit(model_unit) != _norm_unit(stated) and 1 / 3 <= ratio / f_stated <= 3:
                likely.insert(0, model_unit)
            hint = (
                f"units {ch} = {likely[0]!r} would make them agree"
                if likely
                else "check the column mapped to it and its unit"
            )
            raise _err(
                f"data[{i}].units.{ch}",
                f"record {rec.name!r}: {ch} read in {stated!r} has an RMS of {meas:.4g} "
                f"{model_unit}, {ratio:.3g}× the model's at the reference vector "
                f"({scale:.4g} {model_unit}); {hint}",
                "state the column's unit (units are never guessed), or give the variables "
                "nominal values near the data",
            )


def _stated_sigmas(table: Any, rec_table: Any) -> dict[str, float]:
    """σ per channel stated as a plain number (the study's, then the record's)."""
    out: dict[str, float] = {}
    for t in (table, rec_table):
        noise = t.get("noise") if isinstance(t, Mapping) else None
        if isinstance(noise, Mapping):
            for ch, v in noise.items():
                if isinstance(v, int | float) and not isinstance(v, bool):
                    out[str(ch)] = float(v)
                elif isinstance(v, Mapping) and isinstance(v.get("sigma"), int | float):
                    out[str(ch)] = float(v["sigma"])
    return out


def _build_criterion(
    name: str, spec: Mapping[str, Any] | None, model: SystemModel, records: Sequence[Record]
) -> _Crit:
    outs = model.output_names
    libdef = _library_criterion(name if spec is None else spec.get("use"), outs)
    if libdef is not None and (spec is None or "channel" not in spec):
        spec = {**(spec or {}), "channel": libdef.channel, "use": libdef.name}
    if spec is None:
        ch, _, kind = name.rpartition("_")
        if ch not in outs or kind not in KINDS:
            raise _err(
                f"criteria.{name}",
                f"criterion {name!r} is neither <channel>_<kind> (channels {', '.join(outs)}; "
                f"kinds {', '.join(KINDS)}) nor defined under [identification.criteria.{name}]",
                f'name it e.g. "{outs[0]}_rms", or add [identification.criteria.{name}] with '
                f'channel = "{outs[0]}" and use = "rms" (or "package.module:function")',
            )
        spec = {"channel": ch, "use": kind}
    _check_keys(f"criteria.{name}", spec, _CRIT_KEYS)
    ch = spec.get("channel")
    if ch not in outs:
        raise _err(
            f"criteria.{name}.channel",
            f"expected an output channel of model {model.name!r} ({', '.join(outs)}), got {ch!r}",
            suggest(str(ch), outs),
        )
    use = spec.get("use", "rms")
    if not isinstance(use, str):
        raise _err(f"criteria.{name}.use", f"expected text, got {use!r}", 'e.g. use = "rms"')
    data = spec.get("data")
    rnames = [r.name for r in records]
    if data is not None:
        if isinstance(data, str) or not isinstance(data, Sequence) or not data:
            raise _err(
                f"criteria.{name}.data",
                f"expected a list of record names, got {data!r}",
                f"e.g. data = [{rnames[0]!r}]",
            )
        for d in data:
            if d not in rnames:
                raise _err(
                    f"criteria.{name}.data", f"unknown record {d!r}", suggest(str(d), rnames)
                )
        data = tuple(str(d) for d in data)
    for r in records:
        if (data is None or r.name in data) and ch not in r.values:
            raise _err(
                f"criteria.{name}",
                f"record {r.name!r} does not measure {ch!r}, which criterion {name!r} compares",
                f"map a column to {ch} in the record's columns/units, or restrict the criterion "
                "with data = [...]",
            )
    unit = model.unit_of(ch)
    if libdef is not None and libdef.channel == ch:
        return _Crit(name, ch, use, libdef.fn, libdef.unit, data, False)
    if use in KINDS:
        return _Crit(name, ch, use, _kind_fn(use), KINDS[use][1].format(u=unit), data, True)
    if ":" not in use:
        raise _err(
            f"criteria.{name}.use",
            f"unknown criterion kind {use!r}",
            suggest(use, list(KINDS)) + ', or a function of your own "package.module:function"',
        )
    return _Crit(name, ch, use, _user_fn(name, use), "", data, False)


def _library_criterion(use: Any, outputs: Sequence[str]):
    """The flight library's criterion ``use`` when it reads a one-component channel that the
    model outputs under the library's name (e.g. ``alt_abs`` on an ``altitude`` output), else
    None."""
    if not isinstance(use, str) or use in KINDS:
        return None
    try:
        cdef = lib.get_criterion(use)
    except lib.CriterionError:
        return None
    if cdef.channel not in outputs:
        return None
    if lib.MIN_COLUMNS.get(cdef.channel, 1) > 1:
        raise _err(
            f"criteria.{use}",
            f"library criterion {use!r} reads the {lib.MIN_COLUMNS[cdef.channel]}-component "
            f"channel {cdef.channel!r}; an own model's channels are scalars",
            "use a residual kind (abs, sq, rms, max) on each component's channel",
        )
    return cdef


# -- resolving the model of a study ------------------------------------------------------------


def _model_target(name: str) -> str | None:
    """``"package.module:Class"`` a model name stands for, without importing it: an import
    path as it is, a registered name or an entry point's target (None: unknown)."""
    if models._is_import_path(name):
        return name
    return models._REGISTRY.get(name) or models._entry_points().get(name)


def code_modules(spec: Any) -> dict[str, str]:
    """The user's Python modules an ``[identification]`` study runs (the ``code_modules``
    hook of its builder, see :mod:`vectorid.store.inputs`): the module of the model class
    (``model = "msd.dynamics:MassSpringDamper"``, a registered name or an entry point) and
    of each criterion function of your own (``use = "mycrit:f"``), module name -> role.
    vectorid's own models are left out (vectorid's sources are hashed as one)."""
    table = spec.extra.get("identification")
    if not isinstance(table, Mapping):
        return {}
    out: dict[str, str] = {}
    name = table.get("model", spec.model)
    target = _model_target(name) if isinstance(name, str) else None
    if target is not None:
        module = target.partition(":")[0]
        if module.split(".")[0] != "vectorid":
            out[module] = "model module"
    crits = table.get("criteria")
    for c in crits.values() if isinstance(crits, Mapping) else ():
        use = c.get("use") if isinstance(c, Mapping) else None
        if isinstance(use, str) and ":" in use:
            out.setdefault(use.partition(":")[0].strip(), "criterion module")
    return out


def resolve_model(table: Mapping[str, Any], default_model: Any, base_dir: str | Path | None):
    """The model instance an ``[identification]`` table names (its ``model``, else the
    study's), with the study file's folder on the import path for an import path."""
    name = table.get("model", default_model) if isinstance(table, Mapping) else default_model
    if not isinstance(name, str):
        raise _err(
            "model",
            f"expected a model name, got {name!r}",
            f"write model = one of {', '.join(models.available())}, or an import path "
            "'package.module:Class' of your own model",
        )
    if ":" in name and base_dir is not None:
        b = str(Path(base_dir).resolve())
        if b not in sys.path:
            sys.path.insert(0, b)
    opts = table.get("model_options", {}) if isinstance(table, Mapping) else {}
    if not isinstance(opts, Mapping):
        raise _err(
            "model_options", f"expected a table, got {opts!r}", "write model_options = { ... }"
        )
    try:
        return models.get(name, **dict(opts))
    except KeyError as exc:
        raise _err(
            "model", str(exc).strip("'\""), "use a registered model name or an import path"
        ) from None
    except ModuleNotFoundError as exc:
        raise _err(
            "model",
            f"cannot import the model {name!r}: {exc}",
            "put the module beside the study file (or install its package)",
        ) from None
    except ImportError as exc:
        raise _err("model", str(exc), "check the model's import path") from None
    except (TypeError, ValueError) as exc:
        raise _err("model_options", str(exc), "see the model's constructor options") from None
