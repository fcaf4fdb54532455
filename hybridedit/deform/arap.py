"""As-rigid-as-possible deformation (Sorkine & Alexa 2007) of a small mesh: the cage."""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp
from numba import njit, prange

from ..core.linsolve import SPDSolver
from ..core.parallel import pick
from ..core.edge_weights import WEIGHTS, edge_weights  # noqa: F401  (in core: the rig's cage weights need them)
from ..core.graph_laplacian import laplacian  # noqa: F401  (a Laplacian of these edges and weights)
from ..core.twins import twins
from ..core.rotations import LANES, rotations_in_place
from ..core.row_copy import put_rows, take_rows
from ..core.index_sets import union_in_range, unique_in_range, unique_sorted


@njit(cache=True, inline="always")
def _covariance_of(i, rest, cur, indptr, indices, wts, r):
    """r (3, 3) = sum_j w_ij (p'_i - p'_j)(p_i - p_j)^T, whose closest rotation is R_i."""
    a00 = a01 = a02 = a10 = a11 = a12 = a20 = a21 = a22 = 0.0
    for k in range(indptr[i], indptr[i + 1]):
        j = indices[k]
        w = wts[k]
        e0 = rest[i, 0] - rest[j, 0]
        e1 = rest[i, 1] - rest[j, 1]
        e2 = rest[i, 2] - rest[j, 2]
        d0 = w * (cur[i, 0] - cur[j, 0])
        d1 = w * (cur[i, 1] - cur[j, 1])
        d2 = w * (cur[i, 2] - cur[j, 2])
        a00 += d0 * e0
        a01 += d0 * e1
        a02 += d0 * e2
        a10 += d1 * e0
        a11 += d1 * e1
        a12 += d1 * e2
        a20 += d2 * e0
        a21 += d2 * e1
        a22 += d2 * e2
    r[0, 0] = a00
    r[0, 1] = a01
    r[0, 2] = a02
    r[1, 0] = a10
    r[1, 1] = a11
    r[1, 2] = a12
    r[2, 0] = a20
    r[2, 1] = a21
    r[2, 2] = a22


@njit(cache=True, inline="always")
def _rotations_of_block(b, rest, cur, indptr, indices, wts, rots, rows, x, done, elsewhere):
    """R_i of the vertices i = rows[b * LANES: (b + 1) * LANES] into ``rots``: each covariance
    (:func:`_covariance_of`) turned into its closest rotation, in lanes
    (:func:`~hybridedit.core.rotations.rotations_in_place`)."""
    r0 = b * LANES
    nl = min(LANES, rows.shape[0] - r0)
    for l in range(nl):
        _covariance_of(rows[r0 + l], rest, cur, indptr, indices, wts, rots[rows[r0 + l]])
    rotations_in_place(rots, rows, r0, nl, x, done, elsewhere)


@twins()
def _local_step_twins(rest, cur, indptr, indices, wts, rots, rows):
    # (each block makes its own work arrays, so that threads share none: on one thread that costs ~1%)
    for b in prange((rows.shape[0] + LANES - 1) // LANES):
        _rotations_of_block(b, rest, cur, indptr, indices, wts, rots, rows, np.empty((9, LANES)), np.empty(LANES),
                            np.empty(LANES))


def _local_step(rest, cur, indptr, indices, wts, rots, rows):
    """Rotations R_i of the vertices ``rows`` (the ARAP local step), into ``rots`` (n, 3, 3)."""
    pick("rotations", *_local_step_twins, rows.shape[0])(rest, cur, indptr, indices, wts, rots, rows)


@njit(cache=True, inline="always")
def _rhs_of(r, rest, indptr, indices, wts, rots, rows, out):
    """b_i = sum_j w_ij/2 (R_i + R_j)(p_i - p_j) for i = rows[r]."""
    i = rows[r]
    b0 = 0.0
    b1 = 0.0
    b2 = 0.0
    for k in range(indptr[i], indptr[i + 1]):
        j = indices[k]
        h = 0.5 * wts[k]
        e0 = rest[i, 0] - rest[j, 0]
        e1 = rest[i, 1] - rest[j, 1]
        e2 = rest[i, 2] - rest[j, 2]
        b0 += h * ((rots[i, 0, 0] + rots[j, 0, 0]) * e0 + (rots[i, 0, 1] + rots[j, 0, 1]) * e1
                   + (rots[i, 0, 2] + rots[j, 0, 2]) * e2)
        b1 += h * ((rots[i, 1, 0] + rots[j, 1, 0]) * e0 + (rots[i, 1, 1] + rots[j, 1, 1]) * e1
                   + (rots[i, 1, 2] + rots[j, 1, 2]) * e2)
        b2 += h * ((rots[i, 2, 0] + rots[j, 2, 0]) * e0 + (rots[i, 2, 1] + rots[j, 2, 1]) * e1
                   + (rots[i, 2, 2] + rots[j, 2, 2]) * e2)
    out[r, 0] = b0
    out[r, 1] = b1
    out[r, 2] = b2


@twins()
def _rhs_twins(rest, indptr, indices, wts, rots, rows, out):
    for r in prange(rows.shape[0]):
        _rhs_of(r, rest, indptr, indices, wts, rots, rows, out)


def _rhs(rest, indptr, indices, wts, rots, rows, out):
    """The global step's right-hand side for the vertices ``rows``, into ``out``."""
    pick("rotations", *_rhs_twins, rows.shape[0])(rest, indptr, indices, wts, rots, rows, out)


@njit(cache=True, parallel=True)
def _energy_terms(rest, cur, indptr, indices, wts, rots, out):
    for i in prange(rest.shape[0]):
        s = 0.0
        for k in range(indptr[i], indptr[i + 1]):
            j = indices[k]
            for c in range(3):
                re = (rots[i, c, 0] * (rest[i, 0] - rest[j, 0])
                      + rots[i, c, 1] * (rest[i, 1] - rest[j, 1])
                      + rots[i, c, 2] * (rest[i, 2] - rest[j, 2]))
                d = (cur[i, c] - cur[j, c]) - re
                s += wts[k] * d * d
        out[i] = s


class ARAPSolver:
    """ARAP on a triangle mesh with some vertices constrained.

    Parameters
    ----------
    vertices : (n, 3) float64 array
        Rest positions.
    faces : (m, 3) int64 array
    weights : "uniform" or "cotangent"
    backend : linear solver backend, see :class:`~hybridedit.core.linsolve.SPDSolver`.
    links : (k, 2) int array, optional
        Extra edges tying separate parts together (:func:`hybridedit.cage.links.cage_links`).
    edge_data : ((e, 2) int64, (e,) float64), optional
        The mesh's edges and weights as :func:`edge_weights` gives them for ``weights``, when the
        caller has them already (a rig keeps its cage's).

    Notes
    -----
    Use :meth:`set_constrained` once per selection (it factors the Laplacian of
    the free vertices), then :meth:`solve` as often as wanted: each call runs
    local/global iterations warm-started from the current positions.

    The energy measures each edge against the :attr:`reference` pose, the rest pose
    until :meth:`set_reference` makes another (a posed cage, so that the next edit
    starts where the last one ended); the edge weights and the factorization always
    come from the rest pose, so a new reference costs nothing.
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, weights: str = "uniform", backend: str = "auto",
                 *, links: np.ndarray | None = None,
                 edge_data: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        self.rest = np.ascontiguousarray(vertices, dtype=np.float64)
        self.faces = np.asarray(faces, dtype=np.int64)
        self.weights = weights
        self.backend = backend
        n = len(self.rest)
        # (edge_data: what edge_weights(vertices, faces, weights) gives, made already by the caller)
        self.edges, self.w = edge_data if edge_data is not None else edge_weights(self.rest, self.faces, weights)
        if links is not None and len(links):
            lk = np.sort(np.asarray(links, dtype=np.int64).reshape(-1, 2), axis=1)
            if lk.min() < 0 or lk.max() >= n or np.any(lk[:, 0] == lk[:, 1]):
                raise ValueError(f"links must be pairs of distinct vertex indices in [0, {n})")
            code = unique_sorted(lk[:, 0] * n + lk[:, 1])
            have = self.edges[:, 0] * n + self.edges[:, 1]
            code = code[~np.isin(code, have)]
            if code.size:
                # a link is as stiff as a typical edge of the mesh it joins
                lw = np.full(code.size, float(np.median(self.w)))
                self.edges = np.concatenate([self.edges, np.stack([code // n, code % n], axis=1)])
                self.w = np.concatenate([self.w, lw])
        self.L = laplacian(n, self.edges, self.w)
        W = (sp.diags(self.L.diagonal()) - self.L).tocsr()
        W.sort_indices()
        self._indptr = W.indptr.astype(np.int64)
        self._indices = W.indices.astype(np.int64)
        self._wts = W.data.astype(np.float64)
        #: the pose the energy's edge vectors are measured in (see :meth:`set_reference`)
        self.reference = self.rest.copy()
        self.positions = self.rest.copy()
        self.rotations = np.tile(np.eye(3), (n, 1, 1))
        # a solve's rotations are written here and swapped in when it succeeds (a failed solve leaves
        # ``rotations`` as they were, with no copy of them made every frame); outside ``active`` the
        # two arrays agree
        self._spare = self.rotations.copy()
        self.constrained = np.zeros(0, dtype=np.int64)
        self.free = np.arange(n, dtype=np.int64)
        self._all = np.arange(n, dtype=np.int64)
        self.active = self._all
        self._solver: SPDSolver | None = None
        #: seconds spent in the last :meth:`solve` by the local step (rotations) and the
        #: global step (right-hand side and solve)
        self.last_timings = {"local_seconds": 0.0, "global_seconds": 0.0}
        self._L_fc: sp.csr_matrix | None = None
        self._L_ff: sp.csr_matrix | None = None
        self._touching = np.zeros(0, dtype=np.int64)  # constrained vertices with a free neighbour
        self.held = np.zeros(0, dtype=np.int64)
        self._given = self.constrained

    @property
    def n_vertices(self) -> int:
        return int(len(self.rest))

    def set_constrained(self, constrained: np.ndarray, moving: np.ndarray | None = None) -> None:
        """Fix the set of constrained vertices and factor the free Laplacian.

        Parameters
        ----------
        constrained : (k,) int array of vertex indices (handle and fixed).
        moving : (h,) int array, the constrained vertices that later :meth:`solve`
            calls may move (the handle); default: all of them. The others must
            stay where they are now (checked to be constrained).

        Notes
        -----
        Each :meth:`solve` iteration updates only the rotations the global step reads:
        those of the free vertices and of the constrained vertices next to a free one
        (:attr:`active`), so a frame costs in proportion to the free region, whatever
        the size of the handle. The rotation of a constrained vertex inside a handle
        (all of its neighbours constrained) is left as this call computed it;
        :meth:`local_step` brings every rotation up to date.

        A connected part of the mesh (edges and links) with no constrained vertex
        would have an undetermined position: its vertices are held where they are
        (listed in :attr:`held`, constrained like fixed vertices).
        """
        n = self.n_vertices
        c = np.asarray(constrained, dtype=np.int64).ravel()
        if c.size and (c.min() < 0 or c.max() >= n):
            raise ValueError(f"constrained vertex index out of range [0, {n})")
        c = unique_in_range(c, n)
        mask = np.zeros(n, dtype=bool)
        mask[c] = True
        ncomp, labels = sp.csgraph.connected_components(self.L, directed=False)
        has = np.zeros(ncomp, dtype=bool)
        has[labels[mask]] = True
        #: vertices of parts with no constrained vertex, held where they are
        self.held = np.flatnonzero(~has[labels]).astype(np.int64)
        self._given = c
        if self.held.size:
            mask[self.held] = True
            c = np.flatnonzero(mask).astype(np.int64)
        free = np.flatnonzero(~mask)
        if moving is not None:
            mov = np.asarray(moving, dtype=np.int64).ravel()
            if mov.size and (mov.min() < 0 or mov.max() >= n or not np.all(mask[mov])):
                raise ValueError("moving vertices must be constrained")
        self.constrained = c
        self.free = free
        self._all = np.arange(n, dtype=np.int64)
        self.local_step()  # rotations a solve does not update stay these
        L = self.L
        self._solver = SPDSolver(L[free][:, free], backend=self.backend)
        self._L_ff = None  # (made by the first :meth:`iteration_parts`)
        # the free rows' couplings to constrained vertices: only those next to a free vertex have
        # any, and a frame gathers only those (not every held vertex of a big cage)
        L_fc = L[free][:, c].tocsr()
        cols = unique_in_range(L_fc.indices, len(c))
        self._L_fc = L_fc[:, cols].tocsr()
        self._touching = c[cols]
        # the rotations the global step reads (b_i sums R_i + R_j over a free i's edges): not a
        # handle's inside, whose rotations nothing reads (its positions are given)
        self.active = union_in_range(free, self._touching, n)

    def solve(self, constrained_positions: np.ndarray, iterations: int = 2, *,
              slots: np.ndarray | None = None) -> np.ndarray:
        """Move the constrained vertices and run local/global iterations.

        Parameters
        ----------
        constrained_positions : (k, 3) float64 array, in the order of the constrained
            vertices as given (sorted unique) to :meth:`set_constrained`; held
            vertices stay where they are.
        iterations : number of local/global iterations (>= 0).
        slots : (s,) int array, optional
            Positions within that order of the vertices ``constrained_positions`` (then
            (s, 3)) moves; the other constrained vertices stay where they are. A frame
            that moves a handle gives only the handle's (a big cage's fixed vertices are
            most of it).

        Returns
        -------
        (n, 3) float64 array, the current positions (also kept in ``positions``).
        """
        cp, moved = self._checked_constrained(constrained_positions, slots)
        t0 = time.perf_counter()
        free = self.free
        before = (take_rows(self.positions, moved), take_rows(self.positions, free))
        put_rows(cp, moved, self.positions)
        rhs_c = self._L_fc @ take_rows(self.positions, self._touching)
        b = np.empty((len(self.free), 3))
        rots = self._spare  # the iterations' rotations (its entries outside ``active`` are ours)
        t_local = 0.0
        for _ in range(int(iterations)):
            t1 = time.perf_counter()
            _local_step(self.reference, self.positions, self._indptr, self._indices, self._wts, rots, self.active)
            t_local += time.perf_counter() - t1
            _rhs(self.reference, self._indptr, self._indices, self._wts, rots, self.free, b)
            x = self._solver.solve(b - rhs_c)
            if not np.all(np.isfinite(x)):
                put_rows(before[0], moved, self.positions)
                put_rows(before[1], free, self.positions)
                raise FloatingPointError("the solve gave non-finite positions; nothing changed")
            put_rows(x, free, self.positions)
        if iterations > 0:  # the new rotations become ours; the old array is the next solve's to write
            self.rotations, self._spare = rots, self.rotations
        total = time.perf_counter() - t0
        self.last_timings = {"local_seconds": t_local, "global_seconds": total - t_local}
        return self.positions

    def iteration_parts(self, constrained_positions: np.ndarray, *, slots: np.ndarray | None = None) -> dict:
        """Move the constrained vertices (as :meth:`solve` does) and give what an iteration there
        reads, as the keyword arguments of a
        :class:`~hybridedit.deform.local_global.LocalGlobalMap` (made by
        :func:`~hybridedit.deform.local_global.local_global_map`, to iterate to convergence;
        :meth:`adopt` takes its result back). The arguments are :meth:`solve`'s.

        Raises
        ------
        ValueError, FloatingPointError
            As :meth:`solve` (nothing changed).
        """
        cp, moved = self._checked_constrained(constrained_positions, slots)
        put_rows(cp, moved, self.positions)
        rhs_c = np.ascontiguousarray(self._L_fc @ take_rows(self.positions, self._touching))
        if self._L_ff is None:  # (the metric of a converge's error estimate)
            self._L_ff = self.L[self.free][:, self.free].tocsr()
        return {"reference": self.reference, "positions": self.positions, "indptr": self._indptr,
                "indices": self._indices, "weights": self._wts, "free": self.free, "active": self.active,
                "solve": self._solver.solve, "rhs_fixed": rhs_c, "laplacian_free": self._L_ff}

    def adopt(self, free_positions: np.ndarray, active_rotations: np.ndarray) -> None:
        """Take an iteration's result: the (f, 3) positions of the free vertices and the (a, 3, 3)
        rotations of the :attr:`active` ones its global step used (as :meth:`solve` leaves them)."""
        put_rows(np.asarray(free_positions, dtype=np.float64), self.free, self.positions)
        self.rotations[self.active] = active_rotations

    def _checked_constrained(self, constrained_positions: np.ndarray, slots: np.ndarray | None
                             ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`solve`'s constrained positions as (k, 3) float64, checked, and the vertices they move."""
        if self._solver is None:
            raise RuntimeError("call set_constrained first")
        cp = np.asarray(constrained_positions, dtype=np.float64).reshape(-1, 3)
        moved = self._moved_by(slots)
        if len(cp) != len(moved):
            raise ValueError(f"expected {len(moved)} constrained positions, got {len(cp)}")
        if not np.all(np.isfinite(cp)):
            raise FloatingPointError("non-finite constrained positions; nothing changed")
        return cp, moved

    def _moved_by(self, slots: np.ndarray | None) -> np.ndarray:
        """The constrained vertices a :meth:`solve` given ``slots`` writes."""
        if slots is None:
            return self._given
        sl = np.asarray(slots, dtype=np.int64).ravel()
        if sl.size and (sl.min() < 0 or sl.max() >= len(self._given)):
            raise ValueError(f"slots must lie in [0, {len(self._given)})")
        return self._given[sl]

    def local_step(self) -> np.ndarray:
        """Update and return the rotations of all vertices, (n, 3, 3) float64."""
        _local_step(self.reference, self.positions, self._indptr, self._indices, self._wts, self.rotations,
                    self._all)
        self._spare[:] = self.rotations
        return self.rotations

    def energy(self, positions: np.ndarray | None = None) -> float:
        """ARAP energy of ``positions`` (default: current) with optimal rotations."""
        p = self.positions if positions is None else np.ascontiguousarray(positions, dtype=np.float64)
        rots = np.empty((self.n_vertices, 3, 3))
        _local_step(self.reference, p, self._indptr, self._indices, self._wts, rots, self._all)
        out = np.empty(self.n_vertices)
        _energy_terms(self.reference, p, self._indptr, self._indices, self._wts, rots, out)
        return float(out.sum())

    def set_rotations(self, rotations: np.ndarray) -> None:
        """Put the rotations back to ``rotations`` (n, 3, 3) (an undo's snapshot of :attr:`rotations`)."""
        self.rotations[:] = rotations
        self._spare[:] = rotations

    def set_reference(self, positions: np.ndarray) -> None:
        """Measure the energy against ``positions`` (c, 3) from now on, and start there:
        the positions become these and every rotation the identity. The weights and
        the factorization (from the rest pose) are kept."""
        p = np.asarray(positions, dtype=np.float64)
        if p.shape != self.rest.shape or not np.all(np.isfinite(p)):
            raise ValueError(f"a reference pose must be finite and {self.rest.shape}")
        self.reference = np.ascontiguousarray(p).copy()
        self.positions[:] = p
        self.rotations[:] = np.eye(3)
        self._spare[:] = np.eye(3)

    def reset(self) -> None:
        """Back to the rest pose (also as the reference)."""
        self.reference = self.rest.copy()
        self.positions[:] = self.rest
        self.rotations[:] = np.eye(3)
        self._spare[:] = np.eye(3)
