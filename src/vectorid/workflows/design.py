"""The worth of a planned drop: how much of D its data would keep, before flying it.

:func:`design` is the one call (``vectorid design STORE PLAN.toml ...`` runs it)::

    from vectorid.workflows.design import design
    d = design("runs/g12.db", ["brake-steps.toml", "spiral.toml"], members=400, seed=0)
    print(d.describe())            # the same text as the command line
    d.to_dict()                    # the --json document

Each plan is a drop file of one or more planned drops (``[[identification.drops]]`` with
``initial``, ``duration``, ``channels = { name = Hz }``, the wind and the ``noise`` of its
sensors: :mod:`vectorid.identify.planned`, shared with ``vectorid predict``). For each plan:

1. **Fly D's members** over it twice (:func:`vectorid.workflows.predict.members_of` chooses
   them keeping the sampler's weights; the plan is read as ``vectorid predict`` reads it):
   from its stated initial state — each member's record if it were the truth — and from the
   state the study would fit to the plan's first seconds
   (:func:`vectorid.identify.drops.fit_initial_state` on the record of the member nearest
   the members' mean) — each member as the study would simulate it. A sensor the plan lacks
   leaves that part of the state unfitted (no gyro: rates 0; no IMU: attitude 0), as the
   study would; a plan without a position or altitude sensor cannot have its start fitted:
   its initial state is then taken as known, and a note says so.
2. **Judge it with the study's own criteria and limit rule**: the plan's drop gets each
   library criterion of the study that reads one of its sensors (``pos_h_abs@next``, ...: the
   study's criterion function, restricted to the plan's drop, as a study that adds the drop
   would have it), compared on the study's grid (``output_dt``) with the record interpolated
   onto it; its limit is the study's noise floor
   (:func:`vectorid.identify.noise.floor.noise_floor`, the same function the study's
   ``limits = "noise"`` uses, on a drop built from the plan: its sample times, its fitted
   start, the study's reference vector, discrepancy allowances and draws) at one quantile
   for every noise-limited criterion — the study's own on its drops and the plan's — chosen
   so that all hold together in the study's ``noise_coverage`` (95 %), or at its
   ``noise_quantile``.
3. **Let each member play the truth**: its record plus one seeded draw of the stated noise
   (Gauss–Markov where stated) are the data; the start is fitted to them as the study would,
   which moves every member's simulation by J·δ (δ: the fitted start minus the reference
   fit; J: d(outputs)/d(initial state) by the study's central differences at the reference
   member); the members whose criteria all meet their limits against those data are those
   flying the plan would keep. The **expected fraction kept** is the weighted share of D's
   members kept, averaged over the members as truths; its **interval** the 2.5–97.5 % range
   of that average over a seeded two-way bootstrap of the members flown, resampled both as
   the truths and as the members judged (Owen's bootstrap of a crossed table). A plan
   without information keeps about 95 %; one that would cut D keeps less. Plans are ranked
   by it, smallest first (rank 1: the most informative) — except that a plan under which
   the truth itself meets the limits in fewer than half of its records (``truth_kept``; a
   sound plan: about 95 %) would reject the truth, not inform: its data cannot fix what the
   study fits, flying it would likely empty D, and it is ranked after every sound plan and
   said so.
4. **Newly identified**: per truth, the kept members' range of each gain (and of each of D's
   combinations, :mod:`vectorid.analysis.combinations`, with its margin) is judged by the
   verdict rules (width at most 25 % of the box, off its edges, at least max(10, 2p + 1)
   members kept); a gain or combination that is not identified now and would be in at least
   half the truths (weighted) is listed. Ranges are over the members flown, the same ones for
   "now" and "with the plan", so fewer members do not read as narrower. A truth under which
   the plan keeps fewer members than that cannot show which gains it identifies: none counts
   as identified there, and ``thin_share`` says how often it happened (more members resolve it).

What it leaves out: the plan is judged in its stated wind only (a study with
``wind_realisations`` > 1 would average its criteria over perturbed winds); the study's own
criteria on its drops keep their limits (adding the plan's criteria loosens them slightly
under the joint coverage, which could let a few trials outside D in; the share is of D);
window variables do not move the plan's window; the start's error is linearised around the
reference fit. Flying the plans on twins and identifying again with both drops
(``scripts/design_twins.py``, figures in docs/identification.md) is the check.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vectorid.analysis import Analysis
from vectorid.analysis.combinations import identifiable_combinations, widened_range
from vectorid.analysis.identifiability import identifiability, thin_threshold
from vectorid.errors import StudyDefinitionError
from vectorid.identify.criteria import CriterionError, get_criterion
from vectorid.identify.drops import Drop, fit_initial_state
from vectorid.identify.flight import FlightChannel, FlightData
from vectorid.identify.identification import IdentCriterion, Identification, sim_channel
from vectorid.identify.noise.floor import (
    NoiseFloor,
    _interp_matrix,
    _jacobian,
    _state_vector,
    noise_floor,
)
from vectorid.identify.noise.resolve import _drop_discrepancy, _drop_noise, _reference
from vectorid.identify.noise.statements import parse_discrepancy
from vectorid.identify.planned import PREDICTED_CHANNELS, DropToPredict
from vectorid.identify.predictor import _FIT_CHANNELS, BATCH, Predictor
from vectorid.study import Study
from vectorid.workflows.predict import Members, members_of

__all__ = [
    "ADEQUACY_NOTE",
    "COVERAGE",
    "NO_SHRINK",
    "TRUTH_KEPT_MIN",
    "Candidate",
    "Design",
    "design",
]

#: Joint coverage of the plan's noise-grounded limits: the truth meets them in this share.
COVERAGE = 0.95
#: A plan whose expected kept share is at least this does not shrink D (a plan without
#: information keeps about COVERAGE of it).
NO_SHRINK = 0.9
#: Noise draws that set each plan's limits.
LIMIT_DRAWS = 400
#: What every estimate assumes, said with every ranking: measured on the parafoil demo's twin
#: (``vectorid demo parafoil --next-drop``), the spiral ranked first kept 9.6 % of D by the
#: estimate and none when flown with the generator's truth, whose payload joint the model lacks.
ADEQUACY_NOTE = (
    "every estimate assumes the model is as adequate on the plan as on the drops it was "
    "identified from: a plan's limits carry the study's discrepancy allowance, and each member "
    "playing the truth is the model itself, so what the model lacks on a new manoeuvre (a mode "
    "the plan excites and the drops did not) cannot show here; flown, such a plan can keep less "
    "of D, or none. Check the allowance on twins of the plan from a richer model before flying"
)
#: Bootstrap resamples (truths and members) for the interval.
BOOTSTRAP = 1000
#: The plan's noise floor draws with the study's ``noise_seed`` plus this (independent of
#: the draws of the study's own drops, as a second drop's noise is).
FLOOR_SEED_OFFSET = 7919
#: A plan under which the truth itself meets the limits in less than this share of its
#: records (instead of about the coverage, 95 %) would reject the truth: its data cannot fix
#: what the study fits (its initial state), so it is ranked after every sound plan.
TRUTH_KEPT_MIN = 0.5


@dataclass
class Candidate:
    """One plan's worth.

    Attributes
    ----------
    name : str
        The plan (its drop file's stem).
    file : str
    drops : list of str
        Its drops' names.
    channels : list of str
        ``drop.channel`` judged, with their noise.
    expected_fraction_kept : float
        Expected share of D's members (weighted) still meeting the limits with its data.
    interval : (float, float)
        2.5–97.5 % bootstrap interval of that expectation.
    rank : int
        1: the most informative (smallest share kept).
    newly_identified : list of str
        Gains, then combinations (their text), that would become identified.
    identified_share : dict of str to float
        Gain -> weighted share of the truths under which it would be identified.
    combinations : list of dict
        Each of D's not-yet-identified combinations that would become identified: its
        loadings and share of truths.
    failed : int
        Members that failed to fly the plan (left out).
    thin_share : float
        Weighted share of the truths under which the plan keeps fewer than max(10, 2p + 1)
        of the flown members: too few to show which gains it identifies (never counted as
        identified); more members (``members=``) resolve them.
    notes : list of str
        What the judgement could not do as a study would (a start taken as known, a window
        cut where a member lands, a criterion left out for want of noise).
    n_flown : int
        Members that flew every drop of the plan (the truths).
    criteria : dict
        The plan's criteria (``use@drop``) -> ``{"limit", "unit", "from"}``: the limit the
        study would set, its unit, the study criterion it comes from.
    limit_rule : str
        How the limits were set (the joint coverage over how many criteria, or the quantile).
    truth_kept : float
        Weighted share of the truths kept under their own records (about the coverage, 95 %,
        for a sound plan; see :attr:`rejects_truth`).
    """

    name: str
    file: str
    drops: list[str]
    channels: list[str]
    expected_fraction_kept: float
    interval: tuple[float, float]
    rank: int = 0
    newly_identified: list[str] = field(default_factory=list)
    identified_share: dict[str, float] = field(default_factory=dict)
    combinations: list[dict[str, Any]] = field(default_factory=list)
    failed: int = 0
    thin_share: float = 0.0
    notes: list[str] = field(default_factory=list)
    n_flown: int = 0
    criteria: dict[str, dict[str, Any]] = field(default_factory=dict)
    limit_rule: str = ""
    truth_kept: float = float("nan")

    @property
    def below_resolution(self) -> bool:
        """The plan keeps about one of the members flown (the truth itself): the members
        cannot show how much less it would keep; plans below it are not ranked apart."""
        return (
            self.n_flown > 0
            and not self.rejects_truth
            and self.expected_fraction_kept <= 2.0 / self.n_flown
        )

    @property
    def rejects_truth(self) -> bool:
        """Whether the truth itself would fail the limits in most of its records
        (:data:`TRUTH_KEPT_MIN`): flying it would likely empty D, which is no information."""
        return self.truth_kept < TRUTH_KEPT_MIN

    @property
    def shrinks(self) -> bool:
        """Whether the plan would cut D (expected share kept below :data:`NO_SHRINK`)."""
        return self.expected_fraction_kept < NO_SHRINK

    def to_dict(self) -> dict[str, Any]:
        """This plan as one entry of ``vectorid design --json``'s ``candidates``."""
        return {
            "name": self.name,
            "rank": int(self.rank),
            "expected_fraction_kept": float(self.expected_fraction_kept),
            "interval": [float(self.interval[0]), float(self.interval[1])],
            "newly_identified": list(self.newly_identified),
            "shrinks": bool(self.shrinks),
            "file": self.file,
            "drops": list(self.drops),
            "channels": list(self.channels),
            "identified_share": {k: float(v) for k, v in self.identified_share.items()},
            "combinations": list(self.combinations),
            "failed": int(self.failed),
            "thin_share": float(self.thin_share),
            "notes": list(self.notes),
            "n_flown": int(self.n_flown),
            "below_resolution": bool(self.below_resolution),
            "criteria": {k: dict(v) for k, v in self.criteria.items()},
            "limit_rule": self.limit_rule,
            "truth_kept": float(self.truth_kept),
            "rejects_truth": bool(self.rejects_truth),
        }


@dataclass
class Design:
    """The plans' worth, ranked (see the module docstring).

    Attributes
    ----------
    store : str
        The store's path.
    members : Members
        D's members flown (how chosen, from which set).
    candidates : list of Candidate
        One per plan, in the order given (``rank`` orders them).
    identified_now : list of str
        Gains identified before any plan.
    combinations_now : int
        Combinations identified before any plan.
    seed : int
    """

    store: str
    members: Members
    candidates: list[Candidate]
    identified_now: list[str]
    combinations_now: int
    seed: int

    @property
    def none_shrinks(self) -> bool:
        """No sound plan would cut D."""
        return not any(c.shrinks and not c.rejects_truth for c in self.candidates)

    def to_dict(self) -> dict[str, Any]:
        """The ``vectorid design --json`` document."""
        return {
            "store": self.store,
            "members": self.members.to_dict(),
            "coverage": COVERAGE,
            "no_shrink_above": NO_SHRINK,
            "none_shrinks": self.none_shrinks,
            "none_keeps_truth": all(c.rejects_truth for c in self.candidates),
            "identified_now": list(self.identified_now),
            "combinations_identified_now": int(self.combinations_now),
            "seed": int(self.seed),
            "assumes": ADEQUACY_NOTE,
            "candidates": [c.to_dict() for c in sorted(self.candidates, key=lambda c: c.rank)],
        }

    def describe(self) -> str:
        """The plans for people: ranked, each with its expected share of D kept, its interval
        and what it would identify; a plain sentence when none would cut D."""
        m = self.members
        lines = [
            f"store {self.store}: {m.source}, {m.n_set} members; flown: {m.chosen}",
            f"identified now: {', '.join(self.identified_now) or 'no gain'}; "
            f"{self.combinations_now} combination(s) identified",
            "each plan judged as flying it would be: each member of D playing the truth in turn, "
            "its noisy record of the plan judged by the study's own criteria (those that read "
            "the plan's sensors) against the noise-floor limits the study would set for them, "
            "the initial state fitted to the record's first seconds:",
            "",
        ]
        for c in sorted(self.candidates, key=lambda c: c.rank):
            lo, hi = c.interval
            lines.append(
                f"{c.rank}. {c.name} ({', '.join(c.drops)}): keeps {c.expected_fraction_kept:.1%} "
                f"of D (95 % interval {lo:.1%}–{hi:.1%})"
                + (
                    " — would reject the truth"
                    if c.rejects_truth
                    else ("" if c.shrinks else " — would not shrink D")
                )
            )
            crit = ", ".join(
                f"{k} <= {v['limit']:.4g}" + (f" {v['unit']}" if v["unit"] else "")
                for k, v in c.criteria.items()
            )
            lines.append(f"   judged by {crit} ({c.limit_rule})")
            lines.append(
                f"   the truth itself meets them in {c.truth_kept:.0%} of its records"
                + (
                    ": its data cannot fix what the study fits (the initial state: a sensor "
                    "is missing for part of it), so flying it would likely empty D — no "
                    "information; ranked last"
                    if c.rejects_truth
                    else ""
                )
            )
            if c.newly_identified:
                lines.append(f"   newly identified: {', '.join(c.newly_identified)}")
            else:
                lines.append("   newly identified: none")
            if c.thin_share > 0.05:
                lines.append(
                    f"   under {c.thin_share:.0%} of the truths it keeps too few of the flown "
                    "members to show which gains it identifies (those count as not identified): "
                    "fly more members (--members) to resolve them"
                )
            for note in c.notes:
                lines.append(f"   note: {note}")
            if c.failed:
                lines.append(f"   {c.failed} member(s) failed to fly it (left out)")
        lines.append("")
        lines.append(f"Read with care: {ADEQUACY_NOTE}.")
        low = [c.name for c in self.candidates if c.below_resolution]
        if len(low) > 1:
            lines.append(
                f"{', '.join(low)} keep about one of the members flown (the truth itself): the "
                "members cannot show which of them would keep less, so their order among "
                "themselves means nothing; fly more members (--members) or compare shorter plans."
            )
        if all(c.rejects_truth for c in self.candidates):
            lines.append(
                "No plan keeps the truth: under each, the truth itself fails the limits the "
                "study would set in most of its records, so flying any of them and identifying "
                "as the study does would most likely empty D, and what they keep says nothing "
                "about their worth. Give the plans the sensors that fix their start (an IMU for "
                "the attitude and rates, a GPS for the position), or grant the model a "
                "discrepancy allowance, before comparing them."
            )
        elif self.none_shrinks:
            lines.append(
                f"No plan would shrink D: with any that keeps the truth at least {NO_SHRINK:.0%} "
                "of D's "
                "members would still meet the limits (a plan without information keeps about "
                f"{COVERAGE:.0%}); its data would not tell D's members apart. Try another "
                "manoeuvre, a longer drop, or a sensor that sees what D's members disagree on."
            )
        else:
            best = min(self.candidates, key=lambda c: c.rank)
            if best.below_resolution and len(low) > 1:
                lines.append(f"Most informative: one of {', '.join(low)} (see above).")
            else:
                lines.append(
                    f"Most informative: {best.name} (keeps {best.expected_fraction_kept:.1%} of D)."
                )
        return "\n".join(lines)


# -- one plan ---------------------------------------------------------------------------------


@dataclass
class _PlanCriterion:
    """One study criterion as the plan's drop would add it: ``name`` (``use@drop``), the
    library criterion it uses, and its channel."""

    name: str
    use: str
    operator: str | None
    channel: str
    unit: str


def _study_criteria(spec: Any) -> list[tuple[str, str, str | None]]:
    """The study's criteria as (study name, library name, operator), read as
    :meth:`Identification.from_table` reads them."""
    table = spec.extra.get("identification") or {}
    ctab = table.get("criteria") or {}
    out = []
    for name in spec.criterion_names:
        t = ctab.get(name) or {}
        out.append((name, str(t.get("use", name)), t.get("operator")))
    return out


def _channels_read(spec: Any) -> set[str]:
    """The channels the study's library criteria read."""
    out = set()
    for _, use, op in _study_criteria(spec):
        try:
            out.add(get_criterion(use if op is None else f"{use}:{op}").channel)
        except CriterionError:  # not a library criterion (a Python-function study's own)
            continue
    return out


def _plan_criteria(
    spec: Any, drop: DropToPredict, channels: Sequence[str]
) -> tuple[list[_PlanCriterion], dict[str, str], list[str]]:
    """The criteria the plan's drop would be identified with: each library criterion the
    study uses whose channel the plan carries, every component of it with a stated noise;
    the study criterion each comes from; notes on those left out."""
    out: list[_PlanCriterion] = []
    source: dict[str, str] = {}
    notes: list[str] = []
    seen = set()
    for sname, use, op in _study_criteria(spec):
        key = use if op is None else f"{use}:{op}"
        if key in seen:
            continue
        try:
            cdef = get_criterion(key)
        except CriterionError:
            continue
        if cdef.channel not in channels:
            continue
        seen.add(key)
        m = len(PREDICTED_CHANNELS.get(cdef.channel, ((cdef.channel,), ""))[0])
        if drop.noise is None or any(drop.noise.component(cdef.channel, j) is None
                                     for j in range(m)):  # fmt: skip
            notes.append(
                f"{drop.name}: {key} left out (no noise stated for every component of "
                f"{cdef.channel})"
            )
            continue
        name = f"{key}@{drop.name}"
        out.append(_PlanCriterion(name, use, op, cdef.channel, cdef.unit))
        source[name] = sname
    return out, source, notes


class _PlanDrop:
    """One planned drop judged as flying it would be: D's members flown over it, its
    criteria (the study's, restricted to it) and their noise floor (the study's own
    :func:`~vectorid.identify.noise.floor.noise_floor` on a drop built from the plan), and,
    per member playing the truth, its noisy data, the initial state fitted to them and every
    member's criteria against them."""

    def __init__(
        self,
        predictor: Predictor,
        spec: Any,
        members: Members,
        drop: DropToPredict,
        seed: int,
        settings: Mapping[str, Any],
    ) -> None:
        self.drop = drop
        self.notes: list[str] = []
        dt, odt = predictor.dt, predictor.output_dt
        chans = predictor.channel_names(drop)
        self.criteria, self.source, notes = _plan_criteria(spec, drop, chans)
        self.notes += notes
        if not self.criteria:
            used = sorted(_channels_read(spec)) or ["no library channel"]
            raise StudyDefinitionError(
                f"{drop.name}.channels",
                f"the plan carries {', '.join(chans) or 'no channel'}, and no criterion of the "
                f"study reads one of them with a stated noise (the study's criteria read "
                f"{', '.join(used)}), so nothing would judge its data",
                f"add a channel the study's criteria read ({', '.join(used)}) with its noise",
            )
        # fly the members on a step that holds the comparison grid and every sensor's samples
        o_stride = round(odt / dt)
        strides = {c: round(1.0 / (drop.channels[c] * dt)) for c in chans}
        step_n = int(np.gcd.reduce(np.array([o_stride, *strides.values()], dtype=np.int64)))
        step = step_n * dt
        n_out = int(np.floor(drop.duration / step + 1e-9))
        if n_out * step < 2 * odt:
            raise StudyDefinitionError(
                f"{drop.name}.duration",
                f"{drop.duration:g} s is shorter than two comparison steps of {odt:g} s",
                "give a longer duration",
            )
        rng = np.random.default_rng([seed, 17])
        P = predictor.parameters(members.X, drop, rng)
        t = np.arange(n_out + 1) * step
        width = {c: len(predictor._describe(c, drop)[0]) for c in chans}

        def fly(initial: Any) -> tuple[dict[str, NDArray], NDArray, NDArray]:
            m = P.shape[0]
            full = {c: np.full((m, t.size, width[c]), np.nan) for c in chans}
            pos = np.full((m, t.size, 3), np.nan)
            ok = np.zeros(m, dtype=bool)
            for s in range(0, m, BATCH):
                res = predictor.model.simulate(
                    P[s : s + BATCH], t_final=n_out * step, dt=dt, inputs=drop.inputs,
                    wind=drop.wind, output_dt=step, initial=initial,
                    atmosphere=predictor.atmosphere,
                )  # fmt: skip
                good = res.ok
                rows = np.arange(s, s + good.size)[good]
                ok[s : s + good.size] = good
                pos[rows] = sim_channel(res, "position", drop.origin_altitude)[good]
                for c in chans:
                    full[c][rows] = sim_channel(res, c, drop.origin_altitude)[good]
            return full, pos, ok

        full, pos, ok = fly(drop.initial)  # what each member would record as the truth
        if not ok.any():
            raise StudyDefinitionError(
                drop.name,
                "no member of D could fly this planned drop",
                "check its initial state, wind and inputs against the study's drops",
            )
        # the window ends where the first member lands (a drop's data end at the ground)
        end = n_out * step
        if drop.ground_altitude is not None:
            h = -pos[ok, :, 2] - (drop.ground_altitude - drop.origin_altitude)
            below = (h <= 0).any(axis=0)
            below[0] = False
            if below.any():
                end = float(t[int(np.argmax(below)) - 1])
                self.notes.append(
                    f"{drop.name}: judged over its first {end:g} s (a member lands then)"
                )
        for c in chans:  # every grid point between two of the channel's samples
            end = min(end, float(t[:: strides[c] // step_n][-1]))
        T_grid = int(np.floor(end / odt + 1e-9))
        if T_grid < 2:
            raise StudyDefinitionError(
                f"{drop.name}.duration",
                f"only {end:g} s of it can be compared (fewer than two steps of {odt:g} s)",
                "give a longer duration, a higher start, or faster sensors",
            )
        self.T = T_grid * odt
        self.grid = np.arange(T_grid + 1) * odt
        g_idx = np.arange(T_grid + 1) * (o_stride // step_n)
        self.times, self.samples, self.comps, self.W = {}, {}, {}, {}
        for c in chans:
            k = np.arange(0, t.size, strides[c] // step_n)
            self.times[c] = t[k]
            self.samples[c] = full[c][:, k]  # members at the sensor's samples
            self.comps[c] = predictor._describe(c, drop)
            self.W[c] = _interp_matrix(self.grid, t[k])
        # the member nearest the members' weighted mean (box-scaled): its samples stand for
        # the data of the drop built for the noise floor, and the state Jacobian is its
        X = members.X
        span = np.ptp(X, axis=0)
        span = np.where(span > 0, span, 1.0)
        w = np.where(ok, members.weights, 0.0)
        mean = (w / w.sum()) @ X
        ref = int(np.argmin(np.where(ok, np.sum(((X - mean) / span) ** 2, axis=1), np.inf)))
        self.fit_chans = [c for c in chans if c in _FIT_CHANNELS]
        self.span = float(predictor.init_span)
        if "position" in chans or "altitude" in chans:
            # the study simulates from the state fitted to the data's first seconds, and sets
            # its noise floor around it: the fit of the reference member's own record (what
            # the sensors cannot see, e.g. the rates without a gyro, it cannot fit)
            start = self._fit({c: self.samples[c][ref] for c in self.fit_chans})
            moved = not np.allclose(_state_vector(start), _state_vector(drop.initial))
            model_full, _, ok2 = fly(start) if moved else (full, pos, ok)
            ok = ok & ok2
        else:
            self.notes.append(
                f"{drop.name}: no position or altitude sensor, so its initial state cannot be "
                "fitted to its data: taken as known"
            )
            start, model_full = drop.initial, full
        self.ok = ok
        self.sim = {c: model_full[c][:, g_idx] for c in chans}  # members as models, on the grid
        flight = FlightData(
            drop.name,
            {
                c: FlightChannel(c, self.times[c], self.samples[c][ref], *self.comps[c])
                for c in chans
            },
        )
        self.study_drop = Drop(
            drop.name, flight, 0.0, self.T, self.T, drop.wind, 1.0, drop.inputs,
            start, drop.origin_altitude, self.grid, init_span=self.span,
        )  # fmt: skip
        self.ident = Identification(
            predictor.model, [self.study_drop], [],
            [IdentCriterion(c.name, c.use, (drop.name,), c.operator) for c in self.criteria],
            dt=dt, output_dt=odt, atmosphere=predictor.atmosphere,
        )  # fmt: skip
        disc = settings["discrepancy"]
        self.floor = noise_floor(
            self.ident,
            {drop.name: drop.noise},
            draws=int(settings["draws"]),
            seed=int(settings["seed"]) + FLOOR_SEED_OFFSET,
            params=settings["reference"](drop),
            discrepancy={
                "channels": disc["channels"],
                "criteria": {
                    n: disc["criteria"][s] for n, s in self.source.items() if s in disc["criteria"]
                },
            },
        )
        fits = "position" in chans or "altitude" in chans
        self.J = _jacobian(self.ident, P[ref], self.study_drop, drop.wind, chans) if fits else None
        self.zero = _state_vector(start)

    def _fit(self, values: Mapping[str, NDArray]) -> Any:
        """The study's initial-state fit (:func:`~vectorid.identify.drops.fit_initial_state`)
        to a record's first seconds: ``values[channel]`` at the channel's sample times."""
        reach = max(self.span, 3.0) + 1e-9
        chans = {}
        for c in self.fit_chans:
            sel = self.times[c] <= reach
            chans[c] = FlightChannel(c, self.times[c][sel], values[c][sel], *self.comps[c])
        d = self.drop
        return fit_initial_state(
            FlightData("plan", chans), 0.0, self.span, d.origin_altitude, d.wind, d.name
        )

    def kept(self, limits: Mapping[str, float], rng: np.random.Generator) -> NDArray:
        """(m, m) bool: row t, the members that meet every limit of this drop's criteria when
        member t plays the truth (its outputs plus one seeded noise draw are the data)."""
        m = self.ok.size
        K = np.zeros((m, m), dtype=bool)
        noise = self.drop.noise
        data = {}
        for c, Y in self.samples.items():
            E = np.zeros_like(Y)
            for j in range(Y.shape[2]):
                cn = None if noise is None else noise.component(c, j)
                if cn is not None:
                    E[:, :, j] = cn.draw(self.times[c], m, rng)
            data[c] = Y + E
        L = np.array([limits[c.name] for c in self.criteria])
        fns = [get_criterion(c.use if c.operator is None else f"{c.use}:{c.operator}").fn
               for c in self.criteria]  # fmt: skip
        # spectral criteria (a Welch estimate per member) after the others
        order = sorted(range(len(fns)), key=lambda k: self.criteria[k].use.startswith("peak_"))
        rows = np.flatnonzero(self.ok)
        # the members as models (the same for every truth) and every record on the grid at
        # once: one product per channel instead of one per truth
        base = {c: v[rows] for c, v in self.sim.items()}
        on_grid = {}
        for c in self.sim:
            Y = data[c]
            G = self.W[c] @ np.moveaxis(Y, 1, 0).reshape(Y.shape[1], -1)
            on_grid[c] = np.moveaxis(G.reshape(G.shape[0], m, *Y.shape[2:]), 0, 1)
        for i in rows:
            # the start the study would fit to this record moves every member alike
            # (linearised: the state Jacobian)
            shift = {}
            if self.J is not None:
                delta = (
                    _state_vector(self._fit({c: data[c][i] for c in self.fit_chans})) - self.zero
                )
                shift = {c: np.einsum("s,stk->tk", delta, self.J[c]) for c in base}
            meas = {c: on_grid[c][i] for c in self.sim}
            # criterion by criterion, each on the members that still meet every limit so far
            # (a criterion of one member reads only that member): the cheap ones first
            alive = np.arange(rows.size)
            for k in order:
                c = self.criteria[k]
                sim = base[c.channel][alive]
                if c.channel in shift:
                    sim = sim + shift[c.channel]
                v = fns[k](sim, meas[c.channel], self.grid)
                alive = alive[np.asarray(v) <= L[k]]
                if not alive.size:
                    break
            K[i, rows[alive]] = True
        return K


def kept_interval(
    K: NDArray, p: NDArray, rng: np.random.Generator, draws: int = BOOTSTRAP
) -> tuple[float, float]:
    """2.5–97.5 % bootstrap interval of the expected share kept, from ``K`` (n, n) bool (row:
    the member playing the truth, column: the member judged) and the members' probabilities
    ``p`` (n,). The members flown are a sample of D twice over, as the truths and as the
    members judged, so both are resampled (a two-way, "pigeonhole" bootstrap of the crossed
    table, Owen 2007); resampling the truths alone leaves out how the share depends on which
    members were drawn."""
    n = K.shape[0]
    rows = rng.choice(n, size=(draws, n), p=p)
    cols = rng.choice(n, size=(draws, n), p=p)
    means = np.array([K[r][:, c].mean() for r, c in zip(rows, cols, strict=True)])
    return float(np.quantile(means, 0.025)), float(np.quantile(means, 0.975))


def _limits_for(
    plan: Sequence[_PlanDrop], study: Any, settings: Mapping[str, Any]
) -> tuple[dict[str, float], str]:
    """The plan's criteria's limits by the study's rule: one per-criterion quantile of the
    noise floors at which every noise-limited criterion — the study's own and the plan's —
    holds together in the study's coverage (``noise_coverage``, 95 %), or the study's
    ``noise_quantile``; plus each criterion's allowance. The study's floor (``study``) is
    that of its own drops (None: the study limits none of its criteria by the noise)."""
    names, units, cols, allow = [], [], [], {}
    if study is not None:
        names += list(study.names)
        units += list(study.units)
        cols.append(study.samples)
        allow.update(study.allowance)
    for p in plan:
        names += list(p.floor.names)
        units += list(p.floor.units)
        cols.append(p.floor.samples)
        allow.update(p.floor.allowance)
    floor = NoiseFloor(names, units, np.hstack(cols), allow, {}, cols[0].shape[0], 0, {})
    q = settings["quantile"]
    lim = floor.limits(names, quantile=q, coverage=float(settings["coverage"]))
    how = (
        f"q={q:g}" if q is not None
        else f"joint {float(settings['coverage']):.0%} over {len(names)} criteria"
    )  # fmt: skip
    return {n: v for n, (v, _) in lim.items()}, how


def _judge_widths(
    lo: NDArray, hi: NDArray, box: tuple[NDArray, NDArray], n: NDArray, need: int, thr: float
) -> NDArray:
    """(T, q) bool: identified by a gain's rules (width <= thr of the box, off its edges by
    2 %, at least ``need`` members)."""
    b0, b1 = box
    W = b1 - b0
    width = (hi - lo) / W
    off = (lo - b0 > 0.02 * W) & (b1 - hi > 0.02 * W)
    return (width <= thr) & off & (n[:, None] >= need)


def _candidate(
    file: str,
    drops: Sequence[DropToPredict],
    predictor: Predictor,
    members: Members,
    a: Analysis,
    now: set[str],
    combos: Sequence[Any],
    seed: int,
    identified: float,
    settings: Mapping[str, Any],
    study_floor: Any,
) -> Candidate:
    rng = np.random.default_rng([seed, 34])
    plan = [_PlanDrop(predictor, a.spec, members, d, seed, settings) for d in drops]
    L, how = _limits_for(plan, study_floor, settings)
    ok = np.logical_and.reduce([p.ok for p in plan])
    if not ok.any():
        raise StudyDefinitionError(
            Path(file).name,
            "no member of D could fly every drop of this plan "
            f"({', '.join(d.name for d in drops)})",
            "check its initial state, wind and inputs against the study's drops",
        )
    K = np.ones((ok.size, ok.size), dtype=bool)
    for p in plan:
        K &= p.kept(L, rng)
    K[:, ~ok] = False
    K[~ok, :] = False
    w = np.where(ok, members.weights, 0.0)
    w = w / w.sum()
    frac = K.astype(float) @ w  # per truth: the weighted share kept
    truths = np.flatnonzero(ok)
    expected = float(w[truths] @ frac[truths])
    boot_rng = np.random.default_rng([seed, 35])
    pw = w[truths] / w[truths].sum()
    interval = kept_interval(K[np.ix_(truths, truths)], pw, boot_rng)
    truth_kept = float(pw @ np.diag(K)[truths])
    # what the kept members would identify
    X = members.X
    space = a.spec.space
    need = thin_threshold(len(space))
    box = (np.array([float(v.low) for v in space]), np.array([float(v.high) for v in space]))
    lo = np.full((truths.size, X.shape[1]), np.nan)
    hi = lo.copy()
    nk = np.zeros(truths.size)
    for r, i in enumerate(truths):
        sel = K[i]
        nk[r] = sel.sum()
        if sel.any():
            lo[r], hi[r] = X[sel].min(axis=0), X[sel].max(axis=0)
    ident = _judge_widths(lo, hi, box, nk, need, identified)
    share = pw @ ident
    names = list(space.names)
    shares = {n: float(s) for n, s in zip(names, share)}
    new = [n for n, s in zip(names, share) if n not in now and s >= 0.5]
    new_combos = []
    if combos:
        Z = (X - box[0]) / (box[1] - box[0])
        for c in combos:
            u = np.array([c.loadings.get(n, 0.0) for n in names])
            t = Z @ u
            hits = np.zeros(truths.size, dtype=bool)
            for r, i in enumerate(truths):
                sel = K[i]
                if sel.sum() < need:
                    continue
                (rlo, rhi), _ = widened_range(
                    t[sel], w[sel] + 1e-300, p=len(names), extent=c.box_extent
                )
                ew = c.box_extent[1] - c.box_extent[0]
                off = rlo - c.box_extent[0] > 0.02 * ew and c.box_extent[1] - rhi > 0.02 * ew
                hits[r] = (rhi - rlo) <= identified and off
            s = float(pw @ hits)
            if s >= 0.5:
                new_combos.append({"loadings": dict(c.loadings), "text": c.text(), "share": s})
    crit = {}
    for p in plan:
        for c in p.criteria:
            crit[c.name] = {"limit": float(L[c.name]), "unit": c.unit,
                            "from": p.source[c.name]}  # fmt: skip
    return Candidate(
        name=Path(file).stem,
        file=str(file),
        drops=[d.name for d in drops],
        channels=[f"{p.drop.name}.{c}" for p in plan for c in p.sim],
        expected_fraction_kept=expected,
        interval=interval,
        newly_identified=new + [f"combination {c['text']}" for c in new_combos],
        identified_share=shares,
        combinations=new_combos,
        failed=int((~ok).sum()),
        thin_share=float(pw @ (nk < need)),
        notes=[n for p in plan for n in p.notes],
        n_flown=int(ok.sum()),
        criteria=crit,
        limit_rule=how,
        truth_kept=truth_kept,
    )


def _rank(cands: Sequence[Candidate]) -> None:
    """Set each plan's rank: the sound plans first, the one that keeps the least of D first
    (more newly identified breaks a tie), then the plans that would reject the truth."""
    order = sorted(
        cands, key=lambda c: (c.rejects_truth, c.expected_fraction_kept, -len(c.newly_identified))
    )
    for k, c in enumerate(order, 1):
        c.rank = k


def _settings(spec: Any, predictor: Predictor) -> dict[str, Any]:
    """The study's noise-limit rule (coverage, quantile, draws, seed, discrepancy) and its
    reference vector (nominal values, else the middle of the box), as the study's own noise
    limits use them."""
    table = spec.extra.get("identification") or {}
    ref = np.array(
        [
            float(v.nominal) if getattr(v, "nominal", None) is not None
            else 0.5 * (float(v.low) + float(v.high))
            for v in spec.space
        ]
    )  # fmt: skip
    return {
        "coverage": float(table.get("noise_coverage", COVERAGE)),
        "quantile": table.get("noise_quantile"),
        "draws": int(table.get("noise_draws", 2000)),
        "seed": int(table.get("noise_seed", 0)),
        "discrepancy": parse_discrepancy(table.get("discrepancy"), spec.criterion_names),
        "reference": lambda d: predictor.parameters(ref[None, :], d, np.random.default_rng(0))[0],
    }


def _study_floor(spec: Any, settings: Mapping[str, Any]) -> tuple[Any, str]:
    """The noise floor of the study's own noise-limited criteria on its own drops (as the
    study computed their limits), or None when it limits none by the noise; and a note when
    it cannot be rebuilt (its data files moved)."""
    targets = [c.name for c in spec.criteria if c.limit_source == "noise"]
    if not targets:
        return None, ""
    try:
        ident = Identification.from_spec(spec)
        noise = _drop_noise(spec, ident, (spec.extra.get("identification") or {}).get("noise"))
        floor = noise_floor(
            ident, noise, draws=int(settings["draws"]), seed=int(settings["seed"]),
            params=_reference(spec, ident, None),
            discrepancy=_drop_discrepancy(spec, (spec.extra["identification"]).get("discrepancy")),
            criteria=targets,
        )  # fmt: skip
    except (StudyDefinitionError, OSError) as exc:
        return None, (
            f"the study's own noise floors could not be rebuilt ({exc}): the plan's limits "
            "hold their coverage over the plan's criteria alone (a little tighter than the "
            "study would set them)"
        )
    cols = [floor.names.index(n) for n in targets]
    floor.names = targets
    floor.units = [floor.units[j] for j in cols]
    floor.samples = floor.samples[:, cols]
    return floor, ""


def design(
    store: str | Path | Study,
    plans: Iterable[str | Path] | str | Path,
    *,
    members: int | None = 400,
    seed: int = 0,
    limits: Any = None,
    identified: float = 0.25,
) -> Design:
    """Rank planned drops by how much of D their data would keep (module docstring).

    Parameters
    ----------
    store : path or Study
        An identification study's store (only read).
    plans : path or iterable of paths
        Drop files (TOML) of planned drops, one plan per file.
    members : int, optional
        Members of D flown, chosen keeping the weights (default 400; None: all). Cost grows
        with its square (each member plays the truth against every other).
    seed : int
        Seed of the members' choice, the noise draws and the bootstrap.
    limits : optional
        Bounds overriding the study's (D under them).
    identified : float
        The identified threshold on width / box width (a gain's and a combination's).

    Returns
    -------
    Design

    Raises
    ------
    StudyDefinitionError
        A bad plan (unknown channel, zero duration, no noise stated), a store that identifies
        no flight model, an empty D (:class:`~vectorid.workflows.predict.EmptySetError`).
    """
    if isinstance(plans, str | Path):
        plans = [plans]
    plans = list(plans)
    if not plans:
        raise StudyDefinitionError("plans", "no plan given", "give one or more drop files")
    own = not isinstance(store, Study)
    if own and not Path(store).exists():
        raise StudyDefinitionError(
            str(store), "no store there", "run a study first (vectorid run STUDY.toml)"
        )
    st = Study.open(store) if own else store
    try:
        predictor = Predictor.from_spec(st.spec)
        parsed = []
        for p in plans:
            drops = predictor.read_drops(p)
            bad = [d.name for d in drops if d.kind != "planned"]
            if bad:
                raise StudyDefinitionError(
                    f"{Path(p).name}: {bad[0]}",
                    "a drop with data files is no plan: its data are already known",
                    "identify with it (add it to the study's drops), or give initial = ... "
                    "and no file",
                )
            parsed.append((str(p), drops))
        a = st.analysis(limits)
        mem = members_of(st, members, seed, limits=limits, analysis=a)
        now = {v.name for v in identifiability(a) if v.verdict == "identified"}
        combos_all = identifiable_combinations(a, identified=identified, include_all=True)
        # single-gain directions are the gains' own verdicts: only true combinations here
        combos = [c for c in combos_all if not c.identified and len(c.loadings) > 1]
        settings = _settings(st.spec, predictor)
        floor, note = _study_floor(st.spec, settings)
        cands = [
            _candidate(f, drops, predictor, mem, a, now, combos, seed, identified, settings, floor)
            for f, drops in parsed
        ]
        if note:
            for c in cands:
                c.notes.append(note)
        _rank(cands)
        return Design(
            str(st.store.path),
            mem,
            cands,
            sorted(now),
            sum(c.identified for c in combos_all),
            int(seed),
        )
    finally:
        if own:
            st.close()
