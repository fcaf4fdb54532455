"""The fast kernels' layout of the points: batches along the curve and their spheres."""

from __future__ import annotations

import numpy as np
import pytest

from hybridedit.binding import mvc_layout
from hybridedit.binding.mvc_layout import LANES, plan_fast, prepare_fast_cage
from hybridedit.core.parallel import all_parallel

from shapes import bumpy_blob


@pytest.fixture(scope="module")
def cage():
    blob = bumpy_blob(2)
    return prepare_fast_cage(blob.vertices * 3.0 + 5.0, blob.faces)


def _numpy_batches(points, idx, cage, min_radius):
    """The batches as numpy computes them: lanes in the cage's unit box, the sphere about the box's
    centre."""
    pb = (points[idx] - cage.origin) / cage.unit
    center = 0.5 * (pb.min(axis=1) + pb.max(axis=1))
    radius = np.maximum(np.linalg.norm(pb - center[:, None, :], axis=2).max(axis=1), min_radius)
    return pb.transpose(0, 2, 1), np.concatenate([center, radius[:, None]], axis=1)


@pytest.mark.parametrize("parallel", [False, True])
@pytest.mark.parametrize("min_radius", [0.0, 0.05])
def test_batches_are_numpys_bitwise_in_both_twins(cage, parallel, min_radius):
    rng = np.random.default_rng(3)
    points = rng.normal(5.0, 2.0, size=(1000, 3))
    idx = rng.integers(0, len(points), size=(40, LANES))
    idx[7] = idx[7, 0]  # a batch of one point repeated: radius 0 (or the least)
    kernel = mvc_layout._batches_twins.parallel if parallel else mvc_layout._batches_twins.serial
    bx = np.empty((40, 3, LANES))
    bsph = np.empty((40, 4))
    kernel(points, idx, cage.origin, float(cage.unit), min_radius, bx, bsph)
    want_bx, want_sph = _numpy_batches(points, idx, cage, min_radius)
    assert np.array_equal(bx, want_bx)
    assert np.array_equal(bsph, want_sph)
    assert bsph[7, 3] == min_radius


def test_plan_covers_every_point_once_in_curve_order_with_the_last_batch_padded(cage):
    rng = np.random.default_rng(4)
    points = rng.normal(5.0, 2.0, size=(3 * LANES + 5, 3))
    for parallel in (False, True):
        if parallel:
            with all_parallel():
                plan = plan_fast(points, cage)
        else:
            plan = plan_fast(points, cage)
        assert np.array_equal(np.sort(plan.order), np.arange(len(points)))
        pos = np.minimum(np.arange(plan.bx.shape[0] * LANES), len(points) - 1)
        want_bx, want_sph = _numpy_batches(points, plan.order[pos].reshape(-1, LANES), cage, 0.0)
        assert np.array_equal(plan.bx, want_bx) and np.array_equal(plan.bsph, want_sph)
        # every lane inside its batch's sphere
        d = np.linalg.norm(plan.bx - plan.bsph[:, :3, None], axis=1)
        assert np.all(d <= plan.bsph[:, 3:4] * (1 + 1e-12))
