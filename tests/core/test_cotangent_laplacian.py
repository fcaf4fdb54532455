"""The cotangent Laplacian made a block of rows at a time: the rows of the matrix the edge list and
``laplacian`` give, bit for bit, on clean meshes and on faces with repeated indices, repeated faces,
fans and non-manifold edges, by both twins of its kernels."""

from __future__ import annotations

import numpy as np
import pytest

from hybridedit.core.cotangent_laplacian import ShapeLaplacian, cotangent_laplacian, laplacian_rows
from hybridedit.core.edge_weights import COT_FLOOR, edge_weights
from hybridedit.core.graph_laplacian import laplacian
from hybridedit.core.parallel import all_parallel

from shapes import bumpy_blob


def _by_edges(vertices, faces):
    return laplacian(len(vertices), *edge_weights(vertices, faces, "cotangent"))


def _assert_equal(L, R):
    assert L.shape == R.shape and L.has_sorted_indices and L.indices.dtype == R.indices.dtype
    assert np.array_equal(L.indptr, R.indptr) and np.array_equal(L.indices, R.indices)
    assert np.array_equal(L.data, R.data)


def _wild(seed=7):
    """Random triangles (obtuse ones: edges at the floor), an index repeated, faces of one vertex,
    repeated and turned-over faces, a fan of 60 faces and six vertices on no face."""
    rng = np.random.default_rng(seed)
    n = 80
    v = rng.normal(size=(n, 3))
    f = rng.integers(0, n - 6, size=(300, 3))
    f[:8, 1] = f[:8, 0]
    f[8:10] = f[8:10, :1]
    f = np.concatenate([f, f[20:30], f[30:35, ::-1]])
    fan = np.stack([np.zeros(60, dtype=np.int64), np.arange(1, 61), np.arange(2, 62)], axis=1)
    v[5] = v[6]  # a face with two equal corners (cotangents at their bound)
    return v, np.concatenate([f, fan, [[5, 6, 7]]])


@pytest.mark.parametrize("parallel", [False, True])
def test_the_whole_matrix_is_the_edge_lists(parallel):
    m = bumpy_blob(3)
    if parallel:
        with all_parallel():
            L = cotangent_laplacian(m.vertices, m.faces)
    else:
        L = cotangent_laplacian(m.vertices, m.faces)
    _assert_equal(L, _by_edges(m.vertices, m.faces))
    assert np.abs(L @ np.ones(m.n_vertices)).max() < 1e-12 * np.abs(L.data).max()  # rows sum to zero
    assert (L - L.T).count_nonzero() == 0  # symmetric, exactly


@pytest.mark.parametrize("parallel", [False, True])
def test_degenerate_faces_fans_and_non_manifold_edges(parallel):
    v, f = _wild()
    R = _by_edges(v, f)
    if parallel:
        with all_parallel():
            L = cotangent_laplacian(v, f)
    else:
        L = cotangent_laplacian(v, f)
    _assert_equal(L, R)
    assert np.all(np.diff(L.indptr)[-6:] == 0)  # vertices on no edge: empty rows
    assert np.count_nonzero(L.data == -COT_FLOOR) > 0  # (edges at the floor were made)


def test_a_block_of_rows_is_the_matrixs_rows_in_the_order_asked():
    v, f = _wild(3)
    R = _by_edges(v, f)
    index = np.array([0, 79, 12, 5, 6, 40, 2])  # the fan's vertex, one on no face, the equal corners
    _assert_equal(ShapeLaplacian(v, f).rows(index), R[index])
    assert ShapeLaplacian(v, f).rows(np.zeros(0, dtype=np.int64)).shape == (0, 80)
    np.testing.assert_array_equal(laplacian_rows(R, index).toarray(), R[index].toarray())


def test_no_faces_and_bad_input():
    L = cotangent_laplacian(np.zeros((4, 3)), np.zeros((0, 3), dtype=np.int64))
    assert L.shape == (4, 4) and L.nnz == 0
    with pytest.raises(ValueError, match="out of range"):
        ShapeLaplacian(np.zeros((3, 3)), np.array([[0, 1, 3]]))
    L = ShapeLaplacian(np.zeros((3, 3)), np.array([[0, 1, 2]]))
    with pytest.raises(ValueError, match="out of range"):
        L.rows(np.array([3]))
    with pytest.raises(ValueError, match="twice"):
        L.rows(np.array([1, 1]))
