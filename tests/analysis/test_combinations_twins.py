"""Combinations on twins (issue 34, item 1): the parachute6dof model at ten random truths, all
15 parameters free on the sequential sampler, identified from one drop with noise-grounded
limits (the twins of tests/workflows/test_predict_twins.py): every combination's range holds
the truth's projection, the not-identified ones too."""

from __future__ import annotations

import pytest

from tests.workflows.test_predict_twins import ALL, twin
from vectorid.analysis.combinations import identifiable_combinations
from vectorid.study import Study


@pytest.mark.long
@pytest.mark.slow
def test_the_truth_lies_inside_every_combinations_range(tmp_path):
    """Ten twins, about 5 s each (the measured figures are in docs/identification.md)."""
    outside, named = [], 0
    for i in range(1, 21, 2):
        folder = tmp_path / f"t{i}"
        spec, truth, _ = twin(folder, i, ALL)
        with Study.create(spec, folder / "s.db") as st:
            st.run(executor="inline", progress=False)
            a = st.analysis()
        combos = identifiable_combinations(a, include_all=True)
        assert len(combos) >= 10
        named += sum(c.verdict != "not identified" for c in combos)
        for c in combos:
            v = c.value_of(truth)
            if not c.range[0] <= v <= c.range[1]:
                outside.append((i, c.text(), v, c.range))
    assert not outside, outside
    assert named >= 10  # at least one identified or weak combination per twin on average
