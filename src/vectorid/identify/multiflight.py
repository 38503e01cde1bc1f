"""Several flights identified at once: shared design variables, per-flight ones, criteria
averaged over the flights (the seed's "several experiments").

A small parafoil flies a few short flights in unknown wind. One flight rarely determines its
gains; several together can, if each flight keeps its own nuisance variables — its uniform
wind (north, east), which the gains must not absorb. :class:`MultiFlight` is that batch model:
design vector -> criteria, each the mean over the flights of the flight's criterion, with
columns ``[*shared, *(f"{v}.{flight}" for flight in flights for v in per_flight)]``.

Its noise-grounded limits (:meth:`MultiFlight.noise_limits`) average the noise floors of the
flights the way the criteria average the flights: each flight's floor is the Monte Carlo of a
perfect model under that flight's noise (:func:`vectorid.identify.noise.floor.noise_floor`)
with that flight's discrepancy allowance (e.g. :func:`vectorid.identify.gusts.gust_allowance`),
the draws are averaged over the flights, and one joint quantile level gives the limits.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vectorid.errors import StudyDefinitionError
from vectorid.identify.flight import FlightData
from vectorid.identify.identification import Identification, sim_channel
from vectorid.identify.noise.estimate import estimate_noise
from vectorid.identify.noise.floor import NoiseFloor, noise_floor
from vectorid.identify.noise.statements import DISCREPANCY_RULES, NoiseModel, allowance_label

__all__ = ["MultiFlight"]


class MultiFlight:
    """The batch model of several flights: design vector -> criteria averaged over the flights.

    Parameters
    ----------
    idents : mapping
        Flight name -> its identification (one drop each), whose variables are
        ``[*shared, *per_flight]`` and whose criteria are the same for every flight.
    shared : sequence of str
        Design variables every flight shares (the gains).
    per_flight : sequence of str
        Design variables each flight has its own of (its uniform wind), named
        ``"<variable>.<flight>"`` among the study's variables.
    """

    def __init__(
        self,
        idents: Mapping[str, Identification],
        shared: Sequence[str],
        per_flight: Sequence[str] = ("wind_north", "wind_east"),
    ) -> None:
        self.shared = tuple(shared)
        self.per = tuple(per_flight)
        self.idents = dict(idents)
        self.names = list(self.idents)
        if not self.names:
            raise StudyDefinitionError("flights", "no flight given", "pass one flight or more")
        want = [*self.shared, *self.per]
        crit = None
        for name, ident in self.idents.items():
            if list(ident.variables) != want:
                raise StudyDefinitionError(
                    f"flights.{name}",
                    f"the identification's variables are {list(ident.variables)}, expected "
                    f"{want} (the shared ones, then the flight's own)",
                    "build each flight's identification with variables=[*shared, *per_flight]",
                )
            names = [c.name for c in ident.criteria]
            if crit is not None and names != crit:
                raise StudyDefinitionError(
                    f"flights.{name}",
                    f"criteria {names} differ from the first flight's {crit}",
                    "give every flight the same criteria, in the same order",
                )
            crit = names
        self.criterion_names: list[str] = list(crit or [])

    @classmethod
    def from_flights(
        cls,
        flights: Mapping[str, FlightData],
        table: Mapping[str, Any],
        shared: Sequence[str],
        criteria: Sequence[str],
        *,
        per_flight: Sequence[str] = ("wind_north", "wind_east"),
        window_channels: Sequence[str] = ("position",),
        drop: Mapping[str, Any] | None = None,
    ) -> MultiFlight:
        """One identification per flight from one ``[identification]`` table.

        Parameters
        ----------
        flights : mapping
            Flight name -> its data.
        table : mapping
            The ``[identification]`` table without ``drops`` (model, model options, steps).
        shared, per_flight : sequence of str
            As in the class.
        criteria : sequence of str
            Library criteria of every flight (e.g. ``["pos_h_abs", "pos_v_abs"]``).
        window_channels : sequence of str
            Each flight is compared over the span these channels share.
        drop : mapping, optional
            Further keys of each flight's drop table (``origin_altitude``,
            ``interpolation``).
        """
        idents = {}
        for name, fl in flights.items():
            t0 = max(float(fl[c].t[0]) for c in window_channels)
            t1 = min(float(fl[c].t[-1]) for c in window_channels)
            drop_t = {"name": name, "window": [t0, t1], **dict(drop or {})}
            idents[name] = Identification.from_table(
                {**table, "drops": [drop_t]},
                variables=[*shared, *per_flight],
                criteria=list(criteria),
                flights={name: fl},
            )
        return cls(idents, shared, per_flight)

    @property
    def variables(self) -> list[str]:
        """The study's design variables: the shared ones, then each flight's own."""
        own = [f"{v}.{n}" for n in self.names for v in self.per]
        return [*self.shared, *own]

    def columns(self, X: NDArray, k: int) -> NDArray[np.float64]:
        """The columns of flight ``k``'s identification from design vectors X (n, p)."""
        g, m = len(self.shared), len(self.per)
        own = [g + m * k + j for j in range(m)]
        return np.column_stack([X[:, :g], *(X[:, j] for j in own)])

    def per_flight(self, X: NDArray) -> NDArray[np.float64]:
        """Criteria of each flight, (n, flights, criteria)."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        out = [self.idents[n].evaluate(self.columns(X, k))[0] for k, n in enumerate(self.names)]
        return np.stack(out, axis=1)

    def __call__(self, X: NDArray) -> NDArray[np.float64]:
        """Criteria (n, criteria): the mean over the flights."""
        return self.per_flight(X).mean(axis=1)

    def rms_errors(self, x: NDArray) -> dict[str, dict[str, float]]:
        """RMS errors of one design vector on each flight's window: ``horizontal`` (m, where
        the flight measures a position), ``altitude`` (m, where it measures an altitude) and
        the window's ``duration`` (s)."""
        out = {}
        for k, n in enumerate(self.names):
            ident = self.idents[n]
            d = ident.drops[0]
            res = ident.simulate(self.columns(np.atleast_2d(x), k), d)
            row = {"duration": float(d.duration)}
            if "position" in d.flight.channels:
                e = res.position[0, :, :2] - d.measured("position")[:, :2]
                row["horizontal"] = float(np.sqrt(np.mean((e**2).sum(axis=1))))
            if "altitude" in d.flight.channels:
                h = sim_channel(res, "altitude", d.origin_altitude)[0, :, 0]
                eh = h - d.measured("altitude")[:, 0]
                row["altitude"] = float(np.sqrt(np.mean(eh**2)))
            out[n] = row
        return out

    def noise_limits(
        self,
        allowance: Mapping[str, Mapping[str, float]],
        *,
        draws: int = 2000,
        seed: int = 0,
        coverage: float = 0.95,
        channels: Sequence[str] = ("position",),
        noise: Mapping[str, NoiseModel] | None = None,
        params: Mapping[str, float] | None = None,
    ) -> tuple[dict[str, tuple[float, str]], dict[str, str]]:
        """Noise-floor limits of the flight-averaged criteria.

        Each flight's noise is estimated from its data (:func:`estimate_noise` on
        ``channels``: the white part) unless ``noise`` states it; the floor of a perfect
        model under it is flown on that flight with the flight's own allowance
        (``allowance[flight]``, noise keys as in ``discrepancy``; seed ``seed + k`` for the
        k-th flight); the draws are averaged over the flights as the criteria are, and the
        joint ``coverage`` quantile level of all criteria gives the limits.

        Parameters
        ----------
        allowance : mapping
            Flight name -> discrepancy allowance (noise key -> δ in the key's unit).
        draws, seed : int
        coverage : float
            Joint coverage of the limits (0.95: all criteria of a perfect model within
            their limits together in 95 % of the draws).
        channels : sequence of str
            Channels whose noise is estimated.
        noise : mapping, optional
            Flight name -> stated (or borrowed) noise, instead of the flight's estimate.
        params : mapping, optional
            The truth the floor flies (default: each identification's base vector).

        Returns
        -------
        limits : dict
            Criterion name -> (limit in the criterion's unit, note).
        noise : dict
            Flight name -> the noise used, in words.
        """
        samples, used = [], {}
        fl = None
        for k, (name, ident) in enumerate(self.idents.items()):
            est = (noise or {}).get(name) or estimate_noise(ident.drops[0].flight, list(channels))
            fl = noise_floor(
                ident,
                {name: est},
                draws=draws,
                seed=seed + k,
                params=dict(params or {}),
                discrepancy=allowance[name],
            )
            samples.append(fl.samples)
            used[name] = est.describe()
        assert fl is not None  # at least one flight (the constructor checks)
        notes = {}  # the allowance of each criterion, per flight, in words
        for n in fl.names:
            rule = DISCREPANCY_RULES.get(n)
            if rule is None:
                continue
            key, _, unit = allowance_label(rule[0], rule[1])  # allowances are in key units
            vals = [allowance[f].get(key, 0.0) for f in self.idents]
            if max(vals) > 0:
                notes[n] = f"discrepancy {key} {min(vals):.3g}-{max(vals):.3g} {unit} by flight"
        floor = NoiseFloor(
            fl.names, fl.units, np.mean(samples, axis=0), {}, notes, draws, seed, used
        )
        return floor.limits(fl.names, coverage=coverage), used
