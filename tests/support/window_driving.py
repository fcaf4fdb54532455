"""Driving the editor window in tests as a user does: real Qt mouse and key events (pytest-qt's
``qtbot``), and where they land on the screen.

The window itself, loaded with the test shape, is the ``win`` fixture of tests/viewer/conftest.py.
"""

from __future__ import annotations

from contextlib import contextmanager

import numpy as np
from qtpy import QtCore, QtWidgets

from hybridedit.viewer.model.picking import project_points, rectangle_hits

CAGE = 150
"""The cage size the window tests build at (vertices)."""
Qt = QtCore.Qt


def wait_loaded(qtbot, w, timeout: int = 180000) -> None:
    """Wait until the build under way has ended and a shape is on display."""
    qtbot.waitUntil(lambda: w.jobs.worker is None and w.session is not None, timeout=timeout)


@contextmanager
def opened_window(qtbot, *, cage_size, path=None, mesh=None, size=(1000, 760)):
    """A window shown, active (window shortcuts need it) and with the keyboard on its view, the shape of
    ``path`` (a file) or ``mesh`` (a Mesh) loaded; closed afterwards, here and not by qtbot (an unsaved
    pose or kept poses would ask first), also when loading fails: no window is left open to confuse the next test."""
    from hybridedit.viewer.window.main_window import MainWindow

    w = MainWindow(cage_size=cage_size)
    w.resize(*size)
    w.show()
    qtbot.waitExposed(w)
    w.activateWindow()
    qtbot.waitActive(w)
    w.view.setFocus()
    try:
        assert w.loading.open_path(path) if path is not None else w.loading.open_mesh(mesh)
        wait_loaded(qtbot, w)
        yield w
    finally:
        if w.session is not None:
            w.session.poses.mark_saved()  # (kept poses are unsaved work too)
        w.unsaved.set_modified(False)
        w.close()
        w.deleteLater()


def drop_events(pos: QtCore.QPointF, mime: QtCore.QMimeData):
    """The drag-enter and drop events of ``mime`` dropped at widget point ``pos`` with the left button (the
    enter event takes a QPointF from PySide6 6.12, a QPoint before it)."""
    from qtpy import QtGui

    args = (Qt.DropAction.CopyAction, mime, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier)
    try:
        enter = QtGui.QDragEnterEvent(pos, *args)
    except TypeError:
        enter = QtGui.QDragEnterEvent(pos.toPoint(), *args)
    return enter, QtGui.QDropEvent(pos, *args)


def to_widget(w, display_xy) -> QtCore.QPoint:
    """The view's widget point of a display point (VTK's pixels, y up)."""
    return w.view.to_widget(float(display_xy[0]), float(display_xy[1]))


def projected(w, pts: np.ndarray):
    """(display points (n, 3), in front of the camera (n,)) of world points, as the view shows them now."""
    C, size = w.scene.composite_matrix(), w.scene.display_size()
    return project_points(pts, C, size)


def around(w, mask: np.ndarray, margin: float = 8.0) -> tuple[QtCore.QPoint, QtCore.QPoint]:
    """Corners of a rectangle around the cage points of ``mask`` on screen (widget coordinates)."""
    d, _ = projected(w, w.session.cage_positions[mask])
    return (to_widget(w, (d[:, 0].min() - margin, d[:, 1].max() + margin)),
            to_widget(w, (d[:, 0].max() + margin, d[:, 1].min() - margin)))


def mouse_drag(qtbot, widget, a: QtCore.QPoint, b: QtCore.QPoint, steps: int = 6,
               modifier=Qt.KeyboardModifier.NoModifier) -> None:
    """Press at a, move in steps to b, release: real Qt mouse events."""
    qtbot.mousePress(widget, Qt.MouseButton.LeftButton, modifier, a)
    for k in range(1, steps + 1):
        p = a + (b - a) * (k / steps)
        qtbot.mouseMove(widget, p)
        qtbot.wait(5)
    qtbot.mouseRelease(widget, Qt.MouseButton.LeftButton, modifier, b)
    qtbot.wait(10)


def settled(qtbot, w) -> None:
    """Wait until the settle after a drag is done and drawn."""
    qtbot.waitUntil(lambda: not w.dragging.settle_timer.isActive(), timeout=20000)
    qtbot.wait(10)


def polished(qtbot, w, timeout: int = 20000) -> None:
    """Wait until the polish on release has ended and its pose is on display."""
    qtbot.waitUntil(lambda: w.posing.polished is not None and w.polisher.worker is None, timeout=timeout)
    qtbot.wait(10)


def key(qtbot, w, k, modifier=Qt.KeyboardModifier.NoModifier) -> None:
    """A key press on the 3D view (the window's shortcuts take it)."""
    qtbot.keyClick(w.view, k, modifier)
    qtbot.wait(5)


def rubber_band(qtbot, w, x_from: float, modifier=Qt.KeyboardModifier.NoModifier) -> np.ndarray:
    """Drag a rectangle over every cage vertex right of world x = x_from (front view); returns the hit mask."""
    s = w.session
    P = s.cage_positions
    d, front = projected(w, P)
    width, height = w.scene.display_size()
    x0 = d[P[:, 0] > x_from, 0].min() - 1.0
    a = (x0, 3.0)
    b = (width - 3.0, height - 3.0)
    mouse_drag(qtbot, w.view, to_widget(w, a), to_widget(w, b), modifier=modifier)
    # what the rectangle covers, in the display coordinates the window saw
    qa = w.view.to_display(QtCore.QPointF(to_widget(w, a)))
    qb = w.view.to_display(QtCore.QPointF(to_widget(w, b)))
    return rectangle_hits(d, front, qa, qb)


def select_tip(w):
    """ROI: the right half of the test shape's cage; handle: its right end (set directly, and drawn).
    Returns the session."""
    s = w.session
    P = s.cage_positions
    s.selection.set_mask("roi", P[:, 0] > 0.0)
    s.selection.set_mask("handle", P[:, 0] > 1.4)
    w.sync.refresh_selection()
    return s


def handle_point(w) -> QtCore.QPoint:
    """Where the active handle group's centroid is on the view (widget coordinates)."""
    dc, _ = projected(w, w.session.handle_centroid()[None])
    return to_widget(w, dc[0])


def drag_tip(qtbot, w, pixels: int = 80) -> None:
    """ROI: the right half; handle: the right end; drag it up with the mouse (no polish: the engine's pose)."""
    w.polisher.enabled = False
    select_tip(w)
    key(qtbot, w, Qt.Key.Key_D)
    a = handle_point(w)
    mouse_drag(qtbot, w.view, a, a + QtCore.QPoint(0, -pixels), steps=6)
    settled(qtbot, w)


def select_tip_to_drag(qtbot, w) -> None:
    """:func:`select_tip`, then Drag mode (D): the tip is ready to be dragged with the mouse."""
    select_tip(w)
    key(qtbot, w, Qt.Key.Key_D)


def look_down_minus_z(scene) -> None:
    """Frame the scene's shape from +Z, +Y up on screen, whatever its opening view (which shows a shape's
    broad side: parts lined up along Z open side by side)."""
    cam = scene.renderer.GetActiveCamera()
    cam.SetPosition(*(np.array(cam.GetFocalPoint()) + [0.0, 0.0, cam.GetDistance()]))
    cam.SetViewUp(0.0, 1.0, 0.0)
    scene.renderer.ResetCamera(scene.shape.bounds)


def answer_file_dialog(qtbot, path) -> list:
    """Answer the next real file dialog as soon as it shows: ``path`` in its name box and Enter (None: Escape).
    Returns [(its title, the folder it opened in)] once answered."""
    seen = []

    def answer():
        d = QtWidgets.QApplication.activeModalWidget()
        if not isinstance(d, QtWidgets.QFileDialog) or not d.isVisible():
            QtCore.QTimer.singleShot(20, answer)
            return
        seen.append((d.windowTitle(), d.directory().absolutePath()))
        edit = d.findChild(QtWidgets.QLineEdit, "fileNameEdit")
        if path is None:
            qtbot.keyClick(edit, Qt.Key.Key_Escape)
        else:
            edit.setText(str(path))  # (typed, its completer's popup would take the Enter)
            qtbot.keyClick(edit, Qt.Key.Key_Return)

    QtCore.QTimer.singleShot(20, answer)
    return seen
