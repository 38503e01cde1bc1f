"""Identifiability verdicts: which design variables the data determine, and within what range.

For each design variable, from the stored trials and the constraints in force (nothing is
re-run):

- **feasible** — its range [min, max] over the feasible set D; **pareto** — over the
  Edgeworth–Pareto set (a subset of D, so never wider); **box** — the study box Π (widened to
  any trial drawn outside it by a later stage);
- **constrained_by** — the constraints whose limit cuts its range: a criterion (or functional
  constraint) is listed when the variable's range over the trials that meet every *other*
  constraint is wider than over D by more than a quarter of D's width and 2 % of the box
  (removing that limit would let the variable spread); "earlier step's box" when D reaches
  an edge of a box inherited narrowed from an earlier step (``reference``);
- **verdict**, from the relative width w = width(feasible) / width(box):

  ============== ===========================================================================
  identified     w <= 0.25, D holds at least ``min_feasible`` trials (by default
                 max(10, 2p + 1) for p variables: see "thin sets" below), and D stays off
                 both box edges (a range that touches the box may continue beyond it)
  weak           0.25 < w <= 0.6; or w <= 0.25 but D touches a box edge (of the study
                 box, or of a refined stage's box that cut the range: the sampling, not the
                 data, ends it there) or is too small to show its spread
  not identified w > 0.6 (D covers most of the box), no criteria constraint is in force (D
                 is then every trial: nothing was asked of the data), or D is empty
  ============== ===========================================================================

**Thin sets.** A range [min, max] over N points understates the spread of the set they
were drawn from: N points drawn uniformly over an interval span on average (N - 1)/(N + 1)
of it, so 10 points show about 82 % of D's width along a variable (the shortfall is then
of the order of the spread between neighbouring trials) and 6 points only 71 %; and in p
dimensions a set needs at least 2p + 1 points to have one on each side of its centre along
every axis. Below ``min_feasible`` = max(10, 2p + 1) members the verdict is at best
"weak", ``thin`` is set, and the reason says how many members D holds and how many it
needs; the suggestion is more trials (``vectorid run STUDY --trials N``), the sequential
sampler (``[study] sampler = "sequential"``) or a refined box. (A larger number would be
safer still, e.g. 20 for 90 %; 10 is the least at which a range is more the data's than
the sampling's, and the two-step's quantile stand-in already aims at 20.)

The thresholds are arguments (``identified``, ``weak``). With noise-grounded limits
(:mod:`vectorid.identify.noise`) D is the set of vectors the data cannot tell from the truth,
so its spread is the answer's uncertainty; with the quantile stand-in it is only a ranking.
Each verdict carries a suggestion of what would identify the variable (another criterion, a
drop that excites it, a longer window, a wider box, more trials) and :meth:`value_text`, the
way every "chosen vector" prints it: a value only for an identified variable, otherwise its
feasible range with the verdict.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # pragma: no cover - for annotations only (results imports this module)
    from .results import Analysis

__all__ = ["VERDICTS", "ParameterVerdict", "identifiability", "thin_threshold", "verdicts_json"]

#: The verdicts, from best to worst.
VERDICTS = ("identified", "weak", "not identified")


def _g(v: float) -> str:
    return f"{v:.4g}"


@dataclass
class ParameterVerdict:
    """What the data say about one design variable (see the module docstring).

    Attributes
    ----------
    name : str
    verdict : {"identified", "weak", "not identified"}
    feasible, pareto : (float, float) or None
        Range over D and over the Pareto set (None when the set is empty).
    box : (float, float)
    constrained_by : list of str
        Constraints (criteria or functional) whose limit cuts the range.
    suggestion : str
        What would identify it (empty for an identified variable).
    reason : str
        Why this verdict, in words.
    unit, meaning : str
        For people: the variable's unit and what it is (e.g. "C_D base value (eq. 11)").
    width : float
        width(feasible) / width(box) (NaN when D is empty).
    n_feasible : int
    thin : bool
        D holds fewer members than ``n_needed``: too few to show its spread (the range is
        then a lower bound of the uncertainty, and the verdict at best "weak").
    n_needed : int
        Members of D the verdict needs to show a spread (``min_feasible``).
    """

    name: str
    verdict: str
    feasible: tuple[float, float] | None
    pareto: tuple[float, float] | None
    box: tuple[float, float]
    constrained_by: list[str] = field(default_factory=list)
    suggestion: str = ""
    reason: str = ""
    unit: str = ""
    meaning: str = ""
    width: float = math.nan
    n_feasible: int = 0
    thin: bool = False
    n_needed: int = 0

    @property
    def identified(self) -> bool:
        """Whether the verdict is ``"identified"``."""
        return self.verdict == "identified"

    def label(self) -> str:
        """``"x6 (C_D base value (eq. 11))"`` — the name with its meaning."""
        return f"{self.name} ({self.meaning})" if self.meaning else self.name

    def value_text(
        self, value: float | None = None, digits: int = 4, *, with_verdict: bool = True
    ) -> str:
        """How a chosen vector shows this variable: the value (with the feasible range) when
        identified; otherwise the feasible range (or the box) and the verdict, never a value
        alone.

        Parameters
        ----------
        value : float, optional
            The chosen vector's value of this variable, in its unit.
        digits : int
            Significant digits.
        with_verdict : bool
            ``False`` leaves the verdict out, for lines that print it already.

        Returns
        -------
        str
            E.g. ``"1.02 (feasible [0.98, 1.06])"`` or ``"feasible [0.2, 1.9] (weak)"``,
            with the unit.
        """
        u = f" {self.unit}" if self.unit and self.unit != "-" else ""
        rng = self.feasible if self.feasible is not None else self.box
        span = f"[{rng[0]:.{digits}g}, {rng[1]:.{digits}g}]{u}"
        if self.identified and value is not None:
            return f"{value:.{digits}g}{u} (feasible {span})"
        where = "feasible" if self.feasible is not None else "box"
        return f"{where} {span}" + (f" ({self.verdict})" if with_verdict else "")

    def to_dict(self) -> dict[str, Any]:
        """This verdict as one entry of ``vectorid identifiability --json``."""

        def pair(p: tuple[float, float] | None) -> list[float] | None:
            return None if p is None else [float(p[0]), float(p[1])]

        return {
            "name": self.name,
            "verdict": self.verdict,
            "feasible": pair(self.feasible),
            "pareto": pair(self.pareto),
            "box": pair(self.box),
            "constrained_by": list(self.constrained_by),
            "width": None if math.isnan(self.width) else float(self.width),
            "n_feasible": int(self.n_feasible),
            "thin": bool(self.thin),
            "n_needed": int(self.n_needed),
            "reason": self.reason,
            "suggestion": self.suggestion,
            "unit": self.unit,
            "meaning": self.meaning,
        }


def _col_ranges(XT: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per variable (row of ``XT``, the trials' parameters transposed): the smallest and
    largest finite value over the trials in ``mask`` (NaN where none)."""
    S = XT.compress(mask, axis=1)
    if not S.size:
        nan = np.full(XT.shape[0], np.nan)
        return nan, nan.copy()
    if not np.isfinite(S).all():
        S = np.where(np.isfinite(S), S, np.nan)
        return np.fmin.reduce(S, axis=1), np.fmax.reduce(S, axis=1)
    return S.min(axis=1), S.max(axis=1)


def _pair(lo: np.ndarray, hi: np.ndarray, j: int) -> tuple[float, float] | None:
    return None if np.isnan(lo[j]) else (float(lo[j]), float(hi[j]))


def identifiability(
    a: Analysis,
    *,
    identified: float = 0.25,
    weak: float = 0.6,
    min_feasible: int | None = None,
    meanings: Mapping[str, str] | None = None,
    hints: Mapping[str, str] | None = None,
    stages: Sequence[Any] | None = None,
    reference: Mapping[str, tuple[float, float]] | None = None,
    columns: np.ndarray | None = None,
) -> list[ParameterVerdict]:
    """A verdict per design variable of ``a``'s study (see the module docstring).

    Parameters
    ----------
    a : Analysis
        Trials and the constraints in force.
    identified, weak : float
        Thresholds on width(feasible) / width(box).
    min_feasible : int, optional
        Fewer trials in D cannot show its spread: at best "weak" (default max(10, 2p + 1)
        for p design variables; see "thin sets" in the module docstring).
    meanings : mapping, optional
        Variable name -> what it is (shown beside the name).
    hints : mapping, optional
        Variable name -> what would excite it (e.g. "a controlled drop"), used in the
        suggestion of a variable that is not identified.
    stages : sequence of Stage, optional
        ``Store.stages()``: a refined stage whose box edge cuts D's range (D's trials of that
        stage reach an edge that lies inside the study box) makes the range the sampling's,
        not the data's: at best "weak". Without it only the study box's edges are checked.
    reference : mapping, optional
        Variable name -> the range it was first given (e.g. step 1's box for a variable whose
        box step 2 inherited narrowed): widths and edges are judged against it, and where D
        reaches an edge of the narrower study box, "earlier step's box" is among the
        constraints that cut the range. Default: the study's ``[x-identifiability]
        reference`` table (the two-step writes it into step 2's study).
    columns : (p, n) float array, optional
        ``a.trials.X`` transposed, C-contiguous, where the caller keeps it across analyses of
        the same trials (the browser UI does: at 1e6 trials the transpose costs more than
        the verdicts); made here when not given.

    Returns
    -------
    list of ParameterVerdict
        In the order of the study's variables.
    """
    meanings = dict(meanings or {})
    hints = dict(hints or {})
    if reference is None:  # a study that inherited narrowed boxes says where they came from
        ref = a.spec.extra.get("x-identifiability", {})
        reference = ref.get("reference") if isinstance(ref, Mapping) else None
    space = a.spec.space
    if min_feasible is None:
        min_feasible = thin_threshold(len(space))
    X = a.trials.X
    bounds = a.active_bounds()
    crit_bounds = [b for b in bounds if b.name in a.crit_names]
    masks = {(b.name, b.side): a._bound_mask(b.name, b.side) for b in bounds}
    # ranges of every variable over D, the Pareto set and the trials meeting every
    # constraint but one: one pass over the chosen trials per set (about 10 ms at 1e5 trials)
    if columns is not None and np.shape(columns) == (len(space), len(X)):
        XT = np.ascontiguousarray(columns, dtype=float)
    else:
        XT = np.ascontiguousarray(X.T) if len(X) else np.zeros((len(space), 0))
    feas_r = _col_ranges(XT, a.feasible)
    par_r = _col_ranges(XT, a.pareto)
    others = {}  # D lies inside each of these sets: only the trials outside D are gathered
    for b in bounds:
        m = a.ok & ~a.feasible
        for key, mk in masks.items():
            if key != (b.name, b.side):
                m &= mk
        lo, hi = _col_ranges(XT, m)
        others[(b.name, b.side)] = (np.fmin(lo, feas_r[0]), np.fmax(hi, feas_r[1]))
    if len(X):
        all_lo, all_hi = np.fmin.reduce(XT, axis=1), np.fmax.reduce(XT, axis=1)
    out = []
    for j, v in enumerate(space):
        lo = float(getattr(v, "low", all_lo[j] if len(X) else 0.0))
        hi = float(getattr(v, "high", all_hi[j] if len(X) else 1.0))
        if len(X):
            lo, hi = min(lo, float(all_lo[j])), max(hi, float(all_hi[j]))
        study = (lo, hi)
        if reference and v.name in reference:
            lo = min(lo, float(reference[v.name][0]))
            hi = max(hi, float(reference[v.name][1]))
        W = hi - lo if hi > lo else 1.0
        feas = _pair(*feas_r, j) if a.n_feasible else None
        par = _pair(*par_r, j) if a.n_pareto else None
        width = math.nan if feas is None else (feas[1] - feas[0]) / W
        cut = []
        if feas is not None:
            wD = feas[1] - feas[0]
            for b in bounds:
                r = _pair(*others[(b.name, b.side)], j)
                if r is not None and (r[1] - r[0]) - wD > max(0.25 * wD, 0.02 * W):
                    if b.name not in cut:
                        cut.append(b.name)
            ws = study[1] - study[0]
            inherited = (study[0] > lo + 1e-9 * W and feas[0] - study[0] <= 0.02 * ws) or (
                study[1] < hi - 1e-9 * W and study[1] - feas[1] <= 0.02 * ws
            )
            if inherited:
                cut.append("earlier step's box")
        clipped = _clipped(a, j, stages, study) if feas is not None else ""
        verdict, reason, suggestion = _judge(
            v.name,
            width,
            feas,
            (lo, hi),
            a.n_feasible,
            bool(crit_bounds),
            cut,
            identified,
            weak,
            min_feasible,
            hints.get(v.name, ""),
            clipped,
        )
        out.append(
            ParameterVerdict(
                name=v.name,
                verdict=verdict,
                feasible=feas,
                pareto=par,
                box=(lo, hi),
                constrained_by=cut,
                suggestion=suggestion,
                reason=reason,
                unit=getattr(v, "unit", "") or "",
                meaning=meanings.get(v.name, ""),
                width=width,
                n_feasible=a.n_feasible,
                thin=0 < a.n_feasible < min_feasible,
                n_needed=int(min_feasible),
            )
        )
    return out


def _judge(
    name: str,
    width: float,
    feas: tuple[float, float] | None,
    box: tuple[float, float],
    nd: int,
    limited: bool,
    cut: list[str],
    t_id: float,
    t_weak: float,
    min_feasible: int,
    hint: str,
    clipped: str = "",
) -> tuple[str, str, str]:
    excite = hint or "data that excite it (another record, manoeuvre or drop)"
    more = (
        f"add a criterion sensitive to {name}, {excite}, or a longer window "
        "(more of the motion it shapes)"
    )
    if feas is None:
        return (
            "not identified",
            "the feasible set D is empty: no trial meets every constraint",
            "see which constraint empties D (`vectorid pareto STORE`); an empty D among "
            "the trials says the trials have not reached D, not that the model is wrong: run "
            'the sequential sampler (sampler = "sequential", docs/sequential.md), which '
            "moves trials toward the limits and, if it cannot reach them, says whether a "
            "local search from the best trials can",
        )
    if not limited:
        return (
            "not identified",
            "no criteria constraint is in force, so D is every trial and says nothing",
            'state criteria constraints (limits = "noise" in [identification], or --limit)',
        )
    W = box[1] - box[0]
    edge = []
    if feas[0] - box[0] <= 0.02 * W:
        edge.append("low")
    if box[1] - feas[1] <= 0.02 * W:
        edge.append("high")
    pct = f"{width:.0%} of the box"
    by = f"; cut by {', '.join(cut)}" if cut else "; no single constraint's limit cuts it"
    thin = (
        f"D holds only {nd} trials, fewer than the {min_feasible} needed to show its spread "
        "(the range is a lower bound of the uncertainty)"
        if nd < min_feasible
        else ""
    )
    grow = (
        f"run more trials (vectorid run STUDY --trials N, aiming at >= {min_feasible} in D), "
        'or use the sequential sampler ([study] sampler = "sequential"), or refine the box '
        "(double tuning)"
    )
    if width > t_weak:
        return "not identified", f"D spans {pct}{by}", more
    if width <= t_weak and clipped:
        return (
            "weak",
            f"D spans {pct} but reaches the {clipped} edge of a refined stage's box: the "
            "sampling, not the data, ends the range there",
            f"widen the refined box of {name} (or run more trials in the study box)",
        )
    if width <= t_id and nd >= min_feasible and not edge:
        return "identified", f"D spans {pct}{by}", ""
    if width <= t_id and edge:
        side = " and ".join(edge)
        return (
            "weak",
            f"D spans {pct} but reaches the box's {side} edge: the data may allow values beyond it",
            f"widen the box of {name} on its {side} side and run again",
        )
    if width <= t_id:
        return "weak", f"D spans {pct}, but {thin}", grow
    if thin:
        return "weak", f"D spans {pct}{by}; {thin}", f"{grow}; then, if still weak: {more}"
    return "weak", f"D spans {pct}{by}", f"partly determined: {more}"


def _clipped(a: Analysis, j: int, stages: Sequence[Any] | None, box: tuple[float, float]) -> str:
    """ "low"/"high"/"low and high" when D's trials of a refined sample stage reach that
    stage's box edge for variable j while the edge lies inside the study box; else ""."""
    if not stages:
        return ""
    W = box[1] - box[0] if box[1] > box[0] else 1.0
    sides: list[str] = []
    for st in stages:
        if getattr(st, "kind", "sample") != "sample":
            continue
        var = list(st.space)[j]
        if not hasattr(var, "low") or (
            abs(float(var.low) - box[0]) <= 1e-12 * W and abs(float(var.high) - box[1]) <= 1e-12 * W
        ):
            continue  # the study box itself: its edges are judged as the box's
        m = a.feasible & (a.trials.stage == st.stage)
        if not m.any():
            continue
        x = a.trials.X[m, j]
        w = float(var.high) - float(var.low)
        if w <= 0:
            continue
        if float(var.low) > box[0] + 1e-9 * W and x.min() - float(var.low) <= 0.02 * w:
            sides.append("low")
        if float(var.high) < box[1] - 1e-9 * W and float(var.high) - x.max() <= 0.02 * w:
            sides.append("high")
    sides = sorted(set(sides), key=["low", "high"].index)
    return " and ".join(sides)


def thin_threshold(p: int) -> int:
    """Members of D a verdict needs to show a spread, for p design variables:
    max(10, 2p + 1) (see "thin sets" in the module docstring)."""
    return max(10, 2 * int(p) + 1)


def verdicts_json(verdicts: list[ParameterVerdict]) -> dict[str, Any]:
    """The ``vectorid identifiability --json`` document: ``{"parameters": [...]}``."""
    return {"parameters": [v.to_dict() for v in verdicts]}
