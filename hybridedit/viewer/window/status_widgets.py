"""The status bar's parts: fields whose changing text never re-lays the window out, the latest
message on two lines (cut with "…", whole in its tooltip), and the row that fits the fields and
the build's progress bar into the width there is.

A plain ``QLabel`` whose text changes width asks its layout for room every
time, and in a ``QMainWindow`` that re-lays out the status bar, the toolbar and
the 3D view (with a geometry animation for each): the frame rate and edge error
change several times a second while dragging, and each change cost a status bar
layout, a repaint of the window's frame and an animation object. A field keeps
a fixed size that only grows (to the widest text it has shown), so a new text
is only a repaint of the field itself.

Fixed sizes do not shrink, so in a narrow window the fields would print over each other and run
past its edge. :class:`StatusRow` places them itself: as many as fit its width, by priority (a
field that does not fit is hidden, never drawn over another); the progress bar, first, shrinks to
fit. :class:`MessageLine` never asks for room either: it shows what fits in two lines.
"""

from __future__ import annotations

import html
from typing import Callable

from qtpy import QtCore, QtGui, QtWidgets


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

    widened = QtCore.Signal()
    """The field grew to fit a text (its :class:`StatusRow` places the fields again)."""

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
            self.widened.emit()
        super().setText(text)


def _wrapped_tooltip(text: str, hint: str, fm: QtGui.QFontMetrics, chars: int = 64) -> str:
    """``text`` as a tooltip that wraps at about ``chars`` characters (rich text: Qt's own wrapping of a
    long tooltip is a narrow column), with ``hint`` under it in italics."""
    if not text:
        return ""
    widest = max(fm.horizontalAdvance(line) for line in (text.splitlines() or [""]) + [hint])
    width = min(widest + 8, chars * fm.averageCharWidth())
    body = html.escape(text).replace("\n", "<br>") + (f"<br><i>{html.escape(hint)}</i>" if hint else "")
    return f'<table width="{width}"><tr><td>{body}</td></tr></table>'


class MessageLine(QtWidgets.QWidget):
    """The latest message: as much as fits in ``lines`` lines, the last one cut with "…" when the text
    goes on; the whole text in the tooltip. Its size never depends on the text, so a new message is a
    repaint only (no layout, the view never changes size under the mouse).

    Parameters
    ----------
    lines : the lines shown.
    hint : said under the text in the tooltip (where the messages are kept).
    min_chars : the narrowest it gets in a layout, in average characters.

    Signals
    -------
    clicked()   a click on a message (the window shows the message log)
    """

    clicked = QtCore.Signal()

    def __init__(self, lines: int = 2, *, hint: str = "", min_chars: int = 36,
                 parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self._text = ""
        self._lines = max(1, int(lines))
        self._hint = hint
        self._cache: tuple[str, int, list[str]] | None = None
        fm = self.fontMetrics()
        self.setFixedHeight(self._lines * fm.lineSpacing() + 4)
        self.setMinimumWidth(min_chars * fm.averageCharWidth())
        self.setSizePolicy(QtWidgets.QSizePolicy.Policy.Ignored, QtWidgets.QSizePolicy.Policy.Fixed)

    def text(self) -> str:
        """The whole message."""
        return self._text

    def setText(self, text: str) -> None:  # noqa: N802 (Qt's name)
        if text == self._text:
            return
        self._text = text
        self._cache = None
        self.setToolTip(_wrapped_tooltip(text, self._hint, self.fontMetrics()))
        self.update()

    def sizeHint(self) -> QtCore.QSize:  # noqa: N802
        return QtCore.QSize(self.minimumWidth(), self.height())

    def shown_lines(self) -> list[str]:
        """The lines on show at the current width (the last ends with "…" when the message is cut)."""
        width = max(self.contentsRect().width() - 4, 1)
        if self._cache is not None and self._cache[:2] == (self._text, width):
            return self._cache[2]
        flat = " ".join(self._text.split())  # (line breaks and runs of spaces: one space)
        lines: list[str] = []
        if flat:
            layout = QtGui.QTextLayout(flat, self.font())
            layout.beginLayout()
            starts = []
            while len(starts) < self._lines:
                line = layout.createLine()
                if not line.isValid():
                    break
                line.setLineWidth(width)
                starts.append((line.textStart(), line.textLength()))
            layout.endLayout()
            for k, (start, length) in enumerate(starts):
                if k == len(starts) - 1 and start + length < len(flat):
                    rest = flat[start:]
                    cut = self.fontMetrics().elidedText(rest, QtCore.Qt.TextElideMode.ElideRight, width)
                    lines.append(cut if cut != rest else rest[:-1] + "…")
                else:
                    lines.append(flat[start:start + length].rstrip())
        self._cache = (self._text, width, lines)
        return lines

    def is_cut(self) -> bool:
        """The message does not fit whole (it ends in "…"; the tooltip has it all)."""
        lines = self.shown_lines()
        return bool(lines) and " ".join(lines) != " ".join(self._text.split())

    def paintEvent(self, ev: QtGui.QPaintEvent) -> None:  # noqa: N802
        painter = QtGui.QPainter(self)
        painter.setPen(self.palette().color(QtGui.QPalette.ColorRole.WindowText))
        fm = self.fontMetrics()
        r = self.contentsRect()
        y = r.top() + 2 + fm.ascent()
        for line in self.shown_lines():
            painter.drawText(r.left() + 2, y, line)
            y += fm.lineSpacing()
        painter.end()

    def mouseReleaseEvent(self, ev: QtGui.QMouseEvent) -> None:  # noqa: N802
        if ev.button() == QtCore.Qt.MouseButton.LeftButton and self._text and self.rect().contains(ev.pos()):
            self.clicked.emit()
        super().mouseReleaseEvent(ev)


class StatusRow(QtWidgets.QWidget):
    """The status bar's right part: fields and the build's progress bar, placed by hand in the
    width the status bar gives it.

    Each widget has a priority (0 first): the widgets wanted are taken in that order while they fit,
    the others are hidden; those taken are shown in the order they were added, against the right
    edge. A widget with a ``minimum`` (the progress bar) shrinks down to it to fit. The row asks its
    status bar for room (a re-layout) only when what it would need changes: a field widened, a widget
    became wanted or not; a new text that fits is a repaint of its field only.

    Hovering the row shows every field's text (also those hidden for want of room).

    Parameters
    ----------
    reserve : returns the width the row leaves to the rest of its parent (the message, margins and size
        grip): the row asks for no more than what fits in its parent's width less that, so the room its
        hidden fields would leave goes to the message.
    """

    SPACING = 8

    def __init__(self, reserve: Callable[[], int] | None = None, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self._items: list[dict] = []
        self._hint = QtCore.QSize(0, 0)
        self._reserve = reserve
        self._watched: QtWidgets.QWidget | None = None
        self.setSizePolicy(QtWidgets.QSizePolicy.Policy.Preferred, QtWidgets.QSizePolicy.Policy.Fixed)

    def add(self, widget: QtWidgets.QWidget, priority: int, *, preferred: int | None = None,
            minimum: int | None = None, wanted: bool = True) -> None:
        """Place ``widget`` in the row (after those added before).

        Parameters
        ----------
        priority : 0 first; a widget is shown only when every wanted widget of a lower number is.
        preferred : its width when there is room (default: its fixed width, else its size hint).
        minimum : the narrowest it may shrink to; None: it is shown at its preferred width or not at all.
        wanted : shown when it fits (see :meth:`set_wanted`).
        """
        widget.setParent(self)
        self._items.append(dict(widget=widget, priority=priority, preferred=preferred, minimum=minimum,
                                wanted=wanted))
        if isinstance(widget, StatusField):
            widget.widened.connect(self._changed)
        self._changed()

    def set_wanted(self, widget: QtWidgets.QWidget, wanted: bool) -> None:
        """Show ``widget`` when it fits (True), or never (False)."""
        for item in self._items:
            if item["widget"] is widget and item["wanted"] != wanted:
                item["wanted"] = wanted
                self._changed()

    def is_wanted(self, widget: QtWidgets.QWidget) -> bool:
        return any(item["wanted"] for item in self._items if item["widget"] is widget)

    def _width(self, item: dict, shrunk: bool = False) -> int:
        if shrunk and item["minimum"] is not None:
            return item["minimum"]
        if item["preferred"] is not None:
            return item["preferred"]
        w = item["widget"]
        if w.minimumWidth() == w.maximumWidth():
            return w.maximumWidth()
        return w.sizeHint().width()

    def _wanted(self) -> list[dict]:
        return [it for it in self._items if it["wanted"]]

    def sizeHint(self) -> QtCore.QSize:  # noqa: N802
        return self._hint

    def minimumSizeHint(self) -> QtCore.QSize:  # noqa: N802
        """Room for the wanted widgets of the first priority (the progress bar shrunk, its Cancel button)."""
        wanted = self._wanted()
        if not wanted:
            return QtCore.QSize(0, self._hint.height())
        top = min(it["priority"] for it in wanted)
        first = [it for it in wanted if it["priority"] == top]
        width = sum(self._width(it, shrunk=True) for it in first) + self.SPACING * (len(first) - 1)
        return QtCore.QSize(width, self._hint.height())

    def _measure(self) -> QtCore.QSize:
        wanted = self._wanted()
        width = sum(self._width(it) for it in wanted) + self.SPACING * max(len(wanted) - 1, 0)
        parent = self.parentWidget()
        if self._reserve is not None and parent is not None:
            room = max(parent.width() - self._reserve(), self.minimumSizeHint().width())
            if room < width:
                shown = self.layout_of(room)
                width = sum(shown.values()) + self.SPACING * max(len(shown) - 1, 0)
        height = max([it["widget"].sizeHint().height() for it in self._items] +
                     [it["widget"].minimumHeight() for it in self._items] + [0])
        return QtCore.QSize(width, height)

    def _changed(self) -> None:
        hint = self._measure()
        if hint != self._hint:
            self._hint = hint
            self.updateGeometry()  # (the status bar gives the row its width again)
        self.arrange()

    def layout_of(self, width: int) -> dict[QtWidgets.QWidget, int]:
        """The widgets shown in ``width`` pixels, each with its width."""
        taken: list[dict] = []
        used = 0
        for it in sorted(self._wanted(), key=lambda it: it["priority"]):
            need = self._width(it, shrunk=True) + (self.SPACING if taken else 0)
            if used + need > width:
                if it["minimum"] is None:
                    continue  # (a narrower widget of a later priority may still fit)
                break
            taken.append(it)
            used += need
        widths = {id(it): self._width(it, shrunk=True) for it in taken}
        spare = width - used
        for it in taken:  # the shrinkable ones grow back towards their preferred width, first one first
            grow = min(spare, self._width(it) - widths[id(it)])
            if grow > 0:
                widths[id(it)] += grow
                spare -= grow
        return {it["widget"]: widths[id(it)] for it in self._items if id(it) in widths}

    def arrange(self) -> None:
        """Place the widgets that fit against the right edge, in their order; hide the others."""
        shown = self.layout_of(self.width())
        x = self.width()
        h = self.height()
        for it in reversed(self._items):
            w = it["widget"]
            if w not in shown:
                if not w.isHidden():
                    w.hide()
                continue
            width = shown[w]
            x -= width
            height = min(max(w.sizeHint().height(), w.minimumHeight()), w.maximumHeight(), h)
            geometry = QtCore.QRect(x, (h - height) // 2, width, height)
            if w.geometry() != geometry:
                w.setGeometry(geometry)
            if w.isHidden():
                w.show()
            x -= self.SPACING

    def resizeEvent(self, ev: QtGui.QResizeEvent) -> None:  # noqa: N802
        super().resizeEvent(ev)
        self.arrange()

    def eventFilter(self, obj: QtCore.QObject, ev: QtCore.QEvent) -> bool:  # noqa: N802
        if obj is self._watched and ev.type() == QtCore.QEvent.Type.Resize:
            self._changed()  # (what fits beside the message)
        return False

    def event(self, ev: QtCore.QEvent) -> bool:
        if ev.type() == QtCore.QEvent.Type.ParentChange and self._reserve is not None:
            if self._watched is not None:
                self._watched.removeEventFilter(self)
            self._watched = self.parentWidget()
            if self._watched is not None:
                self._watched.installEventFilter(self)
        if ev.type() == QtCore.QEvent.Type.LayoutRequest:
            # a child asked for room (its size limits changed, or it was shown or hidden by someone else)
            self._changed()
            return True
        if ev.type() == QtCore.QEvent.Type.ToolTip:
            texts = [it["widget"].text() for it in self._items
                     if isinstance(it["widget"], StatusField) and it["wanted"] and it["widget"].text()]
            if texts:
                QtWidgets.QToolTip.showText(ev.globalPos(), "\n".join(texts), self)
            else:
                QtWidgets.QToolTip.hideText()
            return True
        return super().event(ev)
