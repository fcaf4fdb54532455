"""The Pose tool (Mode ▸ Pose, ``P``) through real Qt events under Xvfb: hovering a limb shows it and
its joint, ``[`` / ``]`` and the wheel move the joint, a drag turns the limb about its joint (Shift: moves
it), release settles, Ctrl+Z undoes, and Ctrl+E saves an edit that ``hybridedit deform`` replays to the
pose on screen."""

from __future__ import annotations

import numpy as np
import pytest
from qtpy import QtCore, QtGui, QtWidgets

from hybridedit import cli
from hybridedit.core.mesh import edge_error_stats
from hybridedit.fileio.meshfiles import read_mesh, write_mesh
from shapes import figure
from support.window_driving import key, mouse_drag, opened_window, projected, settled, to_widget

Qt = QtCore.Qt
CTRL = Qt.KeyboardModifier.ControlModifier
SHIFT = Qt.KeyboardModifier.ShiftModifier


@pytest.fixture(scope="module")
def figure_file(tmp_path_factory):
    p = tmp_path_factory.mktemp("figure") / "figure.obj"
    write_mesh(p, figure())
    return p


@pytest.fixture
def posing(qtbot, figure_file):
    """The window on the figure (arms out along X, legs down), seen from the front, in Pose mode."""
    with opened_window(qtbot, cage_size=0.1, path=figure_file) as w:
        w.polisher.enabled = False
        w.options.set_view("front")
        qtbot.wait(30)
        key(qtbot, w, Qt.Key.Key_P)
        assert w.controller.mode == "pose" and w.actions_["mode_pose"].isChecked()
        yield w


def right_arm(w):
    """The figure's limb whose tip is at +X (its right arm as seen from the front)."""
    return max(w.session.editor.limbs(), key=lambda limb: limb.tip[0])


def on_screen(w, p) -> QtCore.QPoint:
    d, _ = projected(w, np.asarray(p, dtype=np.float64)[None])
    return to_widget(w, d[0])


def hover(qtbot, w, at: QtCore.QPoint) -> None:
    qtbot.mouseMove(w.view, at)
    qtbot.waitUntil(lambda: w.view.depth.current(), timeout=5000)
    qtbot.mouseMove(w.view, at + QtCore.QPoint(1, 0))
    qtbot.wait(20)


def wheel(w, at: QtCore.QPoint, notches: int) -> None:
    """A real wheel event on the view at ``at``: ``notches`` of 15 degrees (+: away from the user)."""
    ev = QtGui.QWheelEvent(QtCore.QPointF(at), QtCore.QPointF(w.view.mapToGlobal(at)), QtCore.QPoint(0, 0),
                           QtCore.QPoint(0, 120 * notches), Qt.MouseButton.NoButton, Qt.KeyboardModifier.NoModifier,
                           Qt.ScrollPhase.NoScrollPhase, False)
    QtWidgets.QApplication.sendEvent(w.view, ev)


def test_hovering_a_limb_shows_it_and_its_joint_which_the_keys_and_wheel_move(qtbot, posing):
    w = posing
    arm = right_arm(w)
    hand = on_screen(w, arm.tip - [0.1, 0.0, 0.0])
    hover(qtbot, w, hand)
    assert w.limb_posing.shown is arm
    assert w.scene.pivot.visible and not w.scene.gizmo.visible
    key(qtbot, w, Qt.Key.Key_BracketRight)  # the joint toward the body
    assert w.limb_posing.at(arm) == pytest.approx(1.1)
    key(qtbot, w, Qt.Key.Key_BracketLeft)
    key(qtbot, w, Qt.Key.Key_BracketLeft)
    assert w.limb_posing.at(arm) == pytest.approx(0.9)
    camera = w.scene.renderer.GetActiveCamera().GetPosition()
    wheel(w, hand, notches=1)
    assert w.limb_posing.at(arm) == pytest.approx(1.0)
    assert w.scene.renderer.GetActiveCamera().GetPosition() == camera  # (over a limb the wheel does not zoom)
    # the selection is untouched by a hover; off the shape nothing is shown
    assert not w.session.selection.roi.any()
    hover(qtbot, w, QtCore.QPoint(8, 8))
    assert w.limb_posing.shown is None and not w.scene.pivot.visible


def test_a_drag_turns_the_limb_about_its_joint_and_ctrl_e_replays_it(qtbot, posing, figure_file, tmp_path,
                                                                       monkeypatch):
    w = posing
    s = w.session
    V = s.mesh.vertices.copy()
    arm = right_arm(w)
    pose = arm.parts()
    hand = on_screen(w, arm.tip - [0.1, 0.0, 0.0])
    hover(qtbot, w, hand)
    # an 80 px drag upward: the hand swings up about the shoulder
    mouse_drag(qtbot, w.view, hand, hand + QtCore.QPoint(0, -80), steps=8)
    settled(qtbot, w)
    X = s.shape_positions
    sel = s.selection
    assert np.array_equal(sel.handle, pose.cage_handle) and np.array_equal(sel.roi, pose.cage_roi)
    # held vertices stay put; the handle's vertices are a rotation of rest about the joint, about the view axis
    roles = s.editor.vertex_roles
    assert np.abs(X[roles == -1] - V[roles == -1]).max() == 0.0
    h = roles == 1
    A, B = V[h] - pose.joint, X[h] - pose.joint
    R, _ = np.linalg.qr(np.linalg.lstsq(A, B, rcond=None)[0].T)
    R *= np.sign(np.diag(R))
    assert np.abs(A @ R.T - B).max() < 1e-6 * s.mesh.bbox_diagonal()
    angle = np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1)))
    axis = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    assert 10 < angle < 60 and abs(axis[2]) / np.linalg.norm(axis) > 0.99  # about the line of sight (Z)
    assert axis[2] > 0  # counter-clockwise on screen: the right arm goes up
    assert (X[h, 1] - V[h, 1]).mean() > 0.1
    rrms, _ = edge_error_stats(V, X, s.edges)
    assert rrms <= 5.0, rrms
    # Ctrl+E saves it; hybridedit deform replays it to the pose on screen
    edit = tmp_path / "pose.json"
    monkeypatch.setattr(QtWidgets.QFileDialog, "getSaveFileName", staticmethod(lambda *a, **k: (str(edit), "")))
    key(qtbot, w, Qt.Key.Key_E, CTRL)
    assert edit.is_file(), w.status.current_message()
    out = tmp_path / "replayed.obj"
    assert cli.main(["deform", str(figure_file), "-o", str(out), "--edit", str(edit), "-q"]) == 0
    assert np.abs(read_mesh(out).vertices - X).max() <= 1e-6 * s.mesh.bbox_diagonal()
    # Ctrl+Z: back to the rest pose, then to the selection before the pose (none)
    key(qtbot, w, Qt.Key.Key_Z, CTRL)
    assert np.abs(s.shape_positions - V).max() == 0.0
    key(qtbot, w, Qt.Key.Key_Z, CTRL)
    assert not s.selection.roi.any() and not s.selection.handle.any()


def test_shift_drag_moves_the_limb_and_a_press_off_a_limb_says_why(qtbot, posing):
    w = posing
    s = w.session
    V = s.mesh.vertices.copy()
    arm = right_arm(w)
    hand = on_screen(w, arm.tip - [0.1, 0.0, 0.0])
    hover(qtbot, w, hand)
    mouse_drag(qtbot, w.view, hand, hand + QtCore.QPoint(0, -40), steps=4, modifier=SHIFT)
    settled(qtbot, w)
    roles = s.editor.vertex_roles
    moved = s.shape_positions[roles == 1] - V[roles == 1]
    assert np.abs(moved - moved.mean(axis=0)).max() < 1e-9 and moved.mean(axis=0)[1] > 0.05  # one translation, up
    # the body's centre is no limb: a press there poses nothing and says so
    before = s.shape_positions.copy()
    body = on_screen(w, [0.0, 0.0, 0.5])
    mouse_drag(qtbot, w.view, body, body + QtCore.QPoint(30, 0), steps=3)
    assert np.array_equal(s.shape_positions, before)
    assert "No limb there" in w.status.current_message()
