"""A study of 33 gains and 8 criteria, as the engineers open them (the parafoil's stage 2 has
33 gains and 8 criteria): written straight into a store from closed forms (no model runs),
with units of every kind — a physical unit, ``-`` for a dimensionless gain, and none given —
and its limits saved by :func:`vectorid.workflows.extra.relax_study`, relaxed as the last
resort, as a stage that did not reach D saves them."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vectorid import Study
from vectorid.problem import Criterion
from vectorid.sampling import PointSequence
from vectorid.space import Continuous, Space
from vectorid.spec import StudySpec
from vectorid.store import Store
from vectorid.workflows.extra import relax_study

#: The gains: most dimensionless (``-``), a few with a physical unit, one with none given.
GAIN_UNITS = ["-"] * 33
GAIN_UNITS[1], GAIN_UNITS[16], GAIN_UNITS[18], GAIN_UNITS[29] = "m", "1/deg^2", "1/deg", ""
#: The criteria: name, unit ("" = none given).
CRITERIA = [
    ("pos_h", "m·s"),
    ("pos_v", "m·s"),
    ("heading", "rad·s"),
    ("speed", "m"),
    ("turn", "rad"),
    ("peak_roll", "Hz"),
    ("peak_pitch", "Hz"),
    ("peak_yaw", ""),
]
GAINS = [f"gain{j + 1:02d}" for j in range(33)]


def criteria_of(U: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Eight criteria of the unit-box points ``U`` (n, 33): each depends strongly on a few
    gains (so that sensitivity ranks them) and weakly on the rest."""
    n, p = U.shape
    F = np.empty((n, len(CRITERIA)))
    for i in range(len(CRITERIA)):
        w = 0.05 * np.ones(p)
        w[[3 * i % p, (3 * i + 1) % p]] = [3.0, 2.0]
        F[:, i] = ((U - 0.4) ** 2 * w).sum(axis=1) * 10 ** (i % 3)
    return F * (1 + 0.01 * rng.standard_normal(F.shape))


def many_axes_store(
    folder: Path, trials: int = 4000, *, name: str = "gains33", worse: float = 1.0
) -> Path:
    """Write the store (``folder/<name>.db``) and save its limits relaxed: the stated limits
    leave D holding a handful of trials, so :func:`relax_study` relaxes them by a common
    factor and names the relaxation in each limit's note. ``worse`` scales every criterion
    (a second, poorer model of the same data: same stated limits, from the first one's)."""
    folder.mkdir(parents=True, exist_ok=True)
    space = Space([Continuous(g, 0.2, 2.0, nominal=1.0, unit=u) for g, u in zip(GAINS, GAIN_UNITS)])
    spec = StudySpec(
        name=name,
        model="dtlz2-3",
        space=space,
        criteria=[
            Criterion(c, "min", "pure" if i < 3 else "pseudo", unit=u)
            for i, (c, u) in enumerate(CRITERIA)
        ],
        trials=trials,
    )
    path = folder / f"{name}.db"
    store = Store.create(path, spec)
    X = space.scale(PointSequence(33, "sobol").points(0, trials))
    rng = np.random.default_rng(7)
    F0 = criteria_of((X - 0.2) / 1.8, rng)
    F = F0 * worse
    status = np.zeros(trials, np.int8)
    for s in range(0, trials, 2048):
        e = min(trials, s + 2048)
        store.write_batch(
            0, s, X[s:e], F[s:e], np.empty((e - s, 0)), status[s:e], np.zeros(e - s), {}
        )
    store.close()
    stated = {c: float(np.quantile(F0[:, i], 0.05)) for i, (c, _) in enumerate(CRITERIA)}
    notes = {c: "noise floor q=0.99, joint 95% over 8 criteria" for c in stated}
    with Study.open(path, write=True) as st:
        rel = relax_study(st, stated, notes)
    assert rel.relaxed, rel.describe()  # the fixture is a stage that did not reach D
    return path
