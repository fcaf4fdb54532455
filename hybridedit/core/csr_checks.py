"""One compiled pass that checks a CSR matrix read back from a file (a cache entry).

scipy's ``check_format(full_check=True)``, a finiteness test, a row sum and the sortedness test
are four passes over the arrays (at 11M vertices, a binding of 35M weights: about 1.5 s of a
cached open); this is one, on every free core, and it never reads out of bounds however
broken the arrays are.

Examples
--------
>>> import scipy.sparse as sp
>>> M = sp.csr_matrix(np.array([[0.5, 0.5], [0.0, 1.0]]))
>>> csr_check(M.indptr, M.indices, M.data, n_columns=2, row_sum=1.0)
('', True)
>>> csr_check(M.indptr, M.indices, M.data * 2, n_columns=2, row_sum=1.0)
('a row does not sum to 1', True)
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .parallel import pick
from .twins import twins

__all__ = ["csr_check", "FAULTS"]

#: what each row code of :func:`_row_code` means (0: the row is sound)
FAULTS = {
    1: "row pointers out of order or out of range",
    2: "a column index out of range",
    3: "a non-finite value",
    4: "a row does not sum to {row_sum:g}",
}
_UNSORTED = 8  # (a flag, not a fault: the row's columns are not increasing)


@njit(cache=True, inline="always")
def _row_code(i, indptr, indices, data, n_columns, row_sum, tol, check_sum, out):
    a = indptr[i]
    b = indptr[i + 1]
    if a < 0 or b < a or b > indices.shape[0] or b > data.shape[0]:
        out[i] = 1
        return
    s = 0.0
    prev = -1
    code = 0
    for k in range(a, b):
        j = indices[k]
        if j < 0 or j >= n_columns:
            out[i] = 2
            return
        if j <= prev:
            code = _UNSORTED
        prev = j
        v = data[k]
        if not np.isfinite(v):
            out[i] = 3
            return
        s += v
    if check_sum and abs(s - row_sum) > tol:
        out[i] = 4
        return
    out[i] = code


@twins()
def _codes(indptr, indices, data, n_columns, row_sum, tol, check_sum, out):  # pragma: no cover
    for i in prange(out.shape[0]):
        _row_code(i, indptr, indices, data, n_columns, row_sum, tol, check_sum, out)


def csr_check(indptr: np.ndarray, indices: np.ndarray, data: np.ndarray, *, n_columns: int,
              row_sum: float | None = None, tol: float = 1e-9) -> tuple[str, bool]:
    """What is wrong with the CSR arrays of an (r, ``n_columns``) matrix, and whether each row's
    columns are sorted.

    Parameters
    ----------
    indptr : (r + 1,) int array; indices : (nnz,) int array; data : (nnz,) float array
    n_columns : int
    row_sum : float, optional
        Every row must sum to this within ``tol`` (a binding's partition of unity).

    Returns
    -------
    fault : str
        ``''`` when the arrays are a sound matrix, else a fault of :data:`FAULTS` (the
        highest-numbered found: row pointers are checked before anything is read through them).
    columns_sorted : bool
        Every row's column indices increase (what scipy's ``has_sorted_indices`` says).
    """
    indptr = np.asarray(indptr)
    if indptr.ndim != 1 or indptr.size < 1 or indptr[0] != 0 or indptr[-1] != len(indices) \
            or len(indices) != len(data):
        return FAULTS[1], False
    n = indptr.size - 1
    out = np.zeros(n, dtype=np.uint8)
    kernel = pick("propagate", *_codes, n)
    kernel(indptr, indices, data, int(n_columns), float(row_sum or 0.0), float(tol), row_sum is not None, out)
    top = int(out.max(initial=0))
    unsorted = top >= _UNSORTED
    worst = int((out & 7).max()) if unsorted else top
    return (FAULTS[worst].format(row_sum=row_sum) if worst else ""), not unsorted
