"""Files dropped on the window: a mesh opens, an edit file (.json) is loaded."""

from __future__ import annotations

import os
from typing import Protocol, runtime_checkable

from qtpy import QtCore, QtGui, QtWidgets

from .file_actions import dropped_path
from .slot_errors import guarded


@runtime_checkable
class Opens(Protocol):
    """The loading as a drop sees it: a mesh file opened."""

    def open_path(self, path: str | os.PathLike) -> bool: ...


@runtime_checkable
class LoadsEdits(Protocol):
    """The file actions as a drop sees them: an edit file applied."""

    def load_edit_from(self, path: str | os.PathLike) -> bool: ...


@runtime_checkable
class ShowsErrors(Protocol):
    """The status bar, where an unexpected error in a drop is shown (:func:`~.slot_errors.guarded`)."""

    def show_error(self, title: str, text: str) -> None: ...


@runtime_checkable
class DropsHost(Protocol):
    """What :class:`FileDrops` asks of the window (:class:`~.main_window.MainWindow`)."""

    @property
    def loading(self) -> Opens: ...
    @property
    def files(self) -> LoadsEdits: ...
    @property
    def status(self) -> ShowsErrors: ...


class FileDrops(QtCore.QObject):
    """The drag-and-drop events of the main window, taken by an event filter on it: one local mesh or
    edit file is accepted (:func:`~.file_actions.dropped_path`); a dropped mesh goes to
    ``loading.open_path``, an edit file to ``files.load_edit_from``.

    Parameters
    ----------
    window : the window, as far as a drop needs it (:class:`DropsHost`).
    target : the widget files are dropped on (the main window: it accepts drops from now on).
    """

    def __init__(self, window: DropsHost, target: QtWidgets.QWidget) -> None:
        super().__init__(target)
        self.w = window
        target.setAcceptDrops(True)
        target.installEventFilter(self)

    def eventFilter(self, obj: QtCore.QObject, ev: QtCore.QEvent) -> bool:  # noqa: N802
        t = ev.type()
        E = QtCore.QEvent.Type
        if t == E.DragEnter:
            self.drag_enter(ev)
        elif t == E.DragMove:
            self.drag_move(ev)
        elif t == E.Drop:
            self.drop(ev)
        else:
            return False
        return True

    def drag_enter(self, ev: QtGui.QDragEnterEvent) -> None:
        """A file dragged over the window is taken when it is one local mesh or edit file."""
        if dropped_path(ev.mimeData()) is not None:
            ev.acceptProposedAction()
        else:
            ev.ignore()

    def drag_move(self, ev: QtGui.QDragMoveEvent) -> None:
        if dropped_path(ev.mimeData()) is not None:
            ev.acceptProposedAction()

    @guarded
    def drop(self, ev: QtGui.QDropEvent) -> None:
        """A dropped file: an edit file (.json) is loaded, anything else opened as a mesh."""
        p = dropped_path(ev.mimeData())
        if p is None:
            ev.ignore()
            return
        ev.acceptProposedAction()
        # let the drop finish before any question is asked
        if p.suffix.lower() == ".json":
            QtCore.QTimer.singleShot(0, lambda: self.w.files.load_edit_from(p))
        else:
            QtCore.QTimer.singleShot(0, lambda: self.w.loading.open_path(p))
