"""The browser's gestures (hybridedit.web.gestures) on an off-screen scene, without a browser: a
rectangle over the whole shape takes only the cage points in sight, as the window's does, and all
of those in front with no depth buffer (Select Through)."""

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
from hybridedit.web.gestures import ROI, SELECT, Gestures  # noqa: E402


@pytest.fixture
def ball():
    mesh = trimesh.creation.icosphere(4)
    session = Session(he.HybridEditor(he.Mesh(mesh.vertices, mesh.faces), 200), cage_size=200)
    _headless_render_window()
    pl = pv.Plotter(off_screen=True, window_size=[400, 400])
    scene = Scene(pl)
    s = session
    scene.load(s.metrics, s.shown_positions, s.cage_positions, s.editor.cage.faces, s.selection.cage_roles(),
               s.selection.shape_roles())
    scene.reset_camera()
    pl.ren_win.Render()
    yield session, scene, pl
    pl.close()


def _whole_view(g: Gestures, size) -> np.ndarray:
    g.mode, g.target = SELECT, ROI
    g.press(1, 1, False, False)
    g.release(size[0] - 2, size[1] - 2)
    return g.session.selection.roi.copy()


def test_a_rectangle_takes_the_cage_points_in_sight_only(ball):
    session, scene, pl = ball
    grab = DepthGrab(pl.ren_win, scene.renderer)
    grab.wanted = True
    camera = scene.renderer.GetActiveCamera()
    grab.key_fn = lambda: (camera.GetMTime(), tuple(pl.ren_win.GetSize()))
    size = scene.display_size()
    taken = _whole_view(Gestures(session, scene, grab), size)
    P = session.cage_positions
    toward = np.asarray(camera.GetPosition()) - P.mean(axis=0)
    toward /= np.linalg.norm(toward)
    height = (P - P.mean(axis=0)) @ toward  # (c,) toward the camera: the near half > 0
    assert taken.any() and taken.sum() < 0.75 * len(P)
    assert np.all(height[taken] > -0.2)  # none from the far side
    assert taken[height > 0.5].all()  # and every point facing the camera
    session.selection.select(ROI, np.zeros(len(P), bool), "replace")
    assert _whole_view(Gestures(session, scene, None), size).all()  # no depth: every point in front
