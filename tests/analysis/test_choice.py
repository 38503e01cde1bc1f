"""Best trial per criterion and the suggested chosen vector."""

import numpy as np

from tests.analysis_helpers import make_store
from vectorid import Study
from vectorid.analysis.choice import best_per_criterion, suggest_choice


def test_best_and_suggestion(tmp_path):
    path = make_store(tmp_path, trials=256)
    with Study.open(path) as s:
        a = s.analysis({"f1": 60.0})
    best = best_per_criterion(a)
    for name in a.crit_names:
        assert best[name] == a.test_table(name, feasible_only=True).ids[0]
    sid = suggest_choice(a)
    row = np.flatnonzero(a.trials.id == sid)[0]
    assert a.pareto[row]
    empty = Study.open(path)
    with empty:
        e = empty.analysis({"f1": -1.0})
    assert suggest_choice(e) is None and best_per_criterion(e) == {}
