"""The graph Laplacian assembled straight into CSR: the matrix scipy's D - W gives, whatever the
order of the edges, with duplicates summed, self-loops cancelled and edgeless vertices empty."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from hybridedit.core.edge_weights import edge_weights
from hybridedit.core.graph_laplacian import laplacian

from shapes import bumpy_blob


def _reference(n, edges, weights):
    """L = D - W by scipy's own assembly."""
    i, j = edges[:, 0], edges[:, 1]
    W = sp.coo_matrix((np.concatenate([weights, weights]), (np.concatenate([i, j]), np.concatenate([j, i]))),
                      shape=(n, n)).tocsr()
    return (sp.diags(np.asarray(W.sum(axis=1)).ravel()) - W).tocsr()


def test_a_mesh_cotangent_laplacian_is_scipys():
    m = bumpy_blob(3)
    e, w = edge_weights(m.vertices, m.faces, "cotangent")
    L, R = laplacian(m.n_vertices, e, w), _reference(m.n_vertices, e, w)
    R.sort_indices()
    assert L.has_sorted_indices and L.dtype == np.float64 and L.indices.dtype == np.int32
    assert np.array_equal(L.indptr, R.indptr) and np.array_equal(L.indices, R.indices)
    np.testing.assert_allclose(L.data, R.data, rtol=1e-14, atol=0)  # (the diagonal's sums: to rounding)
    assert np.abs(L @ np.ones(m.n_vertices)).max() < 1e-12 * np.abs(w).max()  # rows sum to zero


def test_unsorted_edges_duplicates_self_loops_and_isolated_vertices():
    rng = np.random.default_rng(3)
    n = 60
    e = rng.integers(0, n - 5, size=(400, 2))  # the last five vertices have no edge
    e[:10, 1] = e[:10, 0]  # self-loops
    e = np.concatenate([e, e[20:40]])  # twenty edges given twice (in the other direction below)
    e[-20:] = e[-20:, ::-1]
    w = rng.uniform(0.1, 2.0, size=len(e))
    L, R = laplacian(n, e, w), _reference(n, e, w)
    L.sort_indices()
    assert L.has_sorted_indices
    np.testing.assert_allclose(L.toarray(), R.toarray(), rtol=0, atol=1e-12)
    assert np.all(np.diff(L.indptr)[-5:] == 0)  # edgeless vertices: empty rows, as D - W leaves them
    R.eliminate_zeros()
    assert np.array_equal(L.indptr, R.indptr)


def test_no_edges_and_bad_input():
    L = laplacian(4, np.zeros((0, 2), dtype=np.int64), np.zeros(0))
    assert L.shape == (4, 4) and L.nnz == 0
    with pytest.raises(ValueError, match="out of range"):
        laplacian(3, np.array([[0, 3]]), np.array([1.0]))
    with pytest.raises(ValueError, match="weights"):
        laplacian(3, np.array([[0, 1]]), np.array([1.0, 2.0]))
