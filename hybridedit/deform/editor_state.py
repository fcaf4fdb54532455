"""Undo for the editor: a snapshot of its selection and pose (:class:`EditorState`), taken by
:meth:`~hybridedit.HybridEditor.save_state` and put back, exactly, by
:meth:`~hybridedit.HybridEditor.restore_state` (the :class:`StateSnapshots` part of the editor)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

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
    cage solver's positions and rotations, the residual's rotations ``_rots``, the shape ``_out``)."""

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
