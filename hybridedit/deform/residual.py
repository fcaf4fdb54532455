"""Exact rest pose: the detail M cannot reproduce, carried along rotated.

At bind time each shape vertex keeps its residual d_i = x_i - (M c)_i, the part
of the shape that the truncated coordinates lose. When deforming, the residual
is added back rotated by a blend of the ARAP rotations of the cage vertices that
control the vertex most:

    x'_i = (M y')_i + (sum_k w_ik R_{j_ik}) d_i,

with j_ik the k cage vertices of largest |M_ij| in row i and w_ik their
magnitudes normalized to sum 1. With no edit every R is the identity and the
output is the input exactly; a rigid motion of the whole cage gives every vertex
that same rotation, so the shape moves rigidly. The blend is linear (not
re-orthonormalized): rotations of neighbouring cage vertices differ little, and
the linear blend keeps the result smooth across the shape.
"""

from __future__ import annotations

import copy

import numpy as np
import scipy.sparse as sp
from numba import njit, prange

from ..core.parallel import pick
from ..core.twins import twins
from .propagate import all_rows, propagate
from .propagate import _row as _linear_row

#: Cage rotations blended per shape vertex.
DEFAULT_K = 4


@njit(cache=True, inline="always")
def _top_k_row(i, o, indptr, indices, data, k, idx, w):
    """Row i's k entries of largest |value| (ties: the first in the row) into ``idx[i]``, their
    magnitudes' shares into ``w[o]`` (float64; the caller stores them narrower)."""
    a, b = indptr[i], indptr[i + 1]
    kk = min(k, b - a)
    # insertion into the k best, largest first; a later entry of equal magnitude goes after
    for t in range(kk):
        w[o, t] = -1.0
    for p in range(a, b if kk > 0 else a):
        v = abs(data[p])
        t = kk - 1
        if v <= w[o, t]:
            continue
        while t > 0 and v > w[o, t - 1]:
            w[o, t] = w[o, t - 1]
            idx[i, t] = idx[i, t - 1]
            t -= 1
        w[o, t] = v
        idx[i, t] = indices[p]
    total = 0.0
    for t in range(kk):
        total += w[o, t]
    for t in range(k):
        if t < kk and total > 0.0:
            w[o, t] = w[o, t] / total
        else:  # padding (rows shorter than k): no weight
            idx[i, t] = idx[i, 0] if t > 0 else 0
            w[o, t] = 0.0


@twins()
def _top_k(indptr, indices, data, k, r0, r1, idx, w):  # pragma: no cover - compiled
    for i in prange(r0, r1):
        _top_k_row(i, i - r0, indptr, indices, data, k, idx, w)


#: rows of the top-k made at a time (their float64 shares in a buffer of this many rows)
_TOP_K_ROWS = 1 << 20


def residual_setup(
    M: sp.csr_matrix, points: np.ndarray, cage_vertices: np.ndarray, k: int = DEFAULT_K
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Residuals and rotation-blend weights.

    Parameters
    ----------
    M : (n, c) CSR binding; points : (n, 3) shape rest positions;
    cage_vertices : (c, 3) cage rest positions; k : rotations blended per vertex.

    Returns
    -------
    d : (n, 3) float64 residuals x - M c
    idx : (n, k) int32 cage vertex of each blended rotation
    w : (n, k) float32 blend weights, rows summing to 1 (to float32's precision: the kernels that
        use them make them sum to 1 in float64)
    """
    if k < 1:
        raise ValueError(f"k must be >= 1, got {k}")
    M = sp.csr_matrix(M)
    d = np.ascontiguousarray(points - M @ cage_vertices, dtype=np.float64)
    n = M.shape[0]
    idx = np.zeros((n, k), dtype=np.int32)
    w = np.zeros((n, k), dtype=np.float32)
    shares = np.empty((min(n, _TOP_K_ROWS), k))
    kernel = pick("propagate", *_top_k, n)
    for r0 in range(0, n, _TOP_K_ROWS):
        r1 = min(n, r0 + _TOP_K_ROWS)
        kernel(M.indptr, M.indices, M.data, k, r0, r1, idx, shares)
        w[r0:r1] = shares[: r1 - r0]
    return d, idx, w


@njit(cache=True, inline="always")
def _row(i, o, indptr, indices, data, y, rots, idx, w, d, out):
    """out[o] = (M y)_i + (sum_k w_ik R_idx_ik) d_i."""
    _linear_row(i, o, indptr, indices, data, y, out)
    d0 = d[i, 0]
    d1 = d[i, 1]
    d2 = d[i, 2]
    a0 = 0.0
    a1 = 0.0
    a2 = 0.0
    total = 0.0  # (the weights are stored as float32: they are made to sum to 1 here, in float64,
    for t in range(idx.shape[1]):  # so that equal rotations turn the residual rigidly, exactly)
        total += w[i, t]
    if total <= 0.0:
        return
    inv = 1.0 / total
    for t in range(idx.shape[1]):
        c = w[i, t] * inv
        if c == 0.0:  # (a row shorter than k is padded with weight 0: no rotation to read)
            continue
        r = rots[idx[i, t]]
        a0 += c * (r[0, 0] * d0 + r[0, 1] * d1 + r[0, 2] * d2)
        a1 += c * (r[1, 0] * d0 + r[1, 1] * d1 + r[1, 2] * d2)
        a2 += c * (r[2, 0] * d0 + r[2, 1] * d1 + r[2, 2] * d2)
    out[o, 0] += a0
    out[o, 1] += a1
    out[o, 2] += a2


@twins()
def _rows(indptr, indices, data, y, rots, idx, w, d, out, rows, dest):
    for r in prange(rows.shape[0]):
        _row(rows[r], dest[r], indptr, indices, data, y, rots, idx, w, d, out)


def propagate_with_residual(
    M: sp.csr_matrix,
    y: np.ndarray,
    rotations: np.ndarray,
    d: np.ndarray,
    idx: np.ndarray,
    w: np.ndarray,
    out: np.ndarray | None = None,
    rows: np.ndarray | None = None,
    *,
    dest: np.ndarray | None = None,
) -> np.ndarray:
    """Shape positions (M y)_i + (sum_k w_ik R_idx_ik) d_i, (n, 3) float64.

    Parameters
    ----------
    M : (n, c) CSR binding; y : (c, 3) cage positions; rotations : (c, 3, 3)
    per-cage-vertex rotations; d, idx, w : from :func:`residual_setup`;
    out : optional (n, 3) output array; rows : optional (r,) int64, compute
    only these rows; dest : optional (r,) int64, write row ``rows[k]`` to
    ``out[dest[k]]`` (default ``dest = rows``).
    """
    y = np.ascontiguousarray(y, dtype=np.float64)
    if out is None:
        out = np.empty((M.shape[0], 3))
    rows = all_rows(M.shape[0]) if rows is None else rows
    dest = rows if dest is None else dest
    args = (M.indptr, M.indices, M.data, y, rotations, idx, w, d, out, rows, dest)
    pick("propagate", *_rows, rows.shape[0])(*args)
    return out


#: Rows of a selection are copied out contiguously when they are at most this fraction of the shape.
COMPACT_MAX_FRACTION = 0.5


class SelectionRows:
    """The shape rows a selection recomputes every frame, propagated from their own copy.

    A region's rows lie scattered through the shape's arrays (its vertex order is
    the file's); read in place, each row of M, of the residual and of its blend
    weights is a separate cache miss, and a frame finds them evicted by the cage
    solve before it. Copied out once per selection, they are read in order: at
    173K vertices the 7K rows of the canonical edit take 0.4 ms instead of 0.9 ms.
    Rows that are most of the shape are propagated in place (nothing to gain).

    Parameters
    ----------
    M : (n, c) CSR binding.
    rows : (r,) int64 shape rows to recompute.
    residual : (d, idx, w) from :func:`residual_setup`, or None for the linear x' = M y'.
    """

    def __init__(self, M: sp.csr_matrix, rows: np.ndarray, residual=None) -> None:
        self.rows = np.array(rows, dtype=np.int64)  # writable, contiguous: one compiled version of the kernels
        self._whole = (M, residual)
        self._part = None
        if self.rows.size <= COMPACT_MAX_FRACTION * M.shape[0]:
            Mr = sp.csr_matrix(M[self.rows])
            # the binding's own index type (scipy narrows a slice's): the kernels' compiled version
            Mr.indptr, Mr.indices = Mr.indptr.astype(M.indptr.dtype), Mr.indices.astype(M.indices.dtype)
            part = None if residual is None else tuple(np.ascontiguousarray(a[self.rows]) for a in residual)
            # its rows by number, a writable array as the in-place path passes (one compiled version)
            self._part = (Mr, part, np.arange(self.rows.size, dtype=np.int64))

    def with_residual(self, residual) -> "SelectionRows":
        """The same rows with another residual ``(d, idx, w)`` (e.g. of a new reference pose);
        the sliced binding is shared, nothing is recomputed but the residual's rows."""
        other = copy.copy(self)
        M = self._whole[0]
        other._whole = (M, residual)
        if self._part is not None:
            Mr, _, local = self._part
            part = None if residual is None else tuple(np.ascontiguousarray(a[self.rows]) for a in residual)
            other._part = (Mr, part, local)
        return other

    def run(self, y: np.ndarray, rotations: np.ndarray, out: np.ndarray) -> None:
        """Write rows ``rows`` of ``out`` (n, 3) from cage positions ``y`` (c, 3) and per-cage-vertex
        ``rotations`` (c, 3, 3) (unused by the linear propagation)."""
        if self._part is None:
            M, residual = self._whole
            if residual is None:
                propagate(M, y, out, rows=self.rows)
            else:
                propagate_with_residual(M, y, rotations, *residual, out, rows=self.rows)
            return
        Mr, part, local = self._part
        if part is None:
            propagate(Mr, y, out, rows=local, dest=self.rows)
        else:
            propagate_with_residual(Mr, y, rotations, *part, out, rows=local, dest=self.rows)
