"""Double tuning (seed 001, Sec. VI and Fig. 5): propose a narrower box Π₂ from the trials
in the feasible set D (or in the Edgeworth–Pareto set), and continue the study in a new
sample stage that keeps drawing from the same Sobol sequence.

The rule (one variable at a time; "basis" is D, or the Pareto set with ``basis="pareto"``)
--------------------------------------------------------------------------------------------
1. Quantile envelope: ``lo = Q_q(basis values)``, ``hi = Q_{1-q}(basis values)``
   (``q = quantile``, default 0.05; ``q = 0`` gives the basis's min and max); on a
   sequential store the quantiles use the trials' importance weights
   (:mod:`vectorid.analysis.weights`).
2. Margin: widen both sides by ``margin · (hi − lo)`` (default 0.1).
3. Never cut a Pareto trial: ``lo = min(lo, min over Pareto)``, ``hi = max(hi, max over
   Pareto)``.
4. Clip to the hull of the study box Π and every sample stage's box (where the trials were
   drawn, so step 3 survives clipping).
5. Minimum width: a box narrower than ``min_width`` × the study box's width (default 0.02)
   is widened about its centre (shifted back inside the hull if needed; it only grows, so
   step 3 still holds).
6. Integer variables round outward; choice variables keep the values inside.
7. Explicit ``bounds`` given by the expert replace the proposal for those variables (this is
   how a box is moved or widened, as seed 001 did for x6: [0, 0.6] → [0.3, 1.0]); Pareto
   trials such an override leaves outside are counted in ``pareto_outside``.

Changing the box never deletes or re-runs a trial: the new stage only decides where the
next sequence indices are placed (``vectorid run STORE --trials N`` continues there).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import StudyDefinitionError, suggest
from ..space import Space
from ..store import Stage, Store
from .results import Analysis
from .weights import trial_weights, weighted_quantile

__all__ = ["RefineProposal", "propose_refine", "refine_history"]


@dataclass
class RefineProposal:
    """A proposed narrowed box.

    Attributes
    ----------
    old, new : Space
        The current box (latest sample stage) and the proposal.
    basis : str
        ``"feasible"`` or ``"pareto"``.
    quantile, margin, min_width : float
        Rule parameters (see the module docstring).
    n_basis : int
        Trials the envelope was taken from.
    feasible_inside : int
        Feasible trials inside the new box (of ``n_feasible``).
    n_feasible, n_pareto : int
    pareto_outside : int
        Pareto trials outside the new box (0 unless an explicit bound cut them off).
    overrides : dict
        Explicit bounds by variable name.
    limits : list of str
        The constraints in force when the proposal was made.
    """

    old: Space
    new: Space
    basis: str
    quantile: float
    margin: float
    min_width: float
    n_basis: int
    feasible_inside: int
    n_feasible: int
    n_pareto: int
    pareto_outside: int
    overrides: dict[str, tuple[float, float]] = field(default_factory=dict)
    limits: list[str] = field(default_factory=list)

    @property
    def width_ratio(self) -> np.ndarray:
        """New width / old width per variable (p,)."""
        old = self.old.highs - self.old.lows
        return np.where(old > 0, (self.new.highs - self.new.lows) / np.where(old > 0, old, 1), 1.0)

    @property
    def volume_ratio(self) -> float:
        """Product of the width ratios: the fraction of the old box the new one spans."""
        return float(np.prod(self.width_ratio))

    def rows(self) -> list[dict[str, Any]]:
        """Per variable: old and new bounds and the width ratio."""
        ratio = self.width_ratio
        return [
            {
                "name": o.name,
                "old_low": float(o.low),
                "old_high": float(o.high),
                "new_low": float(n.low),
                "new_high": float(n.high),
                "width_ratio": float(ratio[j]),
                "override": o.name in self.overrides,
            }
            for j, (o, n) in enumerate(zip(self.old, self.new))
        ]

    def note(self) -> str:
        """The stage note written by :func:`vectorid.workflows.extra.apply_refine`."""
        lim = ",".join(s.replace(" ", "") for s in self.limits) or "study"
        return (
            f"refine basis={self.basis} quantile={self.quantile:g} margin={self.margin:g} "
            f"limits={lim} n_basis={self.n_basis} volume_ratio={self.volume_ratio:.4g}"
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "basis": self.basis,
            "quantile": self.quantile,
            "margin": self.margin,
            "min_width": self.min_width,
            "n_basis": self.n_basis,
            "n_feasible": self.n_feasible,
            "feasible_inside": self.feasible_inside,
            "n_pareto": self.n_pareto,
            "pareto_outside": self.pareto_outside,
            "volume_ratio": self.volume_ratio,
            "limits": self.limits,
            "variables": self.rows(),
            "box": self.new.to_list(),
        }


def current_box(
    stages: Sequence[Stage] | None, fallback: Space
) -> tuple[Space, np.ndarray, np.ndarray]:
    """The latest sample stage's box, and the hull (lows, highs) of the study box and every
    sample stage's box."""
    sample = [s for s in (stages or []) if s.kind == "sample"]
    current = sample[-1].space if sample else fallback
    lows, highs = fallback.lows.copy(), fallback.highs.copy()
    for s in sample:
        lows = np.minimum(lows, s.space.lows)
        highs = np.maximum(highs, s.space.highs)
    return current, lows, highs


def propose_refine(
    a: Analysis,
    stages: Sequence[Stage] | None = None,
    *,
    basis: str = "feasible",
    quantile: float = 0.05,
    margin: float = 0.1,
    min_width: float = 0.02,
    bounds: Mapping[str, tuple[float, float]] | None = None,
) -> RefineProposal:
    """Propose a narrowed box by the rule of the module docstring.

    Parameters
    ----------
    a : Analysis
        Trials and sets under the constraints the expert chose.
    stages : sequence of Stage, optional
        ``Store.stages()``: the latest sample stage's box is the "old" box (default: the
        study box).
    basis : {"feasible", "pareto"}
    quantile : float in [0, 0.5)
    margin : float >= 0
        Fraction of the envelope's width added on each side.
    min_width : float in (0, 1]
        Smallest width, as a fraction of the study box's width.
    bounds : mapping name -> (low, high), optional
        Explicit bounds overriding the proposal.

    Raises
    ------
    StudyDefinitionError
        When the basis set is empty (relax a criteria constraint) or an argument is out of
        range.
    """
    if basis not in ("feasible", "pareto"):
        raise StudyDefinitionError(
            "basis", f"expected 'feasible' or 'pareto', got {basis!r}", "use --pareto or omit it"
        )
    if not 0.0 <= quantile < 0.5:
        raise StudyDefinitionError(
            "--quantile", f"expected 0 <= q < 0.5, got {quantile}", "e.g. --quantile 0.05"
        )
    if not (margin >= 0.0 and math.isfinite(margin)):
        raise StudyDefinitionError(
            "--margin", f"expected a finite margin >= 0, got {margin}", "e.g. --margin 0.1"
        )
    if not 0.0 < min_width <= 1.0:
        raise StudyDefinitionError(
            "min_width", f"expected 0 < min_width <= 1, got {min_width}", "e.g. 0.02"
        )
    spec_space = a.spec.space
    bounds = dict(bounds or {})
    for name, pair in bounds.items():
        if name not in spec_space.names:
            raise StudyDefinitionError(
                "--bound", f"unknown variable {name!r}", suggest(name, spec_space.names)
            )
        lo, hi = float(pair[0]), float(pair[1])
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise StudyDefinitionError(
                "--bound", f"expected finite LO < HI for {name}, got {lo} {hi}", "e.g. x6=0.3:1.0"
            )
        bounds[name] = (lo, hi)
    mask = a.pareto if basis == "pareto" else a.feasible
    if not mask.any():
        raise StudyDefinitionError(
            "refine",
            f"the {basis} set is empty under the constraints in force "
            f"({', '.join(str(b) for b in a.active_bounds()) or 'none'})",
            "relax a criteria constraint (`vectorid pareto STORE` says which empties D)",
        )
    old, hull_lo, hull_hi = current_box(stages, spec_space)
    X = a.trials.X
    B = X[mask]
    wb = trial_weights(a, mask)  # a sequential store's trials are not uniform in the box
    P = X[a.pareto]
    new_bounds: dict[str, tuple[float, float]] = {}
    for j, var in enumerate(spec_space):
        v = B[:, j]
        lo, hi = (float(x) for x in weighted_quantile(v, [quantile, 1.0 - quantile], wb))
        pad = margin * (hi - lo)
        lo, hi = lo - pad, hi + pad
        if len(P):
            lo, hi = min(lo, float(P[:, j].min())), max(hi, float(P[:, j].max()))
        hlo, hhi = float(hull_lo[j]), float(hull_hi[j])
        lo, hi = max(lo, hlo), min(hi, hhi)
        need = min(min_width * (var.high - var.low), hhi - hlo)
        if hi - lo < need:  # widen about the centre, shifted back inside the hull
            c = 0.5 * (lo + hi)
            lo, hi = c - 0.5 * need, c + 0.5 * need
            if lo < hlo:
                lo, hi = hlo, hlo + need
            if hi > hhi:
                lo, hi = hhi - need, hhi
        new_bounds[var.name] = (lo, hi)
    new_bounds.update(bounds)
    new = spec_space.with_bounds(new_bounds)
    inside = new.contains(X)
    return RefineProposal(
        old=old,
        new=new,
        basis=basis,
        quantile=float(quantile),
        margin=float(margin),
        min_width=float(min_width),
        n_basis=int(mask.sum()),
        feasible_inside=int((inside & a.feasible).sum()),
        n_feasible=a.n_feasible,
        n_pareto=a.n_pareto,
        pareto_outside=int((~inside & a.pareto).sum()),
        overrides=bounds,
        limits=[str(b) for b in a.active_bounds()],
    )


def refine_history(store: Store) -> list[dict[str, Any]]:
    """The sample stages in order, with their boxes, trial counts and the variables whose
    bounds changed from the previous sample stage."""
    out: list[dict[str, Any]] = []
    prev: Space | None = None
    for s in store.stages():
        if s.kind != "sample":
            continue
        changed = []
        if prev is not None:
            for a, b in zip(prev, s.space):
                if (a.low, a.high) != (b.low, b.high):
                    changed.append(
                        {
                            "name": a.name,
                            "old": [float(a.low), float(a.high)],
                            "new": [float(b.low), float(b.high)],
                        }
                    )
        out.append(
            {
                "stage": s.stage,
                "start_seq": s.start_seq,
                "n": store.count(s.stage),
                "note": s.note,
                "box": s.space.to_list(),
                "changed": changed,
            }
        )
        prev = s.space
    return out
