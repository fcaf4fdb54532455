"""SelectionRows: a selection's rows propagated from their own copy give what the whole binding gives."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.spatial.transform import Rotation

from hybridedit.deform.propagate import propagate
from hybridedit.deform.residual import SelectionRows, propagate_with_residual, residual_setup


def _binding(n: int, c: int, seed: int):
    rng = np.random.default_rng(seed)
    cols = np.stack([rng.choice(c, 5, replace=False) for _ in range(n)])
    vals = rng.random((n, 5)) + 0.1
    M = sp.csr_matrix((vals.ravel() / np.repeat(vals.sum(1), 5), (np.repeat(np.arange(n), 5), cols.ravel())),
                      shape=(n, c))
    cage = rng.normal(size=(c, 3))
    points = M @ cage + 0.05 * rng.normal(size=(n, 3))
    y = cage + 0.2 * rng.normal(size=(c, 3))
    rots = Rotation.random(c, random_state=seed).as_matrix()
    return M, points, cage, y, rots


@pytest.mark.parametrize("residual", [True, False])
@pytest.mark.parametrize("fraction", [0.1, 0.9])  # copied out, and propagated in place
def test_selection_rows_equal_the_whole_propagation(residual, fraction):
    M, points, cage, y, rots = _binding(400, 40, seed=int(fraction * 10) + residual)
    res = residual_setup(M, points, cage) if residual else None
    rows = np.sort(np.random.default_rng(1).choice(400, int(fraction * 400), replace=False))
    sel = SelectionRows(M, rows, res)
    assert (sel._part is not None) == (fraction <= 0.5)
    if sel._part is not None:  # the binding's index type: no second compiled version of the kernels
        assert sel._part[0].indptr.dtype == M.indptr.dtype and sel._part[0].indices.dtype == M.indices.dtype
    out = np.full((400, 3), 7.0)
    sel.run(y, rots, out)
    want = propagate_with_residual(M, y, rots, *res) if residual else propagate(M, y)
    assert np.allclose(out[rows], want[rows], rtol=0, atol=1e-12)
    others = np.setdiff1d(np.arange(400), rows)
    assert np.all(out[others] == 7.0)  # only the selection's rows are written


@pytest.mark.parametrize("threshold", [10**9, 0])  # the serial kernel, then the parallel one
def test_the_rotation_blend_takes_each_rows_largest_coordinates(monkeypatch, threshold):
    from hybridedit.core.parallel import THRESHOLDS

    monkeypatch.setitem(THRESHOLDS, "propagate", threshold)
    rng = np.random.default_rng(7)
    n, c, k = 300, 50, 4
    nnz = rng.integers(0, 12, n)  # empty rows, rows shorter than k, longer ones
    rows = np.repeat(np.arange(n), nnz)
    cols = np.concatenate([rng.choice(c, m, replace=False) for m in nnz])
    vals = rng.choice([0.1, 0.2, 0.3, -0.2, 0.25], rows.size)  # ties and negative values
    M = sp.csr_matrix((vals, (rows, cols)), shape=(n, c))
    d, idx, w = residual_setup(M, np.zeros((n, 3)), np.zeros((c, 3)), k=k)
    for i in range(n):
        a, b = M.indptr[i], M.indptr[i + 1]
        mag = np.abs(M.data[a:b])
        best = np.argsort(-mag, kind="stable")[:k]  # largest first, ties in row order
        m = len(best)
        assert np.array_equal(idx[i, :m], M.indices[a:b][best])
        if m and mag[best].sum() > 0:  # (stored as float32)
            assert np.array_equal(w[i, :m], (mag[best] / mag[best].sum()).astype(np.float32))
        assert np.all(w[i, m:] == 0.0)
    assert idx.dtype == np.int32 and w.dtype == np.float32  # half the bytes of int64 / float64


def test_the_narrow_blend_weights_still_turn_the_residual_rigidly_and_keep_the_rest_pose():
    # float32 weights sum to 1 only to 1e-7; the propagation makes them sum to 1 in float64, so a
    # rigid motion of the whole cage moves every vertex rigidly and the rest pose comes back, to rounding
    M, points, cage, y, rots = _binding(400, 40, seed=3)
    d, idx, w = residual_setup(M, points, cage)
    assert abs(w.astype(np.float64).sum(axis=1) - 1.0).max() > 1e-9  # (the sums are not exact)
    eye = np.tile(np.eye(3), (40, 1, 1))
    assert np.abs(propagate_with_residual(M, cage, eye, d, idx, w) - points).max() < 1e-14
    R = Rotation.from_rotvec([0.3, -1.1, 0.4]).as_matrix()
    t = np.array([0.5, -2.0, 1.0])
    moved = propagate_with_residual(M, cage @ R.T + t, np.tile(R, (40, 1, 1)), d, idx, w)
    assert np.abs(moved - (points @ R.T + t)).max() < 1e-13


def test_the_blends_first_vertex_is_the_rows_dominant_one_ties_and_empty_rows_too():
    """What the editor's set-up takes as each row's dominant cage vertex when the rows are sorted
    without repeats (:func:`hybridedit.binding.bind.dominant_cage_vertex`'s rule)."""
    from hybridedit.binding.bind import dominant_cage_vertex

    for seed in range(3):
        M = sp.random(400, 60, density=0.08, random_state=seed, format="csr")
        M.data -= 0.5  # negative coordinates too
        ties = sp.csr_matrix(([0.3, -0.3, 0.3], ([0, 0, 0], [9, 4, 50])), (1, 60))
        M = sp.vstack([M, sp.csr_matrix((1, 60)), ties, sp.csr_matrix(([1.0], ([0], [59])), (1, 60))]).tocsr()
        M.sort_indices()
        assert M.has_canonical_format
        for k in (1, 4):
            _, idx, _ = residual_setup(M, np.zeros((M.shape[0], 3)), np.zeros((60, 3)), k=k)
            assert np.array_equal(idx[:, 0], dominant_cage_vertex(M))
        assert idx[-2, 0] == 4 and idx[-3, 0] == 0  # the lowest column of equal magnitudes; an empty row's 0
