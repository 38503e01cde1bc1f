"""Feasible set, Pareto set, test tables and empty-D diagnosis on stored trials."""

import math

import numpy as np
import pytest

from vectorid import Study, StudyDefinitionError, StudySpec
from vectorid.analysis import Analysis, parse_limit
from vectorid.demos.g12 import study_toml
from vectorid.spec import load_study
from vectorid.store import Trials


def make(F, G=None, status=None, senses=("min", "min"), roles=None, limits=None, cons=()):
    F = np.asarray(F, float)
    n, k = F.shape
    G = np.zeros((n, 0)) if G is None else np.asarray(G, float)
    spec = StudySpec.from_dict(
        {
            "study": {"name": "t", "model": "binh-korn"},
            "variables": [{"name": "x", "low": 0.0, "high": 1.0}],
            "criteria": [
                {
                    "name": f"f{j + 1}",
                    "sense": senses[j],
                    "role": (roles or ["pure"] * k)[j],
                    **({"limit": limits[j]} if limits and limits[j] is not None else {}),
                }
                for j in range(k)
            ],
            **({"constraints": list(cons)} if cons else {}),
        }
    )
    status = np.zeros(n, np.int8) if status is None else np.asarray(status, np.int8)
    t = Trials(
        np.arange(1, n + 1),
        np.arange(n),
        np.zeros(n, int),
        status,
        np.linspace(0, 1, n)[:, None],
        F,
        G,
        np.zeros(n),
    )
    return spec, t


def test_counts_and_pareto_with_constraints_and_failures():
    F = [[1, 5], [2, 2], [3, 1], [2, 3], [np.nan, np.nan], [0.5, 9], [4, 4]]
    G = [[0], [0], [0], [0], [np.nan], [2], [0]]
    spec, t = make(
        F, G, status=[0, 0, 0, 0, 1, 0, 0], limits=[None, 4.5], cons=[{"name": "g", "high": 1.0}]
    )
    a = Analysis(spec, t)
    assert (a.n, a.n_failed, a.n_functional) == (7, 1, 5)
    # f2 <= 4.5 removes trial 1 (f2=5); g <= 1 removes trial 6
    assert a.feasible.tolist() == [False, True, True, True, False, False, True]
    assert a.pareto.tolist() == [False, True, True, False, False, False, False]
    assert (a.n_feasible, a.n_pareto) == (4, 2)


def test_limits_given_after_the_run_override_the_study():
    spec, t = make([[1, 5], [2, 2], [3, 1]], limits=[None, 4.5])
    assert Analysis(spec, t).n_feasible == 2
    assert Analysis(spec, t, [parse_limit("f2<=inf")]).n_feasible == 3
    assert Analysis(spec, t, [parse_limit("f1<=1.5"), parse_limit("f2<=inf")]).n_feasible == 1
    assert Analysis(spec, t, {"f1": 2.5}).n_feasible == 1  # f1<=2.5 and the study's f2<=4.5
    with pytest.raises(StudyDefinitionError, match="did you mean 'f1'"):
        Analysis(spec, t, [parse_limit("f11<=3")])


def test_pseudo_criteria_constrain_but_do_not_enter_pareto():
    F = [[1, 3, 9], [2, 2, 1], [3, 1, 5], [2, 2.5, 0]]
    spec, t = make(
        F, senses=("min", "min", "min"), roles=["pure", "pure", "pseudo"], limits=[None, None, 6]
    )
    a = Analysis(spec, t)
    assert a.feasible.tolist() == [False, True, True, True]
    # over (f1, f2) only: trial 4 (2, 2.5) is dominated by trial 2 (2, 2) even though f3 is best
    assert a.pareto.tolist() == [False, True, True, False]
    b = Analysis(spec, t, roles={"f3": "pure"})
    assert b.pareto.tolist() == [False, True, True, True]


def test_mixed_senses():
    spec, t = make([[1, 1], [2, 3], [3, 2], [1, 0.5]], senses=("min", "max"))
    a = Analysis(spec, t)
    assert a.pareto.tolist() == [True, True, False, False]
    # a max criterion's limit is a lower bound
    spec2, t2 = make([[1, 1], [2, 3], [3, 2]], senses=("min", "max"), limits=[None, 1.5])
    assert Analysis(spec2, t2).feasible.tolist() == [False, True, True]


def test_test_table_sorted_best_first_with_min_max():
    spec, t = make(
        [[3, 1], [1, 2], [2, 0], [np.nan, np.nan]],
        senses=("min", "max"),
        status=[0, 0, 0, 1],
        limits=[2.5, None],
    )
    a = Analysis(spec, t)
    t1 = a.test_table("f1")
    assert t1.ids.tolist() == [2, 3, 1] and t1.values.tolist() == [1, 2, 3]
    assert (t1.min, t1.max, t1.limit) == (1, 3, 2.5)
    assert t1.feasible.tolist() == [True, True, False]
    t2 = a.test_table("f2")
    assert t2.ids.tolist() == [2, 1, 3]  # max: largest first
    assert a.test_table("f1", feasible_only=True).ids.tolist() == [2, 3]
    d = t1.to_dict(top=2)
    assert d["rows"] == [
        {"id": 2, "value": 1.0, "feasible": True},
        {"id": 3, "value": 2.0, "feasible": True},
    ]


def test_empty_set_names_the_culprit_and_smallest_relaxation():
    F = [[1, 5], [2, 4], [3, 3]]
    spec, t = make(F, limits=[1.5, 3.5])
    a = Analysis(spec, t)
    assert a.n_feasible == 0
    d = a.diagnose_empty()
    assert [(str(b), c) for b, c in d.cumulative] == [("f1 <= 1.5", 1), ("f2 <= 3.5", 0)]
    relax = {str(cur): (new.value, n) for cur, new, n in d.relaxations}
    assert relax == {"f1 <= 1.5": (3.0, 1), "f2 <= 3.5": (5.0, 1)}
    # relaxing exactly as suggested makes D non-empty
    assert Analysis(spec, t, {"f2": 5.0}).n_feasible == 1
    text = d.describe()
    assert "f2 <= 3.5 is the constraint that empties it" in text


def test_empty_set_needing_joint_relaxation():
    spec, t = make(
        [[1, 5], [5, 1]], limits=[0.5, 0.5], cons=[{"name": "g", "high": 0.0}], G=[[1.0], [3.0]]
    )
    d = Analysis(spec, t).diagnose_empty()
    assert d.relaxations == [] and d.joint is not None
    assert d.joint["id"] == 1
    bounds = {b.name: b.value for b in d.joint["bounds"]}
    assert bounds == {"g": 1.0, "f1": 1.0, "f2": 5.0}
    a = Analysis(spec, t, [parse_limit(f"{n}<={v}") for n, v in bounds.items()])
    assert a.n_feasible >= 1


@pytest.mark.parametrize("text", ["f1", "f1=3", "f1<=abc", "<=3", "f1<=nan"])
def test_parse_limit_errors(text):
    with pytest.raises(StudyDefinitionError, match="--limit"):
        parse_limit(text)


def test_parse_limit_forms():
    assert parse_limit("f1<=40").side == "high"
    assert parse_limit(" f2 >= -1e3 ").value == -1000
    assert math.isinf(parse_limit("f1<=inf").value)


def test_zdt1_pareto_trials_approach_the_known_pareto_set(tmp_path):
    """ZDT1 Pareto trials have g(x) -> 1 (residual g - 1 -> 0) as N grows.

    The trials with the smallest f1 stay non-dominated whatever their g (the edge of the
    sample), so the test follows the median and the 90 % quantile, which must shrink.
    Measured with 2 variables: median 0.35 / 0.105 / 0.049 at N = 256 / 1024 / 4096.
    """
    from vectorid import analytic

    prob = analytic.get("zdt1-2")
    stats = []
    for n in (256, 1024, 4096):
        path = tmp_path / f"zdt1-{n}.toml"
        path.write_text(study_toml("zdt1-2", trials=n), encoding="utf-8")
        with Study.create(load_study(path), tmp_path / f"z{n}.db") as st:
            st.run(executor="serial")
            a = st.analysis()
        resid = prob.pareto_set_residual(a.trials.X[a.pareto])
        stats.append((np.median(resid), np.quantile(resid, 0.9), a.n_pareto))
    medians, q90, counts = zip(*stats)
    assert medians[0] > medians[1] > medians[2]
    assert q90[0] > q90[2]
    assert medians[2] < 0.1  # g within 10 % of 1 for most Pareto trials at N = 4096
    assert counts[2] > counts[0]  # the front is resolved more finely


def test_a_widened_analysis_equals_a_fresh_one():
    """Loosening bounds from a memoised analysis (the UI's first loosening at 1e6 trials):
    D and the Pareto set equal a fresh analysis's on data with ties, exact duplicates, NaN,
    ±inf, failed trials, a max criterion, a pseudo one and a functional constraint; a tighter
    bound, a changed functional bound or other roles give None."""
    rng = np.random.default_rng(3)
    n = 3000
    F = rng.integers(0, 12, size=(n, 3)).astype(float)  # many ties and duplicates
    F[rng.random(n) < 0.01, 0] = np.nan
    F[rng.random(n) < 0.005, 1] = np.inf
    F[rng.random(n) < 0.005, 2] = -np.inf
    G = rng.normal(size=(n, 1))
    status = (rng.random(n) < 0.02).astype(np.int8)
    cons = [{"name": "g1", "low": -1.5, "high": 1.5}]
    spec, t = make(F, G, status, senses=("min", "max", "min"), roles=["pure", "pure", "pseudo"],
                   cons=cons)  # fmt: skip
    steps = [
        ({"f1": 2.0, "f2": 9.0, "f3": 3.0}, {"f1": 5.0, "f2": 9.0, "f3": 3.0}),  # one loosened
        ({"f1": 5.0, "f2": 9.0, "f3": 3.0}, {"f1": 8.0, "f2": 4.0, "f3": None}),  # three
        ({"f1": 8.0, "f2": 4.0, "f3": None}, {"f1": 8.0, "f2": 4.0, "f3": None}),  # the same
        ({"f1": 0.0, "f2": 11.0, "f3": -1.0}, {"f1": 1.0, "f2": 11.0, "f3": -1.0}),  # D empty
        ({"f1": 3.0, "f2": 6.0, "f3": 5.0}, {"f1": None, "f2": None, "f3": None}),  # no limit
    ]
    for before, after in steps:
        old = Analysis(spec, t, before)
        got = old.widened(after)
        want = Analysis(spec, t, after)
        assert got is not None, (before, after)
        assert np.array_equal(got.feasible, want.feasible), (before, after)
        assert np.array_equal(got.pareto, want.pareto), (before, after)
        assert got.n_pareto > 0 or want.n_feasible == 0
    old = Analysis(spec, t, {"f1": 5.0, "f2": 4.0})
    assert old.widened({"f1": 4.0, "f2": 3.0}) is None  # f1 tighter
    assert old.widened({"f1": 6.0, "f2": 4.0, "g1": (-1.0, 1.0)}) is None  # functional changed
    assert old.widened({"f1": 6.0, "f2": 4.0}, {"f2": "pseudo"}) is None  # other roles
