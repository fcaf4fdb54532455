"""Run by tests/viewer/test_window_recovery.py in a process of its own (not collected with the suite):
three edits in the window through real events, the first kept in the pose library (K), then the
process killed with SIGKILL, as a crash or
the out-of-memory killer ends it: nothing is closed, saved or cleaned up.

$HE_KILL_DIR names the folder of the test shape (``blob.obj``, written here) and of what the killed
window leaves for the test: ``lost.npy`` (the pose on display when it died), ``kept.npy`` (the pose it
kept) and ``cache.txt`` (its user cache folder, where its recovery file is).
"""

from __future__ import annotations

import os
import signal
from pathlib import Path

import numpy as np
from qtpy import QtCore

from hybridedit.core.cache_dir import default_cache_dir
from hybridedit.fileio.meshfiles import write_mesh
from shapes import capsule_blob
from support.window_driving import CAGE, around, key, mouse_drag, opened_window, polished, settled

Qt = QtCore.Qt


def edit(qtbot, w, roi, handle, move: QtCore.QPoint) -> None:
    """Select the ROI and the handle with rectangles (S, R, H), drag the handle by ``move`` (D), and
    wait for its settle and polish."""
    key(qtbot, w, Qt.Key.Key_S)
    key(qtbot, w, Qt.Key.Key_R)
    mouse_drag(qtbot, w.view, *around(w, roi))
    key(qtbot, w, Qt.Key.Key_H)
    mouse_drag(qtbot, w.view, *around(w, handle, margin=3.0))
    drag(qtbot, w, move)


def drag(qtbot, w, move: QtCore.QPoint) -> None:
    key(qtbot, w, Qt.Key.Key_D)
    from support.window_driving import handle_point

    a = handle_point(w)
    mouse_drag(qtbot, w.view, a, a + move, steps=8)
    settled(qtbot, w)
    polished(qtbot, w)


def test_three_edits_then_killed(qtbot):
    out = Path(os.environ["HE_KILL_DIR"])
    path = out / "blob.obj"
    write_mesh(path, capsule_blob())
    with opened_window(qtbot, cage_size=CAGE, path=path) as w:
        w.scene.reset_camera(tilted=False)
        w.view.request_render()
        qtbot.wait(30)
        P = w.session.cage_positions
        edit(qtbot, w, P[:, 0] > 0.3, P[:, 0] > 1.3, QtCore.QPoint(0, -70))
        key(qtbot, w, Qt.Key.Key_K)  # kept in the pose library
        np.save(out / "kept.npy", w.session.poses[0].positions)
        edit(qtbot, w, P[:, 0] < -0.3, P[:, 0] < -1.3, QtCore.QPoint(0, 60))
        drag(qtbot, w, QtCore.QPoint(40, 0))  # the same handle again: a third edit
        s = w.session
        assert len(s.editor.edit.steps) >= 3 and w.unsaved.modified
        qtbot.waitUntil(w.autosave.up_to_date, timeout=10000)
        np.save(out / "lost.npy", s.shown_positions)
        (out / "cache.txt").write_text(str(default_cache_dir()))
        os.kill(os.getpid(), signal.SIGKILL)
