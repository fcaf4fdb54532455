"""Pure parts of the window: projection, hit tests, set logic, gizmo math, edit-file decomposition."""

from __future__ import annotations

import numpy as np
import pytest

from hybridedit.transforms import apply_transform
from hybridedit.viewer import gizmo as gz
from hybridedit.viewer.history import History, Snapshot
from hybridedit.viewer.selection import (
    ADD, FIXED, FREE, HANDLE, REMOVE, REPLACE, brush_hits, combine, fixed_mask, op_from_modifiers,
    project_points, rectangle_hits, stroke_hits, unproject, vertex_states,
)


def _camera(position=(0.0, 0.0, 10.0), focal=(0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0), size=(640, 480)):
    """A VTK camera's composite matrix and the same points projected by vtkCoordinate."""
    from vtkmodules.vtkRenderingCore import vtkCamera, vtkRenderer, vtkRenderWindow

    ren = vtkRenderer()
    win = vtkRenderWindow()
    win.SetOffScreenRendering(1)
    win.SetSize(*size)
    win.AddRenderer(ren)
    cam = vtkCamera()
    cam.SetPosition(*position)
    cam.SetFocalPoint(*focal)
    cam.SetViewUp(*up)
    ren.SetActiveCamera(cam)
    ren.ResetCameraClippingRange(-3, 3, -3, 3, -3, 3)
    m = cam.GetCompositeProjectionTransformMatrix(size[0] / size[1], -1, 1)
    C = np.array([[m.GetElement(i, j) for j in range(4)] for i in range(4)])
    return C, ren, win


def test_projection_matches_vtk_world_to_display():
    from vtkmodules.vtkRenderingCore import vtkCoordinate

    C, ren, win = _camera(position=(3.0, 4.0, 9.0), up=(0.1, 1.0, 0.0))
    rng = np.random.default_rng(0)
    pts = rng.uniform(-2, 2, size=(20, 3))
    disp, front = project_points(pts, C, (640, 480))
    assert front.all()
    coord = vtkCoordinate()
    coord.SetCoordinateSystemToWorld()
    for p, d in zip(pts, disp):
        coord.SetValue(*p)
        x, y = coord.GetComputedDoubleDisplayValue(ren)
        assert abs(x - d[0]) < 1e-6 and abs(y - d[1]) < 1e-6
    back = unproject(disp[3, 0], disp[3, 1], disp[3, 2], C, (640, 480))
    assert np.allclose(back, pts[3], atol=1e-9)


def test_points_behind_the_camera_never_hit():
    C, _, _ = _camera()
    disp, front = project_points(np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 20.0]]), C, (640, 480))
    assert front.tolist() == [True, False]
    hits = rectangle_hits(disp, front, (-1e9, -1e9), (1e9, 1e9))
    assert hits.tolist() == [True, False]


def test_rectangle_and_brush_hits():
    disp = np.array([[10.0, 10.0, 0], [50.0, 50.0, 0], [100.0, 20.0, 0], [49.0, 52.0, 0]])
    front = np.ones(4, dtype=bool)
    assert rectangle_hits(disp, front, (60, 60), (0, 0)).tolist() == [True, True, False, True]
    assert brush_hits(disp, front, (50, 50), 3.0).tolist() == [False, True, False, True]
    # a stroke sweeps the brush along the segment between two mouse events
    assert stroke_hits(disp, front, (0, 20), (100, 20), 2.0).tolist() == [False, False, True, False]


def test_modifiers_and_combine():
    assert op_from_modifiers(False, False) == REPLACE
    assert op_from_modifiers(True, False) == ADD
    assert op_from_modifiers(False, True) == REMOVE
    cur = np.array([True, True, False, False])
    hits = np.array([False, True, True, False])
    assert combine(cur, hits, REPLACE).tolist() == [False, True, True, False]
    assert combine(cur, hits, ADD).tolist() == [True, True, True, False]
    assert combine(cur, hits, REMOVE).tolist() == [True, False, False, False]
    with pytest.raises(ValueError):
        combine(cur, hits, "xor")


def test_states_and_fixed():
    roi = np.array([True, True, False, False])
    handle = np.array([False, True, False, True])
    assert vertex_states(roi, handle).tolist() == [FREE, HANDLE, FIXED, HANDLE]
    assert fixed_mask(roi, handle).tolist() == [False, False, True, False]


def test_gizmo_drag_math_follows_the_mouse():
    C, _, _ = _camera()
    size = (640, 480)
    center = np.array([0.5, 0.0, 0.0])
    L = 1.0
    c2, _ = project_points(center[None], C, size)
    # the X arrow lies along the screen x axis: dragging 50 px right moves the handle +X by 50 px worth
    t = gz.axis_translation((c2[0, 0], c2[0, 1]), (c2[0, 0] + 50, c2[0, 1] + 30), center, 0, L, C, size)
    moved, _ = project_points((center + t)[None], C, size)
    assert t[1] == 0 and t[2] == 0 and t[0] > 0
    assert abs(moved[0, 0] - (c2[0, 0] + 50)) < 1e-6
    # the Z arrow points at the viewer: no motion along it
    assert np.all(gz.axis_translation((0, 0), (40, 40), center, 2, L, C, size) == 0)
    # the Z ring faces the viewer: dragging counter-clockwise rotates positively about +Z
    r = gz.RING_RATIO * L
    grab = gz.grab_direction((c2[0, 0] + 200, c2[0, 1]), center, 2, r, C, size)
    assert np.allclose(grab, [1, 0, 0], atol=0.05)
    deg = gz.ring_angle((c2[0, 0] + 50, c2[0, 1]), (c2[0, 0] + 50, c2[0, 1] + 10), center, 2, r, grab, C, size)
    assert deg > 0
    # screen-plane translation keeps the depth and follows the mouse
    t = gz.screen_plane_translation((100, 100), (160, 100), center, C, size)
    assert abs(t[2]) < 1e-9 and t[0] > 0 and abs(t[1]) < 1e-9
    # the hit test finds the arrow and the ring
    tip, _ = project_points((center + [0.6 * L, 0, 0])[None], C, size)
    assert gz.hit_test((tip[0, 0], tip[0, 1] + 2), center, L, C, size) == gz.Part("move", 0)
    ring_pt, _ = project_points((center + r * np.array([np.cos(1.0), np.sin(1.0), 0]))[None], C, size)
    assert gz.hit_test((ring_pt[0, 0], ring_pt[0, 1]), center, L, C, size) == gz.Part("rotate", 2)
    assert gz.hit_test((5, 5), center, L, C, size) is None
    # rotation part transform turns about the gizmo center
    T = gz.part_transform(gz.Part("rotate", 2), (c2[0, 0] + 50, c2[0, 1]), (c2[0, 0] + 50, c2[0, 1] + 10),
                          center, L, grab, C, size)
    assert np.allclose(apply_transform(T, center[None])[0], center)


def _snap(k: int) -> Snapshot:
    m = np.zeros(3, dtype=bool)
    return Snapshot(m, m, np.full((3, 3), float(k)), np.eye(4), None, label=f"s{k}")


def test_history_undo_redo_and_branching():
    h = History(limit=10)
    for k in range(3):
        h.push(_snap(k))
    assert h.can_undo() and not h.can_redo()
    assert h.undo().label == "s1"
    assert h.undo().label == "s0"
    assert h.undo() is None  # the base state cannot be undone
    assert h.redo().label == "s1"
    h.push(_snap(9))  # drops the redo branch
    assert not h.can_redo() and h.current.label == "s9"
    assert h.undo().label == "s1"
    h2 = History(limit=3)
    for k in range(5):
        h2.push(_snap(k))
    assert len(h2) == 3 and h2.current.label == "s4"
