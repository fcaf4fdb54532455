"""Nothing lost when the window dies: the recovery file kept while the pose is unsaved, the window killed
with SIGKILL after three edits and its pose recovered exactly, a clean quit leaving nothing, a damaged
recovery file said and ignored (real events throughout)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from qtpy import QtCore, QtWidgets

from hybridedit.viewer.model.recovery import read_recovery
from support.window_driving import CAGE, drag_tip, key, opened_window, polished, settled, wait_loaded

Qt = QtCore.Qt
HERE = Path(__file__).parent


@pytest.fixture
def cache(tmp_path, monkeypatch) -> Path:
    """A user cache folder of this test's own (the recovery files the window finds are only its own)."""
    folder = tmp_path / "cache"
    monkeypatch.setenv("HYBRIDEDIT_CACHE_DIR", str(folder))
    return folder


def recovery_files(cache: Path) -> list[Path]:
    return sorted((cache / "recovery").glob("*.json"))


def dead_pid() -> int:
    """The pid of a process that has ended."""
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def click(qtbot, button) -> None:
    qtbot.mouseClick(button, Qt.MouseButton.LeftButton)
    qtbot.wait(20)


def test_the_unsaved_pose_is_kept_until_saved_and_a_clean_quit_leaves_nothing(qtbot, blob_file, cache, tmp_path):
    with opened_window(qtbot, cage_size=CAGE, path=blob_file) as w:
        assert recovery_files(cache) == []  # nothing unsaved: no file
        drag_tip(qtbot, w)
        qtbot.waitUntil(w.autosave.up_to_date, timeout=5000)
        (f,) = recovery_files(cache)
        rec = read_recovery(f)
        assert rec.pid == os.getpid() and not rec.orphaned and rec.steps == 1 and rec.mesh_name == "blob.obj"
        assert rec.cage_vertices == w.session.editor.cage.n_vertices
        # saved: the file goes; undo (unsaved again): it is back, holding the rest pose's selection
        assert w.files.save_to(tmp_path / "posed.obj")
        qtbot.waitUntil(lambda: recovery_files(cache) == [], timeout=5000)
        key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
        qtbot.waitUntil(lambda: len(recovery_files(cache)) == 1, timeout=5000)
        # a clean quit (the unsaved-pose question answered Discard): nothing is left
        w.unsaved.set_modified(True)

        def discard():
            box = w.files.unsaved_box
            if box is None or not box.isVisible():
                QtCore.QTimer.singleShot(20, discard)
                return
            click(qtbot, box.button(QtWidgets.QMessageBox.StandardButton.Discard))

        QtCore.QTimer.singleShot(20, discard)
        key(qtbot, w, Qt.Key.Key_Q, Qt.KeyboardModifier.ControlModifier)
        qtbot.waitUntil(lambda: not w.isVisible(), timeout=5000)
        assert recovery_files(cache) == []


def test_a_window_killed_after_three_edits_is_recovered_exactly(qtbot, tmp_path, monkeypatch):
    """The window of another process, killed with SIGKILL after three edits made with real events (the
    first kept in the pose library); the next window on the shape offers the pose back, and Recover
    replays it and the kept pose exactly (0 of the diagonal)."""
    out = tmp_path / "killed"
    out.mkdir()
    env = dict(os.environ, HE_KILL_DIR=str(out))
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-x",
                          f"--basetemp={tmp_path / 'child'}", str(HERE / "killed_window.py")],
                         env=env, cwd=HERE.parent.parent, capture_output=True, text=True, timeout=900)
    assert run.returncode == -9, run.stdout[-3000:] + run.stderr[-3000:]
    lost = np.load(out / "lost.npy")
    kept = np.load(out / "kept.npy")
    cache = Path((out / "cache.txt").read_text())
    monkeypatch.setenv("HYBRIDEDIT_CACHE_DIR", str(cache))
    (orphan,) = recovery_files(cache)
    assert read_recovery(orphan).orphaned
    with opened_window(qtbot, cage_size=CAGE, path=out / "blob.obj") as w:
        qtbot.waitUntil(lambda: w.autosave.box is not None and w.autosave.box.isVisible(), timeout=10000)
        text = w.autosave.box.text()
        assert text.startswith("Recover the unsaved pose of blob.obj (") and " steps, 1 kept pose, " in text, text
        assert not np.array_equal(w.session.shown_positions, lost)  # opened at rest
        click(qtbot, w.autosave.recover_button)
        qtbot.waitUntil(lambda: w.autosave.box is None and w.unsaved.modified, timeout=10000)
        np.testing.assert_array_equal(w.session.shown_positions, lost)  # exactly the pose it died with
        assert w.session.poses.names == ["Pose 1"] and w.pose_panel.list.count() == 1
        np.testing.assert_array_equal(w.session.poses[0].positions, kept)  # and the pose it kept
        shown = np.asarray(w.scene.shape.points)
        np.testing.assert_allclose(shown, lost, rtol=0, atol=1e-6 * np.ptp(lost, axis=0).max())
        assert "Recovered the unsaved pose of blob.obj" in w.status.current_message()
        # the orphan is gone; this window's own file holds the pose now
        qtbot.waitUntil(w.autosave.up_to_date, timeout=5000)
        (mine,) = recovery_files(cache)
        assert mine != orphan and read_recovery(mine).pid == os.getpid()
        # the window goes on: undo goes back to the rest pose it was recovered on, redo to the pose
        key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
        assert not np.array_equal(w.session.shown_positions, lost)
        key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier | Qt.KeyboardModifier.ShiftModifier)
        np.testing.assert_array_equal(w.session.shown_positions, lost)


def test_not_now_keeps_the_recovery_until_a_clean_quit(qtbot, blob_file, cache):
    with opened_window(qtbot, cage_size=CAGE, path=blob_file) as w:
        drag_tip(qtbot, w)
        qtbot.waitUntil(w.autosave.up_to_date, timeout=5000)
        posed = w.session.shown_positions.copy()
        (f,) = recovery_files(cache)
        data = json.loads(f.read_text())
    # as if that window had died: its file left behind, naming a process that is gone
    assert not f.exists()
    data["pid"] = dead_pid()
    f.write_text(json.dumps(data))
    with opened_window(qtbot, cage_size=CAGE, path=blob_file) as w:
        qtbot.waitUntil(lambda: w.autosave.box is not None and w.autosave.box.isVisible(), timeout=10000)
        click(qtbot, w.autosave.later_button)
        assert w.autosave.box is None and f.exists()
        assert "kept until hybridedit quits cleanly" in w.status.current_message()
        assert not np.array_equal(w.session.shown_positions, posed)
        drag_tip(qtbot, w)  # the window is usable meanwhile
    assert not f.exists() and recovery_files(cache) == []  # the clean quit removed it


def test_the_last_session_on_another_shape_is_offered_at_the_start_and_opened(qtbot, blob_file, cache, tmp_path,
                                                                            make_blob):
    """The first shape opened after a start (here another one) offers the last session's pose; Recover opens
    its shape at its cage size and replays it exactly."""
    from hybridedit.fileio.meshfiles import write_mesh

    with opened_window(qtbot, cage_size=CAGE, path=blob_file) as w:
        drag_tip(qtbot, w)
        qtbot.waitUntil(w.autosave.up_to_date, timeout=5000)
        posed = w.session.shown_positions.copy()
        cage_vertices = w.session.editor.cage.n_vertices
        (f,) = recovery_files(cache)
        data = json.loads(f.read_text())
    data["pid"] = dead_pid()
    f.write_text(json.dumps(data))
    other = tmp_path / "other.off"
    write_mesh(other, make_blob(3))
    with opened_window(qtbot, cage_size=0.2, path=other) as w:
        qtbot.waitUntil(lambda: w.autosave.box is not None and w.autosave.box.isVisible(), timeout=10000)
        assert "blob.obj" in w.autosave.box.text() and str(blob_file) in w.autosave.box.informativeText()
        click(qtbot, w.autosave.recover_button)
        qtbot.waitUntil(lambda: w.session is not None and w.session.path == blob_file and w.unsaved.modified,
                        timeout=60000)
        assert w.session.editor.cage.n_vertices == cage_vertices
        np.testing.assert_array_equal(w.session.shown_positions, posed)
        assert not f.exists()


def test_a_damaged_recovery_file_is_said_in_one_line_and_ignored(qtbot, blob_file, cache):
    folder = cache / "recovery"
    folder.mkdir(parents=True)
    (folder / f"0123456789abcdef-{dead_pid()}.json").write_text('{"format": "hybridedit-recovery", "vers')
    with opened_window(qtbot, cage_size=CAGE, path=blob_file) as w:
        qtbot.waitUntil(lambda: "Ignored a damaged recovery file" in w.status.log.toPlainText(), timeout=10000)
        line = next(ln for ln in w.status.log.toPlainText().splitlines() if "damaged recovery file" in ln)
        assert "0123456789abcdef-" in line and "not a recovery file" in line
        assert w.autosave.box is None
        drag_tip(qtbot, w)  # opening and editing go on
        assert w.session.is_posed()
