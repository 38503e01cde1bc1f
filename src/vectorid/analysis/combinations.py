"""Identifiable combinations: directions in the gains along which the feasible set D is narrow.

A drop often determines combinations of gains, not the gains one by one: D is a thin slab or
an elongated ellipsoid lying obliquely in the box, so every gain alone spans most of its box
while some weighted sums of gains barely vary over D. This module names those sums, with
their range over D and a verdict by the same rules as a gain's
(:mod:`vectorid.analysis.identifiability`).

**Coordinates.** Each gain is written as a share of its box, z = (x - low)/(high - low), so
every gain's box is [0, 1]. Everything below is computed in z, so the answer does not depend
on how the box is written: a gain given in mm with its box in mm, or in m with its box in m,
has the same z, and the directions, ranges and verdicts are the same (``tests/analysis/
test_combinations.py`` checks it).

**Directions.** The principal directions of D's weighted covariance in z: the eigenvectors
of Σ = Cov_w(z) over D's members, weighted as the sampler says (importance weights or
holding times, :attr:`Analysis.weighting`; a plain store weighs every member once), so that
the members stand for the uniform density on D. The box's own uniform density has covariance
I/12 in z, the same along every unit direction, so an eigenvector of Σ is also a direction
where the ratio of D's spread to the box's spread is stationary (the generalised eigenproblem
Σ v = λ (I/12) v): the narrowest direction of D, relative to the box, is the first
eigenvector, and the others follow, each orthogonal to those before. This is pyPESTO's
ensemble spectral decomposition, taken over D's members rather than a likelihood ensemble.
(A direction found by any other rule — e.g. a sparse one — could be narrower for fewer
gains but is not unique; the principal directions are, and the readable form below keeps
their width.)

**Readable form.** A principal direction of 33 gains has 33 coefficients. Its gains are taken
in order of absolute coefficient and the shortest prefix is kept whose combination (renormalised to
unit length) spreads over D at most ``1.25`` times as much as the full direction; the range
and verdict printed are those of that shorter combination itself, so what is printed is what
is determined. The coefficients are on z; :attr:`Combination.per_unit` gives them per unit of
each gain (coefficient / (high - low)), for reading in the gains' own units.

**Width.** ``width_fraction`` = (hi - lo) of the range, in z along a unit direction: a share of
one box side. A unit direction's spread under the box's uniform density is 1/√12, that of one
box side, in every direction, so a width fraction compares D with the box exactly as a gain's
width does (a gain's own direction gives the gain's width). The box's full extent along a
combination, Σ|v_i|, is *not* the yardstick: in many dimensions almost none of the box lies
near the ends of a combination (along (1, ..., 1)/√33 the box spans 5.7 but holds 90 % of its
volume within 0.95), so a combination would look narrow by it even with D the whole box.

**Ranges that hold D's boundary.** D's members under-cover D near its boundary along a
narrow direction: in p dimensions almost none of D's volume lies near its ends along a
direction, so the members' [min, max] along it falls well short of D's extent (for a uniform
sample of 5,000 points of a 33-dimensional ellipsoid, the min-max covers about 60 % of the
extent along every direction), and a truth that nearly binds a criterion — as the truth of a
twin does — lies at that boundary. The range printed is therefore widened by a margin
estimated from the sample:

    range = [min, max] of the members, joined with mean ± √(m + 2)·sd,

clipped to the box's extent along the direction, with mean and sd the weighted ones along
it and m estimated from the weighted excess kurtosis κ along it: m = -6/κ - 4. The reason:
near its truth a criterion that sums squared residuals is a quadratic form of the gains, so
D is locally an ellipsoid in some m of the directions (bounded by the box in the others); a
uniform density on an m-dimensional ellipsoid projects on any of its directions to a density
∝ (1 - t²)^((m-1)/2), whose half-extent is exactly √(m + 2) standard deviations and whose
excess kurtosis is -6/(m + 4). One direction bounded on both sides (a slab, a uniform
interval: m = 1) gives √3·sd, exactly its half-width; a 33-dimensional ellipsoid gives
√35·sd. κ is taken two standard errors toward zero before solving for m (its asymptotic
variance by the delta method from the weighted moments up to the eighth, over Kish's
effective sample size), and m is kept within [1, p], so a sample that cannot tell the shape
gets the wider margin. Measured
(``tests/analysis/test_combinations.py``, a uniform sample of 5,000 points of a
33-dimensional ellipsoid with semi-axes 0.01–0.2 of a box side, rotated at random): the
widened ranges reach each end of the ellipsoid's known extent along every one of its 30
readable directions to within 2.2 % of the extent, and are never more than 1.03 times as wide,
where the members' min-max holds 53–62 % of it.

**Verdicts**, as a gain's: identified when the width fraction is at most ``identified``
(0.25), D holds at least ``min_feasible`` members and the range stays off the box's extent
along the direction (2 % of it); weak up to ``weak`` (0.6), or when narrow but touching the
box's extent, or when D is thin; not identified above ``weak``, or when no criteria
constraint is in force.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from .identifiability import thin_threshold
from .weights import trial_weights

if TYPE_CHECKING:  # pragma: no cover - for annotations only
    from .results import Analysis

__all__ = [
    "Combination",
    "combinations_json",
    "combinations_of",
    "combinations_text",
    "identifiable_combinations",
    "widened_range",
]

#: A readable combination may spread over D at most this many times its full direction.
READABLE_SPREAD = 1.25


@dataclass
class Combination:
    """One direction in the box-normalised gains and what D says about it.

    Attributes
    ----------
    loadings : dict of str to float
        Gain name -> coefficient on its z = (x - low)/(high - low); a unit vector over the
        gains listed (the others weigh 0), largest absolute coefficient first.
    range : (float, float)
        Range of ``sum(loadings[g] * z[g])`` over D, widened to hold D's boundary (module
        docstring), in z (dimensionless: shares of the box sides).
    members_range : (float, float)
        The members' own [min, max] along it, in z (never wider than ``range``).
    width_fraction : float
        (hi - lo) of ``range``: a share of one box side (module docstring).
    verdict : {"identified", "weak", "not identified"}
    reason : str
        Why, in words.
    spread : float
        Weighted standard deviation over D along it, in z.
    margin_factor : float
        √(m + 2): the half-extent in standard deviations the range allows (module docstring).
    box_extent : (float, float)
        The box's extent along it, in z: (Σ min(v_i, 0), Σ max(v_i, 0)).
    per_unit : dict of str to float
        Gain name -> coefficient per unit of the gain (coefficient / (high - low)).
    lows : dict of str to float
        Gain name -> its box's low end, in its unit (z = (x - low)·per_unit/coefficient).
    units : dict of str to str
        Gain name -> unit.
    n_feasible : int
    thin : bool
        D holds fewer than ``n_needed`` members: at best "weak".
    n_needed : int
    """

    loadings: dict[str, float]
    range: tuple[float, float]
    members_range: tuple[float, float]
    width_fraction: float
    verdict: str
    reason: str = ""
    spread: float = math.nan
    margin_factor: float = math.nan
    box_extent: tuple[float, float] = (0.0, 1.0)
    per_unit: dict[str, float] = field(default_factory=dict)
    lows: dict[str, float] = field(default_factory=dict)
    units: dict[str, str] = field(default_factory=dict)
    n_feasible: int = 0
    thin: bool = False
    n_needed: int = 0

    @property
    def identified(self) -> bool:
        """Whether the verdict is ``"identified"``."""
        return self.verdict == "identified"

    def value_of(self, x: Mapping[str, float]) -> float:
        """This combination of a vector given in the gains' own units (e.g. a twin's truth).

        Parameters
        ----------
        x : mapping of str to float
            Gain name -> value in its unit (every gain of :attr:`loadings`).

        Returns
        -------
        float
            ``sum(per_unit[g] * (x[g] - lows[g]))``, in z.
        """
        return float(sum(c * (float(x[g]) - self.lows[g]) for g, c in self.per_unit.items()))

    def text(self, digits: int = 2, terms: int = 6) -> str:
        """The combination in words, on the box-normalised gains: ``"+0.71 z(x1) +0.71 z(x2)"``
        (z(g) = (g - low)/(high - low)), the ``terms`` largest coefficients first and the
        count and size of the rest (:meth:`to_dict` has them all).

        Parameters
        ----------
        digits : int
            Decimals of the coefficients.
        terms : int
            Terms written out.

        Returns
        -------
        str
        """
        items = list(self.loadings.items())
        out = " ".join(f"{c:+.{digits}f} z({g})" for g, c in items[:terms])
        rest = items[terms:]
        if rest:
            big = max(abs(c) for _, c in rest)
            out += f" ... + {len(rest)} smaller terms (|coefficient| <= {big:.{digits}f})"
        return out

    def own_units(self) -> tuple[dict[str, float], tuple[float, float], str]:
        """The combination read in the gains' own units, scaled so that the leading gain's
        coefficient is 1: ``(coefficients, range, unit)`` with ``sum(coefficients[g] * x[g])``
        within ``range`` over D, in the leading gain's unit (a coefficient carries the unit
        of the leading gain over that of its own gain)."""
        lead = next(iter(self.per_unit))
        a0 = self.per_unit[lead]
        off = sum(c * self.lows[g] for g, c in self.per_unit.items())
        coeffs = {g: c / a0 for g, c in self.per_unit.items()}
        lo, hi = sorted(((self.range[0] + off) / a0, (self.range[1] + off) / a0))
        return coeffs, (lo, hi), self.units.get(lead, "")

    def own_units_text(self, digits: int = 3, terms: int = 6) -> str:
        """:meth:`own_units` in words: ``"x1 + 1·x2 in [0.889, 0.971] m"`` (the ``terms``
        largest terms in z first, and the count of the rest).

        Parameters
        ----------
        digits : int
            Significant digits of the coefficients (one more for the range).
        terms : int
            Terms written out.

        Returns
        -------
        str
        """
        coeffs, (lo, hi), unit = self.own_units()
        items = list(coeffs.items())
        parts = []
        for k, (g, c) in enumerate(items[:terms]):
            parts.append(g if k == 0 else f"{'-' if c < 0 else '+'} {abs(c):.{digits}g}·{g}")
        if len(items) > terms:
            parts.append(f"+ {len(items) - terms} smaller terms")
        u = "" if unit in ("", "-") else f" {unit}"
        return f"{' '.join(parts)} in [{lo:.{digits + 1}g}, {hi:.{digits + 1}g}]{u}"

    def to_dict(self) -> dict[str, Any]:
        """This combination as one entry of ``vectorid identifiability --combinations --json``
        (``range`` in z, the projection's units)."""
        return {
            "loadings": {g: float(c) for g, c in self.loadings.items()},
            "range": [float(self.range[0]), float(self.range[1])],
            "members_range": [float(self.members_range[0]), float(self.members_range[1])],
            "width_fraction": float(self.width_fraction),
            "verdict": self.verdict,
            "reason": self.reason,
            "spread": float(self.spread),
            "margin_factor": float(self.margin_factor),
            "box_extent": [float(self.box_extent[0]), float(self.box_extent[1])],
            "per_unit": {g: float(c) for g, c in self.per_unit.items()},
            "own_units": {
                "coefficients": {g: float(c) for g, c in self.own_units()[0].items()},
                "range": [float(v) for v in self.own_units()[1]],
                "unit": self.own_units()[2],
            },
            "lows": {g: float(v) for g, v in self.lows.items()},
            "units": dict(self.units),
            "n_feasible": int(self.n_feasible),
            "thin": bool(self.thin),
            "n_needed": int(self.n_needed),
        }


#: Most members whose moments give the directions and the margins (evenly spread over the
#: trial order; a weighted covariance and kurtosis from 50,000 are as good as from a million).
STATS_MEMBERS = 50_000


def _wstats(t: np.ndarray, w: np.ndarray) -> tuple[float, float, float, float]:
    """Weighted mean, standard deviation, excess kurtosis of ``t`` (weights sum to 1) and the
    kurtosis's asymptotic variance times n (delta method, symmetric terms:
    [(μ8 - μ4²)/μ2⁴ - 4μ4(μ6 - μ4μ2)/μ2⁵ + 4μ4²(μ4 - μ2²)/μ2⁶]; 24 for a normal density)."""
    mu = float(w @ t)
    d = t - mu
    d2 = d * d
    m2 = float(w @ d2)
    if m2 <= 0:
        return mu, 0.0, 0.0, 24.0
    m4, m6, m8 = float(w @ d2**2), float(w @ d2**3), float(w @ d2**4)
    v = (m8 - m4**2) / m2**4 - 4 * m4 * (m6 - m4 * m2) / m2**5 + 4 * m4**2 * (m4 - m2**2) / m2**6
    return mu, math.sqrt(m2), m4 / m2**2 - 3.0, max(v, 0.0)


def _dimension(kurt: float, nvar: float, ess: float, pmax: float) -> float:
    """The ellipsoid dimension m whose projections have excess kurtosis -6/(m + 4), from a
    kurtosis estimate moved two standard errors toward zero, within [1, pmax]."""
    k_up = kurt + 2.0 * math.sqrt(nvar / max(ess, 1.0))
    if k_up >= -6.0 / (pmax + 4.0):
        return pmax
    return min(max(-6.0 / k_up - 4.0, 1.0), pmax)


def widened_range(
    t: np.ndarray,
    w: np.ndarray | None = None,
    *,
    p: int | None = None,
    extent: tuple[float, float] = (-math.inf, math.inf),
    m_floor: float = 1.0,
) -> tuple[tuple[float, float], float]:
    """The range along one direction that holds D's boundary (module docstring).

    Parameters
    ----------
    t : (n,) ndarray
        D's members projected on the direction (any unit; the range comes back in it).
    w : (n,) ndarray, optional
        Their weights (every member once when None).
    p : int, optional
        Largest ellipsoid dimension allowed (default: no bound but 1e6).
    extent : (float, float)
        Where the set cannot reach beyond (the box's extent along the direction).
    m_floor : float
        Least ellipsoid dimension to assume (the pooled estimate over D's narrow
        directions, :func:`combinations_of`).

    Returns
    -------
    ((float, float), float)
        The range, and the margin factor √(m + 2) used.
    """
    t = np.asarray(t, dtype=float)
    ww = np.ones(len(t)) if w is None else np.asarray(w, dtype=float)
    ww = ww / ww.sum()
    mu, sd, kurt, nvar = _wstats(t, ww)
    ess = 1.0 / float(ww @ ww)
    pmax = float(p) if p else 1e6
    m = max(_dimension(kurt, nvar, ess, pmax), min(m_floor, pmax))
    f = math.sqrt(m + 2.0)
    lo = min(float(t.min()), mu - f * sd)
    hi = max(float(t.max()), mu + f * sd)
    return (max(lo, extent[0]), min(hi, extent[1])), f


def _judge(
    width: float,
    rng: tuple[float, float],
    extent: tuple[float, float],
    nd: int,
    limited: bool,
    t_id: float,
    t_weak: float,
    min_feasible: int,
) -> tuple[str, str]:
    if not limited:
        return (
            "not identified",
            "no criteria constraint is in force, so D is every trial and says nothing",
        )
    ew = extent[1] - extent[0]
    edge = []
    if rng[0] - extent[0] <= 0.02 * ew:
        edge.append("low")
    if extent[1] - rng[1] <= 0.02 * ew:
        edge.append("high")
    pct = f"D spans {width:.0%} of a box side along it"
    if width > t_weak:
        return "not identified", pct
    if width <= t_id and nd >= min_feasible and not edge:
        return "identified", pct
    if edge:
        side = " and ".join(edge)
        return "weak", f"{pct} but reaches the box's {side} end along it"
    if nd < min_feasible:
        return (
            "weak",
            f"{pct}, but D holds only {nd} members, fewer than the {min_feasible} needed "
            "to show its spread",
        )
    return "weak", pct


def combinations_of(
    Z: np.ndarray,
    names: Sequence[str],
    weights: np.ndarray | None = None,
    *,
    identified: float = 0.25,
    weak: float = 0.6,
    min_feasible: int | None = None,
    limited: bool = True,
    include_all: bool = False,
    spans: Sequence[float] | None = None,
    lows: Sequence[float] | None = None,
    units: Sequence[str] | None = None,
) -> list[Combination]:
    """The combinations of D's members given in box-normalised coordinates.

    Parameters
    ----------
    Z : (n, p) ndarray
        D's members, each gain as z = (x - low)/(high - low) (dimensionless).
    names : sequence of str
        The p gains' names.
    weights : (n,) ndarray, optional
        The members' weights as a sample of the uniform density on D (None: once each).
    identified, weak : float
        Thresholds on the width fraction, as for a gain.
    min_feasible : int, optional
        Members D needs to show a spread (default max(10, 2p + 1)); fewer: at best "weak".
    limited : bool
        Whether a criteria constraint is in force (without one every verdict is "not
        identified").
    include_all : bool
        Return every direction, not only the identified and weak ones.
    spans, lows, units : sequence, optional
        Each gain's box width (high - low) and low end in its unit, and the unit, for
        :attr:`Combination.per_unit` (default 1, 0 and "": z itself).

    Returns
    -------
    list of Combination
        Narrowest first.
    """
    Z = np.asarray(Z, dtype=float)
    n, p = Z.shape
    names = list(names)
    if min_feasible is None:
        min_feasible = thin_threshold(p)
    if n < 2:
        return []
    w = np.ones(n) if weights is None else np.asarray(weights, dtype=float)
    keep = np.isfinite(Z).all(axis=1) & np.isfinite(w) & (w >= 0)
    Z, w = Z[keep], w[keep]
    n = len(Z)
    if n < 2 or w.sum() <= 0:
        return []
    # the directions and the moments come from at most STATS_MEMBERS members, spread evenly
    # over the trial order (a million-trial store answers a limit change in the UI at once);
    # the ranges still hold every member (their extremes are taken over all of them)
    sub = np.linspace(0, n - 1, STATS_MEMBERS).round().astype(int) if n > STATS_MEMBERS else None
    Zs, ws = (Z, w) if sub is None else (Z[sub], w[sub])
    if ws.sum() <= 0:
        Zs, ws, sub = Z, w, None
    wn = ws / ws.sum()
    mu = wn @ Zs
    D = Zs - mu
    cov = (D * wn[:, None]).T @ D
    evals, evecs = np.linalg.eigh(cov)
    spans = np.ones(p) if spans is None else np.asarray(spans, dtype=float)
    lows = np.zeros(p) if lows is None else np.asarray(lows, dtype=float)
    units = [""] * p if units is None else list(units)
    tol = 1e-12 * max(float(evals.max()), 1e-300)
    ess = 1.0 / float(wn @ wn)
    found = []  # (readable direction, projections, box extent along it)
    seen: list[np.ndarray] = []
    for i in np.argsort(evals):
        if evals[i] <= tol and n <= p:
            continue  # a direction the few members cannot span: no spread to read
        v = evecs[:, i]
        full_sd = math.sqrt(max(float(evals[i]), 0.0))
        order = np.argsort(-np.abs(v), kind="stable")
        u = v
        for k in range(1, p + 1):
            u = np.zeros(p)
            u[order[:k]] = v[order[:k]]
            u /= np.linalg.norm(u)
            sd_k = math.sqrt(max(float(u @ cov @ u), 0.0))
            if sd_k <= READABLE_SPREAD * full_sd + 1e-15:
                break
        if u[order[0]] < 0:
            u = -u
        if any(abs(float(u @ s)) > 0.95 for s in seen):
            continue  # the same readable combination as a narrower direction's
        seen.append(u)
        t = Zs @ u
        extent = (float(np.minimum(u, 0).sum()), float(np.maximum(u, 0).sum()))
        found.append((u, t, extent))
    # D's ellipsoid dimension pooled over the directions its members keep off the box (there
    # the criteria, not the box, bound D): one m for all of them, so that a direction whose
    # own kurtosis happens to read flatter still gets the margin D's shape calls for
    kurts, nvars = [], []
    for _, t, extent in found:
        ew = extent[1] - extent[0]
        if t.min() - extent[0] > 0.02 * ew and extent[1] - t.max() > 0.02 * ew:
            _, _, kk, nv = _wstats(t, wn)
            kurts.append(kk)
            nvars.append(nv)
    m_pool = (
        _dimension(float(np.mean(kurts)), float(np.mean(nvars)), ess, float(p)) if kurts else 1.0
    )
    out: list[Combination] = []
    for u, t, extent in found:
        rng, f = widened_range(t, ws, p=p, extent=extent, m_floor=m_pool)
        if sub is not None:  # every member inside, not only those the moments came from
            t_all = Z @ u
            lo_all, hi_all = float(t_all.min()), float(t_all.max())
            rng = (max(min(rng[0], lo_all), extent[0]), min(max(rng[1], hi_all), extent[1]))
        else:
            lo_all, hi_all = float(t.min()), float(t.max())
        width = rng[1] - rng[0]
        verdict, reason = _judge(
            width, rng, extent, n, limited, identified, weak, int(min_feasible)
        )
        if not include_all and verdict == "not identified":
            continue
        order = np.argsort(-np.abs(u), kind="stable")
        idx = [j for j in order if u[j] != 0.0]
        out.append(
            Combination(
                loadings={names[j]: float(u[j]) for j in idx},
                range=rng,
                members_range=(lo_all, hi_all),
                width_fraction=float(width),
                verdict=verdict,
                reason=reason,
                spread=float(math.sqrt(max(float(wn @ (t - wn @ t) ** 2), 0.0))),
                margin_factor=f,
                box_extent=extent,
                per_unit={names[j]: float(u[j] / spans[j]) for j in idx},
                lows={names[j]: float(lows[j]) for j in idx},
                units={names[j]: str(units[j] or "") for j in idx},
                n_feasible=n,
                thin=n < min_feasible,
                n_needed=int(min_feasible),
            )
        )
    out.sort(key=lambda c: c.width_fraction)
    return out


def _box(a: Analysis) -> tuple[np.ndarray, np.ndarray]:
    """Each variable's box (low, high) in its unit, widened to any trial drawn outside it,
    as :func:`vectorid.analysis.identifiability.identifiability` takes it."""
    X = a.trials.X
    lo, hi = [], []
    for j, v in enumerate(a.spec.space):
        col = X[:, j] if len(X) else np.zeros(0)
        fin = col[np.isfinite(col)]
        lj = float(getattr(v, "low", fin.min() if len(fin) else 0.0))
        hj = float(getattr(v, "high", fin.max() if len(fin) else 1.0))
        if len(fin):
            lj, hj = min(lj, float(fin.min())), max(hj, float(fin.max()))
        lo.append(lj)
        hi.append(hj if hj > lj else lj + 1.0)
    return np.array(lo), np.array(hi)


def identifiable_combinations(
    a: Analysis,
    *,
    identified: float = 0.25,
    weak: float = 0.6,
    min_feasible: int | None = None,
    include_all: bool = False,
) -> list[Combination]:
    """The combinations of gains D pins down (see the module docstring).

    Parameters
    ----------
    a : Analysis
        Trials, the constraints in force and the sampler's weighting.
    identified, weak : float
        Thresholds on the width fraction (a share of a box side), as for a gain.
    min_feasible : int, optional
        Members D needs to show a spread (default max(10, 2p + 1)).
    include_all : bool
        Return every principal direction, the not-identified ones too.

    Returns
    -------
    list of Combination
        Narrowest first; empty when D holds fewer than two members.

    Examples
    --------
    Only x1 + x2 is determined (the criterion sees nothing else), in a box of three gains:

    >>> import os, tempfile
    >>> import numpy as np
    >>> from vectorid import Continuous, Criterion, Space, Study, StudySpec
    >>> from vectorid.analysis.combinations import identifiable_combinations
    >>> def model(X):
    ...     return np.abs(X[:, :1] + X[:, 1:2] - 1.0), np.empty((len(X), 0))
    >>> space = Space([Continuous(f"x{i}", 0.0, 1.0) for i in (1, 2, 3)])
    >>> spec = StudySpec("sum", model, space, (Criterion("f", limit=0.03),), trials=2048, seed=1)
    >>> with Study.create(spec, os.path.join(tempfile.mkdtemp(), "s.db")) as study:
    ...     _ = study.run(executor="inline")
    ...     combos = identifiable_combinations(study.analysis())
    >>> [(c.verdict, sorted(c.loadings)) for c in combos]
    [('identified', ['x1', 'x2'])]
    >>> sorted((g, round(v, 2)) for g, v in combos[0].loadings.items())
    [('x1', 0.71), ('x2', 0.71)]
    """
    mask = a.feasible
    lows, highs = _box(a)
    spans = highs - lows
    Z = (a.trials.X[mask] - lows) / spans
    w = trial_weights(a, mask)
    if w is not None and not (np.isfinite(w).all() and w.sum() > 0):
        w = None
    limited = any(b.name in a.crit_names for b in a.active_bounds())
    space = a.spec.space
    return combinations_of(
        Z,
        space.names,
        w,
        identified=identified,
        weak=weak,
        min_feasible=min_feasible,
        limited=limited,
        include_all=include_all,
        spans=spans,
        lows=lows,
        units=[getattr(v, "unit", "") or "" for v in space],
    )


def combinations_json(combos: Sequence[Combination]) -> dict[str, Any]:
    """``{"combinations": [...], "range_units": ...}`` for ``--json``."""
    return {
        "combinations": [c.to_dict() for c in combos],
        "range_units": "z = (x - low)/(high - low) per gain: shares of the box sides",
    }


def combinations_text(
    combos: Sequence[Combination], n_feasible: int | None = None, limited: bool = True
) -> str:
    """The combinations for people: one block each, narrowest first, with the range in z,
    the verdict and the reading in the gains' own units; a plain sentence when there is none.

    Parameters
    ----------
    combos : sequence of Combination
        From :func:`identifiable_combinations`.
    n_feasible : int, optional
        Members of D (said when D is too small to have combinations).
    limited : bool
        Whether a criteria constraint is in force (without one D says nothing).

    Returns
    -------
    str
    """
    if n_feasible is not None and n_feasible < 2:
        return (
            f"combinations: D holds {n_feasible} member(s); a combination needs at least two "
            "to show a spread"
        )
    if not limited:
        return (
            "combinations: none: no criteria constraint is in force, so D is every trial and "
            "says nothing (state limits, or --limit)"
        )
    if not combos:
        return (
            "combinations: none is identified or weak: no direction in the gains along which "
            "D is narrower than the 'weak' share of a box side"
        )
    lines = [
        "combinations D pins down (z(g) = (g - low)/(high - low): each gain as a share of its "
        "box; range and width in z, shares of a box side; ranges widened to hold D's boundary, "
        "docs/identification.md):"
    ]
    for k, c in enumerate(combos, 1):
        lines.append(f"  c{k}  {c.text()}")
        lines.append(
            f"      range [{c.range[0]:.4g}, {c.range[1]:.4g}] (members [{c.members_range[0]:.4g}, "
            f"{c.members_range[1]:.4g}]), width {c.width_fraction:.1%} of a box side"
        )
        lines.append(f"      verdict {c.verdict}: {c.reason}")
        lines.append(f"      in the gains' units: {c.own_units_text()}")
    n_id = sum(c.verdict == "identified" for c in combos)
    lines.append(f"  {n_id} identified, {len(combos) - n_id} weak")
    return "\n".join(lines)
