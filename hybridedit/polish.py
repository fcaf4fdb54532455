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

from .arap import ARAPSolver
from .mesh import Mesh
from .topology import connected_parts

#: expected set-up seconds per vertex of the edited region before a :class:`ShapeARAP`
#: has measured its own (the slowest measured on 2 shared cores of the development machine)
SETUP_SECONDS_PER_VERTEX = 2.5e-5


@dataclass
class PolishResult:
    """What :func:`polish` did.

    Attributes
    ----------
    vertices : (n, 3) float64, the polished shape
    iterations : local/global iterations run
    energy_before, energy_after : ARAP energy of the edited region's faces (those
        touching a free vertex) in the input and the output (0 when nothing was polished)
    seconds : wall time
    stopped : "converged", "time" (the budget ran out, possibly before the set-up),
        "iterations" or "cancelled"
    """

    vertices: np.ndarray
    iterations: int
    energy_before: float
    energy_after: float
    seconds: float
    stopped: str


class ShapeARAP:
    """Full-resolution ARAP of the edited region of a shape (cotangent weights).

    Only the faces that touch a free vertex take part: the set-up (weights,
    Laplacian, factorization) costs in proportion to the edited region, not to the
    shape, and is redone only when the set of free vertices changes. A connected
    piece of the region with no held vertex (a loose part wholly free) is left out:
    nothing would pin it down.

    Parameters
    ----------
    mesh : Mesh
        The shape (n vertices).
    weights : "cotangent" or "uniform"
    """

    #: set-up seconds per region vertex, and factorization seconds per second of
    #: weights, of the last set-up completed in this process (estimates for the next)
    _rate = SETUP_SECONDS_PER_VERTEX
    _factor_ratio = 1.0

    def __init__(self, mesh: Mesh, weights: str = "cotangent") -> None:
        self.mesh = mesh
        self.weights = weights
        self._free_key: bytes | None = None
        #: the region's solver (its vertices are ``region`` of the shape), after :meth:`prepare`
        self.solver: ARAPSolver | None = None
        #: (k,) int64 shape vertices of the region, after :meth:`prepare`
        self.region = np.zeros(0, dtype=np.int64)
        #: seconds the last :meth:`prepare` that did work took
        self.setup_seconds = 0.0
        self._pending: tuple | None = None  # a set-up stopped after its weights, for the same free set

    def prepared_for(self, free: np.ndarray) -> bool:
        """Whether :meth:`prepare` has already set up for this set of free vertices."""
        return np.packbits(free).tobytes() == self._free_key

    def prepare(self, free: np.ndarray, deadline: float | None = None) -> bool:
        """Set up and factor for this set of free shape vertices ((n,) bool mask); cached.

        Parameters
        ----------
        free : (n,) bool
        deadline : float, optional
            A ``time.perf_counter()`` value: between its phases (region, weights,
            factorization) the set-up stops when the next phase is expected to end
            after it. What is done is kept for the next call with the same ``free``.

        Returns
        -------
        bool
            True when set up (False: stopped for the deadline).
        """
        key = np.packbits(free).tobytes()
        if key == self._free_key:
            return True
        t0 = time.perf_counter()
        if self._pending is None or self._pending[0] != key:
            region, sub, held = self._region(free)
            if deadline is not None and time.perf_counter() + len(region) * self._rate > deadline:
                return False
            t1 = time.perf_counter()
            solver = ARAPSolver(self.mesh.vertices[region], sub, weights=self.weights)
            t_weights = time.perf_counter() - t1
            self._pending = (key, solver, region, held, t_weights)
        key, solver, region, held, t_weights = self._pending
        if deadline is not None and time.perf_counter() + t_weights * self._factor_ratio > deadline:
            return False
        t2 = time.perf_counter()
        solver.set_constrained(np.flatnonzero(held), moving=np.zeros(0, dtype=np.int64))
        t_factor = time.perf_counter() - t2
        self.solver, self.region, self._free_key, self._pending = solver, region, key, None
        self.setup_seconds = time.perf_counter() - t0
        # what this machine takes now, for the next set-up's estimates (any shape)
        ShapeARAP._rate = self.setup_seconds / max(len(region), 1)
        ShapeARAP._factor_ratio = t_factor / max(t_weights, 1e-9)
        return True

    def _region(self, free: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The region's shape vertices (k,), its faces on them (m, 3) and which of them are held (k,)."""
        f = self.mesh.faces
        sub = f[free[f].any(axis=1)]
        region = np.unique(sub)
        local = np.full(self.mesh.n_vertices, -1, dtype=np.int64)
        local[region] = np.arange(len(region))
        sub = local[sub]
        held = ~free[region]
        count, labels = connected_parts(sub, len(region))
        pinned = np.zeros(count, dtype=bool)
        pinned[labels[held]] = True
        if not np.all(pinned):  # drop the pieces nothing holds
            sub = sub[pinned[labels[sub[:, 0]]]]
            keep = np.unique(sub)
            region, held = region[keep], held[keep]
            sub = np.searchsorted(keep, sub)
        return region, sub, held

    def energy(self, vertices: np.ndarray) -> float:
        """ARAP energy of the region's faces in the pose ``vertices`` ((n, 3)), after :meth:`prepare`."""
        if self.solver is None:
            raise RuntimeError("call prepare first")
        return self.solver.energy(np.asarray(vertices, dtype=np.float64)[self.region])


def polish(
    shape_arap: ShapeARAP,
    vertices: np.ndarray,
    free: np.ndarray,
    seconds: float = 1.0,
    max_iterations: int = 200,
    tolerance: float = 1e-6,
    should_stop: Callable[[], bool] | None = None,
) -> PolishResult:
    """Run full-resolution ARAP iterations on the free vertices, starting from ``vertices``.

    The budget ``seconds`` covers everything, the set-up for a new set of free
    vertices included: each phase of the set-up is started only when it is
    expected to end in time (:meth:`ShapeARAP.prepare`; otherwise nothing is
    polished and ``stopped`` is "time"), and an iteration only when it is expected to end
    within the budget (each is expected to take as long as the last one; the
    first as long as a tenth of the set-up, its usual share).

    Parameters
    ----------
    shape_arap : the shape's :class:`ShapeARAP`.
    vertices : (n, 3) float64, the hybrid pose to start from (not modified).
    free : (n,) bool, the shape vertices allowed to move; all others (the handle
        and the fixed part) keep their positions in ``vertices`` exactly.
    seconds : time budget, set-up included.
    max_iterations : iteration cap.
    tolerance : stop when an iteration moves no vertex by more than this
        fraction of the bounding-box diagonal.
    should_stop : optional callable polled after each iteration; True cancels
        (the result so far is returned, with stopped="cancelled").

    Returns
    -------
    PolishResult
        ``energy_before`` and ``energy_after`` are the ARAP energies of the
        region's faces (those touching a free vertex).
    """
    t0 = time.perf_counter()
    V = np.asarray(vertices, dtype=np.float64)
    free = np.asarray(free, dtype=bool)
    n = shape_arap.mesh.n_vertices
    if V.shape != (n, 3) or free.shape != (n,):
        raise ValueError(f"vertices must be {(n, 3)} and free ({n},)")
    if not np.any(free):
        return PolishResult(V.copy(), 0, 0.0, 0.0, time.perf_counter() - t0, "converged")
    deadline = t0 + float(seconds)
    if not shape_arap.prepare(free, deadline=deadline):
        # the set-up would not fit in the budget: nothing is polished
        return PolishResult(V.copy(), 0, 0.0, 0.0, time.perf_counter() - t0, "time")
    s = shape_arap.solver
    region = shape_arap.region
    s.positions[:] = V[region]
    e0 = s.energy()
    held = s.positions[s.constrained].copy()
    step_tol = tolerance * shape_arap.mesh.bbox_diagonal()
    expected = 0.1 * (time.perf_counter() - t0)
    stopped = "iterations"
    it = 0
    while it < max_iterations:
        start = time.perf_counter()
        if start + expected > deadline:
            stopped = "time"
            break
        before = s.positions[s.free].copy()
        s.solve(held, iterations=1)
        it += 1
        expected = time.perf_counter() - start
        if s.free.size == 0 or np.abs(s.positions[s.free] - before).max() <= step_tol:
            stopped = "converged"
            break
        if should_stop is not None and should_stop():
            stopped = "cancelled"
            break
    out = V.copy()
    out[region] = s.positions
    return PolishResult(out, it, e0, s.energy(), time.perf_counter() - t0, stopped)
