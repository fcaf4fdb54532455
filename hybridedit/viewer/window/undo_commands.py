"""Undo, redo and Reset Pose in the window, and the unsaved-pose mark they move: the title's ``*``
while the pose on display is not the one last saved (or opened).
"""

from __future__ import annotations

import numpy as np

from .status_bar import guarded


class UndoMixin:
    """The Edit menu's history commands and the ``modified`` mark of a :class:`~.main_window.MainWindow`
    (a mixin); the history itself is the ``session``'s (:class:`~..model.history.History`).

    Attributes
    ----------
    modified : the pose on display is not saved (shown as ``*`` in the title).
    """

    @guarded
    def undo(self) -> None:
        """Edit ▸ Undo: the session one step back (a selection, a drag, a polish, a rebuild, ...)."""
        if self.session is None or self.controller.busy:
            return
        self.settle_and_stop_polish()
        label = self.session.history.undo_label()
        if self.session.undo():
            self.set_modified(not self.pose_saved())
            self.refresh_all()
            self.message(f"Undid: {label}")

    @guarded
    def redo(self) -> None:
        """Edit ▸ Redo."""
        if self.session is None or self.controller.busy:
            return
        self.settle_and_stop_polish()
        label = self.session.history.redo_label()
        if self.session.redo():
            self.set_modified(not self.pose_saved())
            self.refresh_all()
            self.message(f"Redid: {label}")

    @guarded
    def reset_pose(self) -> None:
        """Edit ▸ Reset Pose: back to the rest pose, the selection kept (one undo step)."""
        if self.session is None or self.controller.busy:
            return
        self.settle_and_stop_polish()
        self.session.reset_pose()
        self.set_modified(not self.pose_saved())
        self.refresh_all()
        self.message("Back to the rest pose")

    # ------------------------------------------------------------------ unsaved changes
    def set_modified(self, modified: bool) -> None:
        """The pose on display is (not) saved; ``False`` also remembers it as the saved pose, so that undo and
        redo back to it clear the title's ``*`` again."""
        if not modified:
            self._saved_pose = self._pose_reference()
        if bool(modified) == self.modified:
            return  # (every drag frame says so: no window-title event each time)
        self.modified = bool(modified)
        self.setWindowModified(self.modified)

    def _pose_reference(self) -> np.ndarray | None:
        """The pose on display, as an array to compare with later: the undo history's own copy of it when it
        has one (no copy made), else a copy."""
        s = self.session
        if s is None:
            return None
        shown = s.shown_positions
        kept = getattr(getattr(s.history.current, "engine", None), "shape", None)
        return kept if kept is not None and np.array_equal(kept, shown) else shown.copy()

    def pose_saved(self) -> bool:
        """The pose on display is the one last saved (or opened)."""
        s, ref = self.session, self._saved_pose
        return s is not None and ref is not None and ref.shape == s.shown_positions.shape and \
            np.array_equal(ref, s.shown_positions)

    def update_title(self) -> None:
        """The title names the shape's file (the one last saved to by Save As, else the one opened), with
        ``*`` while the pose on display is not saved."""
        name = self.files.document_name
        self.setWindowTitle("hybridedit" if name is None else f"hybridedit — {name}[*]")
        self.setWindowModified(self.modified)
