"""The steps of one interactive frame (one :meth:`hybridedit.HybridEditor.drag` call).

A frame runs, in order:

1. the cage: :func:`cage_targets` (where the held cage vertices go) and
   :func:`solve_cage` (ARAP iterations moving the free ones);
2. the shape, through the :class:`FrameSteps` a selection measured from its base
   pose builds (:func:`build_frame_steps`), each a step with ``run(frame)``:

   - :class:`TurnRotations`: the rotation each cage vertex gives the residual
     (ARAP's for free cage vertices, its group's for a handle's);
   - :class:`PropagateRows`: the selection's rows that nothing else places, through M;
   - the region solver, as a :class:`RegionSolver` wrapping
     :class:`~hybridedit.deform.constraints.RegionStep` (residual propagation: a
     full-resolution ARAP step over the free region, after the exact placement)
     or :class:`~hybridedit.deform.constraints.SeamSpread` (linear propagation: the
     harmonic spread of the seam's mismatch, measured before the exact placement);
   - :class:`PlaceConstrained`: each handle group's shape vertices exactly at its
     transform of where they were (fixed ones are never written, or set back);
   - :class:`AverageMirror`: the displacement of rows with a free mirror image
     averaged with the mirrored displacement of that image (a symmetric result).

Pure compute; the shape array a frame writes is ``frame.out``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numba import njit, prange

from ..core.index_sets import difference_in_range, union_in_range
from ..core.parallel import pick
from ..core.twins import twins
from ..core.row_copy import take_rows

from .constraints import RegionStep, SeamSpread, place, region_to_solve
from .residual import SelectionRows
from .selection import Selection

__all__ = ["MAX_REACH", "Frame", "cage_targets", "solve_cage", "TurnRotations", "PropagateRows", "PlaceConstrained",
           "RegionSolver", "AverageMirror", "FrameSteps", "build_frame_steps"]

#: a drag may move the handle at most this many bounding-box diagonals
MAX_REACH = 1e6


def cage_targets(base_cage: np.ndarray, selection: Selection, transforms: list[np.ndarray], *,
                 scale: float) -> tuple[np.ndarray, np.ndarray]:
    """Where a frame puts the selection's moving cage vertices: each internal group's at its
    (4, 4) transform of where it is in the (c, 3) ``base_cage``. The fixed ones are not
    written by a frame at all (they stay where the base has them).

    Returns
    -------
    slots : (k,) int64 positions within ``selection.constrained`` of the groups' cage vertices.
    target : (k, 3) float64 their positions.

    Raises
    ------
    ValueError
        A target is not finite, or lies farther than :data:`MAX_REACH` times ``scale``
        (the shape's size) from where it starts.
    """
    reach = 0.0
    finite = True
    moved = []
    with np.errstate(all="ignore"):
        for g, T in enumerate(transforms):
            start = take_rows(base_cage, selection.cage_groups[g])
            m = start @ T[:3, :3].T + T[:3, 3]
            moved.append(m)
            reach = max(reach, float(np.max(np.abs(m - start), initial=0.0)))
            finite = finite and bool(np.all(np.isfinite(m)))
    if not finite or not np.isfinite(reach):
        raise ValueError("the drag moves the handle to non-finite positions; refused, nothing changed")
    limit = MAX_REACH * max(scale, np.finfo(float).tiny)
    if reach > limit:
        raise ValueError(
            f"the drag moves the handle {reach:.3g} away, more than {MAX_REACH:g} times the shape's "
            f"size ({scale:.3g}); refused, nothing changed"
        )
    slots = np.concatenate([np.asarray(s, dtype=np.int64) for s in selection.slots[:len(transforms)]]
                           + [np.zeros(0, dtype=np.int64)])
    return slots, np.concatenate(moved + [np.zeros((0, 3))])


def solve_cage(arap, slots: np.ndarray, target: np.ndarray, *, iterations: int) -> None:
    """Run ``iterations`` ARAP iterations of ``arap`` (an :class:`~hybridedit.deform.arap.ARAPSolver`)
    with its constrained vertices at ``slots`` (positions within its constrained order) at
    ``target`` (k, 3), the others where they are (:func:`cage_targets` gives both).

    Raises
    ------
    ValueError
        The solve gave non-finite positions (the solver's positions and rotations are
        then as they were: its solve leaves them so).
    """
    try:
        arap.solve(target, iterations, slots=slots)
    except FloatingPointError:
        raise ValueError("the drag produced non-finite cage positions; refused, nothing changed") from None


@dataclass(frozen=True, slots=True)
class Frame:
    """What the shape steps of one frame read and write.

    base_shape : (n, 3) the shape in the base pose (what the constraints refer to).
    transforms : (4, 4) transform of each internal group.
    cage : (c, 3) cage positions; cage_rotations : (c, 3, 3) ARAP's rotations.
    rotations : (c, 3, 3) the residual's rotations per cage vertex (written by :class:`TurnRotations`).
    propagation_rotations : (c, 3, 3) those the propagation turns with (``rotations``,
        or the identity for the linear propagation).
    out : (n, 3) the shape, written in place.
    """

    base_shape: np.ndarray
    transforms: list
    cage: np.ndarray
    cage_rotations: np.ndarray
    rotations: np.ndarray
    propagation_rotations: np.ndarray
    out: np.ndarray


class TurnRotations:
    """The rotation each cage vertex gives the residual: ARAP's for the (f,) ``free`` cage
    vertices, its transform's for each internal group's ``groups`` (the base's rotations
    are the identity: the others keep it)."""

    def __init__(self, free: np.ndarray, groups: tuple[np.ndarray, ...]) -> None:
        self.free = np.ascontiguousarray(free, dtype=np.int64)
        self._members = np.concatenate([np.asarray(g, dtype=np.int64) for g in groups] + [np.zeros(0, np.int64)])
        self._group_of = np.repeat(np.arange(len(groups), dtype=np.int64), [len(g) for g in groups])

    def run(self, frame: Frame) -> None:
        Rs = np.array([T[:3, :3] for T in frame.transforms], dtype=np.float64).reshape(-1, 3, 3)
        n = self.free.size + self._members.size
        pick("place", *_turn, n)(frame.rotations, frame.cage_rotations, self.free, self._members,
                                 self._group_of, Rs)


@njit(cache=True, inline="always")
def _turn_one(q, out, cage_rots, free, members, group_of, Rs):
    nf = free.shape[0]
    if q < nf:
        i = free[q]
        for a in range(3):
            for b in range(3):
                out[i, a, b] = cage_rots[i, a, b]
    else:
        i = members[q - nf]
        g = group_of[q - nf]
        for a in range(3):
            for b in range(3):
                out[i, a, b] = Rs[g, a, b]


@twins()
def _turn(out, cage_rots, free, members, group_of, Rs):  # pragma: no cover - compiled
    for q in prange(free.shape[0] + members.shape[0]):
        _turn_one(q, out, cage_rots, free, members, group_of, Rs)


class PropagateRows:
    """The rows nothing else places, propagated through M (plus the turned residual)
    (a :class:`~hybridedit.deform.residual.SelectionRows`)."""

    def __init__(self, rows: SelectionRows) -> None:
        self.rows = rows

    def run(self, frame: Frame) -> None:
        self.rows.run(frame.cage, frame.propagation_rotations, frame.out)

    def measured_from(self, base_shape, residual) -> "PropagateRows":
        return PropagateRows(self.rows.with_residual(residual))


class PlaceConstrained:
    """Each internal group's (h_g,) shape vertices ``groups`` exactly at its transform of
    their base positions."""

    def __init__(self, groups: tuple[np.ndarray, ...]) -> None:
        self.groups = groups

    def run(self, frame: Frame) -> None:
        for g, T in enumerate(frame.transforms):
            place(self.groups[g], frame.base_shape, T, frame.out)


class RegionSolver:
    """Places the free moving rows once the constrained ones are exact (the common face
    of :class:`RegionStepSolver` and :class:`SeamSpreadSolver`).

    ``before(frame)`` runs after the propagation, ``after(frame)`` after the exact
    placement; ``solved`` (m,) int64 are the rows it places itself (not propagated);
    ``solver`` is the wrapped object.
    """

    solver: RegionStep | SeamSpread | None = None
    solved = np.zeros(0, dtype=np.int64)

    def before(self, frame: Frame) -> None:
        pass

    def after(self, frame: Frame) -> None:
        pass

    def measured_from(self, base_shape, residual) -> "RegionSolver":
        return self


class RegionStepSolver(RegionSolver):
    """A full-resolution ARAP global step over the free region (residual propagation):
    each free row takes the rotation the cage gives it, its neighbours' exact
    positions are its boundary (:class:`~hybridedit.deform.constraints.RegionStep`)."""

    def __init__(self, step: RegionStep) -> None:
        self.solver = step
        self.solved = step.free

    def after(self, frame: Frame) -> None:
        self.solver.apply(frame.out, frame.rotations)

    def measured_from(self, base_shape, residual) -> "RegionStepSolver":
        return RegionStepSolver(self.solver.with_reference(base_shape))


class SeamSpreadSolver(RegionSolver):
    """The harmonic spread over the free rows of how far the propagation leaves the
    seam's (s,) constrained rows from their exact positions (linear propagation,
    :class:`~hybridedit.deform.constraints.SeamSpread`); the seam's rows are then set back
    to their base positions (handles are placed next).

    ``spread`` is made for ``rows`` and ``seam``; ``seam_role`` (s,) their internal roles.
    """

    def __init__(self, spread: SeamSpread, rows: np.ndarray, seam: np.ndarray, seam_role: np.ndarray) -> None:
        self.solver = spread
        self.rows = rows
        self.seam = seam
        self.seam_role = seam_role

    def before(self, frame: Frame) -> None:
        shape0, out, seam = frame.base_shape, frame.out, self.seam
        goal = shape0[seam]
        for g, T in enumerate(frame.transforms):
            m = self.seam_role == g + 1
            goal[m] = goal[m] @ T[:3, :3].T + T[:3, 3]
        out[self.rows] += self.solver.correction(goal - out[seam])
        out[seam] = shape0[seam]  # fixed ones (propagated above); handles are placed next


class AverageMirror:
    """The displacement from the base of each of the (m,) ``rows`` averaged with the
    mirrored displacement of its mirror image (``mirror``, a
    :class:`~hybridedit.deform.symmetry.Mirror`): the result is symmetric."""

    def __init__(self, rows: np.ndarray, mirror) -> None:
        self.rows = rows
        self.mirror = mirror

    def run(self, frame: Frame) -> None:
        r = self.rows
        shape0, out = frame.base_shape, frame.out
        partner = self.mirror.map[r]
        U = out[r] - shape0[r]
        Um = out[partner] - shape0[partner]
        out[r] = shape0[r] + 0.5 * (U + Um @ self.mirror.S[:3, :3].T)


@dataclass(frozen=True)
class FrameSteps:
    """The shape side of a frame for one selection, measured from one base pose.

    turn, propagate, place : :class:`TurnRotations`, :class:`PropagateRows`, :class:`PlaceConstrained`.
    region : the :class:`RegionSolver`. average : :class:`AverageMirror`, or None (no mirror).
    base : the base pose the steps measure against (a :class:`~hybridedit.deform.base_pose.BasePose`).
    """

    turn: TurnRotations
    propagate: PropagateRows
    region: RegionSolver
    place: PlaceConstrained
    average: AverageMirror | None
    base: object

    def run(self, frame: Frame) -> None:
        """Write the frame's shape into ``frame.out`` (and its rotations into ``frame.rotations``)."""
        self.turn.run(frame)
        self.propagate.run(frame)
        self.region.before(frame)
        self.place.run(frame)
        self.region.after(frame)
        if self.average is not None:
            self.average.run(frame)

    def measured_from(self, base, residual) -> "FrameSteps":
        """The same steps measured from another base pose (its shape (n, 3) is the region
        step's reference; ``residual`` ``(d, idx, w)`` or None is what the propagation
        adds, :func:`hybridedit.deform.base_pose.propagated_residual`); factorizations are shared."""
        return FrameSteps(turn=self.turn, propagate=self.propagate.measured_from(base.shape, residual),
                          region=self.region.measured_from(base.shape, residual), place=self.place,
                          average=self.average, base=base)


def build_frame_steps(selection: Selection, base, *, binding: sp.csr_matrix, residual, propagation: str,
                      laplacian: sp.spmatrix, rest: np.ndarray, blend: tuple[np.ndarray, np.ndarray],
                      cage_edge: float) -> FrameSteps:
    """The frame steps of ``selection`` measured from ``base``.

    Parameters
    ----------
    selection : the :class:`~hybridedit.deform.selection.Selection`.
    base : the :class:`~hybridedit.deform.base_pose.BasePose` the drags start from.
    binding : (n, c) CSR binding M.
    residual : ``(d, idx, w)`` the propagation adds from ``base``, or None (plain M y').
    propagation : "residual" (the region step places the free rows: over the whole
        region when it is small, else over a band around the seam, see
        :func:`~hybridedit.deform.constraints.region_to_solve`) or "linear" (the paper's
        x' = M y' for the region, and the harmonic spread of the seam's correction).
    laplacian : (n, n) sparse cotangent Laplacian of the shape.
    rest : (n, 3) rest shape positions (where the band is measured).
    blend : ``(idx, w)`` (n, k) each shape vertex's rotation blend.
    cage_edge : mean cage edge length.
    """
    rows, seam = selection.rows, selection.seam
    if propagation == "residual":
        solve = region_to_solve(rest, rows, seam, cage_edge)
        region = RegionStepSolver(RegionStep(base.shape, laplacian, solve, *blend))
        propagated = difference_in_range(rows, region.solved, len(rest))  # it places its rows itself
    else:
        region = SeamSpreadSolver(SeamSpread(laplacian, rows, seam), rows, seam, selection.seam_role) \
            if seam.size else RegionSolver()
        propagated = union_in_range(rows, seam, len(rest))
    average = AverageMirror(selection.sym_rows, selection.mirror) if selection.sym_rows.size else None
    return FrameSteps(turn=TurnRotations(selection.free_cage, selection.cage_groups),
                      propagate=PropagateRows(SelectionRows(binding, propagated, residual)), region=region,
                      place=PlaceConstrained(selection.shape_groups), average=average, base=base)
