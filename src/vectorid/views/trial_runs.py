"""Trial runs: the numbers behind the identification views of the report and the UI (seed
000 Fig. 11, seed 001 Figs. 1–2, 7, 9; the Euler-angle spectra of seed 001 Table I, criteria
13–15).

Everything here starts from a study with an ``[identification]`` table and some design
vectors, and returns plain arrays that :mod:`vectorid.views.figures` draws
(``trajectory_figure``, ``trajectory3d_figure``, ``channels_figure``, ``spectra_figure``):

* :func:`simulate_trials` simulates several design vectors over one drop in **one** batch
  call of :meth:`Identification.simulate` and keeps the measured and simulated channels on
  the drop's output grid, in the data's conventions — the very arrays the criteria compare
  (the channel conventions come from :func:`vectorid.identify.identification.sim_channel`,
  the same function :meth:`Identification.evaluate` uses, so a criterion recomputed from a
  :class:`TrialRuns` equals the stored one when the study uses one wind realisation).
* :meth:`TrialRuns.trajectories` gives north/east/up positions (as
  :func:`~vectorid.identify.trial_trajectories`, batched), :meth:`TrialRuns.channel_histories`
  the time histories of one channel with the drop-out envelope ``measurement ± band`` of the
  study's ``[identification.dropout.*]`` functionals, and :meth:`TrialRuns.spectra` the Welch
  power spectra (:func:`vectorid.analysis.signals.power_spectrum`) of the Euler angles.
* :func:`pick_trials` names the trials the report shows: the best trial per pure criterion
  (:func:`vectorid.analysis.choice.best_per_criterion`), the chosen (or suggested) vector,
  the worst successful trial and a subset of the Pareto set for the model envelope.

The trajectories are simulated in the drop's **measured** wind profile; with
``wind_realisations > 1`` the stored criteria are means over wind realisations, so they are
not exactly the criteria of the drawn trajectory (the report says so).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vectorid.analysis.choice import best_per_criterion, pure_scores, suggest_choice
from vectorid.analysis.signals import power_spectrum
from vectorid.identify.criteria import wrap_angle
from vectorid.identify.identification import Drop, Identification, sim_channel

__all__ = [
    "VIEW_CHANNELS",
    "ChannelHistories",
    "TrialPicks",
    "TrialRuns",
    "dropout_bands",
    "nominal_vector",
    "pick_trials",
    "rows_of",
    "simulate_trials",
    "study_runs",
    "worst_trial",
]

#: Channels a :class:`TrialRuns` keeps by default (when the drop measures them).
VIEW_CHANNELS = ("position", "altitude", "velocity", "euler", "rates")
#: Channels in rad (shown in degrees by :meth:`TrialRuns.channel_histories`).
_ANGULAR = {"euler": "deg", "rates": "deg/s"}
_NEU = np.array([1.0, 1.0, -1.0])


@dataclass
class ChannelHistories:
    """Time histories of one channel: the flight, several simulated trials and the drop-out
    envelope, as :func:`vectorid.views.figures.channels_figure` takes them.

    Attributes
    ----------
    channel : str
    t : (T,) float
        Time from the window start, s.
    flight : dict component -> (T,) float
        Measured values on the output grid.
    runs : list of (t (T,), dict component -> (T,))
        One per successful trial, in the order of ``labels``.
    labels : list of str
    band_low, band_high : dict component -> (T,) float
        The drop-out envelope ``measurement ∓ band`` of the components constrained by a
        drop-out functional on this drop (empty when none).
    unit : str
        Unit of every value (``deg``/``deg/s`` for angles when ``degrees``).
    failed : list of str
        Labels of trials whose simulation failed (left out of ``runs``).
    """

    channel: str
    t: NDArray[np.float64]
    flight: dict[str, NDArray[np.float64]]
    runs: list[tuple[NDArray[np.float64], dict[str, NDArray[np.float64]]]]
    labels: list[str]
    band_low: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    band_high: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    unit: str = ""
    failed: list[str] = field(default_factory=list)

    @property
    def bands(self) -> dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]]:
        """``component -> (low, high)``, the ``bands`` argument of ``channels_figure``."""
        return {c: (self.band_low[c], self.band_high[c]) for c in self.band_low}


@dataclass
class TrialRuns:
    """Measured and simulated channels of several design vectors over one drop.

    Attributes
    ----------
    drop : str
    t : (T,) float
        Time from the window start, s (the identification's output grid).
    grid : (T,) float
        The same grid in the flight data's absolute time, s.
    X : (n, p) float
        Design vectors, columns as the study's variables.
    labels : list of str
        One per row of ``X``.
    status : (n,) int
        Simulation status per trial (0 = ok, see ``vectorid.models.base.STATUS_MESSAGES``).
    measured : dict channel -> (T, m) float
        Measured channels on the grid (SI, NED position relative to the data's origin).
    simulated : dict channel -> (n, T, m) float
        Simulated channels in the same conventions.
    components : dict channel -> tuple of str
    units : dict channel -> str
        SI units of ``measured`` and ``simulated``.
    bands : dict channel -> (T, m) float
        Half-width of the drop-out envelope per component (NaN where no drop-out functional
        constrains the component on this drop); see :func:`dropout_bands`.
    """

    drop: str
    t: NDArray[np.float64]
    grid: NDArray[np.float64]
    X: NDArray[np.float64]
    labels: list[str]
    status: NDArray[np.int64]
    measured: dict[str, NDArray[np.float64]]
    simulated: dict[str, NDArray[np.float64]]
    components: dict[str, tuple[str, ...]]
    units: dict[str, str]
    bands: dict[str, NDArray[np.float64]] = field(default_factory=dict)

    @property
    def ok(self) -> NDArray[np.bool_]:
        """Trials whose simulation finished, (n,) bool."""
        return self.status == 0

    def trajectories(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Flight (T, 3) and simulated (n, T, 3) positions: north, east, up in m relative to
        the data's origin (the frame of ``trajectory_figure``); a drop with altitude only
        gives zeros for north and east. Failed trials hold NaN after their failure."""
        if "position" in self.measured:
            return self.measured["position"] * _NEU, self.simulated["position"] * _NEU
        if "altitude" not in self.measured:
            raise KeyError(
                f"drop {self.drop!r}: no position or altitude channel was simulated; "
                "pass channels=('position', ...) to simulate_trials"
            )
        n, T = len(self.labels), len(self.t)
        flight = np.zeros((T, 3))
        flight[:, 2] = self.measured["altitude"][:, 0]
        model = np.zeros((n, T, 3))
        model[:, :, 2] = self.simulated["altitude"][:, :, 0]
        return flight, model

    def _aligned(self, channel: str) -> NDArray[np.float64]:
        """Simulated channel; Euler angles are shown as ``measured + wrap(sim - measured)``,
        the difference the angular criteria integrate."""
        sim = self.simulated[channel]
        if channel == "euler":
            meas = self.measured[channel]
            return meas[None] + wrap_angle(sim - meas[None])
        return sim

    def channel_histories(
        self, channel: str, rows: Sequence[int] | None = None, *, degrees: bool = True
    ) -> ChannelHistories:
        """Time histories of ``channel`` for the trials ``rows`` (default: all), with the
        drop-out envelope of the channel's constrained components.

        Parameters
        ----------
        channel : str
            A channel of :attr:`measured` (e.g. ``"euler"``, ``"velocity"``).
        rows : sequence of int, optional
            Rows of :attr:`X` to include.
        degrees : bool
            Show angles (``euler``, ``rates``) in deg and deg/s instead of rad and rad/s.
        """
        if channel not in self.measured:
            raise KeyError(
                f"drop {self.drop!r} has no simulated {channel!r} channel; available: "
                f"{', '.join(self.measured)}"
            )
        rows = list(range(len(self.labels))) if rows is None else [int(r) for r in rows]
        scale = 180.0 / np.pi if degrees and channel in _ANGULAR else 1.0
        unit = _ANGULAR[channel] if scale != 1.0 else self.units[channel]
        comps = self.components[channel]
        meas = self.measured[channel] * scale
        sim = self._aligned(channel) * scale
        out = ChannelHistories(
            channel, self.t, {c: meas[:, j] for j, c in enumerate(comps)}, [], [], unit=unit
        )
        for r in rows:
            if self.status[r] != 0:
                out.failed.append(self.labels[r])
                continue
            out.runs.append((self.t, {c: sim[r, :, j] for j, c in enumerate(comps)}))
            out.labels.append(self.labels[r])
        band = self.bands.get(channel)
        if band is not None:
            for j, c in enumerate(comps):
                if np.all(np.isfinite(band[:, j])):
                    out.band_low[c] = meas[:, j] - band[:, j] * scale
                    out.band_high[c] = meas[:, j] + band[:, j] * scale
        return out

    def euler_series(
        self, rows: Sequence[int] | None = None
    ) -> tuple[dict[str, NDArray[np.float64]], dict[str, tuple[NDArray, dict[str, NDArray]]]]:
        """The Euler angles (rad) as ``spectra_figure`` takes them: the flight's
        ``{component: (T,)}`` and ``{label: (t, {component: (T,)})}`` for the successful
        trials among ``rows``. Simulated yaw is unwrapped along time (the measured yaw is
        unwrapped when the drop is loaded)."""
        if "euler" not in self.measured:
            raise KeyError(f"drop {self.drop!r} has no 'euler' channel")
        rows = list(range(len(self.labels))) if rows is None else [int(r) for r in rows]
        comps = self.components["euler"]
        meas = self.measured["euler"]
        flight = {c: meas[:, j] for j, c in enumerate(comps)}
        runs = {}
        for r in rows:
            if self.status[r] != 0:
                continue
            sim = np.array(self.simulated["euler"][r])
            sim[:, 2] = np.unwrap(sim[:, 2])
            runs[self.labels[r]] = (self.t, {c: sim[:, j] for j, c in enumerate(comps)})
        return flight, runs

    def spectra(
        self, rows: Sequence[int] | None = None, *, nperseg: int | None = None
    ) -> dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]]:
        """Welch power spectra of the Euler angles: ``{"flight" | label: (freq (F,) Hz,
        psd (F, 3) rad²/Hz)}`` by :func:`vectorid.analysis.signals.power_spectrum` (the
        function ``spectra_figure`` draws with)."""
        flight, runs = self.euler_series(rows)
        out = {
            "flight": power_spectrum(
                self.t, np.column_stack(list(flight.values())), nperseg=nperseg
            )
        }
        for lab, (t, chans) in runs.items():
            out[lab] = power_spectrum(t, np.column_stack(list(chans.values())), nperseg=nperseg)
        return out


def dropout_bands(ident: Identification, drop: str | Drop) -> dict[str, NDArray[np.float64]]:
    """Half-widths of the drop-out envelopes on one drop: ``channel -> (T, m)``.

    A component constrained by several drop-out functionals gets the narrowest band; a
    component no functional constrains is NaN. The band of a
    :class:`~vectorid.identify.identification.DropoutDef` is a scalar or one value per listed
    component (broadcast over the grid as :func:`vectorid.identify.dropout` does).
    """
    d = ident.drop(drop) if isinstance(drop, str) else drop
    T = len(d.grid)
    out: dict[str, NDArray[np.float64]] = {}
    for o in ident.dropouts:
        if o.drops is not None and d.name not in o.drops:
            continue
        comps = d.flight[o.channel].components
        idx = (
            list(range(len(comps))) if not o.components else [comps.index(c) for c in o.components]
        )
        b = np.broadcast_to(np.asarray(o.band, dtype=float), (T, len(idx)))
        cur = out.setdefault(o.channel, np.full((T, len(comps)), np.nan))
        cur[:, idx] = np.fmin(cur[:, idx], b)
    return out


def simulate_trials(
    ident: Identification,
    X: NDArray,
    drop: str | Drop | None = None,
    *,
    labels: Sequence[str] | None = None,
    channels: Sequence[str] | None = None,
) -> TrialRuns:
    """Simulate the design vectors ``X`` over one drop in one batch call.

    Parameters
    ----------
    ident : Identification
        E.g. ``Identification.from_spec(store.spec)``.
    X : (n, p) float
        Design vectors, columns as the study's variables.
    drop : str or Drop, optional
        Default: the first drop.
    labels : sequence of str, optional
        One per row of ``X`` (default ``"trial 1"``, ...).
    channels : sequence of str, optional
        Channels to keep (default: those of :data:`VIEW_CHANNELS` the drop measures).

    Returns
    -------
    TrialRuns
        Simulated in the drop's measured wind profile.
    """
    d = ident.drops[0] if drop is None else (ident.drop(drop) if isinstance(drop, str) else drop)
    X = np.atleast_2d(np.asarray(X, dtype=float))
    labels = [f"trial {i + 1}" for i in range(len(X))] if labels is None else list(labels)
    if len(labels) != len(X):
        raise ValueError(f"expected {len(X)} labels (one per design vector), got {len(labels)}")
    if channels is None:
        channels = [c for c in VIEW_CHANNELS if c in d.flight.channels]
    for c in channels:
        if c not in d.flight.channels:
            raise KeyError(
                f"drop {d.name!r} has no {c!r} channel; available: {', '.join(d.flight.channels)}"
            )
    res = ident.simulate(X, d)
    T = min(len(d.grid), res.t.size)
    measured, simulated, components, units = {}, {}, {}, {}
    for c in channels:
        ch = d.flight[c]
        measured[c] = d.measured(c)[:T]
        simulated[c] = np.asarray(sim_channel(res, c, d.origin_altitude))[:, :T]
        components[c] = tuple(ch.components)
        units[c] = ch.unit
    bands = {c: b[:T] for c, b in dropout_bands(ident, d).items() if c in measured}
    return TrialRuns(
        d.name,
        np.asarray(d.grid[:T] - d.t0, dtype=float),
        np.asarray(d.grid[:T], dtype=float),
        X,
        labels,
        np.asarray(res.status),
        measured,
        simulated,
        components,
        units,
        bands,
    )


# -- which trials to show -----------------------------------------------------------------------


def nominal_vector(spec: Any, ident: Identification) -> NDArray[np.float64]:
    """The nominal design vector (p,): each variable's ``nominal`` in the study where it has
    one, otherwise the model parameter's value the identification starts from (the model's
    nominal or the ``[identification] parameters`` value)."""
    nom = np.array(spec.space.nominal, dtype=float)
    base = ident.base[ident.columns]
    return np.where(np.isfinite(nom), nom, base)


def worst_trial(a: Any) -> int | None:
    """Id of the worst successful trial: the largest sum over the pure criteria of each
    criterion normalised to [0, 1] over the successful trials (0 best, so ``max`` criteria
    are flipped). None when no trial succeeded."""
    rows = np.flatnonzero(a.ok & np.all(np.isfinite(a.trials.F), axis=1))
    if len(rows) == 0:
        return None
    Z = pure_scores(a, rows)
    return int(a.trials.id[rows[int(np.argmax(Z.sum(axis=1)))]])


@dataclass
class TrialPicks:
    """The trials the identification views show (trial ids of ``a.trials.id``).

    Attributes
    ----------
    best : dict criterion -> id
        The best trial per pure criterion (within D; among the trials meeting the functional
        constraints when D is empty).
    chosen : int or None
        The chosen vector (first of ``chosen``) or the suggestion of
        :func:`~vectorid.analysis.choice.suggest_choice`.
    worst : int or None
        See :func:`worst_trial`.
    envelope : list of int
        Up to ``max_envelope`` trials of the Pareto set (or of D, or of the successful
        trials, the first non-empty), spread evenly in the order of the first pure criterion.
    envelope_set : str
        ``"Pareto"``, ``"feasible"`` or ``"successful"``: where ``envelope`` comes from.
    """

    best: dict[str, int]
    chosen: int | None
    worst: int | None
    envelope: list[int]
    envelope_set: str

    def ids(self) -> list[int]:
        """Every picked id once, in a stable order."""
        out: list[int] = []
        for i in [self.chosen, *self.best.values(), self.worst, *self.envelope]:
            if i is not None and i not in out:
                out.append(int(i))
        return out


def pick_trials(a: Any, chosen: Sequence[int] = (), *, max_envelope: int = 40) -> TrialPicks:
    """The trials to draw for the analysis ``a`` (a :class:`vectorid.analysis.Analysis`).

    Parameters
    ----------
    a : Analysis
    chosen : sequence of int
        The expert's chosen trial ids; the first is drawn as the chosen vector.
    max_envelope : int
        Most trials in the model envelope.
    """
    pure = {a.crit_names[j] for j in a.pure} or set(a.crit_names)
    best = best_per_criterion(a) or best_per_criterion(a, feasible_only=False)
    best = {k: v for k, v in best.items() if k in pure}
    pick = int(chosen[0]) if len(chosen) else suggest_choice(a)
    if pick is None and best:
        pick = next(iter(best.values()))
    name, rows = "successful", np.flatnonzero(a.ok)
    for set_name, mask in (("Pareto", a.pareto), ("feasible", a.feasible)):
        if mask.any():
            name, rows = set_name, np.flatnonzero(mask)
            break
    if len(rows):
        j = a.pure[0] if a.pure else 0
        key = a.trials.F[rows, j] * (-1 if a.senses[j] == "max" else 1)
        rows = rows[np.argsort(key, kind="stable")]
        if len(rows) > max_envelope:
            rows = rows[np.unique(np.linspace(0, len(rows) - 1, max_envelope).round().astype(int))]
    return TrialPicks(best, pick, worst_trial(a), [int(a.trials.id[r]) for r in rows], name)


def rows_of(a: Any, ids: Sequence[int]) -> NDArray[np.int64]:
    """Rows of ``a.trials`` holding the trial ids ``ids`` (the first row of each id)."""
    tid = np.asarray(a.trials.id)
    out = []
    for i in ids:
        hit = np.flatnonzero(tid == int(i))
        if not len(hit):
            raise KeyError(f"no stored trial with id {i}")
        out.append(int(hit[0]))
    return np.asarray(out, dtype=np.int64)


def study_runs(
    spec: Any,
    X: NDArray,
    labels: Sequence[str],
    *,
    ident: Identification | None = None,
    channels: Sequence[str] | None = None,
) -> list[TrialRuns]:
    """:func:`simulate_trials` over every drop of the study (one batch call per drop);
    the identification is built from ``spec`` unless given."""
    ident = Identification.from_spec(spec) if ident is None else ident
    return [
        simulate_trials(
            ident,
            X,
            d,
            labels=labels,
            channels=None if channels is None else [c for c in channels if c in d.flight.channels],
        )
        for d in ident.drops
    ]
