"""Seed 000's fix/tie reduction on a study whose answer is known by construction."""

from __future__ import annotations

import numpy as np
import pytest

from vectorid import Study
from vectorid.problem import Criterion
from vectorid.space import Continuous, Space
from vectorid.spec import StudySpec
from vectorid.workflows import propose_reduction

NAMES = ("x1", "x2", "x3", "x4", "x5")


def reduction_model(X: np.ndarray) -> np.ndarray:
    """f1 pins x1 near 0.2 (it grows with x1 over most of the box) and x5 near x1 (a tied
    pair, both narrow over D); f2 holds x3 near x4; x2 enters nothing."""
    x1, _, x3, x4, x5 = X.T
    f1 = (x1 - 0.2) ** 2 + 10.0 * (x5 - x1) ** 2
    f2 = (x3 - x4) ** 2
    return np.column_stack([f1, f2])


@pytest.fixture(scope="module")
def analysis(tmp_path_factory):
    spec = StudySpec(
        name="reduction",
        model=reduction_model,
        space=Space([Continuous(n, 0.0, 1.0) for n in NAMES]),
        criteria=(Criterion("f1", limit=0.005), Criterion("f2", limit=0.08)),
        trials=16384,
        seed=1,
        executor="inline",
    )
    with Study.create(spec, tmp_path_factory.mktemp("red") / "red.db") as st:
        st.run(executor="inline")
        a = st.analysis()
        return a, a.verdicts()


def test_the_irrelevant_variable_is_fixed_and_the_narrow_pair_tied(analysis):
    a, verdicts = analysis
    assert a.n_feasible >= 30
    by = {v.name: v for v in verdicts}
    assert by["x2"].verdict == "not identified"
    red = propose_reduction(a, verdicts, dict.fromkeys(NAMES, 0.5))
    # x2: no influence on any criterion, D does not depend on it -> fixed at its nominal
    assert "x2" in red.insensitive and red.fixed["x2"] == 0.5
    assert red.influence[NAMES.index("x2")] < 0.1
    # x1 and x5 move together over D; the follower is identified, so it is fixed at D's median
    tie = next(t for t in red.ties if {t.keep, t.follower} == {"x1", "x5"})
    assert abs(tie.r) >= 0.4 and tie.identified == by[tie.follower].identified
    assert by[tie.follower].identified
    median = red.medians[tie.follower]
    assert red.fixed[tie.follower] == median
    col = a.trials.X[a.feasible, NAMES.index(tie.follower)]
    assert col.min() <= median <= col.max() and abs(median - 0.2) < 0.05
    assert tie.keep not in red.fixed
    assert red.kept(NAMES) == [n for n in NAMES if n not in red.fixed]


def test_kept_variables_and_chosen_criteria(analysis):
    a, verdicts = analysis
    red = propose_reduction(a, verdicts, dict.fromkeys(NAMES, 0.5), keep=("x2",))
    assert "x2" not in red.fixed  # kept: an earlier stage's narrow box, not a lack of influence
    only_f2 = propose_reduction(a, verdicts, dict.fromkeys(NAMES, 0.5), criteria=["f2"])
    j = red.sensitivity.criteria.index("f2")
    assert np.allclose(only_f2.influence, np.abs(only_f2.sensitivity.spearman[:, j]))
    # x1 shapes f1 but not f2: over f2 alone its influence is small, and fewer criteria never
    # raise a variable's influence (the max over a subset of the same columns)
    assert only_f2.influence[0] < 0.1 < red.influence[0]
    assert np.all(only_f2.influence <= red.influence)
    # no ties when D is too small to show a correlation
    assert propose_reduction(a, verdicts, dict.fromkeys(NAMES, 0.5), min_feasible=10**6).ties == []
