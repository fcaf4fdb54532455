"""Undo, redo and Reset Pose in the window (Edit menu)."""

from __future__ import annotations

from .slot_errors import guarded


class UndoMixin:
    """The Edit menu's history commands of a :class:`~.main_window.MainWindow` (a mixin); the
    history itself is the ``session``'s (:class:`~..model.history.History`)."""

    @guarded
    def undo(self) -> None:
        """Edit ▸ Undo: the session one step back (a selection, a drag, a polish, a rebuild, ...)."""
        if self.session is None or self.controller.busy:
            return
        self.settle_and_stop_polish()
        label = self.session.history.undo_label()
        if self.session.undo():
            self.unsaved.set_modified(not self.unsaved.pose_saved())
            self.refresh_all()
            self.status.message(f"Undid: {label}")

    @guarded
    def redo(self) -> None:
        """Edit ▸ Redo."""
        if self.session is None or self.controller.busy:
            return
        self.settle_and_stop_polish()
        label = self.session.history.redo_label()
        if self.session.redo():
            self.unsaved.set_modified(not self.unsaved.pose_saved())
            self.refresh_all()
            self.status.message(f"Redid: {label}")

    @guarded
    def reset_pose(self) -> None:
        """Edit ▸ Reset Pose: back to the rest pose, the selection kept (one undo step)."""
        if self.session is None or self.controller.busy:
            return
        self.settle_and_stop_polish()
        self.session.reset_pose()
        self.unsaved.set_modified(not self.unsaved.pose_saved())
        self.refresh_all()
        self.status.message("Back to the rest pose")
