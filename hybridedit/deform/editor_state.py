"""Undo for the editor: a snapshot of its selection and pose (:class:`EditorState`), taken by
:meth:`~hybridedit.HybridEditor.save_state` and put back, exactly, by
:meth:`~hybridedit.HybridEditor.restore_state` (the :class:`StateSnapshots` part of the editor)."""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from ..core.held_bytes import held_buffers
from .base_pose import BasePose
from .frame_steps import FrameSteps
from .pose_record import PoseRecord
from .selection import Selection

__all__ = ["EditorState", "StateSnapshots"]


@dataclass(frozen=True)
class EditorState:
    """A snapshot of an editor's selection and pose (see :meth:`HybridEditor.save_state`)."""

    selection: Selection | None
    transforms: tuple[np.ndarray, ...]
    cage_positions: np.ndarray
    arap_rotations: np.ndarray
    rotations: np.ndarray
    shape: np.ndarray
    base: BasePose
    moved: bool
    steps: FrameSteps | None = None  # the selection's frame steps, measured from ``base``
    centers: tuple[np.ndarray, ...] = ()  # the default rotation centre of each handle group
    record: PoseRecord = PoseRecord()  # how the pose was made (what :attr:`HybridEditor.edit` replays)


class StateSnapshots:
    """:class:`~hybridedit.HybridEditor`'s snapshots, mixed into it: every field of its selection and
    pose (``_sel``, ``_steps``, ``_centers``, ``_transforms``, ``_base``, ``_moved``, ``_record``, the
    cage solver's positions and rotations, the residual's rotations ``_rots``, the shape ``_out``), and
    to measure a snapshot, what the editor holds for its whole life (``rig``, ``mesh``, ``M``, ``_blend``,
    ``_maps``, ``_laplacian``, ``_rest_base``, ``_eye``)."""

    def save_state(self) -> EditorState:
        """A snapshot of the selection and pose, for :meth:`restore_state` (undo).

        Snapshots are read, never written; one whose pose is bit for bit the previous snapshot's
        shares that one's arrays (a selection changes no pose: each such step held another copy of
        the shape, 265 MB at 11M)."""
        return EditorState(self._sel, tuple(T.copy() for T in self._transforms), self.arap.positions.copy(),
                           self._kept("arap_rotations", self.arap.rotations), self._kept("rotations", self._rots),
                           self._kept("shape", self._out), self._base,
                           self._moved, steps=self._steps, centers=self._centers, record=self._record)

    def _kept(self, name: str, a: np.ndarray) -> np.ndarray:
        """A copy of ``a`` for a snapshot: the last snapshot's copy when ``a`` is bit for bit the same."""
        kept = self.__dict__.setdefault("_snapshot_arrays", {})
        last = kept.get(name)
        if last is not None and last.shape == a.shape and last.dtype == a.dtype \
                and np.array_equal(last.view(np.uint8), np.ascontiguousarray(a).view(np.uint8)):
            return last
        kept[name] = a.copy()
        return kept[name]

    def state_buffers(self, state: EditorState, *, out: dict[int, int] | None = None) -> dict[int, int]:
        """The memory a snapshot holds beyond the editor's own arrays: {id of a buffer's owner: bytes}
        (:func:`~hybridedit.core.held_bytes.held_buffers`, added to ``out`` when given): its pose, the
        base pose its drags start from, its selection and the frame steps measured from that base
        (their factorization estimated). Snapshots share buffers: their memory together is the union
        of theirs (an undo history's budget). Not counted: what the editor holds for its whole life
        (the shape, binding, Laplacian, rest pose, ...) and the record (the steps :attr:`edit`
        replays, kept by the editor's own record too)."""
        return held_buffers(*(getattr(state, f.name) for f in fields(state) if f.name != "record"),
                            skip=self._own_buffers(), out=out)

    def _own_buffers(self) -> frozenset[int]:
        """ids of the buffers the editor holds for its whole life, which snapshots share (made once)."""
        own = self.__dict__.get("_own_buffer_ids")
        if own is None:
            own = frozenset(held_buffers(self.rig, self.mesh, self.M, self._blend, self._maps, self._laplacian,
                                         self._rest_base, self._eye))
            self.__dict__["_own_buffer_ids"] = own
        return own

    def restore_state(self, state: EditorState) -> np.ndarray:
        """Go back to a snapshot taken by :meth:`save_state` (the selection, the pose it
        starts from and the current pose, exactly); returns the (n, 3) shape."""
        self.arap.reference = state.base.cage
        if state.selection is not self._sel:
            sel = state.selection
            if sel is not None:
                self.arap.set_constrained(sel.constrained, moving=sel.moving)
            self._sel = sel
        self._steps = state.steps
        self._centers = state.centers
        self.arap.positions[:] = state.cage_positions
        self.arap.set_rotations(state.arap_rotations)
        self._rots[:] = state.rotations
        self._out[:] = state.shape
        self._transforms = [T.copy() for T in state.transforms]
        self._base = state.base
        self._moved = state.moved
        self._record = state.record
        return self.deformed_vertices
