"""Identifiable combinations (issue 34, item 1): a known answer (only x1 + x2 determined), the
same answer whatever units the box is written in, ranges that hold a 33-dimensional D's known
extent, and, on parachute twins (slow), the truth inside every range."""

from __future__ import annotations

import doctest
import math

import numpy as np
import pytest

import vectorid.analysis.combinations as combinations_module
from vectorid import Continuous, Criterion, Space, Study, StudySpec
from vectorid.analysis.combinations import (
    combinations_json,
    combinations_of,
    identifiable_combinations,
    widened_range,
)

CENTRE, HALF = 0.93, 0.041  # D: |x1 + x2 - CENTRE| <= HALF


def _sum_spec(scale2: float = 1.0, high3: float = 1.0, unit2: str = "m") -> StudySpec:
    """Three gains, a criterion that sees only x1 + x2; x2 written in 1/scale2 of a metre.

    x2 is the third variable: the first two coordinates of a Sobol table form a net whose
    sums cluster (gaps of 0.01 in x1 + x2), the first and third do not."""

    def model(X):
        f = np.abs(X[:, 0] + X[:, 2] / scale2 - CENTRE)
        return f[:, None], np.empty((len(X), 0))

    space = Space(
        [
            Continuous("x1", 0.0, 1.0, unit="m"),
            Continuous("x3", 0.0, high3, unit="m"),
            Continuous("x2", 0.0, scale2, unit=unit2),
        ]
    )
    return StudySpec(
        "sum", model, space, (Criterion("f", limit=HALF, unit="m"),), trials=2048, seed=1
    )


@pytest.fixture(scope="module")
def sum_analyses(tmp_path_factory):
    """The x1 + x2 study in metres, and again with x2 in millimetres and x3's box 5 m wide."""
    out = []
    for k, kw in enumerate(({}, {"scale2": 1000.0, "unit2": "mm", "high3": 5.0})):
        path = tmp_path_factory.mktemp(f"sum{k}") / "s.db"
        with Study.create(_sum_spec(**kw), path) as st:
            st.run(executor="inline", progress=False)
            out.append(st.analysis())
    return out


def test_only_x1_plus_x2_is_determined(sum_analyses):
    a = sum_analyses[0]
    combos = identifiable_combinations(a, include_all=True)
    assert combos[0].verdict == "identified"
    assert [c.verdict for c in combos[1:]] == ["not identified"] * (len(combos) - 1)
    c = combos[0]
    assert set(c.loadings) == {"x1", "x2"}
    assert c.loadings["x1"] == pytest.approx(math.sqrt(0.5), abs=0.02)
    assert c.loadings["x2"] == pytest.approx(math.sqrt(0.5), abs=0.02)
    # D's extent along (z1 + z2)/√2 is (CENTRE ± HALF)/√2: the range holds it, and not much more
    true = ((CENTRE - HALF) / math.sqrt(2), (CENTRE + HALF) / math.sqrt(2))
    # (within 5 % of its width: D's 151 members of a Sobol table are not centred in it)
    tol = 0.05 * (true[1] - true[0])
    assert c.range[0] <= true[0] + tol and c.range[1] >= true[1] - tol
    assert c.width_fraction < 1.3 * (true[1] - true[0])
    assert c.members_range[0] >= c.range[0] and c.members_range[1] <= c.range[1]
    # every gain alone is not identified: the combination is what the data fix
    assert all(v.verdict != "identified" for v in a.verdicts())
    # the value of a vector in the gains' own units is its projection
    assert c.value_of({"x1": 0.4, "x2": 0.6}) == pytest.approx(
        0.4 * c.loadings["x1"] + 0.6 * c.loadings["x2"]
    )
    doc = combinations_json(identifiable_combinations(a))
    assert [sorted(d["loadings"]) for d in doc["combinations"]] == [["x1", "x2"]]
    assert set(doc["combinations"][0]) >= {"loadings", "range", "width_fraction", "verdict"}
    assert "z-" not in c.text() and "z(x1)" in c.text()


def test_the_box_written_in_other_units_changes_nothing(sum_analyses):
    a, b = sum_analyses
    ca = identifiable_combinations(a, include_all=True)
    cb = identifiable_combinations(b, include_all=True)
    assert [c.verdict for c in ca] == [c.verdict for c in cb]
    for x, y in zip(ca, cb):
        assert list(x.loadings) == list(y.loadings)
        assert np.allclose(list(x.loadings.values()), list(y.loadings.values()), atol=1e-9)
        assert np.allclose(x.range, y.range, atol=1e-9)
    # read in its own unit, x2's coefficient is per mm: 1000 times smaller
    assert cb[0].per_unit["x2"] == pytest.approx(ca[0].per_unit["x2"] / 1000.0)


def _ellipsoid(p: int = 33, n: int = 5000, seed: int = 3):
    """A uniform sample of an ellipsoid in the unit box (semi-axes 0.01–0.2, rotated at random)
    and its matrix M: D = {z : (z - c)ᵀ M⁻¹ (z - c) <= 1}, extent along v: c·v ± √(vᵀ M v)."""
    rng = np.random.default_rng(seed)
    Q, _ = np.linalg.qr(rng.normal(size=(p, p)))
    axes = np.exp(rng.uniform(math.log(0.01), math.log(0.2), p))
    g = rng.normal(size=(n, p))
    g /= np.linalg.norm(g, axis=1)[:, None]
    Y = g * (rng.uniform(size=n) ** (1.0 / p))[:, None] * axes
    return 0.5 + Y @ Q.T, Q @ np.diag(axes**2) @ Q.T


def test_ranges_hold_a_33_dimensional_ds_known_extent():
    """The measurement of the module docstring: the widened ranges hold the extent of a known
    D along every direction reported; the members' own min-max falls short of it."""
    Z, M = _ellipsoid()
    names = [f"g{i}" for i in range(Z.shape[1])]
    combos = combinations_of(Z, names, include_all=True)
    assert len(combos) >= 30
    short, held = [], 0
    for c in combos:
        v = np.array([c.loadings.get(g, 0.0) for g in names])
        ext = math.sqrt(v @ M @ v)
        lo, hi = 0.5 * v.sum() - ext, 0.5 * v.sum() + ext
        held += c.range[0] <= lo + 0.02 * ext and c.range[1] >= hi - 0.02 * ext
        assert c.range[1] - c.range[0] <= 1.1 * (hi - lo)
        assert c.range[0] <= lo + 0.05 * ext and c.range[1] >= hi - 0.05 * ext
        short.append((c.members_range[1] - c.members_range[0]) / (hi - lo))
    assert held >= 0.9 * len(combos), f"{held}/{len(combos)} ranges hold D's extent"
    assert max(short) < 0.85  # the members alone under-cover D's boundary


def test_a_slab_keeps_its_width():
    """A D bounded on both sides along one direction (a uniform interval): √3·sd is its
    half-width, so the range is the interval, not wider."""
    t = np.random.default_rng(0).uniform(0.4, 0.6, 3000)
    (lo, hi), f = widened_range(t, p=10)
    assert f < 2.0
    assert lo == pytest.approx(0.4, abs=0.01) and hi == pytest.approx(0.6, abs=0.01)


def test_thin_d_is_at_most_weak():
    rng = np.random.default_rng(1)
    Z = np.column_stack([rng.uniform(0.49, 0.51, 8), rng.uniform(0.0, 1.0, 8)])
    combos = combinations_of(Z, ["a", "b"])
    assert combos and all(c.verdict == "weak" and c.thin for c in combos)
    assert "fewer than the 10" in combos[0].reason


def test_docstring_example_runs():
    assert doctest.testmod(combinations_module).failed == 0


def test_a_large_d_reads_its_moments_from_a_spread_subsample_and_holds_every_member(monkeypatch):
    """Above STATS_MEMBERS members the directions and margins come from an even subsample:
    every member still lies inside every range, and the answer matches the full computation."""
    rng = np.random.default_rng(5)
    n, p = 12_000, 6
    Z = rng.random((n, p))
    Z[:, 0] = 0.5 + 0.04 * (Z[:, 0] - 0.5) + 0.3 * (Z[:, 1] - 0.5)
    names = [f"x{i}" for i in range(p)]
    full = combinations_of(Z, names)
    monkeypatch.setattr(combinations_module, "STATS_MEMBERS", 3_000)
    part = combinations_of(Z, names)
    assert len(part) == len(full) == 1
    u = np.array([part[0].loadings.get(k, 0.0) for k in names])
    t = Z @ u
    assert part[0].range[0] <= t.min() and t.max() <= part[0].range[1]
    assert part[0].members_range == pytest.approx((t.min(), t.max()))
    assert part[0].verdict == full[0].verdict
    assert part[0].range == pytest.approx(full[0].range, abs=0.01)
