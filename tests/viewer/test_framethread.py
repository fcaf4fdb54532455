"""Drag frames on a worker thread: one job at a time, the latest pending job wins, results on the UI thread."""

from __future__ import annotations

import os
import threading
import time

import numba
import pytest
from qtpy import QtWidgets

from hybridedit.viewer.input.frame_thread import ALL_THREADS, NICE, FrameThread


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
    ft.submit(job(4), beside_render=True)  # an idle worker, but a render comes first: one thread
    qtbot.waitUntil(lambda: len(handled) == 3, timeout=5000)
    assert seen[2][0] == 4 and seen[2][2] == 1
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
