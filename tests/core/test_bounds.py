"""Tests of hybridedit.core.bounds."""

import numpy as np

from hybridedit.core.bounds import points_box
from hybridedit.core.mesh import Mesh


def test_points_box_leaves_out_the_skipped_rows():
    rng = np.random.default_rng(5)
    P = rng.standard_normal((500, 3)).astype(np.float32)
    skip = rng.random(500) < 0.3
    lo, hi = points_box(P, skip=skip)
    assert lo.dtype == np.float64
    assert np.array_equal(lo, P[~skip].min(axis=0)) and np.array_equal(hi, P[~skip].max(axis=0))
    lo, hi = points_box(P)
    assert np.array_equal(lo, P.min(axis=0)) and np.array_equal(hi, P.max(axis=0))
    lo, hi = points_box(P, skip=np.ones(500, dtype=bool))  # nothing left: an empty box
    assert np.all(lo == np.inf) and np.all(hi == -np.inf)
    lo, hi = points_box(np.zeros((0, 3)))
    assert np.all(lo > hi)


def test_points_box_is_numpys_box_nan_included():
    rng = np.random.default_rng(6)
    P = rng.standard_normal((300, 3)) * 1e3
    P[17, 1] = np.nan
    lo, hi = points_box(P)
    with np.errstate(invalid="ignore"):
        assert np.array_equal(lo, P.min(axis=0), equal_nan=True)
        assert np.array_equal(hi, P.max(axis=0), equal_nan=True)
    assert np.isnan(lo[1]) and np.isnan(hi[1]) and np.isfinite(lo[[0, 2]]).all()
    lo, hi = points_box(np.arange(12).reshape(4, 3))  # integers: as float64
    assert np.array_equal(lo, [0, 1, 2]) and np.array_equal(hi, [9, 10, 11]) and lo.dtype == np.float64


def test_mesh_bbox_is_the_compiled_box():
    m = Mesh(np.random.default_rng(7).standard_normal((1000, 3)), np.array([[0, 1, 2]]))
    lo, hi = m.bbox()
    assert np.array_equal(lo, m.vertices.min(axis=0)) and np.array_equal(hi, m.vertices.max(axis=0))
    assert m.bbox_diagonal() == float(np.linalg.norm(hi - lo))
    lo, hi = Mesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)).bbox()
    assert np.array_equal(lo, np.zeros(3)) and np.array_equal(hi, np.zeros(3))
