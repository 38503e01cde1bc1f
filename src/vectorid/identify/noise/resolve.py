"""Study-level resolution of noise-grounded criteria constraints: which criteria a study
limits by the noise, with which noise, quantile, draws and allowance
(:func:`noise_limits`), and the study definition completed with those limits and the
criteria's units (:func:`resolve_noise_limits`, the identification builder's ``prepare``
hook: it runs once, when a store is created). See :mod:`vectorid.identify.noise`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from vectorid.errors import StudyDefinitionError
from vectorid.identify.criteria import get_criterion
from vectorid.identify.identification import INTEGRAL_CRITERIA, Identification, window_variable
from vectorid.identify.noise.estimate import estimate_noise
from vectorid.identify.noise.floor import (
    needed_channels,
    noise_floor,
    record_noise_floor,
    time_mean_unit,
)
from vectorid.identify.noise.statements import NoiseModel, parse_discrepancy, parse_noise
from vectorid.identify.system import SystemIdentification, check_record_scales, resolve_model
from vectorid.models.system import SystemModel

__all__ = ["noise_limits", "resolve_noise_limits"]


def _err(field_: str, problem: str, fix: str = "") -> StudyDefinitionError:
    return StudyDefinitionError(f"identification.{field_}", problem, fix)


def _noise_settings(spec) -> dict[str, Any]:
    table = spec.extra.get("identification", {})
    return {
        "noise": table.get("noise"),
        "limits": table.get("limits"),
        "quantile": table.get("noise_quantile"),
        "coverage": table.get("noise_coverage", 0.95),
        "draws": table.get("noise_draws", 2000),
        "seed": table.get("noise_seed", 0),
        "discrepancy": table.get("discrepancy"),
    }


def noise_limits(
    spec, *, ident=None, params: Mapping[str, float] | None = None
) -> dict[str, tuple[float, str]]:
    """The noise-floor limits of an identification study: criterion name -> (limit, note).

    Which criteria: those with ``limit = "noise"``, and with ``[identification] limits =
    "noise"`` every pure and pseudo criterion that has no number of its own. The noise,
    quantile, coverage, draws, seed and discrepancy come from the ``[identification]``
    table (see :mod:`vectorid.identify.noise`). ``params``: the reference vector (default: the
    variables' nominal values, else the middle of their box).

    A flight identification's floor is :func:`~vectorid.identify.noise.floor.noise_floor`, a
    model of your own's :func:`~vectorid.identify.noise.floor.record_noise_floor`; both are
    read here at the same quantile rule (:meth:`NoiseFloor.limits`), and each note says
    which noise it used."""
    s = _noise_settings(spec)
    if s["limits"] not in (None, "noise"):
        raise _err(
            "limits",
            f'expected "noise", got {s["limits"]!r}',
            'write limits = "noise", or set numbers in each [[criteria]] limit',
        )
    targets = [
        c.name
        for c in spec.criteria
        if (c.limit is None and c.limit_source == "noise")
        or (s["limits"] == "noise" and c.limit is None)
    ]
    if not targets:
        table = spec.extra["identification"]
        unused = [k for k in ("noise_quantile", "noise_coverage", "noise_draws", "noise_seed")
                  if k in table]  # fmt: skip
        if unused and _own_model(spec):  # a setting that changes nothing is an error
            raise _err(
                unused[0],
                f"{unused[0]} shapes noise-floor limits, but no criterion is limited by the noise",
                f'add limits = "noise" (or limit = "noise" to a criterion), or remove {unused[0]}',
            )
        return {}
    if ident is None:
        ident = Identification.from_spec(spec)
    if isinstance(ident, SystemIdentification):  # a model of your own: stated initial states
        _check_settings(s)
        floor, described = record_noise_floor(
            spec, ident, targets, draws=s["draws"], seed=int(s["seed"])
        )
        said = "; ".join(dict.fromkeys(described))
        out = _finite(floor.limits(targets, quantile=s["quantile"], coverage=float(s["coverage"])))
        return {n: (v, f"{note} ({said})") for n, (v, note) in out.items()}
    if s["noise"] is None and not any(
        "noise" in dt
        for dt in spec.extra["identification"].get("drops", [])
        if isinstance(dt, Mapping)
    ):
        raise _err(
            "noise",
            f"criteria {targets} are limited by the noise, but no noise is stated",
            'add noise = { position_h = 1.5, ... } or noise = "estimate" under [identification]',
        )
    noise = _drop_noise(spec, ident, s["noise"])
    disc = _drop_discrepancy(spec, s["discrepancy"])
    _check_settings(s)
    ref = _reference(spec, ident, params)
    floor = noise_floor(
        ident,
        noise,
        draws=s["draws"],
        seed=int(s["seed"]),
        params=ref,
        discrepancy=disc,
        criteria=targets,
    )
    out = _finite(floor.limits(targets, quantile=s["quantile"], coverage=float(s["coverage"])))
    # The stated noise is in the study file; an estimated one is only here, so say it.
    est = "; ".join(f"{k}: {v}" for k, v in floor.noise.items() if v.startswith("estimated"))
    return {n: (v, f"{note} ({est})" if est else note) for n, (v, note) in out.items()}


def _finite(limits: dict[str, tuple[float, str]]) -> dict[str, tuple[float, str]]:
    """The noise-floor limits, each a finite number: a NaN floor is the model's or the
    criterion's doing, said as such (never as a limit the user did not write)."""
    for name, (v, _) in limits.items():
        if not math.isfinite(v):
            raise _err(
                "noise",
                f"the noise floor of criterion {name!r} is {v} (the model at the reference "
                "vector, compared with itself plus the stated noise, gives no finite value): "
                "the model's output or the criterion is NaN or inf there",
                "run the model once at the reference vector (the variables' nominal values, "
                "else the middle of their box) to see where, or give the criterion a number",
            )
    return limits


def _check_settings(s: Mapping[str, Any]) -> None:
    q = s["quantile"]
    if q is not None and not (isinstance(q, int | float) and 0 < q < 1):
        raise _err("noise_quantile", f"expected a number in (0, 1), got {q!r}", "e.g. 0.99")
    cov = s["coverage"]
    if not (isinstance(cov, int | float) and 0 < cov < 1):
        raise _err("noise_coverage", f"expected a number in (0, 1), got {cov!r}", "e.g. 0.95")
    draws = s["draws"]
    if not (isinstance(draws, int) and draws >= 100):
        raise _err("noise_draws", f"expected an integer >= 100, got {draws!r}", "e.g. 2000")


def _reference(spec, ident, params) -> dict[str, float]:
    ref = {}
    for v in spec.space:
        if v.name in ident.model.parameter_names:
            if v.nominal is not None:
                ref[v.name] = float(v.nominal)
            elif hasattr(v, "low"):
                ref[v.name] = 0.5 * (float(v.low) + float(v.high))
    ref.update(dict(params or {}))
    return ref


def _drop_noise(spec, ident, study_noise) -> dict[str, NoiseModel | str]:
    tables = spec.extra["identification"].get("drops", [])
    base = None if study_noise is None else parse_noise(study_noise, "noise")
    out: dict[str, NoiseModel | str] = {}
    for i, d in enumerate(ident.drops):
        t = tables[i] if i < len(tables) and isinstance(tables[i], Mapping) else {}
        own = t.get("noise")
        if own is None:
            if base is None:
                raise _err(
                    f"drops[{i}].noise",
                    f"drop {d.name!r} has no stated noise and the study states none",
                    'add noise = { ... } (or "estimate") to the drop or to [identification]',
                )
            out[d.name] = base
            continue
        mine = parse_noise(own, f"drops[{i}].noise")
        if isinstance(mine, str) or base is None or isinstance(base, str):
            if isinstance(base, str) and not isinstance(mine, str):
                out[d.name] = estimate_noise(d.flight, needed_channels(ident, d)).merged(mine)
            else:
                out[d.name] = mine
        else:
            out[d.name] = base.merged(mine)
    for name, nm in out.items():
        if isinstance(nm, str):
            d = ident.drop(name)
            out[name] = estimate_noise(d.flight, needed_channels(ident, d))
    return out


def _drop_discrepancy(spec, value) -> dict:
    return parse_discrepancy(value, {c.name: c.unit or "" for c in spec.criteria})


def resolve_noise_limits(spec, *, ident=None, params: Mapping[str, float] | None = None):
    """``spec`` with its noise-floor limits computed (``limit_source = "noise"`` and a note on
    each), and with each identification criterion's unit filled from the library where the
    study gives none. A spec without an ``[identification]`` table, or without noise limits,
    comes back unchanged (units filled)."""
    if "identification" not in spec.extra:
        return spec
    if ident is None and _own_model(spec):
        ident = Identification.from_spec(spec)
    if isinstance(ident, SystemIdentification):  # records read in their stated units
        ref = np.array([float(v.nominal) if v.nominal is not None else
                        0.5 * (float(v.low) + float(v.high)) for v in spec.space])  # fmt: skip
        if params:
            ref = np.array([float(params.get(n, r)) for n, r in zip(spec.space.names, ref)])
        check_record_scales(ident, ref, spec.extra["identification"])
    limits = noise_limits(spec, ident=ident, params=params)
    if isinstance(ident, SystemIdentification):
        units = ident.units()
    else:
        units = _library_units(spec)
    crit = []
    for c in spec.criteria:
        new = c
        if not c.unit and units.get(c.name):
            new = replace(new, unit=units[c.name])
        if c.name in limits:
            v, note = limits[c.name]
            new = replace(new, limit=v, limit_source="noise", limit_note=note)
        crit.append(new)
    return replace(spec, criteria=tuple(crit))


def _own_model(spec) -> bool:
    """Whether the study's identification names a model of your own (a SystemModel)."""
    table = spec.extra.get("identification")
    default = spec.model if isinstance(spec.model, str) else None
    try:
        return isinstance(resolve_model(table, default, spec.base_dir), SystemModel)
    except StudyDefinitionError:  # the identification itself says what is wrong
        return False


def _library_units(spec) -> dict[str, str]:
    table = spec.extra.get("identification", {})
    ctab = table.get("criteria", {}) if isinstance(table.get("criteria", {}), Mapping) else {}
    mean_form = any(window_variable(n) is not None for n in spec.space.names)
    out = {}
    for c in spec.criteria:
        t = ctab.get(c.name, {}) if isinstance(ctab.get(c.name, {}), Mapping) else {}
        use, op = str(t.get("use", c.name)), t.get("operator")
        try:
            u = get_criterion(use if op is None else f"{use}:{op}").unit
        except Exception:  # not a library criterion: leave it
            continue
        if mean_form and op is None and use in INTEGRAL_CRITERIA:
            u = time_mean_unit(u)
        out[c.name] = u
    return out
