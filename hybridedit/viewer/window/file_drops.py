"""Files dropped on the window: a mesh opens, an edit file (.json) is loaded."""

from __future__ import annotations

from qtpy import QtCore, QtGui

from .file_actions import dropped_path
from .slot_errors import guarded


class DropsMixin:
    """The drag-and-drop events of a :class:`~.main_window.MainWindow` (a mixin): a dropped file goes to
    ``open_path`` or to ``files.load_edit_from``."""

    def dragEnterEvent(self, ev: QtGui.QDragEnterEvent) -> None:  # noqa: N802
        """A file dragged over the window is taken when it is one local mesh or edit file
        (:func:`~.file_actions.dropped_path`)."""
        if dropped_path(ev.mimeData()) is not None:
            ev.acceptProposedAction()
        else:
            ev.ignore()

    def dragMoveEvent(self, ev: QtGui.QDragMoveEvent) -> None:  # noqa: N802
        if dropped_path(ev.mimeData()) is not None:
            ev.acceptProposedAction()

    @guarded
    def dropEvent(self, ev: QtGui.QDropEvent) -> None:  # noqa: N802
        """A dropped file: an edit file (.json) is loaded, anything else opened as a mesh."""
        p = dropped_path(ev.mimeData())
        if p is None:
            ev.ignore()
            return
        ev.acceptProposedAction()
        # let the drop finish before any question is asked
        if p.suffix.lower() == ".json":
            QtCore.QTimer.singleShot(0, lambda: self.files.load_edit_from(p))
        else:
            QtCore.QTimer.singleShot(0, lambda: self.open_path(p))
