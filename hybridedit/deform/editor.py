"""HybridEditor: cage + binding + cage ARAP + propagation, the engine's front door.

The editor holds the state of an editing session and runs its pipeline (a selection,
its drags, the polish, poses set from outside); each stage is its own module:

- :mod:`hybridedit.deform.selection`: a selection's roles on the shape and the cage
  (with mirror images), the rows a drag can move, the seam;
- :mod:`hybridedit.deform.base_pose`: the pose the next edit starts from (successive
  edits compose) and the shape propagated from it;
- :mod:`hybridedit.deform.frame_steps`: one frame, from the cage's ARAP targets to the
  exactly placed, region-solved, mirror-averaged shape;
- :mod:`hybridedit.deform.transform_arguments`: a drag's arguments as 4x4 transforms.

Its other methods are in the parts it is made of, one job each: ``role_queries`` (the
roles a selection gives each vertex), ``editor_state`` (snapshots, for undo),
``recorded_edits`` (the pose as an edit, an edit replayed), ``editor_files`` (a mesh
file opened, the pose saved into it), ``limb_posing`` (its limbs, one bent at its joint);
``rig_arguments`` gives it its rig.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from ..binding.rig import Progress, Rig
from ..core.mesh import Mesh
from ..core.row_copy import copied
from ..defaults import CAGE_SIZE, CONVERGE_MAX_ITERATIONS, CONVERGE_TOLERANCE, ITERATIONS, TRUNCATION
from . import lbfgs
from .lbfgs import ConvergeResult
from .arap import ARAPSolver
from .base_pose import BasePose, current_base, fit_cage, propagate_from, propagated_residual, rest_base
from .editor_files import EditorFiles
from .editor_state import EditorState, StateSnapshots
from .limb_posing import LimbPosing
from .local_global import local_global_map
from .frame_steps import Frame, FrameSteps, build_frame_steps, cage_targets, solve_cage
from .polish import MAX_ITERATIONS as POLISH_MAX_ITERATIONS
from .polish import TOLERANCE as POLISH_TOLERANCE
from .polish import PolishJob, PolishResult, ShapeARAP
from .pose_record import PoseRecord
from .recorded_edits import RecordedEdits
from .rig_arguments import BuildDefault, rig_from
from .role_queries import RoleQueries
from .shape_setup import shape_setup
from .selection import CageMap, Selection, SelectionError, build_selection, choose_roles, user_roles
from .symmetry import Mirror
from .transform_arguments import requested_transforms

__all__ = ["HybridEditor", "SelectionError", "EditorState", "ConvergeResult"]

#: frame times kept in ``frame_seconds`` (the older half is dropped past this)
FRAME_HISTORY = 10000
PROPAGATIONS = ("residual", "linear")


class HybridEditor(RoleQueries, StateSnapshots, RecordedEdits, EditorFiles, LimbPosing):
    """Interactive hybrid mesh editing of one shape.

    Takes a :class:`~hybridedit.binding.rig.Rig` (cage + binding, see :func:`hybridedit.build_rig`),
    or builds one from a mesh; then :meth:`set_selection` and :meth:`drag` deform
    the cage with ARAP and the shape follows as M @ cage plus the rotated residual.

    Constraints hold exactly in shape space: after any drag, fixed shape vertices
    are where they were when the selection was set and each handle group's shape
    vertices are exactly at its transform of where they were. On the cage, ARAP
    holds the cage vertices whose nearest shape vertex is constrained (for a
    selection made on the cage, the picked ones), fixed or following their
    group's transform; the other cage vertices a constrained row leans on may
    move. The exact placement of the constrained rows, then the region step
    (or, with the linear propagation, the harmonic spread of the seam's
    correction; :mod:`hybridedit.deform.constraints`) absorb what that leaves, so the
    transition happens inside the region of interest.

    The shape is never changed: the cage is built from a repaired private copy
    and :attr:`notes` says in plain words what was repaired. Every input vertex
    is bound, in input order.

    Parameters
    ----------
    mesh : Mesh or Rig
        The shape (n vertices), or a rig built for it (then giving any of
        ``cage_size``, ``cage``, ``binding``, ``truncation``, ``cache`` or
        ``progress`` is a ValueError: they are :func:`hybridedit.build_rig`'s).
    cage_size : int or float
        Cage vertex count (int) or fraction of the shape's vertices (float).
    cage : Mesh, optional
        Use this cage instead of simplifying the shape.
    binding : (n, c) scipy sparse matrix, optional
        Use this binding instead of computing it (rows must sum to 1).
    truncation : float
        Fraction of each row's coordinate magnitude dropped (the paper: 0.03).
    weights : "cotangent" (default) or "uniform" (the paper's w_ij = 1)
        ARAP edge weights on the cage.
    iterations : int
        ARAP local/global iterations per :meth:`drag` call.
    progress : callable(stage: str, fraction: float), optional
        Called during the slow steps (cage, bind); it may raise to cancel them.
    cache : bool or path
        Reuse the cage and binding from an on-disk cache (see :func:`hybridedit.build_rig`).
    propagation : "residual" or "linear"
        "linear" is the paper's x' = M y'. "residual" adds back, rotated with
        the cage, what M loses of the rest shape (:mod:`hybridedit.deform.residual`),
        so that with no edit the output is the input exactly.

    Examples
    --------
    >>> import hybridedit as he
    >>> ed = he.HybridEditor(he.build_rig(mesh, cage_size=0.05))  # doctest: +SKIP
    >>> ed.set_selection(handle=[hand, foot], roi=leg_and_arm)  # doctest: +SKIP
    >>> V = ed.drag(transforms={0: T_hand, 1: T_foot})  # doctest: +SKIP
    """

    def __init__(
        self,
        mesh: Mesh | Rig,
        cage_size: int | float = BuildDefault(CAGE_SIZE),
        *,
        cage: Mesh | None = BuildDefault(None),
        binding: sp.spmatrix | None = BuildDefault(None),
        truncation: float = BuildDefault(TRUNCATION),
        weights: str = "cotangent",
        iterations: int = ITERATIONS,
        progress: Progress | None = BuildDefault(None),
        cache: bool | str | Path = BuildDefault(False),
        propagation: str = "residual",
    ) -> None:
        rig = rig_from(mesh, cage_size=cage_size, cage=cage, binding=binding, truncation=truncation, cache=cache,
                       progress=progress)
        if propagation not in PROPAGATIONS:
            raise ValueError(f"propagation must be one of {PROPAGATIONS}, got {propagation!r}")
        #: the cage and binding this editor works on (see :func:`hybridedit.build_rig`)
        self.rig = rig
        self.mesh = mesh = rig.mesh
        self.cage = cage = rig.cage
        self.M = M = rig.M
        self.truncation = rig.truncation
        self.iterations = int(iterations)
        self.timings: dict[str, float] = dict(rig.timings)
        self.cache_hit = rig.cache_hit
        #: plain-word sentences about what was repaired or adjusted to build the cage
        #: (the shape itself is never changed), e.g. "merged 12 duplicate vertices"
        self.notes: list[str] = list(rig.notes)
        self.propagation = propagation
        # what depends on the shape, cage and binding only: made once, then read from the cache
        t_setup = time.perf_counter()
        setup = shape_setup(rig)
        self.timings["setup_seconds"] = time.perf_counter() - t_setup
        #: True when the shape's set-up (Laplacian, rotation blend, ...) came from the cache
        self.setup_cached = setup.from_cache
        d_rest = setup.residual
        #: the cage vertices and weights of each shape vertex's rotation blend, (n, k) each
        self._blend = (setup.blend_idx, setup.blend_w)
        self.arap = ARAPSolver(cage.vertices, cage.faces, weights=weights, links=rig.links,
                               edge_data=rig.cage_weights if weights == "cotangent" else None)
        self._scale = max(mesh.bbox_diagonal(), float(np.linalg.norm(np.ptp(cage.vertices, axis=0))))
        #: how shape and cage vertices stand for each other in a selection
        self._maps = CageMap(nearest=setup.nearest, dominant=setup.dominant)
        # the shape's cotangent Laplacian, for the free region's solve: each selection makes its
        # region's rows when it is made, rather than the open the whole matrix
        self._laplacian = setup.laplacian
        ce = self.arap.edges
        self._cage_edge = float(np.mean(np.linalg.norm(cage.vertices[ce[:, 0]] - cage.vertices[ce[:, 1]], axis=1))) \
            if len(ce) else self._scale
        self._mirrors: dict[str, Mirror] = {}
        #: rotations the residual turns with, per cage vertex (ARAP's for free
        #: vertices, the constraint's for held ones)
        self._rots = np.tile(np.eye(3), (cage.n_vertices, 1, 1))
        self._eye = np.tile(np.eye(3), (cage.n_vertices, 1, 1))  # the linear propagation's "rotations"
        self._sel: Selection | None = None
        #: the selection's frame steps, measured from ``self._base`` (None without a selection)
        self._steps: FrameSteps | None = None
        self._centers: tuple[np.ndarray, ...] = ()  # default rotation centre of each handle group
        self._transforms: list[np.ndarray] = []
        #: the pose the current selection's drags start from; the rest pose first
        self._base = self._rest_base = rest_base(binding=M, cage=cage.vertices, residual=d_rest, blend=self._blend,
                                                 propagation=propagation, shape=mesh.vertices)
        self._out = copied(self._rest_base.shape)  # (new memory: faulted in on two threads)
        self._moved = False  # the pose changed since the base was taken
        #: how the pose was made from the rest pose (the steps :attr:`edit` describes)
        self._record = PoseRecord()
        self._shape_arap: ShapeARAP | None = None  # the full-resolution polish's set-up, made by the first
        #: wall time of recent :meth:`drag` calls, oldest first (bounded, see FRAME_HISTORY)
        self.frame_seconds: list[float] = []
        #: where the last frame's time went: local_seconds, global_seconds,
        #: propagate_seconds, total_seconds
        self.frame_breakdown: dict[str, float] = {}

    # ------------------------------------------------------------------ properties
    @property
    def nnz_per_row(self) -> float:
        """Mean number of cage vertices each shape vertex depends on."""
        return self.M.nnz / max(self.M.shape[0], 1)

    @property
    def cage_edges(self) -> np.ndarray:
        """(e, 2) int64 the cage's edges as ARAP sees them (its faces' edges and the links that tie
        separate cage parts together), column 0 < column 1."""
        return self.arap.edges.copy()

    @property
    def transforms(self) -> list[np.ndarray]:
        """Current (4, 4) transform of each handle group, relative to the pose when
        the selection was set (copies)."""
        return [T.copy() for T in self._transforms]

    @property
    def transform(self) -> np.ndarray:
        """The transform of handle group 0 (identity before a selection is set)."""
        return self._transforms[0].copy() if self._transforms else np.eye(4)

    # ------------------------------------------------------------------ selection
    def set_selection(
        self,
        handle,
        fixed=None,
        roi=None,
        *,
        space: str = "shape",
        symmetry=None,
    ) -> None:
        """Choose the handle groups and what stays fixed.

        Parameters
        ----------
        handle : selection, or a list of selections (one per handle group)
            Vertices that follow a drag transform. A selection is a boolean mask of
            length n or a list / range / integer array of indices.
        fixed : selection, optional
            Vertices that stay where they are now.
        roi : selection, optional
            Alternative to ``fixed``: everything outside ``roi`` and the handles is fixed.
            With neither, nothing is fixed.
        space : "shape" (shape vertex indices) or "cage" (cage vertex indices; shape
            vertices then take the role of the cage vertex they depend on most).
        symmetry : None, "x", "y", "z" or (point, normal)
            Mirror the selection across this plane (through the centre of the shape's
            bounding box for an axis): each handle group's mirror image follows the
            mirrored transform and the result is symmetric. A shape that is not
            symmetric across the plane is refused with its measured asymmetry.

        Raises
        ------
        SelectionError
            A malformed or empty selection, overlapping groups, handle and fixed
            sharing vertices, or a shape not symmetric enough.

        Notes
        -----
        The current pose becomes the reference of the next drags (successive edits
        compose): fixed vertices keep their current positions, :meth:`drag`
        transforms are relative to the handles' current positions, and the ARAP
        energy of the next drags is measured against the current pose, so that an
        identity drag leaves every vertex where it is and nothing outside the new
        region moves. :meth:`reset` goes back to the rest pose.
        """
        user = user_roles(handle, fixed, roi, space=space, maps=self._maps)
        mirror = self._mirror(symmetry) if symmetry is not None else None
        roles = choose_roles(user, mirror=mirror, maps=self._maps)
        record = self._record_closed()
        base = self._current_base()
        before = (self.arap.reference, self.arap.rotations.copy())
        self.arap.set_reference(base.cage)  # before the factorization: it takes the rotations there
        try:
            self.arap.set_constrained(roles.constrained, moving=roles.moving)
        except ValueError as e:
            self.arap.reference = before[0]
            self.arap.set_rotations(before[1])
            raise SelectionError(str(e)) from None
        sel = build_selection(roles, free_cage=self.arap.free, held=self.arap.held, binding=self.M,
                              blend_idx=self._blend[0] if self.propagation == "residual" else None)
        self._steps = self._frame_steps(sel, base)
        self._centers = sel.centers(shape=base.shape, cage=base.cage)
        self._sel = sel
        self._transforms = [np.eye(4) for _ in range(sel.n_groups)]
        self._start_from(base)
        self._record = record.restarted()

    def _frame_steps(self, sel: Selection, base: BasePose) -> FrameSteps:
        """The frame steps of ``sel`` measured from ``base`` (factored here, once per selection)."""
        return build_frame_steps(sel, base, binding=self.M, residual=self._propagated_residual(base),
                                 propagation=self.propagation, laplacian=self._laplacian, rest=self.mesh.vertices,
                                 blend=self._blend, cage_edge=self._cage_edge)

    # ------------------------------------------------------------------ the pose an edit starts from
    def _current_base(self) -> BasePose:
        """The current pose as the base of the next edit (the base itself when nothing moved)."""
        return current_base(self._base, moved=self._moved, cage=self.arap.positions, shape=self._out, binding=self.M)

    def _propagated_residual(self, base: BasePose):
        """What the selection's rows add to M y' from ``base`` (:func:`~hybridedit.deform.base_pose.propagated_residual`)."""
        return propagated_residual(base, self._blend, propagation=self.propagation)

    @property
    def _residual(self):
        """What the rows add to M y' from the current base (:meth:`_propagated_residual`): (d, idx, w),
        or None for the paper's plain x' = M y'."""
        return self._propagated_residual(self._base)

    def _prop_rotations(self) -> np.ndarray:
        """The rotations the residual turns with: the cage's, or none for the linear propagation."""
        return self._rots if self.propagation == "residual" else self._eye

    def _start_from(self, base: BasePose) -> None:
        """Make ``base`` the pose the current selection's drags start from (the shape and
        cage must be in that pose): the energy is measured against it, every rotation
        restarts at the identity, the transforms at the identity."""
        self._base = base
        self._moved = False
        self.arap.set_reference(base.cage)
        self._rots[:] = np.eye(3)
        self._transforms = [np.eye(4) for _ in self._transforms]
        if self._sel is not None and self._steps.base is not base:  # the same selection, from the new base
            self._steps = self._steps.measured_from(base, self._propagated_residual(base))
            self._centers = self._sel.centers(shape=base.shape, cage=base.cage)

    # ------------------------------------------------------------------ deformation
    def drag(
        self,
        translate=None,
        *,
        rotate=None,
        transform: np.ndarray | None = None,
        group: int = 0,
        transforms: dict | None = None,
        iterations: int | None = None,
    ) -> np.ndarray:
        """One interactive frame: move handle groups and deform (``iterations`` ARAP iterations).

        This is the step a window runs once per mouse event: each call continues the
        solve from the previous one, so calling it again with the same transform
        moves the shape closer to the converged pose (tens to hundreds of calls).
        A script that wants the finished pose calls :meth:`pose` instead.

        Parameters
        ----------
        translate : (3,) translation of handle group ``group``, and/or
        rotate : rotation of that group about its centroid: a (3, 3) matrix, a scipy
            ``Rotation``, or ``{"axis": (3,), "degrees": a, "center": (3,)}``; or
        transform : (4, 4) affine transform of that group. All are absolute, relative
            to the handles' pose when the selection was set.
        group : int
            The handle group moved; the others keep their current transforms.
        transforms : dict {group: (4, 4) transform}, optional
            Set several groups at once (instead of the above).
        iterations : ARAP iterations for this call (default ``self.iterations``).

        Returns
        -------
        (n, 3) float64 array, the deformed shape: a read-only view of the engine's own
        array, which the next ``drag`` (and any other call that changes the pose)
        overwrites; ``.copy()`` it to keep this frame.
        """
        sel = self._sel
        if sel is None:
            raise SelectionError("set a selection (handle) before dragging")
        new = requested_transforms(self._transforms, self._centers, translate=translate, rotate=rotate,
                                   transform=transform, group=group, transforms=transforms)
        k = self.iterations if iterations is None else int(iterations)
        if k < 0:
            raise ValueError(f"iterations must be >= 0, got {k}")
        t0 = time.perf_counter()
        base = self._base
        internal = sel.group_transforms(new)
        solve_cage(self.arap, *cage_targets(base.cage, sel, internal, scale=self._scale), iterations=k)
        same = len(new) == len(self._transforms) and all(np.array_equal(a, b) for a, b in zip(new, self._transforms))
        self._record = self._record.after_drag(same_transforms=same, iterations=k)
        self._transforms = new
        self._moved = True
        t1 = time.perf_counter()
        self._steps.run(Frame(base_shape=base.shape, transforms=internal, cage=self.arap.positions,
                              cage_rotations=self.arap.rotations, rotations=self._rots,
                              propagation_rotations=self._prop_rotations(), out=self._out))
        t2 = time.perf_counter()
        self.frame_seconds.append(t2 - t0)
        if len(self.frame_seconds) > FRAME_HISTORY:
            del self.frame_seconds[: -FRAME_HISTORY // 2]
        self.frame_breakdown = {**self.arap.last_timings, "propagate_seconds": t2 - t1, "total_seconds": t2 - t0}
        return self.deformed_vertices

    def reset(self) -> None:
        """Back to the rest pose (the selection is kept; its drags start from the rest pose)."""
        self.arap.reset()
        self._rots[:] = np.eye(3)
        self._base = self._rest_base
        self._out[:] = self._rest_base.shape  # (the rest pose as the editor opened it, exactly)
        self._start_from(self._rest_base)
        self._record = PoseRecord()

    @property
    def cage_positions(self) -> np.ndarray:
        """Current cage vertex positions, (c, 3) float64 (a copy)."""
        return self.arap.positions.copy()

    @property
    def starts_at_rest(self) -> bool:
        """The current selection's drags start from the rest pose (then :attr:`edit`,
        replayed on a fresh editor, gives the current pose)."""
        return self._base.at_rest

    def set_cage_positions(self, positions: np.ndarray) -> np.ndarray:
        """Put the cage in a given pose, measured from the rest pose, and update the
        shape (every vertex follows the cage); the next drags start from that pose.

        Returns the (n, 3) deformed shape.
        """
        p = np.asarray(positions, dtype=np.float64)
        if p.shape != self.arap.positions.shape or not np.all(np.isfinite(p)):
            raise ValueError(f"cage positions must be finite and {self.arap.positions.shape}")
        self.arap.reset()
        self.arap.positions[:] = p
        self._rots[:] = self.arap.local_step()
        self._base = self._rest_base
        self._propagate_all()
        self._moved = True
        self._start_from(self._current_base())
        self._record = PoseRecord.from_outside("the cage was put in a pose by set_cage_positions")
        return self.deformed_vertices

    def set_pose(self, vertices: np.ndarray, *, cage_positions: np.ndarray | None = None) -> np.ndarray:
        """Make ``vertices`` the current shape (a polished pose, a pose carried over from
        another cage of the same shape, ...): the next drags start from it exactly.

        Parameters
        ----------
        vertices : (n, 3) float64 shape positions.
        cage_positions : (c, 3) float64, optional
            The cage pose that goes with them (e.g. the current one, for a polish of
            the current pose). By default every cage vertex moves as the shape vertex
            nearest to it did from the rest pose.

        Returns
        -------
        (n, 3) float64 array, the shape (a read-only view that later calls update).

        A pose set here was made outside the editor: :attr:`edit` describes only the
        steps after it (:attr:`replayable` is False). A polish is given with
        :meth:`adopt_polish`, another cage's pose with :meth:`carry_pose`: those are
        recorded.

        Examples
        --------
        >>> ed.set_pose(sculpted)  # doctest: +SKIP
        """
        self._put_pose(vertices, cage_positions)
        self._record = PoseRecord.from_outside("the pose was set by set_pose")
        return self.deformed_vertices

    def _put_pose(self, vertices: np.ndarray, cage_positions: np.ndarray | None) -> None:
        """Make ``vertices`` (and the cage pose, by default fitted to them) the pose the next drags start from."""
        V = np.asarray(vertices, dtype=np.float64)
        if V.shape != self._out.shape or not np.all(np.isfinite(V)):
            raise ValueError(f"a pose must be finite and {self._out.shape}, got {V.shape}")
        if cage_positions is None:
            Y = fit_cage(V, rest_shape=self.mesh.vertices, rest_cage=self.cage.vertices, nearest=self._maps.nearest)
        else:
            Y = np.asarray(cage_positions, dtype=np.float64)
            if Y.shape != self.arap.positions.shape or not np.all(np.isfinite(Y)):
                raise ValueError(f"cage positions must be finite and {self.arap.positions.shape}")
        self.arap.positions[:] = Y
        self._out[:] = V
        self._moved = True
        self._start_from(self._current_base())

    def carry_pose(self, other: "HybridEditor") -> np.ndarray:
        """Take the pose of another editor of the same shape (another cage: a rebuild), exactly,
        with the steps that made it: :attr:`edit` goes on from them (each step keeps the cage it
        ran on). Every cage vertex moves as its nearest shape vertex did from the rest pose; the
        next selection starts from the pose.

        Returns
        -------
        (n, 3) float64 array, the shape (a read-only view that later calls update).
        """
        if other.mesh.n_vertices != self.mesh.n_vertices or other.mesh.n_faces != self.mesh.n_faces:
            raise ValueError("carry_pose: the other editor is for another shape")
        if other._base.at_rest and not other._moved:
            self.reset()
            return self.deformed_vertices
        self._put_pose(other.deformed_vertices, None)
        self._record = PoseRecord.of(other._steps_made(), unknown=other._record.unknown)
        return self.deformed_vertices

    def continue_from_pose(self) -> None:
        """The current selection's next drags start from the pose as it is (their transforms
        again at the identity): its drags so far become one step of :attr:`edit`, and the
        next ones another. (What a polish does, without the polish.)"""
        if self._sel is None:
            raise SelectionError("set a selection first")
        record = self._record_closed()
        self._put_pose(self._out.copy(), self.arap.positions.copy())
        self._record = record.restarted(continues=True)

    # ------------------------------------------------------------------ polish
    def polish_job(self, *, max_iterations: int = POLISH_MAX_ITERATIONS,
                   tolerance: float = POLISH_TOLERANCE) -> PolishJob:
        """A full-resolution polish of the current pose's edited region (the selection's free
        rows), to run anywhere (:meth:`~hybridedit.deform.polish.PolishJob.run`, e.g. in a worker
        thread) and give back with :meth:`adopt_polish`.

        Raises
        ------
        SelectionError
            No selection is set.
        """
        if self._sel is None:
            raise SelectionError("set a selection first: a polish works on its region")
        return PolishJob(self._out.copy(), self.free_mask, int(max_iterations), float(tolerance))

    def adopt_polish(self, job: PolishJob, result: PolishResult) -> np.ndarray:
        """Make a polish of the current pose the pose (the next drags start from it), recorded
        as the end of the current step with its iteration count, so that :attr:`edit` replays it.

        Raises
        ------
        ValueError
            The pose changed since ``job`` was made (the polish is of a pose that is gone).
        """
        if self._sel is None or not np.array_equal(job.start, self._out):
            raise ValueError("the pose changed since the polish started: its result is not taken")
        record = self._record_closed(polish=result.iterations)
        self._put_pose(result.vertices, self.arap.positions.copy())
        self._record = record.restarted(continues=True)
        return self.deformed_vertices

    def polish(self, *, iterations: int | None = None, max_iterations: int = POLISH_MAX_ITERATIONS,
               tolerance: float = POLISH_TOLERANCE) -> PolishResult:
        """Polish the current pose now and make it the pose (:meth:`polish_job`, run here,
        :meth:`adopt_polish`).

        Parameters
        ----------
        iterations : int, optional
            Run exactly this many iterations (a replay); otherwise until an iteration moves
            no vertex by more than ``tolerance`` of the diagonal, at most ``max_iterations``.

        Returns
        -------
        PolishResult
        """
        if iterations is not None:
            job = self.polish_job(max_iterations=int(iterations), tolerance=0.0)
        else:
            job = self.polish_job(max_iterations=max_iterations, tolerance=tolerance)
        if self._shape_arap is None:
            self._shape_arap = ShapeARAP(self.mesh)
        result = job.run(self._shape_arap)
        self.adopt_polish(job, result)
        return result

    def _propagate_all(self) -> None:
        """Every shape vertex from the current cage pose and rotations, from the base pose."""
        propagate_from(self._base, binding=self.M, cage=self.arap.positions, rotations=self._prop_rotations(),
                       blend=self._blend, propagation=self.propagation, out=self._out)

    # ------------------------------------------------------------------ results
    @property
    def deformed_vertices(self) -> np.ndarray:
        """The current deformed shape, (n, 3) float64: a read-only view of the engine's
        array, which later calls update (``.copy()`` it to keep a pose)."""
        view = self._out.view()
        view.flags.writeable = False
        return view

    @property
    def deformed(self) -> Mesh:
        """The current deformed shape as a Mesh (a copy; same faces as the input)."""
        return Mesh(self._out.copy(), self.mesh.faces, name=self.mesh.name)

    @property
    def deformed_cage(self) -> Mesh:
        """The current cage pose as a Mesh (a copy)."""
        return Mesh(self.arap.positions.copy(), self.cage.faces, name="cage")

    # ------------------------------------------------------------------ scripts: a solved pose
    def pose(self, translate=None, *, rotate=None, transform: np.ndarray | None = None, group: int = 0,
             transforms: dict | None = None, tolerance: float = 1e-6, max_frames: int = 1000) -> np.ndarray:
        """Solve an edit to convergence: :meth:`drag` frames at the given transform until a
        frame moves no vertex by more than ``tolerance`` times the bounding-box diagonal,
        or ``max_frames`` frames (then a RuntimeWarning says how far the last one moved).

        Takes :meth:`drag`'s transform arguments (absolute, relative to the pose when the
        selection was set). Calling it again with the same transform returns the same
        pose (within ``tolerance``).

        Returns
        -------
        (n, 3) float64 array, the converged shape (a copy of its own).
        """
        if not (tolerance > 0) or int(max_frames) < 1:
            raise ValueError(f"tolerance must be > 0 and max_frames >= 1, got {tolerance!r}, {max_frames!r}")
        diagonal = max(self.mesh.bbox_diagonal(), np.finfo(float).tiny)
        previous = self._out.copy()
        moved = np.inf
        for _ in range(int(max_frames)):
            V = self.drag(translate, rotate=rotate, transform=transform, group=group, transforms=transforms)
            moved = float(np.abs(V - previous).max(initial=0.0))
            if moved <= tolerance * diagonal:
                return V.copy()
            previous[:] = V
        import warnings

        warnings.warn(f"pose: not converged after {int(max_frames)} frames (the last moved "
                      f"{moved / diagonal:.2g} of the diagonal, tolerance {tolerance:g})",
                      RuntimeWarning, stacklevel=2)
        return self._out.copy()

    def converge(self, translate=None, *, rotate=None, transform: np.ndarray | None = None, group: int = 0,
                 transforms: dict | None = None, tolerance: float = CONVERGE_TOLERANCE,
                 max_iterations: int = CONVERGE_MAX_ITERATIONS, start: str = "current", cancel=None,
                 progress: Progress | None = None) -> ConvergeResult:
        """Solve the selection's transforms to convergence on the cage alone, then propagate once.

        The cage's ARAP iterations run at the transforms, warm-started from the current cage
        pose (or from the selection's start pose), until the cage is within ``tolerance`` of the
        diagonal of the fixed point, by a bound (not the last step: L-BFGS in the Laplacian's
        metric with a line search on the energy, :mod:`hybridedit.deform.lbfgs`); then the shape is
        propagated from it once, as a :meth:`drag` frame is. What a window's settle or an add-on
        runs when the handles stop, and how an animation frame is solved from the start pose.

        Parameters
        ----------
        translate, rotate, transform, group, transforms
            The transforms, as :meth:`drag` takes them (absolute, relative to the pose when the
            selection was set).
        tolerance : float
            The bound on the cage's distance to the fixed point (the largest coordinate of any
            vertex's), a fraction of the bounding-box diagonal, > 0.
        max_iterations : int
            Cap on the iterations (>= 1); a run stopped there says so (``converged`` False) and
            its pose is kept.
        start : "current" or "base"
            Warm-start from the current cage pose, or from the selection's start pose (the
            pose :meth:`set_selection` was given, whatever ran since: the same transforms give
            the same pose bit for bit, as a replay does).
        cancel : callable() -> bool or threading.Event, optional
            Checked between iterations; once true (set) the run stops and nothing is changed
            (``stopped`` "cancelled").
        progress : callable(stage, fraction), optional
            Told ("converging", fraction) after each iteration, the fraction by a rule (the
            reduction of the residual, on a log scale), never the clock.

        Returns
        -------
        ConvergeResult
            ``vertices`` (n, 3) float64 the shape (a read-only view, as :meth:`drag` gives),
            ``converged``, ``stopped``, ``iterations``, ``distance`` (the bound, a fraction of
            the diagonal).

        Raises
        ------
        SelectionError
            No selection is set.
        ValueError
            A bad transform, tolerance or cap, or the solve gave non-finite positions (then
            nothing changed).

        Notes
        -----
        The pose record (:attr:`edit`) keeps the converge as its step's ``"converge"``: a
        converge from the start pose, or after iterations all at these transforms, replays bit
        for bit; one warm-started from interactive frames replays as a converge from the start
        pose, to the same tolerance.

        Examples
        --------
        >>> ed.set_selection(hand, roi=arm)  # doctest: +SKIP
        >>> r = ed.converge(transforms={0: T})  # doctest: +SKIP
        >>> r.converged, r.iterations, r.vertices.shape  # doctest: +SKIP
        (True, 172, (691858, 3))
        """
        sel = self._sel
        if sel is None:
            raise SelectionError("set a selection (handle) before converging")
        if start not in ("current", "base"):
            raise ValueError(f"start must be 'current' or 'base', got {start!r}")
        new = requested_transforms(self._transforms, self._centers, translate=translate, rotate=rotate,
                                   transform=transform, group=group, transforms=transforms)
        tol = float(tolerance)
        if not (tol > 0 and np.isfinite(tol)) or int(max_iterations) < 1:
            raise ValueError(f"tolerance must be > 0 and max_iterations >= 1, got {tolerance!r}, {max_iterations!r}")
        t0 = time.perf_counter()
        base = self._base
        internal = sel.group_transforms(new)
        slots, target = cage_targets(base.cage, sel, internal, scale=self._scale)
        before = self.arap.positions.copy()
        if start == "base":
            self.arap.positions[:] = base.cage
        say = None if progress is None else (lambda fraction: progress("converging", fraction))
        diagonal = max(self.mesh.bbox_diagonal(), np.finfo(float).tiny)
        try:
            gmap = local_global_map(self.arap, target, slots=slots)
            x, stats = lbfgs.converge(gmap, tolerance=tol * diagonal, max_iterations=int(max_iterations),
                                         cancel=cancel, progress=say)
        except FloatingPointError:
            self.arap.positions[:] = before
            raise ValueError("the converge produced non-finite cage positions; refused, nothing changed") from None
        except BaseException:
            self.arap.positions[:] = before  # (a progress callback that raised: nothing changed either)
            raise
        if stats.stopped == "cancelled":
            self.arap.positions[:] = before
        else:
            self.arap.adopt(x, gmap.rotations())
            same = len(new) == len(self._transforms) and all(np.array_equal(a, b)
                                                             for a, b in zip(new, self._transforms))
            self._record = self._record.after_converge(
                {"tolerance": tol, "max_iterations": int(max_iterations)}, same_transforms=same,
                from_start=start == "base")
            self._transforms = new
            self._moved = True
            self._steps.run(Frame(base_shape=base.shape, transforms=internal, cage=self.arap.positions,
                                  cage_rotations=self.arap.rotations, rotations=self._rots,
                                  propagation_rotations=self._prop_rotations(), out=self._out))
        return ConvergeResult(vertices=self.deformed_vertices, converged=stats.converged, stopped=stats.stopped,
                              iterations=stats.iterations, rejected=stats.rejected,
                              distance=stats.distance / diagonal, seconds=time.perf_counter() - t0)
