"""Drag frames on a worker thread: one job at a time, the latest pending job wins, results on the UI thread."""

from __future__ import annotations

import os
import threading
import time

import numba
import pytest
from qtpy import QtWidgets

from hybridedit.viewer.framethread import ALL_THREADS, NICE, FrameThread
from test_window import win  # noqa: F401 (fixture)


@pytest.fixture
def app():
    return QtWidgets.QApplication.instance() or QtWidgets.QApplication([])


def _thread(handled):
    ui = threading.get_ident()

    def handler(ok, value):
        handled.append((ok, value, threading.get_ident() == ui))

    return FrameThread(handler)


def test_results_reach_the_handler_on_the_ui_thread_latest_pending_wins(qtbot, app):
    handled = []
    ft = _thread(handled)
    gate = threading.Event()
    seen, nice = [], []

    def job(k, wait=False):
        def run():
            if wait:
                gate.wait(5.0)
            seen.append((k, threading.get_ident() != threading.main_thread().ident, numba.get_num_threads()))
            nice.append(os.getpriority(os.PRIO_PROCESS, threading.get_native_id()))
            return k
        return run

    ft.submit(job(1, wait=True))
    ft.submit(job(2))
    ft.submit(job(3))  # replaces 2: only the newest waiting job runs
    assert ft.busy
    gate.set()
    qtbot.waitUntil(lambda: len(handled) == 2, timeout=5000)
    assert [h[1] for h in handled] == [1, 3]
    assert all(ok and on_ui for ok, _, on_ui in handled)
    assert [k for k, _, _ in seen] == [1, 3] and all(off_ui for _, off_ui, _ in seen)
    # the job submitted to an idle worker gets every core; the pending one runs beside the render
    assert seen[0][2] == ALL_THREADS and seen[1][2] == 1
    assert min(nice) >= NICE  # the render's threads come first
    qtbot.waitUntil(lambda: not ft.busy, timeout=5000)
    ft.stop()


def test_flush_finishes_and_hands_over_everything_now(app):
    handled = []
    ft = _thread(handled)
    ft.submit(lambda: (time.sleep(0.05), "a")[1])
    ft.submit(lambda: "b")
    ft.flush()  # no event loop needed: both handled, in order, before flush returns
    assert [h[1] for h in handled] == ["a", "b"]
    assert not ft.busy
    app.processEvents()  # the queued notifications find nothing left to hand over
    assert len(handled) == 2
    ft.stop()


def test_errors_come_back_as_values_and_discard_drops_the_rest(app):
    handled = []
    ft = _thread(handled)

    def bad():
        raise ValueError("degenerate transform")

    ft.submit(bad)
    ft.flush()
    ok, err, on_ui = handled[0]
    assert not ok and isinstance(err, ValueError) and on_ui
    gate = threading.Event()
    ft.submit(lambda: gate.wait(5.0))
    ft.submit(lambda: "never")
    threading.Timer(0.05, gate.set).start()
    ft.discard()  # waits for the running job, drops its result and the pending job
    ft.flush()
    app.processEvents()
    assert len(handled) == 1 and not ft.busy
    ft.stop()
    ft.submit(lambda: "after stop")  # ignored
    assert not ft.busy


# ------------------------------------------------------------------ in the window

def test_window_drag_frames_show_the_engine_pose_mid_drag_and_failures_undo(qtbot, win, monkeypatch):
    import numpy as np
    from qtpy import QtCore

    from test_window_polish import handle_point, select_tip  # noqa: I001

    Qt = QtCore.Qt
    w = win
    s = w.session
    rest = s.shape_positions.copy()
    select_tip(qtbot, w)
    a = handle_point(w)
    qtbot.mousePress(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, a)
    for k in range(1, 5):
        qtbot.mouseMove(w.view, a + QtCore.QPoint(0, -15 * k))
        qtbot.wait(5)
        w.frames.flush()  # the frame of this mouse position is on its way to the screen
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
    qtbot.waitUntil(lambda: not w.settle_timer.isActive(), timeout=20000)
    posed = s.shape_positions.copy()
    assert np.allclose(w.scene.parts.drawn_points(), posed, atol=1e-5)
    # a frame that fails on the frame thread: the drag is undone and said so, nothing half-shown
    monkeypatch.setattr(type(s), "drag_to", lambda self, T, iterations=None: (_ for _ in ()).throw(
        ValueError("the drag moves the handle to non-finite positions")))
    a = handle_point(w)
    qtbot.mousePress(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, a)
    qtbot.mouseMove(w.view, a + QtCore.QPoint(0, -20))
    qtbot.waitUntil(lambda: w.last_error is not None, timeout=5000)
    qtbot.mouseRelease(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, a + QtCore.QPoint(0, -20))
    assert "non-finite" in w.last_error and "undone" in w.last_error
    assert w.controller.gesture is None and not w.frames.busy
    assert np.allclose(s.shape_positions, posed) and np.allclose(w.scene.parts.drawn_points(), posed, atol=1e-5)
