"""The binding: truncated mean value coordinates of the shape w.r.t. the cage.

``bind`` computes the exact 3D mean value coordinates (:mod:`hybridedit.mvc`)
chunk by chunk into a dense buffer, truncates every row in a parallel kernel
and assembles a CSR matrix ``M`` with ``M @ cage_vertices ~= points``.

Truncation (Borosán et al., "Hybrid Mesh Editing", 2010): in each row the
coordinates of smallest magnitude are dropped while their cumulative magnitude
stays within ``truncation * sum_j |lambda_j|``; the kept ones are rescaled so
that the row sums to 1 again. Rows keep at least ``1 - truncation`` of their
magnitude, and the matrix stays a partition of unity, so a rigid motion of the
cage still moves the shape rigidly.

To avoid sorting whole rows, every entry with ``|lambda| <= truncation * S / c``
(``S`` the row magnitude, ``c`` the row length) is dropped first: together they
weigh at most ``truncation * S`` and they are the smallest entries, so the full
rule would drop them all. The same argument is repeated on the survivors with
the budget that is left, then only the few remaining candidates are sorted and
the cumulative rule continues from the mass already dropped.

One safeguard departs from the plain rule: if the dropped entries carry so
much signed weight that the kept ones would sum to less than
``MIN_KEPT_SUM`` (possible only for rows with large negative coordinates, i.e.
points far outside the cage, where ``S > 0.5 / truncation``), the row is kept
whole instead of being rescaled by a large factor.
"""

from __future__ import annotations

from collections.abc import Callable

import numba
import numpy as np
import scipy.sparse as sp
from numba import njit, prange

from .mesh import Mesh
from .mvc import as_points, check_closed, compute_into, prepare_cage

__all__ = ["bind", "truncate_rows", "MIN_KEPT_SUM"]

#: Below this signed sum of the kept coordinates a row is left untruncated.
MIN_KEPT_SUM = 0.5
#: Default budget for the dense coordinate buffer of one chunk, in bytes.
CHUNK_BYTES = 64 * 2**20


@njit(cache=True, fastmath=False, error_model="numpy")
def _truncate_row(row, truncation, min_kept_sum, surv, vals):
    """Truncate one row in place (dropped entries set to 0); return its nnz.

    Returns -1 (row untouched) if the row holds an inf or nan.

    ``surv`` (int64) and ``vals`` (float64), both at least as long as the
    row, are scratch.
    """
    c = row.shape[0]
    # Row magnitude with four partial sums (a single running sum is bound by
    # the latency of the additions).
    m0 = 0.0
    m1 = 0.0
    m2 = 0.0
    m3 = 0.0
    c4 = c - c % 4
    for j in range(0, c4, 4):
        m0 += abs(row[j])
        m1 += abs(row[j + 1])
        m2 += abs(row[j + 2])
        m3 += abs(row[j + 3])
    for j in range(c4, c):
        m0 += abs(row[j])
    mag = (m0 + m1) + (m2 + m3)
    if not (mag < np.inf):
        return -1  # inf or nan in the row
    budget = truncation * mag
    # Stage 1: entries of magnitude <= budget / c are always dropped.
    small = budget / c
    n_surv = 0
    for j in range(c):
        # Branch-free compaction: always write, advance only for survivors.
        surv[n_surv] = j
        n_surv += 1 if abs(row[j]) > small else 0
    kept_mag = 0.0
    for k in range(n_surv):
        a = abs(row[surv[k]])
        vals[k] = a
        kept_mag += a
    dropped = max(0.0, mag - kept_mag)
    # Stage 1b: the same argument on the survivors with what is left of the
    # budget: those of magnitude <= left / n_live total at most ``left`` and
    # are the smallest survivors. Repeat while it drops something; each round
    # moves the still-live entries to the front of surv/vals.
    n_live = n_surv
    while n_live > 0:
        tau = (budget - dropped) / n_live
        k = 0
        gone = 0.0
        for m in range(n_live):
            a = vals[m]
            if a <= tau:
                gone += a
            else:
                # Swap it down to slot k; slots k..m-1 hold dropped entries.
                jj = surv[m]
                surv[m] = surv[k]
                vals[m] = vals[k]
                surv[k] = jj
                vals[k] = a
                k += 1
        if k == n_live:
            break
        dropped += gone
        n_live = k
    # Stage 2: sort what is left, smallest first, and drop while the budget
    # allows.
    order = np.argsort(vals[:n_live], kind="mergesort")
    n_drop = 0
    for k in range(n_live):
        a = vals[order[k]]
        if dropped + a <= budget:
            dropped += a
            n_drop += 1
        else:
            break
    kept_sum = 0.0
    for k in range(n_drop, n_live):
        kept_sum += row[surv[order[k]]]
    if not (kept_sum >= min_kept_sum):
        # Safeguard (see module docstring): keep every nonzero.
        nnz = 0
        for j in range(c):
            if row[j] != 0.0:
                nnz += 1
        return nnz
    # Rewrite the row with the kept entries only. ``order`` and ``vals`` are
    # reused for their indices and values: entry k is written after entry
    # n_drop + k >= k has been read.
    n_keep = n_live - n_drop
    for k in range(n_keep):
        j = surv[order[n_drop + k]]
        order[k] = j
        vals[k] = row[j]
    inv = 1.0 / kept_sum
    for j in range(c):
        row[j] = 0.0
    for k in range(n_keep):
        row[order[k]] = vals[k] * inv
    return n_keep


@njit(cache=True, fastmath=False, error_model="numpy", parallel=True)
def _truncate_block(buf, truncation, min_kept_sum, counts, n_blocks):
    """Truncate every row of ``buf`` in place; counts[i] = nnz of row i."""
    n = buf.shape[0]
    c = buf.shape[1]
    for blk in prange(n_blocks):
        start = (blk * n) // n_blocks
        stop = ((blk + 1) * n) // n_blocks
        if stop <= start:
            continue
        surv = np.empty(c, dtype=np.int64)
        vals = np.empty(c)
        for i in range(start, stop):
            counts[i] = _truncate_row(buf[i], truncation, min_kept_sum, surv, vals)


@njit(cache=True, fastmath=False, error_model="numpy", parallel=True)
def _gather_rows(buf, indptr, data, indices):
    """Copy the nonzeros of each row (column order) to data/indices[indptr[i]:]."""
    for i in prange(buf.shape[0]):
        row = buf[i]
        k = indptr[i]
        for j in range(row.shape[0]):
            v = row[j]
            if v != 0.0:
                data[k] = v
                indices[k] = j
                k += 1


def _check_truncation(truncation: float) -> float:
    try:
        t = float(truncation)
    except (TypeError, ValueError):
        raise ValueError(f"truncation must be a number in [0, 1), got {truncation!r}") from None
    if not (0.0 <= t < 1.0):
        raise ValueError(f"truncation must be in [0, 1), got {truncation!r}")
    return t


def _truncate_into_csr_parts(buf: np.ndarray, truncation: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Truncate ``buf`` (m, c) in place; return (counts, data, indices) of its rows.

    If a row is not finite its count is -1 and data/indices are empty.
    """
    m = buf.shape[0]
    counts = np.empty(m, dtype=np.int64)
    n_blocks = max(1, min(m, 8 * numba.get_num_threads()))
    _truncate_block(buf, truncation, MIN_KEPT_SUM, counts, n_blocks)
    if m and counts.min() < 0:
        # A row with inf/nan: report it, nothing to gather.
        return counts, np.empty(0), np.empty(0, dtype=np.int32)
    indptr = np.zeros(m + 1, dtype=np.int64)
    np.cumsum(counts, out=indptr[1:])
    nnz = int(indptr[-1])
    data = np.empty(nnz)
    indices = np.empty(nnz, dtype=np.int32 if buf.shape[1] < 2**31 else np.int64)
    _gather_rows(buf, indptr, data, indices)
    return counts, data, indices


def _assemble(parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]], n: int, c: int) -> sp.csr_matrix:
    counts = np.concatenate([p[0] for p in parts]) if parts else np.zeros(0, dtype=np.int64)
    nnz = int(counts.sum())
    idx_dtype = np.int32 if (nnz < 2**31 and c < 2**31) else np.int64
    indptr = np.zeros(n + 1, dtype=idx_dtype)
    np.cumsum(counts, out=indptr[1:])
    data = np.concatenate([p[1] for p in parts]) if parts else np.zeros(0)
    indices = (
        np.concatenate([p[2] for p in parts]).astype(idx_dtype, copy=False)
        if parts
        else np.zeros(0, dtype=idx_dtype)
    )
    M = sp.csr_matrix((data, indices, indptr), shape=(n, c))
    M.has_sorted_indices = True
    return M


def truncate_rows(dense: np.ndarray, truncation: float = 0.03) -> sp.csr_matrix:
    """Truncate the rows of a dense coordinate matrix (see the module docstring).

    Parameters
    ----------
    dense : (n, c) array
        Finite rows, each summing to a positive value (normally 1).
    truncation : float in [0, 1)
        Fraction of each row's magnitude ``sum_j |lambda_j|`` that may be
        dropped. 0 keeps every nonzero.

    Returns
    -------
    (n, c) float64 CSR matrix with sorted column indices; every truncated row
    sums to 1 (a row kept whole by the safeguard keeps its own sum).
    ``dense`` is not modified.
    """
    t = _check_truncation(truncation)
    a = np.asarray(dense)
    if a.ndim != 2:
        raise ValueError(f"dense must be a 2D array, got shape {a.shape}")
    buf = np.array(a, dtype=np.float64, order="C", copy=True)
    if not np.all(np.isfinite(buf)):
        raise ValueError("dense must be finite")
    n, c = buf.shape
    if n == 0 or c == 0:
        return sp.csr_matrix((n, c))
    return _assemble([_truncate_into_csr_parts(buf, t)], n, c)


def bind(
    points: np.ndarray,
    cage: Mesh,
    truncation: float = 0.03,
    chunk_size: int | None = None,
    progress: Callable[[float], None] | None = None,
) -> sp.csr_matrix:
    """Truncated mean value coordinates of ``points`` w.r.t. ``cage``.

    Parameters
    ----------
    points : (n, 3) array
        Finite positions (usually the shape's vertices).
    cage : Mesh
        A closed, consistently oriented triangle mesh (either orientation).
    truncation : float in [0, 1)
        Fraction of each row's coordinate magnitude that may be dropped
        (0.03 in the paper). 0 keeps every nonzero: the exact coordinates.
    chunk_size : int, optional
        Points per chunk (the dense buffer holds ``chunk_size`` x ``c``
        doubles). By default chosen to keep the buffer near 64 MB.
    progress : callable(fraction), optional
        Called with the fraction of points done (0 before the first chunk,
        then after every chunk). An exception raised by it propagates, which
        cancels the binding.

    Returns
    -------
    M : (n, c) float64 scipy.sparse.csr_matrix
        Sorted column indices; rows sum to 1; ``M @ cage.vertices``
        approximates ``points`` (exactly with truncation 0).

    Raises
    ------
    ValueError
        Bad points, a cage without faces or not closed, truncation outside
        [0, 1), or a non-positive chunk size.
    """
    p = as_points(points)
    if not isinstance(cage, Mesh):
        raise ValueError(f"cage must be a hybridedit.Mesh, got {type(cage).__name__}")
    if cage.n_faces == 0:
        raise ValueError("the cage has no faces")
    t = _check_truncation(truncation)
    c = cage.n_vertices
    n = p.shape[0]
    if chunk_size is None:
        chunk = max(1, CHUNK_BYTES // (8 * c))
    else:
        if isinstance(chunk_size, (bool, np.bool_)) or int(chunk_size) != chunk_size or chunk_size < 1:
            raise ValueError(f"chunk_size must be a positive integer, got {chunk_size!r}")
        chunk = int(chunk_size)
    data = prepare_cage(cage.vertices, cage.faces)
    check_closed(data.faces)
    if n == 0:
        return sp.csr_matrix((0, c))
    chunk = min(chunk, n)
    buf = np.empty((chunk, c))
    parts = []
    if progress is not None:
        progress(0.0)
    for start in range(0, n, chunk):
        stop = min(n, start + chunk)
        view = buf[: stop - start]
        compute_into(p[start:stop], data, view)
        counts, vals, cols = _truncate_into_csr_parts(view, t)
        if counts.size and counts.min() < 0:
            bad = start + int(np.flatnonzero(counts < 0)[0])
            raise ValueError(
                f"mean value coordinates of point {bad} ({p[bad].tolist()}) are not finite; "
                "is the cage degenerate?"
            )
        parts.append((counts, vals, cols))
        if progress is not None:
            progress(stop / n)
    return _assemble(parts, n, c)
