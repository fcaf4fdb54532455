"""A status-bar field whose changing text never re-lays the window out.

A plain ``QLabel`` whose text changes width asks its layout for room every
time, and in a ``QMainWindow`` that re-lays out the status bar, the toolbar and
the 3D view (with a geometry animation for each): the frame rate and edge error
change several times a second while dragging, and each change cost a status bar
layout, a repaint of the window's frame and an animation object. A field keeps
a fixed size that only grows (to the widest text it has shown), so a new text
is only a repaint of the field itself.
"""

from __future__ import annotations

from qtpy import QtCore, QtWidgets


class StatusField(QtWidgets.QLabel):
    """A plain-text label of fixed size that widens (never narrows) to fit its text.

    Parameters
    ----------
    text : the initial text.
    template : a text at least as wide as the usual ones (sets the initial width).
    parent : the parent widget.

    Examples
    --------
    >>> field = StatusField("", template="000 fps")  # doctest: +SKIP
    >>> field.setText("24 fps")  # no layout request: the width already fits  # doctest: +SKIP
    """

    PADDING = 8
    """Pixels beside the text."""

    def __init__(self, text: str = "", *, template: str = "", parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.setTextFormat(QtCore.Qt.TextFormat.PlainText)
        fm = self.fontMetrics()
        self.setFixedHeight(fm.height() + 2)
        self.setFixedWidth(self._needed(template) if template else 0)
        self.setText(text)

    def _needed(self, text: str) -> int:
        return self.fontMetrics().horizontalAdvance(text) + self.PADDING

    def setText(self, text: str) -> None:  # noqa: N802 (Qt's name)
        """Show ``text``; the field widens first if it does not fit (the only case that re-lays out)."""
        if text == self.text():
            return
        need = self._needed(text) if text else 0
        if need > self.maximumWidth():
            self.setFixedWidth(need)
        super().setText(text)
