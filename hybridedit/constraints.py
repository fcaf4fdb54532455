"""The seam between constrained and free shape vertices.

Constrained shape vertices are placed exactly (fixed: where they were; handle:
at their group's transform of where they were). The cage vertices their rows
lean on are not all held, so near the border of the region of interest the cage
would carry a constrained vertex slightly off its target: a small mismatch that
varies smoothly along the border (the drift and handle error of a plain
x' = M y'). The constraint removes it, and the free vertices take the harmonic
extension of that correction (the smoothest field that equals the correction on
the seam and vanishes on the vertices that do not move), so the surface stays
smooth across the seam.

Roles are small integers, the same for shape and cage vertices:
``-1`` fixed, ``0`` free, ``k + 1`` handle group ``k``.
"""

from __future__ import annotations

import copy

import numpy as np
import scipy.sparse as sp
from numba import njit

from .linsolve import SPDSolver

FIXED = -1
FREE = 0


def _bounded(L: sp.csr_matrix, free: np.ndarray) -> np.ndarray:
    """The vertices of ``free`` in parts of the free region that touch a vertex
    outside it (a part that touches none, e.g. a loose part carried by its host,
    has no boundary to be solved from and is left out)."""
    free = np.asarray(free, dtype=np.int64)
    if free.size == 0:
        return free
    rows = L[free]
    K = rows[:, free]
    n_parts, part = sp.csgraph.connected_components(K, directed=False)
    inside = np.zeros(L.shape[0], dtype=bool)
    inside[free] = True
    out_deg = np.diff(rows.indptr) - np.diff(K.tocsr().indptr)
    touches = np.zeros(n_parts, dtype=bool)
    touches[part[out_deg > 0]] = True
    return free[touches[part]]


class SeamSpread:
    """Harmonic extension of the seam's correction over the free moving vertices.

    Parameters
    ----------
    laplacian : (n, n) sparse shape Laplacian (positive weights).
    free : (f,) int64 free shape vertices that move (the unknowns).
    seam : (s,) int64 constrained shape vertices whose correction can be nonzero.

    Every other vertex counts as a boundary with no correction. Factored once
    (per selection); :meth:`correction` is two triangular solves.

    Examples
    --------
    >>> L = sp.csr_matrix(np.array([[1.0, -1, 0], [-1, 2, -1], [0, -1, 1]]))
    >>> s = SeamSpread(L, np.array([1]), np.array([0]))
    >>> s.correction(np.array([[2.0, 0, 0]])).round(6).tolist()  # halfway to the far end
    [[1.0, 0.0, 0.0]]
    """

    def __init__(self, laplacian: sp.spmatrix, free: np.ndarray, seam: np.ndarray) -> None:
        self.free = np.asarray(free, dtype=np.int64)
        self.seam = np.asarray(seam, dtype=np.int64)
        self._solver = None
        self._rows = np.zeros(0, dtype=np.int64)
        if self.free.size and self.seam.size:
            L = sp.csr_matrix(laplacian)
            solved = _bounded(L, self.free)  # a part with no boundary gets no correction
            self._rows = np.searchsorted(self.free, solved) if np.all(np.diff(self.free) > 0) \
                else np.flatnonzero(np.isin(self.free, solved))
            rows = L[solved]
            self._solver = SPDSolver(rows[:, solved].tocsc(), simplicial=True)
            self._coupling = rows[:, self.seam].tocsr()

    def correction(self, mismatch: np.ndarray) -> np.ndarray:
        """(f, 3) correction of the free vertices for the seam's (s, 3) ``mismatch``."""
        out = np.zeros((self.free.size, 3))
        if self._solver is not None:
            out[self._rows] = self._solver.solve(-(self._coupling @ mismatch))
        return out


@njit(cache=True)
def _blend_rotations(rows, idx, w, cage_rots, out):
    """out[i] = sum_k w[i, k] cage_rots[idx[i, k]] for i in rows (a linear blend, as the
    residual turns with: neighbouring cage rotations differ little; making it
    orthonormal changes the result by less than 0.2% in benchmarks/table1.py)."""
    for r in range(rows.shape[0]):
        i = rows[r]
        for p in range(3):
            for q in range(3):
                acc = 0.0
                for k in range(idx.shape[1]):
                    acc += w[i, k] * cage_rots[idx[i, k], p, q]
                out[i, p, q] = acc


@njit(cache=True)
def place(rows, source, T, out):
    """out[i] = T applied to source[i] for i in rows ((4, 4) affine T): the exact
    position of constrained vertices, in one pass."""
    for r in range(rows.shape[0]):
        i = rows[r]
        x0, x1, x2 = source[i, 0], source[i, 1], source[i, 2]
        for p in range(3):
            out[i, p] = T[p, 0] * x0 + T[p, 1] * x1 + T[p, 2] * x2 + T[p, 3]


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
    from scipy.spatial import cKDTree

    d, _ = cKDTree(points[seam]).query(points[free], distance_upper_bound=BAND_CAGE_EDGES * cage_edge)
    return free[np.isfinite(d)]


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
    laplacian : (n, n) sparse shape Laplacian (positive weights).
    free : (f,) int64 free moving shape vertices (the unknowns).
    idx, w : (n, k) the cage vertices and blend weights of each shape vertex's
        rotation (:func:`hybridedit.residual.residual_setup`).
    """

    def __init__(self, rest: np.ndarray, laplacian: sp.spmatrix, free: np.ndarray, idx: np.ndarray,
                 w: np.ndarray) -> None:
        from .arap import _rhs  # the ARAP right-hand side kernel

        self._rhs = _rhs
        self.free = np.asarray(free, dtype=np.int64)
        self._solver = None
        if self.free.size == 0:
            return
        L = sp.csr_matrix(laplacian)
        n = L.shape[0]
        self.free = _bounded(L, self.free)  # a part with no boundary keeps its propagated pose
        if self.free.size == 0:
            return
        rows = L[self.free]
        inside = np.zeros(n, dtype=bool)
        inside[self.free] = True
        around = np.unique(rows.indices)
        self.boundary = around[~inside[around]].astype(np.int64)
        self._solver = SPDSolver(rows[:, self.free].tocsc(), simplicial=True)
        self._coupling = rows[:, self.boundary].tocsr()
        # the vertices whose rotations the step uses (free and boundary), numbered on their own and
        # copied out once: a frame reads their rows in order instead of scattered through the shape
        turning = np.union1d(self.free, self.boundary).astype(np.int64)
        Lt = L[turning][:, turning].tocsr()
        W = (sp.diags(Lt.diagonal()) - Lt).tocsr()  # the edge weights among them
        W.sort_indices()
        self._W = (W.indptr.astype(np.int64), W.indices.astype(np.int64), W.data.astype(np.float64))
        self._turning = turning
        self._rest = np.ascontiguousarray(rest[turning])
        self._idx, self._w = np.ascontiguousarray(idx[turning]), np.ascontiguousarray(w[turning])
        self._all = np.arange(turning.size, dtype=np.int64)
        self._free_local = np.searchsorted(turning, self.free).astype(np.int64)
        self._rots = np.zeros((turning.size, 3, 3))
        self._b = np.empty((self.free.size, 3))

    def with_reference(self, positions: np.ndarray) -> "RegionStep":
        """The same step measuring its edge vectors in ``positions`` (n, 3) (the pose an
        edit starts from) instead of the rest positions; the factorization is shared."""
        other = copy.copy(self)
        if self._solver is not None:
            other._rest = np.ascontiguousarray(positions[self._turning], dtype=np.float64)
            other._rots = np.zeros_like(self._rots)
            other._b = np.empty_like(self._b)
        return other

    def apply(self, out: np.ndarray, cage_rotations: np.ndarray) -> None:
        """Replace ``out[free]`` by the step's solution; the other rows of ``out``
        (constrained and still vertices) are its boundary values."""
        if self._solver is None:
            return
        _blend_rotations(self._all, self._idx, self._w, cage_rotations, self._rots)
        indptr, indices, data = self._W
        self._rhs(self._rest, indptr, indices, data, self._rots, self._free_local, self._b)
        out[self.free] = self._solver.solve(self._b - self._coupling @ out[self.boundary])
