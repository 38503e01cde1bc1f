"""What a sequential run that did not reach D says: never that the model or the limits do not
fit while a search inside the box might still meet them; a local search pressed against the
box's edge says the box may be too narrow there, naming the variables and the edges."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from vectorid.problem import Criterion
from vectorid.run.loop import run_store
from vectorid.samplers.sequential import LocalSearch, SequentialSummary
from vectorid.space import Continuous, Space
from vectorid.spec import StudySpec
from vectorid.store import Store

SRC = Path(__file__).resolve().parents[3] / "src" / "vectorid"
BLAME = re.compile(
    r"(model|limits)[^.;\n]{0,40}(do|does|may) not fit (the|these) (data|flights?)", re.I
)


def beyond_the_box(X):
    """Best at x0 = 1.3, outside the box [0, 1]: the nearest vectors sit on x0's high edge."""
    return np.abs(X[:, [0]] - 1.3) + 0.1 * np.abs(X[:, [1]] - 0.5), np.zeros((len(X), 0))


def test_a_search_on_the_box_edge_blames_the_box_not_the_model(tmp_path):
    spec = StudySpec(
        name="edge", model=beyond_the_box,
        space=Space([Continuous("x0", 0.0, 1.0, unit="m"), Continuous("x1", 0.0, 1.0)]),
        criteria=(Criterion("f", limit=0.05),), sampler="sequential", trials=64, budget=600,
        population=50, seed=0,
    )  # fmt: skip
    with Store.create(tmp_path / "edge.db", spec) as st:
        s = run_store(st, executor="inline", progress=False)
    text = s.describe()
    assert not s.converged and s.search is not None and not s.search.met, text
    assert s.search.edges == [("x0", "high", 1.0)], s.search.edges
    assert "against its high edge 1" in text and "the box may be too narrow" in text, text
    assert not BLAME.search(text), text


def _summary(**kw) -> SequentialSummary:
    base = dict(
        target=0, budget=1000, population=100, generations=5, evaluations=1000, members=0,
        ess=0.0, converged=False, relaxed=1.4, names=["a", "b"],
    )  # fmt: skip
    return SequentialSummary(**(base | kw))


def _search(factor, edges=()):
    return LocalSearch(7, 1.5, factor, np.array([0.1, 0.2]), 400, 1, list(edges))


def test_only_a_search_that_also_misses_inside_the_box_may_blame_the_model():
    cases = {
        "budget spent, no search": _summary(),
        "search met": _summary(search=_search(0.9)),
        "search at the edge": _summary(search=_search(1.2, [("b", "low", 0.0)])),
        "collapsed": _summary(members=150, ess=3.0),
        "members, ESS short": _summary(members=150, ess=60.0),
    }
    for what, s in cases.items():
        text = s.verdict()
        assert "D not reached" in text, (what, text)
        assert not BLAME.search(text), (what, text)
    edge = cases["search at the edge"].verdict()
    assert "b=0.2 against its low edge 0" in edge and "too narrow" in edge
    inside = _summary(search=_search(1.2)).verdict()
    assert "also misses" in inside and "inside the box" in inside and BLAME.search(inside)
    assert "D reached" in _summary(members=150, ess=150.0, converged=True).verdict()


def test_edges_are_those_within_a_percent_of_the_width():
    from vectorid.samplers.sequential import search_edges

    spec = StudySpec(
        name="e", model=beyond_the_box, criteria=(Criterion("f", limit=0.05),),
        space=Space([Continuous("a", 0.1, 3.0), Continuous("b", -1.0, 1.0),
                     Continuous("c", 0.0, 1.0)]),
    )  # fmt: skip
    u = np.array([0.0006, 0.5, 0.995])  # the ETH search's Cnr: 0.1017 in [0.1, 3]
    assert search_edges(spec, u) == [("a", "low", 0.1), ("c", "high", 1.0)]
    assert search_edges(spec, np.array([0.02, 0.5, 0.98])) == []


def test_no_other_message_blames_the_model_or_the_limits():
    """The sampler's verdict above is the only place the source may say the model or the
    limits may not fit; anything else would speak before a search has tried."""
    hits = []
    for path in [*SRC.rglob("*.py"), *(SRC.parents[1] / "examples").glob("*.py")]:
        text = path.read_text(encoding="utf-8")
        for m in BLAME.finditer(text):
            line = text.count("\n", 0, m.start()) + 1
            hits.append(f"{path.relative_to(SRC.parents[1])}:{line}")
    allowed = {p for p in hits if p.startswith("src/vectorid/samplers/sequential/sampler.py")}
    assert set(hits) == allowed, hits
    seq = (SRC / "samplers" / "sequential" / "sampler.py").read_text(encoding="utf-8")
    body = seq[seq.index("def verdict") : seq.index("def describe")]
    assert len(BLAME.findall(body)) == 1 and "inside the box, so the model" in body
