"""The worth of a planned drop: how much of D its data would keep, before flying it.

:func:`design` is the one call (``vectorid design STORE PLAN.toml ...`` runs it)::

    from vectorid.workflows.design import design
    d = design("runs/g12.db", ["brake-steps.toml", "spiral.toml"], members=400, seed=0)
    print(d.describe())            # the same text as the command line
    d.to_dict()                    # the --json document

Each plan is a drop file of one or more planned drops (``[[identification.drops]]`` with
``initial``, ``duration``, ``channels = { name = Hz }``, the wind and the ``noise`` of its
sensors: :mod:`vectorid.identify.planned`, shared with ``vectorid predict``). For each plan:

1. **Fly D's members** over it (:func:`vectorid.workflows.predict.members_of` chooses them
   keeping the sampler's weights; :func:`~vectorid.workflows.predict.simulate_members` flies
   them, so the plan is read and flown exactly as ``vectorid predict`` does).
2. **Judge the plan's data as the study would**, with a noise-grounded limit: per drop and
   channel, the criterion is the mean square of the residual over its samples and components,
   each component scaled by its stated noise (σ, the total of its correlated and white parts),
   and its limit is that criterion's value under the noise alone at a joint coverage of 95 %
   over the plan's channels (seeded draws of the stated noise, Gauss–Markov where stated): the
   truth itself meets every limit in 95 % of records, as with ``limits = "noise"`` in a study.
   The noise acts twice, as it would once the drop is flown and identified: on the samples
   (ε), and through the initial state the study fits to the noisy first seconds
   (:func:`vectorid.identify.drops.fit_initial_state`), which moves every member's simulation
   by J·δ (δ: that fit's error under the same draw; J: d(outputs)/d(initial state) at the
   member nearest the members' mean, :meth:`~vectorid.identify.predictor.Predictor.
   state_jacobian`). A plan without a position or altitude sensor cannot have its start
   fitted to its own data: its initial state is then taken as known, and a note says so.
3. **Let each member play the truth**: its outputs plus one seeded draw of the noise are the
   data; the members that meet every limit against those data are those the plan would keep.
   The **expected fraction kept** is the weighted share of D's members kept, averaged over the
   members as truths (weighted: they stand for D's uniform density); its **interval** is the
   2.5–97.5 % range of that average over a seeded bootstrap of the truths (the Monte-Carlo
   uncertainty of the estimate from these members and draws). A plan whose data carry no
   information keeps about 95 % (every member meets the limits as often as the truth); a plan
   that would cut D keeps less. Plans are ranked by it, the smallest first (rank 1: the most
   informative).
4. **Newly identified**: per truth, the kept members' range of each gain (and of each of D's
   combinations, :mod:`vectorid.analysis.combinations`, with its margin) is judged by the
   verdict rules (width at most 25 % of the box, off its edges, at least max(10, 2p + 1)
   members kept); a gain or combination that is not identified now and would be in at least
   half the truths (weighted) is listed. Ranges are over the members flown, the same ones for
   "now" and "with the plan", so fewer members do not read as narrower. A truth under which
   the plan keeps fewer members than that cannot show which gains it identifies: none counts
   as identified there, and ``thin_share`` says how often it happened (more members resolve it).

What this does not do: it judges the plan's data by a criterion of its own (a mean square of
noise-scaled residuals), not by the study's criteria, and it does not re-identify. Flying the
plans on twins and identifying again (``scripts/design_twins.py``, figures in
docs/identification.md) is the check; it does not yet show the ranking right in 80 % of twins.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vectorid.analysis import Analysis
from vectorid.analysis.combinations import identifiable_combinations, widened_range
from vectorid.analysis.identifiability import identifiability, thin_threshold
from vectorid.errors import StudyDefinitionError
from vectorid.identify.drops import fit_initial_state
from vectorid.identify.flight import FlightChannel, FlightData
from vectorid.identify.noise.floor import _state_vector
from vectorid.identify.planned import DropToPredict
from vectorid.identify.predictor import _FIT_CHANNELS, Predictor
from vectorid.study import Study
from vectorid.workflows.predict import Members, _alive_after_landing, members_of, simulate_members

__all__ = ["COVERAGE", "NO_SHRINK", "Candidate", "Design", "design"]

#: Joint coverage of the plan's noise-grounded limits: the truth meets them in this share.
COVERAGE = 0.95
#: A plan whose expected kept share is at least this does not shrink D (a plan without
#: information keeps about COVERAGE of it).
NO_SHRINK = 0.9
#: Noise draws that set each plan's limits.
LIMIT_DRAWS = 400
#: Bootstrap resamples of the truths for the interval.
BOOTSTRAP = 1000


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

    @property
    def below_resolution(self) -> bool:
        """The plan keeps about one of the members flown (the truth itself): the members
        cannot show how much less it would keep; plans below it are not ranked apart."""
        return self.n_flown > 0 and self.expected_fraction_kept <= 2.0 / self.n_flown

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
        """No plan would cut D."""
        return not any(c.shrinks for c in self.candidates)

    def to_dict(self) -> dict[str, Any]:
        """The ``vectorid design --json`` document."""
        return {
            "store": self.store,
            "members": self.members.to_dict(),
            "coverage": COVERAGE,
            "no_shrink_above": NO_SHRINK,
            "none_shrinks": self.none_shrinks,
            "identified_now": list(self.identified_now),
            "combinations_identified_now": int(self.combinations_now),
            "seed": int(self.seed),
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
            "each plan's data judged with noise-grounded limits (the truth meets them in "
            f"{COVERAGE:.0%} of records), each member of D playing the truth in turn:",
            "",
        ]
        for c in sorted(self.candidates, key=lambda c: c.rank):
            lo, hi = c.interval
            lines.append(
                f"{c.rank}. {c.name} ({', '.join(c.drops)}): keeps {c.expected_fraction_kept:.1%} "
                f"of D (95 % interval {lo:.1%}–{hi:.1%})"
                + ("" if c.shrinks else " — would not shrink D")
            )
            lines.append(f"   judged on {', '.join(c.channels)}")
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
        low = [c.name for c in self.candidates if c.below_resolution]
        if len(low) > 1:
            lines.append(
                f"{', '.join(low)} keep about one of the members flown (the truth itself): the "
                "members cannot show which of them would keep less, so their order among "
                "themselves means nothing; fly more members (--members) or compare shorter plans."
            )
        if self.none_shrinks:
            lines.append(
                f"No plan would shrink D: with any of them at least {NO_SHRINK:.0%} of D's "
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


class _DropNoise:
    """What the noise does to one planned drop's residuals once it is flown and identified:
    the sensors' noise ε, and through the initial state the study fits to the noisy first
    seconds (:func:`vectorid.identify.drops.fit_initial_state`, the study's own fit) a
    member's simulation moved by J·δ (δ: the fit's error, J: d(outputs)/d(initial state) of
    the reference member, :meth:`Predictor.state_jacobian`). The residual a member shows
    against the data is then its difference from the truth minus (ε - J·δ)."""

    def __init__(
        self, predictor: Predictor, drop: DropToPredict, flown: Any, ref: int, p_ref: NDArray
    ) -> None:
        self.drop = drop
        self.comps = {
            c: [
                None if drop.noise is None else drop.noise.component(c, j)
                for j in range(Y.shape[2])
            ]
            for c, Y in flown.channels.items()
        }
        self.times = flown.times
        self.J: dict[str, NDArray] | None = None
        self.note = ""
        span = float(predictor.init_span)
        reach = max(span, 3.0)
        base: dict[str, FlightChannel] = {}
        for c, Y in flown.channels.items():
            if c not in _FIT_CHANNELS or not any(x is not None for x in self.comps[c]):
                continue
            t = flown.times[c]
            sel = t <= reach + 1e-9
            if sel.sum() >= 2 and np.isfinite(Y[ref][sel]).all():
                base[c] = FlightChannel(c, t[sel], Y[ref][sel], flown.components[c], flown.units[c])
        self.base = base
        if not ("position" in base or "altitude" in base):
            self.note = (
                f"{drop.name}: no position or altitude sensor, so its initial state cannot be "
                "fitted to its data: taken as known"
            )
            return
        self.span = span
        try:
            self.zero = self._fit(base)
        except (StudyDefinitionError, ValueError, np.linalg.LinAlgError) as exc:
            self.note = f"{drop.name}: its initial state cannot be fitted ({exc}): taken as known"
            return
        self.J = predictor.state_jacobian(p_ref, drop)

    def _fit(self, chans: dict[str, FlightChannel]) -> NDArray:
        d = self.drop
        s = fit_initial_state(
            FlightData("plan", chans), 0.0, self.span, d.origin_altitude, d.wind, d.name
        )
        return _state_vector(s)

    def draw(self, n: int, rng: np.random.Generator) -> dict[str, NDArray]:
        """``n`` draws of ε - J·δ per channel, (n, T, k) in the channel's unit (0 where a
        component has no stated noise)."""
        out = {}
        for c, comps in self.comps.items():
            t = self.times[c]
            E = np.zeros((n, t.size, len(comps)))
            for j, cn in enumerate(comps):
                if cn is not None:
                    E[:, :, j] = cn.draw(t, n, rng)
            out[c] = E
        if self.J is None:
            return out
        delta = np.empty((n, len(self.zero)))
        for r in range(n):
            chans = {}
            for c, b in self.base.items():
                k = b.t.size
                chans[c] = FlightChannel(c, b.t, b.values + out[c][r, :k], b.components, b.unit)
            delta[r] = self._fit(chans) - self.zero
        for c in out:
            if c in self.J:
                out[c] = out[c] - np.einsum("rs,stk->rtk", delta, self.J[c])
        return out


def _blocks(
    predictor: Predictor, members: Members, drops: Sequence[DropToPredict], seed: int
) -> tuple[list[tuple[str, NDArray, int, str, NDArray, NDArray]], NDArray, list[_DropNoise]]:
    """Per drop and channel with stated noise: (label, Y (m, T, k') in σ units, drop index,
    channel, kept components, their σ); the members that flew every drop; each drop's noise."""
    blocks = []
    noises = []
    ok = np.ones(len(members), dtype=bool)
    flowns = [simulate_members(predictor, members, d, seed) for d in drops]
    for f in flowns:
        ok &= f.ok
    if ok.any():  # the member nearest the members' weighted mean (box-scaled) is linearised
        X = members.X
        span = np.ptp(X, axis=0)
        span = np.where(span > 0, span, 1.0)
        w = np.where(ok, members.weights, 0.0)
        mean = (w / w.sum()) @ X
        ref = int(np.argmin(np.where(ok, np.sum(((X - mean) / span) ** 2, axis=1), np.inf)))
    for di, (d, flown) in enumerate(zip(drops, flowns)):
        landing = _alive_after_landing(flown, d)
        for name, Y in flown.channels.items():
            Y = np.array(Y, dtype=float)
            t = flown.times[name]
            if landing is not None:  # after landing a member says nothing more
                Y[t[None, :] > landing[:, None] + 1e-9] = np.nan
            comps = [
                None if d.noise is None else d.noise.component(name, j) for j in range(Y.shape[2])
            ]
            keep = [j for j, c in enumerate(comps) if c is not None and c.total > 0]
            if not keep:
                continue
            sig = np.array([comps[j].total for j in keep])
            allow = list(predictor.allowance.get(name) or ())
            allow = np.array([(allow[j] if j < len(allow) else 0.0) for j in keep]) / sig
            blocks.append(
                (f"{d.name}.{name}", Y[:, :, keep] / sig, di, name, np.array(keep), sig, allow)
            )
        if ok.any():
            p_ref = predictor.parameters(members.X[ref : ref + 1], d, np.random.default_rng(0))[0]
            noises.append(_DropNoise(predictor, d, flown, ref, p_ref))
    if not blocks:
        raise StudyDefinitionError(
            "noise",
            f"no channel of plan drop(s) {', '.join(d.name for d in drops)} has a stated noise, "
            "so nothing says how closely its data would tell members apart",
            "state it in the drop: noise = { position_h = 1.5, position_v = 3.0 } (or in the "
            "study's [identification] noise)",
        )
    return blocks, ok, noises


def _draw(blocks, noises: Sequence[_DropNoise], n: int, rng) -> list[NDArray]:
    """``n`` joint draws of every block's effective noise, in σ units: (n, T, k') each."""
    per_drop = [nz.draw(n, rng) for nz in noises]
    return [per_drop[di][ch][:, :, keep] / sig for _, _, di, ch, keep, sig, _ in blocks]


def _beyond(r: NDArray, allow: NDArray) -> NDArray:
    """Residuals (σ units, components last) less the study's discrepancy allowance: what
    lies beyond ±allowance (0 inside it), as the with-allowance band of ``predict`` reads."""
    if not np.any(allow):
        return r
    return np.sign(r) * np.maximum(np.abs(r) - allow, 0.0)


def _limits(blocks, noises: Sequence[_DropNoise], rng) -> NDArray:
    """Per block, the mean-square criterion's limit under the noise alone at a joint coverage
    of :data:`COVERAGE` (seeded draws)."""
    E = _draw(blocks, noises, LIMIT_DRAWS, rng)
    S = np.column_stack([np.nanmean(_beyond(e, b[6]) ** 2, axis=(1, 2)) for e, b in zip(E, blocks)])
    lo, hi = COVERAGE, 1.0
    for _ in range(40):  # the per-block quantile at which the joint coverage is COVERAGE
        q = 0.5 * (lo + hi)
        L = np.quantile(S, q, axis=0)
        if np.mean(np.all(S <= L, axis=1)) >= COVERAGE:
            hi = q
        else:
            lo = q
    return np.quantile(S, hi, axis=0)


def _kept(blocks, noises: Sequence[_DropNoise], L: NDArray, ok: NDArray, rng) -> NDArray:
    """(m, m) bool: row t, the members kept when member t plays the truth (one noise draw)."""
    m = ok.size
    K = np.ones((m, m), dtype=bool)
    K[:, ~ok] = False
    E = _draw(blocks, noises, m, rng)
    for b, (_, Y, *_rest, allow) in enumerate(blocks):
        D = (Y + E[b]).reshape(m, -1)  # each member's data when it is the truth
        Yf = Y.reshape(m, -1)
        a_flat = np.tile(allow, Y.shape[1])
        for i in np.flatnonzero(ok):
            cols = np.isfinite(D[i])
            if not cols.any():
                continue
            Yc = Yf[:, cols]
            bad = ~np.isfinite(Yc).all(axis=1)
            r = np.where(bad[:, None], 0.0, _beyond(Yc - D[i, cols], a_flat[cols]))
            s = np.einsum("ij,ij->i", r, r) / cols.sum()
            K[i] &= (s <= L[b]) & ~bad
    return K


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
) -> Candidate:
    rng = np.random.default_rng([seed, 34])
    blocks, ok, noises = _blocks(predictor, members, drops, seed)
    if not ok.any():
        raise StudyDefinitionError(
            Path(file).name,
            f"no member of D could fly this plan ({', '.join(d.name for d in drops)})",
            "check its initial state, wind and inputs against the study's drops",
        )
    L = _limits(blocks, noises, rng)
    K = _kept(blocks, noises, L, ok, rng)
    w = np.where(ok, members.weights, 0.0)
    w = w / w.sum()
    frac = K.astype(float) @ w  # per truth: the weighted share kept
    truths = np.flatnonzero(ok)
    expected = float(w[truths] @ frac[truths])
    boot_rng = np.random.default_rng([seed, 35])
    pw = w[truths] / w[truths].sum()
    draws = boot_rng.choice(truths.size, size=(BOOTSTRAP, truths.size), p=pw)
    means = frac[truths][draws].mean(axis=1)
    interval = (float(np.quantile(means, 0.025)), float(np.quantile(means, 0.975)))
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
    labels = [lab for lab, *_ in blocks]
    return Candidate(
        name=Path(file).stem,
        file=str(file),
        drops=[d.name for d in drops],
        channels=labels,
        expected_fraction_kept=expected,
        interval=interval,
        newly_identified=new + [f"combination {c['text']}" for c in new_combos],
        identified_share=shares,
        combinations=new_combos,
        failed=int((~ok).sum()),
        thin_share=float(pw @ (nk < need)),
        notes=[nz.note for nz in noises if nz.note],
        n_flown=int(ok.sum()),
    )


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
        cands = [
            _candidate(f, drops, predictor, mem, a, now, combos, seed, identified)
            for f, drops in parsed
        ]
        order = sorted(cands, key=lambda c: (c.expected_fraction_kept, -len(c.newly_identified)))
        for k, c in enumerate(order, 1):
            c.rank = k
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
