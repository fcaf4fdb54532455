"""After a file dialog: Save Edit starts beside the mesh, an unreadable file is refused before the
unsaved-pose question, and the keyboard is back in the 3D view (real dialogs and keys under Xvfb)."""

from __future__ import annotations

import numpy as np
import pytest
from qtpy import QtCore, QtWidgets

from support.window_driving import answer_file_dialog, drag_tip, key

Qt = QtCore.Qt


def capture_start(monkeypatch, name: str, answer: str = "") -> list:
    """Patch ``QFileDialog.name``: record the folder it would start in, answer ``answer``."""
    starts = []

    def fake(parent, caption, start="", *a, **k):
        starts.append(start)
        return answer, ""

    monkeypatch.setattr(QtWidgets.QFileDialog, name, staticmethod(fake))
    return starts


def test_save_edit_starts_in_the_mesh_folder_then_the_last_one(qtbot, win, tmp_path, monkeypatch, blob_file):
    w = win
    drag_tip(qtbot, w)
    # an edit loaded from elsewhere (the project's data/ folder, say) is not where a new one is saved
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    assert w.files.save_edit_to(elsewhere / "loaded.json")
    w.files.saved_edit_path = None  # (as if it had been loaded, not saved, in this session)
    w.files.edit_path = elsewhere / "loaded.json"
    starts = capture_start(monkeypatch, "getSaveFileName")
    assert not w.files.save_edit_dialog()
    assert starts[-1] == str(blob_file.absolute().with_name("blob-edit.json"))
    # once saved somewhere, Save Edit starts there (as Save As does)
    chosen = tmp_path / "mine" / "pose.json"
    chosen.parent.mkdir()
    capture_start(monkeypatch, "getSaveFileName", str(chosen))
    w.actions_["save_edit"].trigger()
    assert chosen.exists()
    starts = capture_start(monkeypatch, "getSaveFileName")
    w.actions_["save_edit"].trigger()
    assert starts == [str(chosen)]


@pytest.mark.parametrize("contents", ["v 1 2\nf 1 2 3\n", "", None])
def test_an_unreadable_file_is_refused_without_the_unsaved_question(qtbot, win, tmp_path, monkeypatch, contents):
    w = win
    drag_tip(qtbot, w)
    assert w.unsaved.modified
    pose = w.session.shown_positions.copy()
    asked = []
    monkeypatch.setattr(QtWidgets.QMessageBox, "exec", lambda box: asked.append(box.text()) or 0)
    bad = tmp_path / ("bad.obj" if contents is not None else "bad.txt")
    bad.write_text(contents or "")
    session = w.session
    assert not w.loading.open_path(bad)
    assert asked == []  # no Save / Discard / Cancel question
    assert w.status.last_error.startswith(f"{bad.name}: ") and "\n" not in w.status.last_error
    assert w.jobs.worker is None and w.session is session and w.unsaved.modified
    assert np.array_equal(w.session.shown_positions, pose)
    # a readable file still asks first
    good = tmp_path / "good.off"
    from hybridedit.fileio.meshfiles import write_mesh
    write_mesh(good, w.session.mesh)
    assert not w.loading.open_path(good)  # (the patched question answers 0: neither Save nor Discard)
    assert len(asked) == 1 and asked[0].startswith("The pose of")


@pytest.mark.parametrize("action, answer", [("open", None), ("save_as", "posed.ply"), ("save_edit", "pose.json"),
                                            ("load_edit", None), ("screenshot", "shot.png")])
def test_the_keyboard_is_back_in_the_view_after_a_file_dialog(qtbot, win, tmp_path, action, answer):
    w = win
    drag_tip(qtbot, w)
    assert QtWidgets.QApplication.focusWidget() is w.view
    seen = answer_file_dialog(qtbot, None if answer is None else tmp_path / answer)
    w.actions_[action].trigger()  # a real dialog, answered by the timer
    assert seen, "no file dialog was shown"
    if answer is not None:
        assert (tmp_path / answer).exists(), (w.status.last_error, seen, list(tmp_path.iterdir()))
    qtbot.waitUntil(lambda: QtWidgets.QApplication.focusWidget() is w.view, timeout=3000)
    # and a single-key shortcut works without a click
    key(qtbot, w, Qt.Key.Key_S)
    assert w.actions_["mode_select"].isChecked()
