"""ARAP's local/global step as a map of the free vertices alone, for iterating to convergence.

One local/global iteration of an :class:`~hybridedit.deform.arap.ARAPSolver` is a map
``x -> G(x)`` of its free vertices' positions (the constrained ones held): the local
step takes the rotations of ``x``, the global step solves the free positions those
rotations ask for. :class:`LocalGlobalMap` evaluates it on the part of the cage the
iteration reads: the free vertices, the constrained ones next to them (whose rotations
the global step reads) and their neighbours. A selection's region is a small part of
a big cage (the 692K armadillo's canonical edit: 6.4K of 34.6K cage vertices), so an
iteration costs in proportion to the region; its rotations and positions are bitwise
those of :meth:`~hybridedit.deform.arap.ARAPSolver.solve` (the same kernels, each row's
neighbours in the same order).

The local step also gives the ARAP energy of ``x`` for free: with the rotations of
``x`` optimal, the energy is the sum of each active vertex's edge terms
(:meth:`LocalGlobalMap.rotate`). Rows outside the active set add a constant (their
positions and rotations never change here), left out.

Since ``G(x) = x - L_ff^{-1} grad E(x) / 2`` (the global step is a gradient step
preconditioned by the free Laplacian, the rotations being optimal), a fixed point of
``G`` is a stationary point of the energy, and one iteration never raises it.
"""

from __future__ import annotations

from typing import Callable

import numba
import numpy as np

from ..core.index_sets import union_in_range
from ..core.parallel import pick
from ..core.row_copy import put_rows, take_rows
from .arap import _energy_terms, _local_step, _rhs

__all__ = ["LocalGlobalMap", "local_global_map"]


def local_global_map(arap, constrained_positions: np.ndarray, *, slots: np.ndarray | None = None) -> "LocalGlobalMap":
    """The local/global map of ``arap``'s (an :class:`~hybridedit.deform.arap.ARAPSolver`) free
    vertices with its constrained ones moved to ``constrained_positions`` (at ``slots``), as
    :meth:`~hybridedit.deform.arap.ARAPSolver.solve` takes them; its
    :meth:`~hybridedit.deform.arap.ARAPSolver.adopt` takes the result back.

    Examples
    --------
    >>> gmap = local_global_map(arap, targets, slots=slots)  # doctest: +SKIP
    >>> x = gmap.start(); gmap.rotate(x); arap.adopt(gmap.step(), gmap.rotations())  # doctest: +SKIP
    """
    return LocalGlobalMap(**arap.iteration_parts(constrained_positions, slots=slots))


class LocalGlobalMap:
    """The local/global map of a solver's free vertices, on the part of the cage it reads.

    Parameters
    ----------
    reference : (c, 3) float64
        The pose the energy's edge vectors are measured in.
    positions : (c, 3) float64
        The current positions (read here once: the constrained ones stay these).
    indptr, indices, weights : the cage's edge weights as CSR rows (c + 1,), (e,), (e,),
        each row's neighbours sorted.
    free : (f,) int64, the free vertices.
    active : (a,) int64, the vertices whose rotations the global step reads (free ones
        and constrained ones with a free neighbour), sorted.
    solve : callable((f, 3) float64) -> (f, 3) float64
        The free Laplacian's solve.
    rhs_fixed : (f, 3) float64
        What the constrained vertices add to the global step's right-hand side
        (``L_fc @ positions[constrained]``), subtracted from it.
    laplacian_free : (f, f) sparse, the free Laplacian L_ff (the metric :meth:`metric` applies).
    """

    def __init__(self, *, reference: np.ndarray, positions: np.ndarray, indptr: np.ndarray, indices: np.ndarray,
                 weights: np.ndarray, free: np.ndarray, active: np.ndarray,
                 solve: Callable[[np.ndarray], np.ndarray], rhs_fixed: np.ndarray, laplacian_free) -> None:
        c = len(reference)
        rows = np.repeat(np.arange(c, dtype=np.int64), np.diff(indptr))
        in_active = np.zeros(c, dtype=bool)
        in_active[active] = True
        kept = in_active[rows]  # the active rows' entries, in their order
        touched = union_in_range(active, indices[kept], c)  # the active vertices and their neighbours
        local = np.full(c, -1, dtype=np.int64)
        local[touched] = np.arange(touched.size)
        counts = np.zeros(touched.size, dtype=np.int64)
        counts[local[active]] = np.diff(indptr)[active]
        #: (u,) int64 the cage vertices the map works on (rows of the compact problem)
        self.vertices = touched
        self._indptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        self._indices = local[indices[kept]]
        self._wts = np.ascontiguousarray(weights[kept], dtype=np.float64)
        self._reference = take_rows(reference, touched)
        self._positions = take_rows(positions, touched)
        self._free = local[free]
        self._active = local[active]
        self._rotations = np.tile(np.eye(3), (touched.size, 1, 1))
        self._terms = np.zeros(touched.size)
        self._rhs = np.empty((free.size, 3))
        self._solve = solve
        self._rhs_fixed = rhs_fixed
        self._L_ff = laplacian_free
        #: (f,) int64 and (a,) int64: the free and active cage vertices
        self.free = free
        self.active = active

    @property
    def n_free(self) -> int:
        return int(self.free.size)

    def start(self) -> np.ndarray:
        """(f, 3) float64 the free vertices' positions it was made at (a copy)."""
        return take_rows(self._positions, self._free)

    def rotate(self, x: np.ndarray) -> float:
        """The local step at ``x`` (f, 3): the rotations of ``x``, kept for :meth:`step`; returns
        the ARAP energy of ``x`` (up to a constant: the rows outside the active set)."""
        put_rows(x, self._free, self._positions)
        _local_step(self._reference, self._positions, self._indptr, self._indices, self._wts, self._rotations,
                    self._active)
        # (a parallel-only kernel: its threads as the local step would have them, since a parallel
        # pass beside a busy core waits for its slowest thread; each row's term is the same either way)
        threads = numba.get_num_threads()
        numba.set_num_threads(pick("rotations", 1, threads, self._active.size))
        try:
            _energy_terms(self._reference, self._positions, self._indptr, self._indices, self._wts, self._rotations,
                          self._terms)
        finally:
            numba.set_num_threads(threads)
        return float(self._terms.sum())

    def step(self) -> np.ndarray:
        """The global step from the rotations of the last :meth:`rotate`: G(x), (f, 3) float64 (new).

        Raises
        ------
        FloatingPointError
            The solve gave non-finite positions.
        """
        _rhs(self._reference, self._indptr, self._indices, self._wts, self._rotations, self._free, self._rhs)
        np.subtract(self._rhs, self._rhs_fixed, out=self._rhs)
        g = np.ascontiguousarray(self._solve(self._rhs))
        if not np.all(np.isfinite(g)):
            raise FloatingPointError("the solve gave non-finite positions")
        return g

    def metric(self, v: np.ndarray) -> np.ndarray:
        """L_ff v for (f, k) ``v``, (f, k) float64: the inner product in which the map's Jacobian is
        symmetric (``I - J = L_ff^{-1} H / 2``, H the energy's Hessian)."""
        return self._L_ff @ v

    def rotations(self) -> np.ndarray:
        """(a, 3, 3) float64 the rotations of the last :meth:`rotate`, of the active vertices (a copy)."""
        return self._rotations[self._active]
