import numpy as np
import pytest
from scipy.stats import qmc

from vectorid import PointSequence, StudyDefinitionError


def test_unscrambled_sobol_is_lp_tau_numbered_from_one():
    s = PointSequence(3)
    pts = s.points(0, 4)
    ref = qmc.Sobol(3, scramble=False).random(8)[1:5]
    np.testing.assert_array_equal(pts, ref)
    np.testing.assert_array_equal(pts[0], [0.5, 0.5, 0.5])  # Q_1 of the LP_tau tables


@pytest.mark.parametrize("kind", ["sobol", "lhs"])
@pytest.mark.parametrize("scramble", [False, True])
def test_continuation_equals_one_long_draw(kind, scramble):
    s = PointSequence(5, kind, scramble=scramble, seed=7, block=256)
    whole = s.points(0, 2048)
    parts = np.vstack([s.points(0, 1024), s.points(1024, 1000), s.points(2024, 24)])
    np.testing.assert_array_equal(whole, parts)
    # any odd window is the same slice
    np.testing.assert_array_equal(s.points(333, 517), whole[333:850])


def test_same_seed_same_points_different_seed_different():
    a = PointSequence(4, scramble=True, seed=1).points(0, 64)
    b = PointSequence(4, scramble=True, seed=1).points(0, 64)
    c = PointSequence(4, scramble=True, seed=2).points(0, 64)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)


def test_lhs_blocks_are_latin_hypercubes():
    s = PointSequence(3, "lhs", seed=3, block=100)
    pts = s.points(100, 100)  # block 1 exactly
    for j in range(3):
        cells = np.floor(pts[:, j] * 100).astype(int)
        assert sorted(cells) == list(range(100))


def test_sobol_points_fill_unit_cube_uniformly():
    pts = PointSequence(2).points(0, 1023)
    # every 1/32 x 1/32 cell of the first 1024 points holds exactly one point (t=0 net),
    # the skipped origin being the missing one
    cells = np.floor(pts * 32).astype(int)
    assert len({tuple(c) for c in cells}) == 1023


def test_unknown_sequence_rejected():
    with pytest.raises(StudyDefinitionError, match="unknown point sequence 'halton'"):
        PointSequence(2, "halton")
