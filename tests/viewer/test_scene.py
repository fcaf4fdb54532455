"""A clear view: the shape is what is seen; cage points only where they help; the fixed region as a tint."""

from __future__ import annotations

import numpy as np
from qtpy import QtCore

from hybridedit.deform.roles import FIXED
from hybridedit.viewer.render.palette import SHAPE_COLOR
from support.window_driving import drag_tip, key, projected, to_widget

Qt = QtCore.Qt


def test_cage_points_only_where_they_help(qtbot, win):
    w = win
    s = w.session
    assert len(w.scene.shown_points) == 0  # nothing selected: no cage point hides the shape
    assert not w.scene.cage_front.GetVisibility()  # the wireframe is a toggle (W), off
    assert np.all(w.scene.parts.face_colours() == SHAPE_COLOR.astype(np.uint8))
    P = s.cage_positions
    s.selection.set_mask("roi", P[:, 0] > 0.0)
    s.selection.set_mask("handle", P[:, 0] > 1.4)
    w.sync.refresh_selection()
    shown = set(w.scene.shown_points.tolist())
    assert shown == set(np.flatnonzero(s.selection.cage_roles() != FIXED).tolist())  # the ROI and the handle
    assert w.scene.points_poly.n_verts == len(shown)
    # the fixed region is a tint on the shape, the free region keeps the shape's colour, the handle orange
    # (a face takes its vertices' common role; faces between roles keep the shape's colour)
    fr = s.selection.shape_roles()[s.mesh.faces]
    tint = w.scene.parts.face_colours()
    base = SHAPE_COLOR.astype(np.uint8)
    fixed, free, hand = (fr < 0).all(axis=1), (fr == 0).any(axis=1), (fr > 0).all(axis=1)
    assert fixed.any() and np.all(np.any(tint[fixed] != base, axis=1))
    assert np.all(tint[free] == base)
    assert hand.any() and np.all(tint[hand, 0] > tint[hand, 2])  # warm: orange over the handle
    assert np.all(w.scene.parts.drawn_faces() == 1)  # every face drawn, once
    # Select mode: the cage points near the cursor show too, wherever it is
    key(qtbot, w, Qt.Key.Key_S)
    far_end = P[P[:, 0] < -1.5].mean(axis=0)
    dc, _ = projected(w, far_end[None])
    qtbot.mouseMove(w.view, to_widget(w, dc[0]))
    qtbot.wait(30)
    near = set(w.scene.shown_points.tolist()) - shown
    assert near and np.all(P[sorted(near), 0] < -0.5)
    # back in Camera mode they go
    key(qtbot, w, Qt.Key.Key_C)
    assert set(w.scene.shown_points.tolist()) == shown


def test_a_dense_cage_draws_small_points_and_they_grow_as_the_view_zooms_in(qtbot, win):
    """Cage points are drawn a fraction of the cage's spacing on screen wide: the ROI of a dense cage tints the
    surface instead of covering it."""
    from hybridedit.viewer.render.scene import POINT_PIXELS, POINT_SPACING

    w = win
    sc = w.scene
    w.view.render()
    size = sc.points_actor.prop.point_size
    assert size == sc.point_pixels() and POINT_PIXELS[0] <= size <= POINT_PIXELS[1]
    # the spacing on screen, measured: the projected length of the cage's median edge
    P = w.session.cage_positions
    d, _ = projected(w, np.array([P.mean(axis=0), P.mean(axis=0) + [sc.cage_spacing, 0, 0]]))
    assert abs(size - POINT_SPACING * np.hypot(*(d[1, :2] - d[0, :2]))) <= 1.0 or size in POINT_PIXELS
    # a cage fifty times as dense draws its points at the smallest size
    sc.cage_spacing /= 50.0
    w.view.render()
    assert sc.points_actor.prop.point_size == POINT_PIXELS[0] < size
    # zoomed in, they grow back
    sc.renderer.GetActiveCamera().Zoom(6.0)
    w.view.render()
    assert sc.points_actor.prop.point_size > POINT_PIXELS[0]
    # the stretch map's legend: text at a readable fixed size, not scaled to the bar's width
    bar = sc.stretch_bar
    assert bar.GetUnconstrainedFontSize() and bar.GetTitleTextProperty().GetFontSize() >= 12


def test_undoing_a_drag_keeps_the_shapes_parts_and_a_new_selection_remakes_them(qtbot, win):
    """The shape's parts (one actor per role) are remade only when the roles change: undoing a drag
    (same selection) redraws the rest pose in the same parts; selecting something else splits anew."""

    w = win
    s = w.session
    drag_tip(qtbot, w)
    parts = list(w.scene.parts.parts)
    assert s.is_posed()
    w.actions_["undo"].trigger()
    qtbot.waitUntil(lambda: not s.is_posed(), timeout=10000)
    assert [id(p) for p in w.scene.parts.parts] == [id(p) for p in parts]
    drawn = w.scene.parts.drawn_points()
    np.testing.assert_array_equal(drawn, s.shape_positions.astype(np.float32))  # the rest pose, in them
    P = s.cage_positions
    s.selection.set_mask("handle", P[:, 0] > 1.2)  # another handle: the tint changes, the parts are made again
    w.sync.refresh_selection()
    assert not any(p is q for p in w.scene.parts.parts for q in parts)
    np.testing.assert_array_equal(w.scene.parts.drawn_points(), s.shape_positions.astype(np.float32))
