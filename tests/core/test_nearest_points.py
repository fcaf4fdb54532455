"""The nearest point of a set, from a k-d tree built ahead of its one query."""

from __future__ import annotations

import numpy as np
import pytest

from hybridedit.core.nearest_points import NearestPoints, nearest_points


def _brute(points, queries):
    return np.argmin(((queries[:, None, :] - points[None, :, :]) ** 2).sum(axis=2), axis=1)


def test_the_nearest_points_are_the_brute_force_ones():
    rng = np.random.default_rng(3)
    points = rng.normal(size=(2000, 3))
    queries = rng.normal(scale=1.5, size=(300, 3))
    want = _brute(points, queries)
    got = NearestPoints(points).query(queries)
    assert got.dtype == np.int64 and np.array_equal(got, want)
    assert np.array_equal(nearest_points(points, queries), want)
    # a query at a point is that point
    assert np.array_equal(nearest_points(points, points[[5, 17]]), [5, 17])


def test_the_tree_answers_one_query_and_lets_go():
    near = NearestPoints(np.eye(3))
    assert near.query(np.array([[0.9, 0.1, 0.0]])).tolist() == [0]
    with pytest.raises(RuntimeError, match="queried before"):
        near.query(np.zeros((1, 3)))
