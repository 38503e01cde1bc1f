"""The reduction of seed 000 (Fig. 14): which design variables to fix and which to tie, read
from the correlation and sensitivity of a study over its feasible set D.

After a study of every gain, seed 000 fixes the gains the results do not depend on and ties
pairs that move together over D, and identifies the reduced set again. :func:`propose_reduction`
makes that proposal from an analysis and its identifiability verdicts, with each rule stated:

* **fix** (at its nominal value) a variable that is not identified, has little influence on the
  chosen criteria (max |Spearman ρ| over the successful trials below ``rho_below``) and on which
  D does not depend (Kolmogorov–Smirnov test of its values in D against the rest, p >=
  ``p_at_least``);
* **tie** the pairs correlated over D (|r| >= ``tie_at``, strongest first, each variable in one
  pair at most; only with ``min_feasible`` trials in D): the variable D depends on more (larger
  KS statistic) stays free, the other follows it. A follower is fixed at D's median only where
  its verdict calls it identified; fixing it at a value the data do not determine would bias
  the one it follows, so there both stay free (the model cannot express the tie itself).

Medians over D are importance-weighted on a sequential store. The caller prints and runs the
reduced study (the parafoil demo's stage 3).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..analysis.correlation import correlation_of
from ..analysis.results import Analysis
from ..analysis.sensitivity import Sensitivity, sensitivity
from ..analysis.weights import trial_weights, weighted_quantile

__all__ = ["Reduction", "Tie", "propose_reduction"]


@dataclass(frozen=True)
class Tie:
    """One tied pair: ``follower`` follows ``keep`` (correlation ``r`` over D);
    ``identified``: the follower's verdict, which decides whether it is fixed at D's median."""

    keep: str
    follower: str
    r: float
    identified: bool


@dataclass
class Reduction:
    """A fix/tie proposal (see the module docstring).

    Attributes
    ----------
    sensitivity : Sensitivity
        Spearman's ρ of every variable with every criterion, and the KS test over D.
    influence : (p,) float
        Max |ρ| of each variable (order of ``sensitivity.params``) over the chosen criteria.
    insensitive : list of str
        Variables fixed at their nominal value.
    pairs : list of dict
        Correlations over D (``a``, ``b``, ``r``), strongest first (empty when D holds fewer
        than 3 trials).
    ties : list of Tie
    medians : dict
        Variable -> its median over D (each variable's unit; empty when D is empty).
    fixed : dict
        Variable -> the value it is fixed at: nominal for the insensitive ones, D's median for
        an identified follower.
    """

    sensitivity: Sensitivity
    influence: NDArray[np.float64]
    insensitive: list[str]
    pairs: list[dict[str, Any]]
    ties: list[Tie] = field(default_factory=list)
    medians: dict[str, float] = field(default_factory=dict)
    fixed: dict[str, float] = field(default_factory=dict)

    def kept(self, names: Sequence[str]) -> list[str]:
        """``names`` without the fixed ones (the reduced set's variables, in order)."""
        return [n for n in names if n not in self.fixed]


def propose_reduction(
    a: Analysis,
    verdicts: Sequence[Any],
    nominal: Mapping[str, float],
    *,
    criteria: Sequence[str] | None = None,
    keep: Sequence[str] = (),
    rho_below: float = 0.1,
    p_at_least: float = 0.05,
    correlation_at: float = 0.25,
    tie_at: float = 0.4,
    min_feasible: int = 30,
) -> Reduction:
    """Seed 000's fix/tie proposal from an analysis and its identifiability verdicts.

    Parameters
    ----------
    a : Analysis
        The study of every variable, under the limits in force.
    verdicts : sequence of ParameterVerdict
        Its identifiability verdicts (:func:`vectorid.analysis.identifiability`).
    nominal : mapping
        Variable -> the value a fixed variable takes (its unit).
    criteria : sequence of str, optional
        The criteria whose influence counts (default: all; the parafoil demo takes the
        trajectory criteria, not the spectral peaks).
    keep : sequence of str
        Variables never fixed (e.g. those an earlier stage narrowed: a narrow box, not a lack
        of influence, makes their ρ small).
    rho_below, p_at_least : float
        The fix rule: max |ρ| below ``rho_below`` and KS p-value at least ``p_at_least``.
    correlation_at : float
        |r| at which a pair over D is listed.
    tie_at : float
        |r| at which a pair is tied.
    min_feasible : int
        Fewest trials in D for a tie (fewer cannot show a correlation).

    Returns
    -------
    Reduction
    """
    sens = sensitivity(a)
    cols = list(range(len(sens.criteria)))
    if criteria is not None:
        cols = [sens.criteria.index(c) for c in criteria]
    influence = np.abs(sens.spearman[:, cols]).max(axis=1)
    judged = {v.name for v in verdicts if v.verdict != "not identified"}
    insensitive = [
        n
        for n, r, p in zip(sens.params, influence, sens.ks_pvalue)
        if n not in keep and n not in judged and r < rho_below and not p < p_at_least
    ]
    corr = (
        correlation_of(a, "feasible", threshold=correlation_at, spread_threshold=0.0)
        if a.n_feasible >= 3
        else None
    )
    pairs = corr.pairs if corr is not None else []
    ks = dict(zip(sens.params, sens.ks))
    identified = {v.name: bool(v.identified) for v in verdicts}
    ties: list[Tie] = []
    used = set(insensitive)
    for pr in pairs if a.n_feasible >= min_feasible else []:
        x, y = pr["a"], pr["b"]
        if abs(pr["r"]) < tie_at or x in used or y in used:
            continue
        stay, follower = (x, y) if ks[x] >= ks[y] else (y, x)
        ties.append(Tie(stay, follower, float(pr["r"]), identified.get(follower, False)))
        used.add(follower)
    medians: dict[str, float] = {}
    if a.n_feasible:  # D's median, importance-weighted on a sequential store
        w = trial_weights(a, a.feasible)
        Xd = a.trials.X[a.feasible]
        names = a.spec.space.names
        medians = {n: float(weighted_quantile(Xd[:, j], 0.5, w)) for j, n in enumerate(names)}
    fixed = {n: float(nominal[n]) for n in insensitive}
    for t in ties:
        if t.identified:
            fixed[t.follower] = medians[t.follower]
    return Reduction(sens, influence, insensitive, pairs, ties, medians, fixed)
