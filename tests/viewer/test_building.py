"""Build jobs (hybridedit.viewer.building): progress, cancel, refusals, failures and the message after a build.

The window tests run the real build thread and its queued signals; the build itself is held at a
gate where a test needs it to last (a fake ``build_rig`` that reports progress until let through).
"""

from __future__ import annotations

import threading
from pathlib import Path
from types import SimpleNamespace

import numpy as np
from qtpy import QtCore, QtWidgets

from hybridedit.viewer.model import building
from hybridedit.viewer.jobs.build_jobs import build_size, built_message
from hybridedit.viewer.model.cage_size import DEFAULT_SIZE, MAX_SHARE, fit_cage_size
from hybridedit.viewer.window.main_window import MainWindow
from hybridedit.viewer.jobs.build_worker import BuildRequest
from support.window_driving import wait_loaded

Qt = QtCore.Qt
JOB_ACTIONS = ("open", "rebuild", "load_edit")


# ---------------------------------------------------------------------------- helpers


def record_errors(w: MainWindow, monkeypatch) -> list[tuple[str, str]]:
    """Every error the window shows, as (title, text), still shown as usual."""
    shown = []
    show = w.status.show_error
    monkeypatch.setattr(w.status, "show_error", lambda title, text: shown.append((title, text)) or show(title, text))
    return shown


def close_boxes(w: MainWindow) -> None:
    for box in w.findChildren(QtWidgets.QMessageBox):
        if box.isVisible():
            box.close()


def assert_idle(w: MainWindow) -> None:
    assert w.jobs.worker is None and not w.jobs.busy
    assert not w.jobs.progress.isVisible() and not w.jobs.cancel_button.isVisible()
    assert all(w.actions_[n].isEnabled() for n in JOB_ACTIONS) and not w.actions_["cancel_job"].isEnabled()


# ---------------------------------------------------------------------------- the message after a build


def build_of(path=None, rebuild=False, cache_hit=False, notes=(), timings=None, name="blob", n_cage=1234):
    editor = SimpleNamespace(timings=timings or {}, cache_hit=cache_hit, notes=list(notes))
    result = SimpleNamespace(request=BuildRequest(cage_size=0.05, path=path, rebuild=rebuild), editor=editor)
    session = SimpleNamespace(mesh=SimpleNamespace(name=name), n_cage=n_cage)
    return result, session


def test_built_message_says_what_was_built_and_how():
    r, s = build_of(Path("/data/creature.ply"), cache_hit=True)
    assert built_message(r, s, rebuilt=False) == "Loaded creature.ply: cage 1,234 vertices (from the cache)"
    r, s = build_of(timings={"cage_seconds": 1.26, "bind_seconds": 4.04})
    assert built_message(r, s, rebuilt=False) == "Loaded blob: cage 1,234 vertices (cage 1.3 s, binding 4.0 s)"
    r, s = build_of(name="", timings={})
    assert built_message(r, s, rebuilt=False) == "Loaded shape: cage 1,234 vertices (cage 0.0 s, binding 0.0 s)"
    # repairs are told when a shape is loaded, not again when its cage is rebuilt
    r, s = build_of(Path("a.obj"), cache_hit=True, notes=["merged 3 duplicate vertices", "dropped 1 face"])
    assert built_message(r, s, rebuilt=False) == (
        "Loaded a.obj: cage 1,234 vertices (from the cache) · input repaired: merged 3 duplicate vertices; "
        "dropped 1 face (File ▸ Mesh Info…)")
    r, s = build_of(Path("a.obj"), rebuild=True, cache_hit=True, notes=["dropped 1 face"])
    assert built_message(r, s, rebuilt=True, note="the pose was solved again") == (
        "Rebuilt the cage of a.obj: cage 1,234 vertices (from the cache); the pose was solved again")


# ---------------------------------------------------------------------------- in the window


def test_progress_fills_the_bar_and_esc_cancels_keeping_the_shape(qtbot, win, make_blob, gate, monkeypatch):
    w = win
    s = w.session
    before = s.shape_positions.copy()
    errors = record_errors(w, monkeypatch)
    assert_idle(w)
    assert w.loading.open_mesh(make_blob(3))
    # at once: the bar with the job's label, Cancel, and no other job can start
    assert w.jobs.worker is not None and w.jobs.busy
    assert w.jobs.progress.isVisible() and w.jobs.progress.text() == "Building…"
    assert w.jobs.cancel_button.isVisible() and w.jobs.cancel_button.isEnabled()
    assert not any(w.actions_[n].isEnabled() for n in JOB_ACTIONS) and w.actions_["cancel_job"].isEnabled()
    # the thread's reports reach the bar: stage and percentage
    qtbot.waitUntil(lambda: w.jobs.progress.format() == "binding %p%", timeout=20000)
    assert w.jobs.progress.value() == 250 and w.jobs.progress.text() == "binding 25%"
    # Esc (Cage > Cancel): the bar says so at once, and a report still on its way does not overwrite it
    job = w.jobs.worker
    qtbot.keyClick(w.view, Qt.Key.Key_Escape)  # (no event loop turn: the job has not ended yet)
    assert job.cancel_requested and w.jobs.worker is job
    assert w.jobs.progress.text() == "Cancelling…" and not w.jobs.cancel_button.isEnabled()
    job.progress.emit("binding", 0.9)
    assert w.jobs.progress.text() == "Cancelling…"
    qtbot.waitUntil(lambda: w.jobs.worker is None, timeout=20000)
    assert not gate.is_set()  # it never got past the gate: cancelled, not built
    assert w.session is s and np.array_equal(s.shape_positions, before) and s.mesh.n_vertices == 2562
    assert w.status.current_message() == "Cancelled; the current shape and edit are unchanged."
    assert errors == []
    assert_idle(w)


def test_a_second_job_is_refused_and_the_first_one_shows_its_shape(qtbot, win, make_blob, blob_file, gate,
                                                                   monkeypatch):
    w = win
    errors = record_errors(w, monkeypatch)
    other = make_blob(3)
    assert w.loading.open_mesh(other)
    job = w.jobs.worker
    assert not w.loading.open_path(blob_file) and not w.loading.rebuild()
    assert errors == [("Busy", "A cage is being built; wait for it or cancel it first.")] * 2
    assert w.jobs.worker is job
    close_boxes(w)
    gate.set()
    wait_loaded(qtbot, w)
    assert w.session.mesh is other and w.session.path is None and not w.unsaved.modified
    assert w.status.current_message().startswith(f"Loaded blob: cage {w.session.n_cage:,} vertices (")
    assert len(errors) == 2
    assert_idle(w)


def test_failures_show_one_error_and_keep_the_shape(qtbot, win, tmp_path, monkeypatch):
    w = win
    s = w.session
    n_cage = s.n_cage
    errors = record_errors(w, monkeypatch)
    # an unreadable file: refused before a build starts (window/file_check.py)
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nf 1 2 3\n")
    assert not w.loading.open_path(bad)
    assert len(errors) == 1 and errors[0][0] == "Could not open the mesh" and "bad.obj" in errors[0][1]
    assert w.session is s and w.jobs.worker is None
    # one too large to be read first: the build reads it, and says why it cannot
    from hybridedit.viewer.window import file_check

    monkeypatch.setattr(file_check, "READ_FIRST_BYTES", 0)
    assert w.loading.open_path(bad)
    wait_loaded(qtbot, w)
    qtbot.wait(50)  # (nothing else arrives)
    assert len(errors) == 2 and errors[1] == errors[0]
    assert w.session is s and w.status.last_error == errors[1][1]
    assert_idle(w)
    close_boxes(w)
    del errors[0]

    # a rebuild that fails says so in its own words
    def no_cage(mesh, **kwargs):
        raise ValueError("no cage for you")

    monkeypatch.setattr(building, "build_rig", no_cage)
    assert w.loading.rebuild()
    wait_loaded(qtbot, w)
    qtbot.wait(50)
    assert errors[1:] == [("Could not rebuild the cage", "no cage for you")]
    assert w.session is s and s.n_cage == n_cage
    assert_idle(w)
    close_boxes(w)
    monkeypatch.undo()  # the real build again (and the real show_error)
    errors = record_errors(w, monkeypatch)

    # a build that cannot be shown: an unexpected error, said in the status bar with its crash report
    def broken(result):
        raise RuntimeError("no room on screen")

    monkeypatch.setattr(w.loading, "install_build", broken)
    assert w.loading.open_path(w.session.path)
    wait_loaded(qtbot, w)
    assert errors == []
    assert w.status.last_error == w.status.current_message()
    assert w.status.last_error.startswith(f"The build of {s.path.name} failed (RuntimeError: no room on screen); "
                                          "the shape on display is kept. Report: ")
    assert w.session is s
    assert_idle(w)
    close_boxes(w)


def test_rebuild_without_a_shape_says_so(qtbot, monkeypatch):
    w = MainWindow(cage_size=150)
    qtbot.addWidget(w)
    errors = record_errors(w, monkeypatch)
    assert not w.loading.rebuild()
    assert errors == [("Rebuild cage", "Open a mesh first.")]
    assert_idle(w)
    close_boxes(w)


# ---------------------------------------------------------------------------- the cage size


def test_a_count_above_half_the_shape_is_built_at_5_percent_and_said():
    assert fit_cage_size(9_999_999, 32_000) == (0.05, "a cage of 9,999,999 vertices is more than half this "
                                                      "shape's 32,000 vertices: using 5% (about 1,600)")
    assert fit_cage_size(16_000, 32_000) == (16_000, None)  # half: taken
    assert fit_cage_size(16_001, 32_000)[0] == DEFAULT_SIZE == 0.05 and MAX_SHARE == 0.5
    assert fit_cage_size(1.0, 100) == (1.0, None)  # a percentage is the user's
    assert fit_cage_size(5000, None) == (5000, None)  # not known yet: checked once read
    # a new shape does not start from the count of the shape on display; a percentage, or a count typed
    # since, is used (checked against the shape when its size is known)
    assert build_size(3000, True, new_shape=True, n_vertices=None) == (0.05, None)
    assert build_size(3000, True, new_shape=False, n_vertices=10_000) == (3000, None)  # a rebuild: kept
    assert build_size(0.12, True, new_shape=True, n_vertices=None) == (0.12, None)
    assert build_size(70, False, new_shape=True, n_vertices=2562) == (70, None)  # set since
    assert build_size(2000, False, new_shape=True, n_vertices=2562)[0] == 0.05  # (2,000 > 1,281)
    assert build_size(2000, False, new_shape=True, n_vertices=None) == (2000, None)  # a file: read first


def test_a_rebuild_at_too_many_vertices_says_so_before_the_build_and_the_box_shows_5_percent(qtbot, win, gate):
    w = win
    s = w.session
    w.cage_control.set_value(5000)  # the blob has 2,562 vertices
    assert w.loading.rebuild()
    said = "a cage of 5,000 vertices is more than half this shape's 2,562 vertices: using 5% (about 128)"
    # at once, while the build has just started
    assert w.jobs.worker is not None and w.jobs.worker.request.cage_size == 0.05
    assert w.status.current_message() == f"Cage size: {said}."
    assert w.cage_control.value() == 0.05 and w.cage_control.unit.currentText() == "%"
    assert abs(w.cage_control.spin.value() - 5.0) < 1e-9
    gate.set()
    wait_loaded(qtbot, w)
    assert w.session is s and s.cage_size == 0.05 and abs(s.n_cage - 128) < 30
    assert w.status.current_message().startswith("Rebuilt the cage of blob.obj") and said in w.status.current_message()
    assert w.cage_control.value() == 0.05
    assert said in w.status.log.toPlainText()


def test_a_cancelled_build_puts_the_box_back(qtbot, win, gate):
    w = win
    w.cage_control.set_value(5000)
    assert w.loading.rebuild()
    assert w.cage_control.value() == 0.05
    w.loading.cancel_job()
    qtbot.waitUntil(lambda: w.jobs.worker is None, timeout=20000)
    assert w.cage_control.value() == 5000 and w.session.cage_size == 150 and not w.cage_control.of_shape
    # a new shape that starts from 5% and is cancelled: the box shows the shape's count again, as the shape's
    w.cage_control.set_value(150, of_shape=True)
    assert w.loading.open_path(w.session.path)
    assert w.cage_control.value() == 0.05
    w.loading.cancel_job()
    qtbot.waitUntil(lambda: w.jobs.worker is None, timeout=20000)
    assert w.cage_control.value() == 150 and w.cage_control.of_shape


def test_a_file_opened_at_too_many_vertices_is_read_then_built_at_5_percent(qtbot, gate, tmp_path, blob_file,
                                                                            monkeypatch):
    """The command line's --cage 5000, say, for a shape of 2,562 vertices: the count is checked once the file
    is read, before its cage is built; the file's colours still show."""
    from hybridedit.fileio.meshfiles import read_mesh

    blob = read_mesh(blob_file)
    coloured = tmp_path / "coloured.obj"
    coloured.write_text("".join(f"v {x:.17g} {y:.17g} {z:.17g} 0.2 0.5 0.8\n" for x, y, z in blob.vertices)
                        + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in blob.faces))
    w = MainWindow(cage_size=5000)
    qtbot.addWidget(w)
    w.show()
    qtbot.waitExposed(w)
    assert w.cage_control.value() == 5000
    assert w.loading.open_path(coloured)
    said = "a cage of 5,000 vertices is more than half this shape's 2,562 vertices: using 5% (about 128)"
    # held at the gate: the file is read, the count checked and said, the cage not built yet
    qtbot.waitUntil(lambda: said in w.status.current_message(), timeout=20000)
    assert w.jobs.worker is not None and not gate.is_set() and w.cage_control.value() == 0.05
    gate.set()
    wait_loaded(qtbot, w)
    s = w.session
    assert s.path == coloured and s.cage_size == 0.05 and abs(s.n_cage - 128) < 30
    assert said in w.status.current_message() and w.status.current_message().startswith("Loaded coloured.obj")
    assert s.look is not None and s.look.colors is not None  # (read before the build, shown after it)
    assert w.scene.look_mode == "colors"
    # a count that fits is used as asked
    w.cage_control.set_value(300)
    assert w.loading.open_path(blob_file)
    wait_loaded(qtbot, w)
    assert w.session.path == blob_file and w.session.cage_size == 300 and w.cage_control.value() == 300
    w.close()


def test_another_file_starts_from_5_percent_not_from_the_last_count(qtbot, win, tmp_path, make_blob):
    from hybridedit.fileio.meshfiles import write_mesh

    w = win
    assert w.session.cage_size == 150 and w.cage_control.value() == 150  # (the window was made with --cage 150)
    assert w.cage_control.of_shape
    other = tmp_path / "other.obj"
    write_mesh(other, make_blob(5))  # 10K vertices: 150 would do, but it was the blob's count
    assert w.loading.open_path(other)
    assert w.cage_control.value() == 0.05  # at once, in the box
    wait_loaded(qtbot, w)
    s = w.session
    assert s.path == other and s.cage_size == 0.05 and w.cage_control.value() == 0.05
    assert abs(s.n_cage - 0.05 * s.mesh.n_vertices) < 0.2 * 0.05 * s.mesh.n_vertices
    # a percentage the user chose carries over
    w.cage_control.set_value(0.08)
    assert w.loading.rebuild()
    wait_loaded(qtbot, w)
    assert w.loading.open_path(other)
    wait_loaded(qtbot, w)
    assert w.session.cage_size == 0.08 and w.cage_control.value() == 0.08
    # a count set in the box for the next file is used, also when it is the count on display
    w.cage_control.set_value(400)
    assert w.loading.rebuild()
    wait_loaded(qtbot, w)
    assert w.session.cage_size == 400 and w.cage_control.of_shape
    w.cage_control.set_value(400)  # (as a script, or typed)
    assert not w.cage_control.of_shape
    assert w.loading.open_path(other)
    wait_loaded(qtbot, w)
    assert w.session.cage_size == 400


def test_a_count_typed_in_the_box_is_no_longer_the_shapes(qtbot, win):
    w = win
    spin = w.cage_control.spin
    assert w.cage_control.of_shape
    spin.setFocus()
    spin.selectAll()
    qtbot.keyClicks(spin, "150")  # the same number, typed: the user's choice for what comes next
    qtbot.keyClick(spin, Qt.Key.Key_Return)
    assert w.cage_control.value() == 150 and not w.cage_control.of_shape
    w.cage_control.set_value(150, of_shape=True)
    qtbot.keyClick(spin, Qt.Key.Key_Up)  # the arrows too
    assert w.cage_control.value() != 150 and not w.cage_control.of_shape
    w.cage_control.set_value(150, of_shape=True)
    w.cage_control.unit.setCurrentIndex(0)  # and the unit
    assert not w.cage_control.of_shape


def test_a_new_shape_is_drawn_while_its_cage_is_built_and_the_camera_works(qtbot, win, make_blob, gate):
    """Opening a shape shows it at once (plain, framed) while the cage and binding are built; the camera
    turns it; editing waits; Cancel brings the shape before back, and a build that ends shows the new shape
    with the camera where the user left it."""
    w = win
    s = w.session
    other = make_blob(3)
    assert w.loading.open_mesh(other)
    qtbot.waitUntil(lambda: w.scene.shape is not None and w.scene.shape.n_points == other.n_vertices,
                    timeout=20000)
    assert w.jobs.worker is not None and w.session is None  # still building; nothing to edit yet
    assert np.allclose(np.asarray(w.scene.shape.points), other.vertices, atol=1e-6)
    img = np.asarray(w.view.screenshot(None, return_img=True))[..., :3].astype(int)
    assert ((img[..., 0] - img[..., 2]) > 15).mean() > 0.02  # the shape's warm colour is on screen
    assert not w.actions_["save"].isEnabled() and not w.actions_["reset_pose"].isEnabled()
    cam = w.scene.renderer.GetActiveCamera()
    cam.Azimuth(30)  # the camera works during the build
    turned = cam.GetPosition()
    w.view.render()
    # Esc: the shape before is back, as it was
    qtbot.keyClick(w.view, Qt.Key.Key_Escape)
    qtbot.waitUntil(lambda: w.jobs.worker is None, timeout=20000)
    assert w.session is s and w.scene.shape.n_points == s.mesh.n_vertices
    # again, to the end: the new shape, and the camera the user set on it
    gate.clear()
    assert w.loading.open_mesh(other)
    qtbot.waitUntil(lambda: w.session is None and w.scene.shape is not None, timeout=20000)
    cam.Azimuth(30)
    turned = cam.GetPosition()
    gate.set()
    wait_loaded(qtbot, w)
    assert w.session.mesh is other and np.allclose(cam.GetPosition(), turned)


def test_the_view_sets_of_a_new_shape_are_made_on_the_build_thread_once(qtbot, win, make_blob, tmp_path,
                                                                        monkeypatch):
    """The per-frame index sets of the view (ShapeMetrics: edges, incidences, rest lengths; 23 s of an
    11M shape) are made beside the cage and binding, off the UI thread, and the session takes them;
    a rebuild (same shape, another cage) keeps the session's."""
    from hybridedit.core import region_metrics
    from hybridedit.fileio.meshfiles import write_mesh

    w = win
    path = tmp_path / "another.ply"
    shape = make_blob(2)  # (162 vertices)
    write_mesh(path, shape)
    n = shape.n_vertices
    made = []
    init = region_metrics.ShapeMetrics.__init__

    def recording(self, rest, faces):
        init(self, rest, faces)
        if self.n == n:  # (the shape's, not the cage's: the scene has its own for the cage's normals)
            made.append(threading.get_ident())

    monkeypatch.setattr(region_metrics.ShapeMetrics, "__init__", recording)
    assert w.loading.open_path(path)
    wait_loaded(qtbot, w)
    qtbot.waitUntil(lambda: w.session is not None and w.session.path == path, timeout=30000)
    assert len(made) == 1 and made[0] != threading.get_ident()
    metrics = w.session.metrics
    w.cage_control.set_value(60)
    assert w.loading.rebuild()
    qtbot.waitUntil(lambda: w.jobs.worker is None and w.session.cage_size == 60, timeout=30000)
    assert w.session.metrics is metrics and len(made) == 1
