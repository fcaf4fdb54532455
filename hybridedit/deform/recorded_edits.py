"""The editor's pose as an edit, and an edit replayed on it: how the pose was made from the rest pose
(:attr:`~hybridedit.HybridEditor.edit`, the :class:`~hybridedit.deform.pose_record.PoseRecord` behind
it, the steps it closes) and :meth:`~hybridedit.HybridEditor.apply_edit` (the :class:`RecordedEdits`
part of :class:`~hybridedit.HybridEditor`)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Callable

import numpy as np

from ..defaults import SETTLE_FRAMES
from ..fileio.editfile import Edit, HandleEdit, mesh_fingerprint
from .packed_step import PackedStep
from .pose_record import PoseRecord
from .roles import FIXED
from .selection import SelectionError

if TYPE_CHECKING:
    from ..binding.rig import Progress
    from .editor import HybridEditor

__all__ = ["RecordedEdits"]


class RecordedEdits:
    """:class:`~hybridedit.HybridEditor`'s record of how its pose was made, mixed into it: it reads
    the record ``_record``, the selection ``_sel`` with its ``_transforms`` and ``_centers``, the
    base pose ``_base``, and the ``rig`` (the cage a step ran on)."""

    @property
    def edit(self) -> Edit:
        """How the current pose was made, as a shape-space :class:`Edit` that :meth:`apply_edit`
        replays: the current selection and handle transforms, after the steps before it
        (:attr:`Edit.before`: earlier selections, polishes). Each step records the ARAP
        iterations run at its transforms when they all ran at them (a settle, or frames at one
        transform), the converge that followed them, its polish iterations, and its cage. See
        :attr:`replayable`.

        Raises
        ------
        SelectionError
            No selection has been set (there is nothing to describe).
        """
        steps = self._steps_made(current_if_empty=True)
        if not steps:
            raise SelectionError("no selection to describe: set one first")
        last = steps[-1]
        return Edit(handles=last.handles, fixed=last.fixed, roi=last.roi, space=last.space, symmetry=last.symmetry,
                    iterations=last.iterations, polish=last.polish, cage=last.cage, continues=last.continues,
                    before=steps[:-1], mesh=mesh_fingerprint(self.mesh), converge=last.converge)

    def packed_steps(self) -> tuple[PackedStep, ...]:
        """The steps of :attr:`edit`, oldest first, as the record keeps them (:class:`PackedStep`, the
        current one packed here): the edit without every step's index lists unpacked (what a long
        session's autosave writes, :meth:`PackedStep.to_json`). Its mesh fingerprint is not in it.

        Raises
        ------
        SelectionError
            No selection has been set (as :attr:`edit`).
        """
        r = self._record
        steps = r.packed
        if self._sel is not None and (r.dragged or not r.continues):  # (as _steps_made(current_if_empty=True))
            steps = steps + (PackedStep.of(self._current_step()),)
        if not steps:
            raise SelectionError("no selection to describe: set one first")
        return steps

    @property
    def record(self) -> PoseRecord:
        """How the current pose was made from the rest pose (:class:`~hybridedit.deform.pose_record.PoseRecord`,
        read-only): the steps :attr:`edit` describes."""
        return self._record

    @property
    def replayable(self) -> bool:
        """Replaying :attr:`edit` from the rest pose on this cage gives the current pose (no pose
        was set from outside, and no drag is left unsettled: interactive frames at changing
        transforms make a pose that depends on their path)."""
        return self._record.replayable

    def _steps_made(self, current_if_empty: bool = False) -> list[Edit]:
        """The steps of the record, the current one included when it has done something (or,
        ``current_if_empty``, when it is a new selection)."""
        r = self._record
        steps = list(r.done)
        if self._sel is not None and (r.dragged or (current_if_empty and not r.continues)):
            steps.append(self._current_step())
        return steps

    def _current_step(self, polish: int | None = None) -> Edit:
        """The current selection and transforms as one step (see :class:`~hybridedit.deform.pose_record.PoseRecord`)."""
        sel, r = self._sel, self._record
        roles = sel.user_roles
        handles = [HandleEdit.from_matrix(np.flatnonzero(roles == g + 1), self._transforms[g], center=self._centers[g])
                   for g in range(sel.n_groups)]
        fixed = np.flatnonzero(roles == FIXED)
        # (the shorter list, but as it was given where a mirror makes them differ: with "roi" a vertex stays
        # fixed only where its mirror image is fixed too, with "fixed" as listed)
        as_roi = sel.roi_mode if sel.mirror is not None else fixed.size * 2 > roles.size
        fixed_kw = {"roi": np.flatnonzero(roles != FIXED)} if as_roi else {"fixed": fixed}
        size = self.rig.cage_size
        cage = {"size": int(size) if isinstance(size, (int, np.integer)) else float(size),
                "vertices": int(self.cage.n_vertices)}
        return Edit(handles=handles, space="shape", symmetry=None if sel.mirror is None else sel.mirror.spec,
                    iterations=r.iterations if r.settled else None, polish=polish, cage=cage,
                    continues=r.continues, converge=r.converge, **fixed_kw)

    def _record_closed(self, polish: int | None = None) -> PoseRecord:
        """The record with the current step closed (kept when it did something: a drag or a polish)."""
        r = self._record
        if self._sel is None or (not r.dragged and polish is None):
            return r
        return r.closed(self._current_step(polish))

    def apply_edit(self, edit: Edit, *, frames: int = SETTLE_FRAMES, iterations: int | None = None,
                   progress: Progress | None = None, path: str | None = None,
                   editor_for_cage: Callable[[dict], "HybridEditor"] | None = None) -> np.ndarray:
        """Replay an edit on the current pose (from the rest pose after :meth:`reset`): each
        step sets its selection, runs its ARAP iterations at its transforms, then its polish
        (:func:`hybridedit.deform.replay.replay`, the one replay loop).

        Parameters
        ----------
        edit : Edit
            Its steps (:attr:`Edit.steps`); a version 2 file is one step.
        frames : int
            A step that does not record its iterations runs ``frames`` drags of
            ``iterations`` each (0: the last step's selection is set and nothing is run).
        iterations : int, optional
            ARAP iterations a frame (default ``self.iterations``).
        progress : callable(stage, fraction), optional
        path : str, optional
            The edit file's name, for messages.
        editor_for_cage : callable({"size", "vertices"}) -> HybridEditor, optional
            An editor of this shape on the cage a step records, for an exact replay of an
            edit made across cages (a rebuild); without it every step runs on this cage.

        Returns
        -------
        (n, 3) float64 array, the deformed shape.

        Raises
        ------
        EditFileError
            The edit was made for another mesh.
        SelectionError
            Its selection does not fit this mesh (indices out of range, ...).
        """
        from .replay import replay

        return replay(self, edit, frames=frames, iterations=iterations, progress=progress, path=path,
                      editor_for_cage=editor_for_cage)

    def edit_transforms(self, edit: Edit) -> dict[int, np.ndarray]:
        """The (4, 4) transform of each of an edit's handle groups, {group: T}; a
        rotation without a centre turns about the group's centroid (in the edit's
        space, in the pose the current selection was set at)."""
        if self._sel is None:
            raise SelectionError("set the edit's selection first")
        pts = self._base.shape if edit.space == "shape" else self._base.cage
        return {g: h.transform(default_center=pts[h.indices].mean(axis=0)) for g, h in enumerate(edit.handles)}
