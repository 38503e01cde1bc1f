"""What the identified set predicts: ensemble predictions of new drops from D's members.

:func:`predict` is the one call (``vectorid predict STORE DROP.toml`` runs it)::

    from vectorid.workflows.predict import predict
    p = predict("runs/g12.db", ["next-drop.toml"], members=1000, seed=0)
    print(p.describe())            # the same text as the command line
    p.to_dict()                    # the --json document

It chooses members of the feasible set D (:func:`members_of`), flies each over each drop
(:func:`simulate_members`, batched through the compiled model with the study's fixed
parameters and options, :class:`vectorid.identify.predictor.Predictor`) and summarises:

* per channel and time, the weighted median and the 5–95 % band of the members' outputs —
  the **credible band**: where the model's output lies for the parameter vectors the data
  could not tell apart — and the same band with the stated measurement noise of each channel
  added — the **with-noise band**: where a *measured sample* is expected (for a drop with
  data the noise also enters through the initial state the study fits to noisy samples). Only
  the with-noise band is a prediction interval for measurements; the credible band is not;
* where the drop has data: the share of measured samples inside each band
  (``coverage_credible``, ``coverage_with_noise``), the median's RMS error, and a plain
  verdict: the data lie within what D predicts, or they do not (which channels, when, by how
  much);
* the landing (planned drops: where each member reaches the ground) or end-of-window
  dispersion: every member's point, the radii R50/R90/R95 around the ensemble's centre that
  hold 50/90/95 % of the points (weighted) with a seeded bootstrap interval, the 1/2/3-σ
  covariance ellipses with the share of points each actually holds, and the measured point
  with whether it lies inside R95.

Members (:func:`members_of`): all of D, or ``n`` of them chosen to keep the weights: a
sequential store's importance weights (or holding times) are used as they are, and ``n`` of
its members are drawn by seeded systematic resampling in proportion to them (a member drawn
k times weighs k); on a plain store every member weighs 1 and ``n`` are drawn without
replacement (a seeded random subset). An empty D is an error that says so; the nearest
generation of a sequential store is used only when asked by name (``nearest_generation``),
and every output then names it as not D.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vectorid.analysis import Analysis
from vectorid.analysis.weights import trial_weights
from vectorid.errors import StudyDefinitionError
from vectorid.identify.planned import DropToPredict
from vectorid.identify.predictor import Flown, Predictor
from vectorid.limits import Limits, parse_user_limits
from vectorid.samplers.sequential.state import generations, relaxed, tolerance_of
from vectorid.study import Study

__all__ = [
    "CHECK_COVERAGE",
    "LEVEL",
    "ChannelPrediction",
    "Dispersion",
    "DropPrediction",
    "EmptySetError",
    "Members",
    "Prediction",
    "members_of",
    "predict",
    "simulate_members",
    "weighted_quantiles",
]

#: The bands' quantiles: 5 % and 95 % (a 90 % band), and the median.
LEVEL = (0.05, 0.95)
#: A channel passes the predictive check when its with-noise 90 % band holds at least this
#: share of its measured samples (independent samples inside a 90 % band fall below 80 % in
#: under 1 % of records of 50 samples or more; correlated noise makes that likelier, so a
#: share below it is reported, never hidden, and the numbers are always printed).
CHECK_COVERAGE = 0.80
#: With-noise bands draw at least this many noisy samples per time (members x draws).
NOISE_SAMPLES = 2000
#: Bootstrap resamples of the dispersion radii.
BOOTSTRAP = 400
#: Share of the members' weight that must still be flying for a band to be given at a time.
ALIVE_SHARE = 0.5
#: Nominal share of a bivariate normal inside its k-sigma ellipse, k = 1, 2, 3.
NOMINAL_ELLIPSE = {k: 1.0 - math.exp(-0.5 * k * k) for k in (1, 2, 3)}


class EmptySetError(StudyDefinitionError):
    """D holds no member under the limits in force: there is nothing to predict from."""


# -- members ----------------------------------------------------------------------------------


@dataclass
class Members:
    """The members of D that are flown.

    Attributes
    ----------
    X : (m, p) float
        Their design vectors, columns as the study's variables.
    weights : (m,) float
        Their weights, summing to 1.
    ids : (m,) int
        Their trial ids.
    n_set : int
        Members of the set they were chosen from.
    source : str
        The set, in words ("D at the stated limits", or the nearest generation, named as
        not D).
    chosen : str
        How they were chosen, in words.
    is_d : bool
        False when they come from the nearest generation (not D).
    ess : float
        Kish's effective sample size of the weights of the set.
    """

    X: NDArray[np.float64]
    weights: NDArray[np.float64]
    ids: NDArray[np.int64]
    n_set: int
    source: str
    chosen: str
    is_d: bool = True
    ess: float = 0.0

    def __len__(self) -> int:
        return len(self.weights)

    def to_dict(self) -> dict[str, Any]:
        return {
            "flown": len(self),
            "of": self.n_set,
            "set": self.source,
            "is_d": self.is_d,
            "chosen": self.chosen,
            "ess": round(float(self.ess), 1),
        }


def _nearest_generation(study: Study) -> tuple[dict[str, float], str]:
    """Limits of the sequential store's nearest generation (the smallest relaxation of the
    stated limits its tolerances reached) and their description."""
    spec = study.spec
    gens = generations(study.store)
    constrained, floor = Limits(spec).constrained()
    best = None
    for g in gens:
        eps = tolerance_of(g, spec, constrained)
        f = relaxed(eps, floor)
        if f is not None and (best is None or f < best[0]):
            best = (f, g, eps)
    if best is None:
        raise EmptySetError(
            "--nearest-generation",
            "this store has no generation with finite limits (it is no sequential store, or "
            "its first generation only)",
            "relax the limits by name instead (--limit 'NAME<=VALUE')",
        )
    f, g, eps = best
    limits = {}
    for j, e in zip(constrained, eps):
        c = spec.criteria[j]
        limits[c.name] = float(e if c.sense == "min" else -e)
    return limits, f"the nearest generation ({g.gen}: the stated limits relaxed ×{f:.3g}), NOT D"


def members_of(
    study: Study | str | Path,
    n: int | None = None,
    seed: int = 0,
    *,
    limits: Any = None,
    nearest_generation: bool = False,
    analysis: Analysis | None = None,
    relaxed_by: float | None = None,
) -> Members:
    """Members of D to fly: all of them, or ``n`` chosen to keep the weights.

    Parameters
    ----------
    study : Study or path
        The store (opened read-only when a path).
    n : int, optional
        How many to fly (default: all). On a weighted (sequential) store ``n`` draws of
        seeded systematic resampling in proportion to the weights (a member drawn k times
        weighs k); on a plain store a seeded random subset of ``n`` members, each weighing 1.
    seed : int
        Seed of the choice.
    limits : optional
        Bounds overriding the study's (as :meth:`vectorid.Study.analysis` takes them): D is
        taken under them, and the output says so.
    nearest_generation : bool
        Where D is empty on a sequential store, fly the members of its nearest generation
        instead, named in every output as not D.
    analysis : Analysis, optional
        The analysis to read D from (default: the store's under ``limits``).
    relaxed_by : float, optional
        ``limits`` are the stated ones relaxed by this factor (a stage's last resort, where D
        at the stated limits is empty): the set is named so, as not D, in every output.

    Raises
    ------
    EmptySetError
        D holds no member (the message names the nearest generation where there is one).
    """
    own = not isinstance(study, Study)
    st = Study.open(study) if own else study
    try:
        a = analysis if analysis is not None else st.analysis(limits)
        source = "D at the stated limits" if limits is None else "D under the limits given"
        is_d = True
        stand_in = [
            c.limit_note for c in st.spec.criteria
            if c.limit is not None and c.limit_source == "quantile" and "stand-in" in c.limit_note
        ]  # fmt: skip
        if limits is None and stand_in:  # a stage's last resort, saved in the store
            why = stand_in[0].split(": stated limit")[0].removeprefix("stand-in, ")
            source = f"the set under the store's saved limits, stand-ins ({why}), NOT D"
            is_d = False
        if relaxed_by is not None:
            source = (
                f"the set under the stated limits relaxed ×{relaxed_by:.3g} (the last resort: D "
                "at the stated limits is empty), NOT D"
            )
            is_d = False
        if not a.n_feasible:
            gens = generations(st.store)
            if nearest_generation and gens:
                near, source = _nearest_generation(st)
                a = st.analysis(near)
                is_d = False
            else:
                offer = (
                    "; pass --nearest-generation to predict from the sampler's nearest "
                    "generation instead (named as not D in every output)"
                    if gens
                    else ""
                )
                raise EmptySetError(
                    "store",
                    f"D is empty: none of the {a.n} trials of {str(st.store.path)!r} meets every "
                    f"limit in force ({', '.join(str(b) for b in a.active_bounds())})",
                    "run the study further (vectorid run), or relax a limit by name "
                    f"(--limit 'NAME<=VALUE'){offer}",
                )
        rows = np.flatnonzero(a.feasible)
        w = trial_weights(a, a.feasible)
        weighted = w is not None
        w = np.ones(rows.size) if w is None else np.asarray(w, dtype=float)
        keep = w > 0
        rows, w = rows[keep], w[keep]
        ess = float(w.sum() ** 2 / np.sum(w**2)) if w.size else 0.0
        rng = np.random.default_rng(seed)
        if n is None or n >= rows.size:
            pick, counts = np.arange(rows.size), w
            chosen = f"all {rows.size} members" + (", with their weights" if weighted else "")
        elif not weighted:
            pick = np.sort(rng.choice(rows.size, size=int(n), replace=False))
            counts = np.ones(pick.size)
            chosen = f"{pick.size} of {rows.size} members, a seeded random subset (seed {seed})"
        else:
            order = rng.permutation(rows.size)
            cw = np.cumsum(w[order]) / w.sum()
            u = (rng.random() + np.arange(int(n))) / int(n)
            k = np.minimum(np.searchsorted(cw, u, side="right"), rows.size - 1)
            pick, counts = np.unique(order[k], return_counts=True)
            chosen = (
                f"{int(n)} draws of systematic resampling in proportion to the weights "
                f"(seed {seed}): {pick.size} distinct members, each weighing its draws"
            )
        X = a.trials.X[rows[pick]]
        weights = np.asarray(counts, dtype=float)
        weights = weights / weights.sum()
        return Members(
            X, weights, a.trials.id[rows[pick]].astype(np.int64), int(rows.size), source,
            chosen, is_d, ess,
        )  # fmt: skip
    finally:
        if own:
            st.close()


def simulate_members(
    predictor: Predictor,
    members: Members,
    drop: DropToPredict,
    seed: int = 0,
) -> Flown:
    """Fly ``members`` over ``drop`` (per-drop variables drawn with ``seed`` where the drop
    says ``"drawn"``); see :meth:`vectorid.identify.predictor.Predictor.fly`."""
    rng = np.random.default_rng([seed, 17])
    P = predictor.parameters(members.X, drop, rng)
    return predictor.fly(P, drop)


# -- statistics -------------------------------------------------------------------------------


def weighted_quantiles(
    Y: NDArray, w: NDArray, qs: Sequence[float], min_share: float = 0.0
) -> NDArray[np.float64]:
    """Weighted quantiles along axis 0 of ``Y`` (n, ...), ignoring NaN.

    The weights' midpoints on the cumulative distribution are interpolated (Hyndman–Fan
    type 5 with weights, as :func:`vectorid.analysis.weights.weighted_quantile`). Where the
    finite values carry less than ``min_share`` of the total weight the result is NaN.

    Returns
    -------
    (len(qs), ...) float
    """
    Y = np.asarray(Y, dtype=float)
    n = Y.shape[0]
    w = np.asarray(w, dtype=float)
    flat = np.ascontiguousarray(Y.reshape(n, -1).T)  # (columns, n): sorted along the last axis
    valid = np.isfinite(flat)
    if n and np.all(w == w[0]):  # equal weights: Hazen's quantiles of the sorted values
        nvalid = valid.sum(1)
        ys = np.sort(np.where(valid, flat, np.inf), axis=1)
        rows = np.arange(flat.shape[0])
        top = np.maximum(nvalid - 1, 0)
        out = np.full((len(qs), flat.shape[0]), np.nan)
        share = nvalid / n
        for i, q in enumerate(qs):
            pos = q * nvalid - 0.5
            lo = np.clip(np.floor(pos).astype(np.int64), 0, top)
            hi = np.minimum(lo + 1, top)
            f = np.clip(pos - lo, 0.0, 1.0)
            ylo, yhi = ys[rows, lo], ys[rows, hi]
            with np.errstate(invalid="ignore"):
                v = np.where(hi > lo, ylo + f * (yhi - ylo), ylo)
            out[i] = np.where((nvalid > 0) & (share >= min_share), v, np.nan)
        return out.reshape(len(qs), *Y.shape[1:])
    order = np.argsort(np.where(valid, flat, np.inf), axis=1)
    ys = np.take_along_axis(flat, order, 1)
    ws = np.where(np.take_along_axis(valid, order, 1), w[order], 0.0)
    tot = ws.sum(1)
    nvalid = valid.sum(1)
    cum = np.cumsum(ws, 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        c = (cum - 0.5 * ws) / tot[:, None]
    c[ws <= 0] = np.inf
    rows = np.arange(flat.shape[0])
    out = np.full((len(qs), flat.shape[0]), np.nan)
    share = tot / max(float(np.sum(w)), 1e-300)
    top = np.maximum(nvalid - 1, 0)
    for i, q in enumerate(qs):
        k = (c < q).sum(1)
        hi = np.minimum(k, top)
        lo = np.clip(k - 1, 0, top)
        clo, chi = c[rows, lo], c[rows, hi]
        ylo, yhi = ys[rows, lo], ys[rows, hi]
        with np.errstate(invalid="ignore", divide="ignore"):
            f = np.where(chi > clo, (q - clo) / (chi - clo), 0.0)
        f = np.clip(np.nan_to_num(f), 0.0, 1.0)
        v = ylo + f * (yhi - ylo)
        out[i] = np.where((nvalid > 0) & (share >= min_share), v, np.nan)
    return out.reshape(len(qs), *Y.shape[1:])


@dataclass
class ChannelPrediction:
    """One channel's prediction on one drop.

    Attributes
    ----------
    name, unit : str
    components : tuple of str
    t : (T,) float
        Times, s from the drop's start.
    median : (T, m) float
        Weighted median of the members' outputs.
    credible : (2, T, m) float
        The credible 5–95 % band: the members' outputs alone (not a prediction interval).
    with_noise : (2, T, m) float or None
        The 5–95 % band of a measured sample: outputs plus the stated measurement noise (NaN
        for a component without stated noise; None where no component has one).
    noise_text : str
        The noise added, in words.
    measured_t, measured : arrays or None
        The measured samples in the drop's window (s from its start; (K, m)).
    coverage_credible, coverage_with_noise : float or None
        Share of measured samples (all components) inside each band.
    allowance : tuple of float or None
        The study's model-discrepancy allowance per component (``unit``), where it states one.
    coverage_with_allowance : float or None
        Share of measured samples inside the with-noise band widened by that allowance (what
        the study itself granted the model; None where it grants nothing).
    median_rms : float or None
        RMS over the samples of the length of the median's error vector, in ``unit``.
    component_rms : dict
        Component -> RMS error of the median, in ``unit``.
    outside : list of dict
        Spans of consecutive samples outside the with-noise band (component, start and end
        s from the drop's start, the largest excess beyond the band in ``unit``, samples).
    """

    name: str
    unit: str
    components: tuple[str, ...]
    t: NDArray[np.float64]
    median: NDArray[np.float64]
    credible: NDArray[np.float64]
    with_noise: NDArray[np.float64] | None
    noise_text: str
    measured_t: NDArray[np.float64] | None = None
    measured: NDArray[np.float64] | None = None
    coverage_credible: float | None = None
    coverage_with_noise: float | None = None
    allowance: tuple[float, ...] | None = None
    coverage_with_allowance: float | None = None
    median_rms: float | None = None
    component_rms: dict[str, float] = field(default_factory=dict)
    outside: list[dict[str, Any]] = field(default_factory=list)

    @property
    def passes(self) -> bool | None:
        """Whether the with-noise band holds at least :data:`CHECK_COVERAGE` of the samples
        (None: no data or no stated noise)."""
        if self.coverage_with_noise is None:
            return None
        return self.coverage_with_noise >= CHECK_COVERAGE

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "unit": self.unit,
            "components": list(self.components),
            "coverage_credible": _r(self.coverage_credible),
            "coverage_with_noise": _r(self.coverage_with_noise),
            "allowance": None if self.allowance is None else [_r(a) for a in self.allowance],
            "coverage_with_allowance": _r(self.coverage_with_allowance),
            "median_rms": _r(self.median_rms),
            "component_rms": {k: _r(v) for k, v in self.component_rms.items()},
            "noise": self.noise_text,
            "outside": self.outside[:10],
        }


@dataclass
class Dispersion:
    """Where the members' load lands (or is at the end of the window), and how sure that is.

    Attributes
    ----------
    kind : {"landing", "end of window"}
    time_s : float
        Median landing time, or the end of the window, s from the drop's start.
    points : (k, 2) float
        Every member's point, north and east of the origin, m (members that flew).
    weights : (k,) float
    centre : (2,) float
        The ensemble's (weighted) centre, north and east, m.
    radii : dict
        ``"r50"``, ``"r90"``, ``"r95"`` -> radius around the centre holding that share of
        the points (weighted), m.
    intervals : dict
        The same keys -> (5 %, 95 %) of the seeded bootstrap, m.
    r95_with_noise : float or None
        R95 of the points plus the position noise of a measured fix (m): what a measured
        point is checked against where noise is stated.
    ellipses : list of dict
        The 1/2/3-σ covariance ellipses: ``sigma``, ``semi_axes_m``, ``angle_deg`` (of the
        major axis, from north towards east), ``share`` (weighted share of points inside) and
        ``nominal_share`` (a bivariate normal's).
    measured : (2,) float or None
        The measured point (north, east, m).
    measured_inside_r95 : bool or None
    not_landed : int
        Members still above the ground at the end of the window (landing: then the
        dispersion is the end of the window's).
    """

    kind: str
    time_s: float
    points: NDArray[np.float64]
    weights: NDArray[np.float64]
    centre: NDArray[np.float64]
    radii: dict[str, float]
    intervals: dict[str, tuple[float, float]]
    r95_with_noise: float | None
    ellipses: list[dict[str, Any]]
    measured: NDArray[np.float64] | None = None
    measured_inside_r95: bool | None = None
    not_landed: int = 0
    bootstrap_seed: int = 0

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "time_s": _r(self.time_s),
            "r50_m": _r(self.radii["r50"]),
            "r90_m": _r(self.radii["r90"]),
            "r95_m": _r(self.radii["r95"]),
            "intervals_m": {k: [_r(a), _r(b)] for k, (a, b) in self.intervals.items()},
            "bootstrap": {"resamples": BOOTSTRAP, "seed": self.bootstrap_seed},
            "r95_with_noise_m": _r(self.r95_with_noise),
            "centre_ne_m": [_r(v) for v in self.centre],
            "ellipses": self.ellipses,
            "measured_ne_m": None if self.measured is None else [_r(v) for v in self.measured],
            "measured_inside_r95": self.measured_inside_r95,
            "not_landed": self.not_landed,
            "points": len(self.points),
        }


@dataclass
class DropPrediction:
    """What D predicts for one drop."""

    name: str
    kind: str
    duration: float
    channels: list[ChannelPrediction]
    dispersion: Dispersion | None
    verdict: str
    within: bool | None
    failed: int
    flown: int
    notes: list[str]
    wind_text: str
    noise_text: str
    parameters_text: str = ""

    def channel(self, name: str) -> ChannelPrediction:
        for c in self.channels:
            if c.name == name:
                return c
        raise KeyError(name)

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "kind": self.kind,
            "duration_s": _r(self.duration),
            "channels": [c.to_dict() for c in self.channels],
            "landing": None if self.dispersion is None else self.dispersion.to_dict(),
            "verdict": self.verdict,
            "within": self.within,
            "failed": self.failed,
            "flown": self.flown,
            "wind": self.wind_text,
            "noise": self.noise_text,
            "parameters": self.parameters_text,
            "notes": self.notes,
        }


@dataclass
class Prediction:
    """What D predicts for the drops asked (see the module docstring)."""

    store: str
    members: Members
    drops: list[DropPrediction]
    seed: int
    model: str

    def drop(self, name: str) -> DropPrediction:
        for d in self.drops:
            if d.name == name:
                return d
        raise KeyError(name)

    def to_dict(self) -> dict[str, Any]:
        """The ``vectorid predict --json`` document."""
        return {
            "store": self.store,
            "model": self.model,
            "members": len(self.members),
            "set": self.members.to_dict(),
            "seed": self.seed,
            "bands": {
                "credible": "5-95 % of the members' outputs (not a prediction interval)",
                "with_noise": "5-95 % of a measured sample: outputs plus the stated noise",
            },
            "drops": [d.to_dict() for d in self.drops],
        }

    def describe(self) -> str:
        """The prediction in words, with units (what ``vectorid predict`` prints)."""
        m = self.members
        lines = [
            f"What {m.source} predicts (store {self.store}, model {self.model}; {len(m)} members "
            f"flown: {m.chosen}; effective sample size of the set {m.ess:.0f})",
            "  bands: credible = 5-95 % of the members' outputs (their spread, not a "
            "prediction interval);",
            "         with-noise = 5-95 % of a measured sample (outputs + the stated "
            "measurement noise)",
        ]
        if not m.is_d:
            lines.append(f"  NOTE: these members are {m.source}")
        for d in self.drops:
            lines += ["", *_describe_drop(d)]
        return "\n".join(lines)


def _r(v: Any, digits: int = 4) -> Any:
    if v is None:
        return None
    v = float(v)
    if not math.isfinite(v):
        return None
    return float(f"{v:.{digits}g}")


# -- one drop ---------------------------------------------------------------------------------


def _alive_after_landing(flown: Flown, drop: DropToPredict) -> NDArray | None:
    """(n,) landing times (s, NaN: never) of a planned drop's members."""
    if drop.ground_altitude is None:
        return None
    h = -flown.position[:, :, 2] - (drop.ground_altitude - drop.origin_altitude)
    below = h <= 0
    below[:, 0] = False
    first = np.where(below.any(axis=1), below.argmax(axis=1), -1)
    t = flown.t
    out = np.full(h.shape[0], np.nan)
    rows = np.flatnonzero(first > 0)
    k = first[rows]
    h0, h1 = h[rows, k - 1], h[rows, k]
    f = h0 / (h0 - h1)
    out[rows] = t[k - 1] + f * (t[k] - t[k - 1])
    return out


def _noise_samples(
    ch: ChannelPrediction, Y: NDArray, w: NDArray, drop: DropToPredict, init: NDArray | None,
    rng: np.random.Generator,
) -> tuple[NDArray | None, NDArray, str]:  # fmt: skip
    """Members' outputs plus noise draws: (N, T, m) samples, their weights, the noise text."""
    noise = drop.noise
    m = len(ch.components)
    comps = [None if noise is None else noise.component(ch.name, j) for j in range(m)]
    if all(c is None for c in comps):
        return None, w, "none stated"
    n = Y.shape[0]
    K = max(1, math.ceil(NOISE_SAMPLES / max(n, 1)))
    S = np.repeat(Y, K, axis=0)
    for j, c in enumerate(comps):
        if c is None:
            S[:, :, j] = np.nan
        else:
            S[:, :, j] += c.draw(ch.t + drop.t0, S.shape[0], rng)
    if init is not None:
        S += init[rng.integers(0, init.shape[0], S.shape[0])]
    texts = []
    for j, c in enumerate(comps):
        texts.append(f"{ch.components[j]} {'-' if c is None else c.describe(1.0, ch.unit)}")
    how = ", ".join(texts)
    if init is not None:
        how += "; and through the initial state fitted to noisy samples"
    return S, np.repeat(w, K) / K, how


def _check(ch: ChannelPrediction, drop: DropToPredict) -> None:
    """Coverage, RMS and the spans outside the with-noise band of a channel with data."""
    fl = drop.flight
    if fl is None or ch.name not in fl.channels:
        return
    c = fl[ch.name]
    t_end = drop.t0 + ch.t[-1]
    sel = (c.t >= drop.t0 - 1e-9) & (c.t <= t_end + 1e-9)
    if not sel.any():
        return
    tm, vm = c.t[sel] - drop.t0, c.values[sel]
    ch.measured_t, ch.measured = tm, vm

    def at(A: NDArray) -> NDArray:
        return np.column_stack([np.interp(tm, ch.t, A[:, j]) for j in range(A.shape[1])])

    med = at(ch.median)
    lo, hi = at(ch.credible[0]), at(ch.credible[1])
    ok = np.isfinite(lo) & np.isfinite(hi)
    tol = 1e-9 * (1.0 + np.abs(vm))  # a band of zero width holds what equals it
    inside = (vm >= lo - tol) & (vm <= hi + tol)
    ch.coverage_credible = float(inside[ok].mean()) if ok.any() else None
    e = med - vm
    fin = np.all(np.isfinite(e), axis=1)
    if fin.any():
        ch.median_rms = float(np.sqrt(np.mean(np.sum(e[fin] ** 2, axis=1))))
        ch.component_rms = {
            n: float(np.sqrt(np.mean(e[fin, j] ** 2))) for j, n in enumerate(ch.components)
        }
    if ch.with_noise is None:
        return
    nlo, nhi = at(ch.with_noise[0]), at(ch.with_noise[1])
    nok = np.isfinite(nlo) & np.isfinite(nhi)
    if not nok.any():
        return
    ninside = (vm >= nlo - tol) & (vm <= nhi + tol)
    ch.coverage_with_noise = float(ninside[nok].mean())
    if ch.allowance is not None:
        a = np.asarray(ch.allowance)[None, :]
        ainside = (vm >= nlo - a - tol) & (vm <= nhi + a + tol)
        ch.coverage_with_allowance = float(ainside[nok].mean())
    excess = np.where(vm > nhi, vm - nhi, np.where(vm < nlo, nlo - vm, 0.0))
    spans = []
    for j, name in enumerate(ch.components):
        out = nok[:, j] & ~ninside[:, j]
        k = 0
        while k < out.size:
            if not out[k]:
                k += 1
                continue
            s = k
            while k < out.size and out[k]:
                k += 1
            spans.append({
                "component": name,
                "from_s": _r(tm[s]),
                "to_s": _r(tm[k - 1]),
                "samples": int(k - s),
                "max_excess": _r(float(excess[s:k, j].max())),
            })  # fmt: skip
    spans.sort(key=lambda d: -d["samples"])
    ch.outside = spans


def _dispersion(
    flown: Flown, w: NDArray, drop: DropToPredict, landing: NDArray | None, seed: int,
    rng: np.random.Generator,
) -> tuple[Dispersion | None, list[str]]:  # fmt: skip
    notes: list[str] = []
    ok = flown.ok
    if ok.sum() < 3:
        return None, ["fewer than 3 members flew the drop: no dispersion"]
    kind = "end of window"
    pts_all = flown.position[:, -1, :2]
    time_s = float(flown.t[-1])
    not_landed = 0
    if landing is not None:
        not_landed = int(np.sum(ok & ~np.isfinite(landing)))
        if not_landed == 0:
            kind = "landing"
            P = flown.position
            k = np.clip(np.searchsorted(flown.t, landing, side="left"), 1, flown.t.size - 1)
            rows = np.flatnonzero(ok)
            kk = k[rows]
            f = (landing[rows] - flown.t[kk - 1]) / (flown.t[kk] - flown.t[kk - 1])
            pts_all = np.full((P.shape[0], 2), np.nan)
            pts_all[rows] = P[rows, kk - 1, :2] + f[:, None] * (
                P[rows, kk, :2] - P[rows, kk - 1, :2]
            )
            time_s = float(weighted_quantiles(landing[rows], w[rows], [0.5])[0])
        else:
            notes.append(
                f"{not_landed} of {int(ok.sum())} members are still above the ground at the end "
                f"of the window ({flown.t[-1]:g} s): the dispersion is the end of the window's, "
                "not the landing's — give a longer duration"
            )
    rows = np.flatnonzero(ok & np.all(np.isfinite(pts_all), axis=1))
    pts, ww = pts_all[rows], w[rows] / w[rows].sum()
    centre = ww @ pts
    dist = np.linalg.norm(pts - centre, axis=1)
    qs = (0.5, 0.9, 0.95)
    radii = dict(zip(("r50", "r90", "r95"), map(float, weighted_quantiles(dist, ww, qs))))
    brng = np.random.default_rng([seed, 29])
    boot = np.empty((BOOTSTRAP, 3))
    for b in range(BOOTSTRAP):
        idx = brng.choice(len(pts), size=len(pts), p=ww)
        c = pts[idx].mean(axis=0)
        boot[b] = np.quantile(np.linalg.norm(pts[idx] - c, axis=1), qs)
    intervals = {
        k: (float(np.quantile(boot[:, i], 0.05)), float(np.quantile(boot[:, i], 0.95)))
        for i, k in enumerate(("r50", "r90", "r95"))
    }
    # covariance ellipses, labelled with the share they hold
    cov = np.cov(pts.T, aweights=ww, bias=True) if len(pts) > 1 else np.zeros((2, 2))
    ellipses = []
    vals, vecs = np.linalg.eigh(cov)
    if vals.min() > 1e-12 * max(vals.max(), 1e-300):
        inv = np.linalg.inv(cov)
        d2 = np.einsum("ni,ij,nj->n", pts - centre, inv, pts - centre)
        major = vecs[:, 1]
        angle = math.degrees(math.atan2(major[1], major[0]))
        for k in (1, 2, 3):
            ellipses.append({
                "sigma": k,
                "semi_axes_m": [_r(k * math.sqrt(vals[1])), _r(k * math.sqrt(vals[0]))],
                "angle_deg": _r(angle),
                "share": _r(float(ww[d2 <= k * k].sum())),
                "nominal_share": _r(NOMINAL_ELLIPSE[k]),
            })  # fmt: skip
    else:
        notes.append("the points lie on a line or a point: no covariance ellipse")
    # a measured fix: its noise
    r95n = None
    noise = drop.noise
    comps = [None if noise is None else noise.component("position", j) for j in (0, 1)]
    if all(c is not None for c in comps):
        K = max(1, math.ceil(NOISE_SAMPLES / len(pts)))
        S = np.repeat(pts, K, axis=0) + np.column_stack(
            [rng.normal(0.0, c.total, len(pts) * K) for c in comps]  # type: ignore[union-attr]
        )
        dn = np.linalg.norm(S - centre, axis=1)
        r95n = float(weighted_quantiles(dn, np.repeat(ww, K), [0.95])[0])
    measured = None
    inside = None
    fl = drop.flight
    if fl is not None and "position" in fl.channels and kind == "end of window":
        c = fl["position"]
        t_abs = drop.t0 + flown.t[-1]
        if c.t[0] - 1e-9 <= t_abs <= c.t[-1] + 1e-9:
            measured = c.at([min(max(t_abs, c.t[0]), c.t[-1])])[0, :2]
            r = r95n if r95n is not None else radii["r95"]
            inside = bool(np.linalg.norm(measured - centre) <= r)
    disp = Dispersion(
        kind, time_s, pts, ww, centre, radii, intervals, r95n, ellipses, measured, inside,
        not_landed, seed,
    )  # fmt: skip
    return disp, notes


def _predict_drop(
    predictor: Predictor, members: Members, drop: DropToPredict, seed: int
) -> DropPrediction:
    flown = simulate_members(predictor, members, drop, seed)
    ok = flown.ok
    notes: list[str] = []
    if drop.name in predictor.study_drops and drop.kind == "data":
        notes.append(
            f"drop {drop.name!r} is one of the study's own drops: D was identified from its "
            "data, so this is no check on a drop the study never saw"
        )
    failed = int((~ok).sum())
    if failed:
        reasons: dict[str, int] = {}
        for i in np.flatnonzero(~ok):
            reasons[flown.messages[i]] = reasons.get(flown.messages[i], 0) + 1
        top = "; ".join(f"{k} ({v})" for k, v in sorted(reasons.items(), key=lambda kv: -kv[1])[:3])
        notes.append(
            f"{failed} of {len(ok)} members failed to fly this drop ({top}); the bands are those "
            "of the members that flew"
        )
    if not ok.any():
        raise StudyDefinitionError(
            drop.name,
            f"every one of the {len(ok)} members failed to fly this drop ({flown.messages[0]})",
            "check the drop's initial state, wind and inputs against the study's drops",
        )
    w = np.where(ok, members.weights, 0.0)
    w = w / w.sum()
    landing = _alive_after_landing(flown, drop)
    rng = np.random.default_rng([seed, 7])
    init = None
    jac = None
    if drop.kind == "data" and drop.noise is not None:
        delta = predictor.initial_state_errors(drop, 400, rng)
        if np.any(delta):
            # the member nearest the members' weighted mean (box-scaled) is linearised
            X = members.X
            span = np.ptp(X, axis=0)
            span = np.where(span > 0, span, 1.0)
            mean = w @ X
            ref = int(np.argmin(np.where(ok, np.sum(((X - mean) / span) ** 2, axis=1), np.inf)))
            P = predictor.parameters(members.X[ref : ref + 1], drop, np.random.default_rng(0))
            jac = predictor.state_jacobian(P[0], drop)
            init = delta
    channels = []
    for name in flown.channels:
        Y = np.array(flown.channels[name])
        t = flown.times[name]
        if landing is not None:  # after its landing a member no longer counts
            Y[t[None, :] > landing[:, None] + 1e-9] = np.nan
        Y[~ok] = np.nan
        med, lo, hi = weighted_quantiles(Y, w, (0.5, *LEVEL), ALIVE_SHARE)
        ch = ChannelPrediction(
            name, flown.units[name], flown.components[name], t, med, np.stack([lo, hi]), None,
            "none stated",
        )  # fmt: skip
        eff = None if init is None or jac is None else np.einsum("rs,stm->rtm", init, jac[name])
        allow = predictor.allowance.get(name)
        if allow and any(allow):
            m_ = len(ch.components)
            ch.allowance = tuple((list(allow) + [0.0] * m_)[:m_])
        S, sw, how = _noise_samples(ch, Y, w, drop, eff, rng)
        ch.noise_text = how
        if S is not None:
            nlo, nhi = weighted_quantiles(S, sw, LEVEL, ALIVE_SHARE)
            ch.with_noise = np.stack([nlo, nhi])
        _check(ch, drop)
        channels.append(ch)
    disp, dnotes = _dispersion(flown, w, drop, landing, seed, rng)
    notes += dnotes
    verdict, within = _verdict(drop, channels, disp, "D" if members.is_d else "this set")
    wind = drop.wind_text
    if drop.wind is None and any("wind" in k for k in drop.parameters):
        wind = "no profile: the model's own wind parameters (see the drop's parameters)"
    return DropPrediction(
        drop.name, drop.kind, predictor.duration(drop), channels, disp, verdict, within, failed,
        int(ok.sum()), notes, wind, drop.noise_text, predictor.describe_parameters(drop),
    )  # fmt: skip


def _verdict(
    drop: DropToPredict,
    channels: list[ChannelPrediction],
    disp: Dispersion | None,
    what: str = "D",
) -> tuple[str, bool | None]:
    if drop.kind == "planned":
        return "a planned drop: no data to check the prediction against", None
    judged = [c for c in channels if c.passes is not None]
    unjudged = [c.name for c in channels if c.passes is None and c.measured is not None]
    if not judged:
        return (
            "cannot be judged: no channel with data has a stated noise, and the credible band "
            "alone is no prediction interval for measured samples (state the noise)",
            None,
        )
    bad = [c for c in judged if not c.passes]
    shares = ", ".join(f"{c.name} {100 * c.coverage_with_noise:.0f} %" for c in judged)  # type: ignore[operator]
    tail = f" ({', '.join(unjudged)}: no stated noise, not judged)" if unjudged else ""
    if not bad:
        text = (
            f"the data lie within what {what} predicts: every channel's with-noise 90 % band "
            f"holds at least {100 * CHECK_COVERAGE:.0f} % of its samples ({shares}){tail}"
        )
        if disp is not None and disp.measured_inside_r95 is False:
            text += (
                f"; but the measured end point lies outside R95 ({disp.kind}, "
                f"{np.linalg.norm(disp.measured - disp.centre):.1f} m from the centre)"  # type: ignore[operator]
            )
        return text, True
    allowed = [c for c in bad if c.coverage_with_allowance is not None]
    parts = []
    for c in bad:
        spans = "; ".join(
            f"{s['component']} {s['from_s']:g}-{s['to_s']:g} s by up to {s['max_excess']:g} "
            f"{c.unit}"
            for s in c.outside[:3]
        )
        parts.append(
            f"{c.name} holds {100 * c.coverage_with_noise:.0f} % of its samples in its "  # type: ignore[operator]
            f"with-noise 90 % band (outside: {spans})"
        )
    text = f"the data do NOT lie within what {what} predicts: " + "; ".join(parts) + tail
    if allowed:
        held = [c for c in allowed if c.coverage_with_allowance >= CHECK_COVERAGE]  # type: ignore[operator]
        shares = ", ".join(
            f"{c.name} {100 * c.coverage_with_allowance:.0f} %"  # type: ignore[operator]
            for c in allowed
        )
        text += (
            f". Widened by the study's own model-discrepancy allowance, the with-noise band "
            f"holds {shares} of the samples"
            + (
                ": the model misses this drop by about what the study granted it"
                if len(held) == len(allowed) == len(bad)
                else ""
            )
        )
    return text, False


def _describe_drop(d: DropPrediction) -> list[str]:
    head = "planned drop" if d.kind == "planned" else "drop with data"
    lines = [
        f"{d.name} ({head}, {d.duration:g} s; wind: {d.wind_text}; noise: {d.noise_text}):",
        f"  members flown {d.flown}" + (f", failed {d.failed}" if d.failed else ""),
    ]
    if d.parameters_text:
        lines.append(f"  parameters of this drop: {d.parameters_text}")
    for c in d.channels:
        lines.append(f"  {c.name} [{c.unit}] ({', '.join(c.components)}), s from the start:")
        alive = np.flatnonzero(np.all(np.isfinite(c.median), axis=1))
        last = int(alive[-1]) if alive.size else c.t.size - 1
        idx = np.unique(np.linspace(0, last, min(5, last + 1)).astype(int))
        for k in idx:
            cells = []
            for j, comp in enumerate(c.components):
                m, lo, hi = c.median[k, j], c.credible[0, k, j], c.credible[1, k, j]
                cell = f"{comp} {m:.4g} [{lo:.4g}, {hi:.4g}]"
                if c.with_noise is not None and np.isfinite(c.with_noise[0, k, j]):
                    cell += f" noisy [{c.with_noise[0, k, j]:.4g}, {c.with_noise[1, k, j]:.4g}]"
                cells.append(cell)
            lines.append(f"    t {c.t[k]:7.2f}  " + "; ".join(cells))
        if last < c.t.size - 1:
            lines.append(f"    (after {c.t[last]:g} s too few members still fly: no band)")
        if c.measured is not None:
            cov = f"{100 * c.coverage_credible:.0f} %" if c.coverage_credible is not None else "-"
            covn = (
                f"{100 * c.coverage_with_noise:.0f} %"
                if c.coverage_with_noise is not None
                else "- (no stated noise)"
            )
            rms = "-" if c.median_rms is None else f"{c.median_rms:.3g} {c.unit}"
            lines.append(
                f"    {len(c.measured_t)} measured samples inside the credible band {cov}, the "  # type: ignore[arg-type]
                f"with-noise band {covn}; median's RMS error {rms}"
            )
            if c.coverage_with_allowance is not None:
                al = ", ".join(f"{a:.3g}" for a in c.allowance)  # type: ignore[union-attr]
                lines.append(
                    f"    (the with-noise band widened by the study's discrepancy allowance "
                    f"{al} {c.unit}: {100 * c.coverage_with_allowance:.0f} %)"
                )
    disp = d.dispersion
    if disp is not None:
        iv = disp.intervals
        lines.append(
            f"  {disp.kind} at {disp.time_s:.1f} s: centre north {disp.centre[0]:.1f} m, east "
            f"{disp.centre[1]:.1f} m of the origin; R50 {disp.radii['r50']:.1f} m "
            f"[{iv['r50'][0]:.1f}, {iv['r50'][1]:.1f}], R90 {disp.radii['r90']:.1f} m "
            f"[{iv['r90'][0]:.1f}, {iv['r90'][1]:.1f}], R95 {disp.radii['r95']:.1f} m "
            f"[{iv['r95'][0]:.1f}, {iv['r95'][1]:.1f}] (bootstrap 5-95 %)"
        )
        for e in disp.ellipses:
            lines.append(
                f"    {e['sigma']}-sigma ellipse {e['semi_axes_m'][0]:.3g} x "
                f"{e['semi_axes_m'][1]:.3g} m at {e['angle_deg']:.0f} deg: holds "
                f"{100 * e['share']:.1f} % of the points (a normal's "
                f"{100 * e['nominal_share']:.1f} %)"
            )
        if disp.measured is not None:
            r = disp.r95_with_noise if disp.r95_with_noise is not None else disp.radii["r95"]
            which = "with-noise R95" if disp.r95_with_noise is not None else "R95"
            where = "inside" if disp.measured_inside_r95 else "OUTSIDE"
            dist = float(np.linalg.norm(disp.measured - disp.centre))
            lines.append(
                f"    measured point north {disp.measured[0]:.1f} m, east "
                f"{disp.measured[1]:.1f} m: "
                f"{dist:.1f} m from the centre, {where} the {which} ({r:.1f} m)"
            )
    for n in d.notes:
        lines.append(f"  note: {n}")
    lines.append(f"  verdict: {d.verdict}")
    return lines


# -- the one call ------------------------------------------------------------------------------


def predict(
    store: str | Path | Study,
    drops: Iterable[str | Path | DropToPredict] | str | Path,
    *,
    members: int | None = None,
    seed: int = 0,
    limits: Any = None,
    nearest_generation: bool = False,
    relaxed_by: float | None = None,
) -> Prediction:
    """What D predicts for ``drops`` (see the module docstring).

    Parameters
    ----------
    store : path or Study
        An identification study's store (opened read-only; nothing is written to it).
    drops : path, or iterable of paths or DropToPredict
        Drop files (TOML, :mod:`vectorid.identify.planned`) or drops already parsed.
    members : int, optional
        How many members to fly (default: every member of D), chosen as
        :func:`members_of` says.
    seed : int
        Seed of the members' choice, the noise draws and the bootstrap.
    limits : optional
        Bounds overriding the study's (``{"pos_h": 40.0}`` or ``--limit`` bounds): D under them.
    nearest_generation : bool
        Where D is empty on a sequential store, fly its nearest generation (named as not D).
    relaxed_by : float, optional
        ``limits`` are the stated ones relaxed by this factor (named as not D; see
        :func:`members_of`).

    Returns
    -------
    Prediction

    Raises
    ------
    StudyDefinitionError
        A bad drop file, a store that identifies no flight model, an empty D
        (:class:`EmptySetError`), ...
    """
    own = not isinstance(store, Study)
    if own and not Path(store).exists():
        raise StudyDefinitionError(
            str(store), "no store there", "run a study first (vectorid run STUDY.toml)"
        )
    st = Study.open(store) if own else store
    try:
        spec = st.spec
        predictor = Predictor.from_spec(spec)
        if isinstance(drops, str | Path):
            drops = [drops]
        parsed: list[DropToPredict] = []
        for d in drops:
            if isinstance(d, DropToPredict):
                predictor.check_drop(d)
                parsed.append(d)
            else:
                parsed += predictor.read_drops(d)
        if not parsed:
            raise StudyDefinitionError("drops", "no drop to predict", "give a drop file")
        mem = members_of(
            st, members, seed, limits=limits, nearest_generation=nearest_generation,
            relaxed_by=relaxed_by,
        )  # fmt: skip
        preds = [_predict_drop(predictor, mem, d, seed) for d in parsed]
        return Prediction(str(st.store.path), mem, preds, int(seed), predictor.model.name)
    finally:
        if own:
            st.close()


def as_limits(spec: Any, texts: Sequence[str]) -> Any:
    """``--limit`` texts as bounds for :func:`predict` (None when none)."""
    if not texts:
        return None
    return parse_user_limits(spec, texts)
