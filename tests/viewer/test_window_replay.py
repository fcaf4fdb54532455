"""The window's word is the file's word: whole sequences of real Qt events (selections, drags, the
polish on release, handle groups, Mirror X, successive edits, a rebuild), then Ctrl+E and Ctrl+S;
``hybridedit deform`` of the saved edit gives the saved mesh."""

from __future__ import annotations

import json

import numpy as np
from qtpy import QtCore, QtWidgets

from hybridedit import cli
from hybridedit.fileio.meshfiles import read_mesh
from hybridedit.viewer.window.main_window import MainWindow
from support.window_driving import (
    CAGE, key, mouse_drag, polished, projected, rubber_band, settled, to_widget, wait_loaded,
)

Qt = QtCore.Qt
CTRL = Qt.KeyboardModifier.ControlModifier

#: What a replay must reproduce: the window's pose to this fraction of the bounding-box diagonal.
REPLAY_TOLERANCE = 1e-6


def select_by_rectangles(qtbot, w: MainWindow, roi_from: float, handle_from: float, *, left: bool = False) -> None:
    """Select Through, target ROI, a rectangle over the cage right (or left) of x = roi_from; target Handle,
    one right (left) of x = handle_from: real key and mouse events."""
    key(qtbot, w, Qt.Key.Key_S)
    if not w.controller.select_through:
        key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.AltModifier)
    key(qtbot, w, Qt.Key.Key_R)
    rectangle(qtbot, w, roi_from, left)
    key(qtbot, w, Qt.Key.Key_H)
    rectangle(qtbot, w, handle_from, left)


def rectangle(qtbot, w: MainWindow, x_from: float, left: bool) -> None:
    if not left:
        rubber_band(qtbot, w, x_from)
        return
    P = w.session.cage_positions
    d, _ = projected(w, P)
    width, height = w.scene.display_size()
    x1 = d[P[:, 0] < x_from, 0].max() + 1.0
    mouse_drag(qtbot, w.view, to_widget(w, (3.0, 3.0)), to_widget(w, (x1, height - 3.0)))


def drag_handle(qtbot, w: MainWindow, dx: int, dy: int) -> None:
    """Drag mode, press on the active group's handle, move, release; wait for the settle and the polish."""
    key(qtbot, w, Qt.Key.Key_D)
    dc, _ = projected(w, w.session.handle_centroid()[None])
    a = to_widget(w, dc[0])
    mouse_drag(qtbot, w.view, a, a + QtCore.QPoint(dx, -dy))
    settled(qtbot, w)
    polished(qtbot, w, timeout=30000)


def save_edit_and_mesh(qtbot, w: MainWindow, folder, name: str, monkeypatch):
    """Ctrl+E (the file dialog answered with ``name``.json), then the pose saved as an OBJ."""
    edit = folder / f"{name}.json"
    monkeypatch.setattr(QtWidgets.QFileDialog, "getSaveFileName", staticmethod(lambda *a, **k: (str(edit), "")))
    key(qtbot, w, Qt.Key.Key_E, CTRL)
    assert edit.is_file(), w.status.current_message()
    said = w.status.current_message()
    saved = folder / f"{name}-window.obj"
    assert w.files.save_to(saved)
    return edit, saved, said


def replay_error(src, edit, saved, folder, *extra) -> float:
    """``hybridedit deform`` of ``edit``: its largest distance to the saved mesh, in diagonals."""
    out = folder / f"{edit.stem}-deform.obj"
    assert cli.main(["deform", str(src), "-o", str(out), "--edit", str(edit), "-q", *extra]) == 0
    A, B = read_mesh(out).vertices, read_mesh(saved).vertices
    return float(np.abs(A - B).max() / read_mesh(src).bbox_diagonal())


def test_drag_release_polish_then_ctrl_e_replays_to_the_saved_mesh(qtbot, win, blob_file, tmp_path, monkeypatch):
    w = win
    s = w.session
    select_by_rectangles(qtbot, w, 0.0, 1.4)
    drag_handle(qtbot, w, 0, 90)
    assert "polished" in w.status.error_label.text()
    edit, saved, said = save_edit_and_mesh(qtbot, w, tmp_path, "one", monkeypatch)
    assert "1 step (1 selection, 1 polish)" in said and "replays them to the pose on screen" in said
    data = json.loads(edit.read_text())
    assert data["version"] == 3 and len(data["steps"]) == 1
    step = data["steps"][0]
    assert step["iterations"] == s.settle_frames * s.settle_iterations and step["polish"] >= 1
    assert np.linalg.norm(step["handles"][0]["translate"]) > 0.1  # the drag itself, not the identity
    err = replay_error(blob_file, edit, saved, tmp_path)
    print(f"replay error, drag + polish: {err:.2g} of the diagonal")
    assert err <= REPLAY_TOLERANCE
    # the same file loaded in the window (Ctrl+L's path) gives the same pose again
    w.files.load_edit_from(edit)
    assert np.abs(s.shape_positions - read_mesh(saved).vertices).max() <= REPLAY_TOLERANCE * s.mesh.bbox_diagonal()


def test_two_groups_and_a_second_drag_of_the_first(qtbot, win, blob_file, tmp_path, monkeypatch):
    w = win
    select_by_rectangles(qtbot, w, -3.0, 1.4)  # ROI: everything
    drag_handle(qtbot, w, 0, 60)
    key(qtbot, w, Qt.Key.Key_G, CTRL)  # a second handle group: the other end
    key(qtbot, w, Qt.Key.Key_S)
    rectangle(qtbot, w, -1.4, left=True)
    assert w.session.selection.n_groups == 2
    drag_handle(qtbot, w, 40, -50)
    key(qtbot, w, Qt.Key.Key_G)  # back to the first group, dragged again from the polished pose
    drag_handle(qtbot, w, 30, 0)
    edit, saved, _ = save_edit_and_mesh(qtbot, w, tmp_path, "groups", monkeypatch)
    data = json.loads(edit.read_text())
    assert len(data["steps"]) == 3 and data["steps"][2]["continues"] and len(data["steps"][2]["handles"]) == 2
    err = replay_error(blob_file, edit, saved, tmp_path)
    print(f"replay error, two groups, three drags: {err:.2g} of the diagonal")
    assert err <= REPLAY_TOLERANCE


def test_mirror_x_with_its_polish(qtbot, win, capsule_file, tmp_path, monkeypatch):
    w = win
    w.cage_control.set_value(CAGE)
    assert w.loading.open_path(capsule_file)
    wait_loaded(qtbot, w)
    qtbot.waitUntil(lambda: w.session is not None and w.session.path == capsule_file, timeout=60000)
    w.scene.reset_camera(tilted=False)
    key(qtbot, w, Qt.Key.Key_X, Qt.KeyboardModifier.ShiftModifier)
    assert w.session.selection.symmetry == "x"
    select_by_rectangles(qtbot, w, 0.0, 1.4)
    drag_handle(qtbot, w, 0, 80)
    edit, saved, _ = save_edit_and_mesh(qtbot, w, tmp_path, "mirror", monkeypatch)
    assert json.loads(edit.read_text())["steps"][0]["symmetry"] == "x"
    err = replay_error(capsule_file, edit, saved, tmp_path)
    print(f"replay error, Mirror X: {err:.2g} of the diagonal")
    assert err <= REPLAY_TOLERANCE


def test_successive_edits_across_a_rebuild(qtbot, win, blob_file, tmp_path, monkeypatch):
    """First edit, polished; a second selection, polished; the cage rebuilt at another size (the pose carried
    over); a third edit on the new cage. deform builds each cage the steps ran on and gives the pose."""
    w = win
    s = w.session
    select_by_rectangles(qtbot, w, 0.0, 1.4)
    drag_handle(qtbot, w, 0, 80)
    key(qtbot, w, Qt.Key.Key_A, Qt.KeyboardModifier.ControlModifier | Qt.KeyboardModifier.ShiftModifier)
    select_by_rectangles(qtbot, w, 0.0, -1.4, left=True)
    drag_handle(qtbot, w, 0, -60)
    w.unsaved.set_modified(False)  # (the rebuild would ask to save first)
    w.cage_control.set_value(90)
    key(qtbot, w, Qt.Key.Key_B, CTRL)
    qtbot.waitUntil(lambda: w.jobs.worker is None and w.session.n_cage != CAGE, timeout=60000)
    assert abs(w.session.n_cage - 90) < 10
    drag_handle(qtbot, w, 40, 0)  # the second selection, carried over to the new cage
    edit, saved, _ = save_edit_and_mesh(qtbot, w, tmp_path, "rebuilt", monkeypatch)
    data = json.loads(edit.read_text())
    cages = [st["cage"]["vertices"] for st in data["steps"]]
    assert len(set(cages)) == 2 and cages[-1] == w.session.n_cage
    err = replay_error(blob_file, edit, saved, tmp_path)
    print(f"replay error, two edits, a rebuild, a third edit: {err:.2g} of the diagonal")
    assert err <= REPLAY_TOLERANCE
    # --cage given: replayed on that cage as asked, with a note, close but not the same
    far = replay_error(blob_file, edit, saved, tmp_path, "--cage", str(CAGE))
    assert far < 0.05
    del s


def test_an_unsettled_drag_says_so(qtbot, win, tmp_path, monkeypatch):
    w = win
    w.actions_["settle"].trigger()
    assert not w.posing.settle_on_release
    select_by_rectangles(qtbot, w, 0.0, 1.4)
    drag_handle(qtbot, w, 0, 80)
    edit, _, said = save_edit_and_mesh(qtbot, w, tmp_path, "unsettled", monkeypatch)
    assert "not settled" in said
    assert "iterations" not in json.loads(edit.read_text())["steps"][0]
