"""The view controller on a real view (VTK under Xvfb) driven by real Qt mouse events, with a stand-in
for the window: what a rectangle, a click and a brush take, in sight or through the shape."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from qtpy import QtCore

from hybridedit.deform.roles import FIXED, FREE
from hybridedit.viewer.input import mouse_gestures as interaction
from hybridedit.viewer.input.mouse_gestures import BRUSH, CAMERA, SELECT, ViewController
from hybridedit.core.region_metrics import ShapeMetrics
from hybridedit.viewer.render.scene import Scene
from hybridedit.core.normals import vertex_normals
from hybridedit.viewer.model.picking import REPLACE, combine, project_points
from hybridedit.viewer.model.surface_pick import thickness
from hybridedit.viewer.render.view import View
from support.window_driving import look_down_minus_z

Qt = QtCore.Qt
FRONT_Z, BACK_Z = 1.6, -1.6
"""Two unit balls, one behind the other along the line of sight of the front view."""


class Window:
    """What the controller asks of the window's selection and drags, recorded."""

    def __init__(self, P: np.ndarray, cage_faces: np.ndarray | None = None) -> None:
        self.P = P
        self.edges = None if cage_faces is None else np.sort(
            np.vstack([cage_faces[:, [0, 1]], cage_faces[:, [1, 2]], cage_faces[:, [2, 0]]]), axis=1)
        self.thick = None if cage_faces is None else thickness(P, vertex_normals(P, cage_faces))
        self.mask = np.zeros(len(P), dtype=bool)
        self.calls: list[tuple[np.ndarray, str]] = []
        self.missed_clicks = 0
        self.begun = self.ended = 0

    def cage_points(self):
        return self.P.copy()

    def cage_edges(self):
        return self.edges

    def cage_thickness(self):
        return self.thick

    def handle_center(self):
        return None

    def begin_select(self) -> bool:
        self.begun += 1
        return True

    def select_hits(self, hits, op) -> None:
        self.calls.append((np.asarray(hits).copy(), op))
        self.mask = combine(self.mask, hits, op)

    def end_select(self) -> None:
        self.ended += 1

    def begin(self) -> bool:
        return False

    def move(self, D) -> None:
        raise AssertionError("no drag here")

    def end(self) -> None:
        pass

    def missed(self) -> None:
        self.missed_clicks += 1


def _ball(subdivisions: int, radius: float, z: float):
    s = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    return np.asarray(s.vertices) + [0.0, 0.0, z], np.asarray(s.faces)


@pytest.fixture
def rig(qtbot):
    """A view of two balls (front one at z = 1.6, back one at z = -1.6), each with a "cage" of 162 points
    just inside its surface (as QEM puts some), seen from +Z; the controller in Select mode."""
    Vf, Ff = _ball(4, 1.0, FRONT_Z)
    Vb, Fb = _ball(4, 1.0, BACK_Z)
    V = np.vstack([Vf, Vb])
    F = np.vstack([Ff, Fb + len(Vf)])
    Pf, Cf = _ball(2, 0.97, FRONT_Z)
    Pb, Cb = _ball(2, 0.97, BACK_Z)
    P = np.vstack([Pf, Pb])
    CF = np.vstack([Cf, Cb + len(Pf)])
    view = View()
    view.resize(700, 560)
    view.show()
    qtbot.waitExposed(view)
    scene = Scene(view.plotter)
    scene.load(ShapeMetrics(V, F), V, P, CF, np.full(len(P), FIXED, dtype=np.int8), np.full(len(V), FREE, dtype=np.int8))
    scene.reset_camera(tilted=False)
    look_down_minus_z(scene)
    win = Window(P, CF)
    ctl = ViewController(view, scene, win, win)
    ctl.set_mode(SELECT)
    view.render()
    qtbot.wait(20)
    yield view, scene, ctl, win
    view.close()
    view.deleteLater()


def _widget(view: View, xy) -> QtCore.QPoint:
    return view.to_widget(float(xy[0]), float(xy[1]))


def _drag(qtbot, view, a: QtCore.QPoint, b: QtCore.QPoint, steps: int = 6,
          modifier=Qt.KeyboardModifier.NoModifier) -> None:
    qtbot.mouseMove(view, a)
    qtbot.mousePress(view, Qt.MouseButton.LeftButton, modifier, a)
    for k in range(1, steps + 1):
        qtbot.mouseMove(view, a + (b - a) * (k / steps))
        qtbot.wait(5)
    qtbot.mouseRelease(view, Qt.MouseButton.LeftButton, modifier, b)
    qtbot.wait(10)


def _projected(scene: Scene, P: np.ndarray):
    return project_points(P, scene.composite_matrix(), scene.display_size())


def _everything(view, scene, P) -> tuple[QtCore.QPoint, QtCore.QPoint]:
    """Corners of a rectangle around every cage point."""
    d, _ = _projected(scene, P)
    return (_widget(view, (d[:, 0].min() - 8, d[:, 1].max() + 8)),
            _widget(view, (d[:, 0].max() + 8, d[:, 1].min() - 8)))


def test_the_rectangle_takes_the_part_in_front_through_its_thickness(qtbot, rig, monkeypatch):
    view, scene, ctl, win = rig
    P = win.P
    front_ball = P[:, 2] > 0
    local_z = P[:, 2] - np.where(front_ball, FRONT_Z, BACK_Z)  # towards the camera, from the ball's centre
    tests = []
    real = interaction.in_sight
    monkeypatch.setattr(interaction, "in_sight", lambda *a, **k: tests.append(1) or real(*a, **k))
    a, b = _everything(view, scene, P)
    _drag(qtbot, view, a, b, steps=12)
    taken = win.mask
    assert win.calls[-1][1] == REPLACE and win.begun == win.ended == 1
    assert len(tests) == 1  # one visibility test for the whole gesture, not one per mouse move
    # the back ball is hidden behind the front one: not taken; the front one is taken whole, its far half
    # too (hidden only by the ball itself: one wall in front of it), as Select Through takes it
    assert not taken[~front_ball].any()
    assert np.all(taken[front_ball])
    sight = ctl.takeable(P, scene.composite_matrix(), scene.display_size(), *_projected(scene, P))
    assert np.all(sight[front_ball & (local_z > 0.25)]) and not sight[front_ball & (local_z < -0.25)].any()
    # Select Through takes every point in the rectangle
    ctl.set_select_through(True)
    _drag(qtbot, view, a, b)
    assert win.mask.all()
    assert len(tests) == 1  # (no visibility test then)


def test_a_click_takes_one_point_and_a_click_on_empty_space_nothing(qtbot, rig):
    view, scene, ctl, win = rig
    P = win.P
    d, _ = _projected(scene, P)
    win.mask[:] = True
    i = int(np.argmax(P[:, 2]))  # the point nearest the camera, in the middle of the front ball
    # a click on empty space: no change at all, and the window is told
    corner = _widget(view, (10.0, 10.0))
    _drag(qtbot, view, corner, corner + QtCore.QPoint(2, 1), steps=1)
    assert win.calls == [] and win.mask.all()
    assert win.missed_clicks == 1  # (the window says so: test_window_select)
    # a click next to a point takes it alone (replace), Ctrl+click removes it
    a = _widget(view, d[i, :2]) + QtCore.QPoint(3, -2)
    _drag(qtbot, view, a, a, steps=1)
    assert np.flatnonzero(win.mask).tolist() == [i]
    _drag(qtbot, view, a, a + QtCore.QPoint(1, 1), steps=1, modifier=Qt.KeyboardModifier.ControlModifier)
    assert not win.mask.any()
    # a click where the front ball hides the back ball's nearest point takes the front one
    j = int(np.argmax(np.where(P[:, 2] < 0, P[:, 2], -np.inf)))  # the back ball's point facing the camera
    _drag(qtbot, view, _widget(view, d[j, :2]), _widget(view, d[j, :2]), steps=1)
    assert win.mask.sum() == 1 and P[win.mask][0, 2] > 0
    # through the shape it is the hidden one, if it is the nearest on screen
    ctl.set_select_through(True)
    _drag(qtbot, view, _widget(view, d[j, :2]), _widget(view, d[j, :2]), steps=1)
    k = int(np.flatnonzero(win.mask)[0])
    assert win.mask.sum() == 1 and np.hypot(*(d[k, :2] - d[j, :2])) <= np.hypot(*(d[i, :2] - d[j, :2]))


def test_a_brush_stroke_over_empty_space_keeps_the_selection(qtbot, rig):
    view, scene, ctl, win = rig
    ctl.set_tool(BRUSH)
    ctl.set_brush_radius(15)
    P = win.P
    d, _ = _projected(scene, P)
    win.mask[: len(P) // 2] = True
    before = win.mask.copy()
    a = _widget(view, (12.0, 12.0))
    _drag(qtbot, view, a, a + QtCore.QPoint(60, 0))  # a replacing stroke that touches nothing
    assert win.calls == [] and np.array_equal(win.mask, before) and win.ended == 1
    # a stroke that starts on empty space and reaches the ball replaces with its first touch
    i = int(np.argmax(P[:, 2]))
    _drag(qtbot, view, _widget(view, (d[i, 0] - 200, d[i, 1])), _widget(view, d[i, :2]), steps=20)
    assert win.calls[0][1] == REPLACE and all(op == "add" for _, op in win.calls[1:])
    assert win.mask[i] and not win.mask[P[:, 2] < 0].any()  # (the back ball: hidden)
    # a brush as wide as the ball takes it through its depth, its far side too; the ball behind it still not
    ctl.set_brush_radius(160)
    c = _widget(view, d[i, :2])
    _drag(qtbot, view, c, c + QtCore.QPoint(1, 0), steps=1)
    assert win.mask[P[:, 2] > 0].all() and not win.mask[P[:, 2] < 0].any()


def test_the_points_shown_near_the_cursor_are_those_a_selection_takes(qtbot, rig):
    view, scene, ctl, win = rig
    P = win.P
    d, _ = _projected(scene, P)
    c = _widget(view, d[int(np.argmax(P[:, 2])), :2])
    qtbot.mouseMove(view, c + QtCore.QPoint(7, 5))  # (from elsewhere: a move to where the cursor is sends nothing)
    qtbot.wait(10)
    qtbot.mouseMove(view, c)
    qtbot.waitUntil(lambda: len(scene.shown_points) > 0, timeout=3000)
    qtbot.wait(50)
    shown = scene.shown_points
    assert len(shown) > 5 and np.all(P[shown, 2] > 0)  # the back ball's points under the cursor: not shown
    ctl.set_select_through(True)
    assert np.any(P[scene.shown_points, 2] < 0)
    ctl.set_select_through(False)
    assert np.array_equal(scene.shown_points, shown)


def test_the_depth_is_read_once_per_view_and_only_in_select_mode(qtbot, rig):
    view, scene, ctl, win = rig
    depth = view.depth
    assert depth.current()
    n = depth.serial
    view.render()
    view.render()
    assert depth.serial == n  # the same view: not read again
    cam = scene.renderer.GetActiveCamera()
    cam.Azimuth(20)
    view.render()
    assert depth.serial == n + 1 and depth.current()
    assert depth.depth.shape == (scene.display_size()[1], scene.display_size()[0])
    assert 0.0 < depth.depth.min() < 1.0 and depth.depth.max() == 1.0  # the balls and the background
    ctl.set_mode(CAMERA)
    cam.Azimuth(20)
    view.render()
    assert depth.serial == n + 1 and not depth.current()  # (Camera mode: not read)
    # back in Select mode a gesture reads it first (one render), then decides
    ctl.set_mode(SELECT)
    a, b = _everything(view, scene, win.P)
    _drag(qtbot, view, a, b)
    assert depth.serial == n + 2
    # turned 40 degrees, the balls no longer hide each other: each is taken whole, through its thickness
    assert win.mask.all()
