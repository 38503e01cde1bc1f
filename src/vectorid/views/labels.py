"""Units and meanings of the names of a study (criteria, functional constraints, parameters),
for every axis, field and table header a person reads."""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

__all__ = ["Labels", "Relaxed", "labels_of", "relaxation_line", "relaxed_of"]


@dataclass(frozen=True)
class Labels:
    """Unit and meaning of every criterion, functional constraint and parameter.

    Attributes
    ----------
    unit : dict
        Name -> unit ("" when the study gives none).
    meaning : dict
        Name -> what it is, in words ("" when unknown).
    kind : dict
        Name -> ``"criterion"``, ``"functional"`` or ``"parameter"``.
    nominal : dict
        Parameter -> its nominal value: the study's, else (identification studies) the
        model's, the value ``vectorid demo`` and the report call nominal; None when neither
        gives one.
    """

    unit: dict[str, str]
    meaning: dict[str, str]
    kind: dict[str, str]
    nominal: dict[str, float | None] = field(default_factory=dict)

    def axis(self, name: str) -> str:
        """An axis title: ``name, unit — meaning`` (the parts that are known)."""
        u = self.unit.get(name, "")
        m = self.meaning.get(name, "")
        text = f"{name}, {u}" if u and u != "-" else name
        return f"{text} — {m}" if m else text

    def short(self, name: str) -> str:
        """``name [unit]`` for table headers and legends."""
        u = self.unit.get(name, "")
        return f"{name} [{u}]" if u and u != "-" else name

    def unit_text(self, name: str) -> str:
        """The unit as every axis title shows it: the study's unit, ``-`` for a dimensionless
        quantity (the study says ``unit = "-"``), ``no unit given`` where the study (and, for
        an identification, the model and the criteria library) gives none: never guessed."""
        u = self.unit.get(name, "")
        return u if u else "no unit given"

    def title(self, name: str) -> str:
        """``name [unit]`` with the unit always said (:meth:`unit_text`): an axis title."""
        return f"{name} [{self.unit_text(name)}]"

    def hover(self, name: str) -> str:
        """Name, unit and meaning on one line (an axis title's hover, a header's tooltip)."""
        m = self.meaning.get(name, "")
        kind = self.kind.get(name, "")
        text = f"{self.title(name)}" + (f" — {kind}" if kind else "")
        return f"{text}: {m}" if m else text

    def tip(self, name: str) -> str:
        """A one-line tooltip: kind, unit and meaning."""
        parts = [self.kind.get(name, "")]
        if self.unit.get(name):
            parts.append(f"unit {self.unit[name]}")
        if self.meaning.get(name):
            parts.append(self.meaning[name])
        return "; ".join(p for p in parts if p)


def labels_of(spec: Any) -> Labels:
    """Units and meanings from the study (units of variables, criteria and functional
    constraints) and, for an identification study, from the model's parameter table and the
    criteria library (:data:`vectorid.identify.criteria.CRITERIA`)."""
    unit: dict[str, str] = {}
    meaning: dict[str, str] = {}
    kind: dict[str, str] = {}
    nominal: dict[str, float | None] = {}
    for v in spec.space:
        unit[v.name] = v.unit or ""
        kind[v.name] = "parameter"
        nominal[v.name] = None if v.nominal is None else float(v.nominal)
    for c in spec.criteria:
        unit[c.name] = getattr(c, "unit", "") or ""
        kind[c.name] = f"criterion ({c.sense}, {c.role})"
    for g in spec.constraints:
        unit[g.name] = getattr(g, "unit", "") or ""
        kind[g.name] = "functional constraint"
    ident = spec.extra.get("identification") if isinstance(spec.extra, Mapping) else None
    if isinstance(ident, Mapping):
        try:  # best effort: the names are the model's and the library's
            from ..models import get as get_model

            model = get_model(str(ident.get("model", spec.model)))
            fixed = dict(ident.get("parameters") or {})
            for p in model.parameters:
                if p.name in unit:
                    meaning[p.name] = p.meaning
                    if nominal.get(p.name) is None:
                        nominal[p.name] = float(fixed.get(p.name, p.nominal))
                    if not unit[p.name] and p.unit and p.unit != "-":
                        unit[p.name] = p.unit
        except Exception:  # an unknown model: the names stay without meanings
            pass
        try:
            from ..identify.criteria import get_criterion

            table = ident.get("criteria") if isinstance(ident.get("criteria"), Mapping) else {}
            for c in spec.criteria:
                use = table.get(c.name, {}).get("use", c.name) if table else c.name
                try:  # a library name, a band-limited spectral one ("peak_roll@0.05-0.5")
                    d = get_criterion(str(use))
                except Exception:
                    d = None
                if d is not None:
                    meaning[c.name] = d.meaning
                    if not unit[c.name]:
                        unit[c.name] = d.unit
        except Exception:
            pass
    return Labels(unit, meaning, kind, nominal)


#: How :func:`vectorid.analysis.relaxation.relaxation_text` names a relaxation in a saved
#: limit's note (:func:`vectorid.workflows.extra.relax_study`), and the stated limit it gives.
_RELAXED = re.compile(r"limits relaxed x(?P<f>[0-9]+(?:\.[0-9]+)?(?:e[+-]?[0-9]+)?)")
_STATED = re.compile(r"stated limit (?P<v>[-+]?[0-9.]+(?:e[+-]?[0-9]+)?)(?: \((?P<why>[^)]*)\))?")


@dataclass(frozen=True)
class Relaxed:
    """A criteria constraint saved relaxed, as the last resort when D at the stated limits
    was not reached (:func:`vectorid.workflows.extra.relax_study`).

    Attributes
    ----------
    factor : float
        Common factor on the stated limit (dimensionless, > 1).
    stated : float or None
        The stated limit, in the criterion's unit (None where the note does not give it).
    why : str
        Where the stated limit came from (its note: the noise floor and its allowance).
    """

    factor: float
    stated: float | None
    why: str = ""

    def label(self) -> str:
        """``relaxed x1.35 (last resort: D not reached at the stated limits)``."""
        return f"relaxed x{self.factor:g} (last resort: D not reached at the stated limits)"

    def text(self, unit: str = "") -> str:
        """The label, then the stated limit and where it came from."""
        u = f" {unit}" if unit and unit != "-" else ""
        parts = [self.label()]
        if self.stated is not None:
            parts.append(
                f"stated limit {self.stated:.4g}{u}" + (f" ({self.why})" if self.why else "")
            )
        return "; ".join(parts)


def relaxed_of(criterion: Any) -> Relaxed | None:
    """The relaxation a criterion's saved limit carries (its source is the stand-in's and
    its note names the relaxation), or None for a limit that is not relaxed."""
    note = getattr(criterion, "limit_note", "") or ""
    if getattr(criterion, "limit", None) is None or getattr(criterion, "source", "") != "quantile":
        return None
    m = _RELAXED.search(note)
    if m is None:
        return None
    s = _STATED.search(note)
    stated = float(s.group("v").rstrip(".")) if s else None
    return Relaxed(float(m.group("f")), stated, (s.group("why") or "") if s else "")


def relaxation_line(spec: Any) -> str:
    """One line for the study as a whole: "" where no saved limit is relaxed; otherwise which
    factor, on which criteria, and what it means for the ranges read under them."""
    rel = {c.name: relaxed_of(c) for c in spec.criteria}
    rel = {k: v for k, v in rel.items() if v is not None}
    if not rel:
        return ""
    factors = sorted({r.factor for r in rel.values()})
    f = ", ".join(f"x{v:g}" for v in factors)
    names = ", ".join(rel) if len(rel) < len(spec.criteria) else "every criterion"
    return (
        f"D was not reached at the stated limits: the limits saved with the study are relaxed "
        f"{f} on {names} (the last resort); ranges read under them are outer bounds of what "
        "the data determine"
    )
