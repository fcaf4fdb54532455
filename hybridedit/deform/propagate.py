"""Propagation of cage positions to the shape: x' = M y', one fused CSR kernel."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numba import njit, prange

from ..core.parallel import pick
from ..core.twins import twins

_ALL_ROWS: dict[int, np.ndarray] = {}


def all_rows(n: int) -> np.ndarray:
    """arange(n) as int64, cached (the row list of a full product)."""
    r = _ALL_ROWS.get(n)
    if r is None:
        r = _ALL_ROWS[n] = np.arange(n, dtype=np.int64)
        r.setflags(write=False)
    return r


@njit(cache=True, inline="always")
def _row(i, o, indptr, indices, data, y, out):
    """out[o] = sum_k data[k] * y[indices[k]] over row i."""
    a0 = 0.0
    a1 = 0.0
    a2 = 0.0
    for k in range(indptr[i], indptr[i + 1]):
        j = indices[k]
        w = data[k]
        a0 += w * y[j, 0]
        a1 += w * y[j, 1]
        a2 += w * y[j, 2]
    out[o, 0] = a0
    out[o, 1] = a1
    out[o, 2] = a2


@twins()
def _csr_times_xyz(indptr, indices, data, y, out, rows, dest):
    for r in prange(rows.shape[0]):
        _row(rows[r], dest[r], indptr, indices, data, y, out)


def propagate(
    M: sp.csr_matrix, y: np.ndarray, out: np.ndarray | None = None, rows: np.ndarray | None = None,
    *, dest: np.ndarray | None = None,
) -> np.ndarray:
    """Shape positions M @ y.

    Parameters
    ----------
    M : (n, c) float64 CSR matrix, the binding.
    y : (c, 3) float64 array, cage positions.
    out : optional (n, 3) float64 array to write into.
    rows : optional (r,) int64 array: compute only these rows of ``out``
        (the others are left as they are).
    dest : optional (r,) int64 array: write row ``rows[k]`` of the product to
        ``out[dest[k]]`` (default ``dest = rows``; ``out`` then needs no more rows than ``dest`` names).

    Returns
    -------
    (n, 3) float64 array.
    """
    y = np.ascontiguousarray(y, dtype=np.float64)
    if y.shape != (M.shape[1], 3):
        raise ValueError(f"cage positions must be ({M.shape[1]}, 3), got {y.shape}")
    if out is None:
        out = np.empty((M.shape[0], 3))
    rows = all_rows(M.shape[0]) if rows is None else rows
    dest = rows if dest is None else dest
    pick("propagate", *_csr_times_xyz, rows.shape[0])(M.indptr, M.indices, M.data, y, out, rows, dest)
    return out
