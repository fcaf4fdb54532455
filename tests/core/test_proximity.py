"""Tests of hybridedit.core.proximity."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from hybridedit.core import parallel
from hybridedit.core.proximity import rows_near


def _tree_answer(P, rows, sites, radius):
    d, _ = cKDTree(P[sites]).query(P[rows], distance_upper_bound=radius)
    return np.isfinite(d)


@pytest.mark.parametrize("threshold", [0, 10**9])  # the parallel twin, the serial one
def test_rows_near_is_the_k_d_trees_answer(monkeypatch, threshold):
    monkeypatch.setitem(parallel.THRESHOLDS, "propagate", threshold)
    rng = np.random.default_rng(2)
    P = rng.uniform(-1, 1, (30_000, 3))
    P[:50] *= 1e3  # points far outside the sites' grid
    rows = rng.choice(30_000, 12_000, replace=False)
    sites = rng.choice(30_000, 4_000, replace=False)
    for radius in (1e-3, 0.02, 0.1, 0.5, 5.0):
        got = rows_near(P, rows, sites, radius)
        assert np.array_equal(got, _tree_answer(P, rows, sites, radius)), radius
    # a handful of sites spread over a huge box: the grid's cells widen (still exact)
    few = np.array([50, 51, 52, 100])
    assert np.array_equal(rows_near(P, rows, few, 0.05), _tree_answer(P, rows, few, 0.05))
    # sites on a plane (a flat box), a site exactly at the radius (strictly less counts)
    flat = P.copy()
    flat[:, 2] = 0.0
    assert np.array_equal(rows_near(flat, rows, sites, 0.03), _tree_answer(flat, rows, sites, 0.03))
    Q = np.array([[0.0, 0, 0], [1.0, 0, 0], [0, 0.999, 0]])
    assert rows_near(Q, np.array([1, 2]), np.array([0]), 1.0).tolist() == [False, True]


def test_rows_near_with_nothing_to_look_at():
    P = np.zeros((4, 3))
    assert rows_near(P, np.zeros(0, np.int64), np.array([0]), 1.0).shape == (0,)
    assert not rows_near(P, np.array([1, 2]), np.zeros(0, np.int64), 1.0).any()
    assert not rows_near(P, np.array([1, 2]), np.array([0]), 0.0).any()
