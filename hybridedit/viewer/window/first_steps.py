"""The first-steps hint: a small panel in the 3D view's corner that says which keys to press first.

It is shown when a window opens, until the first selection (then it is gone for the rest of that
window's life), and never again once dismissed with its × button or Esc: that is remembered as the
flag :data:`DISMISSED` (:mod:`hybridedit.fileio.user_flags`, in the user cache folder). The
off-screen ``--screenshot`` mode makes no window, so it never shows there.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

from qtpy import QtCore, QtGui, QtWidgets

from ...fileio.user_flags import flag_set, set_flag
from .help_texts import FIRST_STEPS

DISMISSED = "first-steps-dismissed"
"""The user flag set when the hint is dismissed."""


class FirstStepsPanel(QtWidgets.QWidget):
    """The hint's panel: its text and a × button, on a dark ground.

    A native child window of the view, as :class:`~..render.view.OutlineOverlay` is: nothing Qt
    paints shows through the view's native render window, and for the same reason it cannot be
    see-through; it is kept small and in the top-left corner instead.

    Parameters
    ----------
    parent : the 3D view.
    """

    MARGIN = 10  # from the view's edges, pixels

    def __init__(self, parent: QtWidgets.QWidget) -> None:
        super().__init__(parent)
        self.setObjectName("firstSteps")
        self.setAttribute(QtCore.Qt.WidgetAttribute.WA_NativeWindow)
        self.setAttribute(QtCore.Qt.WidgetAttribute.WA_StyledBackground)
        self.setStyleSheet("#firstSteps { background: rgb(38, 42, 50); border: 1px solid rgb(110, 116, 128);"
                           " border-radius: 4px; } QLabel { color: rgb(232, 234, 238); }"
                           " QToolButton { color: rgb(232, 234, 238); border: none; font-size: 15px; }"
                           " QToolButton:hover { color: white; background: rgb(70, 76, 88); }")
        self.text = QtWidgets.QLabel(FIRST_STEPS, self)
        self.text.setTextFormat(QtCore.Qt.TextFormat.RichText)
        self.close_button = QtWidgets.QToolButton(self)
        self.close_button.setText("×")
        self.close_button.setToolTip("Close this hint for good (Esc)")
        self.close_button.setCursor(QtCore.Qt.CursorShape.PointingHandCursor)
        layout = QtWidgets.QHBoxLayout(self)
        layout.setContentsMargins(12, 8, 6, 10)
        layout.addWidget(self.text)
        layout.addWidget(self.close_button, 0, QtCore.Qt.AlignmentFlag.AlignTop)
        self.adjustSize()
        self.move(self.MARGIN, self.MARGIN)
        self.hide()


@runtime_checkable
class HintHost(Protocol):
    """What :class:`FirstSteps` asks of the window (:class:`~.main_window.MainWindow`): the 3D view to
    show the panel on."""

    @property
    def view(self) -> QtWidgets.QWidget: ...


class FirstSteps(QtCore.QObject):
    """The first-steps hint of a :class:`~.main_window.MainWindow`.

    Parameters
    ----------
    window : the window (:class:`HintHost`).

    Attributes
    ----------
    panel : the panel on the view (:class:`FirstStepsPanel`).
    """

    def __init__(self, window: HintHost) -> None:
        super().__init__(window.view)
        self.w = window
        self.panel = FirstStepsPanel(window.view)
        self.panel.close_button.clicked.connect(self.dismiss)
        if not flag_set(DISMISSED):
            self.panel.show()
            self.panel.raise_()
            QtWidgets.QApplication.instance().installEventFilter(self)  # Esc, wherever the focus is

    @property
    def shown(self) -> bool:
        """Whether the hint is up (on the view once the window is shown)."""
        return not self.panel.isHidden()

    def selected(self) -> None:
        """A selection was made: the hint has done its job in this window (it is shown in the next one)."""
        self._hide()

    def dismiss(self) -> None:
        """× or Esc: the hint goes, and is never shown again (:data:`DISMISSED`)."""
        if self.panel.isHidden():
            return
        self._hide()
        set_flag(DISMISSED)  # (a cache folder that cannot be written: shown again next time, nothing worse)

    def _hide(self) -> None:
        self.panel.hide()
        QtWidgets.QApplication.instance().removeEventFilter(self)

    def eventFilter(self, obj: QtCore.QObject, ev: QtCore.QEvent) -> bool:  # noqa: N802
        """Esc pressed in the window while the hint is shown dismisses it (a build under way takes Esc first:
        its Cancel shortcut)."""
        if (ev.type() == QtCore.QEvent.Type.KeyPress and isinstance(ev, QtGui.QKeyEvent)
                and ev.key() == QtCore.Qt.Key.Key_Escape and isinstance(obj, QtWidgets.QWidget)
                and obj.window() is self.w.view.window() and not self.panel.isHidden()):
            self.dismiss()
            return True
        return False
