"""How a study's design vectors fly a drop: the model, its fixed parameters, the steps.

A :class:`Predictor` is built from a study definition (:meth:`Predictor.from_spec`): its
``[identification]`` table gives the model (with its options), the fixed parameters, the
integration step ``dt``, the comparison grid ``output_dt``, the initial-state fit span and the
atmosphere; its design variables map to model parameters by name. A study whose model is a
Python function wrapping identifications (the several-flights model,
:class:`vectorid.identify.multiflight.MultiFlight`) says the same in an
``[x-predict.identification]`` table, and its per-drop design variables are named
``"<parameter>.<drop>"`` (``"wind_north.flight1"``).

:meth:`Predictor.fly` simulates full parameter vectors over one
:class:`~vectorid.identify.planned.DropToPredict` in batches through the compiled model (its
threads use every core) and returns :class:`Flown`: each channel in the data's conventions
(position north, east, down relative to the drop's origin, m; altitude above it, m; velocity
NED, m/s; Euler angles, rad; body rates, rad/s), on the channel's own time base. What the
measurement noise does to the prediction of a drop with data — the initial state is fitted to
noisy samples — is :meth:`Predictor.initial_state_errors` (the fit applied to seeded noise)
times :meth:`Predictor.state_jacobian` (central differences).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vectorid.errors import StudyDefinitionError, suggest
from vectorid.identify.flight import FlightChannel, FlightData
from vectorid.identify.identification import sim_channel, window_variable
from vectorid.identify.noise.floor import _STATE, _shift, _state_vector
from vectorid.identify.noise.statements import parse_discrepancy
from vectorid.identify.planned import (
    POSITION_SPAN,
    PREDICTED_CHANNELS,
    DropToPredict,
    fit_prediction_state,
    read_drop_file,
)
from vectorid.identify.system import resolve_model
from vectorid.models.atmosphere import ISA
from vectorid.models.base import Model, SimulationResult
from vectorid.models.system import SystemModel
from vectorid.timesteps import check_time_steps

__all__ = ["BATCH", "Flown", "Predictor"]

#: Members simulated per call of the compiled model (bounds the memory of one batch).
BATCH = 2048
#: Channels the initial-state fit reads.
_FIT_CHANNELS = ("position", "velocity", "euler", "rates", "altitude")


def _err(field_: str, problem: str, fix: str = "") -> StudyDefinitionError:
    return StudyDefinitionError(field_, problem, fix)


@dataclass
class Flown:
    """Members flown over one drop.

    Attributes
    ----------
    channels : dict
        Channel name -> (n, T_c, m) array in the data's conventions (NaN rows for members
        whose simulation failed).
    times : dict
        Channel name -> (T_c,) times, s from the drop's start.
    components : dict
        Channel name -> component names.
    units : dict
        Channel name -> unit.
    ok : (n,) bool
        Members that flew the whole drop.
    messages : list of str
        One line per member (why it failed, or "ok").
    t : (T,) float
        The simulation's output times, s from the start.
    position : (n, T, 3) float
        Position north, east, down relative to the origin on ``t`` (for the landing point).
    """

    channels: dict[str, NDArray[np.float64]]
    times: dict[str, NDArray[np.float64]]
    components: dict[str, tuple[str, ...]]
    units: dict[str, str]
    ok: NDArray[np.bool_]
    messages: list[str]
    t: NDArray[np.float64]
    position: NDArray[np.float64]


class Predictor:
    """The model and settings that fly a study's design vectors over new drops.

    Parameters
    ----------
    model : Model
        The flight model (with the study's options).
    variables : sequence of str
        The study's design variables, in the column order of its trials.
    fixed : mapping, optional
        Model parameters the study fixes (the others stay nominal).
    dt, output_dt : float
        Integration step and comparison grid step, s.
    init_span : float
        s of data fitted for a data drop's initial state.
    atmosphere : ISA or None
    noise : optional
        The study's noise statement (``[identification] noise``: a table, ``"estimate"`` or None).
    study_drops : sequence of str
        The study's drop names (for per-drop variables).
    allowance : mapping, optional
        The study's model-discrepancy allowance per channel (``[identification] discrepancy``
        noise keys, SI): channel -> one bound per component.
    """

    def __init__(
        self,
        model: Model,
        variables: Sequence[str],
        *,
        fixed: Mapping[str, float] | None = None,
        dt: float = 0.05,
        output_dt: float = 0.5,
        init_span: float = 1.0,
        atmosphere: ISA | None = None,
        noise: Any = None,
        study_drops: Sequence[str] = (),
        allowance: Mapping[str, Sequence[float]] | None = None,
    ) -> None:
        if isinstance(model, SystemModel) or not isinstance(model, Model):
            raise _err(
                "identification.model",
                f"predictions fly drops of a flight model; {getattr(model, 'name', model)!r} "
                "is a model of your own (records, not drops)",
                "compare its simulation with new records by `vectorid report`",
            )
        self.model = model
        self.variables = list(variables)
        self.dt, self.output_dt, self.init_span = float(dt), float(output_dt), float(init_span)
        check_time_steps(self.dt, self.output_dt, where="identification")
        self.atmosphere = atmosphere
        self.noise = noise
        self.allowance = {k: [float(x) for x in v] for k, v in dict(allowance or {}).items()}
        pnames = list(model.parameter_names)
        self.base = model.nominal.copy()
        for k, v in dict(fixed or {}).items():
            if k not in pnames:
                raise _err(f"identification.parameters.{k}", "unknown model parameter",
                           suggest(k, pnames))  # fmt: skip
            self.base[pnames.index(k)] = float(v)
        #: (column of X, model parameter index) of the variables every drop shares
        self.shared: list[tuple[int, int]] = []
        #: model parameter -> {drop name: column of X} of the per-drop variables
        self.per_drop: dict[str, dict[str, int]] = {}
        #: columns that move a comparison window only (no effect on a prediction)
        self.window_columns: list[int] = []
        for j, v in enumerate(self.variables):
            if window_variable(v) is not None:
                self.window_columns.append(j)
            elif v in pnames:
                self.shared.append((j, pnames.index(v)))
            else:
                param, dot, drop = v.partition(".")
                if dot and param in pnames and drop:
                    self.per_drop.setdefault(param, {})[drop] = j
                else:
                    raise _err(
                        f"variables.{v}",
                        f"{v!r} is neither a parameter of model {model.name!r} nor a "
                        "per-drop one (<parameter>.<drop>)",
                        suggest(v, pnames),
                    )
        self.study_drops = list(study_drops) or sorted(
            {d for cols in self.per_drop.values() for d in cols}
        )

    # -- construction -------------------------------------------------------------------

    @classmethod
    def from_spec(cls, spec: Any) -> Predictor:
        """The predictor of a study definition (:class:`~vectorid.spec.StudySpec`).

        Raises
        ------
        StudyDefinitionError
            When the study identifies no flight model (no ``[identification]`` table, or a
            model of your own).
        """
        table = spec.extra.get("identification")
        if table is None:
            table = (spec.extra.get("x-predict") or {}).get("identification")
        if not isinstance(table, Mapping):
            model = spec.model if isinstance(spec.model, str) else "a Python function"
            raise _err(
                "store",
                f"its study ({spec.name!r}, model {model}) has no [identification] table: it "
                "identifies no flight model, so there is nothing to fly a drop with",
                "predict from the store of an identification study (vectorid demo, or a study "
                "file with [identification])",
            )
        default = spec.model if isinstance(spec.model, str) else None
        model = resolve_model(table, default, spec.base_dir)
        atm = table.get("atmosphere")
        drops = table.get("drops") or []
        names = [
            str(d.get("name", f"drop{i + 1}"))
            for i, d in enumerate(drops)
            if isinstance(d, Mapping)
        ]
        return cls(
            model,
            spec.space.names,
            fixed=table.get("parameters"),
            dt=float(table.get("dt", 0.05)),
            output_dt=float(table.get("output_dt", 0.5)),
            init_span=float(table.get("init_span", 1.0)),
            atmosphere=None if atm is None else ISA(float(atm.get("temperature_offset", 0.0))),
            noise=table.get("noise"),
            study_drops=names,
            allowance=parse_discrepancy(table.get("discrepancy"), spec.criterion_names)["channels"],
        )

    def read_drops(self, path: str | Path) -> list[DropToPredict]:
        """The drops of a drop file (:func:`~vectorid.identify.planned.read_drop_file`), with
        this study's noise, grid and fit span; their parameters are checked against the
        study's design variables."""
        drops = read_drop_file(
            path, self.model, study_noise=self.noise, output_dt=self.output_dt,
            init_span=self.init_span, dt=self.dt,
        )  # fmt: skip
        for d in drops:
            self.check_drop(d)
        return drops

    def check_drop(self, drop: DropToPredict) -> None:
        """Raise when ``drop``'s parameters clash with the design variables, or a per-drop
        variable of the study has no value for it."""
        identified = {self.model.parameter_names[i] for _, i in self.shared}
        for k, v in drop.parameters.items():
            if k in identified:
                raise _err(
                    f"{drop.name}.parameters.{k}",
                    f"{k!r} is a design variable of the study: its values come from D's members",
                    "remove it from parameters",
                )
            if isinstance(v, str) and k not in self.per_drop:
                raise _err(
                    f"{drop.name}.parameters.{k}",
                    f"{v!r} draws from the study's per-drop values, but {k!r} is no per-drop "
                    "variable of the study",
                    "give a number",
                )
        missing = [
            p
            for p, cols in self.per_drop.items()
            if drop.name not in cols and p not in drop.parameters
        ]
        if missing:
            shown = ", ".join(missing)
            raise _err(
                f"{drop.name}.parameters",
                f"the study identifies {shown} per drop ({', '.join(self.study_drops)}), and "
                f"drop {drop.name!r} is none of them, so its {shown} is unknown",
                f'state it: parameters = {{ {missing[0]} = 0.0 }} (a value), or "drawn" (each '
                "member's value on one of the study's drops, at random) or \"mean\"",
            )

    def describe_parameters(self, drop: DropToPredict) -> str:
        """How ``drop``'s own parameters are set, in words ("" when it sets none)."""
        parts = []
        for k, v in drop.parameters.items():
            if v == "drawn":
                parts.append(f"{k}: each member's own on one of {', '.join(self.study_drops)}, "
                             "drawn at random")  # fmt: skip
            elif v == "mean":
                parts.append(f"{k}: each member's mean over {', '.join(self.study_drops)}")
            else:
                parts.append(f"{k} = {v:g}")
        own = [p for p, cols in self.per_drop.items() if drop.name in cols]
        if own and not any(p in drop.parameters for p in own):
            parts.append(f"{', '.join(own)}: each member's own on {drop.name} (identified)")
        return "; ".join(parts)

    # -- parameters ---------------------------------------------------------------------

    def parameters(
        self, X: NDArray, drop: DropToPredict, rng: np.random.Generator | None = None
    ) -> NDArray[np.float64]:
        """Full model parameter vectors (n, p_model) of design vectors ``X`` (n, p) on ``drop``.

        Per-drop variables take the drop's own column when the study identified this drop,
        else the drop's ``parameters`` (a value; ``"drawn"``: one of the study's drops per
        member from ``rng``, the same drop for every drawn parameter of that member, so a
        flight's wind stays whole; or ``"mean"``)."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        P = np.tile(self.base, (X.shape[0], 1))
        pnames = list(self.model.parameter_names)
        for k, v in drop.parameters.items():
            if not isinstance(v, str):
                P[:, pnames.index(k)] = float(v)
        for j, i in self.shared:
            P[:, i] = X[:, j]
        pick = None  # one study drop per member, shared by every "drawn" parameter
        for param, cols in self.per_drop.items():
            i = pnames.index(param)
            rule = drop.parameters.get(param)
            if drop.name in cols and rule is None:
                P[:, i] = X[:, cols[drop.name]]
            elif rule == "mean":
                P[:, i] = X[:, list(cols.values())].mean(axis=1)
            elif rule == "drawn":
                if pick is None:
                    rng = rng if rng is not None else np.random.default_rng(0)
                    pick = rng.integers(0, len(self.study_drops), X.shape[0])
                names = [self.study_drops[k] for k in pick]
                P[:, i] = [X[r, cols[n]] if n in cols else np.nan for r, n in enumerate(names)]
        return P

    # -- flying -------------------------------------------------------------------------

    def output_step(self, drop: DropToPredict) -> float:
        """The output step of ``drop``'s simulation, s: the study's grid for a drop with data,
        else the largest step every channel's rate is a whole multiple of."""
        if drop.kind == "data":
            return self.output_dt
        strides = [round(1.0 / (hz * self.dt)) for hz in drop.channels.values() if hz]
        return self.dt * int(np.gcd.reduce(np.array(strides, dtype=np.int64)))

    def duration(self, drop: DropToPredict) -> float:
        """Simulated time, s: the drop's, floored to a whole number of output steps."""
        step = self.output_step(drop)
        n = int(np.floor(drop.duration / step + 1e-9))
        if n < 2:
            raise _err(
                f"{drop.name}.duration",
                f"{drop.duration:g} s is shorter than two output steps of {step:g} s",
                "give a longer duration",
            )
        return n * step

    def simulate(self, P: NDArray, drop: DropToPredict, initial=None) -> SimulationResult:
        """One batch of full parameter vectors ``P`` over ``drop`` (model frame: altitude
        above sea level)."""
        return self.model.simulate(
            P,
            t_final=self.duration(drop),
            dt=self.dt,
            inputs=drop.inputs,
            wind=drop.wind,
            output_dt=self.output_step(drop),
            initial=drop.initial if initial is None else initial,
            atmosphere=self.atmosphere,
        )

    def channel_names(self, drop: DropToPredict) -> list[str]:
        """The channels predicted for ``drop``: a planned drop's, or the data's that the model
        gives (controls are inputs, not outputs)."""
        outs = set(self.model.output_names)
        return [c for c in drop.channels if c in PREDICTED_CHANNELS or c in outs]

    def fly(self, P: NDArray, drop: DropToPredict) -> Flown:
        """Fly full parameter vectors ``P`` (n, p_model) over ``drop``, in batches of
        :data:`BATCH`; every channel in the data's conventions on its own time base."""
        P = np.atleast_2d(np.asarray(P, dtype=float))
        n = P.shape[0]
        names = self.channel_names(drop)
        step = self.output_step(drop)
        t = np.arange(round(self.duration(drop) / step) + 1) * step
        strides = {
            c: (1 if drop.channels[c] is None else round(1.0 / (drop.channels[c] * step)))
            for c in names
        }
        chans: dict[str, NDArray] = {}
        comps: dict[str, tuple[str, ...]] = {}
        units: dict[str, str] = {}
        for c in names:
            comp, unit = self._describe(c, drop)
            comps[c], units[c] = comp, unit
            chans[c] = np.full((n, len(t[:: strides[c]]), len(comp)), np.nan)
        position = np.full((n, t.size, 3), np.nan)
        ok = np.zeros(n, dtype=bool)
        messages: list[str] = []
        for s in range(0, n, BATCH):
            res = self.simulate(P[s : s + BATCH], drop)
            good = res.ok
            ok[s : s + len(good)] = good
            messages += res.messages
            rows = np.arange(s, s + len(good))[good]
            pos = sim_channel(res, "position", drop.origin_altitude)
            position[rows] = pos[good]
            for c in names:
                v = sim_channel(res, c, drop.origin_altitude)[:, :: strides[c]]
                chans[c][rows] = v[good]
        times = {c: t[:: strides[c]] for c in names}
        return Flown(chans, times, comps, units, ok, messages, t, position)

    def _describe(self, c: str, drop: DropToPredict) -> tuple[tuple[str, ...], str]:
        if drop.flight is not None and c in drop.flight.channels:
            ch = drop.flight[c]
            return tuple(ch.components), ch.unit
        if c in PREDICTED_CHANNELS:
            return PREDICTED_CHANNELS[c]
        for ch in self.model.outputs:
            if ch.name == c:
                return (c,), ch.unit
        return (c,), ""

    # -- the measurement noise through the fitted initial state --------------------------

    def initial_state_errors(
        self, drop: DropToPredict, draws: int, rng: np.random.Generator
    ) -> NDArray[np.float64]:
        """Errors (draws, 12) of a data drop's fitted initial state under its stated noise:
        the fit (:func:`~vectorid.identify.planned.fit_prediction_state`) of the data plus a
        seeded noise draw, minus its fit of the data (zeros for a planned drop, whose initial
        state is stated, or where no fitted channel has a stated noise). Order: altitude,
        north, east, velocity (3), Euler angles (3), rates (3)."""
        out = np.zeros((draws, len(_STATE)))
        d = drop.drop
        if d is None or drop.noise is None:
            return out
        t0, span = float(d.t0), float(d.init_span)
        reach = max(span, 3.0, POSITION_SPAN)
        base: dict[str, FlightChannel] = {}
        noisy: list[str] = []
        for ch in _FIT_CHANNELS:
            if ch not in d.flight.channels:
                continue
            c = d.flight[ch]
            sel = (c.t >= t0 - 1e-9) & (c.t <= t0 + reach + 1e-9)
            if not sel.any():
                continue
            base[ch] = FlightChannel(ch, c.t[sel], c.values[sel], c.components, c.unit)
            if any(drop.noise.component(ch, j) is not None for j in range(c.m)):
                noisy.append(ch)
        if not noisy:
            return out

        def fit(chans: dict[str, FlightChannel]) -> NDArray[np.float64]:
            fd = FlightData("noise", chans)
            s = fit_prediction_state(fd, t0, span, d.origin_altitude, d.wind, drop.name,
                                     end=t0 + d.duration)  # fmt: skip
            return _state_vector(s)

        zero = fit(base)
        for r in range(draws):
            chans = dict(base)
            for ch in noisy:
                c = base[ch]
                v = np.array(c.values)
                for j in range(c.m):
                    cn = drop.noise.component(ch, j)
                    if cn is not None:
                        v[:, j] += cn.draw(c.t, 1, rng)[0]
                chans[ch] = FlightChannel(ch, c.t, v, c.components, c.unit)
            out[r] = fit(chans) - zero
        return out

    def state_jacobian(self, p: NDArray, drop: DropToPredict) -> dict[str, NDArray[np.float64]]:
        """d(channel)/d(initial state) of one full parameter vector ``p`` over ``drop`` by
        central differences: channel -> (12, T_c, m), on the channels' time bases of
        :meth:`fly`. A member whose shifted flights fail gives zeros (no sensitivity known)."""
        names = self.channel_names(drop)
        out: dict[str, list[NDArray]] = {c: [] for c in names}
        P = np.atleast_2d(np.asarray(p, dtype=float))
        for s, (_, _, h) in enumerate(_STATE):
            e = np.zeros(len(_STATE))
            e[s] = h
            pair = []
            for sign in (1.0, -1.0):
                res = self.simulate(P, drop, initial=_shift(drop.initial, sign * e))
                pair.append(res)
            for c in names:
                if not (pair[0].ok[0] and pair[1].ok[0]):
                    plus = minus = sim_channel(pair[0], c, drop.origin_altitude)[0] * 0.0
                else:
                    plus = sim_channel(pair[0], c, drop.origin_altitude)[0]
                    minus = sim_channel(pair[1], c, drop.origin_altitude)[0]
                stride = (
                    1
                    if drop.channels[c] is None
                    else round(1.0 / (drop.channels[c] * self.output_step(drop)))
                )
                out[c].append(((plus - minus) / (2 * h))[::stride])
        return {c: np.nan_to_num(np.stack(v)) for c, v in out.items()}
