"""Several handle groups in the window: new group, switch group, each its own colour and transform."""

from __future__ import annotations

import json

import numpy as np
from qtpy import QtCore

from hybridedit.deform.roles import handle
from hybridedit.viewer.render.palette import ROLE_COLORS, role_rows
from support.window_driving import key, mouse_drag, projected, settled, to_widget

Qt = QtCore.Qt


def drag_active(qtbot, w, dy: int) -> None:
    dc, _ = projected(w, w.session.handle_centroid()[None])
    a = to_widget(w, dc[0])  # the gizmo's centre: a drag in the view plane
    mouse_drag(qtbot, w.view, a, a + QtCore.QPoint(0, dy), steps=6)
    settled(qtbot, w)


def test_two_handle_groups_move_independently(qtbot, win, tmp_path):
    w = win
    s = w.session
    w.polisher.enabled = False
    P = s.cage_positions
    rest = s.mesh.vertices
    s.selection.set_mask("roi", np.abs(P[:, 0]) > 0.4)
    s.selection.set_mask("handle", P[:, 0] > 1.4)
    w.actions_["new_group"].trigger()  # Ctrl+G
    assert s.selection.n_groups == 2 and s.selection.active == 1 and not s.selection.handle.any()
    s.selection.set_mask("handle", P[:, 0] < -1.4)
    w.sync.refresh_selection()
    groups = s.selection.handle_group
    assert np.all(groups[P[:, 0] > 1.4] == 1) and np.all(groups[P[:, 0] < -1.4] == 2)
    # each group its own colour, on the cage points and on the shape
    rgba = np.asarray(w.scene.points_poly.point_data["role"])[:, :3]
    first, second = ROLE_COLORS[role_rows(handle(0))], ROLE_COLORS[role_rows(handle(1))]
    assert not np.array_equal(first, second)
    assert np.all(rgba[P[:, 0] > 1.4] == first) and np.all(rgba[P[:, 0] < -1.4] == second)
    key(qtbot, w, Qt.Key.Key_D)
    # drag group 2 (the left end) up: the right end stays
    drag_active(qtbot, w, -60)
    V1 = s.shape_positions.copy()
    left, right = rest[:, 0] < -1.9, rest[:, 0] > 1.9
    assert (V1[left] - rest[left])[:, 1].min() > 0.1
    assert np.abs(V1[right] - rest[right]).max() < 1e-9
    assert s.editor.n_groups == 2 and set(np.unique(s.editor.vertex_roles)) >= {1, 2}
    fr = s.editor.vertex_roles[s.mesh.faces]
    tint = w.scene.parts.face_colours()
    assert not np.array_equal(tint[(fr == 1).all(axis=1)][0], tint[(fr == 2).all(axis=1)][0])
    # G: group 1 (the right end); dragging it keeps group 2 where it was put
    key(qtbot, w, Qt.Key.Key_G)
    assert s.selection.active == 0
    drag_active(qtbot, w, 60)
    V2 = s.shape_positions.copy()
    assert (V2[right] - rest[right])[:, 1].max() < -0.1
    assert np.abs(V2[left] - V1[left]).max() < 1e-9
    # the edit file has both groups with their transforms
    edit = tmp_path / "two.json"
    assert w.files.save_edit_to(edit)
    data = json.loads(edit.read_text())
    assert len(data["steps"][-1]["handles"]) == 2
    # undo the last drag: group 2's pose is back, group 1 at rest
    key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
    assert np.allclose(s.shape_positions, V1, atol=1e-6)
