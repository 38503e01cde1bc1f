"""The truth-versus-limits check of the twin demos."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from vectorid.workflows import TruthCheck, check_truth, truth_in_ranges


def test_check_truth_evaluates_the_truth_and_compares_each_limited_criterion():
    calls = []

    def evaluate(X):  # a batch model returning (F, G), as Identification.evaluate does
        calls.append(X.copy())
        return np.array([[2.0 * X[0, 0], X[0, 1], 7.0]]), np.zeros((1, 0))

    check = check_truth(evaluate, {"b": 3.0, "a": 1.0}, ["a", "b"], ["f", "g", "h"],
                        {"f": 4.0, "g": 2.0})  # fmt: skip
    assert np.array_equal(calls[0], [[1.0, 3.0]])  # columns in the variables' order
    assert check.values == {"f": 2.0, "g": 3.0, "h": 7.0}
    assert check.ratios == {"f": 0.5, "g": 1.5}  # h has no limit: not checked
    assert check.over == {"g": 1.5} and not check.meets
    assert check.closest() == ("g", 1.5)
    # a model that returns F alone
    only_f = check_truth(lambda X: X * 0.1, {"a": 1.0}, ["a"], ["f"], {"f": 1.0})
    assert only_f.meets and only_f.closest() == ("f", pytest.approx(0.1))
    with pytest.raises(KeyError):
        check_truth(evaluate, {"a": 1.0}, ["a", "b"], ["f"], {})


def test_a_criterion_the_truth_cannot_compute_does_not_meet_its_limit():
    check = TruthCheck({"f": float("nan"), "g": 0.5}, {"f": 1.0, "g": 1.0})
    assert not check.meets and list(check.over) == ["f"]


def test_truth_in_ranges_per_verdict():
    verdicts = [
        SimpleNamespace(name="a", feasible=(0.0, 1.0)),
        SimpleNamespace(name="b", feasible=(2.0, 3.0)),
        SimpleNamespace(name="c", feasible=None),  # D empty: no range to hold it
        SimpleNamespace(name="d", feasible=(0.0, 1.0)),  # no truth given
    ]
    got = truth_in_ranges(verdicts, {"a": 1.0, "b": 1.5, "c": 0.0})
    assert got == {"a": True, "b": False, "c": None, "d": False}
