"""Pure parts of the window: projection, hit tests, set logic, gizmo math, edit-file decomposition."""

from __future__ import annotations

import numpy as np
import pytest

from hybridedit.core.transforms import apply_transform
from hybridedit.deform.roles import FIXED, FREE, handle as handle_role
from hybridedit.viewer.model import gizmo as gz
from hybridedit.viewer.model.history import History, Snapshot
from hybridedit.viewer.model.picking import (
    ADD, REMOVE, REPLACE, brush_hits, combine, nearest_hit, op_from_modifiers, project_points,
    rectangle_hits, selection_roles, stroke_hits, unproject, visible_points,
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


def test_visible_points_against_a_depth_buffer():
    """A wall facing the camera covers the left half of the view; right of it the background above the
    middle row and another wall, farther back, below it. What lies behind the near wall is hidden,
    unless it is within the tolerance of it (a cage point just inside the surface) or lies on the
    surface seen within the radius (near the rim of a silhouette, where its own pixel shows the
    surface in front of it); a point behind the wall's outline with the background beyond is hidden."""
    size = (640, 480)
    C, _, _ = _camera(size=size)  # at (0, 0, 10) looking down -Z; the wall is the plane z = 0, x < 0
    z_ndc = {z: project_points(np.array([[0.0, 0.0, z]]), C, size)[0][0, 2] for z in (0.0, -1.0)}
    depth = np.ones((size[1], size[0]), dtype=np.float32)  # background: the far plane
    depth[:, : size[0] // 2] = 0.5 * (z_ndc[0.0] + 1.0)  # (a plane facing the camera: one depth)
    depth[size[1] // 2:, size[0] // 2:] = 0.5 * (z_ndc[-1.0] + 1.0)  # the far wall, z = -1, lower right
    edge = size[0] / 2
    pts = np.array([
        [-1.0, 0.0, -1.0],                      # 0 behind the wall
        [1.0, -0.5, -1.0],                      # 1 right of it, in front of the background
        [-1.0, 0.5, -0.05],                     # 2 just behind the wall's surface
        [-1.0, 0.0, 0.5],                       # 3 in front of the wall
        unproject(edge - 1.5, 200.0, z_ndc[-1.0], C, size),  # 4 behind the wall's rim, background beyond
        unproject(edge - 0.5, 300.0, z_ndc[-1.0], C, size),  # 5 on the far wall, behind the rim by a pixel
        unproject(edge - 2.5, 300.0, z_ndc[-1.0], C, size),  # 6 the same, by three pixels
        [-100.0, 0.0, -1.0],                    # 7 off screen
        [0.0, 0.0, 20.0],                       # 8 behind the camera
    ])
    disp, front = project_points(pts, C, size)

    def vis(tolerance=0.1, radius=1, image=depth, origin=(0, 0)):
        return visible_points(disp, front, image, origin, C, size, tolerance=tolerance, radius=radius).tolist()

    assert vis() == [False, True, True, True, False, True, False, False, False]
    assert not vis(tolerance=0.01)[2]
    assert not vis(radius=0)[5] and vis(radius=3)[6] and not vis(radius=3)[4]
    # a depth image of part of the view: pixels are counted from its origin
    inside = (disp[:, 0] >= 200) & (disp[:, 0] < 400) & (disp[:, 1] >= 100) & (disp[:, 1] < 400)
    assert vis(image=depth[100:400, 200:400], origin=(200, 100)) == (np.array(vis()) & inside).tolist()


def test_a_click_takes_the_nearest_point():
    disp = np.array([[10.0, 10.0, 0.2], [14.0, 10.0, 0.1], [30.0, 30.0, 0.0], [14.0, 10.0, -0.3]])
    front = np.array([True, True, True, False])
    assert nearest_hit(disp, front, (11.0, 10.0), 12.0).tolist() == [True, False, False, False]
    # two points on one pixel: the one nearer the camera (the one behind it is not in front here)
    front[3] = True
    assert nearest_hit(disp, front, (14.0, 10.0), 12.0).tolist() == [False, False, False, True]
    assert not nearest_hit(disp, front, (100.0, 100.0), 12.0).any()  # nothing near: nothing taken


def test_selection_roles():
    roi = np.array([True, True, False, False])
    handle = np.array([False, True, False, True])
    assert selection_roles(roi, handle).tolist() == [FREE, handle_role(0), FIXED, handle_role(0)]
    groups = np.array([0, handle_role(1), 0, handle_role(0)], dtype=np.int8)  # (the session's handle_group)
    assert selection_roles(roi, groups).tolist() == [FREE, handle_role(1), FIXED, handle_role(0)]


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
