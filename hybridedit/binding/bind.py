"""The binding: truncated mean value coordinates of the shape w.r.t. the cage.

``bind`` computes the 3D mean value coordinates (:mod:`hybridedit.binding.mvc`)
chunk by chunk, truncates every row and assembles a CSR matrix ``M`` with
``M @ cage_vertices ~= points``. By default (method "fast") the hierarchical
kernel (:mod:`hybridedit.binding.mvc_tree`) computes each truncated row from the
cage vertices near the point, with far regions of the cage in aggregate;
rows it cannot decide go to a second pass with a smaller opening ratio, then
to the flat kernel (:mod:`hybridedit.binding.mvc_flat`: every face per point, exact
near, a quadrature far), which also makes whole rows (truncation 0). The
exact method (:mod:`hybridedit.binding.mvc_exact`, the reference) writes a chunk of
dense rows to a buffer and truncates them in a parallel kernel; the flat
kernel truncates each row as soon as it is made, while it is in cache, and
stores only the kept entries.

Every row is truncated by the rule of :mod:`hybridedit.binding.truncation` (the
paper's: the smallest coordinates are dropped up to 3% of the row's
magnitude, the rest rescaled to sum to 1); a row the rule keeps wider than
:data:`hybridedit.binding.truncation.MAX_ROW` keeps its largest, refitted to sum to 1 and reproduce
its point (:func:`hybridedit.binding.truncation.cap_rows`). Entries of exactly equal magnitude
at the threshold are decided by their order in the row: the caller's column
order for the exact method, the cage's internal vertex order for the fast
one.
"""

from __future__ import annotations

from collections.abc import Callable

import numba
import numpy as np
import scipy.sparse as sp
from numba import njit, prange

from ..defaults import TRUNCATION
from ..core.mesh import Mesh
from ..core.parallel import pick
from ..core.twins import twins
from ..core.topology import check_closed
from .mvc_exact import as_points, compute_into, n_blocks
from .mvc_flat import (FAR_RATIO, check_far_ratio, compute_fast_sorted, compute_fast_truncated, fast_scratch,
                       on_cage_truncated)
from .mvc_layout import LANES, plan_fast, plan_groups, prepare_cage, prepare_fast_cage
from .mvc_tree import THETA, TREE_FAR_RATIO, compute_tree_truncated, tree_scratch
from .tree_cage import prepare_tree_cage
from .truncation import MAX_ROW, MIN_KEPT_SUM, UNDECIDED, cap_rows, check_truncation, truncate_row

__all__ = ["bind", "truncate_rows", "dominant_cage_vertex", "MIN_KEPT_SUM", "METHODS"]

#: The ways ``bind`` can compute the coordinates (see :func:`bind`).
METHODS = ("fast", "flat", "exact")

#: Default budget for the dense coordinate buffer of one chunk, in bytes.
CHUNK_BYTES = 64 * 2**20
#: Nonzeros per row the fast method's truncating kernel stores (rows that
#: keep more are recomputed through the dense buffer).
SPARSE_ROW_CAP = 256
#: Nonzeros per row the hierarchical kernel's first pass stores (rows that keep more are made
#: with the others it leaves undecided, :data:`SPARSE_ROW_CAP` wide). Rows keep 3-12 entries and
#: a binding at most :data:`hybridedit.binding.truncation.MAX_ROW`: buffer rows 256 wide lay the
#: kept entries 1-2 KB apart, and packing a chunk's rows cost a page-table miss a row (11M: 3.5 s
#: on one core in all).
FIRST_PASS_ROW_CAP = 64


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
        idx = np.empty(c, dtype=np.int64)
        for i in range(start, stop):
            counts[i] = truncate_row(buf[i], truncation, min_kept_sum, surv, vals, idx)


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


@njit(cache=True, fastmath=False, error_model="numpy", parallel=True)
def _gather_rows_permuted(buf, col_of, indptr, data, indices):
    """As ``_gather_rows`` for rows whose column ``j`` is stored at ``col_of[j]``."""
    for i in prange(buf.shape[0]):
        row = buf[i]
        k = indptr[i]
        for j in range(col_of.shape[0]):
            v = row[col_of[j]]
            if v != 0.0:
                data[k] = v
                indices[k] = j
                k += 1


@njit(cache=True, inline="always")
def _pack_row(r, rows, ptr, counts, cols, vals, indices, data):
    """The first ``counts[r]`` entries of row ``rows[r]`` of cols / vals at ``ptr[r]`` (a row wider
    than the buffers is filled in separately)."""
    n = counts[r]
    if n > cols.shape[1]:
        return
    k = ptr[r]
    b = rows[r]
    for m in range(n):
        indices[k + m] = cols[b, m]
        data[k + m] = vals[b, m]


@twins()
def _pack_rows_twins(rows, ptr, counts, cols, vals, indices, data):  # pragma: no cover - compiled
    for r in prange(counts.shape[0]):
        _pack_row(r, rows, ptr, counts, cols, vals, indices, data)


def _pack_rows(counts: np.ndarray, cols: np.ndarray, vals: np.ndarray,
               rows: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(data, indices): the first ``counts[r]`` (>= 0) entries of row ``rows[r]`` (by default r) of
    the buffers ``cols`` (m, w) / ``vals`` concatenated; a row of more than w entries gets room,
    filled by the caller."""
    rows = np.arange(counts.shape[0]) if rows is None else rows
    ptr = np.zeros(counts.shape[0] + 1, dtype=np.int64)
    np.cumsum(counts, out=ptr[1:])
    data = np.empty(int(ptr[-1]))
    indices = np.empty(data.size, dtype=np.int32)
    # (sized by the buffers' entries, not the few copied: each row is a buffer row apart, a cache
    # miss or two, which two threads take side by side in half the time)
    pick("copy", *_pack_rows_twins, counts.shape[0] * cols.shape[1])(
        rows, ptr, counts, cols, vals, indices, data)
    return data, indices


def _truncate_into_csr_parts(
    buf: np.ndarray, truncation: float, col_of: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Truncate ``buf`` (m, c) in place; return (counts, data, indices) of its rows.

    With ``col_of``, column ``j`` of the result is stored at ``buf[:, col_of[j]]``.
    If a row is not finite its count is -1 and data/indices are empty.
    """
    m = buf.shape[0]
    counts = np.empty(m, dtype=np.int64)
    _truncate_block(buf, truncation, MIN_KEPT_SUM, counts, n_blocks(m))
    if m and counts.min() < 0:
        # A row with inf/nan: report it, nothing to gather.
        return counts, np.empty(0), np.empty(0, dtype=np.int32)
    indptr = np.zeros(m + 1, dtype=np.int64)
    np.cumsum(counts, out=indptr[1:])
    nnz = int(indptr[-1])
    data = np.empty(nnz)
    indices = np.empty(nnz, dtype=np.int32 if buf.shape[1] < 2**31 else np.int64)
    if col_of is None:
        _gather_rows(buf, indptr, data, indices)
    else:
        _gather_rows_permuted(buf, col_of, indptr, data, indices)
    return counts, data, indices


@njit(cache=True, inline="always")
def _row_to_point(k, src_ptr, src_data, src_idx, row_of, ptr, data, indices):
    """Row k of the (src_ptr, src_data, src_idx) CSR into row ``row_of[k]`` of (ptr, data, indices)."""
    a = src_ptr[k]
    o = ptr[row_of[k]]
    for q in range(src_ptr[k + 1] - a):
        data[o + q] = src_data[a + q]
        indices[o + q] = src_idx[a + q]


@twins()
def _rows_to_points(src_ptr, src_data, src_idx, row_of, ptr, data, indices):  # pragma: no cover
    for k in prange(row_of.shape[0]):
        _row_to_point(k, src_ptr, src_data, src_idx, row_of, ptr, data, indices)


def _assemble(parts: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]], n: int, c: int,
              row_of: np.ndarray | None = None) -> sp.csr_matrix:
    """The (n, c) CSR of the rows ``parts``: each (positions, counts, data, indices), the row at
    ``positions[k]`` (row ``row_of[positions[k]]`` with ``row_of`` (n,), a permutation) the k-th
    of the part. A row is in one part, or in several with every count but one 0 (a row a first
    pass left undecided, made in a later part). The rows are copied into place part by part (no
    concatenation of the parts first, and no splicing of a chunk's rows: both were whole passes
    over the data on one core)."""
    counts = [p[1] for p in parts]
    nnz = int(sum(int(k.sum()) for k in counts))
    idx_dtype = np.int32 if (nnz < 2**31 and c < 2**31) else np.int64
    dests = [pos if row_of is None else row_of[pos] for pos, *_ in parts]
    per_point = np.zeros(n, dtype=np.int64)
    for dest, k in zip(dests, counts):
        per_point[dest] += k
    indptr = np.zeros(n + 1, dtype=idx_dtype)
    np.cumsum(per_point, out=indptr[1:])
    data = np.empty(nnz)
    indices = np.empty(nnz, dtype=idx_dtype)
    copy = pick("copy", *_rows_to_points, n)
    for dest, (_, k, part_data, part_indices) in zip(dests, parts):
        if part_data.size:
            src_ptr = np.zeros(k.size + 1, dtype=np.int64)
            np.cumsum(k, out=src_ptr[1:])
            copy(src_ptr, part_data, part_indices, dest, indptr, data, indices)
    M = sp.csr_matrix((data, indices, indptr), shape=(n, c))
    M.has_sorted_indices = True
    return M


def _fast_truncated_chunk(plan, fast, ratio, scratch, t, start, stop, counts_buf, cols_buf,
                          vals_buf):
    """(counts, data, indices) of sorted positions [start, stop), fast method, truncated.

    Rows keeping more than the buffers' width are recomputed through a dense
    buffer (the same rows and truncation, so the same result).
    """
    m = stop - start
    counts = counts_buf[:m]
    compute_fast_truncated(plan, fast, start, stop, t, MIN_KEPT_SUM, counts, cols_buf, vals_buf,
                           ratio, scratch)
    if np.any(counts == -1):  # a row with inf/nan: reported by the caller
        return counts.copy(), np.empty(0), np.empty(0, dtype=np.int32)
    wide = np.flatnonzero(counts == -2)
    counts = counts.copy()
    wide_rows = {}
    if wide.size:
        # Dense rows for these positions, in runs of consecutive positions.
        runs = np.split(wide, np.flatnonzero(np.diff(wide) > 1) + 1)
        c = fast.n_vertices
        for run in runs:
            lo, hi = int(run[0]), int(run[-1]) + 1
            dense = np.empty((hi - lo, c))
            compute_fast_sorted(plan, fast, start + lo, start + hi, dense, ratio, correct=False,
                                scratch=scratch)
            cnt, v, cidx = _truncate_into_csr_parts(dense, t, fast.inv_perm)
            offs = np.concatenate([[0], np.cumsum(cnt)])
            for k in range(hi - lo):
                wide_rows[lo + k] = (v[offs[k]:offs[k + 1]], cidx[offs[k]:offs[k + 1]])
                counts[lo + k] = cnt[k]
    data, indices = _pack_rows(counts, cols_buf, vals_buf)
    if wide_rows:
        offs = np.concatenate([[0], np.cumsum(counts)])
        for r, (v, cidx) in wide_rows.items():
            data[offs[r]:offs[r + 1]] = v
            indices[offs[r]:offs[r + 1]] = cidx
    return counts, data, indices


def truncate_rows(dense: np.ndarray, truncation: float = TRUNCATION) -> sp.csr_matrix:
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
    t = check_truncation(truncation)
    a = np.asarray(dense)
    if a.ndim != 2:
        raise ValueError(f"dense must be a 2D array, got shape {a.shape}")
    buf = np.array(a, dtype=np.float64, order="C", copy=True)
    if not np.all(np.isfinite(buf)):
        raise ValueError("dense must be finite")
    n, c = buf.shape
    if n == 0 or c == 0:
        return sp.csr_matrix((n, c))
    return _assemble([(np.arange(n), *_truncate_into_csr_parts(buf, t))], n, c)


def bind(
    points: np.ndarray,
    cage: Mesh,
    truncation: float = TRUNCATION,
    chunk_size: int | None = None,
    progress: Callable[[float], None] | None = None,
    method: str = "fast",
    far_ratio: float | None = None,
    max_row: int | None = MAX_ROW,
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
        (0.03 in the paper). 0 keeps every nonzero: the whole coordinates.
    chunk_size : int, optional
        Points per chunk (the dense buffer holds ``chunk_size`` x ``c``
        doubles). By default chosen to keep the buffer near 64 MB.
    progress : callable(fraction), optional
        Called with the fraction of points done (0 before the first chunk,
        then after every chunk). An exception raised by it propagates, which
        cancels the binding.
    method : "fast", "flat" or "exact"
        "exact" evaluates the coordinates of every point with every cage face
        exactly. "flat" does so only for faces closer to the point than
        ``far_ratio`` times their size and integrates the others by a
        quadrature (see :mod:`hybridedit.binding.mvc_flat`); at the default ratio its
        rows differ from the exact ones by about 1e-5 of their magnitude,
        far below what the truncation drops. "fast" (the default) is "flat"
        for whole rows (truncation 0); when truncating it visits only the
        cage vertices near each point and accounts for far regions of the
        cage in aggregate (:mod:`hybridedit.binding.mvc_tree`), with the rows of the
        truncation rule on the flat coordinates up to the far field's
        approximation. All give partitions of unity, and with truncation 0
        all reproduce linear functions to rounding.
    far_ratio : float >= 1, optional
        Only for "fast" and "flat": larger is more accurate and slower;
        ``inf`` makes every near face exact. By default
        :data:`hybridedit.binding.mvc_flat.FAR_RATIO` for whole rows and the flat kernel, and
        :data:`hybridedit.binding.mvc_tree.TREE_FAR_RATIO` for the hierarchical kernel's
        truncated rows.
    max_row : int or None
        When truncating, the most coordinates a row keeps
        (:func:`hybridedit.binding.truncation.cap_rows`: a wider row keeps its largest, refitted
        to sum to 1 and reproduce its point); None: no bound (the plain rule).

    Returns
    -------
    M : (n, c) float64 scipy.sparse.csr_matrix
        Sorted column indices; rows sum to 1; ``M @ cage.vertices``
        approximates ``points`` (to rounding with truncation 0).

    Raises
    ------
    ValueError
        Bad points, a cage without faces or not closed, truncation outside
        [0, 1), a non-positive chunk size, an unknown method or a far ratio
        below 1.
    """
    p = as_points(points)
    if not isinstance(cage, Mesh):
        raise ValueError(f"cage must be a hybridedit.Mesh, got {type(cage).__name__}")
    if cage.n_faces == 0:
        raise ValueError("the cage has no faces")
    t = check_truncation(truncation)
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    ratio = check_far_ratio(FAR_RATIO if far_ratio is None else far_ratio)
    tree_ratio = TREE_FAR_RATIO if far_ratio is None else ratio
    c = cage.n_vertices
    n = p.shape[0]
    chunk = _chunk_rows(chunk_size, method, t, c)
    rows = _Rows(p, cage, method, t, ratio, tree_ratio)
    if n == 0:
        return sp.csr_matrix((0, c))
    chunk = min(chunk, n)
    rows.allocate(chunk)
    parts = []
    if progress is not None:
        progress(0.0)
    for start in range(0, n, chunk):
        stop = min(n, start + chunk)
        parts.extend(rows.chunk(start, stop))
        if stop == n:
            parts.extend(rows.leftovers())
        if progress is not None:
            progress(stop / n)
    if t > 0.0 and max_row is not None:
        parts = [_capped(part, p, cage.vertices, rows.row_of, int(max_row)) for part in parts]
    return _assemble(parts, n, c, rows.row_of)


def _capped(part, points: np.ndarray, cage_vertices: np.ndarray, row_of: np.ndarray | None, max_row: int):
    """A part of :func:`_assemble` with its rows cut to ``max_row`` entries and refitted
    (:func:`cap_rows`, with the points of its rows: ``points[row_of[positions]]``, or
    ``points[positions]`` when ``row_of`` is None). Cut part by part, while the part is small, the
    whole binding needs no pass of its own (11M rows: about a second on one core)."""
    pos, counts, data, indices = part
    if not counts.size or int(counts.max()) <= max_row:
        return part
    indptr = np.zeros(counts.size + 1, dtype=np.int64)
    np.cumsum(counts, out=indptr[1:])
    M = sp.csr_matrix((data, indices, indptr), shape=(counts.size, cage_vertices.shape[0]))
    M.has_sorted_indices = True
    at = pos if row_of is None else row_of[pos]
    M = cap_rows(M, points[at], cage_vertices, max_row)
    return pos, np.diff(M.indptr), M.data, M.indices


def _chunk_rows(chunk_size: int | None, method: str, t: float, c: int) -> int:
    """Points per chunk: ``chunk_size`` checked, or by default what keeps a chunk's buffers near
    :data:`CHUNK_BYTES` (whole batches of the fast kernels)."""
    if chunk_size is not None:
        if isinstance(chunk_size, (bool, np.bool_)) or int(chunk_size) != chunk_size or chunk_size < 1:
            raise ValueError(f"chunk_size must be a positive integer, got {chunk_size!r}")
        return int(chunk_size)
    if t > 0.0 and method in ("fast", "flat"):  # truncated as made: sparse buffers
        chunk = max(1, CHUNK_BYTES // (12 * min(c, FIRST_PASS_ROW_CAP if method == "fast" else SPARSE_ROW_CAP)))
    else:
        chunk = max(1, CHUNK_BYTES // (8 * c))
    if method in ("fast", "flat"):
        # Whole batches of the fast kernels (a batch split between two
        # chunks would be computed twice).
        chunk = max(LANES, chunk - chunk % LANES)
    return chunk


class _Rows:
    """The truncated rows of ``points`` by one method, chunk by chunk: the cage prepared (and
    checked closed) for the method's kernel, and the kernel's work arrays.

    ``row_of`` is None, or for the fast kernels the point of each position (chunks run over the
    points in the plan's order, :attr:`hybridedit.binding.mvc_layout.FastPlan.order`).
    """

    def __init__(self, p: np.ndarray, cage: Mesh, method: str, t: float, ratio: float, tree_ratio: float) -> None:
        self.p, self.method, self.t, self.ratio, self.tree_ratio = p, method, t, ratio, tree_ratio
        self.flat_kind = method in ("fast", "flat")
        self.tree = method == "fast" and t > 0.0  # hierarchical, truncated as made
        self.sparse = method == "flat" and t > 0.0  # every face per point, truncated as made
        self.row_of = None
        if method == "exact":
            self.data = prepare_cage(cage.vertices, cage.faces)
            check_closed(self.data.faces)
        else:
            self.fast = prepare_fast_cage(cage.vertices, cage.faces)
            check_closed(self.fast.exact.faces)

    def allocate(self, chunk: int) -> None:
        """The plan of the fast kernels and the work arrays for chunks of ``chunk`` points."""
        c = self.data.n_vertices if self.method == "exact" else self.fast.n_vertices
        if self.flat_kind:
            self.plan = plan_fast(self.p, self.fast)
            self.row_of = self.plan.order
            n_workers = min(-(-chunk // LANES) + 1, 4 * numba.get_num_threads())
        if self.flat_kind and not self.tree:
            self.scratch = fast_scratch(self.fast, n_workers)
        if self.tree:
            self.hier = prepare_tree_cage(self.fast)
            self.tscratch = tree_scratch(self.hier, n_workers)
            self.undecided: list[np.ndarray] = []  # positions each chunk left undecided (made in leftovers())
            self.second_radius = SECOND_RADIUS * float(np.median(self.plan.bsph[:, 3]))
        if self.sparse or self.tree:
            cap = min(c, FIRST_PASS_ROW_CAP if self.tree else SPARSE_ROW_CAP)
            self.counts_buf = np.empty(chunk, dtype=np.int64)
            self.cols_buf = np.empty((chunk, cap), dtype=np.int32)
            self.vals_buf = np.empty((chunk, cap))
        else:
            self.buf = np.empty((chunk, c))

    def chunk(self, start: int, stop: int) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
        """The rows of positions [start, stop) as parts of :func:`_assemble` (positions, counts,
        data, indices); ValueError for a row not finite."""
        t, ratio = self.t, self.ratio
        if self.method == "exact":
            view = self.buf[: stop - start]
            compute_into(self.p[start:stop], self.data, view)
            parts = [(np.arange(start, stop), *_truncate_into_csr_parts(view, t))]
        elif self.tree:
            part, redo = _tree_chunk(self.plan, self.hier, self.tree_ratio, self.tscratch, t, start, stop,
                                     self.counts_buf, self.cols_buf, self.vals_buf)
            parts = [part]
            self.undecided.append(redo)
        elif not self.sparse:
            # Rows kept whole: restore their exact linear precision (see
            # hybridedit.binding.mvc_flat). When truncating, that correction (~1e-5
            # of a row) is far below what the truncation drops and is skipped.
            view = self.buf[: stop - start]
            compute_fast_sorted(self.plan, self.fast, start, stop, view, ratio, correct=True,
                                scratch=self.scratch)
            parts = [(np.arange(start, stop), *_truncate_into_csr_parts(view, t, self.fast.inv_perm))]
        else:
            parts = [(np.arange(start, stop), *_fast_truncated_chunk(
                self.plan, self.fast, ratio, self.scratch, t, start, stop, self.counts_buf, self.cols_buf,
                self.vals_buf))]
        return self._checked(parts)

    @property
    def ratios(self) -> tuple[float, float]:
        """(the flat kernel's far ratio, the hierarchical kernel's)."""
        return self.ratio, self.tree_ratio

    def leftovers(self) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
        """The rows the chunks of the hierarchical kernel left undecided, all made at once after
        the last chunk (:func:`_undecided_rows`), as parts of :func:`_assemble`; [] otherwise."""
        if not self.tree or not self.undecided:
            return []
        redo = np.concatenate(self.undecided)
        self.undecided = []
        if not redo.size:
            return []
        return self._checked(_undecided_rows(redo, self.plan, self.hier, self.ratios, self.tscratch, self.t,
                                              min(self.fast.n_vertices, SPARSE_ROW_CAP), self.p,
                                              self.second_radius))

    def _checked(self, parts):
        """``parts``; ValueError naming the point of a row that is not finite."""
        for pos, counts, _, _ in parts:
            if counts.size and counts.min() < 0:
                bad = int(pos[np.flatnonzero(counts < 0)[0]])
                if self.row_of is not None:
                    bad = int(self.row_of[bad])
                raise ValueError(
                    f"mean value coordinates of point {bad} ({self.p[bad].tolist()}) are not finite; "
                    "is the cage degenerate?"
                )
        return parts


def _decided_rows(counts, cols, vals, rows=None):
    """(counts, data, indices, redo): the rows whose ``counts`` are >= 0 packed (a copy of
    ``counts``, 0 for the others; row k is row ``rows[k]``, by default k, of ``cols`` / ``vals``),
    and ``redo`` the indices k of the others (undecided, too wide)."""
    redo = np.flatnonzero(counts < 0)
    counts = counts.copy()
    counts[redo] = 0
    data, indices = _pack_rows(counts, cols, vals, rows)
    return counts, data, indices, redo


def _tree_chunk(plan, hier, ratio, scratch, t, start, stop, counts_buf, cols_buf, vals_buf):
    """The rows of sorted positions [start, stop) the hierarchical kernel decides, as a part of
    :func:`_assemble` (0 entries for the others), and the positions of the others (undecided or
    too wide for the buffers: :func:`_undecided_rows` makes them after the last chunk).
    """
    m = stop - start
    counts = counts_buf[:m]
    compute_tree_truncated(plan, hier, start, stop, t, MIN_KEPT_SUM, counts, cols_buf, vals_buf, ratio, scratch)
    counts, data, indices, redo = _decided_rows(counts, cols_buf, vals_buf)
    return (np.arange(start, stop), counts, data, indices), start + redo


def _undecided_rows(redo, plan, hier, ratios, scratch, t, width, p, radius):
    """The rows of sorted positions ``redo`` (k,) that the first pass left undecided, as parts of
    :func:`_assemble`: the unit row of a cage vertex a point sits on, the row of a cage face it
    lies on (as the flat kernel makes it, :func:`on_cage_truncated`), else computed again in
    batches of points within ``radius`` of each other only (:func:`_second_pass_rows`).

    They are made once, after the last chunk, rather than chunk by chunk: a chunk's few hundred
    undecided points made a few small kernel calls that kept one core of two busy, and the steps
    around them (the curve, the batches, the vertex look-up) ran on one core 500 times at 11M.
    """
    points = p[plan.order[redo]]
    at, col = _at_cage_vertex(points, hier.fast)
    parts = []
    if at.size:
        parts.append((redo[at], np.ones(at.size, dtype=np.int64), np.ones(at.size), col.astype(np.int32)))
        keep = np.ones(redo.size, dtype=bool)
        keep[at] = False
        redo, points = redo[keep], points[keep]
    # A point on a cage face is undecided at every opening ratio (its face is opened and the point
    # is on it): its face's row is made here, not after every ratio of the second pass has failed
    # (694 rows of the 2.77M armadillo kept three such passes busy for 2.3 s).
    on = (np.full(redo.size, UNDECIDED, dtype=np.int64), np.empty((redo.size, width), dtype=np.int32),
          np.empty((redo.size, width)))
    on_cage_truncated(points, hier.fast, t, MIN_KEPT_SUM, *on)
    hit = on[0] >= 0
    if hit.any():
        parts.append((redo[hit], on[0][hit], *_pack_rows(on[0][hit], on[1], on[2], np.flatnonzero(hit))))
        redo, points = redo[~hit], points[~hit]
    if not redo.size:
        return parts
    for local, *rows in _second_pass_rows(points, hier, ratios, scratch, t, width, radius):
        parts.append((redo[local], *rows))
    return parts


#: Opening ratios of the second pass (:func:`_second_pass_rows`), tried in turn.
SECOND_THETAS = (0.5 * THETA, 0.25 * THETA, 0.125 * THETA)
#: Radius of the second pass's batches, in median first-pass batch radii: a batch twice as wide
#: holds more of the scattered undecided points (the 100K creature's bind 1.13 s instead of 1.5 s
#: at one radius); much wider ones leave more rows to the smaller ratios.
SECOND_RADIUS = 2.0
#: Batches of the second pass computed at a time (their rows in buffers).
SECOND_BATCHES = 256


def _second_pass_rows(points, hier, ratios, scratch, t, width, radius):
    """The rows of the (k, 3) ``points`` that the first pass left undecided, as parts of
    :func:`_assemble` (positions: indices into ``points``); ``ratios``: the far ratios of the flat
    and the hierarchical kernel.

    Two things leave a row undecided. A wide batch (one straddling a thin part or a jump of the
    curve) opens more vertices than its buffers hold; and a point that sees much of the cage from
    afar (inside a round cage) has more aggregated mass than the truncation may drop. Batched
    again along the curve, the undecided points lie far apart: every batch is wide. So
    here a batch holds only points within ``radius`` of its first (:data:`SECOND_RADIUS` typical
    first-pass batch radii: :func:`hybridedit.binding.mvc_layout.plan_groups`), and the opening ratio is
    lowered step by step (:data:`SECOND_THETAS`: fewer nodes aggregated); batched along the curve,
    most of these rows went on to the flat kernel (728 of the 690K armadillo's 1,067).
    What is still undecided goes to the flat kernel (a pass over every cage face: O(c) a row, the
    part of the binding that grew faster than the shape).
    """
    fast = hier.fast
    ratio, tree_ratio = ratios
    parts = []
    redo = np.arange(points.shape[0])
    for theta in SECOND_THETAS:
        if not redo.size:
            break
        plan, position = plan_groups(points[redo], fast, radius)
        nbatch = plan.bx.shape[0]
        n = min(nbatch, SECOND_BATCHES) * LANES
        c_buf, i_buf, v_buf = np.empty(n, dtype=np.int64), np.empty((n, width), dtype=np.int32), np.empty((n, width))
        left = []
        for b0 in range(0, nbatch, SECOND_BATCHES):
            b1 = min(nbatch, b0 + SECOND_BATCHES)
            compute_tree_truncated(plan, hier, b0 * LANES, b1 * LANES, t, MIN_KEPT_SUM, c_buf, i_buf, v_buf, tree_ratio,
                                   scratch, theta=theta)
            mine = np.flatnonzero((position >= b0 * LANES) & (position < b1 * LANES))
            at = position[mine] - b0 * LANES
            counts, data, indices, undecided = _decided_rows(c_buf[at], i_buf, v_buf, at)
            parts.append((redo[mine], counts, data, indices))
            left.append(redo[mine[undecided]])
        redo = np.concatenate(left)
    if not redo.size:
        return parts
    kk = len(redo)
    bufs = (np.full(kk, UNDECIDED, dtype=np.int64), np.empty((kk, width), dtype=np.int32), np.empty((kk, width)))
    sub_plan = plan_fast(points[redo], fast)
    # (work arrays for as many workers as batches, made for this call: they hold a few rows of the
    # whole cage per worker, 150 MB a worker at 2.77M, and few rows ever come here)
    sub = _fast_truncated_chunk(sub_plan, fast, ratio, None, t, 0, kk, *bufs)
    return parts + [(redo[sub_plan.order], *sub)]


def _at_cage_vertex(points: np.ndarray, fast) -> tuple[np.ndarray, np.ndarray]:
    """Which of the (k, 3) ``points`` lie at a cage vertex (within the on-cage vertex tolerance of
    :func:`hybridedit.binding.mvc_faces.tolerances`), and the caller's column of that vertex.

    A quadric simplification keeps some of the shape's own vertices, so about 0.3% of a shape's
    points sit exactly on a cage vertex. Their row is the unit row of that vertex (what the flat
    kernel's on-cage rule gives them), found here with a KD-tree over the cage instead of a pass
    over every cage face (O(c) a row: the part of the binding that grew faster than the shape).
    """
    from scipy.spatial import cKDTree

    from .mvc_faces import tolerances

    x = (points - fast.origin) / fast.unit  # (as plan_fast places them)
    d, j = cKDTree(fast.verts_t.T).query(x)
    at = np.flatnonzero(d <= tolerances(fast.scale)[0])
    return at, fast.perm[j[at]]


def dominant_cage_vertex(M: sp.spmatrix) -> np.ndarray:
    """Per row of a binding, the cage vertex with the largest |coordinate|.

    Parameters
    ----------
    M : (n, c) sparse binding (or some of its rows).

    Returns
    -------
    (n,) int64 cage vertex indices (the lowest index among equal largest ones; 0
    for an empty row).
    """
    M = sp.csr_matrix(M)
    if not M.has_canonical_format:  # sorted, no duplicates (the caller's matrix is not changed)
        M = M.copy()
        M.sum_duplicates()
    out = np.zeros(M.shape[0], dtype=np.int64)
    # one compiled pass over the entries (numpy's sort-based version: 1.6 s at 11M rows)
    _dominant_rows(M.indptr, M.indices, M.data, out)
    return out


@njit(cache=True)
def _dominant_rows(indptr, indices, data, out):  # pragma: no cover - compiled
    for i in range(out.shape[0]):
        best = -1.0
        col = 0
        for k in range(indptr[i], indptr[i + 1]):
            a = abs(data[k])
            if a > best or (a == best and indices[k] < col):
                best = a
                col = indices[k]
        out[i] = col
