"""Integration step ``dt``, output step ``output_dt`` and simulated time ``t_final``: the
combinations a model can run, checked where a study is read, with a valid value named.

A model integrates with fixed steps ``dt`` and reports every ``output_dt``, so ``output_dt``
must be a whole multiple of ``dt`` (``k × dt``, ``k >= 1``), and ``t_final`` a whole number of
``output_dt`` (hence of ``dt``). A study that breaks this is refused when it is loaded, with
one line naming the field and the nearest valid values:

>>> check_time_steps(0.05, 0.07, where="identification")
Traceback (most recent call last):
...
vectorid.errors.StudyDefinitionError: identification.output_dt: output_dt = 0.07 s is not a \
whole multiple of dt = 0.05 s — use 0.05 or 0.1
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from .errors import StudyDefinitionError

__all__ = ["check_identification_steps", "check_time_steps"]

#: Relative tolerance of "whole multiple" (float steps such as 0.1 = 2 × 0.05).
_TOL = 1e-9


def _g(x: float) -> str:
    """A step in seconds, short (``0.1``, not ``0.10000000000000001``)."""
    return f"{float(f'{x:.12g}'):g}"


def _number(where: str, name: str, value: Any) -> float:
    ok = isinstance(value, int | float) and not isinstance(value, bool)
    out = float(value) if ok else math.nan
    if not (math.isfinite(out) and out > 0):
        raise StudyDefinitionError(
            f"{where}.{name}" if where else name,
            f"expected a positive number of seconds, got {value!r}",
            f"write e.g. {name} = {0.05 if name == 'dt' else 0.5}",
        )
    return out


def check_time_steps(
    dt: Any, output_dt: Any, *, t_final: Any = None, where: str = ""
) -> tuple[float, float]:
    """Refuse ``dt``/``output_dt``/``t_final`` that no fixed-step model can run.

    Parameters
    ----------
    dt : float
        Integration step, s.
    output_dt : float
        Output (comparison) step, s: a whole multiple of ``dt``.
    t_final : float, optional
        Simulated time, s: a whole number of ``output_dt``.
    where : str
        The table holding them (``"identification"``), for the field name in the message.

    Returns
    -------
    dt, output_dt : float

    Raises
    ------
    StudyDefinitionError
        Naming the field and the nearest valid values.
    """
    field = lambda name: f"{where}.{name}" if where else name  # noqa: E731
    dt = _number(where, "dt", dt)
    output_dt = _number(where, "output_dt", output_dt)
    ratio = output_dt / dt
    k = round(ratio)
    if k < 1 or abs(k * dt - output_dt) > _TOL * max(1.0, output_dt):
        low = max(1, math.floor(ratio + _TOL))
        options = sorted({low * dt, (low + 1) * dt} if ratio >= 1 else {dt})
        use = " or ".join(_g(v) for v in options)
        extra = f" (or dt = {_g(output_dt)})" if ratio < 1 else ""
        raise StudyDefinitionError(
            field("output_dt"),
            f"output_dt = {_g(output_dt)} s is not a whole multiple of dt = {_g(dt)} s",
            f"use {use}{extra}",
        )
    if t_final is not None:
        t_final = _number(where, "t_final", t_final)
        n = round(t_final / output_dt)
        if n < 1 or abs(n * output_dt - t_final) > _TOL * max(1.0, t_final):
            low = max(1, math.floor(t_final / output_dt + _TOL))
            use = " or ".join(_g(v) for v in sorted({low * output_dt, (low + 1) * output_dt}))
            raise StudyDefinitionError(
                field("t_final"),
                f"t_final = {_g(t_final)} s is not a whole number of output_dt = {_g(output_dt)} s",
                f"use {use}",
            )
    return dt, output_dt


#: The identification's defaults (:mod:`vectorid.identify.identification`).
IDENTIFICATION_DT = 0.05
IDENTIFICATION_OUTPUT_DT = 0.5


def check_identification_steps(spec: Any) -> None:
    """The check of an ``[identification]`` table's ``dt`` and ``output_dt`` (registered as
    its builder's ``check`` hook, run when the study file is loaded)."""
    table = getattr(spec, "extra", {}).get("identification")
    if not isinstance(table, Mapping):
        return
    check_time_steps(
        table.get("dt", IDENTIFICATION_DT),
        table.get("output_dt", IDENTIFICATION_OUTPUT_DT),
        where="identification",
    )
