"""A big shape's binding from a quarter of its rows: the others interpolated from their neighbours.

Mean value coordinates are smooth functions of space, and a scanned shape of millions of vertices
samples them far more densely than they vary: at a 5% cage a shape vertex is about a fifth of a
cage edge from its neighbours. The hierarchical bind's cost is mostly per batch of points (the
cage regions a batch opens and aggregates), not per point: the 2.77M armadillo's quarter of
vertices binds in 45% of the time of all of them. So a shape of at least
:data:`INTERPOLATE_FROM` vertices binds only a maximal independent set of its vertex graph (the
*seeds*, about a quarter of the vertices; every other vertex has a seed among its neighbours), and
each other vertex's row is the average of its neighbouring seeds' rows, weighted by inverse
distance, truncated by the same rule as a bound row (:func:`hybridedit.binding.truncation.keep_row`)
and rescaled to sum to 1.

What the residual propagation then moves such a vertex by: with weights ``a_k`` on seeds ``s_k``,
its row gives ``sum_k a_k (M y')_{s_k}`` and its residual ``d = x - sum_k a_k (M c)_{s_k}``
carries its offset from the seeds, turned with the rotation the cage gives it; a vertex follows its
seeds rigidly, about as a bound row would (the edge error of the 2.77M armadillo's edits within
1% of the bound rows'). Rows still sum to 1, the rest pose is exact (the residual), and a row
reproduces its point to about its distance from its seeds' weighted centre, not to the
truncation's error as a bound row does.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
import scipy.sparse as sp
from numba import njit, prange

from ..core.parallel import pick
from ..core.topology import incidence
from ..core.twins import twins
from .truncation import MAX_ROW, MIN_KEPT_SUM, NOT_FINITE, cap_rows

__all__ = ["INTERPOLATE_FROM", "seed_vertices", "interpolated_binding"]

#: Shapes with at least this many vertices get interpolated rows (the 2.77M armadillo's bind in
#: 55% of the time of binding every vertex); smaller ones bind every vertex.
INTERPOLATE_FROM = 1_000_000

#: Rows made per block of the parallel loops (each block has its own scratch).
_BLOCK = 2048


@njit(cache=True)
def _greedy_seeds(ptr, fid, faces, seed):  # pragma: no cover - compiled
    for v in range(seed.shape[0]):
        free = True
        for p in range(ptr[v], ptr[v + 1]):
            for u in faces[fid[p]]:
                if u != v and seed[u]:
                    free = False
        seed[v] = free


def seed_vertices(n: int, faces: np.ndarray) -> np.ndarray:
    """A maximal independent set of the vertex graph of ``faces``, greedily in vertex order.

    No two seeds share a face and every other vertex shares one with a seed (a vertex on no face is
    a seed). On a triangle mesh about a quarter of the vertices are seeds.

    Parameters
    ----------
    n : int, the number of vertices
    faces : (f, 3) int, vertex indices in [0, n)

    Returns
    -------
    (n,) bool, True for the seeds

    Examples
    --------
    >>> seed_vertices(5, np.array([[0, 1, 2], [1, 3, 2], [3, 4, 2]])).tolist()
    [True, False, False, True, False]
    """
    return _seeds(np.ascontiguousarray(faces, dtype=np.int64).reshape(-1, 3), n)[2]


def _seeds(f: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(ptr, fid, seed): the vertex-to-face incidence of the (f, 3) int64 ``f`` and the seeds."""
    ptr, fid = incidence(f, n)
    seed = np.zeros(n, dtype=np.bool_)
    _greedy_seeds(ptr, fid, f, seed)
    return ptr, fid, seed


@njit(cache=True, inline="always")
def _stencil(v, ptr, fid, faces, seed, points, near, weight):
    """The seeds sharing a face with vertex v into ``near`` and their inverse-distance weights
    (summing to 1) into ``weight``; returns how many."""
    m = 0
    for p in range(ptr[v], ptr[v + 1]):
        for u in faces[fid[p]]:
            if u == v or not seed[u]:
                continue
            known = False
            for k in range(m):
                if near[k] == u:
                    known = True
            if not known:
                near[m] = u
                m += 1
    total = 0.0
    for k in range(m):
        u = near[k]
        d = np.sqrt((points[v, 0] - points[u, 0]) ** 2 + (points[v, 1] - points[u, 1]) ** 2
                    + (points[v, 2] - points[u, 2]) ** 2)
        weight[k] = 1.0 / max(d, 1e-300)  # (a seed on the vertex itself takes all of it)
        total += weight[k]
    for k in range(m):
        weight[k] /= total
    return m


@njit(cache=True, inline="always")
def _row_of(v, ptr, fid, faces, seed, slot, points, indptr, indices, data, truncation, near, weight, cols, vals,
            kvals, kidx):
    """Vertex v's row: a seed's bound row, or its seeds' rows summed with their weights, truncated
    and rescaled; returns (length, scale): its columns are ``cols[kidx[:length]]`` and its values
    ``kvals[:length] * scale``."""
    q = 0
    if seed[v]:
        s = slot[v]
        for p in range(indptr[s], indptr[s + 1]):
            kidx[q] = q
            cols[q] = indices[p]
            kvals[q] = data[p]
            q += 1
        return q, 1.0
    m = _stencil(v, ptr, fid, faces, seed, points, near, weight)
    for k in range(m):
        s = slot[near[k]]
        a = weight[k]
        for p in range(indptr[s], indptr[s + 1]):
            col = indices[p]
            found = -1
            for u in range(q):
                if cols[u] == col:
                    found = u
            if found >= 0:
                vals[found] += a * data[p]
            else:
                cols[q] = col
                vals[q] = a * data[p]
                q += 1
    return _keep(vals, q, truncation, kvals, kidx)


@njit(cache=True, inline="always")
def _keep(vals, q, truncation, kvals, kidx):
    """The truncation rule of :func:`~hybridedit.binding.truncation.keep_row` on the ``q`` entries
    ``vals[:q]`` of a short row, without its stages for long rows (nor their allocations): the
    smallest entries dropped while their magnitudes total at most ``truncation`` of the row's; the
    kept ones rescaled to sum to 1, unless they sum to less than ``MIN_KEPT_SUM`` (then every
    nonzero is kept as it is). Returns (length, scale) as :func:`_row_of` does."""
    mag = 0.0
    for u in range(q):
        a = abs(vals[u])
        if not a < np.inf:
            return NOT_FINITE, 1.0
        mag += a
        t = u  # (insertion by magnitude, smallest first; equal ones keep their order)
        while t > 0 and abs(vals[kidx[t - 1]]) > a:
            kidx[t] = kidx[t - 1]
            t -= 1
        kidx[t] = u
    budget = truncation * mag
    dropped = 0.0
    n_drop = 0
    while n_drop < q and dropped + abs(vals[kidx[n_drop]]) <= budget:
        dropped += abs(vals[kidx[n_drop]])
        n_drop += 1
    kept = 0.0
    for k in range(n_drop, q):
        kept += vals[kidx[k]]
    if kept >= MIN_KEPT_SUM:
        for k in range(n_drop, q):
            kidx[k - n_drop] = kidx[k]
            kvals[k - n_drop] = vals[kidx[k - n_drop]]
        return q - n_drop, 1.0 / kept
    m = 0
    for u in range(q):  # the safeguard: every nonzero, unscaled
        if vals[u] != 0.0:
            kidx[m] = u
            kvals[m] = vals[u]
            m += 1
    return m, 1.0


#: Entries a row keeps from the first pass (at most; a wider row is made again by the second): the
#: rows have 3.4 entries on average, and this many of each, 12 bytes an entry, is 0.8 GB at 11M.
_FIRST = 6


@njit(cache=True, inline="always")
def _store_sorted(q, scale, cols, kvals, kidx, out_indices, out_data, o):
    """The row's ``q`` kept entries into ``out_indices[o:o + q]`` / ``out_data``, in column order."""
    for k in range(q):
        col = cols[kidx[k]]
        t = o + k
        while t > o and out_indices[t - 1] > col:
            out_indices[t] = out_indices[t - 1]
            out_data[t] = out_data[t - 1]
            t -= 1
        out_indices[t] = col
        out_data[t] = kvals[k] * scale


@njit(cache=True, inline="always")
def _scratch(stencil, width):
    """A block's work arrays for :func:`_row_of`: (near, weight) of a stencil's length and (cols,
    vals, kvals, kidx) of a merged row's."""
    return (np.empty(stencil, dtype=np.int64), np.empty(stencil), np.empty(width, dtype=np.int64),
            np.empty(width), np.empty(width), np.empty(width, dtype=np.int64))


@twins()
def _first_rows(ptr, fid, faces, seed, slot, points, indptr, indices, data, truncation, width, stencil, counts,
                first_indices, first_data):  # pragma: no cover - compiled
    n = seed.shape[0]
    for b in prange((n + _BLOCK - 1) // _BLOCK):
        near, weight, cols, vals, kvals, kidx = _scratch(stencil, width)
        for v in range(b * _BLOCK, min(n, (b + 1) * _BLOCK)):
            q, scale = _row_of(v, ptr, fid, faces, seed, slot, points, indptr, indices, data, truncation, near,
                               weight, cols, vals, kvals, kidx)
            counts[v] = q
            if 0 <= q <= first_indices.shape[1]:
                _store_sorted(q, scale, cols, kvals, kidx, first_indices[v], first_data[v], 0)


@twins()
def _fill_rows(ptr, fid, faces, seed, slot, points, indptr, indices, data, truncation, width, stencil, counts,
               first_indices, first_data, out_ptr, out_indices, out_data):  # pragma: no cover - compiled
    n = seed.shape[0]
    for b in prange((n + _BLOCK - 1) // _BLOCK):
        near, weight, cols, vals, kvals, kidx = _scratch(stencil, width)
        for v in range(b * _BLOCK, min(n, (b + 1) * _BLOCK)):
            o = out_ptr[v]
            if counts[v] <= first_indices.shape[1]:
                for k in range(counts[v]):
                    out_indices[o + k] = first_indices[v, k]
                    out_data[o + k] = first_data[v, k]
                continue
            q, scale = _row_of(v, ptr, fid, faces, seed, slot, points, indptr, indices, data, truncation, near,
                               weight, cols, vals, kvals, kidx)
            _store_sorted(q, scale, cols, kvals, kidx, out_indices, out_data, o)


def interpolated_binding(points: np.ndarray, faces: np.ndarray, bind_rows: Callable[[np.ndarray], sp.csr_matrix],
                         *, cage_vertices: np.ndarray, truncation: float, max_row: int = MAX_ROW) -> sp.csr_matrix:
    """The binding of ``points`` with the rows of the seeds (:func:`seed_vertices`) bound and each
    other vertex's row the sum of the rows of the seeds it shares a face with, weighted by inverse
    distance, truncated by the binding's rule and rescaled to sum to 1.

    Parameters
    ----------
    points : (n, 3) float64 the shape's vertices
    faces : (f, 3) int its faces
    bind_rows : callable(seeds (s,) int64) -> (s, c) CSR
        The bound rows of those vertices, rows summing to 1.
    cage_vertices : (c, 3) float64
        The cage's vertices (where an interpolated row wider than ``max_row`` is refitted).
    truncation : float
        The binding's truncation (:func:`~hybridedit.binding.truncation.keep_row`'s rule).
    max_row : int
        The most coordinates a row keeps, as :func:`hybridedit.binding.bind.bind`'s rows
        (:func:`~hybridedit.binding.truncation.cap_rows`).

    Returns
    -------
    (n, c) CSR with sorted indices, rows summing to 1

    Raises
    ------
    ValueError
        A bound row that is not finite (from ``bind_rows``), or an interpolated one.

    Examples
    --------
    >>> P = np.array([[0.0, 0, 0], [1, 0, 0], [1.5, 2, 0], [3, 0, 0]])  # two triangles: seeds 0 and 3
    >>> rows = lambda seeds: sp.csr_matrix(np.eye(2))  # each seed bound to a cage vertex of its own
    >>> F = np.array([[0, 1, 2], [1, 3, 2]])
    >>> M = interpolated_binding(P, F, rows, cage_vertices=P[[0, 3]], truncation=0.0)
    >>> np.round(M.toarray(), 3).tolist()
    [[1.0, 0.0], [0.667, 0.333], [0.5, 0.5], [0.0, 1.0]]
    """
    P = np.ascontiguousarray(points, dtype=np.float64)
    n = len(P)
    f = np.ascontiguousarray(faces, dtype=np.int64).reshape(-1, 3)
    ptr, fid, seed = _seeds(f, n)
    seeds = np.flatnonzero(seed)
    bound = sp.csr_matrix(bind_rows(seeds))
    slot = np.full(n, -1, dtype=np.int64)
    slot[seeds] = np.arange(seeds.size)
    stencil = max(2 * int(np.diff(ptr).max(initial=0)), 1)  # (each face gives a vertex two neighbours)
    row = int(np.diff(bound.indptr).max(initial=0))
    width = max(stencil * row, 1)
    args = (ptr, fid, f, seed, slot, P, bound.indptr.astype(np.int64), bound.indices.astype(np.int64),
            bound.data.astype(np.float64), float(truncation), width, stencil)
    column = np.int32 if cage_vertices.shape[0] < 2**31 else np.int64
    counts = np.empty(n, dtype=np.int64)
    first = (np.empty((n, _FIRST), dtype=column), np.empty((n, _FIRST)))
    pick("propagate", *_first_rows, n)(*args, counts, *first)
    if counts.size and counts.min() < 0:
        raise ValueError(f"the interpolated row of vertex {int(np.argmin(counts))} is not finite")
    out_ptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(counts, out=out_ptr[1:])
    indices = np.empty(int(out_ptr[-1]), dtype=column)
    data = np.empty(int(out_ptr[-1]))
    pick("propagate", *_fill_rows, n)(*args, counts, *first, out_ptr, indices, data)
    del first
    M = sp.csr_matrix((data, indices, out_ptr), shape=(n, bound.shape[1]))
    M.has_sorted_indices = True
    if n and int(counts.max()) > max_row:
        M = cap_rows(M, P, cage_vertices, max_row)
    return M
