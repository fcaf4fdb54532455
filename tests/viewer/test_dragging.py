"""Dragging in the window (viewer/dragging.py), through real Qt mouse events: frames computed beside
the render show the engine's pose, a failing frame undoes the drag, the edge error is measured a
few times a second, and the settle after a release runs in slices or completes at once."""

from __future__ import annotations

import threading

import numpy as np
from qtpy import QtCore

from hybridedit.viewer.input import drags as dragging
from support.window_driving import handle_point, select_tip_to_drag

Qt = QtCore.Qt


def test_window_drag_frames_show_the_engine_pose_mid_drag_and_failures_undo(qtbot, win, monkeypatch):
    w = win
    s = w.session
    rest = s.shape_positions.copy()
    select_tip_to_drag(qtbot, w)
    a = handle_point(w)
    qtbot.mousePress(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, a)
    for k in range(1, 5):
        qtbot.mouseMove(w.view, a + QtCore.QPoint(0, -15 * k))
        qtbot.wait(5)
        w.dragging.frames.flush()  # the frame of this mouse position is on its way to the screen
        assert np.allclose(w.scene.parts.drawn_points(), s.shape_positions, atol=1e-5)
        # the cage's normals and bounds came with the frame, for this pose
        cage = np.asarray(w.scene.points_poly.points)
        assert np.allclose(cage, s.cage_positions)
        lo, hi = w.scene._cage_bounds
        assert np.allclose(lo, cage.min(axis=0)) and np.allclose(hi, cage.max(axis=0))
        fresh = np.zeros((len(cage), 3), dtype=np.float32)
        w.scene._cage_metrics.write_normals(cage, fresh, everything=True)
        assert np.allclose(w.scene._cage_normals, fresh, atol=1e-6)
    assert np.abs(s.shape_positions - rest).max() > 0.05  # it moved, mid-drag
    qtbot.mouseRelease(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, a + QtCore.QPoint(0, -60))
    qtbot.waitUntil(lambda: not w.dragging.settle_timer.isActive(), timeout=20000)
    posed = s.shape_positions.copy()
    assert np.allclose(w.scene.parts.drawn_points(), posed, atol=1e-5)
    # a frame that fails on the frame thread: the drag is undone and said so, nothing half-shown
    monkeypatch.setattr(type(s), "drag_to", lambda self, T, iterations=None: (_ for _ in ()).throw(
        ValueError("the drag moves the handle to non-finite positions")))
    a = handle_point(w)
    qtbot.mousePress(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, a)
    qtbot.mouseMove(w.view, a + QtCore.QPoint(0, -20))
    qtbot.waitUntil(lambda: w.status.last_error is not None, timeout=5000)
    qtbot.mouseRelease(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, a + QtCore.QPoint(0, -20))
    assert "non-finite" in w.status.last_error and "undone" in w.status.last_error
    assert w.controller.gesture is None and not w.dragging.frames.busy
    assert np.allclose(s.shape_positions, posed) and np.allclose(w.scene.parts.drawn_points(), posed, atol=1e-5)


def _press_and_move(qtbot, w, moves: int, step: int = 6) -> QtCore.QPoint:
    a = handle_point(w)
    qtbot.mousePress(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, a)
    for k in range(1, moves + 1):
        qtbot.mouseMove(w.view, a + QtCore.QPoint(0, -step * k))
        qtbot.wait(5)
        w.dragging.frames.flush()
    return a + QtCore.QPoint(0, -step * moves)


def test_edge_error_a_few_times_a_second_and_every_frame_with_the_stretch_map(qtbot, win, monkeypatch):
    w = win
    w.polisher.enabled = False
    s = w.session
    select_tip_to_drag(qtbot, w)
    monkeypatch.setattr(dragging, "ERROR_INTERVAL", 60.0)  # at most once in this drag
    measured = []
    ui = threading.get_ident()
    update_error = type(s.metrics).update_error

    def counting(metrics, V, *, everything=False):
        if threading.get_ident() != ui:  # (a drag frame's, on the frame thread)
            measured.append(everything)
        return update_error(metrics, V, everything=everything)

    monkeypatch.setattr(type(s.metrics), "update_error", counting)
    end = _press_and_move(qtbot, w, 6)
    assert measured == [False]  # the first frame measures its region's edges, the other five do not
    assert 0 < w.dragging.engine_ms <= w.dragging.thread_ms  # (the solve is part of the frame thread's work)
    qtbot.mouseRelease(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, end)
    qtbot.waitUntil(lambda: not w.dragging.settle_timer.isActive(), timeout=20000)
    qtbot.keyClick(w.view, Qt.Key.Key_T)  # the stretch map: every frame measures (the colours follow the pose)
    assert w.scene.stretch_visible
    measured.clear()
    end = _press_and_move(qtbot, w, 4)
    assert measured.count(False) == 4
    qtbot.mouseRelease(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, end)
    qtbot.waitUntil(lambda: not w.dragging.settle_timer.isActive(), timeout=20000)


def test_a_release_settles_in_slices_and_finish_completes_it_at_once(qtbot, win):
    w = win
    w.polisher.enabled = False
    s = w.session
    select_tip_to_drag(qtbot, w)
    end = _press_and_move(qtbot, w, 4, step=15)
    qtbot.mouseRelease(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, end)
    assert s.settling and w.dragging.settle_timer.isActive()  # the last interactive frame stays on screen meanwhile
    w.posing.finish_settle()  # e.g. a save right after the release: the settled pose, now
    assert not s.settling and not w.dragging.settle_timer.isActive()
    assert w.actions_["undo"].isEnabled() and s.history.can_undo()  # the drag is one undo step, recorded now
    assert np.allclose(w.scene.parts.drawn_points(), s.shape_positions, atol=1e-5)


def test_a_move_while_a_frame_waits_to_be_drawn_is_computed_beside_that_render(qtbot, win, monkeypatch):
    """A move handed over before the previous frame is drawn runs on one thread beside that render
    (a parallel region beside the software rasterizer waits for its slowest thread); a move the
    window has to wait for gets every core."""
    w = win
    w.polisher.enabled = False
    select_tip_to_drag(qtbot, w)
    asked = []
    submit = w.dragging.frames.submit
    monkeypatch.setattr(w.dragging.frames, "submit", lambda job, *, beside_render=False: (
        asked.append(beside_render), submit(job, beside_render=beside_render)))
    a = handle_point(w)
    qtbot.mousePress(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, a)
    qtbot.waitUntil(lambda: not w.view.render_pending, timeout=5000)  # nothing left to draw
    qtbot.mouseMove(w.view, a + QtCore.QPoint(0, -10))
    w.dragging.frames.flush()  # its frame is handed over: a render is due now
    assert w.view.render_pending
    qtbot.mouseMove(w.view, a + QtCore.QPoint(0, -20))
    assert asked == [False, True]
    qtbot.mouseRelease(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, a + QtCore.QPoint(0, -20))
    qtbot.waitUntil(lambda: not w.dragging.settle_timer.isActive(), timeout=20000)
