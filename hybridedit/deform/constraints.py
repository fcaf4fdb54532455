"""The seam between constrained and free shape vertices.

Constrained shape vertices are placed exactly (fixed: where they were; handle:
at their group's transform of where they were). On the cage, only the cage
vertices whose nearest shape vertex is constrained are held (fixed, or following
their group's transform; for a selection made on the cage, the picked ones). The
other cage vertices a constrained row leans on are free and may move, so near
the border of the region of interest the cage alone would carry a constrained
vertex slightly off its target: a small mismatch that varies smoothly along the
border (the drift and handle error of a plain x' = M y'). The exact placement
removes it on the constrained rows, and the free rows are then solved with
those exact positions as their boundary: with the residual propagation by
:class:`RegionStep` (one full-resolution ARAP step over the free region), with
the linear propagation by :class:`SeamSpread`, the harmonic extension of the
correction (the smoothest field that equals the correction on the seam and
vanishes on the vertices that do not move), so the surface stays smooth across
the seam.

Roles are those of :mod:`hybridedit.deform.roles`: ``-1`` fixed, ``0`` free,
``k + 1`` handle group ``k``.
"""

from __future__ import annotations

import copy

import numpy as np
import scipy.sparse as sp
from numba import njit, prange

from ..core.cotangent_laplacian import ShapeLaplacian, laplacian_rows
from ..core.index_sets import union_in_range, unique_in_range
from ..core.linsolve import SPDSolver
from ..core.parallel import pick
from ..core.twins import twins
from ..core.proximity import rows_near
from ..core.row_copy import put_rows


def _bounded(rows: sp.csr_matrix, free: np.ndarray) -> np.ndarray:
    """Which vertices of ``free`` (f,) lie in parts of the free region that touch a vertex outside
    it, (f,) bool, from their rows ``rows`` (f, n) of the Laplacian (a part that touches none, e.g.
    a loose part carried by its host, has no boundary to be solved from and is left out)."""
    if free.size == 0:
        return np.zeros(0, dtype=bool)
    K = rows[:, free]
    n_parts, part = sp.csgraph.connected_components(K, directed=False)
    out_deg = np.diff(rows.indptr) - np.diff(K.tocsr().indptr)
    touches = np.zeros(n_parts, dtype=bool)
    touches[part[out_deg > 0]] = True
    return touches[part]


def _bounded_rows(laplacian, free: np.ndarray) -> tuple[np.ndarray, sp.csr_matrix, np.ndarray]:
    """(kept, rows, at): the vertices of ``free`` that :func:`_bounded` keeps, their rows of
    ``laplacian`` (a :class:`~hybridedit.core.cotangent_laplacian.ShapeLaplacian` makes only
    these) and their positions in ``free``."""
    rows = laplacian_rows(laplacian, free)
    keep = _bounded(rows, free)
    if keep.all():
        return free, rows, np.arange(free.size)
    return free[keep], rows[keep], np.flatnonzero(keep)


class SeamSpread:
    """Harmonic extension of the seam's correction over the free moving vertices.

    Parameters
    ----------
    laplacian : (n, n) shape Laplacian (positive weights): a sparse matrix, or a
        :class:`~hybridedit.core.cotangent_laplacian.ShapeLaplacian` (only the rows of ``free``
        are made).
    free : (f,) int64 free shape vertices that move (the unknowns).
    seam : (s,) int64 constrained shape vertices whose correction can be nonzero.

    Every other vertex counts as a boundary with no correction. Factored once
    (per selection); :meth:`correction` is two triangular solves.

    Examples
    --------
    >>> L = sp.csr_matrix(np.array([[1.0, -1, 0], [-1, 2, -1], [0, -1, 1]]))
    >>> s = SeamSpread(L, np.array([1]), np.array([0]))
    >>> (s.correction(np.array([[2.0, 0, 0]])).round(6) + 0.0).tolist()  # halfway to the far end
    [[1.0, 0.0, 0.0]]
    """

    def __init__(self, laplacian: "sp.spmatrix | ShapeLaplacian", free: np.ndarray, seam: np.ndarray) -> None:
        self.free = np.asarray(free, dtype=np.int64)
        self.seam = np.asarray(seam, dtype=np.int64)
        self._solver = None
        self._rows = np.zeros(0, dtype=np.int64)
        if self.free.size and self.seam.size:
            # a part with no boundary gets no correction
            solved, rows, self._rows = _bounded_rows(laplacian, self.free)
            self._solver = SPDSolver(rows[:, solved].tocsc(), simplicial=True)
            self._coupling = rows[:, self.seam].tocsr()

    def correction(self, mismatch: np.ndarray) -> np.ndarray:
        """(f, 3) correction of the free vertices for the seam's (s, 3) ``mismatch``."""
        out = np.zeros((self.free.size, 3))
        if self._solver is not None:
            out[self._rows] = self._solver.solve(-(self._coupling @ mismatch))
        return out




def _summing_to_one(w: np.ndarray) -> np.ndarray:
    """(t, k) float64 blend weights ``w`` (stored as float32) made to sum to 1 per row in float64
    (rows of no weight stay zero): equal rotations then blend to that rotation to rounding."""
    out = np.asarray(w, dtype=np.float64)
    total = out.sum(axis=1, keepdims=True)
    return np.ascontiguousarray(np.divide(out, total, out=np.zeros_like(out), where=total > 0))


@njit(cache=True, inline="always")
def _blend_one(i, idx, w, cage_rots, out):
    """out[i] = sum_k w[i, k] cage_rots[idx[i, k]]: the rotation a shape vertex takes, a linear
    blend (as the residual turns with: neighbouring cage rotations differ little; making it
    orthonormal changes the result by less than 0.2% in benchmarks/table1.py)."""
    a00 = a01 = a02 = a10 = a11 = a12 = a20 = a21 = a22 = 0.0
    for k in range(idx.shape[1]):
        c = w[i, k]
        if c == 0.0:  # (padding of a row shorter than k)
            continue
        r = cage_rots[idx[i, k]]
        a00 += c * r[0, 0]
        a01 += c * r[0, 1]
        a02 += c * r[0, 2]
        a10 += c * r[1, 0]
        a11 += c * r[1, 1]
        a12 += c * r[1, 2]
        a20 += c * r[2, 0]
        a21 += c * r[2, 1]
        a22 += c * r[2, 2]
    t = out[i]
    t[0, 0] = a00
    t[0, 1] = a01
    t[0, 2] = a02
    t[1, 0] = a10
    t[1, 1] = a11
    t[1, 2] = a12
    t[2, 0] = a20
    t[2, 1] = a21
    t[2, 2] = a22


@njit(cache=True, inline="always")
def _region_rhs_of(r, rots, free_local, indptr, indices, he, s, cptr, cidx, cw, x, b):
    """b[r] = R_i s_r + sum_j R_j he_rj + sum_{j boundary} w_ij x_j for the free vertex
    i = free_local[r]: the ARAP right-hand side sum_j w_ij/2 (R_i + R_j)(p_i - p_j) with the
    edge terms he_rj = w_ij/2 (p_i - p_j) and their sum s_r made once, and the boundary
    vertices' known positions moved over."""
    ri = rots[free_local[r]]
    s0, s1, s2 = s[r, 0], s[r, 1], s[r, 2]
    b0 = ri[0, 0] * s0 + ri[0, 1] * s1 + ri[0, 2] * s2
    b1 = ri[1, 0] * s0 + ri[1, 1] * s1 + ri[1, 2] * s2
    b2 = ri[2, 0] * s0 + ri[2, 1] * s1 + ri[2, 2] * s2
    for k in range(indptr[r], indptr[r + 1]):
        rj = rots[indices[k]]
        e0, e1, e2 = he[k, 0], he[k, 1], he[k, 2]
        b0 += rj[0, 0] * e0 + rj[0, 1] * e1 + rj[0, 2] * e2
        b1 += rj[1, 0] * e0 + rj[1, 1] * e1 + rj[1, 2] * e2
        b2 += rj[2, 0] * e0 + rj[2, 1] * e1 + rj[2, 2] * e2
    for k in range(cptr[r], cptr[r + 1]):
        g = cidx[k]
        c = cw[k]
        b0 += c * x[g, 0]
        b1 += c * x[g, 1]
        b2 += c * x[g, 2]
    b[r, 0] = b0
    b[r, 1] = b1
    b[r, 2] = b2


@twins()
def _region_rhs(idx, w, cage_rots, rots, free_local, indptr, indices, he, s, cptr, cidx, cw, x, b):
    for i in prange(rots.shape[0]):
        _blend_one(i, idx, w, cage_rots, rots)
    for r in prange(free_local.shape[0]):
        _region_rhs_of(r, rots, free_local, indptr, indices, he, s, cptr, cidx, cw, x, b)


def region_rhs(idx, w, cage_rots, rots, free_local, indptr, indices, he, s, cptr, cidx, cw, x, b):
    """The region step's right-hand side in one pass over its vertices (numbered on their own).

    Parameters
    ----------
    idx, w : (t, k) cage vertices and weights of each vertex's rotation blend.
    cage_rots : (c, 3, 3) cage rotations. rots : (t, 3, 3) scratch, gets the blends.
    free_local : (f,) int64 the unknowns among the t vertices.
    indptr, indices, he : CSR by unknown of its edges: the other end (of the t) and
        w_ij/2 (p_i - p_j), (e, 3). s : (f, 3) their sums per unknown.
    cptr, cidx, cw : CSR by unknown of its edges to boundary vertices: their rows of ``x`` and w_ij.
    x : (n, 3) current shape positions.
    b : (f, 3) output (any memory order): sum_j w_ij/2 (R_i + R_j)(p_i - p_j) + sum_{j boundary} w_ij x_j.
    """
    args = (idx, w, cage_rots, rots, free_local, indptr, indices, he, s, cptr, cidx, cw, x, b)
    pick("region_step", *_region_rhs, rots.shape[0])(*args)


@njit(cache=True, inline="always")
def _place_one(i, source, T, out):
    x0, x1, x2 = source[i, 0], source[i, 1], source[i, 2]
    for p in range(3):
        out[i, p] = T[p, 0] * x0 + T[p, 1] * x1 + T[p, 2] * x2 + T[p, 3]


@twins()
def _place(rows, source, T, out):
    for r in prange(rows.shape[0]):
        _place_one(rows[r], source, T, out)




def place(rows, source, T, out):
    """out[i] = T applied to source[i] for i in rows ((4, 4) affine T): the exact
    position of constrained vertices, in one pass."""
    pick("place", *_place, rows.shape[0])(rows, source, T, out)


#: A free region up to this many vertices is solved whole every frame; a larger one
#: only in a band around the seam (its inside follows the cage as in the paper),
#: so that a frame costs about the same as the plain propagation on big regions.
REGION_WHOLE_MAX = 8000
#: Width of that band, in mean cage edge lengths.
BAND_CAGE_EDGES = 2.0


def region_to_solve(points: np.ndarray, free: np.ndarray, seam: np.ndarray, cage_edge: float) -> np.ndarray:
    """The free vertices the region step solves: all of them for a small region,
    else those within :data:`BAND_CAGE_EDGES` cage edges of the seam.

    Parameters
    ----------
    points : (n, 3) float64 shape positions; free : (f,) int64; seam : (s,) int64;
    cage_edge : mean cage edge length.

    Returns
    -------
    (b,) int64 sorted subset of ``free``.
    """
    free = np.asarray(free, dtype=np.int64)
    if free.size <= REGION_WHOLE_MAX or seam.size == 0:
        return free
    return free[rows_near(points, free, seam, BAND_CAGE_EDGES * cage_edge)]


class RegionStep:
    """One full-resolution ARAP global step over the free moving vertices.

    The cage gives every shape vertex a rotation (the blend of the rotations of
    the cage vertices it depends on most, the same one its residual turns with).
    With those rotations fixed, the positions of the free vertices that minimise
    the shape's ARAP energy, given the constrained and still vertices around
    them, are one sparse solve with the free region's Laplacian (factored once
    per selection, as :class:`SeamSpread` does). It carries the seam's correction
    into the region and removes the stretch that interpolating through the
    coarse cage leaves.

    Parameters
    ----------
    rest : (n, 3) float64 rest positions of the shape.
    laplacian : (n, n) shape Laplacian (positive weights): a sparse matrix, or a
        :class:`~hybridedit.core.cotangent_laplacian.ShapeLaplacian` (only the rows of ``free``
        are made).
    free : (f,) int64 free moving shape vertices (the unknowns).
    idx, w : (n, k) the cage vertices and blend weights of each shape vertex's
        rotation (:func:`hybridedit.deform.residual.residual_setup`).
    """

    def __init__(self, rest: np.ndarray, laplacian: "sp.spmatrix | ShapeLaplacian", free: np.ndarray,
                 idx: np.ndarray, w: np.ndarray) -> None:
        self.free = np.asarray(free, dtype=np.int64)
        self._solver = None
        if self.free.size == 0:
            return
        n = laplacian.shape[0]
        # a part with no boundary keeps its propagated pose
        self.free, rows, _ = _bounded_rows(laplacian, self.free)
        if self.free.size == 0:
            return
        inside = np.zeros(n, dtype=bool)
        inside[self.free] = True
        around = unique_in_range(rows.indices, n)
        self.boundary = around[~inside[around]].astype(np.int64)
        self._solver = SPDSolver(rows[:, self.free].tocsc(), simplicial=True)
        # the vertices whose rotations the step uses (free and boundary), numbered on their own and
        # copied out once: a frame reads their rows in order instead of scattered through the shape
        turning = union_in_range(self.free, self.boundary, n)
        self._turning = turning
        self._idx = np.ascontiguousarray(idx[turning], dtype=np.int64)
        self._w = _summing_to_one(w[turning])
        self._free_local = np.searchsorted(turning, self.free).astype(np.int64)
        # each unknown's edges (the weights w_ij = -L_ij), the other end numbered among ``turning``
        E = sp.csr_matrix(-rows[:, turning])
        E.data[E.indices == np.repeat(self._free_local, np.diff(E.indptr))] = 0.0  # no edge to itself
        E.eliminate_zeros()
        E.sort_indices()
        self._E = (E.indptr.astype(np.int64), E.indices.astype(np.int64))
        self._Ew = E.data.astype(np.float64)
        # and its edges to boundary vertices, by their row of the shape: their positions are known
        # (w_ij x_j moves to the right-hand side, in the same pass)
        C = (-rows[:, self.boundary]).tocsr()
        C.eliminate_zeros()
        C.sort_indices()
        self._C = (C.indptr.astype(np.int64), self.boundary[C.indices].astype(np.int64),
                   C.data.astype(np.float64))
        self._edge_terms(rest)
        self._scratch()

    def _edge_terms(self, positions: np.ndarray) -> None:
        """The per-edge terms w_ij/2 (p_i - p_j) of the right-hand side, and their sums per
        unknown, for reference positions ``positions`` (n, 3)."""
        indptr, indices = self._E
        wts = self._Ew
        p = np.asarray(positions, dtype=np.float64)[self._turning]
        r = np.repeat(np.arange(self.free.size), np.diff(indptr))
        he = (0.5 * wts)[:, None] * (p[self._free_local[r]] - p[indices])
        self._he = np.ascontiguousarray(he)
        self._s = np.ascontiguousarray(np.stack([np.bincount(r, he[:, c], minlength=self.free.size)
                                                 for c in range(3)], axis=1))

    def _scratch(self) -> None:
        """Buffers a frame writes (each copy of the step has its own)."""
        self._rots = np.zeros((self._turning.size, 3, 3))
        self._b = np.empty((self.free.size, 3), order="F")  # the solver's column order: passed without a copy

    def with_reference(self, positions: np.ndarray) -> "RegionStep":
        """The same step measuring its edge vectors in ``positions`` (n, 3) (the pose an
        edit starts from) instead of the rest positions; the factorization is shared."""
        other = copy.copy(self)
        if self._solver is not None:
            other._edge_terms(positions)
            other._scratch()
        return other

    def apply(self, out: np.ndarray, cage_rotations: np.ndarray) -> None:
        """Replace ``out[free]`` by the step's solution; the other rows of ``out``
        (constrained and still vertices) are its boundary values."""
        if self._solver is None:
            return
        region_rhs(self._idx, self._w, cage_rotations, self._rots, self._free_local, *self._E, self._he,
                   self._s, *self._C, out, self._b)
        put_rows(self._solver.solve(self._b), self.free, out)
