"""Relaxed criteria constraints, the named last resort (vectorid.analysis.relaxation)."""

from __future__ import annotations

import numpy as np
import pytest

from tests.analysis_helpers import make_store
from vectorid import Study
from vectorid.analysis.relaxation import relaxation_text, relaxed_limits
from vectorid.workflows.extra import relax_study


def test_relaxed_limits_are_the_smallest_common_factor_that_fills_d(tmp_path):
    with Study.open(make_store(tmp_path, trials=1000)) as st:
        a = st.analysis()
        limits = {"f1": 2.0, "f2": 4.0}
        assert st.analysis(limits).n_feasible < 50
        f, relaxed = relaxed_limits(a, limits, share=0.05, min_count=10)
        k = max(10, int(np.ceil(0.05 * st.analysis({}).n_feasible)))  # the constraints hold
        assert f > 1 and relaxed == pytest.approx({"f1": 2.0 * f, "f2": 4.0 * f})
        assert st.analysis(relaxed).n_feasible >= k
        tighter = {n: v * (f - 0.011) / f for n, v in relaxed.items()}
        assert st.analysis(tighter).n_feasible < k  # the smallest such factor (to 0.01)
        # D under the limits lies inside D under the relaxed ones (an outer bound)
        inner, outer = st.analysis(limits).feasible, st.analysis(relaxed).feasible
        assert np.all(outer[inner])
        # enough trials already: no relaxation
        assert relaxed_limits(a, {"f1": 1e6, "f2": 1e6}, share=0.05, min_count=10)[0] == 1.0


def test_relax_study_saves_the_relaxation_under_its_name(tmp_path):
    with Study.open(make_store(tmp_path, trials=1000), write=True) as st:
        rel = relax_study(st, {"f1": 2.0, "f2": 4.0}, {"f1": "noise floor"}, min_count=10)
        assert rel.relaxed and rel.n_at_limits < rel.n_needed
        assert "last resort: D at the stated limits was not reached" in rel.describe()
        crit = {c.name: c for c in st.spec.criteria}
        assert crit["f1"].limit == pytest.approx(2.0 * rel.factor)
        assert crit["f1"].source == "quantile"
        assert relaxation_text(rel.factor) in crit["f1"].limit_note
        # stated limits that D fills are saved as they are, with their source
        rel = relax_study(st, {"f1": 1e6, "f2": 1e6}, {"f1": "noise floor"}, min_count=10)
        assert not rel.relaxed and "stated limits" in rel.describe()
        crit = {c.name: c for c in st.spec.criteria}
        assert crit["f1"].limit == 1e6 and crit["f1"].source == "noise"
