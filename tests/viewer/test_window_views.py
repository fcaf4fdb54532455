"""Front, side and top views and the up axis, through real key events: a Z-up statue opens standing,
numpad 1 / 3 / 7 (Ctrl: the other side) look at it as Blender's do, and the up axis chosen is remembered."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from qtpy import QtCore

from hybridedit.fileio.meshfiles import write_mesh
from hybridedit.core.mesh import Mesh
from hybridedit.viewer.render.scene import view_directions
from hybridedit.viewer.window.main_window import MainWindow
from support.window_driving import key, projected, wait_loaded

Qt = QtCore.Qt
KP, CTRL = Qt.KeyboardModifier.KeypadModifier, Qt.KeyboardModifier.ControlModifier


def z_up_statue() -> Mesh:
    """A ball on a flat box base, +Z up; the ball a little towards -Y (the statue's front, Z up)."""
    base = trimesh.creation.box(extents=[1.0, 1.0, 0.2])
    ball = trimesh.creation.icosphere(subdivisions=3, radius=0.5)
    ball.apply_translation([0.0, -0.15, 0.7])
    t = trimesh.util.concatenate([base, ball])
    return Mesh(np.asarray(t.vertices, dtype=np.float64), np.asarray(t.faces), name="statue")


@pytest.fixture
def statue(qtbot, tmp_path, monkeypatch):
    monkeypatch.setenv("HYBRIDEDIT_CACHE_DIR", str(tmp_path / "cache"))
    path = tmp_path / "statue.ply"
    write_mesh(path, z_up_statue())
    w = MainWindow(cage_size=120)
    w.resize(900, 700)
    w.show()
    qtbot.waitExposed(w)
    w.activateWindow()
    qtbot.waitActive(w)
    w.view.setFocus()
    assert w.loading.open_path(path)
    wait_loaded(qtbot, w)
    yield w, path
    w.unsaved.set_modified(False)
    w.close()
    w.deleteLater()


def screen_up(w: MainWindow) -> np.ndarray:
    """The world direction that points up on screen, and the one towards the camera."""
    cam = w.scene.renderer.GetActiveCamera()
    return np.array(cam.GetViewUp()), np.array(cam.GetPosition()) - np.array(cam.GetFocalPoint())


def test_a_z_up_statue_opens_standing_and_the_views_follow_its_up_axis(qtbot, statue):
    w, _ = statue
    s = w.session
    assert s.up_axis == "+Z" and w.actions_["up_+Z"].isChecked()
    up, _ = screen_up(w)
    assert up[2] > 0.9  # +Z up on screen (the opening view is turned a little)
    V = s.shape_positions
    d, _ = projected(w, V)
    assert d[V[:, 2] > 0.5, 1].mean() > d[V[:, 2] < 0.0, 1].mean()  # the ball above the base on screen
    expected = {(Qt.Key.Key_1, False): "front", (Qt.Key.Key_1, True): "back", (Qt.Key.Key_3, False): "right",
                (Qt.Key.Key_3, True): "left", (Qt.Key.Key_7, False): "top", (Qt.Key.Key_7, True): "bottom"}
    for (k, ctrl), view in expected.items():
        key(qtbot, w, k, KP | CTRL if ctrl else KP)
        up, towards = screen_up(w)
        direction, want_up = view_directions("+Z", view)
        assert np.allclose(towards / np.linalg.norm(towards), direction, atol=1e-6), view
        assert np.allclose(up, want_up, atol=1e-6), view
    key(qtbot, w, Qt.Key.Key_1)  # the digit row too
    assert np.allclose(view_directions("+Z", "front")[0], [0, -1, 0])  # (Blender's front view, Z up: from -Y)
    _, towards = screen_up(w)
    assert towards[1] < 0 and abs(towards[0]) < 1e-9 and abs(towards[2]) < 1e-9
    assert w.status.current_message().startswith("Front view")


def test_the_up_axis_chosen_is_remembered_for_the_shape(qtbot, statue):
    w, path = statue
    w.actions_["up_-X"].trigger()
    assert w.session.up_axis == "-X" and "remembered" in w.status.current_message()
    up, _ = screen_up(w)
    assert up[0] < -0.9
    w.unsaved.set_modified(False)
    assert w.loading.open_path(path)  # the same file again: it opens the way it was shown
    qtbot.waitUntil(lambda: w.jobs.worker is None and w.session.up_axis == "-X", timeout=60000)
    assert w.actions_["up_-X"].isChecked() and screen_up(w)[0][0] < -0.9


def test_the_screenshot_stands_a_z_up_statue_up(tmp_path, monkeypatch):
    from PIL import Image

    from hybridedit.viewer.app import render_screenshot

    monkeypatch.setenv("HYBRIDEDIT_CACHE_DIR", str(tmp_path / "cache"))
    path = tmp_path / "statue.ply"
    write_mesh(path, z_up_statue())
    out = tmp_path / "statue.png"
    assert render_screenshot(path, out, 120) == 0
    img = np.asarray(Image.open(out).convert("RGB")).astype(int)
    shape = (img[..., 0] - img[..., 2] > 15)  # the warm shape on the grey-blue background
    rows = np.flatnonzero(shape.any(axis=1))
    top, bottom = rows.min(), rows.max()
    width = shape.sum(axis=1)
    # the base (as wide as the ball is, a thin slab) at the bottom, the round ball above: the upper half
    # of the silhouette is the ball, narrowing to its top
    upper = width[top:(top + bottom) // 2]
    assert upper[: len(upper) // 4].mean() < upper[-len(upper) // 4:].mean()
