"""The editor window driven through real Qt mouse and key events (pytest-qt, under Xvfb)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import numpy as np
import pytest
from qtpy import QtCore, QtWidgets

from hybridedit import cli
from hybridedit.fileio.meshfiles import read_mesh, write_mesh
from hybridedit.viewer.model import gizmo as gz
from hybridedit.viewer.window.main_window import MainWindow
from support.window_driving import (
    CAGE, drop_events, key, mouse_drag, projected, rubber_band, settled, to_widget, wait_loaded,
)

Qt = QtCore.Qt


def select_roi_and_handle(qtbot, w: MainWindow) -> tuple[np.ndarray, np.ndarray]:
    key(qtbot, w, Qt.Key.Key_S)  # Select mode
    assert w.controller.mode == "select"
    key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.AltModifier)  # Select Through: the far side of the ends too
    assert w.controller.select_through
    key(qtbot, w, Qt.Key.Key_R)  # target ROI
    roi = rubber_band(qtbot, w, 0.0)
    key(qtbot, w, Qt.Key.Key_H)  # target handle
    handle = rubber_band(qtbot, w, 1.4)
    return roi, handle


# ---------------------------------------------------------------------------- tests


def test_select_drag_undo_redo_save_and_replay(qtbot, win, blob_file, tmp_path):
    w = win
    s = w.session
    w.actions_["polish"].trigger()  # this test checks the engine's pose on screen (the polish has its own tests)
    assert not w.polisher.enabled
    rest_cage = s.cage_positions
    rest_shape = s.shape_positions.copy()
    assert w.status.size_label.text().startswith("shape 2,562 v")

    roi, handle = select_roi_and_handle(qtbot, w)
    assert np.array_equal(s.selection.roi, roi) and np.array_equal(s.selection.handle, handle)
    P = rest_cage
    assert roi.sum() > 20 and np.all(P[roi, 0] > -0.2) and np.all(roi[P[:, 0] > 0.05])
    assert 5 <= handle.sum() < roi.sum() and np.all(P[handle, 0] > 1.3)
    assert "ROI" in w.status.sel_label.text()

    # Drag mode: drag the handle 80 px up the screen (world +Y in the front view)
    key(qtbot, w, Qt.Key.Key_D)
    center = s.handle_centroid()
    dc, _ = projected(w, center[None])
    a = to_widget(w, dc[0])
    b = a + QtCore.QPoint(0, -80)
    C, size = w.scene.composite_matrix(), w.scene.display_size()
    t = gz.screen_plane_translation(w.view.to_display(QtCore.QPointF(a)), w.view.to_display(QtCore.QPointF(b)),
                                    center, C, size)
    assert t[1] > 0.3 and abs(t[0]) < 1e-9 and abs(t[2]) < 1e-9
    mouse_drag(qtbot, w.view, a, b, steps=8)
    settled(qtbot, w)

    moved_cage = s.cage_positions
    assert np.allclose(moved_cage[handle] - rest_cage[handle], t, atol=1e-9)  # the handle follows the mouse
    fixed = ~roi & ~handle
    assert np.array_equal(moved_cage[fixed], rest_cage[fixed])  # fixed cage vertices stay
    V = s.shape_positions.copy()
    M = s.editor.M.tocsr()
    # shape vertices that depend on the handle's cage vertices only... follow it (up to the engine's
    # rotated rest-shape residual, which is small)
    w_handle = np.asarray(M[:, np.flatnonzero(handle)].sum(axis=1)).ravel()
    follow = w_handle > 0.999
    assert follow.sum() > 10
    assert np.allclose(V[follow] - rest_shape[follow], t, atol=0.05 * np.linalg.norm(t))
    # ... the handle side moved up, in world space
    tip = rest_shape[:, 0] > 1.7
    assert np.all(V[tip, 1] - rest_shape[tip, 1] > 0.8 * t[1])
    # shape vertices bound to fixed cage vertices only did not move (but for the engine's rotated
    # rest-shape residual: fixed cage vertices next to free ones turn a little)
    only_fixed = np.diff(M[:, np.flatnonzero(~fixed)].tocsr().indptr) == 0
    assert only_fixed.sum() > 100
    assert np.abs(V[only_fixed] - rest_shape[only_fixed]).max() < 0.01 * np.linalg.norm(t)
    far = rest_shape[:, 0] < -1.0
    assert np.abs(V[far] - rest_shape[far]).max() < 1e-3 * np.linalg.norm(t)
    # what is drawn is what the engine computed
    assert np.allclose(w.scene.parts.drawn_points(), V, atol=1e-5)
    assert w.status.error_label.text().startswith("edge error")

    # undo (Ctrl+Z) restores the rest pose, redo (Ctrl+Shift+Z) the drag
    key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
    assert np.array_equal(s.cage_positions, rest_cage)
    assert np.allclose(s.shape_positions, rest_shape, atol=1e-12)
    assert np.allclose(w.scene.parts.drawn_points(), rest_shape, atol=1e-5)
    assert np.array_equal(s.selection.handle, handle)  # the selection is still there
    key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier | Qt.KeyboardModifier.ShiftModifier)
    assert np.allclose(s.shape_positions, V, atol=1e-12)
    # undo twice more: the handle selection goes away too
    key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
    key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
    assert not s.selection.handle.any() and np.array_equal(s.selection.roi, roi)
    for _ in range(2):
        key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier | Qt.KeyboardModifier.ShiftModifier)
    assert np.allclose(s.shape_positions, V, atol=1e-12)

    # save writes the shown vertices
    out = tmp_path / "out.obj"
    assert w.files.save_to(out)
    assert np.array_equal(read_mesh(out).vertices, s.shape_positions)
    assert np.array_equal(read_mesh(out).faces, s.mesh.faces)

    # the edit file replays in batch to the shape shown
    edit_path = tmp_path / "edit.json"
    assert w.files.save_edit_to(edit_path)
    data = json.loads(edit_path.read_text())
    # in shape space, with the mesh's fingerprint: it fits any cage of this shape
    step = data["steps"][-1]
    assert step["space"] == "shape" and data["mesh"]["vertices"] == 2562
    assert step["handles"][0]["indices"] == np.flatnonzero(s.editor.vertex_roles == 1).tolist()
    assert np.array_equal(s.editor.cage_roles == 1, handle)  # the cage picks, exactly
    roles = s.selection.shape_roles()
    assert np.array_equal(roles, s.editor.vertex_roles)
    assert np.allclose(step["handles"][0]["translate"], t, atol=1e-12)
    replay = tmp_path / "replay.obj"
    rc = cli.main(["deform", str(blob_file), "-o", str(replay), "--edit", str(edit_path), "--cage", str(CAGE), "-q"])
    assert rc == 0
    diag = s.mesh.bbox_diagonal()
    assert np.abs(read_mesh(replay).vertices - V).max() < 1e-6 * diag

    # reset the pose, then load the edit back
    key(qtbot, w, Qt.Key.Key_R, Qt.KeyboardModifier.ControlModifier)
    assert np.array_equal(s.cage_positions, rest_cage)
    assert w.files.load_edit_from(edit_path)
    assert np.abs(s.shape_positions - V).max() < 1e-9 * diag
    assert np.array_equal(s.selection.shape_roles(), roles)


def test_gizmo_rotate_and_translate(qtbot, win, tmp_path, blob_file):
    w = win
    s = w.session
    P = s.cage_positions
    s.selection.set_mask("roi", P[:, 0] > 0.0)
    s.selection.set_mask("handle", P[:, 0] > 1.4)
    w.sync.refresh_selection()
    qtbot.wait(20)
    key(qtbot, w, Qt.Key.Key_C)  # gizmo works in Camera mode too
    g = w.scene.gizmo
    assert g.visible and np.allclose(g.center, s.handle_centroid())
    # translate: grab the X arrow near its tip, pull it 60 px right
    tip, _ = projected(w, (g.center + [0.85 * g.length, 0, 0])[None])
    a = to_widget(w, tip[0])
    mouse_drag(qtbot, w.view, a, a + QtCore.QPoint(60, 0))
    settled(qtbot, w)
    dx = s.cage_positions[s.selection.handle] - P[s.selection.handle]
    assert np.all(dx[:, 0] > 0.1) and np.allclose(dx, dx[0], atol=1e-9) and np.allclose(dx[:, 1:], 0, atol=1e-9)
    # rotate: grab the Z ring (facing the viewer) on its right and pull it up: positive turn about +Z
    center = s.handle_centroid()
    before = s.cage_positions[s.selection.handle]
    r = gz.RING_RATIO * g.length
    right, _ = projected(w, (center + [r * np.cos(0.3), r * np.sin(0.3), 0])[None])
    a = to_widget(w, right[0])
    mouse_drag(qtbot, w.view, a, a + QtCore.QPoint(0, -40))
    settled(qtbot, w)
    after = s.cage_positions[s.selection.handle]
    rel0, rel1 = before - center, after - center
    ang = np.degrees(np.arctan2(rel1[:, 1], rel1[:, 0]) - np.arctan2(rel0[:, 1], rel0[:, 0]))
    ang = (ang + 180) % 360 - 180
    assert np.all(ang > 5) and np.ptp(ang) < 1e-6
    assert np.allclose(np.linalg.norm(rel1, axis=1), np.linalg.norm(rel0, axis=1))
    # the saved edit has the rotation and replays it
    edit_path = tmp_path / "rot.json"
    assert w.files.save_edit_to(edit_path)
    data = json.loads(edit_path.read_text())
    rot = data["steps"][-1]["handles"][0]["rotate"]
    assert abs(rot["degrees"] - ang[0]) < 1e-6 and np.allclose(np.abs(rot["axis"]), [0, 0, 1])
    replay = tmp_path / "rot.obj"
    rc = cli.main(["deform", str(blob_file), "-o", str(replay), "--edit", str(edit_path), "--cage", str(CAGE), "-q"])
    assert rc == 0
    assert np.abs(read_mesh(replay).vertices - s.shape_positions).max() < 1e-6 * s.mesh.bbox_diagonal()


def test_brush_modifiers_clear_invert(qtbot, win):
    w = win
    s = w.session
    key(qtbot, w, Qt.Key.Key_S)
    key(qtbot, w, Qt.Key.Key_B)
    assert w.controller.tool == "brush"
    w.options.brush_spin.setValue(40)
    P = s.cage_positions
    d, front = projected(w, P)
    i_right, i_left = int(np.argmax(P[:, 0])), int(np.argmin(P[:, 0]))
    # plain stroke replaces: a short stroke at the right end
    a = to_widget(w, d[i_right])
    mouse_drag(qtbot, w.view, a, a + QtCore.QPoint(-10, 0), steps=2)
    first = s.selection.roi.copy()
    assert first[i_right] and not first[i_left]
    # Shift adds the left end
    a = to_widget(w, d[i_left])
    mouse_drag(qtbot, w.view, a, a + QtCore.QPoint(10, 0), steps=2, modifier=Qt.KeyboardModifier.ShiftModifier)
    assert s.selection.roi[i_right] and s.selection.roi[i_left] and np.all(s.selection.roi[first])
    # Ctrl removes the right end again
    a = to_widget(w, d[i_right])
    mouse_drag(qtbot, w.view, a, a, steps=1, modifier=Qt.KeyboardModifier.ControlModifier)
    assert not s.selection.roi[i_right] and s.selection.roi[i_left]
    # one stroke is one undo step
    n_hist = len(s.history)
    before = s.selection.roi.copy()
    key(qtbot, w, Qt.Key.Key_I, Qt.KeyboardModifier.ControlModifier)  # invert
    assert np.array_equal(s.selection.roi, ~before)
    key(qtbot, w, Qt.Key.Key_A, Qt.KeyboardModifier.ControlModifier | Qt.KeyboardModifier.ShiftModifier)  # clear
    assert not s.selection.roi.any()
    assert len(s.history) == n_hist + 2
    key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
    key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
    assert np.array_equal(s.selection.roi, before)
    # the colours follow: cage points and shape tint
    cols = np.asarray(w.scene.points_poly.point_data["role"])
    assert not np.array_equal(cols[i_left], cols[i_right])
    assert "brush" in w.controller.tool


def test_errors_leave_the_state_intact(qtbot, win, tmp_path):
    w = win
    s = w.session
    # dragging with an empty handle: a message, nothing moves
    key(qtbot, w, Qt.Key.Key_D)
    c = w.view.rect().center()
    mouse_drag(qtbot, w.view, c, c + QtCore.QPoint(30, 30))
    assert w.status.last_error and "handle is empty" in w.status.last_error
    assert not s.is_posed()
    # an unreadable mesh file
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nf 1 2 3\n")
    w.status.last_error = None
    w.loading.open_path(bad)
    wait_loaded(qtbot, w)
    assert w.session is s and w.status.last_error and "bad.obj" in w.status.last_error
    # a bad edit file
    bad_edit = tmp_path / "bad.json"
    bad_edit.write_text(json.dumps({"handle": [999999], "space": "cage"}))
    assert not w.files.load_edit_from(bad_edit)
    assert "out of range" in w.status.last_error and w.session is s and not s.is_posed()
    bad_edit.write_text("{not json")
    assert not w.files.load_edit_from(bad_edit)
    assert "not valid JSON" in w.status.last_error
    # saving an edit without a handle
    assert not w.files.save_edit_to(tmp_path / "e.json")
    assert "handle is empty" in w.status.last_error
    # unsupported output format
    assert not w.files.save_to(tmp_path / "out.xyz")
    assert not (tmp_path / "out.xyz").exists()


def test_save_never_overwrites_the_input_without_asking(qtbot, win, blob_file, tmp_path, monkeypatch):
    w = win
    s = w.session
    inp = tmp_path / "input.obj"
    inp.write_bytes(blob_file.read_bytes())
    s.path = inp
    original = inp.read_bytes()
    asked = []
    monkeypatch.setattr(w.status, "confirm", lambda title, text: asked.append(title) or False)
    assert not w.files.save_to(inp)
    assert asked == ["Overwrite the input file?"] and inp.read_bytes() == original
    monkeypatch.setattr(w.status, "confirm", lambda title, text: True)
    assert w.files.save_to(inp)
    # the Save As dialog path goes through the same check
    monkeypatch.setattr(w.status, "confirm", lambda title, text: asked.append(title) or False)
    monkeypatch.setattr(QtWidgets.QFileDialog, "getSaveFileName", staticmethod(lambda *a, **k: (str(inp), "")))
    assert not w.files.save_as_dialog()
    assert asked[-1] == "Overwrite the input file?"
    out = tmp_path / "other"
    monkeypatch.setattr(QtWidgets.QFileDialog, "getSaveFileName",
                        staticmethod(lambda *a, **k: (str(out), "STL (*.stl)")))
    assert w.files.save_as_dialog()
    assert (tmp_path / "other.stl").exists()


def test_drop_shortcuts_cage_toggle_and_rebuild(qtbot, win, blob_file, tmp_path, make_blob):
    w = win
    s = w.session
    # Help > Shortcuts lists the actions with their keys
    w.actions_["shortcuts"].trigger()
    dlg = w.dialogs.shortcuts_dialog
    qtbot.waitExposed(dlg)
    texts = {dlg.table.item(r, 1).text() for r in range(dlg.table.rowCount())}
    assert {"Undo", "Redo", "Drag Mode", "Reset Pose", "Save Edit…"} <= texts
    dlg.close()
    # the cage wireframe is off by default; W shows it and hides it again
    assert not w.scene.cage_front.GetVisibility()
    key(qtbot, w, Qt.Key.Key_W)
    assert w.scene.cage_front.GetVisibility() and w.scene.cage_ghost.GetVisibility()
    key(qtbot, w, Qt.Key.Key_W)
    assert not w.scene.cage_front.GetVisibility()
    # rebuild at another size keeps the selection (through the shape)
    P = s.cage_positions
    s.selection.set_mask("handle", P[:, 0] > 1.4)
    w.cage_control.set_value(80)
    assert w.loading.rebuild()
    wait_loaded(qtbot, w)
    assert w.session is s and abs(s.n_cage - 80) < 10  # the same session goes on, on the new cage
    h = w.session.selection.handle
    assert h.any() and np.all(w.session.cage_positions[h, 0] > 1.0)
    # dropping a mesh file opens it
    other = tmp_path / "sphere.off"
    m = make_blob(3)
    write_mesh(other, m)
    mime = QtCore.QMimeData()
    mime.setUrls([QtCore.QUrl.fromLocalFile(str(other))])
    enter, drop = drop_events(QtCore.QPointF(w.view.rect().center()), mime)
    QtWidgets.QApplication.sendEvent(w, enter)
    assert enter.isAccepted()
    QtWidgets.QApplication.sendEvent(w, drop)
    wait_loaded(qtbot, w)
    qtbot.waitUntil(lambda: w.session is not None and w.session.mesh.n_vertices == m.n_vertices, timeout=30000)
    assert "sphere.off" in w.windowTitle()


def test_worker_cancel_keeps_the_previous_state(qtbot, win, tmp_path, make_blob):
    w = win
    s = w.session
    big = tmp_path / "big.obj"
    write_mesh(big, make_blob(6))  # 41K vertices: binding takes a while
    w.cage_control.set_value(0.05)
    during_build = []  # at each tick of a timer on the UI thread: is a build running?
    timer = QtCore.QTimer()
    timer.timeout.connect(lambda: during_build.append(w.jobs.busy))
    timer.start(20)
    stages = []

    def on_progress(stage, fraction):
        stages.append(stage)
        if stage == "binding" and fraction > 0:
            w.jobs.cancel_button.click()

    assert w.loading.open_path(big)
    w.jobs.worker.progress.connect(on_progress)
    assert w.jobs.progress.isVisible() and w.jobs.cancel_button.isVisible()
    assert not w.actions_["open"].isEnabled()
    wait_loaded(qtbot, w)
    timer.stop()
    assert "binding" in stages
    assert w.session is s and s.mesh.n_vertices == 2562
    assert "Cancelled" in w.status.current_message()
    assert not w.jobs.progress.isVisible() and w.actions_["open"].isEnabled()
    # the event loop kept running while the worker built the cage: the UI thread's timer fired meanwhile
    assert sum(during_build) >= 2, during_build
    # and the window still works
    P = s.cage_positions
    s.selection.set_mask("handle", P[:, 0] > 1.4)
    s.begin_drag()
    s.drag_to(np.eye(4))


@pytest.mark.slow  # (a new process: Python, VTK and a cage build of its own)
def test_screenshot_mode(tmp_path, blob_file):
    """`hybridedit --screenshot out.png mesh`: no window, status 0, a PNG with the shape and the cage."""
    from PIL import Image

    from hybridedit.viewer.app import render_screenshot

    out = tmp_path / "shot.png"
    env = dict(os.environ)
    r = subprocess.run([sys.executable, "-m", "hybridedit", "--screenshot", str(out), "--cage", str(CAGE),
                        str(blob_file)], env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    img = np.asarray(Image.open(out).convert("RGB")).astype(np.float64)
    assert img.shape[0] > 400 and img.shape[1] > 400
    assert img.std() > 10  # not blank
    def cage_coloured(im):  # teal / blue: the cage lines and points, unlike the warm shape and grey background
        return (im[..., 1] - im[..., 0] > 40) & (im[..., 2] - im[..., 0] > 40)

    # as the window first shows it: the shape, no cage in the way
    warm = (img[..., 0] - img[..., 2] > 15)  # the shape's warm colour against the grey-blue background
    assert warm.mean() > 0.05
    cage_img = tmp_path / "cage.png"
    assert render_screenshot(blob_file, cage_img, CAGE, show_cage=True) == 0  # with the wireframe
    img2 = np.asarray(Image.open(cage_img).convert("RGB")).astype(np.float64)
    cage_px = cage_coloured(img2)
    assert cage_px.sum() > 2000 and cage_coloured(img).sum() < 0.05 * cage_px.sum()
    # errors: one line, status 2
    r = subprocess.run([sys.executable, "-m", "hybridedit", "--screenshot", str(out), str(tmp_path / "nope.obj")],
                       env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "nope.obj" in r.stderr and "Traceback" not in r.stderr


@pytest.mark.slow  # (a new process: Python, VTK and a cage build of its own)
def test_screenshot_without_a_display_says_nothing_but_its_result(tmp_path, blob_file):
    """No X display (a server, CI): the render is off-screen through EGL, with no warning from VTK's
    X window on the terminal."""
    from PIL import Image

    out = tmp_path / "headless.png"
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "VTK_DEFAULT_OPENGL_WINDOW")}
    r = subprocess.run([sys.executable, "-m", "hybridedit", "--screenshot", str(out), "--cage", str(CAGE),
                        str(blob_file)], env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stderr == "" and r.stdout == ""
    img = np.asarray(Image.open(out).convert("RGB")).astype(np.float64)
    assert (img[..., 0] - img[..., 2] > 15).mean() > 0.05  # the shape is there


def test_launcher_opens_the_default_mesh_and_exits_zero(qapp, blob_file, monkeypatch):
    """`hybridedit` with no argument opens cli.DEFAULT_MESH in the window; closing it returns 0."""
    monkeypatch.setattr(cli, "DEFAULT_MESH", blob_file)
    seen = {}
    before = set(map(id, QtWidgets.QApplication.topLevelWidgets()))  # (a window a failed test left open)
    deadline = time.monotonic() + 180

    def check():
        wins = [w for w in QtWidgets.QApplication.topLevelWidgets()
                if isinstance(w, MainWindow) and w.isVisible() and id(w) not in before]
        if wins and wins[0].session is not None and wins[0].jobs.worker is None:
            seen["vertices"] = wins[0].session.mesh.n_vertices
            seen["title"] = wins[0].windowTitle()
            wins[0].close()
        elif time.monotonic() > deadline:  # never hang the suite: close it and fail below
            seen["timed out"] = True
            for w in wins:
                w.close()
        else:
            QtCore.QTimer.singleShot(50, check)

    QtCore.QTimer.singleShot(50, check)
    hook = sys.excepthook
    assert cli.main(["--cage", str(CAGE)]) == 0
    assert seen == {"vertices": 2562, "title": "hybridedit — blob.obj[*]"}  # [*]: the unsaved marker
    assert sys.excepthook is hook


def test_first_run_compiles_the_kernels_in_words(qtbot, blob_file, tmp_path, monkeypatch):
    """With no record of the warm-up (a plain pip install), the build thread compiles first and says so."""
    from hybridedit import warmup

    monkeypatch.setenv("HYBRIDEDIT_CACHE_DIR", str(tmp_path))
    assert not warmup.is_warm()
    w = MainWindow(cage_size=CAGE)
    qtbot.addWidget(w)
    w.show()
    stages = []
    assert w.loading.open_path(blob_file)
    w.jobs.worker.progress.connect(lambda stage, f: stages.append(w.jobs.progress.text()))
    wait_loaded(qtbot, w)
    assert any(s.startswith("compiling the kernels for this computer (first run only") for s in stages)
    assert warmup.is_warm()
