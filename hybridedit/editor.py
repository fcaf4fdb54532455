"""HybridEditor: cage + binding + cage ARAP + propagation, the engine's front door."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from .arap import ARAPSolver
from .binding import dominant_cage_vertex
from .mesh import Mesh, MeshError
from .propagate import propagate
from .residual import propagate_with_residual, residual_setup
from .rig import Progress, Rig, build_rig
from .transforms import check_transform, rigid_transform

SPACES = ("shape", "cage")
#: frame times kept in ``frame_seconds`` (the older half is dropped past this)
FRAME_HISTORY = 10000
PROPAGATIONS = ("residual", "linear")
#: a drag may move the handle at most this many bounding-box diagonals
MAX_REACH = 1e6



class SelectionError(ValueError):
    """A selection (handle / fixed / ROI) that cannot be used; the message says why."""


class HybridEditor:
    """Interactive hybrid mesh editing of one shape.

    Builds the cage (QEM) and the binding (truncated mean value coordinates) at
    construction; then :meth:`set_selection` and :meth:`drag` deform the cage with
    ARAP and the shape follows as M @ cage.

    The shape is never changed: the cage is built from a repaired private copy
    (:func:`hybridedit.repair.cage_source`; duplicate vertices merged, degenerate
    faces dropped, holes of the cage closed, ...) and :attr:`notes` says in plain
    words what was repaired. Every input vertex is bound, in input order.

    Parameters
    ----------
    mesh : Mesh
        The shape (n vertices).
    cage_size : int or float
        Cage vertex count (int) or fraction of the shape's vertices (float).
    cage : Mesh, optional
        Use this cage instead of simplifying the shape.
    binding : (n, c) scipy sparse matrix, optional
        Use this binding instead of computing it (rows must sum to 1).
    truncation : float
        Fraction of each row's coordinate magnitude dropped (the paper: 0.03).
    weights : "cotangent" (default) or "uniform" (the paper's w_ij = 1)
        ARAP edge weights on the cage; cotangent gives the lower edge error in
        benchmarks/table1.py.
    iterations : int
        ARAP local/global iterations per :meth:`drag` call.
    progress : callable(stage: str, fraction: float), optional
        Called during the slow steps (cage, bind); it may raise to cancel them.
    cache : bool or path
        Reuse the cage and binding from an on-disk cache (True: the user cache
        folder, see :func:`hybridedit.bindcache.default_cache_dir`; a path: that
        folder), keyed by the shape, ``cage_size`` and ``truncation``; store them
        there after computing them. Ignored when ``cage`` or ``binding`` is given.
    propagation : "residual" or "linear"
        "linear" is the paper's x' = M y'. "residual" adds back, rotated with
        the cage, what M loses of the rest shape (:mod:`hybridedit.residual`),
        so that with no edit the output is the input exactly.
    """

    def __init__(
        self,
        mesh: Mesh | Rig,
        cage_size: int | float = 0.05,
        *,
        cage: Mesh | None = None,
        binding: sp.spmatrix | None = None,
        truncation: float = 0.03,
        weights: str = "cotangent",
        iterations: int = 2,
        progress: Progress | None = None,
        cache: bool | str | Path = False,
        propagation: str = "residual",
    ) -> None:
        if isinstance(mesh, Rig):
            rig = mesh
        else:
            rig = build_rig(mesh, cage_size=cage_size, cage=cage, binding=binding, truncation=truncation,
                            cache=cache, progress=progress)
        #: the cage and binding this editor works on (see :func:`hybridedit.build_rig`)
        self.rig = rig
        mesh = rig.mesh
        self.mesh = mesh
        self.truncation = rig.truncation
        self.iterations = int(iterations)
        self.timings: dict[str, float] = dict(rig.timings)
        self.cache_hit = rig.cache_hit
        #: plain-word sentences about what was repaired or adjusted to build the cage
        #: (the shape itself is never changed), e.g. "merged 12 duplicate vertices"
        self.notes: list[str] = list(rig.notes)
        cage = rig.cage
        self.cage = cage
        M = rig.M
        self.M = M
        if propagation not in PROPAGATIONS:
            raise ValueError(f"propagation must be one of {PROPAGATIONS}, got {propagation!r}")
        self.propagation = propagation
        self._residual = residual_setup(M, mesh.vertices, cage.vertices) if propagation == "residual" else None
        self.arap = ARAPSolver(cage.vertices, cage.faces, weights=weights)
        self._scale = max(mesh.bbox_diagonal(), float(np.linalg.norm(np.ptp(cage.vertices, axis=0))))
        self._cage_to_shape = cKDTree(mesh.vertices).query(cage.vertices)[1].astype(np.int64)
        self._out = np.empty((mesh.n_vertices, 3))
        self._rows: np.ndarray | None = None
        self._propagate()
        self.handle = np.zeros(0, dtype=np.int64)
        self.fixed = np.zeros(0, dtype=np.int64)
        self._constrained = np.zeros(0, dtype=np.int64)
        self._anchor = np.zeros((0, 3))
        self._is_handle = np.zeros(0, dtype=bool)
        self.transform = np.eye(4)
        #: wall time of recent :meth:`drag` calls, oldest first (bounded, see FRAME_HISTORY)
        self.frame_seconds: list[float] = []
        #: where the last frame's time went: local_seconds, global_seconds,
        #: propagate_seconds, total_seconds
        self.frame_breakdown: dict[str, float] = {}

    # ------------------------------------------------------------------ selection
    @property
    def nnz_per_row(self) -> float:
        """Mean number of cage vertices each shape vertex depends on."""
        return self.M.nnz / max(self.M.shape[0], 1)

    def to_cage(self, indices: np.ndarray, space: str = "shape", role: str = "selection") -> np.ndarray:
        """Map a vertex selection to cage vertex indices.

        Shape vertices map to the cage vertices whose nearest shape vertex is
        selected; a small selection that contains no such vertex maps to the cage
        vertex with the largest coordinate of each selected shape vertex.

        Parameters
        ----------
        indices : (k,) int array of vertex indices in ``space``.
        space : "shape" or "cage".

        Returns
        -------
        (j,) int64 array of sorted unique cage vertex indices.
        """
        if space not in SPACES:
            raise SelectionError(f"space must be one of {SPACES}, got {space!r}")
        idx = np.asarray(indices)
        if idx.size == 0:
            return np.zeros(0, dtype=np.int64)
        if not np.issubdtype(idx.dtype, np.integer):
            if not np.all(np.isfinite(idx)) or not np.all(np.equal(np.mod(idx, 1), 0)):
                raise SelectionError(f"{role} indices must be integers")
        idx = idx.astype(np.int64).ravel()
        n = self.mesh.n_vertices if space == "shape" else self.cage.n_vertices
        bad = (idx < 0) | (idx >= n)
        if np.any(bad):
            raise SelectionError(
                f"{role} has {int(bad.sum())} {space} vertex indices out of range [0, {n - 1}], "
                f"e.g. {int(idx[bad][0])}"
            )
        if space == "cage":
            return np.unique(idx)
        selected = np.zeros(self.mesh.n_vertices, dtype=bool)
        selected[idx] = True
        cage_idx = np.flatnonzero(selected[self._cage_to_shape])
        if cage_idx.size == 0:
            rows = self.M[np.unique(idx)]
            cage_idx = np.unique(dominant_cage_vertex(rows))
        return cage_idx.astype(np.int64)

    def set_selection(
        self,
        handle: np.ndarray,
        fixed: np.ndarray | None = None,
        roi: np.ndarray | None = None,
        space: str = "shape",
    ) -> None:
        """Choose the handle and what stays fixed.

        Parameters
        ----------
        handle : (k,) int array, vertices that follow the drag transform.
        fixed : (j,) int array, vertices that stay where they are now.
        roi : (r,) int array, alternative to ``fixed``: everything outside
            ``roi`` (and not in the handle) is fixed.
        space : "shape" (shape vertex indices) or "cage" (cage vertex indices).

        The current pose becomes the reference of the next drags: fixed vertices
        keep their current positions and :meth:`drag` transforms are relative to
        the handle's current position.
        """
        if fixed is not None and roi is not None:
            raise SelectionError("give either fixed or roi, not both")
        h = self.to_cage(handle, space, "handle")
        if h.size == 0:
            raise SelectionError("the handle is empty: select at least one vertex to drag")
        nc = self.cage.n_vertices
        if roi is not None:
            inside = np.zeros(nc, dtype=bool)
            inside[self.to_cage(roi, space, "roi")] = True
            inside[h] = True
            f = np.flatnonzero(~inside).astype(np.int64)
        elif fixed is not None:
            f = self.to_cage(fixed, space, "fixed")
            both = np.intersect1d(h, f)
            if both.size:
                raise SelectionError(
                    f"handle and fixed share {both.size} cage vertices; a vertex cannot be both"
                )
        else:
            f = np.zeros(0, dtype=np.int64)
        constrained = np.union1d(h, f)
        try:
            self.arap.set_constrained(constrained, moving=h)
        except ValueError as e:
            raise SelectionError(str(e)) from None
        self._rows = self._rows_that_can_move()
        self._propagate(all_rows=True)
        self.handle = h
        self.fixed = f
        self._constrained = constrained
        self._is_handle = np.isin(constrained, h)
        self._anchor = self.arap.positions[constrained].copy()
        self.transform = np.eye(4)

    # ------------------------------------------------------------------ deformation
    def drag(
        self,
        translate: np.ndarray | tuple | None = None,
        transform: np.ndarray | None = None,
        iterations: int | None = None,
    ) -> np.ndarray:
        """Move the handle and deform.

        Parameters
        ----------
        translate : (3,) translation of the handle, or
        transform : (4, 4) affine transform of the handle; both are absolute,
            relative to the handle's pose when the selection was set.
        iterations : ARAP iterations for this call (default ``self.iterations``).

        Returns
        -------
        (n, 3) float64 array, the deformed shape (a view that later calls update).
        """
        if self._constrained.size == 0:
            raise SelectionError("set a selection (handle) before dragging")
        if transform is not None and translate is not None:
            raise ValueError("give translate or transform, not both")
        T = check_transform(transform) if transform is not None else rigid_transform(translate=translate)
        k = self.iterations if iterations is None else int(iterations)
        if k < 0:
            raise ValueError(f"iterations must be >= 0, got {k}")
        t0 = time.perf_counter()
        target = self._anchor.copy()
        hp = target[self._is_handle]
        with np.errstate(all="ignore"):
            target[self._is_handle] = hp @ T[:3, :3].T + T[:3, 3]
            reach = float(np.max(np.abs(target - self._anchor), initial=0.0))
        if not np.all(np.isfinite(target)):
            raise ValueError("the drag moves the handle to non-finite positions; refused, nothing changed")
        limit = MAX_REACH * max(self._scale, np.finfo(float).tiny)
        if reach > limit:
            raise ValueError(
                f"the drag moves the handle {reach:.3g} away, more than {MAX_REACH:g} times the shape's "
                f"size ({self._scale:.3g}); refused, nothing changed"
            )
        saved = (self.arap.positions.copy(), self.arap.rotations.copy())
        self.arap.solve(target, k)
        if not np.all(np.isfinite(self.arap.positions)):
            self.arap.positions[:] = saved[0]
            self.arap.rotations[:] = saved[1]
            raise ValueError("the drag produced non-finite cage positions; refused, nothing changed")
        self.transform = T
        t1 = time.perf_counter()
        self._propagate()
        t2 = time.perf_counter()
        self.frame_seconds.append(t2 - t0)
        if len(self.frame_seconds) > FRAME_HISTORY:
            del self.frame_seconds[: -FRAME_HISTORY // 2]
        self.frame_breakdown = {**self.arap.last_timings, "propagate_seconds": t2 - t1, "total_seconds": t2 - t0}
        return self._out

    def reset(self) -> None:
        """Back to the rest pose (the selection is kept, its reference is the rest pose)."""
        self.arap.reset()
        self._propagate(all_rows=True)
        if self._constrained.size:
            self._anchor = self.arap.positions[self._constrained].copy()
        self.transform = np.eye(4)

    @property
    def cage_positions(self) -> np.ndarray:
        """Current cage vertex positions, (c, 3) float64 (a copy)."""
        return self.arap.positions.copy()

    def set_cage_positions(self, positions: np.ndarray) -> np.ndarray:
        """Put the cage in a given pose (e.g. for undo) and update the shape.

        Returns the (n, 3) deformed shape.
        """
        p = np.asarray(positions, dtype=np.float64)
        if p.shape != self.arap.positions.shape or not np.all(np.isfinite(p)):
            raise ValueError(f"cage positions must be finite and {self.arap.positions.shape}")
        self.arap.positions[:] = p
        self.arap.local_step()
        if self._constrained.size:
            self._anchor = p[self._constrained].copy()
        self.transform = np.eye(4)
        self._propagate(all_rows=True)
        return self._out

    def _rows_that_can_move(self) -> np.ndarray:
        """Shape vertices that a drag can move: those bound to a free or handle cage
        vertex, or (residual mode) rotating with a cage vertex whose rotation changes."""
        changing = np.zeros(self.cage.n_vertices, dtype=bool)
        changing[self.arap.active] = True  # free, their neighbours, handle
        M = self.M
        row_of_nz = np.repeat(np.arange(M.shape[0]), np.diff(M.indptr))
        mask = np.zeros(M.shape[0], dtype=bool)
        mask[row_of_nz[changing[M.indices]]] = True
        if self._residual is not None:
            mask |= changing[self._residual[1]].any(axis=1)
        return np.flatnonzero(mask).astype(np.int64)

    def _propagate(self, all_rows: bool = False) -> None:
        """The shape from the current cage pose, into ``self._out``.

        During a drag only the rows that can move are recomputed; the others
        depend on cage vertices (and rotations) the drag does not change.
        """
        rows = None if all_rows or self._rows is None else self._rows
        if self._residual is None:
            propagate(self.M, self.arap.positions, self._out, rows=rows)
        else:
            d, idx, w = self._residual
            propagate_with_residual(self.M, self.arap.positions, self.arap.rotations, d, idx, w, self._out, rows=rows)

    @property
    def deformed_vertices(self) -> np.ndarray:
        """The current deformed shape, (n, 3) float64 (a view)."""
        return self._out

    @property
    def deformed(self) -> Mesh:
        """The current deformed shape as a Mesh (a copy; same faces as the input)."""
        return Mesh(self._out.copy(), self.mesh.faces, name=self.mesh.name)

    @property
    def deformed_cage(self) -> Mesh:
        """The current cage pose as a Mesh (a copy)."""
        return Mesh(self.arap.positions.copy(), self.cage.faces, name="cage")
