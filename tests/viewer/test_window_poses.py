"""The pose library in the window, through real Qt events: two edits each kept with K, the Poses panel
listing them; a double-click continues from one (its shape exactly); rename in place, Delete; Save Edit
keeps them beside the edit, a fresh window's Load Edit restores them exactly (and ``hybridedit deform``
of that file gives the pose on display); Export Poses writes them as glTF morph targets; kept poses are
unsaved work (the title's mark, the Save / Discard / Cancel question)."""

from __future__ import annotations

import json

import numpy as np
import pygltflib
from qtpy import QtCore, QtWidgets

from hybridedit import cli
from hybridedit.fileio.meshfiles import read_document, read_mesh
from support.pose_files import morphed
from support.window_driving import (
    CAGE, answer_file_dialog, key, mouse_drag, opened_window, polished, projected, rubber_band, settled, to_widget,
)

Qt = QtCore.Qt
CTRL = Qt.KeyboardModifier.ControlModifier


def select_end(qtbot, w, *, left: bool) -> None:
    """Target ROI, a rectangle over the cage beyond x = 0 (the right or left half); target Handle, one
    beyond x = 1.4 (that end): real key and mouse events, Select Through on."""
    key(qtbot, w, Qt.Key.Key_S)
    if not w.controller.select_through:
        key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.AltModifier)
    for target, x in ((Qt.Key.Key_R, 0.0), (Qt.Key.Key_H, 1.4)):
        key(qtbot, w, target)
        if not left:
            rubber_band(qtbot, w, x)
            continue
        P = w.session.cage_positions
        d, _ = projected(w, P)
        _, height = w.scene.display_size()
        x1 = d[P[:, 0] < -x, 0].max() + 1.0
        mouse_drag(qtbot, w.view, to_widget(w, (3.0, 3.0)), to_widget(w, (x1, height - 3.0)))


def drag_handle(qtbot, w, dy: int) -> None:
    """Drag mode, the handle dragged up by ``dy`` pixels; the settle and the polish waited for."""
    key(qtbot, w, Qt.Key.Key_D)
    dc, _ = projected(w, w.session.handle_centroid()[None])
    a = to_widget(w, dc[0])
    mouse_drag(qtbot, w.view, a, a + QtCore.QPoint(0, -dy))
    settled(qtbot, w)
    polished(qtbot, w, timeout=30000)


def item_point(panel, row: int) -> QtCore.QPoint:
    return panel.list.visualItemRect(panel.list.item(row)).center()


def double_click(qtbot, panel, row: int) -> None:
    """A double-click on ``row``'s name as the mouse makes it: press and release, then press again."""
    qtbot.mouseClick(panel.list.viewport(), Qt.MouseButton.LeftButton, pos=item_point(panel, row))
    qtbot.mouseDClick(panel.list.viewport(), Qt.MouseButton.LeftButton, pos=item_point(panel, row))


def names(panel) -> list[str]:
    return [panel.list.item(k).text() for k in range(panel.list.count())]


def click_row(qtbot, panel, row: int) -> None:
    qtbot.mouseClick(panel.list.viewport(), Qt.MouseButton.LeftButton, pos=item_point(panel, row))
    qtbot.waitUntil(lambda: QtWidgets.QApplication.focusWidget() is panel.list, timeout=3000)


def rename_in_place(qtbot, panel, row: int, text: str) -> None:
    """Choose ``row``, F2 opens its name for typing, the text typed and Enter."""
    click_row(qtbot, panel, row)
    qtbot.keyClick(panel.list, Qt.Key.Key_F2)
    qtbot.waitUntil(lambda: isinstance(QtWidgets.QApplication.focusWidget(), QtWidgets.QLineEdit), timeout=3000)
    editor = QtWidgets.QApplication.focusWidget()
    editor.selectAll()
    qtbot.keyClicks(editor, text)
    qtbot.keyClick(editor, Qt.Key.Key_Return)
    qtbot.wait(20)


def two_poses(qtbot, w) -> tuple[np.ndarray, np.ndarray]:
    """The right end lifted and kept (K), then the left end lowered too and kept; returns both poses."""
    select_end(qtbot, w, left=False)
    drag_handle(qtbot, w, 80)
    key(qtbot, w, Qt.Key.Key_K)
    first = w.session.shown_positions.copy()
    select_end(qtbot, w, left=True)
    drag_handle(qtbot, w, -70)
    key(qtbot, w, Qt.Key.Key_K)
    return first, w.session.shown_positions.copy()


def test_keep_continue_rename_delete_save_reopen_and_export(qtbot, win, blob_file, tmp_path):
    w = win
    s = w.session
    panel = w.pose_panel
    assert not panel.dock.isVisible() and not w.actions_["export_poses"].isEnabled()
    first, second = two_poses(qtbot, w)
    assert not np.array_equal(first, second)
    # the panel came up at the first K and lists both, the last one chosen
    assert panel.dock.isVisible() and w.actions_["show_poses"].isChecked()
    assert names(panel) == ["Pose 1", "Pose 2"] and panel.list.currentRow() == 1
    assert "Kept the pose as 'Pose 2' (2 kept poses)" in w.status.current_message()
    np.testing.assert_array_equal(s.poses[0].positions, first)
    np.testing.assert_array_equal(s.poses[1].positions, second)
    assert w.actions_["export_poses"].isEnabled()

    # a double-click continues from the first: its shape exactly, drawn; Ctrl+Z goes back to the second
    double_click(qtbot, panel, 0)
    qtbot.waitUntil(lambda: np.array_equal(w.session.shown_positions, first), timeout=10000)
    assert w.session.history.current.label == "continue from Pose 1"
    assert "Continued from 'Pose 1'" in w.status.current_message()
    drawn = np.asarray(w.scene.shape.points)
    assert np.abs(drawn - first).max() <= 1e-6 * s.mesh.bbox_diagonal()
    qtbot.wait(2 * QtWidgets.QApplication.doubleClickInterval())
    assert panel.list.state() != QtWidgets.QAbstractItemView.State.EditingState  # (no rename opened)
    assert QtWidgets.QApplication.focusWidget() is w.view  # the keys are the editing's again
    key(qtbot, w, Qt.Key.Key_Z, CTRL)
    np.testing.assert_array_equal(w.session.shown_positions, second)

    # rename in place; a taken or empty name is refused in one line and the old name comes back
    rename_in_place(qtbot, panel, 1, "left down")
    assert names(panel) == ["Pose 1", "left down"] and s.poses.names == ["Pose 1", "left down"]
    rename_in_place(qtbot, panel, 1, "Pose 1")
    assert names(panel) == ["Pose 1", "left down"]
    said = w.status.current_message()
    assert said == "Not renamed: There is a pose named 'Pose 1' already." and "\n" not in said
    # Delete removes the chosen pose (a third, kept for it)
    key(qtbot, w, Qt.Key.Key_K)
    assert names(panel) == ["Pose 1", "left down", "Pose 3"]
    click_row(qtbot, panel, 2)
    qtbot.keyClick(panel.list, Qt.Key.Key_Delete)
    assert names(panel) == ["Pose 1", "left down"] and len(s.poses) == 2

    # kept poses are unsaved work: the mesh saved, the title's mark stays until Save Edit keeps them
    assert w.files.save_to(tmp_path / "posed.obj")
    assert w.unsaved.modified and w.isWindowModified() and w.unsaved.poses_unsaved()
    edit = tmp_path / "kept.json"
    seen = answer_file_dialog(qtbot, edit)
    key(qtbot, w, Qt.Key.Key_E, CTRL)
    assert seen and edit.is_file(), w.status.current_message()
    assert "Saved the edit and 2 kept poses to" in w.status.current_message()
    assert not w.unsaved.modified and not w.isWindowModified()
    data = json.loads(edit.read_text())
    assert [p["name"] for p in data["poses"]] == ["Pose 1", "left down"]
    # hybridedit deform of that file still gives the pose on display
    out = tmp_path / "deformed.obj"
    assert cli.main(["deform", str(blob_file), "-o", str(out), "--edit", str(edit), "--cage", str(CAGE), "-q"]) == 0
    shown = w.session.shown_positions
    assert np.abs(read_mesh(out).vertices - shown).max() <= 1e-6 * s.mesh.bbox_diagonal()

    # Export Poses: Qt's own file dialog, answered; the morph targets are the poses
    glb = tmp_path / "kept-poses.glb"
    seen = answer_file_dialog(qtbot, glb.with_suffix(""))  # (no extension: the type chosen gives it)
    panel.buttons["export"].click()
    assert seen and seen[0][0] == "Export poses" and glb.is_file(), w.status.current_message()
    assert w.status.current_message().startswith(f"Exported 2 poses to {glb} as morph targets.")
    gltf = pygltflib.GLTF2.load(str(glb))
    assert gltf.meshes[0].extras["targetNames"] == ["Pose 1", "left down"]
    file_vertex = read_document(glb).native.file_vertex
    diagonal = s.mesh.bbox_diagonal()
    for k, pose in enumerate((first, second)):
        for prim in gltf.meshes[0].primitives:
            assert np.abs(morphed(gltf, prim, k) - pose[file_vertex]).max() <= 1e-6 * diagonal
    # an export that cannot be written is one line in the status bar
    assert not panel.export_to(tmp_path / "kept.obj")
    said = w.status.current_message()
    assert said.startswith("Could not export the poses: kept.obj: cannot write poses") and "\n" not in said

    # a fresh window: Load Edit restores both poses, with their exact positions
    with opened_window(qtbot, cage_size=CAGE, path=blob_file) as fresh:
        assert fresh.files.load_edit_from(edit)
        assert "Its 2 kept poses are in the Poses panel." in fresh.status.current_message()
        assert names(fresh.pose_panel) == ["Pose 1", "left down"] and fresh.pose_panel.dock.isVisible()
        lib = fresh.session.poses
        np.testing.assert_array_equal(lib[0].positions, first)
        np.testing.assert_array_equal(lib[1].positions, second)
        assert not lib.unsaved  # (as the file has them)
        np.testing.assert_array_equal(fresh.session.shown_positions, shown)
        fresh.pose_panel.list.setCurrentRow(1)
        fresh.pose_panel.buttons["continue"].click()
        np.testing.assert_array_equal(fresh.session.shown_positions, second)


def test_kept_poses_alone_ask_before_quitting(qtbot, win, monkeypatch, tmp_path):
    """The pose saved, a pose kept: quitting asks about the kept poses; Cancel keeps the window; the
    recovery file holds them meanwhile."""
    w = win
    # (K is Keep Pose's alone: no two actions share a key)
    keys = [k.toString() for a in w.actions_.values() for k in a.shortcuts()]
    assert w.actions_["keep_pose"].shortcut().toString() == "K" and len(keys) == len(set(keys))
    select_end(qtbot, w, left=False)
    drag_handle(qtbot, w, 60)
    assert w.files.save_to(tmp_path / "posed.obj")
    assert not w.unsaved.modified and not w.isWindowModified()
    key(qtbot, w, Qt.Key.Key_K)
    assert w.unsaved.modified and w.isWindowModified() and not w.unsaved.pose_modified
    qtbot.waitUntil(w.autosave.up_to_date, timeout=5000)
    from hybridedit.viewer.model.recovery import read_recovery

    assert [n for n, _ in read_recovery(w.autosave.keeper.path).poses] == ["Pose 1"]
    asked = []
    monkeypatch.setattr(QtWidgets.QMessageBox, "exec",
                        lambda box: asked.append((box.windowTitle(), box.text()))
                        or int(QtWidgets.QMessageBox.StandardButton.Cancel))
    key(qtbot, w, Qt.Key.Key_Q, CTRL)
    assert asked == [("Unsaved poses", "The kept pose of posed.obj is not saved (Save Edit keeps it).\n\n"
                                       "Save it before quitting?")]
    assert w.isVisible()
