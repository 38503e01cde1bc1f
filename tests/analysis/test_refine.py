"""Double tuning never cuts off a Pareto trial; applying it continues the Sobol sequence."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.analysis_helpers import make_store
from vectorid import Study
from vectorid.analysis.refine import propose_refine, refine_history
from vectorid.errors import StudyDefinitionError
from vectorid.sampling import PointSequence
from vectorid.workflows.extra import apply_refine


@pytest.fixture(scope="module")
def zdt(tmp_path_factory):
    path = make_store(tmp_path_factory.mktemp("ref"), problem="binh-korn", trials=512)
    with Study.open(path) as s:
        yield s.spec, s.store.load(), s.store.stages()


@settings(max_examples=40, deadline=None)
@given(
    f1=st.floats(5.0, 150.0),
    f2=st.floats(5.0, 60.0),
    q=st.floats(0.0, 0.45),
    margin=st.floats(0.0, 0.5),
    pareto=st.booleans(),
)
def test_never_excludes_a_pareto_trial(zdt, f1, f2, q, margin, pareto):
    from vectorid.analysis import Analysis

    spec, trials, stages = zdt
    a = Analysis(spec, trials, {"f1": f1, "f2": f2})
    if a.n_feasible == 0:
        return
    p = propose_refine(
        a, stages, basis="pareto" if pareto else "feasible", quantile=q, margin=margin
    )
    assert p.pareto_outside == 0
    assert np.all(p.new.contains(trials.X[a.pareto]))
    assert np.all(p.new.lows >= spec.space.lows) and np.all(p.new.highs <= spec.space.highs)
    assert np.all(p.new.highs - p.new.lows >= 0.02 * (spec.space.highs - spec.space.lows) - 1e-12)


def test_rule_on_constructed_envelope(zdt):
    from vectorid.analysis import Analysis

    spec, trials, stages = zdt
    a = Analysis(spec, trials, {"f1": 20.0})
    p = propose_refine(a, stages, quantile=0.0, margin=0.0)
    # quantile 0, margin 0: the box is the feasible set's bounding box (Pareto inside it)
    X = trials.X[a.feasible]
    np.testing.assert_allclose(p.new.lows, X.min(axis=0))
    np.testing.assert_allclose(p.new.highs, X.max(axis=0))
    assert p.feasible_inside == a.n_feasible
    p2 = propose_refine(a, stages, quantile=0.0, margin=0.1)
    w = X.max(axis=0) - X.min(axis=0)
    np.testing.assert_allclose(p2.new.highs, np.minimum(X.max(axis=0) + 0.1 * w, [5, 3]))


def test_override_and_errors(zdt):
    from vectorid.analysis import Analysis

    spec, trials, stages = zdt
    a = Analysis(spec, trials, {"f1": 60.0})
    p = propose_refine(a, stages, bounds={"x1": (3.0, 4.0)})
    assert (p.new.lows[0], p.new.highs[0]) == (3.0, 4.0) and p.overrides == {"x1": (3.0, 4.0)}
    outside = ~((trials.X[a.pareto, 0] >= 3.0) & (trials.X[a.pareto, 0] <= 4.0))
    assert p.pareto_outside == int(outside.sum()) > 0
    with pytest.raises(StudyDefinitionError, match="unknown variable"):
        propose_refine(a, stages, bounds={"x9": (0, 1)})
    with pytest.raises(StudyDefinitionError, match="LO < HI"):
        propose_refine(a, stages, bounds={"x1": (2, 1)})
    with pytest.raises(StudyDefinitionError, match="quantile"):
        propose_refine(a, stages, quantile=0.7)
    empty = Analysis(spec, trials, {"f1": -1.0})
    with pytest.raises(StudyDefinitionError, match="empty"):
        propose_refine(empty, stages)


def test_apply_continues_the_sobol_sequence_in_the_new_box(tmp_path):
    path = make_store(tmp_path, trials=256)
    with Study.open(path, write=True) as s:
        a = s.analysis({"f1": 30.0})
        p = propose_refine(a, s.store.stages())
        stage = apply_refine(s.store, p)
        assert stage.kind == "sample" and stage.start_seq == 256
        s.run(trials=384, executor="serial")
        t = s.store.load()
        hist = refine_history(s.store)
    new = t.stage == stage.stage
    assert new.sum() == 128
    assert np.array_equal(t.seq[new], np.arange(256, 384))
    assert np.array_equal(t.id[new], np.arange(257, 385))
    assert np.all(p.new.contains(t.X[new]))
    # the same Sobol points, scaled to the new box
    q = PointSequence(2, "sobol").points(256, 128)
    np.testing.assert_allclose(t.X[new], p.new.scale(q))
    assert [h["stage"] for h in hist] == [0, stage.stage]
    assert {c["name"] for c in hist[1]["changed"]} <= {"x1", "x2"} and hist[1]["changed"]
    assert "basis=feasible" in hist[1]["note"] and hist[1]["n"] == 128
