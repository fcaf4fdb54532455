"""Status-bar fields: new texts repaint the field and never re-lay out the window."""

from __future__ import annotations

from qtpy import QtCore, QtWidgets

from hybridedit.viewer.window.status_widgets import StatusField


class LayoutRequests(QtCore.QObject):
    """Counts the layout requests that reach the watched widgets."""

    def __init__(self, *widgets: QtWidgets.QWidget) -> None:
        super().__init__()
        self.count = 0
        for w in widgets:
            w.installEventFilter(self)

    def eventFilter(self, obj, ev) -> bool:  # noqa: N802
        if ev.type() == QtCore.QEvent.Type.LayoutRequest:
            self.count += 1
        return False


def test_texts_that_fit_change_no_layout_and_the_field_only_widens(qtbot):
    win = QtWidgets.QMainWindow()
    qtbot.addWidget(win)
    field = StatusField(template="00 fps · engine 00.0 ms")
    win.statusBar().addPermanentWidget(field)
    win.show()
    qtbot.waitExposed(win)
    qtbot.wait(50)  # (the window's own first layouts)
    width = field.width()
    assert width >= field.fontMetrics().horizontalAdvance("00 fps · engine 00.0 ms")
    watch = LayoutRequests(win, win.statusBar())
    for text in ("7 fps · engine 20.5 ms", "12 fps · engine 3.1 ms", "idle", "", "9 fps"):
        field.setText(text)
        QtWidgets.QApplication.processEvents()
        assert field.text() == text
    assert watch.count == 0 and field.width() == width
    long = "123 fps · engine 1234.5 ms · render 999 ms"
    field.setText(long)  # does not fit: the field widens (one layout), and stays that wide
    qtbot.wait(50)
    assert field.width() >= field.fontMetrics().horizontalAdvance(long) and watch.count >= 1
    wide, before = field.width(), watch.count
    field.setText("1 fps")
    qtbot.wait(50)
    assert field.width() == wide and watch.count == before


def test_a_plain_label_would_re_lay_out(qtbot):
    """The cost the field avoids: a QLabel's wider text asks the window for a new layout."""
    win = QtWidgets.QMainWindow()
    qtbot.addWidget(win)
    label = QtWidgets.QLabel("1 fps")
    win.statusBar().addPermanentWidget(label)
    win.show()
    qtbot.waitExposed(win)
    qtbot.wait(50)
    watch = LayoutRequests(win, win.statusBar())
    label.setText("12 fps · engine 3.1 ms · render 41 ms")
    QtWidgets.QApplication.processEvents()
    assert watch.count >= 1
