"""A window that survives its own failures (issue 44, item 3), through the real window and real Qt events:
an exception injected in a drag frame, a polish, a build, a slot and the excepthook is said in one line in
the status bar and the message log naming its crash report (written, with the traceback, to the user cache
folder), the last good pose stays on screen exactly, and the next selection and drag work."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np
from qtpy import QtCore, QtWidgets

from hybridedit.deform.polish import PolishJob
from hybridedit.viewer.app import _install_excepthook
from hybridedit.viewer.model import building
from hybridedit.viewer.model.crash_reports import reports_folder
from hybridedit.viewer.window.main_window import MainWindow
from support.window_driving import (
    CAGE, drag_tip, handle_point, key, mouse_drag, polished, select_tip_to_drag, settled, wait_loaded,
)

Qt = QtCore.Qt
REPORT = re.compile(r"Report: (\S+\.txt)$")


def reported(w, starts: str) -> tuple[str, str]:
    """The message on show starts with ``starts``, is the latest error and in the message log, and names a
    crash report in the user cache folder that holds a traceback; returns (message, report text)."""
    msg = w.status.current_message()
    assert msg.startswith(starts), msg
    assert w.status.last_error in (msg, msg.split(": ", 1)[-1])  # (a message box's title comes first)
    assert msg in w.status.log.toPlainText()
    m = REPORT.search(msg)
    assert m is not None, msg
    path = Path(m.group(1))
    assert path.parent == reports_folder() and path.is_file()
    text = path.read_text(encoding="utf-8")
    assert "Traceback (most recent call last)" in text
    return msg, text


def shows(w, pose: np.ndarray) -> None:
    """The session's pose is ``pose`` exactly, and the scene draws exactly that."""
    assert np.array_equal(w.session.shown_positions, pose)
    assert np.array_equal(w.scene.parts.drawn_points(), pose.astype(np.float32))


def drag_works(qtbot, w, before: np.ndarray) -> None:
    """A selection and a drag with the mouse after a failure: the pose moves from ``before``, said as usual."""
    errors = w.status.last_error
    select_tip_to_drag(qtbot, w)
    a = handle_point(w)
    mouse_drag(qtbot, w.view, a, a + QtCore.QPoint(0, -60), steps=6)
    settled(qtbot, w)
    assert w.status.last_error == errors  # (nothing new went wrong)
    assert np.abs(w.session.shown_positions - before).max() > 0.05
    shows(w, w.session.shown_positions.copy())


def recovery_holds(qtbot, w, pose: np.ndarray) -> None:
    """The autosave is intact: this window's recovery file, replayed on a new session of the shape, gives
    ``pose`` exactly."""
    import hybridedit as he
    from hybridedit.viewer.model.recovery import read_recovery, recover
    from hybridedit.viewer.model.session import Session

    qtbot.waitUntil(w.autosave.up_to_date, timeout=5000)
    s = w.session
    fresh = Session(he.HybridEditor(s.mesh, s.cage_size, cache=True), cage_size=s.cage_size)
    recover(fresh, read_recovery(w.autosave.keeper.path))
    assert np.array_equal(fresh.shown_positions, pose)


def close_boxes(w) -> None:
    for box in w.findChildren(QtWidgets.QMessageBox):
        if box.isVisible():
            box.close()


def test_a_failing_drag_frame_keeps_the_last_good_pose_and_the_window_usable(qtbot, win, monkeypatch):
    w = win
    s = w.session
    drag_tip(qtbot, w)  # a good drag first (no polish): the last good pose is a posed one
    good = s.shown_positions.copy()
    # the engine's solve of the next frame moves the engine's state on, then raises (on the frame thread)
    ed = s.editor
    real, calls = ed.drag, []

    def drag_then_fail(*args, **kwargs):
        calls.append(1)
        V = real(*args, **kwargs)
        if len(calls) == 1:
            raise RuntimeError("injected failure in a drag frame")
        return V

    monkeypatch.setattr(ed, "drag", drag_then_fail)
    select_tip_to_drag(qtbot, w)
    step = s.history.current  # the last good state: the drag's step, and the selection since
    a = handle_point(w)
    qtbot.mousePress(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, a)
    qtbot.mouseMove(w.view, a + QtCore.QPoint(0, -20))
    qtbot.waitUntil(lambda: "drag frame failed" in (w.status.last_error or ""), timeout=10000)
    qtbot.mouseMove(w.view, a + QtCore.QPoint(0, -40))  # (the rest of the gesture is no drag's)
    qtbot.mouseRelease(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, a + QtCore.QPoint(0, -40))
    qtbot.wait(20)
    msg, text = reported(w, "The drag frame failed (RuntimeError: injected failure in a drag frame); "
                            "the drag was undone and the last good pose kept. Report: ")
    assert "what failed: drag frame" in text and "drag_then_fail" in text and "its cage: " in text
    assert len(calls) == 1  # no frame after the failed one
    # the drag ended cleanly: no gesture, frame, settle or polish under way, the cage points back
    assert w.controller.gesture is None and not w.dragging.frames.busy and not s.settling
    assert not w.dragging.settle_timer.isActive() and not w.scene.dragging and w.polisher.worker is None
    shows(w, good)
    assert np.array_equal(w.scene.points_poly.points, s.cage_positions.astype(np.float32))
    assert s.history.current is step and not s.history.can_redo()  # (no undo step for the failed drag)
    recovery_holds(qtbot, w, good)
    drag_works(qtbot, w, good)


def test_a_failing_settle_after_the_release_undoes_the_drag(qtbot, win, monkeypatch):
    w = win
    s = w.session
    drag_tip(qtbot, w)
    good = s.shown_positions.copy()
    ed = s.editor
    real = ed.drag

    def settle_fails(*args, iterations=None, **kwargs):
        V = real(*args, iterations=iterations, **kwargs)
        if iterations is not None:  # (a settle slice: the frames run the default)
            raise RuntimeError("injected failure in a settle")
        return V

    monkeypatch.setattr(ed, "drag", settle_fails)
    select_tip_to_drag(qtbot, w)
    a = handle_point(w)
    mouse_drag(qtbot, w.view, a, a + QtCore.QPoint(0, -50), steps=6)
    settled(qtbot, w)
    reported(w, "The settle after the drag failed (RuntimeError: injected failure in a settle); the drag was "
                "undone and the last good pose kept. Report: ")
    assert not s.settling and w.polisher.worker is None and not w.scene.dragging
    shows(w, good)
    monkeypatch.undo()
    drag_works(qtbot, w, good)


def test_a_failing_polish_keeps_the_settled_pose(qtbot, win, monkeypatch):
    w = win
    s = w.session
    assert w.polisher.enabled
    real = PolishJob.run

    def fail(self, shape_arap, *, should_stop=None):
        raise RuntimeError("injected failure in a polish")

    monkeypatch.setattr(PolishJob, "run", fail)
    select_tip_to_drag(qtbot, w)
    a = handle_point(w)
    mouse_drag(qtbot, w.view, a, a + QtCore.QPoint(0, -60), steps=6)
    settled(qtbot, w)
    settled_pose = s.shown_positions.copy()
    qtbot.waitUntil(lambda: "polish failed" in (w.status.last_error or "") and w.polisher.worker is None,
                    timeout=20000)
    msg, text = reported(w, "The polish failed (RuntimeError: injected failure in a polish); the settled pose "
                            "is kept. Report: ")
    assert "what failed: polish" in text and "in fail" in text
    # the polish was dropped: nothing of it adopted, the settled pose on screen, one undo step (the drag)
    assert s.polished is None and w.posing.last_polish is None
    assert s.history.undo_label() == "drag"
    shows(w, settled_pose)
    recovery_holds(qtbot, w, settled_pose)
    qtbot.waitUntil(lambda: w.status.time_label.text() != "polishing…", timeout=2000)
    # a polish that runs but cannot be adopted (on the UI thread): the settled pose is back
    monkeypatch.setattr(PolishJob, "run", real)
    adopt = s.editor.adopt_polish

    def adopt_then_fail(job, result):
        adopt(job, result)  # (the engine's pose is the polish now)
        raise RuntimeError("injected failure adopting a polish")

    monkeypatch.setattr(s.editor, "adopt_polish", adopt_then_fail)
    select_tip_to_drag(qtbot, w)
    a = handle_point(w)
    mouse_drag(qtbot, w.view, a, a + QtCore.QPoint(0, -30), steps=6)
    settled(qtbot, w)
    settled_pose = s.shown_positions.copy()
    qtbot.waitUntil(lambda: "adopting a polish" in (w.status.last_error or "") and w.polisher.worker is None,
                    timeout=20000)
    reported(w, "The polish failed (RuntimeError: injected failure adopting a polish); the settled pose is kept. ")
    assert s.polished is None and s.history.undo_label() == "drag"
    shows(w, settled_pose)
    monkeypatch.setattr(s.editor, "adopt_polish", adopt)
    # the next drag polishes again
    select_tip_to_drag(qtbot, w)
    a = handle_point(w)
    mouse_drag(qtbot, w.view, a, a + QtCore.QPoint(0, -40), steps=6)
    settled(qtbot, w)
    polished(qtbot, w)
    assert w.status.current_message().startswith("polished: ")
    assert np.abs(s.shown_positions - settled_pose).max() > 0.05
    shows(w, s.shown_positions.copy())


def test_a_failing_build_keeps_the_shape_and_pose_on_display(qtbot, win, blob_file, monkeypatch):
    w = win
    s = w.session
    drag_tip(qtbot, w)
    w.unsaved.set_modified(False)  # (opening asks nothing)
    good = s.shown_positions.copy()

    def broken(mesh, **kwargs):
        raise RuntimeError("injected failure in a build")

    monkeypatch.setattr(building, "build_rig", broken)
    # opening a file: read and shown while built, then the build fails: the shape before is back
    assert w.loading.open_path(blob_file)
    wait_loaded(qtbot, w)
    msg, text = reported(w, "The build of blob.obj failed (RuntimeError: injected failure in a build); "
                            "the shape on display is kept. Report: ")
    assert "what failed: build of blob.obj" in text and "in broken" in text and "failed while: building" in text
    assert w.session is s
    shows(w, good)
    # a rebuild of the cage: the shape, its cage and its edit stay
    n_cage = s.n_cage
    assert w.loading.rebuild()
    wait_loaded(qtbot, w)
    reported(w, "The rebuild of the cage of blob.obj failed (RuntimeError: injected failure in a build); "
                "the shape and edit on display are kept. Report: ")
    assert w.session is s and s.n_cage == n_cage
    shows(w, good)
    assert all(w.actions_[n].isEnabled() for n in ("open", "rebuild", "load_edit"))
    monkeypatch.undo()
    drag_works(qtbot, w, good)


def test_a_failing_build_in_an_empty_window_leaves_it_usable(qtbot, blob_file, monkeypatch):
    w = MainWindow(cage_size=CAGE)
    w.show()
    qtbot.waitExposed(w)
    try:
        monkeypatch.setattr(building, "build_rig", lambda mesh, **kwargs: {}["no rig"])
        assert w.loading.open_path(blob_file)
        qtbot.waitUntil(lambda: w.jobs.worker is None, timeout=60000)
        reported(w, "The build of blob.obj failed (KeyError: 'no rig'); no shape is open. Report: ")
        assert w.session is None and w.scene.shape is None
        monkeypatch.undo()
        assert w.loading.open_path(blob_file)
        wait_loaded(qtbot, w)
        assert w.session.mesh.name == "blob.obj" and w.status.current_message().startswith("Loaded blob.obj")
    finally:
        w.unsaved.set_modified(False)
        w.close()
        w.deleteLater()


def test_a_failing_slot_and_the_excepthook_name_their_reports(qtbot, win, monkeypatch, capsys):
    w = win
    s = w.session
    drag_tip(qtbot, w)
    good = s.shown_positions.copy()
    # Ctrl+Z, whose slot (guarded) meets an unexpected error
    monkeypatch.setattr(type(s), "undo", lambda self: {}["injected"])
    key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
    msg, text = reported(w, "Unexpected error: Undo failed (KeyError: 'injected'). Report: ")
    assert "what failed: UndoCommands.undo" in text
    close_boxes(w)
    monkeypatch.undo()
    shows(w, good)
    # an error that reaches the excepthook (a Qt callback with no guard)
    undo_hook = _install_excepthook(w)
    try:
        try:
            raise ZeroDivisionError("injected in a callback")
        except ZeroDivisionError as e:
            sys.excepthook(type(e), e, e.__traceback__)
    finally:
        undo_hook()
    msg, text = reported(w, "Unexpected error: ZeroDivisionError: injected in a callback. Report: ")
    assert "what failed: unexpected error" in text and "shape on display: blob" in text
    assert capsys.readouterr().err.strip().endswith(msg.split("Report: ")[1])
    close_boxes(w)
    # a user's error in a slot is said, not reported
    from hybridedit.deform.selection import SelectionError

    before = sorted(reports_folder().iterdir())
    monkeypatch.setattr(type(s), "undo", lambda self: (_ for _ in ()).throw(SelectionError("nothing to undo here")))
    w.undo_commands.undo()  # (the slot itself: the window is no longer the active one once a box was shown)
    assert w.status.last_error == "SelectionError: nothing to undo here"
    assert sorted(reports_folder().iterdir()) == before
    close_boxes(w)
    monkeypatch.undo()
    drag_works(qtbot, w, good)
