"""The status bar fits the window: at 700x500 no widget lies over another or past the window's edge
(also during a build, progress bar and all), a long message is cut with "…" and whole in its tooltip
and the message log, and new frame rates, edge errors and messages re-lay nothing out."""

from __future__ import annotations

import pytest
from qtpy import QtCore, QtGui, QtWidgets

from hybridedit.viewer.window.status_widgets import MessageLine, StatusField, StatusRow
from support.window_driving import key, mouse_drag, wait_loaded

Qt = QtCore.Qt

LONG = ("Loaded creature.ply: cage 1,600 vertices (cage 1.2 s, binding 4.0 s); a cage of 9,999,999 vertices is more "
        "than half this shape's 32,000 vertices: using 5% (about 1,600) · input repaired: merged 312 duplicate "
        "vertices;\ndropped 4 degenerate faces;\nclosed 2 holes (File ▸ Mesh Info…)")


def shown_in_status_bar(w) -> dict[str, QtCore.QRect]:
    """Every visible widget of the status bar that draws something (the row's own widgets, not the row),
    with its geometry in the window's coordinates."""
    sb = w.statusBar()
    found = {}
    for child in sb.findChildren(QtWidgets.QWidget):
        if not child.isVisible() or isinstance(child, StatusRow):
            continue
        if child.parentWidget() not in (sb, w.status.row):
            continue  # (parts of a widget: the progress bar's, the button's)
        top_left = child.mapTo(w, QtCore.QPoint(0, 0))
        name = child.text() if isinstance(child, (StatusField, QtWidgets.QPushButton)) else type(child).__name__
        found[f"{name or type(child).__name__} #{len(found)}"] = QtCore.QRect(top_left, child.size())
    return found


def assert_fits(w) -> dict[str, QtCore.QRect]:
    shown = shown_in_status_bar(w)
    inside = w.rect()
    for name, r in shown.items():
        assert r.width() > 0 and inside.contains(r), (name, r, inside)
    names = list(shown)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            assert not shown[a].intersects(shown[b]), (a, shown[a], b, shown[b])
    return shown


def narrow(qtbot, w, width: int = 700, height: int = 500) -> None:
    w.resize(width, height)
    qtbot.waitUntil(lambda: w.width() == width and w.height() == height, timeout=5000)
    qtbot.wait(100)  # (the status bar's layout and the row's)


class LayoutRequests(QtCore.QObject):
    def __init__(self, *widgets) -> None:
        super().__init__()
        self.seen: list[str] = []
        self.widgets = widgets
        for widget in widgets:
            widget.installEventFilter(self)

    def eventFilter(self, obj, ev) -> bool:  # noqa: N802
        if ev.type() == QtCore.QEvent.Type.LayoutRequest:
            self.seen.append(type(obj).__name__)
        return False

    def stop(self) -> None:
        for widget in self.widgets:
            widget.removeEventFilter(self)


def test_at_700x500_nothing_overlaps_and_a_long_message_is_cut_whole_elsewhere(qtbot, win):
    w = win
    narrow(qtbot, w)
    w.status.message(LONG)
    qtbot.wait(50)
    shown = assert_fits(w)
    # the message and the edge error at least; a field that does not fit is hidden, not drawn over another
    assert any(n.startswith("MessageLine") for n in shown) and any(n.startswith("edge error") for n in shown)
    assert w.status.message_label.width() >= w.status.message_label.minimumWidth()
    # the message: two lines, the second cut with "…"; whole in the tooltip and in the log
    label = w.status.message_label
    lines = label.shown_lines()
    assert len(lines) == 2 and lines[1].endswith("…") and label.is_cut()
    assert " ".join(lines).rstrip("…").split()[:6] == LONG.split()[:6]
    fm = label.fontMetrics()
    assert all(fm.horizontalAdvance(line) <= label.width() for line in lines)
    tip = QtGui.QTextDocumentFragment.fromHtml(label.toolTip()).toPlainText()
    assert " ".join(LONG.split()) in " ".join(tip.split())
    assert w.status.current_message() == LONG
    assert LONG.splitlines()[0] in w.status.log.toPlainText() and LONG.splitlines()[-1] in w.status.log.toPlainText()
    # a short one is not cut
    w.status.message("Back to the rest pose")
    assert label.shown_lines() == ["Back to the rest pose"] and not label.is_cut()
    # the fields' texts, hidden ones too, when hovering the row
    st = w.status
    hidden = [f for f in (st.time_label, st.size_label, st.sel_label, st.error_label) if not f.isVisible()]
    assert hidden and w.status.time_label in hidden  # (at 700 px the timing is the first to give way)


def test_a_click_on_the_message_shows_the_message_log(qtbot, win):
    w = win
    w.status.message(LONG)
    assert not w.status.log_dock.isVisible()
    qtbot.mouseClick(w.status.message_label, Qt.MouseButton.LeftButton, pos=QtCore.QPoint(10, 8))
    qtbot.waitUntil(w.status.log_dock.isVisible, timeout=3000)
    assert w.actions_["messages"].isChecked()
    assert LONG.splitlines()[-1] in w.status.log.toPlainText()


def test_a_wide_window_shows_every_field(qtbot, win):
    w = win
    narrow(qtbot, w, 1280, 900)
    assert_fits(w)
    for field in (w.status.time_label, w.status.size_label, w.status.sel_label, w.status.error_label):
        assert field.isVisible(), field.text()
    # and a narrow one gives the fields' room back to them when it widens again
    narrow(qtbot, w)
    assert not w.status.time_label.isVisible()
    narrow(qtbot, w, 1280, 900)
    assert w.status.time_label.isVisible()
    # a message on two lines, and fields as wide as a drag with two handle groups makes them: all still shown
    w.status.timer.stop()
    w.status.message(LONG)
    w.status.time_label.setText("24 fps · engine 12.5 ms · render 140 ms")
    w.status.sel_label.setText("ROI 12,345 · handle 1,234 (group 2 of 3) · fixed 45,678")
    w.status.error_label.setText("edge error 12.34 % (polished)")
    qtbot.wait(100)
    assert_fits(w)
    st = w.status
    assert all(f.isVisible() for f in (st.time_label, st.size_label, st.sel_label, st.error_label))
    assert w.status.message_label.is_cut() and len(w.status.message_label.shown_lines()) == 2


def test_during_a_build_the_progress_bar_stays_inside_the_window(qtbot, win, make_blob, gate):
    w = win
    narrow(qtbot, w)
    assert w.loading.open_mesh(make_blob(3))
    qtbot.waitUntil(lambda: w.jobs.progress.format() == "binding %p%", timeout=20000)
    qtbot.wait(50)
    shown = assert_fits(w)
    bar, cancel = w.jobs.progress, w.jobs.cancel_button
    assert bar.isVisible() and cancel.isVisible() and any(n.startswith("Cancel") for n in shown)
    assert bar.width() >= w.jobs.PROGRESS_MIN
    # the bar's text is readable: it fits the bar
    assert bar.fontMetrics().horizontalAdvance(bar.text()) < bar.width()
    gate.set()
    wait_loaded(qtbot, w)
    qtbot.wait(50)
    assert not bar.isVisible() and not cancel.isVisible()
    assert_fits(w)


def test_new_frame_rates_edge_errors_and_messages_re_lay_nothing_out(qtbot, win):
    w = win
    narrow(qtbot, w)
    w.status.time_label.setText("00 fps · engine 00.0 ms · render 000 ms")
    qtbot.wait(50)
    watch = LayoutRequests(w, w.statusBar(), w.status.row)
    for k in range(30):
        w.status.time_label.setText(f"{k} fps · engine {k / 7:.1f} ms · render {k} ms")
        w.status.error_label.setText(f"edge error {k / 9:.2f} %")
        w.status.message(LONG if k % 2 else f"message {k}")
        QtWidgets.QApplication.processEvents()
    qtbot.wait(50)
    watch.stop()
    assert watch.seen == []
    assert_fits(w)


@pytest.mark.parametrize("width", [700, 1000])
def test_a_row_places_by_priority_and_shrinks_only_what_may_shrink(qtbot, width):
    win = QtWidgets.QMainWindow()
    qtbot.addWidget(win)
    row = StatusRow(reserve=lambda: 300)
    a, b, c = (StatusField(t) for t in ("first field of the row", "second field", "third field, widest of all"))
    bar = QtWidgets.QProgressBar()
    row.add(a, 3)
    row.add(b, 1)
    row.add(c, 2)
    row.add(bar, 0, preferred=400, minimum=100, wanted=False)
    win.statusBar().addWidget(MessageLine(2), 1)
    win.statusBar().addPermanentWidget(row)
    win.resize(width, 300)
    win.show()
    qtbot.waitExposed(win)
    qtbot.wait(50)
    room = width - 300
    taken = row.layout_of(room)
    assert b in taken  # the first priority is always placed when it fits
    assert sum(taken.values()) + row.SPACING * (len(taken) - 1) <= room
    row.set_wanted(bar, True)
    qtbot.wait(50)
    taken = row.layout_of(row.width())
    assert bar in taken and 100 <= taken[bar] <= 400 and bar.isVisible()
    # the widgets shown keep their order, against the right edge, one after the other
    shown = sorted((w for w in (a, b, c, bar) if w.isVisible()), key=lambda w: w.x())
    order = [w for w in (a, b, c, bar) if w.isVisible()]
    assert shown == order
    assert shown[-1].geometry().right() == row.width() - 1
    for left, right in zip(shown, shown[1:]):
        assert left.geometry().right() < right.x()


def test_a_brush_stroke_is_not_a_frame_rate(qtbot, win):
    """The timing field gives a drag's frames per second; the renders of a brush stroke are none."""

    w = win
    key(qtbot, w, Qt.Key.Key_S)
    key(qtbot, w, Qt.Key.Key_B)
    c = w.view.rect().center()
    mouse_drag(qtbot, w.view, c, c + QtCore.QPoint(120, 40), steps=20)
    assert w.view.display_fps() > 0  # the stroke did render
    assert w.status.timing_text().startswith("idle")
