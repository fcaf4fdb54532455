"""Successive edits and Mirror X in the real window: nothing moves that the user did not touch
(pytest-qt, Xvfb, real mouse and key events)."""

from __future__ import annotations

import numpy as np
import pytest
from qtpy import QtCore

from hybridedit import cli
from hybridedit.fileio.meshfiles import read_mesh
from hybridedit.viewer.window.main_window import MainWindow
from support.window_driving import CAGE, handle_point, key, mouse_drag, polished, settled, wait_loaded

Qt = QtCore.Qt


def select(w: MainWindow, roi: np.ndarray, handle: np.ndarray) -> None:
    s = w.session
    s.selection.set_mask("roi", roi)
    s.selection.set_mask("handle", handle)
    w.sync.refresh_selection()


def drag_handle(qtbot, w: MainWindow, dy: int) -> None:
    key(qtbot, w, Qt.Key.Key_D)  # Drag mode
    a = handle_point(w)
    mouse_drag(qtbot, w.view, a, a + QtCore.QPoint(0, -dy), steps=max(1, min(abs(dy), 6)))
    settled(qtbot, w)


def test_a_second_edit_starts_where_the_first_ended(qtbot, win):
    """Pose the right end, release, polish; select the left end; drag it 1 px: the right end stays
    exactly where the polish put it; undo and redo across the selection change keep the pose."""
    w = win
    s = w.session
    P = s.cage_positions
    select(w, P[:, 0] > 0.0, P[:, 0] > 1.4)
    drag_handle(qtbot, w, 80)
    settled_pose = s.shape_positions.copy()
    polished(qtbot, w)
    first = s.shape_positions.copy()  # the polished pose, the engine's own
    assert not np.array_equal(first, settled_pose)
    diag = s.mesh.bbox_diagonal()
    # another end: a new selection, and a nudge of one pixel
    select(w, P[:, 0] < 0.0, P[:, 0] < -1.4)
    drag_handle(qtbot, w, 1)
    polished(qtbot, w)  # (the nudge's polish: its pose is the one to compare)
    second = s.shape_positions.copy()
    moving = s.editor.moving_vertices
    still = np.setdiff1d(np.arange(s.mesh.n_vertices), moving)
    assert still.size > 0.3 * s.mesh.n_vertices
    assert np.abs(second[still] - first[still]).max() < 1e-9 * diag  # the first edit, polish included, stays
    right = s.mesh.vertices[:, 0] > 1.0  # the posed end, far from the new region
    assert np.abs(second[right] - first[right]).max() < 1e-9 * diag
    # the nudge moved the new handle a little and nothing far
    assert 0 < np.abs(second - first).max() < 0.05 * diag
    # undo the nudge's polish and the nudge, then the selection changes: the pose is the first one
    assert s.history.undo_label() == "polish"
    while s.history.undo_label() != "drag":
        assert s.history.can_undo()
        key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
        if s.history.undo_label() in ("select ROI", "select handle"):
            assert np.array_equal(s.shape_positions, first)
    key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)  # that drag is the nudge
    assert np.abs(s.shape_positions - first).max() < 1e-12 * diag
    for _ in range(2):  # the two selection steps: the shape does not move
        key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
        assert np.array_equal(s.shape_positions, first)
        assert np.allclose(w.scene.parts.drawn_points(), first, atol=1e-5)
    for _ in range(2):
        key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier | Qt.KeyboardModifier.ShiftModifier)
        assert np.array_equal(s.shape_positions, first)
    for _ in range(2):  # the nudge, then its polish
        key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier | Qt.KeyboardModifier.ShiftModifier)
    assert np.abs(s.shape_positions - second).max() < 1e-12 * diag


def test_mirror_x_drag_equals_the_deform_replay_of_its_edit(qtbot, win, capsule_file, tmp_path):
    w = win
    w.actions_["polish"].trigger()  # compare the settled pose (the polish is not in an edit file)
    w.cage_control.set_value(CAGE)  # (a count for this file: the blob's does not carry over)
    assert w.loading.open_path(capsule_file)
    wait_loaded(qtbot, w)
    s = w.session
    assert s.path == capsule_file
    key(qtbot, w, Qt.Key.Key_X, Qt.KeyboardModifier.ShiftModifier)
    assert w.actions_["mirror_x"].isChecked() and s.selection.symmetry == "x"
    P = s.cage_positions
    select(w, P[:, 0] > 0.0, P[:, 0] > 1.4)
    s.apply_selection()
    w.sync.refresh_selection()
    # the mirrored selection is drawn on both sides: the engine's roles, mirror images included
    from hybridedit.deform.roles import FIXED, is_handle

    st = s.selection.cage_roles()
    far = st[P[:, 0] < -1.45]  # (the cage is not itself symmetric: the mirror maps through the shape)
    assert np.mean(is_handle(far)) > 0.8 and not np.any(far == FIXED)
    assert not np.any(st[(P[:, 0] < -0.3) & (P[:, 0] > -1.3)] == FIXED)  # the mirrored region is free
    drag_handle(qtbot, w, 80)
    V = s.shape_positions.copy()
    diag = s.mesh.bbox_diagonal()
    mirror = s.editor.symmetry
    image = V[mirror.map] @ mirror.S[:3, :3].T + mirror.S[:3, 3]
    assert np.abs(V - s.mesh.vertices).max() > 0.05 * diag
    assert np.abs(image - V).max() < 0.01 * diag  # both ends bent alike: no tear
    edit_path = tmp_path / "mirror.json"
    assert w.files.save_edit_to(edit_path)
    replay = tmp_path / "replay.obj"
    rc = cli.main(["deform", str(capsule_file), "-o", str(replay), "--edit", str(edit_path), "--cage", str(CAGE),
                   "-q"])
    assert rc == 0
    assert np.abs(read_mesh(replay).vertices - V).max() < 1e-9 * diag


def test_mirror_x_is_checked_against_each_shape(qtbot, win, capsule_file, blob_file):
    w = win
    s = w.session  # the bumpy blob: not symmetric across x
    key(qtbot, w, Qt.Key.Key_X, Qt.KeyboardModifier.ShiftModifier)  # refused at once, no selection needed
    assert not w.actions_["mirror_x"].isChecked() and s.selection.symmetry is None
    assert "not symmetric" in w.status.last_error and "%" in w.status.last_error
    w.status.error_box.done(0)  # the message box read
    w.activateWindow()
    qtbot.waitActive(w)
    w.view.setFocus()
    assert w.loading.open_path(capsule_file)
    qtbot.waitUntil(lambda: w.session is not None and w.session.path == capsule_file and w.jobs.worker is None,
                    timeout=60000)
    key(qtbot, w, Qt.Key.Key_X, Qt.KeyboardModifier.ShiftModifier)
    assert w.actions_["mirror_x"].isChecked() and w.session.selection.symmetry == "x"
    w.unsaved.set_modified(False)
    assert w.loading.open_path(blob_file)  # Mirror X is still ticked: the new shape is checked when it opens
    qtbot.waitUntil(lambda: w.session is not None and w.session.path == blob_file and w.jobs.worker is None,
                    timeout=60000)
    assert not w.actions_["mirror_x"].isChecked() and w.session.selection.symmetry is None
    assert "Mirror X is off" in w.status.current_message()


def test_a_mirrored_selection_is_drawn_on_both_sides_as_it_is_made(qtbot, win, capsule_file):
    w = win
    assert w.loading.open_path(capsule_file)
    qtbot.waitUntil(lambda: w.session is not None and w.session.path == capsule_file and w.jobs.worker is None,
                    timeout=60000)
    s = w.session
    key(qtbot, w, Qt.Key.Key_X, Qt.KeyboardModifier.ShiftModifier)
    P = s.cage_positions
    select(w, P[:, 0] > 0.0, P[:, 0] > 1.4)  # one side only; nothing applied to the engine yet
    assert not s.applied
    from hybridedit.deform.roles import FIXED, is_handle

    st = s.selection.cage_roles()
    far = st[P[:, 0] < -1.45]
    assert np.mean(is_handle(far)) > 0.8 and not np.any(far == FIXED)
    roles = s.selection.shape_roles()
    assert np.count_nonzero(roles[s.mesh.vertices[:, 0] < -1.5] == 1) > 0  # the tint covers the mirror image
    # what is drawn before the drag is what the engine takes at the drag
    s.apply_selection()
    assert np.array_equal(s.selection.cage_roles(), st) and np.array_equal(s.selection.shape_roles(), roles)
