"""A shape's cotangent Laplacian, made a block of rows at a time: the rows a selection solves for.

The region step of a drag solves over the moving part of the shape, so it needs only that part's
rows of the shape's Laplacian. Made whole at an editor's first open, from the shape's edge list
(:mod:`hybridedit.core.edge_weights`, :mod:`hybridedit.core.graph_laplacian`), the matrix cost
8-11 s at 11M vertices, three passes of scattered writes bound by memory, not by cores. Here
:class:`ShapeLaplacian` makes only the rows it is asked for, each from the faces around its vertex:
one pass marks the faces that touch the rows, the rest costs what the rows cost. An edge's weight
needs only its two faces (the floor is a constant,
:data:`hybridedit.core.edge_weights.COT_FLOOR`), so a block of rows is the whole matrix's, bit for
bit.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numba import njit, prange

from .edge_weights import COT_FLOOR, corner_cotangent
from .parallel import pick
from .twins import twins

__all__ = ["ShapeLaplacian", "cotangent_laplacian", "laplacian_rows"]

#: Rows made per block of the parallel loops (each block has its own scratch).
_BLOCK = 4096


class ShapeLaplacian:
    """The cotangent Laplacian L = D - W of a triangle mesh, its rows made when asked for.

    W holds the weights of :func:`hybridedit.core.edge_weights.edge_weights` (``"cotangent"``):
    an edge's half cotangents summed, at least
    :data:`~hybridedit.core.edge_weights.COT_FLOOR`; L_ij = -w_ij off the diagonal and L_ii =
    sum_j w_ij; a vertex on no edge has an empty row. Every row is the one
    ``laplacian(n, *edge_weights(vertices, faces, "cotangent"))`` has, bit for bit.

    Parameters
    ----------
    vertices : (n, 3) float array (kept, not copied, when float64 and C-contiguous)
    faces : (m, 3) int array, indices in [0, n); repeated indices, repeated faces and edges of
        more than two faces are allowed (a self-loop adds nothing; an edge's half-edges add up)

    Examples
    --------
    >>> L = ShapeLaplacian(np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]))
    >>> L.shape, np.round(L.rows(np.array([2])).toarray(), 4).tolist()  # (edge 1-2 faces the right angle: the floor)
    ((3, 3), [[-0.5, -0.0006, 0.5006]])
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray) -> None:
        self._v = np.ascontiguousarray(vertices, dtype=np.float64).reshape(-1, 3)
        self._f = np.ascontiguousarray(np.asarray(faces, dtype=np.int64).reshape(-1, 3))
        n = len(self._v)
        if self._f.size and (self._f.min() < 0 or self._f.max() >= n):
            raise ValueError(f"face index out of range [0, {n})")
        self.shape = (n, n)

    def rows(self, index: np.ndarray) -> sp.csr_matrix:
        """Rows ``index`` (k,) of L (distinct vertices, in any order), (k, n) float64 CSR with
        sorted indices (int32 where they fit): row i is L's row ``index[i]``."""
        n = self.shape[0]
        index = np.asarray(index, dtype=np.int64).ravel()
        if index.size and (index.min() < 0 or index.max() >= n):
            raise ValueError(f"row index out of range [0, {n})")
        local = np.full(n, -1, dtype=np.int64)
        local[index] = np.arange(index.size)
        if index.size and np.count_nonzero(local >= 0) != index.size:
            raise ValueError("a row is asked for twice")
        f = self._f
        touched = np.zeros(len(f), dtype=np.bool_)
        pick("faces", *_touching, len(f))(f, local, touched)
        near = np.flatnonzero(touched)
        ptr, fid = _row_faces(f, near, local, index.size)
        width = 2 * int(np.diff(ptr).max()) if index.size else 0
        blocks = max(1, -(-index.size // _BLOCK))
        counts = np.zeros(index.size, dtype=np.int64)
        pick("faces", *_row_sizes, near.size)(index, ptr, fid, f, self._v, width, blocks, counts)
        indptr64 = np.zeros(index.size + 1, dtype=np.int64)
        np.cumsum(counts, out=indptr64[1:])
        entries = int(indptr64[-1])
        kind = np.int32 if max(n, entries) < np.iinfo(np.int32).max else np.int64
        indices = np.empty(entries, dtype=kind)
        data = np.empty(entries)
        pick("faces", *_fill_rows, near.size)(index, ptr, fid, f, self._v, width, blocks, COT_FLOOR,
                                              indptr64, indices, data)
        R = sp.csr_matrix((data, indices, indptr64.astype(kind)), shape=(index.size, n))
        R.has_sorted_indices = True
        return R


def cotangent_laplacian(vertices: np.ndarray, faces: np.ndarray) -> sp.csr_matrix:
    """The whole cotangent Laplacian of a triangle mesh (:class:`ShapeLaplacian`), (n, n) CSR.

    Examples
    --------
    >>> L = cotangent_laplacian(np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]))
    >>> np.round(L.toarray(), 4).tolist()
    [[1.0, -0.5, -0.5], [-0.5, 0.5006, -0.0006], [-0.5, -0.0006, 0.5006]]
    """
    laplacian = ShapeLaplacian(vertices, faces)
    return laplacian.rows(np.arange(laplacian.shape[0]))


def laplacian_rows(laplacian: "ShapeLaplacian | sp.spmatrix", index: np.ndarray) -> sp.csr_matrix:
    """Rows ``index`` of ``laplacian``, a :class:`ShapeLaplacian` or any (n, n) sparse matrix,
    as (k, n) CSR."""
    if isinstance(laplacian, ShapeLaplacian):
        return laplacian.rows(index)
    return sp.csr_matrix(laplacian)[np.asarray(index, dtype=np.int64)]


@twins(nogil=True)
def _touching(f, local, out):  # pragma: no cover - compiled
    for t in prange(f.shape[0]):
        out[t] = local[f[t, 0]] >= 0 or local[f[t, 1]] >= 0 or local[f[t, 2]] >= 0


@njit(cache=True, nogil=True)
def _row_faces(f, near, local, k):  # pragma: no cover - compiled
    """(ptr, fid): the faces of ``near`` around each of the k rows, in increasing order (a face
    twice where it has the row's vertex twice), by a counting sort."""
    ptr = np.zeros(k + 1, dtype=np.int64)
    for t in near:
        for c in range(3):
            r = local[f[t, c]]
            if r >= 0:
                ptr[r + 1] += 1
    for r in range(k):
        ptr[r + 1] += ptr[r]
    at = ptr[:-1].copy()
    fid = np.empty(ptr[k], dtype=np.int64)
    for t in near:
        for c in range(3):
            r = local[f[t, c]]
            if r >= 0:
                fid[at[r]] = t
                at[r] += 1
    return ptr, fid


@twins(nogil=True)
def _row_sizes(index, ptr, fid, f, v, width, blocks, counts):  # pragma: no cover - compiled
    """Per row, its entries: the neighbours of its vertex and the diagonal (none on no edge)."""
    k = counts.shape[0]
    for blk in prange(blocks):
        nb = np.empty(width, dtype=np.int64)
        wt = np.empty(width)
        for r in range(blk * _BLOCK, min(k, (blk + 1) * _BLOCK)):
            q = _row_neighbours(r, index[r], ptr, fid, f, v, nb, wt, False)
            counts[r] = q + 1 if q else 0


@twins(nogil=True)
def _fill_rows(index, ptr, fid, f, v, width, blocks, floor, indptr, indices, data):  # pragma: no cover
    """Each row in column order, the diagonal in its place: -max(w, floor) off it, the sum of the
    others' negations on it (in column order, as :func:`hybridedit.core.graph_laplacian.laplacian`)."""
    k = indptr.shape[0] - 1
    for blk in prange(blocks):
        nb = np.empty(width, dtype=np.int64)
        wt = np.empty(width)
        for r in range(blk * _BLOCK, min(k, (blk + 1) * _BLOCK)):
            vertex = index[r]
            q = _row_neighbours(r, vertex, ptr, fid, f, v, nb, wt, True)
            if q == 0:
                continue
            o = indptr[r]
            total = 0.0
            d = -1
            for i in range(q):
                if d < 0 and nb[i] > vertex:
                    d = o
                    o += 1
                x = -max(wt[i], floor)
                indices[o] = nb[i]
                data[o] = x
                total -= x
                o += 1
            if d < 0:
                d = o
            indices[d] = vertex
            data[d] = total


@njit(cache=True, inline="always")
def _row_neighbours(r, vertex, ptr, fid, f, v, nb, wt, weights):  # pragma: no cover - compiled
    """The neighbours of ``vertex`` (row r, its faces ``fid[ptr[r]:ptr[r + 1]]``) into ``nb[:q]``
    in increasing order and, with ``weights``, their edges' weights into ``wt[:q]``: an edge's
    half cotangents summed from 0.0 in half-edge order, as ``np.bincount`` sums them in
    :func:`~hybridedit.core.edge_weights.edge_weights` (self-loops left out). Returns q."""
    q = 0
    for p in range(ptr[r], ptr[r + 1]):
        t = fid[p]
        if p > ptr[r] and fid[p - 1] == t:
            continue  # (a face with the vertex twice: its half-edges were taken the first time)
        for c in range(3):
            a = f[t, c]
            b = f[t, (c + 1) % 3]
            if a == b:
                continue
            if a == vertex:
                nb[q] = b
            elif b == vertex:
                nb[q] = a
            else:
                continue
            wt[q] = corner_cotangent(v, f, t, c) if weights else 0.0
            q += 1
    _sort_by_neighbour(nb, wt, q)
    m = 0  # a neighbour's half-edges summed into one entry
    for i in range(q):
        if m > 0 and nb[m - 1] == nb[i]:
            wt[m - 1] += wt[i]
        else:
            nb[m] = nb[i]
            wt[m] = 0.0 + wt[i]
            m += 1
    return m


@njit(cache=True, inline="always")
def _sort_by_neighbour(nb, wt, q):  # pragma: no cover - compiled
    """``nb[:q]`` (with ``wt``) in increasing order, stably: a neighbour's half-edges stay in
    half-edge order. An insertion sort for the few of a usual vertex, a merge sort for a fan."""
    if q > 32:
        o = np.argsort(nb[:q], kind="mergesort")
        nb[:q] = nb[:q][o]
        wt[:q] = wt[:q][o]
        return
    for i in range(1, q):
        u, x = nb[i], wt[i]
        j = i - 1
        while j >= 0 and nb[j] > u:
            nb[j + 1] = nb[j]
            wt[j + 1] = wt[j]
            j -= 1
        nb[j + 1] = u
        wt[j + 1] = x
