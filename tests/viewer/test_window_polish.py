"""Polish on release, the stretch map and the mesh info / repair notes, in the real window (pytest-qt, Xvfb)."""

from __future__ import annotations


import numpy as np
from qtpy import QtCore

from hybridedit.deform.arap import ARAPSolver
from hybridedit.fileio.meshfiles import read_mesh
from hybridedit.core.mesh import edge_stretch, vertex_stretch
from hybridedit.viewer.model import building as worker_module
from hybridedit.viewer.window.dialogs import mesh_info_text
from hybridedit.viewer.window.main_window import MainWindow
from support.window_driving import handle_point, key, mouse_drag, polished, select_tip_to_drag, settled, wait_loaded

Qt = QtCore.Qt


def drag_up(qtbot, w: MainWindow, pixels: int = 80) -> None:
    a = handle_point(w)
    mouse_drag(qtbot, w.view, a, a + QtCore.QPoint(0, -pixels), steps=6)
    settled(qtbot, w)


def test_polish_on_release_lowers_the_energy_and_save_writes_it(qtbot, win, tmp_path):
    w = win
    s = w.session
    assert w.actions_["polish"].isChecked() and w.polisher.enabled
    rest = s.shape_positions.copy()
    select_tip_to_drag(qtbot, w)
    drag_up(qtbot, w)
    hybrid = s.shape_positions.copy()  # the engine's (settled) pose
    polished(qtbot, w)
    P = w.posing.polished.copy()
    # the polish ran in the background and the window shows its result
    assert np.allclose(w.scene.parts.drawn_points(), P, atol=1e-5)
    assert not np.allclose(P, hybrid, atol=1e-6)
    msg = w.status.current_message()
    assert msg.startswith("polished: ") and "iterations, edge error" in msg and "→" in msg
    assert w.status.error_label.text().endswith("(polished)")
    # lower full-mesh ARAP energy than the hybrid pose
    arap = ARAPSolver(s.mesh.vertices, s.mesh.faces, weights="cotangent")
    assert arap.energy(P) < arap.energy(hybrid)
    assert w.posing.last_polish.result.energy_after < w.posing.last_polish.result.energy_before
    # only the edited region moved: the handle's and the fixed part's vertices are where the hybrid pose put them
    ed = s.editor
    free = ed.free_mask
    assert free.any() and (~free).any()
    assert np.array_equal(P[~free], hybrid[~free])
    # the polish is the engine's pose now (the next edit starts from it), one undo step
    assert np.array_equal(s.shape_positions, P)
    assert s.history.undo_label() == "polish"
    # save writes what is shown (the polished pose)
    out = tmp_path / "polished.obj"
    assert w.files.save_to(out)
    assert np.array_equal(read_mesh(out).vertices, P)
    assert "polish" in mesh_info_text(w.session, w.posing.last_polish).lower()
    # undo takes back the polish (the settled pose, exactly), then the drag
    key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
    assert w.posing.polished is None
    assert np.array_equal(s.shape_positions, hybrid)
    assert np.allclose(w.scene.parts.drawn_points(), hybrid, atol=1e-5)
    key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
    assert np.allclose(s.shape_positions, rest, atol=1e-12)
    assert np.allclose(w.scene.parts.drawn_points(), rest, atol=1e-5)
    # redo brings the settled pose back, then the polished one, exactly (no new polish runs)
    key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier | Qt.KeyboardModifier.ShiftModifier)
    assert np.array_equal(s.shape_positions, hybrid) and w.posing.polished is None
    key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier | Qt.KeyboardModifier.ShiftModifier)
    assert np.array_equal(s.shape_positions, P)
    assert np.allclose(w.scene.parts.drawn_points(), P, atol=1e-5)
    assert w.polisher.worker is None
    assert w.posing.polished is not None  # (redone: still the polish)
    assert w.status.error_label.text().endswith("(polished)")
    # a selection changed, and undone: the pose on display is still the polished one, and says so
    Pc = s.cage_positions
    s.selection.set_mask("handle", Pc[:, 0] < -1.4)
    w.sync.refresh_selection()
    w.sync.measure(everything=True)
    assert w.status.error_label.text().endswith("(polished)")
    key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
    assert np.array_equal(s.shape_positions, P) and w.status.error_label.text().endswith("(polished)")
    # off: a release shows the engine's pose only
    w.actions_["polish"].trigger()
    assert not w.polisher.enabled
    drag_up(qtbot, w, 30)
    qtbot.wait(200)
    assert w.polisher.worker is None and w.posing.polished is None
    assert np.allclose(w.scene.parts.drawn_points(), s.shape_positions, atol=1e-5)


def test_a_new_drag_or_undo_cancels_a_running_polish(qtbot, win):
    w = win
    s = w.session
    select_tip_to_drag(qtbot, w)
    # a polish that would run for a minute: never converges, no iteration cap
    w.polisher.iterations, w.polisher.tolerance = 10 ** 9, 0.0
    drag_up(qtbot, w)
    qtbot.waitUntil(lambda: w.polisher.worker is not None and w.polisher.holder.shape_arap is not None, timeout=10000)
    qtbot.wait(150)  # iterating now
    running = w.polisher.worker
    assert running.isRunning()
    # pressing on the handle starts a new drag: the polish stops after its current iteration
    a = handle_point(w)
    qtbot.mousePress(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, a)
    assert running.cancel_requested
    qtbot.waitUntil(lambda: w.polisher.worker is None, timeout=5000)
    assert w.posing.polished is None and w.posing.last_polish is None  # the result was dropped
    for k in range(1, 4):
        qtbot.mouseMove(w.view, a + QtCore.QPoint(0, -10 * k))
        qtbot.wait(5)
    qtbot.mouseRelease(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, a + QtCore.QPoint(0, -30))
    settled(qtbot, w)
    # the release started another long polish; undo cancels it too and shows the pose before that drag
    qtbot.waitUntil(lambda: w.polisher.worker is not None, timeout=5000)
    running = w.polisher.worker
    before = s.history.current
    key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
    assert running.cancel_requested and s.history.current is not before
    qtbot.waitUntil(lambda: w.polisher.worker is None, timeout=5000)
    qtbot.wait(50)
    assert w.posing.polished is None and w.posing.last_polish is None
    assert np.allclose(w.scene.parts.drawn_points(), s.shape_positions, atol=1e-5)


def test_stretch_map(qtbot, win):
    w = win
    s = w.session
    a = w.actions_["stretch"]
    assert not a.isChecked() and not w.scene.stretch_bar.GetVisibility()
    select_tip_to_drag(qtbot, w)
    drag_up(qtbot, w)
    polished(qtbot, w)
    w.view.render()
    before = np.asarray(w.view.screenshot(None, return_img=True)).astype(np.int16)
    key(qtbot, w, Qt.Key.Key_T)  # on
    assert a.isChecked()
    assert all(p.mapper.GetScalarVisibility() for p in w.scene.parts.parts)
    assert w.scene.stretch_bar.GetVisibility()
    V = w.posing.polished  # the shape on display
    expected = 100.0 * vertex_stretch(s.mesh.n_vertices, s.edges, edge_stretch(s.mesh.vertices, V, s.edges))
    shown = np.asarray(w.scene.shape.point_data["stretch"])
    assert np.allclose(shown, expected, rtol=1e-5, atol=1e-4)
    for p in w.scene.parts.parts:  # what each part draws
        assert np.allclose(p.stretch, expected[p.vertices], rtol=1e-5, atol=1e-4)
    far = s.mesh.vertices[:, 0] < -1.0  # the fixed end
    # the bent part shows, the fixed part does not
    assert expected.max() > 1.0 and expected[far].max() < 0.05 * expected.max()
    w.view.render()
    after = np.asarray(w.view.screenshot(None, return_img=True)).astype(np.int16)
    assert before.shape == after.shape
    assert (np.abs(after - before).max(axis=2) > 30).mean() > 0.01  # the colours changed
    # it follows the shape: undo the polish and the drag, back to rest, no stretch anywhere
    key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
    key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
    assert np.abs(np.asarray(w.scene.shape.point_data["stretch"])).max() < 1e-3
    # off: back to the selection tint
    key(qtbot, w, Qt.Key.Key_T)
    assert not a.isChecked()
    assert not any(p.mapper.GetScalarVisibility() for p in w.scene.parts.parts)
    assert not w.scene.stretch_bar.GetVisibility()
    w.view.render()
    off = np.asarray(w.view.screenshot(None, return_img=True)).astype(np.int16)
    assert (np.abs(off - after).max(axis=2) > 30).mean() > 0.01


def test_repair_notes_are_shown_after_loading(qtbot, blob_file, monkeypatch):
    notes = ["merged 3 duplicate vertices", "removed 2 degenerate faces"]

    class Noted(worker_module.HybridEditor):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            self.notes = list(notes)

    monkeypatch.setattr(worker_module, "HybridEditor", Noted)
    w = MainWindow(cage_size=150)
    qtbot.addWidget(w)
    w.show()
    qtbot.waitExposed(w)
    assert not w.actions_["mesh_info"].isEnabled()
    assert w.loading.open_path(blob_file)
    wait_loaded(qtbot, w)
    msg = w.status.current_message()
    assert "repaired" in msg and notes[0] in msg and notes[1] in msg
    assert w.actions_["mesh_info"].isEnabled()
    w.actions_["mesh_info"].trigger()
    box = w.dialogs.mesh_info_box
    qtbot.waitExposed(box)
    assert not box.isModal()
    text = box.text()
    assert "2,562" in text and f"{w.session.n_cage}" in text and notes[0] in text and notes[1] in text
    box.close()
    # without notes: "none"
    w.session.editor.notes = []
    assert "none" in mesh_info_text(w.session, w.posing.last_polish)
