"""Nothing is lost: the unsaved-pose question (each choice, real clicks), Rebuild keeping pose and undo,
the keyboard after the cage box, and the status bar's frame rate."""

from __future__ import annotations

import re

import numpy as np
import pytest
from qtpy import QtCore, QtWidgets

from hybridedit.fileio.meshfiles import read_mesh, write_mesh
from support.window_driving import (
    drag_tip, drop_events, key, mouse_drag, projected, select_tip, settled, to_widget, wait_loaded,
)

Qt = QtCore.Qt
Btn = QtWidgets.QMessageBox.StandardButton


def press_on_handle(qtbot, w) -> QtCore.QPoint:
    """ROI: the right half; handle: the right end; Drag mode and the left button down on the handle.
    Returns where it was pressed."""
    s = select_tip(w)
    key(qtbot, w, Qt.Key.Key_D)
    dc, _ = projected(w, s.handle_centroid()[None])
    a = to_widget(w, dc[0])
    qtbot.mousePress(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, a)
    return a


def answer(qtbot, w, button) -> list:
    """Click ``button`` in the unsaved-pose question as soon as it shows; returns what was asked."""
    asked = []

    def click():
        box = w.files.unsaved_box
        if box is None or not box.isVisible():
            QtCore.QTimer.singleShot(20, click)
            return
        asked.append(box.text())
        qtbot.mouseClick(box.button(button), Qt.MouseButton.LeftButton)

    QtCore.QTimer.singleShot(20, click)
    return asked


def drop(w, path) -> None:
    mime = QtCore.QMimeData()
    mime.setUrls([QtCore.QUrl.fromLocalFile(str(path))])
    for ev in drop_events(QtCore.QPointF(w.view.rect().center()), mime):
        QtWidgets.QApplication.sendEvent(w, ev)


@pytest.fixture
def other_mesh(tmp_path, make_blob):
    p = tmp_path / "other.off"
    write_mesh(p, make_blob(3))
    return p


def test_title_marks_an_unsaved_pose(qtbot, win, tmp_path):
    w = win
    assert w.windowTitle() == "hybridedit — blob.obj[*]" and not w.isWindowModified()
    drag_tip(qtbot, w)
    assert w.unsaved.modified and w.isWindowModified()
    assert w.files.save_to(tmp_path / "posed.obj")
    assert not w.isWindowModified()


def test_a_long_save_shows_its_progress(qtbot, win, tmp_path, monkeypatch):
    from hybridedit.viewer.window import file_actions as files

    monkeypatch.setattr(files, "PROGRESS_AFTER_MS", 0)  # a small mesh saves at once: show it anyway
    shown = []
    original = files.SaveProgress.__call__

    def spy(self, step, fraction):
        original(self, step, fraction)
        shown.append((step, self.dialog.isVisible(), self.dialog.value(), self.dialog.labelText()))

    monkeypatch.setattr(files.SaveProgress, "__call__", spy)
    w = win
    drag_tip(qtbot, w)
    assert w.files.save_to(tmp_path / "posed.obj")
    # the opened file's structure is read again, then the new one written, each shown with its progress
    steps = [st for st, _, _, _ in shown]
    assert steps[0] == "reading blob.obj" and steps[-1] == "writing posed.obj"
    assert all(visible for _, visible, _, _ in shown)
    assert shown[-1][2] == 100 and shown[-1][3] == "Writing posed.obj…"
    qtbot.wait(20)
    assert not any(d.isVisible() for d in w.findChildren(QtWidgets.QProgressDialog))
    assert np.allclose(read_mesh(tmp_path / "posed.obj").vertices, w.session.shown_positions)


def test_save_as_names_the_new_file_in_the_title(qtbot, win, tmp_path, monkeypatch, other_mesh):
    w = win
    drag_tip(qtbot, w)
    assert w.windowTitle() == "hybridedit — blob.obj[*]" and w.isWindowModified()
    out = tmp_path / "posed.ply"
    monkeypatch.setattr(QtWidgets.QFileDialog, "getSaveFileName", staticmethod(lambda *a, **k: (str(out), "")))
    w.actions_["save_as"].trigger()
    assert out.exists()
    assert w.windowTitle() == "hybridedit — posed.ply[*]" and not w.isWindowModified() and not w.unsaved.modified
    # the next change marks the new file's title; the question before dropping it names that file
    drag_tip(qtbot, w)
    assert w.windowTitle() == "hybridedit — posed.ply[*]" and w.isWindowModified()
    asked = answer(qtbot, w, Btn.Cancel)
    assert not w.loading.open_path(other_mesh)
    assert asked and asked[0].startswith("The pose of posed.ply is not saved.")
    # Save writes to it again, the title stays
    w.actions_["save"].trigger()
    assert w.windowTitle() == "hybridedit — posed.ply[*]" and not w.isWindowModified()
    # another shape: its own name, nothing saved yet
    assert w.loading.open_path(other_mesh)
    wait_loaded(qtbot, w)
    qtbot.waitUntil(lambda: w.session is not None and w.session.path == other_mesh, timeout=30000)
    assert w.windowTitle() == "hybridedit — other.off[*]" and not w.isWindowModified()


@pytest.mark.parametrize("how", ["open", "drop"])
def test_open_or_drop_asks_before_dropping_the_pose(qtbot, win, other_mesh, tmp_path, monkeypatch, how):
    w = win
    s = w.session
    drag_tip(qtbot, w)
    posed = s.shape_positions.copy()

    def go():
        if how == "open":
            w.loading.open_path(other_mesh)
        else:
            drop(w, other_mesh)
        qtbot.wait(300)

    # Cancel: nothing happens
    asked = answer(qtbot, w, Btn.Cancel)
    go()
    assert asked and "not saved" in asked[0] and "other.off" in asked[0]
    assert w.jobs.worker is None and w.session is s and np.array_equal(s.shape_positions, posed)
    # Save: the pose is written first (Save As, as nothing was saved yet), then the other mesh opens
    out = tmp_path / "saved.ply"
    monkeypatch.setattr(QtWidgets.QFileDialog, "getSaveFileName", staticmethod(lambda *a, **k: (str(out), "")))
    answer(qtbot, w, Btn.Save)
    go()
    wait_loaded(qtbot, w)
    qtbot.waitUntil(lambda: w.session is not s, timeout=30000)
    assert np.array_equal(read_mesh(out).vertices, posed)
    assert "other.off" in w.windowTitle() and not w.unsaved.modified
    # Discard: the pose is dropped without a file
    drag_tip(qtbot, w)
    s2 = w.session
    answer(qtbot, w, Btn.Discard)
    go()
    wait_loaded(qtbot, w)
    qtbot.waitUntil(lambda: w.session is not s2, timeout=30000)
    assert not w.unsaved.modified


def test_quit_asks_before_dropping_the_pose(qtbot, win, tmp_path, monkeypatch):
    w = win
    drag_tip(qtbot, w)
    posed = w.session.shape_positions.copy()
    answer(qtbot, w, Btn.Cancel)
    assert not w.close()
    assert w.isVisible()
    # Save, with the save dialog cancelled: nothing is written and the window stays
    monkeypatch.setattr(QtWidgets.QFileDialog, "getSaveFileName", staticmethod(lambda *a, **k: ("", "")))
    answer(qtbot, w, Btn.Save)
    assert not w.close() and w.isVisible()
    # Save to a file: written, then the window closes
    out = tmp_path / "quit.obj"
    monkeypatch.setattr(QtWidgets.QFileDialog, "getSaveFileName", staticmethod(lambda *a, **k: (str(out), "")))
    answer(qtbot, w, Btn.Save)
    assert w.close()
    assert np.array_equal(read_mesh(out).vertices, posed)


def test_quit_discard_closes(qtbot, win):
    w = win
    drag_tip(qtbot, w)
    answer(qtbot, w, Btn.Discard)
    assert w.close()


def test_rebuild_asks_then_keeps_the_pose_and_the_undo_history(qtbot, win):
    w = win
    s = w.session
    drag_tip(qtbot, w)
    posed = s.shape_positions.copy()
    n_old = s.n_cage
    steps = len(s.history)
    rest = s.mesh.vertices
    moved = np.linalg.norm(posed - rest, axis=1)
    w.cage_control.set_value(90)
    answer(qtbot, w, Btn.Cancel)
    assert not w.loading.rebuild() and w.jobs.worker is None and s.n_cage == n_old
    answer(qtbot, w, Btn.Discard)
    assert w.loading.rebuild()
    wait_loaded(qtbot, w)
    qtbot.waitUntil(lambda: s.n_cage != n_old, timeout=30000)
    assert w.session is s and abs(s.n_cage - 90) < 10
    # the same edit solved on the new cage: the tip is where it was dragged, the far end did not move
    new = s.shape_positions.copy()
    tip = rest[:, 0] > 1.9
    far = rest[:, 0] < -1.7
    assert np.linalg.norm(new[tip] - posed[tip], axis=1).max() < 0.1 * moved[tip].min()
    assert np.abs(new[far] - rest[far]).max() < 1e-3
    assert np.allclose(w.scene.parts.drawn_points(), new, atol=1e-5)
    assert w.scene.points_poly.n_points == s.n_cage
    # the undo history stayed: undo the rebuild (back to the old cage and its exact pose), then the drag
    assert len(s.history) == steps + 1 and s.history.undo_label() == "rebuild cage"
    # (Edit > Undo: without a window manager, Xvfb gives no window the keyboard after a modal box)
    w.actions_["undo"].trigger()
    assert s.n_cage == n_old and np.allclose(s.shape_positions, posed, atol=1e-6)  # as undo always did
    assert w.scene.points_poly.n_points == n_old
    w.actions_["undo"].trigger()
    assert np.allclose(s.shape_positions, rest, atol=1e-12) and np.allclose(s.cage_positions, s.editor.cage.vertices)
    # and redo twice is the rebuilt pose again
    for _ in range(2):
        w.actions_["redo"].trigger()
    assert abs(s.n_cage - 90) < 10 and np.allclose(s.shape_positions, new, atol=1e-9)


def test_keyboard_returns_to_the_view_after_the_cage_box(qtbot, win):
    w = win
    spin = w.cage_control.spin
    qtbot.mouseClick(spin, Qt.MouseButton.LeftButton)
    spin.setFocus()
    assert spin.hasFocus() or spin.lineEdit().hasFocus()
    spin.selectAll()
    qtbot.keyClicks(spin, "120")
    qtbot.keyClick(spin, Qt.Key.Key_Return)
    assert w.cage_control.value() == 120
    assert w.view.hasFocus()
    key(qtbot, w, Qt.Key.Key_S)  # a single-letter shortcut reaches the window again
    assert w.controller.mode == "select"


def test_status_bar_shows_displayed_fps_first(qtbot, win):
    w = win
    a = press_on_handle(qtbot, w)
    for k in range(1, 25):
        qtbot.mouseMove(w.view, a + QtCore.QPoint(0, -2 * k))
        qtbot.wait(15)
    text = w.status.timing_text()
    qtbot.mouseRelease(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, a + QtCore.QPoint(0, -48))
    settled(qtbot, w)
    m = re.match(r"(\d+) fps · frame (\d+) ms · render \d+ ms$", text)
    assert m, text
    assert "engine's solve" in w.status.time_label.toolTip()  # (the frame thread's split)
    assert int(m.group(1)) == round(w.view.display_fps()) or int(m.group(1)) > 0


def test_a_drag_re_lays_nothing_out(qtbot, win):
    """While dragging, the status bar's frame rate and edge error change several times a second:
    each change repaints its field only (a re-layout of the window, with geometry animations of the
    toolbar and the view, came every other frame on a large mesh)."""
    w = win
    a = press_on_handle(qtbot, w)
    for k in range(1, 6):  # the fields take their first texts (they may widen once)
        qtbot.mouseMove(w.view, a + QtCore.QPoint(0, -2 * k))
        qtbot.wait(60)
    requests = []

    class Watch(QtCore.QObject):
        def eventFilter(self, obj, ev):  # noqa: N802
            if ev.type() == QtCore.QEvent.Type.LayoutRequest:
                requests.append(type(obj).__name__)
            return False

    watch = Watch()
    for widget in (w, w.statusBar()):
        widget.installEventFilter(watch)
    texts = set()
    for k in range(6, 30):
        qtbot.mouseMove(w.view, a + QtCore.QPoint(0, -2 * k))
        qtbot.wait(40)
        texts.add((w.status.time_label.text(), w.status.error_label.text()))
    for widget in (w, w.statusBar()):
        widget.removeEventFilter(watch)
    qtbot.mouseRelease(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, a + QtCore.QPoint(0, -60))
    settled(qtbot, w)
    assert len(texts) >= 2  # the fields did change meanwhile
    assert requests == []


def test_an_edit_saved_at_one_cage_size_replays_at_another(qtbot, win, tmp_path, make_blob):
    w = win
    s = w.session
    drag_tip(qtbot, w)
    posed = s.shape_positions.copy()
    roles = s.selection.shape_roles()
    edit = tmp_path / "tip.json"
    assert w.files.save_edit_to(edit)
    assert "replays them to the pose on screen" in w.status.current_message()
    # the same mesh on a cage of another size
    w.unsaved.set_modified(False)
    w.cage_control.set_value(70)
    assert w.loading.open_path(s.path)
    wait_loaded(qtbot, w)
    qtbot.waitUntil(lambda: w.session is not s, timeout=30000)
    s2 = w.session
    assert abs(s2.n_cage - 70) < 10 and s2.n_cage != s.n_cage
    assert w.files.load_edit_from(edit)
    said = w.status.current_message()
    assert f"made on a cage of {s.n_cage:,} vertices and replayed on this one of {s2.n_cage:,}" in said
    V = s2.shape_positions
    # the same constraints, held exactly, and the same shape up to the cage's resolution
    assert np.array_equal(s2.selection.shape_roles(), roles)
    diag = s2.mesh.bbox_diagonal()
    held = roles != 0
    assert np.abs(V[held] - posed[held]).max() < 1e-9 * diag
    assert np.abs(V - posed).max() < 0.05 * diag
    # a different mesh refuses it in one line that says so, and keeps its state
    other = tmp_path / "other.obj"
    write_mesh(other, make_blob(3))
    w.unsaved.set_modified(False)
    assert w.loading.open_path(other)
    wait_loaded(qtbot, w)
    qtbot.waitUntil(lambda: w.session is not s2, timeout=30000)
    before = w.session.shape_positions.copy()
    assert not w.files.load_edit_from(edit)
    error = w.status.last_error
    assert "tip.json" in error and "2,562 vertices" in error and "refused" in error
    assert len(w.status.last_error.splitlines()) == 1
    assert np.array_equal(w.session.shape_positions, before)


def test_mirror_x_moves_both_sides_or_says_why_not(qtbot, win, tmp_path):
    import trimesh

    from hybridedit.core.mesh import Mesh

    w = win
    # the test blob is not symmetric: refused in words, nothing changes
    s = select_tip(w)
    w.actions_["mirror_x"].trigger()
    assert "mirror" in w.status.last_error.lower() or "symmetr" in w.status.last_error.lower()
    assert s.selection.symmetry is None and not w.actions_["mirror_x"].isChecked()
    # an exactly symmetric capsule: the mirrored end follows the mirrored drag
    sym = trimesh.creation.capsule(height=3.0, radius=0.6, count=[24, 24])
    path = tmp_path / "capsule.obj"
    write_mesh(path, Mesh(np.asarray(sym.vertices)[:, [2, 1, 0]], np.asarray(sym.faces)))  # long along X
    w.unsaved.set_modified(False)
    assert w.loading.open_path(path)
    wait_loaded(qtbot, w)
    qtbot.waitUntil(lambda: w.session is not s, timeout=30000)
    s = w.session
    w.scene.reset_camera(tilted=False)
    P = s.cage_positions
    s.selection.set_mask("roi", P[:, 0] > 0.3)
    s.selection.set_mask("handle", P[:, 0] > 1.6)
    w.sync.refresh_selection()
    w.actions_["mirror_x"].trigger()
    assert s.selection.symmetry == "x" and w.actions_["mirror_x"].isChecked()
    from hybridedit.deform.roles import handle

    roles = s.selection.cage_roles()
    assert np.any(roles[P[:, 0] < -1.6] == handle(0))  # the other end is a handle too, shown as one
    w.polisher.enabled = False
    key(qtbot, w, Qt.Key.Key_D)
    dc, _ = projected(w, s.handle_centroid()[None])
    a = to_widget(w, dc[0])
    mouse_drag(qtbot, w.view, a, a + QtCore.QPoint(0, -60), steps=6)
    settled(qtbot, w)
    rest = s.mesh.vertices
    V = s.shape_positions
    right, left = rest[:, 0] > 1.8, rest[:, 0] < -1.8
    up_r = (V[right] - rest[right])[:, 1].mean()
    up_l = (V[left] - rest[left])[:, 1].mean()
    assert up_r > 0.1 and abs(up_r - up_l) < 1e-3 * s.mesh.bbox_diagonal()


def test_save_writes_what_deform_writes_and_says_what_a_conversion_drops(qtbot, win, tmp_path):
    from hybridedit.fileio.meshfiles import read_document, write_document

    w = win
    blob = read_mesh(w.session.path)
    coloured = tmp_path / "coloured.obj"  # the blob with a colour on every vertex
    coloured.write_text("".join(f"v {x:.17g} {y:.17g} {z:.17g} 0.2 0.5 0.8\n" for x, y, z in blob.vertices)
                        + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in blob.faces))
    assert w.loading.open_path(coloured)
    wait_loaded(qtbot, w)
    assert w.session.path == coloured
    drag_tip(qtbot, w)
    shown = w.session.shown_positions.copy()
    assert np.any(shown != blob.vertices)
    assert w.files.save_to(tmp_path / "posed.obj")
    write_document(tmp_path / "api.obj", read_document(coloured).with_vertices(shown))
    assert (tmp_path / "posed.obj").read_bytes() == (tmp_path / "api.obj").read_bytes()
    assert " 0.2 0.5 0.8" in (tmp_path / "posed.obj").read_text().splitlines()[0]
    assert w.files.save_to(tmp_path / "posed.stl")
    said = w.status.current_message()
    assert said.startswith(f"Saved {tmp_path / 'posed.stl'}.") and "Note: STL cannot hold" in said
    assert "colours" in said or "colors" in said


def test_the_title_star_follows_the_pose_through_undo_redo_and_saves(qtbot, win, tmp_path):
    """`*` while the pose on display differs from the one last saved or opened, also after undo and redo."""
    w = win
    s = w.session
    assert not w.isWindowModified()
    drag_tip(qtbot, w)
    assert w.isWindowModified() and w.windowTitle().endswith("[*]")
    while s.history.can_undo():  # back to the file as it was opened: no star
        key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
    assert not w.isWindowModified()
    key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier | Qt.KeyboardModifier.ShiftModifier)
    assert not w.isWindowModified()  # (the selection: the pose is the opened one still)
    while s.history.can_redo():
        key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier | Qt.KeyboardModifier.ShiftModifier)
    assert w.isWindowModified()
    assert w.files.save_to(tmp_path / "posed.obj")
    assert not w.isWindowModified()
    key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)  # the saved pose undone: a star again
    assert w.isWindowModified()
    key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier | Qt.KeyboardModifier.ShiftModifier)
    assert not w.isWindowModified()
    key(qtbot, w, Qt.Key.Key_R, Qt.KeyboardModifier.ControlModifier)  # reset: the rest pose is not the saved one
    assert w.isWindowModified()
