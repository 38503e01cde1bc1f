"""The report's and UI's identifiability fragments: the combinations table (issue 34)."""

from __future__ import annotations

from tests.analysis.test_combinations import _sum_spec
from vectorid import Study
from vectorid.views.identifiability import combinations_html


def test_combinations_html_names_the_combination_and_checks_a_truth(tmp_path):
    with Study.create(_sum_spec(), tmp_path / "s.db") as st:
        st.run(executor="inline", progress=False)
        a = st.analysis()
    html = combinations_html(a, truth={"x1": 0.5, "x2": 0.43, "x3": 0.2})
    assert "z(x1)" in html and "z(x2)" in html and "z(x3)" not in html
    assert "identified" in html and "truth inside" in html and ">yes (" in html
    far = combinations_html(a, truth={"x1": 0.9, "x2": 0.9, "x3": 0.2})
    assert ">NO (" in far
    empty = combinations_html(a.narrowed({"f": 1e-9}))
    assert "no combination can show a spread" in empty
