"""Choose the integration step for a stated accuracy.

The batch models integrate with fixed-step RK4 (:mod:`vectorid.models.integrate`): the step
``dt`` sets both the cost (evaluations per trial scale as ``1/dt``) and the error (the global
error of RK4 scales as ``dt**4`` while the step resolves the dynamics). An identification study
compares trajectories with flight data at metre level, so a step whose error is far below the
measurement noise wastes time, and one above it biases the answer. :func:`choose_step` measures
the error of each candidate step on the trials and the flight the user gives and returns the
largest one within a stated tolerance.

How the error is measured
-------------------------
For each candidate ``dt`` the trials are integrated over ``t_final`` and compared, at every
output time, with a reference integration of the same trials at ``reference_dt`` (default: a
quarter of the smallest candidate, so its own RK4 error is about 4**4 = 256 times smaller than
that candidate's). The error of a step is the largest distance between the two position
vectors (N, E, D; m) over every output time and trial. A trial that fails (diverges) at a
candidate step but not in the reference counts as an infinite error; trials that fail in the
reference are left out (and counted). ``tests/models/test_steps.py`` checks the reference
against ``scipy.integrate.solve_ivp`` at ``rtol=1e-10`` on the parachute's plain-numpy
right-hand side.

The result says what was measured; it chooses nothing silently: the study file keeps an
explicit ``dt`` (reproducible), and ``vectorid step STUDY`` prints the table that justifies it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["DEFAULT_CANDIDATES", "StepChoice", "choose_step"]

#: Candidate steps, s, largest first (each divides 1 s, so any whole-second output grid).
DEFAULT_CANDIDATES: tuple[float, ...] = (0.5, 0.25, 0.2, 0.1, 0.05, 0.04, 0.025, 0.02, 0.01)


@dataclass(frozen=True)
class StepChoice:
    """What :func:`choose_step` measured.

    Attributes
    ----------
    dt : float or None
        The largest candidate step whose error is within ``tolerance``, s; ``None`` when none
        is.
    tolerance : float
        The stated accuracy: largest position error allowed, m.
    errors : dict of float to float
        Candidate step (s) -> largest position error against the reference, m (``inf``: some
        trial diverged at that step only).
    reference_dt : float
        Step of the reference integration, s.
    trials : int
        Trials compared (those the reference integrated to the end).
    failed_in_reference : int
        Trials left out because the reference itself failed on them.
    t_final : float
        Duration integrated, s.
    """

    dt: float | None
    tolerance: float
    errors: dict[float, float]
    reference_dt: float
    trials: int
    failed_in_reference: int
    t_final: float

    def summary(self) -> str:
        """A few lines for a person: the table and the choice."""
        lines = [
            f"largest position error against RK4 at dt = {self.reference_dt:g} s, over "
            f"{self.trials} trials x {self.t_final:g} s:"
        ]
        for dt, err in self.errors.items():
            mark = "within" if err <= self.tolerance else "above"
            lines.append(f"  dt = {dt:<6g} s   {err:10.4g} m   ({mark} {self.tolerance:g} m)")
        if self.dt is None:
            lines.append(
                f"no candidate step is within {self.tolerance:g} m; try smaller candidates"
            )
        else:
            lines.append(f"chosen: dt = {self.dt:g} s (the largest within {self.tolerance:g} m)")
        if self.failed_in_reference:
            lines.append(
                f"{self.failed_in_reference} trial(s) failed in the reference and were left out"
            )
        return "\n".join(lines)


def _divides(dt: float, span: float) -> bool:
    k = span / dt
    return abs(k - round(k)) < 1e-9 * max(1.0, k)


def choose_step(
    model,
    params: ArrayLike,
    *,
    t_final: float,
    tolerance: float = 0.1,
    candidates: Sequence[float] = DEFAULT_CANDIDATES,
    output_dt: float = 1.0,
    reference_dt: float | None = None,
    **simulate_kwargs,
) -> StepChoice:
    """The largest integration step whose trajectories stay within ``tolerance`` of a reference.

    Parameters
    ----------
    model : vectorid.models.Model
        The batch model.
    params : array_like, shape (n, p) or (p,)
        Parameter vectors to test (e.g. the nominal and a Sobol sample of the study box: the
        error depends on the parameters, so test the ones the study will fly).
    t_final : float
        Duration, s; a multiple of ``output_dt``.
    tolerance : float
        Largest position error allowed, m (default 0.1 m).
    candidates : sequence of float
        Steps to try, s. Those that do not divide ``output_dt`` are skipped.
    output_dt : float
        Interval of the compared positions, s.
    reference_dt : float or None
        Step of the reference, s; default a quarter of the smallest candidate.
    **simulate_kwargs
        ``inputs``, ``wind``, ``initial``, ``atmosphere`` of :meth:`Model.simulate` (the
        flight the study compares with).

    Returns
    -------
    StepChoice
        The measured errors and the choice; see :class:`StepChoice`.
    """
    if not (tolerance > 0 and math.isfinite(tolerance)):
        raise ValueError(f"tolerance must be a positive number of metres, got {tolerance!r}")
    if not _divides(output_dt, t_final):
        raise ValueError(
            f"t_final ({t_final:g} s) must be a multiple of output_dt ({output_dt:g} s)"
        )
    steps = sorted({float(c) for c in candidates if c > 0 and _divides(c, output_dt)}, reverse=True)
    if not steps:
        raise ValueError(
            f"no candidate step divides output_dt = {output_dt:g} s; got {list(candidates)}"
        )
    ref_dt = steps[-1] / 4.0 if reference_dt is None else float(reference_dt)
    if not _divides(ref_dt, output_dt):
        raise ValueError(f"reference_dt {ref_dt:g} s does not divide output_dt {output_dt:g} s")
    X = np.atleast_2d(np.asarray(params, dtype=float))
    kw = dict(t_final=t_final, output_dt=output_dt, **simulate_kwargs)
    ref = model.simulate(X, dt=ref_dt, **kw)
    good = ref.ok
    errors: dict[float, float] = {}
    for dt in steps:
        res = model.simulate(X[good], dt=dt, **kw)
        if not np.all(res.ok):
            errors[dt] = math.inf
            continue
        d = np.linalg.norm(res.position - ref.position[good], axis=-1)
        errors[dt] = float(d.max()) if d.size else 0.0
    within = [dt for dt in steps if errors[dt] <= tolerance]
    return StepChoice(
        dt=within[0] if within else None,
        tolerance=float(tolerance),
        errors=errors,
        reference_dt=ref_dt,
        trials=int(good.sum()),
        failed_in_reference=int((~good).sum()),
        t_final=float(t_final),
    )
