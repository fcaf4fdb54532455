"""Polish on release: full-resolution ARAP on the shape, warm-started from the hybrid pose.

The cage gives speed while dragging; when the user lets go, a bounded number of
ARAP iterations on the shape itself (the paper's "continuum" end) removes what
the cage could not express. Only the shape vertices of the edited region move;
the handle's and the fixed part's vertices stay where the hybrid pose put them.
Each local/global iteration can only lower the ARAP energy, so polishing never
makes the pose worse by that measure.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

import numpy as np
import scipy.sparse as sp

from .arap import ARAPSolver
from .binding import dominant_cage_vertex
from .mesh import Mesh


@dataclass
class PolishResult:
    """What :func:`polish` did.

    Attributes
    ----------
    vertices : (n, 3) float64, the polished shape
    iterations : local/global iterations run
    energy_before, energy_after : full-mesh ARAP energy of the input and output
    seconds : wall time
    stopped : "converged", "time", "iterations" or "cancelled"
    """

    vertices: np.ndarray
    iterations: int
    energy_before: float
    energy_after: float
    seconds: float
    stopped: str


class ShapeARAP:
    """Full-resolution ARAP of a shape, set up once per shape (cotangent weights)."""

    def __init__(self, mesh: Mesh, weights: str = "cotangent") -> None:
        self.mesh = mesh
        self.solver = ARAPSolver(mesh.vertices, mesh.faces, weights=weights)
        self._free_key: bytes | None = None

    def prepare(self, free: np.ndarray) -> None:
        """Factor for this set of free shape vertices ((n,) bool mask); cached."""
        key = np.packbits(free).tobytes()
        if key != self._free_key:
            self.solver.set_constrained(np.flatnonzero(~free), moving=np.zeros(0, dtype=np.int64))
            self._free_key = key


def free_shape_vertices(M: sp.csr_matrix, free_cage: np.ndarray, n_cage: int) -> np.ndarray:
    """Shape vertices of the edited region: those whose dominant cage vertex (largest
    |M_ij| in their row) is free, i.e. neither fixed nor in the handle.

    Parameters
    ----------
    M : (n, c) CSR binding; free_cage : (k,) int cage vertices that ARAP moves;
    n_cage : c.

    Returns
    -------
    (n,) bool mask.
    """
    is_free = np.zeros(n_cage, dtype=bool)
    is_free[free_cage] = True
    return is_free[dominant_cage_vertex(M)]


def polish(
    shape_arap: ShapeARAP,
    vertices: np.ndarray,
    free: np.ndarray,
    seconds: float = 1.0,
    max_iterations: int = 200,
    tolerance: float = 1e-6,
    should_stop: Callable[[], bool] | None = None,
) -> PolishResult:
    """Run full-mesh ARAP iterations on the free vertices, starting from ``vertices``.

    Parameters
    ----------
    shape_arap : the shape's :class:`ShapeARAP`.
    vertices : (n, 3) float64, the hybrid pose to start from (not modified).
    free : (n,) bool, the shape vertices allowed to move (others are held).
    seconds : time budget (checked after each iteration).
    max_iterations : iteration cap.
    tolerance : stop when an iteration moves no vertex by more than this
        fraction of the bounding-box diagonal.
    should_stop : optional callable polled after each iteration; True cancels
        (the result so far is returned, with stopped="cancelled").
    """
    t0 = time.perf_counter()
    V = np.asarray(vertices, dtype=np.float64)
    free = np.asarray(free, dtype=bool)
    s = shape_arap.solver
    if V.shape != s.rest.shape or free.shape != (len(V),):
        raise ValueError(f"vertices must be {s.rest.shape} and free ({len(V)},)")
    e0 = s.energy(V)
    if not np.any(free):
        return PolishResult(V.copy(), 0, e0, e0, time.perf_counter() - t0, "converged")
    shape_arap.prepare(free)
    s.positions[:] = V
    held = V[s.constrained]
    step_tol = tolerance * shape_arap.mesh.bbox_diagonal()
    stopped = "iterations"
    it = 0
    while it < max_iterations:
        before = s.positions[s.free].copy()
        s.solve(held, iterations=1)
        it += 1
        if np.abs(s.positions[s.free] - before).max() <= step_tol:
            stopped = "converged"
            break
        if should_stop is not None and should_stop():
            stopped = "cancelled"
            break
        if time.perf_counter() - t0 >= seconds:
            stopped = "time"
            break
    out = s.positions.copy()
    return PolishResult(out, it, e0, s.energy(out), time.perf_counter() - t0, stopped)
