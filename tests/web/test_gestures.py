"""The browser's gestures (hybridedit.web.gestures) on an off-screen scene, without a browser: a
rectangle or a brush takes the part in sight through its thickness and not the part hidden behind
it, as the window's does; with no depth buffer, every point in front; one undo step a gesture."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

pytest.importorskip("pyvista")

import pyvista as pv  # noqa: E402

import hybridedit as he  # noqa: E402
from hybridedit.viewer.app import _headless_render_window  # noqa: E402
from hybridedit.viewer.model.session import Session  # noqa: E402
from hybridedit.viewer.render.depth_grab import DepthGrab  # noqa: E402
from hybridedit.viewer.render.scene import Scene  # noqa: E402
from hybridedit.viewer.model.picking import project_points  # noqa: E402
from hybridedit.viewer.model import gizmo as gz  # noqa: E402
from hybridedit.web.gestures import BRUSH, DRAG, HANDLE, POSE, ROI, SELECT, Gestures  # noqa: E402


def _scene(session, size=(400, 400)):
    _headless_render_window()
    pl = pv.Plotter(off_screen=True, window_size=list(size))
    scene = Scene(pl)
    s = session
    scene.load(s.metrics, s.shown_positions, s.cage_positions, s.editor.cage.faces, s.selection.cage_roles(),
               s.selection.shape_roles())
    cam = scene.renderer.GetActiveCamera()
    cam.SetFocalPoint(0.0, 0.0, 0.0)
    cam.SetPosition(0.0, 0.0, 12.0)  # looking down -Z
    cam.SetViewUp(0.0, 1.0, 0.0)
    scene.renderer.ResetCameraClippingRange()
    pl.ren_win.Render()
    grab = DepthGrab(pl.ren_win, scene.renderer)
    grab.wanted = True
    grab.key_fn = lambda: (cam.GetMTime(), tuple(pl.ren_win.GetSize()))
    return pl, scene, grab


@pytest.fixture
def two_balls():
    """A ball in front of another (along the line of sight), as a quadruped's near leg hides its far one."""
    a, b = trimesh.creation.icosphere(3), trimesh.creation.icosphere(3)
    b.apply_translation([0.0, 0.0, -4.0])
    both = trimesh.util.concatenate([a, b])
    session = Session(he.HybridEditor(he.Mesh(both.vertices, both.faces), 160), cage_size=160)
    pl, scene, grab = _scene(session)
    yield session, scene, grab
    pl.close()


def test_a_rectangle_takes_the_part_in_sight_whole_and_not_the_one_behind(two_balls):
    session, scene, grab = two_balls
    g = Gestures(session, scene, grab)
    g.mode, g.target = SELECT, ROI
    w, h = scene.display_size()
    g.press(2, 2, False, False)
    assert g.release(w - 2, h - 2)
    P = session.cage_positions
    near = P[:, 2] > -2.0
    taken = session.selection.roi
    assert taken[near].all(), "the near ball is taken through its thickness, its far side too"
    assert not taken[~near].any(), "the ball hidden behind it is not"
    assert session.undo() and not session.selection.roi.any()  # one undo step


def test_a_brush_stroke_is_one_undo_step_and_takes_what_it_passes(two_balls):
    session, scene, grab = two_balls
    g = Gestures(session, scene, grab)
    g.mode, g.target, g.tool = SELECT, ROI, BRUSH
    w, h = scene.display_size()
    P = session.cage_positions
    C = scene.composite_matrix()
    display, _ = project_points(P, C, (w, h))
    assert g.press(w / 2 - 60, h / 2, False, False)  # the first dab takes points
    first = session.selection.roi.copy()
    assert first.any()
    for k in range(1, 7):
        g.move(w / 2 - 60 + 20 * k, h / 2)  # a stroke to the right
    assert g.release(w / 2 + 60, h / 2)
    taken = session.selection.roi
    assert (taken & ~first).any() and (taken >= first).all()  # the stroke added what it passed over
    near = P[:, 2] > -2.0
    assert not taken[~near].any()
    dx = np.abs(display[taken & (P[:, 2] > 0.5), 0] - w / 2)  # the points facing the camera it took
    assert dx.max() <= 60 + g.brush_radius + 1
    assert session.undo() and not session.selection.roi.any()  # the whole stroke: one undo step
    g.press(5, 5, False, False)  # a stroke over empty space changes nothing
    assert not g.release(6, 6)


def test_a_rectangle_without_depth_takes_every_point_in_front(two_balls):
    session, scene, _ = two_balls
    g = Gestures(session, scene, None)
    g.mode, g.target = SELECT, ROI
    w, h = scene.display_size()
    g.press(2, 2, False, False)
    g.release(w - 2, h - 2)
    assert session.selection.roi.all()


@pytest.fixture
def ball():
    mesh = trimesh.creation.icosphere(3)
    session = Session(he.HybridEditor(he.Mesh(mesh.vertices, mesh.faces), 120), cage_size=120)
    pl, scene, grab = _scene(session)
    yield session, scene
    pl.close()


def _pixel_on(scene, part) -> tuple[float, float]:
    """A display pixel where the gizmo's hit test finds ``part``."""
    C, (w, h) = scene.composite_matrix(), scene.display_size()
    for y in range(0, h, 3):
        for x in range(0, w, 3):
            if scene.gizmo.hit((x, y), C, (w, h)) == part:
                return float(x), float(y)
    raise AssertionError(f"{part} is nowhere on screen")


@pytest.mark.parametrize("part", [gz.Part("move", 0), gz.Part("rotate", 2)])
def test_a_drag_on_the_gizmo_moves_along_its_arrow_or_turns_round_its_ring(ball, part):
    session, scene = ball
    P = session.cage_positions
    sel = session.selection
    sel.select(ROI, P[:, 1] > -0.3, "replace")
    sel.select(HANDLE, P[:, 1] > 0.6, "replace")
    session.apply_selection()
    scene.gizmo.place(session.handle_centroid())  # (as the editor shows it in Drag mode)
    g = Gestures(session, scene, None)
    g.mode = DRAG
    x, y = _pixel_on(scene, part)
    handle = sel.handle.copy()
    before = session.cage_positions[handle]
    center = before.mean(axis=0)
    assert g.press(x, y, False, False)
    for k in range(1, 6):
        g.move(x + 6 * k, y + 6 * k)
    assert g.release(x + 30, y + 30)
    after = session.cage_positions[handle]
    if part.kind == "move":  # along X only, the handle rigidly
        d = after - before
        assert abs(d[:, 0].mean()) > 0.05
        np.testing.assert_allclose(d, np.tile(d.mean(axis=0), (len(d), 1)), atol=1e-6)
        np.testing.assert_allclose(d.mean(axis=0)[1:], 0.0, atol=1e-6)
    else:  # round Z through the handle's centre: z and the distance to the axis kept, the points turned
        np.testing.assert_allclose(after[:, 2], before[:, 2], atol=1e-6)
        r0 = np.linalg.norm((before - center)[:, :2], axis=1)
        np.testing.assert_allclose(np.linalg.norm((after - center)[:, :2], axis=1), r0, atol=1e-6)
        assert np.abs(after - before).max() > 0.01


@pytest.fixture(scope="module")
def figure_session():
    from shapes import figure

    mesh = figure()
    return Session(he.HybridEditor(mesh, 0.1), cage_size=0.1)


def test_pose_mode_turns_the_limb_under_the_mouse_about_its_joint(figure_session):
    session = figure_session
    pl, scene, grab = _scene(session, (500, 400))
    try:
        g = Gestures(session, scene, grab)
        g.mode = POSE
        arm = max(session.editor.limbs(), key=lambda limb: limb.tip[0])  # the arm out along +X
        C, size = scene.composite_matrix(), scene.display_size()
        tip = project_points(np.asarray(arm.tip, dtype=np.float64)[None], C, size)[0][0]
        g.press(5, 5, False, False)  # empty space: no limb, said so, nothing changed
        assert not g.busy and "No limb there" in g.message and not session.selection.roi.any()
        at = (tip[0] - 15, tip[1])
        assert g.press(*at, False, False)
        pose = arm.parts().placed(session.cage_positions)
        np.testing.assert_array_equal(session.selection.handle, pose.cage_handle)  # the limb is the selection
        np.testing.assert_array_equal(session.selection.roi, pose.cage_roi)
        assert scene.pivot.visible  # the joint is shown while the limb turns
        rest = session.shape_positions.copy()
        before = session.cage_positions[pose.cage_handle]
        for k in range(1, 6):
            g.move(at[0], at[1] + 12 * k)  # up on screen: the arm swings up about its shoulder
        assert g.release(at[0], at[1] + 60)
        assert not scene.pivot.visible
        after = session.cage_positions[pose.cage_handle]
        joint = np.asarray(pose.joint)
        np.testing.assert_allclose(np.linalg.norm(after - joint, axis=1), np.linalg.norm(before - joint, axis=1),
                                   atol=1e-6)  # turned about the joint, rigidly
        assert after[:, 1].mean() > before[:, 1].mean() + 0.2
        V = session.shape_positions
        body = np.abs(rest[:, 0]) < 0.3
        assert np.abs(V[body] - rest[body]).max() < 1e-9  # the body held
        assert session.undo() and np.array_equal(session.shape_positions, rest)  # the drag: one undo step
    finally:
        pl.close()


def test_select_through_takes_the_part_behind_too(two_balls):
    session, scene, grab = two_balls
    g = Gestures(session, scene, grab)
    g.mode, g.target, g.select_through = SELECT, ROI, True
    w, h = scene.display_size()
    g.press(2, 2, False, False)
    assert g.release(w - 2, h - 2)
    assert session.selection.roi.all()  # both balls, the hidden one too


def test_pose_mode_shows_the_limb_under_the_mouse_and_brackets_move_its_joint(figure_session):
    session = figure_session
    pl, scene, grab = _scene(session, (500, 400))
    try:
        g = Gestures(session, scene, grab)
        g.mode = POSE
        arm = max(session.editor.limbs(), key=lambda limb: limb.tip[0])
        C, size = scene.composite_matrix(), scene.display_size()
        tip = project_points(np.asarray(arm.tip, dtype=np.float64)[None], C, size)[0][0]
        at = (tip[0] - 15, tip[1])
        assert not g.hover(5, 5) and g.shown_limb is None  # empty space: nothing shown
        assert g.hover(*at) and g.shown_limb is arm and scene.pivot.visible
        assert not g.hover(at[0] + 1, at[1])  # the same limb: nothing to redraw
        before = g.joints.parts(arm, session.cage_positions).joint
        assert g.move_joint(-3) and "Joint at 70%" in g.message
        moved = g.joints.parts(arm, session.cage_positions)
        assert np.linalg.norm(moved.joint - arm.tip) < np.linalg.norm(before - arm.tip)  # toward the tip
        assert g.press(*at, False, False)  # the press takes the limb with its joint where it was moved
        np.testing.assert_array_equal(session.selection.handle, moved.cage_handle)
        g.release(*at)
        assert not scene.pivot.visible
        assert g.hover(*at) and g.shown_limb is arm  # shown again when the mouse moves on it
        assert g.hover(5, 5) and g.shown_limb is None and not scene.pivot.visible
        assert not g.move_joint(1)  # no limb shown: the brackets size the brush instead (the editor's)
    finally:
        pl.close()
