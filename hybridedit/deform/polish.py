"""Polish: full-resolution ARAP on the shape, warm-started from the hybrid pose.

The cage gives speed while dragging; when the user lets go, ARAP iterations on
the shape itself (the paper's "continuum" end) remove what the cage could not
express. Only the shape vertices of the edited region move; the handle's and the
fixed part's vertices stay where the hybrid pose put them. Each local/global
iteration can only lower the ARAP energy, so polishing never makes the pose worse
by that measure.

A polish stops by a rule that gives the same pose on any machine: when an
iteration moves no vertex by more than ``tolerance`` of the bounding-box diagonal,
or after ``max_iterations``; never by the clock. The number of iterations it ran
is what an edit file records (``"polish": k``), and a replay runs exactly those.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from .arap import ARAPSolver
from ..defaults import POLISH_MAX_ITERATIONS as MAX_ITERATIONS
from ..defaults import POLISH_TOLERANCE as TOLERANCE
from ..core.index_sets import unique_in_range
from ..core.mesh import Mesh
from ..core.topology import connected_parts


@dataclass
class PolishResult:
    """What :func:`polish` did.

    Attributes
    ----------
    vertices : (n, 3) float64, the polished shape
    iterations : local/global iterations run
    energy_before, energy_after : ARAP energy of the edited region's faces (those
        touching a free vertex) in the input and the output (0 when nothing was polished)
    seconds : wall time (reported only: it never decides anything)
    stopped : "converged", "iterations" (``max_iterations`` ran) or "cancelled"
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

    def prepared_for(self, free: np.ndarray) -> bool:
        """Whether :meth:`prepare` has already set up for this set of free vertices."""
        return np.packbits(free).tobytes() == self._free_key

    def prepare(self, free: np.ndarray) -> None:
        """Set up and factor for this set of free shape vertices ((n,) bool mask); cached."""
        key = np.packbits(free).tobytes()
        if key == self._free_key:
            return
        t0 = time.perf_counter()
        region, sub, held = self._region(free)
        solver = ARAPSolver(self.mesh.vertices[region], sub, weights=self.weights)
        solver.set_constrained(np.flatnonzero(held), moving=np.zeros(0, dtype=np.int64))
        self.solver, self.region, self._free_key = solver, region, key
        self.setup_seconds = time.perf_counter() - t0

    def _region(self, free: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The region's shape vertices (k,), its faces on them (m, 3) and which of them are held (k,)."""
        f = self.mesh.faces
        sub = f[free[f].any(axis=1)]
        region = unique_in_range(sub, self.mesh.n_vertices)
        local = np.full(self.mesh.n_vertices, -1, dtype=np.int64)
        local[region] = np.arange(len(region))
        sub = local[sub]
        held = ~free[region]
        count, labels = connected_parts(sub, len(region))
        pinned = np.zeros(count, dtype=bool)
        pinned[labels[held]] = True
        if not np.all(pinned):  # drop the pieces nothing holds
            sub = sub[pinned[labels[sub[:, 0]]]]
            keep = unique_in_range(sub, len(region))
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
    *,
    max_iterations: int = MAX_ITERATIONS,
    tolerance: float = TOLERANCE,
    should_stop: Callable[[], bool] | None = None,
) -> PolishResult:
    """Run full-resolution ARAP iterations on the free vertices, starting from ``vertices``.

    Parameters
    ----------
    shape_arap : the shape's :class:`ShapeARAP`.
    vertices : (n, 3) float64, the hybrid pose to start from (not modified).
    free : (n,) bool, the shape vertices allowed to move; all others (the handle
        and the fixed part) keep their positions in ``vertices`` exactly.
    max_iterations : iteration cap (a replay gives the count it recorded here, with
        ``tolerance=0``).
    tolerance : stop when an iteration moves no vertex by more than this fraction
        of the bounding-box diagonal (0: run ``max_iterations``).
    should_stop : optional callable polled after each iteration; True cancels
        (the result so far is returned, with stopped="cancelled").

    Returns
    -------
    PolishResult
        ``energy_before`` and ``energy_after`` are the ARAP energies of the
        region's faces (those touching a free vertex).

    Examples
    --------
    >>> r = polish(ShapeARAP(mesh), posed, editor.free_mask)  # doctest: +SKIP
    >>> r.iterations, r.stopped  # doctest: +SKIP
    (37, 'converged')
    """
    t0 = time.perf_counter()
    V = np.asarray(vertices, dtype=np.float64)
    free = np.asarray(free, dtype=bool)
    n = shape_arap.mesh.n_vertices
    if V.shape != (n, 3) or free.shape != (n,):
        raise ValueError(f"vertices must be {(n, 3)} and free ({n},)")
    if int(max_iterations) < 0 or not tolerance >= 0:
        raise ValueError(f"max_iterations must be >= 0 and tolerance >= 0, got {max_iterations!r}, {tolerance!r}")
    if not np.any(free) or int(max_iterations) == 0:
        return PolishResult(V.copy(), 0, 0.0, 0.0, time.perf_counter() - t0, "converged")
    shape_arap.prepare(free)
    s = shape_arap.solver
    region = shape_arap.region
    s.positions[:] = V[region]
    e0 = s.energy()
    held = s.positions[s.constrained].copy()
    step_tol = float(tolerance) * shape_arap.mesh.bbox_diagonal()
    stopped = "iterations"
    it = 0
    while it < int(max_iterations):
        before = s.positions[s.free].copy()
        s.solve(held, iterations=1)
        it += 1
        if s.free.size == 0 or np.abs(s.positions[s.free] - before).max() <= step_tol:
            stopped = "converged"
            break
        if should_stop is not None and should_stop():
            stopped = "cancelled"
            break
    out = V.copy()
    out[region] = s.positions
    return PolishResult(out, it, e0, s.energy(), time.perf_counter() - t0, stopped)


@dataclass(frozen=True)
class PolishJob:
    """A polish of an editor's pose, to run anywhere (a worker thread) and give back to the
    editor (:meth:`hybridedit.HybridEditor.adopt_polish`), which takes it only while its pose
    is still ``start``.

    Attributes
    ----------
    start : (n, 3) float64, the pose polished (a copy).
    free : (n,) bool, the vertices it may move (the selection's free rows).
    max_iterations, tolerance : the stopping rule (see :func:`polish`).
    """

    start: np.ndarray
    free: np.ndarray
    max_iterations: int = MAX_ITERATIONS
    tolerance: float = TOLERANCE

    def run(self, shape_arap: ShapeARAP, *, should_stop: Callable[[], bool] | None = None) -> PolishResult:
        """Polish ``start`` with ``shape_arap`` (the shape's, reused across jobs)."""
        return polish(shape_arap, self.start, self.free, max_iterations=self.max_iterations,
                      tolerance=self.tolerance, should_stop=should_stop)
