"""Fuzz table: what a model may return or do. Every bad answer becomes a failed trial whose
reason names what came (real values and shapes, never masked), every good one is stored
exactly; crashes, exits and hangs fail only their trial in every executor; a study whose
first trials all fail stops at once with the reason and the fix, storing nothing."""

from __future__ import annotations

import decimal
import textwrap

import numpy as np
import pytest

from vectorid import Criterion, FunctionalConstraint, Problem, Study, load_study
from vectorid.problem import FAILED, OK, as_batch

from ..conftest import write_user_study
from ._harness import cli, expect, expect_error

KIND = "models"

CRIT = (Criterion("f1"), Criterion("f2"))
CONS = (FunctionalConstraint("g", high=1.5),)
X = np.linspace(0.1, 0.9, 24).reshape(8, 3)


def good(X):
    return np.column_stack([X[:, 0], X[:, 1]]), X[:, 2:3]


def _c(X):
    f, g = good(X)
    return f.astype(complex) + 1j, g


def _c0(X):
    f, g = good(X)
    return f.astype(complex), g


def _nan(X):
    f, g = good(X)
    f[2, 0] = np.nan
    return f, g


def _inf(X):
    f, g = good(X)
    g[3, 0] = np.inf
    return f, g


def _mutate(X):
    out = good(X.copy())
    X[:] = 99.0
    return out


# (id, model, predicate on the EvalResult, what it checks)
BATCH_CASES = [
    (
        "complex",
        _c,
        lambda r: r.messages[0].startswith("complex result") and "f1=" in r.messages[0],
    ),
    ("complex zero imag", _c0, lambda r: (r.status == OK).all()),
    (
        "strings",
        lambda X: ([["1", "2"]] * len(X), X[:, :1]),
        lambda r: "not numbers" in r.messages[0],
    ),
    ("bools", lambda X: (X[:, :2] > 0.5, X[:, :1]), lambda r: "not numbers" in r.messages[0]),
    ("None cells", lambda X: ([[None, 1.0]] * len(X), X[:, :1]), lambda r: "None" in r.messages[0]),
    (
        "decimals",
        lambda X: ([[decimal.Decimal(1), 1.0]] * len(X), X[:, :1]),
        lambda r: "Decimal" in r.messages[0],
    ),
    (
        "too many columns",
        lambda X: (np.ones((len(X), 3)), X[:, :1]),
        lambda r: "shape (8, 3), expected (8, 2)" in r.messages[0],
    ),
    (
        "one column",
        lambda X: np.ones(len(X)),
        lambda r: "shape (8,), expected (8, 2)" in r.messages[0],
    ),
    ("no functionals", lambda X: np.ones((len(X), 2)), lambda r: "no functionals" in r.messages[0]),
    ("triple", lambda X: (1, 2, 3), lambda r: "tuple of 3" in r.messages[0]),
    ("None", lambda X: None, lambda r: (r.status == FAILED).all()),
    ("dict", lambda X: {"f1": 1}, lambda r: (r.status == FAILED).all()),
    ("raises", lambda X: 1 / 0, lambda r: r.messages[0].startswith("ZeroDivisionError")),
    (
        "nan",
        _nan,
        lambda r: r.messages.get(2) == "non-finite result: f1=nan" and len(r.messages) == 1,
    ),
    (
        "inf",
        _inf,
        lambda r: r.messages.get(3) == "non-finite result: g=inf" and len(r.messages) == 1,
    ),
    (
        "sys.exit",
        lambda X: __import__("sys").exit(3),
        lambda r: "the model called sys.exit(3)" in r.messages[0],
    ),
    (
        "float32",
        lambda X: tuple(a.astype(np.float32) for a in good(X)),
        lambda r: (r.status == OK).all(),
    ),
    (
        "ints",
        lambda X: (np.ones((len(X), 2), int), np.zeros((len(X), 1), int)),
        lambda r: (r.status == OK).all(),
    ),
    (
        "lists",
        lambda X: (good(X)[0].tolist(), good(X)[1].tolist()),
        lambda r: (r.status == OK).all(),
    ),
    ("mutates X", _mutate, lambda r: (r.status == OK).all()),
]


@pytest.mark.parametrize(("case", "model", "check"), BATCH_CASES, ids=[c[0] for c in BATCH_CASES])
def test_batch_model_answers(case, model, check):
    x = X.copy()
    res = Problem(model, CRIT, CONS).evaluate(x)
    ok = bool(check(res))
    if case in ("float32", "ints", "lists", "complex zero imag"):
        f, g = good(X)
        want = (np.ones((8, 2)), np.zeros((8, 1))) if case == "ints" else (f, g)
        tol = 1e-6 if case == "float32" else 0
        ok = ok and np.allclose(res.criteria, want[0], rtol=tol, atol=tol)
    if case == "mutates X":
        ok = ok and np.array_equal(x, X) and np.array_equal(res.criteria, good(X)[0])
    expect(KIND, ok, f"{case}: {res.status} {res.messages}")


PER_TRIAL_CASES = [
    ("scalar for two criteria", lambda x: 1.0, "shape (1,), expected (2,)"),
    ("row and row", lambda x: ([x[0], x[1]], [x[2]]), None),
    ("complex row", lambda x: ([1 + 1j, 2.0], [0.0]), "complex result"),
    ("string row", lambda x: (["a", "b"], [0.0]), "not numbers"),
    ("exit", lambda x: __import__("sys").exit("bye"), "sys.exit('bye')"),
]


@pytest.mark.parametrize(
    ("case", "func", "match"), PER_TRIAL_CASES, ids=[c[0] for c in PER_TRIAL_CASES]
)
def test_per_trial_model_answers(case, func, match):
    res = Problem(as_batch(func), CRIT, CONS).evaluate(X.copy())
    if match is None:
        ok = (res.status == OK).all() and np.array_equal(res.criteria, X[:, :2])
    else:
        ok = (res.status == FAILED).all() and all(match in m for m in res.messages.values())
    expect(KIND, bool(ok), f"{case}: {res.messages}")


FAULTS = """
import ctypes
import os
import sys
import time

import numpy as np

from usermodel import evaluate

A = 0.40625  # x1 of trial 27


def _hit(X):
    return bool(np.any(np.abs(X[:, 0] - A) < 1e-12))


def segfault(X):
    if _hit(X):
        ctypes.string_at(0)
    return evaluate(X)


def abort(X):
    if _hit(X):
        os.abort()
    return evaluate(X)


def exit0(X):
    if _hit(X):
        os._exit(0)
    return evaluate(X)


def sysexit(X):
    if _hit(X):
        sys.exit(0)
    return evaluate(X)


def hang(X):
    if _hit(X):
        time.sleep(600)
    return evaluate(X)


def wrong_shape(X):
    return np.ones((len(X), 3)), X[:, :1]


def all_nan(X):
    return np.full((len(X), 2), np.nan), X[:, :1]


def index_error(X):
    return np.column_stack([X[:, 5], X[:, 0]]), X[:, :1]
"""

FAULT_CASES = [
    ("segfault", "killed by signal 11 (SIGSEGV"),
    ("abort", "killed by signal 6 (SIGABRT"),
    ("exit0", "exited with status 0"),
    ("sysexit", "the model called sys.exit(0)"),
    ("hang", "timed out after 1"),
]


def _fault_study(folder, func):
    study = write_user_study(folder, trials=48)
    (folder / "faults.py").write_text(textwrap.dedent(FAULTS))
    text = study.read_text().replace("usermodel:evaluate", f"faults:{func}")
    path = folder / f"{func}.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("executor", ["serial", "processes"])
@pytest.mark.parametrize(("func", "match"), FAULT_CASES, ids=[c[0] for c in FAULT_CASES])
def test_faulty_trial_fails_alone_in_every_executor(tmp_path, executor, func, match):
    study = _fault_study(tmp_path / "s", func)
    reference = load_study(study.with_name("user.toml"))
    with Study.create(load_study(study), tmp_path / "f.db") as st:
        st.run(executor=executor, workers=2, batch_size=8, timeout=1.0)
        t = st.trials()
    X = reference.space.scale(reference.point_sequence().points(0, 48))
    ref = reference.problem().evaluate(X)
    bad = np.flatnonzero(t.id == 27)
    others = t.id != 27
    ok = (
        len(t) == 48
        and t.status[bad[0]] == FAILED
        and match in t.message(int(bad[0]))
        and np.array_equal(t.status[others], ref.status[others])
        and np.array_equal(
            np.nan_to_num(t.F[others], nan=-1), np.nan_to_num(ref.criteria[others], nan=-1)
        )
    )
    expect(KIND, bool(ok), f"{executor}/{func}: {t.message(int(bad[0])) if len(bad) else 'none'}")


LOUD_CASES = [
    ("wrong_shape", r"all 8 trials .*shape \(8, 3\), expected \(8, 2\).*2 criteria \(f1, f2\)"),
    ("all_nan", r"all 8 trials .*non-finite result: f1=nan, f2=nan.*NaN"),
    ("index_error", r"all 8 trials .*IndexError: index 5 is out of bounds.*3 variables"),
]


@pytest.mark.parametrize(("func", "match"), LOUD_CASES, ids=[c[0] for c in LOUD_CASES])
def test_study_whose_first_trials_all_fail_stops_at_once(tmp_path, func, match):
    study = _fault_study(tmp_path / "s", func)
    store = tmp_path / "l.db"
    r = cli("run", study, "--store", store, "--batch-size", "8", "--quiet")
    expect_error(KIND, r, match)
    from vectorid.store import Store

    with Store.open(store) as st:
        expect(KIND, st.count() == 0, "trials stored after a loud stop")
    r = cli("run", study, "--store", store, "--batch-size", "8", "--quiet", "--keep-going")
    expect(KIND, r.code == 0 and "48 of 48 trials failed (100 %)" in r.out, r.out + r.err, r)


def test_readme_study_with_a_two_variable_builtin(tmp_path):
    """The README's one-variable study with model = "binh-korn": stopped before any trial,
    naming both shapes (it used to store 2048 failed trials and print '2048 0 0')."""
    text = textwrap.dedent(
        """
        [study]
        name = "example"
        model = "binh-korn"
        trials = 2048
        seed = 1

        [[variables]]
        name = "x1"
        low = 0.0
        high = 5.0

        [[criteria]]
        name = "f1"
        sense = "min"
        limit = 40.0

        [[constraints]]
        name = "g1"
        low = 0.0
        high = 25.0
        """
    )
    path = tmp_path / "example.toml"
    path.write_text(text)
    r = cli("run", path, "--quiet")
    expect_error(KIND, r, r"'binh-korn' takes 2 variables \(x1, x2\).*this study has 1 variable")
    # fixed file, same store: re-created without deleting anything by hand
    fixed = text.replace(
        "[[criteria]]", '[[variables]]\nname = "x2"\nlow = 0.0\nhigh = 3.0\n\n[[criteria]]', 1
    )
    fixed = fixed.replace(
        "limit = 40.0", 'limit = 40.0\n\n[[criteria]]\nname = "f2"\nsense = "min"'
    )
    fixed += '\n[[constraints]]\nname = "g2"\nlow = 7.7\n'
    path.write_text(fixed)
    r = cli("run", path, "--quiet", "--trials", "64", "--executor", "serial")
    expect(KIND, r.code == 0 and "64 trials computed" in r.out, r.out + r.err, r)
