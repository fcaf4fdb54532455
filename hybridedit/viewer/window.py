"""The main window: menus, toolbar, status bar, file dialogs; glue between the view and the session."""

from __future__ import annotations

import functools
import os
import time
from pathlib import Path
from typing import Callable

import numpy as np
from qtpy import QtCore, QtGui, QtWidgets

from ..atomic import WriteError
from ..editfile import EditFileError, load_edit, save_edit
from ..editor import SelectionError
from ..io import SUPPORTED_EXTENSIONS, MeshFileError, write_mesh
from ..mesh import MeshError
from ..polish import free_shape_vertices
from .cagesize import CageSizeControl
from .help import HOWTO, ShortcutsDialog
from .interaction import BRUSH, CAMERA, DRAG, RECTANGLE, SELECT, ViewController
from .scene import STATE_COLORS, Scene
from .session import HANDLE, ROI, Session
from .view import View
from .worker import (BuildRequest, BuildResult, BuildWorker, PolishOutcome, PolishRequest, PolishWorker,
                     ShapeARAPHolder)

MESH_FILTER = "Meshes (*.obj *.ply *.stl *.off);;OBJ (*.obj);;PLY (*.ply);;STL (*.stl);;OFF (*.off);;All files (*)"
EDIT_FILTER = "Edit files (*.json);;All files (*)"
RRMS_INTERVAL = 0.3  # seconds between edge-error updates of the status bar while dragging
POLISH_SECONDS = 1.0  # time budget of the polish on release (iterations; the one-off set-up comes on top)

def _same_file(a: Path, b: Path) -> bool:
    try:
        return a.resolve() == b.resolve() or (a.exists() and b.exists() and os.path.samefile(a, b))
    except OSError:
        return False


def _fmt(n: int) -> str:
    return f"{n:,}"


def guarded(method: Callable) -> Callable:
    """Run a UI slot and show any unexpected error in a message box instead of a traceback."""

    @functools.wraps(method)
    def wrapper(self: "MainWindow", *args, **kwargs):
        try:
            return method(self, *args, **kwargs)
        except Exception as e:  # noqa: BLE001
            self.show_error("Unexpected error", f"{e.__class__.__name__}: {e}")
            return None

    return wrapper


class MainWindow(QtWidgets.QMainWindow):
    """The hybridedit editor window.

    Parameters
    ----------
    cage_size : initial cage size (int vertex count or float fraction of the shape).
    """

    def __init__(self, cage_size: int | float = 0.05) -> None:
        super().__init__()
        self.setWindowTitle("hybridedit")
        self.session: Session | None = None
        self.save_path: Path | None = None
        self.edit_path: Path | None = None
        self.worker: BuildWorker | None = None
        self.last_error: str | None = None
        self.modified = False
        self.settle_on_release = True
        self._error_box: QtWidgets.QMessageBox | None = None
        self._drag_T0 = np.eye(4)
        self._pending_T: np.ndarray | None = None
        self._settle_chunk = 2
        self._rrms_dirty = False
        self._rrms_full = True  # the next measure must walk every edge (the pose changed outside a drag)
        self._rrms_time = 0.0
        self._engine_ms = 0.0
        self.polish_on_release = True
        self.polish_seconds = POLISH_SECONDS
        self.polish_iterations = 200
        self.polish_tolerance = 1e-6
        self.polish_worker: PolishWorker | None = None
        self._polish_next: PolishRequest | None = None
        self._polish_token = 0
        self._polish_holder: ShapeARAPHolder | None = None
        self.polished: np.ndarray | None = None  # the polished pose on display (a view state), or None
        self.last_polish: PolishOutcome | None = None

        self.view = View(self)
        self.setCentralWidget(self.view)
        self.scene = Scene(self.view)
        self.controller = ViewController(self.view, self.scene, self)
        self.actions_: dict[str, QtGui.QAction] = {}
        self._make_actions()
        self._make_menus()
        self._make_toolbar()
        self._make_statusbar()
        self.set_cage_size(cage_size)
        self.setAcceptDrops(True)
        self.view.rendered.connect(self._on_rendered)
        self.status_timer = QtCore.QTimer(self)
        self.status_timer.setInterval(250)
        self.status_timer.timeout.connect(self._tick)
        self.status_timer.start()
        self.settle_timer = QtCore.QTimer(self)
        self.settle_timer.setInterval(0)
        self.settle_timer.timeout.connect(self._settle_tick)
        self.target = ROI
        self._set_target(ROI)
        self._update_actions()
        self.resize(1280, 900)

    # ================================================================== building the UI
    def _action(self, name: str, text: str, slot: Callable | None = None,
                shortcut: str | QtGui.QKeySequence | None = None, checkable: bool = False, tip: str = "",
                short: str = "") -> QtGui.QAction:
        a = QtGui.QAction(text, self)
        if short:
            a.setIconText(short)
        if shortcut:
            a.setShortcut(QtGui.QKeySequence(shortcut))
            a.setShortcutContext(QtCore.Qt.ShortcutContext.WindowShortcut)
        a.setCheckable(checkable)
        if tip:
            a.setStatusTip(tip)
            a.setToolTip(f"{text.replace('&', '')} ({a.shortcut().toString()})" if shortcut else tip)
        if slot is not None:
            a.triggered.connect(lambda *_: slot())
        self.addAction(a)
        self.actions_[name] = a
        return a

    def _make_actions(self) -> None:
        A = self._action
        Seq = QtGui.QKeySequence
        A("open", "&Open…", self.open_dialog, Seq.StandardKey.Open, tip="Open a mesh (OBJ, PLY, STL, OFF)")
        A("save", "&Save", self.save, Seq.StandardKey.Save, tip="Save the deformed mesh")
        A("save_as", "Save &As…", self.save_as_dialog, "Ctrl+Shift+S", tip="Save the deformed mesh to a new file")
        A("load_edit", "&Load Edit…", self.load_edit_dialog, "Ctrl+L", tip="Load a JSON edit file and apply it")
        A("save_edit", "Save &Edit…", self.save_edit_dialog, "Ctrl+E",
          tip="Save the selection and the handle transform as a JSON edit file (for hybridedit deform)")
        A("screenshot", "Save Screens&hot…", self.screenshot_dialog, tip="Save the 3D view as a PNG image")
        A("quit", "&Quit", self.close, Seq.StandardKey.Quit, tip="Quit")
        A("undo", "&Undo", self.undo, "Ctrl+Z", tip="Undo the last selection or drag", short="Undo")
        A("redo", "&Redo", self.redo, "Ctrl+Shift+Z", tip="Redo", short="Redo")
        A("reset_pose", "Reset &Pose", self.reset_pose, "Ctrl+R", tip="Back to the rest pose (keeps the selection)",
          short="Reset")
        A("select_all", "Select &All", lambda: self._selection_op("all"), "Ctrl+A",
          tip="Select every cage vertex (current target)")
        A("clear_sel", "&Clear Selection", lambda: self._selection_op("clear"), "Ctrl+Shift+A",
          tip="Empty the current target (ROI or handle)")
        A("invert_sel", "&Invert Selection", lambda: self._selection_op("invert"), "Ctrl+I",
          tip="Invert the current target (ROI or handle)")
        settle = A("settle", "Settle on Release", self._toggle_settle, checkable=True,
                   tip="On release, solve the final transform from the selection's start pose with the batch "
                       "settings, so the window shows what 'hybridedit deform' computes")
        settle.setChecked(True)
        pol = A("polish", "Polish on Release", self._toggle_polish, checkable=True,
                tip="After a drag, run full-resolution ARAP on the edited region in the background (about 1 s) "
                    "and show the result; the next drag starts from the cage pose again")
        pol.setChecked(True)
        A("mode_camera", "&Camera Mode", lambda: self.set_mode(CAMERA), "C", checkable=True,
          tip="Left drag rotates the view", short="Camera")
        A("mode_select", "&Select Mode", lambda: self.set_mode(SELECT), "S", checkable=True,
          tip="Left drag selects cage vertices (Shift adds, Ctrl removes)", short="Select")
        A("mode_drag", "&Drag Mode", lambda: self.set_mode(DRAG), "D", checkable=True,
          tip="Left drag moves the handle parallel to the view", short="Drag")
        A("target_roi", "Target &ROI", lambda: self._set_target(ROI), "R", checkable=True,
          tip="Selections change the region of interest (green)", short="ROI")
        A("target_handle", "Target &Handle", lambda: self._set_target(HANDLE), "H", checkable=True,
          tip="Selections change the handle (orange)", short="Handle")
        A("tool_rect", "Rec&tangle", lambda: self._set_tool(RECTANGLE), "X", checkable=True,
          tip="Rubber-band rectangle selection", short="Rect")
        A("tool_brush", "&Brush", lambda: self._set_tool(BRUSH), "B", checkable=True, tip="Brush selection")
        A("brush_bigger", "Bigger Brush", lambda: self._scale_brush(1.25), "]", tip="Enlarge the brush")
        A("brush_smaller", "Smaller Brush", lambda: self._scale_brush(0.8), "[", tip="Shrink the brush")
        A("show_cage", "Show Cage &Wireframe", self._toggle_cage, "W", checkable=True,
          tip="Show the cage wireframe (the ROI and handle cage points are always shown)", short="Cage")
        A("stretch", "S&tretch Map", self._toggle_stretch, "T", checkable=True,
          tip="Colour the shape by the relative edge-length change against the rest shape (0 to 20 %)",
          short="Stretch")
        A("mesh_info", "Mesh &Info…", self.show_mesh_info,
          tip="Vertex, face and cage counts; repairs made to the input")
        A("reset_camera", "&Frame Shape", self.reset_camera, "F", tip="Reset the camera to show the whole shape")
        A("antialias", "&Anti-aliasing", self._toggle_antialias, checkable=True,
          tip="Multisample anti-aliasing (off by default with software OpenGL, where it is slow)")
        A("rebuild", "Re&build Cage", self.rebuild, "Ctrl+B", tip="Build the cage and binding again at the chosen size",
          short="Rebuild")
        A("cancel_job", "Cancel", self.cancel_job, "Esc", tip="Cancel the cage build")
        A("shortcuts", "&Shortcuts…", self.show_shortcuts, Seq.StandardKey.HelpContents, tip="List the shortcuts")
        A("howto", "&How to Edit…", self.show_howto, tip="The editing workflow in a few steps")
        A("about", "&About", self.show_about)
        for group_names in (("mode_camera", "mode_select", "mode_drag"), ("target_roi", "target_handle"),
                            ("tool_rect", "tool_brush")):
            g = QtGui.QActionGroup(self)
            g.setExclusive(True)
            for n in group_names:
                g.addAction(self.actions_[n])
        self.actions_["mode_camera"].setChecked(True)
        self.actions_["target_roi"].setChecked(True)
        self.actions_["tool_rect"].setChecked(True)

    def _make_menus(self) -> None:
        mb = self.menuBar()
        a = self.actions_
        menus = {
            "&File": ["open", "save", "save_as", None, "load_edit", "save_edit", None, "screenshot", None,
                      "mesh_info", None, "quit"],
            "&Edit": ["undo", "redo", None, "reset_pose", None, "select_all", "clear_sel", "invert_sel", None,
                      "settle", "polish"],
            "&Mode": ["mode_camera", "mode_select", "mode_drag", None, "target_roi", "target_handle", None,
                      "tool_rect", "tool_brush", "brush_bigger", "brush_smaller"],
            "&View": ["show_cage", "stretch", "reset_camera", "antialias"],
            "&Cage": ["rebuild", "cancel_job"],
            "&Help": ["howto", "shortcuts", "about"],
        }
        for title, names in menus.items():
            m = mb.addMenu(title)
            for n in names:
                if n is None:
                    m.addSeparator()
                else:
                    m.addAction(a[n])

    def _make_toolbar(self) -> None:
        tb = self.addToolBar("Tools")
        tb.setObjectName("tools")
        tb.setMovable(False)
        a = self.actions_
        tb.addWidget(QtWidgets.QLabel(" Mode "))
        for n in ("mode_camera", "mode_select", "mode_drag"):
            tb.addAction(a[n])
        tb.addSeparator()
        tb.addWidget(QtWidgets.QLabel(" Target "))
        for n in ("target_roi", "target_handle"):
            tb.addAction(a[n])
        tb.addSeparator()
        for n in ("tool_rect", "tool_brush"):
            tb.addAction(a[n])
        self.brush_spin = QtWidgets.QSpinBox()
        self.brush_spin.setRange(3, 400)
        self.brush_spin.setValue(30)
        self.brush_spin.setSuffix(" px")
        self.brush_spin.setToolTip("Brush radius ([ and ] change it)")
        self.brush_spin.valueChanged.connect(lambda v: self.controller.set_brush_radius(v))
        tb.addWidget(self.brush_spin)
        tb.addSeparator()
        tb.addWidget(QtWidgets.QLabel(" Cage "))
        self.cage_control = CageSizeControl(lambda: self.session.mesh.n_vertices if self.session else None)
        tb.addWidget(self.cage_control)
        tb.addAction(a["rebuild"])
        tb.addAction(a["show_cage"])
        tb.addSeparator()
        for n in ("undo", "redo", "reset_pose"):
            tb.addAction(a[n])

    def _make_statusbar(self) -> None:
        sb = self.statusBar()
        self.size_label = QtWidgets.QLabel("no shape")
        self.sel_label = QtWidgets.QLabel("")
        self.time_label = QtWidgets.QLabel("")
        self.error_label = QtWidgets.QLabel("")
        for w in (self.size_label, self.sel_label, self.time_label, self.error_label):
            w.setTextFormat(QtCore.Qt.TextFormat.PlainText)
            sb.addPermanentWidget(w)
        self.progress = QtWidgets.QProgressBar()
        self.progress.setRange(0, 1000)
        self.progress.setFixedWidth(260)
        self.progress.setTextVisible(True)
        self.cancel_button = QtWidgets.QPushButton("Cancel")
        self.cancel_button.clicked.connect(self.cancel_job)
        sb.addPermanentWidget(self.progress)
        sb.addPermanentWidget(self.cancel_button)
        self.progress.hide()
        self.cancel_button.hide()

    # ================================================================== messages
    def show_error(self, title: str, text: str) -> None:
        """Tell the user about a problem (a non-blocking window-modal message box)."""
        self.last_error = text
        box = QtWidgets.QMessageBox(QtWidgets.QMessageBox.Icon.Warning, title, text,
                                    QtWidgets.QMessageBox.StandardButton.Ok, self)
        box.setAttribute(QtCore.Qt.WidgetAttribute.WA_DeleteOnClose)
        self._error_box = box
        box.open()
        self.statusBar().showMessage(text.splitlines()[0] if text else title, 8000)

    def confirm(self, title: str, text: str) -> bool:
        """Ask a yes/no question (No is the default)."""
        Btn = QtWidgets.QMessageBox.StandardButton
        r = QtWidgets.QMessageBox.question(self, title, text, Btn.Yes | Btn.No, Btn.No)
        return r == Btn.Yes

    def message(self, text: str, ms: int = 6000) -> None:
        self.statusBar().showMessage(text, ms)

    # ================================================================== cage size control
    def cage_size(self) -> int | float:
        """The cage size set in the toolbar: an int vertex count or a float fraction."""
        return self.cage_control.value()

    def set_cage_size(self, size: int | float) -> None:
        self.cage_control.set_value(size)

    # ================================================================== modes
    def set_mode(self, mode: str) -> None:
        self.controller.set_mode(mode)
        self.actions_[f"mode_{mode}"].setChecked(True)
        self.message({CAMERA: "Camera mode: left drag rotates the view",
                      SELECT: "Select mode: left drag selects (Shift adds, Ctrl removes); R / H switch ROI / handle",
                      DRAG: "Drag mode: left drag moves the handle in the view plane; the gizmo rotates it"}[mode])

    def _set_target(self, target: str) -> None:
        self.target = target
        self.actions_["target_roi" if target == ROI else "target_handle"].setChecked(True)
        rgb = STATE_COLORS[1] if target == ROI else STATE_COLORS[2]
        self.controller.target_color = QtGui.QColor(int(rgb[0]), int(rgb[1]), int(rgb[2]))

    def _set_tool(self, tool: str) -> None:
        self.controller.set_tool(tool)
        self.actions_["tool_rect" if tool == RECTANGLE else "tool_brush"].setChecked(True)

    def _scale_brush(self, factor: float) -> None:
        self.brush_spin.setValue(int(round(self.brush_spin.value() * factor)))

    def _toggle_cage(self) -> None:
        self.scene.set_cage_visible(self.actions_["show_cage"].isChecked())
        self.view.request_render()

    def _toggle_antialias(self) -> None:
        self.view.set_antialiasing(self.actions_["antialias"].isChecked())

    def _toggle_settle(self) -> None:
        self.settle_on_release = self.actions_["settle"].isChecked()
        if self.session is not None:
            self.session.settle_on_release = self.settle_on_release

    def _toggle_polish(self) -> None:
        self.polish_on_release = self.actions_["polish"].isChecked()
        if not self.polish_on_release:
            self.cancel_polish()

    def _toggle_stretch(self) -> None:
        self.scene.set_stretch_visible(self.actions_["stretch"].isChecked())
        self._measure(everything=True)
        self.view.request_render()

    def reset_camera(self) -> None:
        self.scene.reset_camera()
        self.view.request_render()

    # ================================================================== loading (worker thread)
    def open_path(self, path: str | os.PathLike) -> bool:
        """Read a mesh and build its cage and binding in the worker thread."""
        p = Path(path)
        return self._start_job(BuildRequest(cage_size=self.cage_size(), path=p), f"Opening {p.name}")

    def open_mesh(self, mesh, path: Path | None = None) -> bool:
        """Build an already loaded shape (used by tests and scripts)."""
        return self._start_job(BuildRequest(cage_size=self.cage_size(), path=path, mesh=mesh), "Building")

    @guarded
    def rebuild(self) -> bool:
        """Build the cage and binding again at the toolbar's size; the selection carries over, the pose resets."""
        self._finish_settle()
        s = self.session
        if s is None:
            self.show_error("Rebuild cage", "Open a mesh first.")
            return False
        carry = {
            "rebuild": True,
            "roi": np.flatnonzero(s.roi[s.dominant]),
            "handle": np.flatnonzero(s.handle[s.dominant]),
        }
        return self._start_job(BuildRequest(cage_size=self.cage_size(), path=s.path, mesh=s.mesh, carry=carry),
                               "Rebuilding the cage")

    def _start_job(self, request: BuildRequest, label: str) -> bool:
        if self.worker is not None:
            self.show_error("Busy", "A cage is being built; wait for it or cancel it first.")
            return False
        self.controller.cancel()
        self.cancel_polish()
        w = BuildWorker(request, self)
        w.progress.connect(self._job_progress)
        w.succeeded.connect(self._job_succeeded)
        w.failed.connect(self._job_failed)
        w.cancelled.connect(self._job_cancelled)
        w.finished.connect(self._job_finished)
        self.worker = w
        self.progress.setValue(0)
        self.progress.setFormat(f"{label}…")
        self.progress.show()
        self.cancel_button.show()
        self.cancel_button.setEnabled(True)
        self._update_actions()
        w.start()
        return True

    def cancel_job(self) -> None:
        if self.worker is not None:
            self.worker.cancel()
            self.cancel_button.setEnabled(False)
            self.progress.setFormat("Cancelling…")

    def _job_progress(self, stage: str, fraction: float) -> None:
        if self.worker is not None and self.worker.cancel_requested:
            return
        self.progress.setValue(int(round(1000 * min(max(fraction, 0.0), 1.0))))
        self.progress.setFormat(f"{stage} %p%")

    def _job_succeeded(self, result: BuildResult) -> None:
        try:
            self._install(result)
        except Exception as e:  # noqa: BLE001
            self.show_error("Could not show the shape", f"{e.__class__.__name__}: {e}")

    def _job_failed(self, message: str) -> None:
        req = self.worker.request if self.worker is not None else None
        rebuilding = req is not None and req.carry.get("rebuild")
        what = "Could not rebuild the cage" if rebuilding else "Could not open the mesh"
        self.show_error(what, message)

    def _job_cancelled(self) -> None:
        self.message("Cancelled; the current shape and edit are unchanged.")

    def _job_finished(self) -> None:
        w = self.worker
        self.worker = None
        if w is not None:
            w.wait()
            w.deleteLater()
        self.progress.hide()
        self.cancel_button.hide()
        self._update_actions()

    def _install(self, result: BuildResult) -> None:
        req = result.request
        ed = result.editor
        rebuild = bool(req.carry.get("rebuild"))
        roi = handle = None
        if rebuild:
            c = ed.cage.n_vertices
            roi = np.zeros(c, dtype=bool)
            handle = np.zeros(c, dtype=bool)
            if len(req.carry["roi"]):
                roi[ed.to_cage(req.carry["roi"], "shape")] = True
            if len(req.carry["handle"]):
                handle[ed.to_cage(req.carry["handle"], "shape")] = True
        session = Session(ed, path=req.path, cage_size=req.cage_size, roi=roi, handle=handle)
        session.settle_on_release = self.settle_on_release
        self.controller.cancel()
        self._finish_settle()
        self.settle_timer.stop()
        self.cancel_polish()
        self.session = session
        self.polished = None
        self.last_polish = None
        if self._polish_holder is not None and self._polish_holder.mesh is not session.mesh:
            self._polish_holder = None  # a new shape: its full-resolution set-up is built by its first polish
        self.scene.load(session.metrics, session.shape_positions, session.cage_positions,
                        ed.cage.faces, session.states(), session.shape_roles())
        self.scene.gizmo.place(session.handle_centroid())
        if not rebuild:
            self.save_path = None
            self.edit_path = None
            self.scene.reset_camera()
        self.modified = False
        self._rrms_dirty = self._rrms_full = True
        name = req.path.name if req.path is not None else (session.mesh.name or "shape")
        self.setWindowTitle(f"hybridedit — {name}")
        t = ed.timings
        how = "from the cache" if getattr(ed, "cache_hit", False) else (
            f"cage {t.get('cage_seconds', 0):.1f} s, binding {t.get('bind_seconds', 0):.1f} s")
        notes = [str(n) for n in (getattr(ed, "notes", None) or [])]
        msg = f"{'Rebuilt' if rebuild else 'Loaded'} {name} ({how})"
        if notes and not rebuild:
            msg += f" · input repaired: {'; '.join(notes)} (File ▸ Mesh Info…)"
        self.message(msg, 20000 if notes else 10000)
        self._update_labels()
        self._update_actions()
        self._measure()
        self.view.request_render()

    # ================================================================== Handler (called by the view controller)
    def cage_points(self) -> np.ndarray | None:
        self._finish_settle()
        return None if self.session is None else self.session.cage_positions

    def handle_center(self) -> np.ndarray | None:
        self._finish_settle()
        return None if self.session is None else self.session.handle_centroid()

    def begin_select(self) -> bool:
        self._finish_settle()
        self.cancel_polish()
        if self.session is None:
            return False
        self.session.begin_stroke(self.target)
        return True

    def select_hits(self, hits: np.ndarray, op: str) -> None:
        if self.session is None:
            return
        self.session.stroke(hits, op)
        self._refresh_selection()

    def end_select(self) -> None:
        if self.session is None:
            return
        self.session.end_stroke()
        self._refresh_selection()
        self._update_actions()

    def begin_drag(self) -> bool:
        self._finish_settle()
        self.cancel_polish()
        if self.session is None:
            return False
        self._drop_polished()  # the drag starts from the engine's pose
        try:
            self._drag_T0 = self.session.begin_drag()
        except SelectionError as e:
            self.show_error("Cannot drag", str(e))
            return False
        self._pending_T = None
        self.scene.set_moving(self.session.moving_vertices())
        self._measure()  # every edge once: then each frame only the moving region's
        return True

    def drag(self, D: np.ndarray) -> None:
        """A new handle transform from the mouse: applied on the next event-loop pass, so the
        mouse moves that arrive while a frame renders collapse into one engine frame."""
        s = self.session
        if s is None or not s.applied:
            return
        schedule = self._pending_T is None
        self._pending_T = np.asarray(D) @ self._drag_T0
        if schedule:
            QtCore.QTimer.singleShot(0, self._apply_pending_drag)

    def _apply_pending_drag(self) -> None:
        s = self.session
        T, self._pending_T = self._pending_T, None
        if s is None or T is None or not s.applied:
            return
        t0 = time.perf_counter()
        try:
            V = s.drag_to(T)
        except (ValueError, ArithmeticError) as e:  # e.g. a degenerate transform: stop this drag
            self.controller.gesture = None
            s.cancel_drag()
            self._refresh_all()
            self.show_error("Drag failed", f"{e}; the drag was undone.")
            return
        t1 = time.perf_counter()
        normals_s, upload_s = self.scene.update_shape(V)
        self.scene.update_cage(s.cage_positions)
        self.scene.gizmo.place(s.handle_centroid())
        split = self.view.split
        split.add("engine", t1 - t0)
        split.add("normals", normals_s)
        split.add("vtk update", upload_s)
        self._engine_ms = (t1 - t0) * 1e3
        self._rrms_dirty = True
        if self.scene.stretch_visible:
            self._measure(everything=False)
        self.modified = True
        self.view.request_render()

    def end_drag(self) -> None:
        s = self.session
        if s is None or not s.applied:
            return
        self._apply_pending_drag()
        if not np.all(np.isfinite(s.shape_positions)):
            s.cancel_drag()
            self._refresh_all()
            self.show_error("Drag failed", "The deformation became non-finite; the drag was undone.")
            return
        if s.end_drag():
            self._settle_chunk = 2
            self.settle_timer.start()  # settle in slices; the last interactive frame stays on screen
        else:
            self._after_drag()

    def _settle_tick(self) -> None:
        s = self.session
        if s is None:
            self.settle_timer.stop()
            return
        done = True
        if s.settling:  # (something may have read the pose, which completes the settle)
            t0 = time.perf_counter()
            done = s.settle_step(self._settle_chunk)
            per = (time.perf_counter() - t0) / max(self._settle_chunk, 1)
            # aim at slices of ~15 ms so the window stays responsive
            self._settle_chunk = int(min(max(0.015 / max(per, 1e-6), 1), 30))
        if done:
            self.settle_timer.stop()
            self._after_drag()

    def _finish_settle(self) -> None:
        """Complete a settle under way now (before anything reads or changes the pose)."""
        s = self.session
        if s is not None and s.settling:
            s.finish_settle()
            self.settle_timer.stop()
            self._after_drag()

    def _after_drag(self) -> None:
        self._refresh_pose()
        self._update_actions()
        self._start_polish()

    # ================================================================== polish on release (worker thread)
    def shown_vertices(self) -> np.ndarray | None:
        """The shape on display: the polished pose when one is shown, else the engine's pose."""
        if self.session is None:
            return None
        return self.polished if self.polished is not None else self.session.shape_positions

    def _start_polish(self) -> None:
        """Polish the engine's pose in the background (after a drag's settle)."""
        s = self.session
        if not self.polish_on_release or s is None or not s.applied or s.settling:
            return
        ed = s.editor
        free = free_shape_vertices(ed.M, ed.arap.free, ed.cage.n_vertices)
        if not free.any():
            return
        if self._polish_holder is None or self._polish_holder.mesh is not s.mesh:
            self._polish_holder = ShapeARAPHolder(s.mesh)
        self._polish_token += 1
        req = PolishRequest(self._polish_holder, s.shape_positions.copy(), free, s.edges,
                            seconds=self.polish_seconds, max_iterations=self.polish_iterations,
                            tolerance=self.polish_tolerance, token=self._polish_token)
        if self.polish_worker is not None:  # one at a time (they share the set-up): queue it
            self.polish_worker.cancel()
            self._polish_next = req
        else:
            self._launch_polish(req)

    def _launch_polish(self, req: PolishRequest) -> None:
        w = PolishWorker(req, self)
        w.succeeded.connect(self._polish_succeeded)
        w.failed.connect(self._polish_failed)
        w.finished.connect(self._polish_finished)
        self.polish_worker = w
        self.time_label.setText("polishing…")
        w.start()

    def cancel_polish(self) -> None:
        """Stop a polish under way (or queued); its result will be dropped. A polished pose on display stays."""
        self._polish_token += 1
        self._polish_next = None
        if self.polish_worker is not None:
            self.polish_worker.cancel()

    def _drop_polished(self) -> None:
        """Show the engine's pose again instead of a polished one."""
        if self.polished is None:
            return
        self.polished = None
        if self.session is not None:
            self.scene.update_shape(self.session.shape_positions, everything=True)
            self._pose_shown_changed()
            self.view.request_render()

    def _polish_current(self, out: PolishOutcome) -> bool:
        s = self.session
        return (out.request.token == self._polish_token and s is not None and not s.settling
                and out.request.holder is self._polish_holder and s.mesh is out.request.holder.mesh)

    def _polish_succeeded(self, out: PolishOutcome) -> None:
        if not self._polish_current(out):
            return  # a drag, an undo or the like came in between: the result is stale
        self.last_polish = out
        self.polished = out.result.vertices
        self.scene.update_shape(self.polished, everything=True)
        self._pose_shown_changed()
        self.view.request_render()
        r = out.result
        self.message(f"polished: {r.iterations} iterations, edge error {out.error_before:.2f}% → "
                     f"{out.error_after:.2f}% ({out.seconds:.2f} s)", 10000)

    def _polish_failed(self, message: str) -> None:
        self.message(f"Polish failed: {message}", 10000)

    def _polish_finished(self) -> None:
        w = self.polish_worker
        self.polish_worker = None
        if w is not None:
            w.wait()
            w.deleteLater()
        req, self._polish_next = self._polish_next, None
        if req is not None and req.token == self._polish_token and self.session is not None:
            self._launch_polish(req)

    # ================================================================== edge error and stretch map
    def _pose_shown_changed(self) -> None:
        """The shape on display changed outside a drag: edge error and stretch map are measured again."""
        self._rrms_full = True
        self._measure()

    def _measure(self, everything: bool | None = None) -> None:
        """Edge error (status bar) and, when shown, the stretch map of the shape on display.

        During a drag only the edges of the moving region are measured again
        (:class:`~.regional.ShapeMetrics`); after any other change, every edge.
        """
        s = self.session
        if s is None:
            self.error_label.setText("")
            return
        full = self._rrms_full if everything is None else everything
        self._rrms_full = False
        self._rrms_time = time.perf_counter()
        self._rrms_dirty = False
        err = s.metrics.update_error(self.shown_vertices(), everything=full)
        self.error_label.setText(f"edge error {err:.2f} %{' (polished)' if self.polished is not None else ''}")
        if self.scene.stretch_visible:
            s.metrics.write_stretch(self.scene.stretch32, everything=full)
            self.scene.stretch_modified()
            self.view.request_render()

    # ================================================================== refresh
    def _refresh_pose(self) -> None:
        s = self.session
        if s is None:
            return
        self.polished = None
        self.scene.update_shape(s.shape_positions, everything=True)
        self.scene.update_cage(s.cage_positions)
        self.scene.gizmo.place(s.handle_centroid())
        self._pose_shown_changed()
        self.view.request_render()

    def _refresh_selection(self) -> None:
        s = self.session
        if s is None:
            return
        self.scene.update_states(s.states(), s.shape_roles())
        self.scene.gizmo.place(s.handle_centroid())
        self._update_labels()
        self.view.request_render()

    def _refresh_all(self) -> None:
        self._refresh_pose()
        self._refresh_selection()
        self._update_actions()

    def _update_labels(self) -> None:
        s = self.session
        if s is None:
            self.size_label.setText("no shape")
            self.sel_label.setText("")
            return
        m, c = s.mesh, s.editor.cage
        self.size_label.setText(f"shape {_fmt(m.n_vertices)} v / {_fmt(m.n_faces)} f · cage {_fmt(c.n_vertices)} v")
        n_roi = int(np.count_nonzero(s.roi & ~s.handle))
        n_h = int(np.count_nonzero(s.handle))
        n_f = int(np.count_nonzero(~s.roi & ~s.handle))
        self.sel_label.setText(f"ROI {n_roi} · handle {n_h} · fixed {n_f}")

    def _on_rendered(self, seconds: float) -> None:
        a = self.actions_["antialias"]
        if self.view.antialiasing is not None and a.isChecked() != self.view.antialiasing:
            a.setChecked(self.view.antialiasing)

    def _tick(self) -> None:
        if self.session is None or self.session.settling:
            return
        if self._rrms_dirty and time.perf_counter() - self._rrms_time >= RRMS_INTERVAL:
            self._measure()
        if self.polish_worker is not None:
            self.time_label.setText("polishing…")
            return
        self.time_label.setText(self.timing_text())

    def timing_text(self) -> str:
        """Frames shown per second first (what the eye gets), then the engine's and the render's share."""
        fps = self.view.display_fps()
        parts = [f"{fps:.0f} fps" if fps > 0 else "idle"]
        if self._engine_ms > 0:
            parts.append(f"engine {self._engine_ms:.1f} ms")
        if self.view.render_seconds > 0:
            parts.append(f"render {self.view.render_seconds * 1e3:.0f} ms")
        return " · ".join(parts)

    def _update_actions(self) -> None:
        a = self.actions_
        s = self.session
        h = s.history if s else None
        a["undo"].setEnabled(bool(h and h.can_undo()))
        a["redo"].setEnabled(bool(h and h.can_redo()))
        a["undo"].setText(f"&Undo {h.undo_label()}" if h and h.can_undo() else "&Undo")
        a["redo"].setText(f"&Redo {h.redo_label()}" if h and h.can_redo() else "&Redo")
        busy = self.worker is not None
        for n in ("open", "rebuild", "load_edit"):
            a[n].setEnabled(not busy)
        for n in ("save", "save_as", "save_edit", "reset_pose", "select_all", "clear_sel", "invert_sel", "screenshot",
                  "mesh_info"):
            a[n].setEnabled(s is not None)
        a["cancel_job"].setEnabled(busy)

    # ================================================================== edit actions
    @guarded
    def undo(self) -> None:
        if self.session is None or self.controller.busy:
            return
        self._finish_settle()
        self.cancel_polish()
        if self.session.undo():
            self._refresh_all()

    @guarded
    def redo(self) -> None:
        if self.session is None or self.controller.busy:
            return
        self._finish_settle()
        self.cancel_polish()
        if self.session.redo():
            self._refresh_all()

    @guarded
    def reset_pose(self) -> None:
        if self.session is None or self.controller.busy:
            return
        self._finish_settle()
        self.cancel_polish()
        self.session.reset_pose()
        self._refresh_all()
        self.message("Back to the rest pose")

    def _selection_op(self, op: str) -> None:
        s = self.session
        if s is None or self.controller.busy:
            return
        self._finish_settle()
        self.cancel_polish()
        {"all": s.select_all, "clear": s.clear, "invert": s.invert}[op](self.target)
        self._refresh_selection()
        self._update_actions()

    # ================================================================== files
    @guarded
    def open_dialog(self) -> None:
        start = str(self.session.path.parent) if self.session and self.session.path else os.getcwd()
        path, _ = QtWidgets.QFileDialog.getOpenFileName(self, "Open mesh", start, MESH_FILTER)
        if path:
            self.open_path(path)

    def _suggested_path(self, suffix: str, ext: str) -> str:
        s = self.session
        if s is not None and s.path is not None:
            return str(s.path.with_name(f"{s.path.stem}{suffix}{ext}"))
        return str(Path.cwd() / f"shape{suffix}{ext}")

    @guarded
    def save(self) -> bool:
        if self.session is None:
            return False
        if self.save_path is None:
            return bool(self.save_as_dialog())
        return self.save_to(self.save_path, asked=False)

    @guarded
    def save_as_dialog(self) -> bool:
        if self.session is None:
            return False
        ext = self.session.path.suffix.lower() if self.session.path else ".ply"
        start = str(self.save_path) if self.save_path else self._suggested_path("-edited", ext)
        path, selected = QtWidgets.QFileDialog.getSaveFileName(
            self, "Save deformed mesh", start, MESH_FILTER,
            options=QtWidgets.QFileDialog.Option.DontConfirmOverwrite)
        if not path:
            return False
        p = Path(path)
        if not p.suffix:
            for e in SUPPORTED_EXTENSIONS:
                if f"*{e}" in selected:
                    p = p.with_suffix(e)
                    break
            else:
                p = p.with_suffix(".ply")
        return self.save_to(p, asked=False)

    def save_to(self, path: str | os.PathLike, asked: bool = False) -> bool:
        """Write the deformed shape; asks before replacing the opened file or any existing file."""
        self._finish_settle()
        s = self.session
        if s is None:
            return False
        p = Path(path)
        if p.suffix.lower() not in SUPPORTED_EXTENSIONS:
            self.show_error("Cannot save", f"{p.name}: unsupported format; use .obj, .ply, .stl or .off")
            return False
        if not asked:
            if s.path is not None and _same_file(p, s.path):
                if not self.confirm("Overwrite the input file?",
                                    f"{p} is the file this shape was opened from.\n\n"
                                    "Replace it with the deformed shape? The original will be lost."):
                    self.message("Not saved")
                    return False
            elif p.exists() and p != self.save_path:
                if not self.confirm("Replace file?", f"{p} already exists. Replace it?"):
                    self.message("Not saved")
                    return False
        try:
            # what is shown: the polished pose when one is on display
            write_mesh(p, s.editor.deformed if self.polished is None else s.mesh.copy(vertices=self.polished.copy()))
        except (MeshError, MeshFileError, WriteError, OSError) as e:
            self.show_error("Could not save the mesh", str(e))
            return False
        self.save_path = p
        self.modified = False
        self.message(f"Saved {p}")
        return True

    @guarded
    def save_edit_dialog(self) -> bool:
        if self.session is None:
            return False
        start = str(self.edit_path) if self.edit_path else self._suggested_path("-edit", ".json")
        path, _ = QtWidgets.QFileDialog.getSaveFileName(self, "Save edit", start, EDIT_FILTER)
        if not path:
            return False
        p = Path(path)
        if not p.suffix:
            p = p.with_suffix(".json")
        return self.save_edit_to(p)

    def save_edit_to(self, path: str | os.PathLike) -> bool:
        """Write the selection and handle transform as a JSON edit file (cage indices)."""
        self._finish_settle()
        s = self.session
        if s is None:
            return False
        try:
            edit = s.to_edit()
            save_edit(path, edit)
        except (SelectionError, ValueError, WriteError, OSError) as e:
            self.show_error("Could not save the edit", str(e))
            return False
        self.edit_path = Path(path)
        note = "" if s.anchor_at_rest or not s.applied else (
            " Note: this selection was made on a deformed pose; 'hybridedit deform' replays it from the rest pose.")
        self.message(f"Saved the edit to {path} (the last selection and its drag; cage {s.n_cage} vertices, "
                     f"use the same --cage with hybridedit deform).{note}", 12000)
        return True

    @guarded
    def load_edit_dialog(self) -> bool:
        if self.session is None:
            self.show_error("Load edit", "Open a mesh first.")
            return False
        start = str(self.edit_path) if self.edit_path else self._suggested_path("-edit", ".json")
        path, _ = QtWidgets.QFileDialog.getOpenFileName(self, "Load edit", start, EDIT_FILTER)
        if not path:
            return False
        return self.load_edit_from(path)

    def load_edit_from(self, path: str | os.PathLike) -> bool:
        """Apply a JSON edit file as 'hybridedit deform' does (from the rest pose)."""
        self._finish_settle()
        s = self.session
        if s is None:
            self.show_error("Load edit", "Open a mesh first.")
            return False
        if self.controller.busy:
            return False
        self.cancel_polish()
        try:
            edit = load_edit(path)
            s.load_edit(edit)
        except (EditFileError, SelectionError, ValueError) as e:
            self.show_error("Could not load the edit", str(e))
            return False
        self.edit_path = Path(path)
        self.modified = True
        self._refresh_all()
        self.message(f"Applied {Path(path).name}")
        return True

    @guarded
    def screenshot_dialog(self) -> bool:
        path, _ = QtWidgets.QFileDialog.getSaveFileName(self, "Save screenshot", self._suggested_path("", ".png"),
                                                        "PNG images (*.png)")
        if not path:
            return False
        try:
            self.view.screenshot(path)
        except Exception as e:  # noqa: BLE001
            self.show_error("Could not save the screenshot", f"{path}: {e}")
            return False
        self.message(f"Saved {path}")
        return True

    # ================================================================== drag and drop
    @staticmethod
    def _dropped_path(mime: QtCore.QMimeData) -> Path | None:
        urls = mime.urls() if mime.hasUrls() else []
        if len(urls) != 1 or not urls[0].isLocalFile():
            return None
        p = Path(urls[0].toLocalFile())
        if p.suffix.lower() in SUPPORTED_EXTENSIONS + (".json",):
            return p
        return None

    def dragEnterEvent(self, ev: QtGui.QDragEnterEvent) -> None:  # noqa: N802
        if self._dropped_path(ev.mimeData()) is not None:
            ev.acceptProposedAction()
        else:
            ev.ignore()

    def dragMoveEvent(self, ev: QtGui.QDragMoveEvent) -> None:  # noqa: N802
        if self._dropped_path(ev.mimeData()) is not None:
            ev.acceptProposedAction()

    @guarded
    def dropEvent(self, ev: QtGui.QDropEvent) -> None:  # noqa: N802
        p = self._dropped_path(ev.mimeData())
        if p is None:
            ev.ignore()
            return
        ev.acceptProposedAction()
        if p.suffix.lower() == ".json":
            self.load_edit_from(p)
        else:
            self.open_path(p)

    # ================================================================== help
    def show_shortcuts(self) -> None:
        dlg = ShortcutsDialog(list(self.actions_.values()), self)
        dlg.setAttribute(QtCore.Qt.WidgetAttribute.WA_DeleteOnClose)
        self._shortcuts_dialog = dlg
        dlg.open()

    def show_howto(self) -> None:
        QtWidgets.QMessageBox.information(self, "How to edit", HOWTO)

    def mesh_info_text(self) -> str:
        s = self.session
        if s is None:
            return "No shape loaded."
        m, c = s.mesh, s.editor.cage
        lines = [
            f"Shape: {s.path if s.path is not None else (m.name or 'shape')}",
            f"Vertices: {_fmt(m.n_vertices)}",
            f"Faces: {_fmt(m.n_faces)}",
            f"Edges: {_fmt(len(s.edges))}",
            f"Cage: {_fmt(c.n_vertices)} vertices, {_fmt(c.n_faces)} faces",
        ]
        notes = [str(n) for n in (getattr(s.editor, "notes", None) or [])]
        lines.append("")
        if notes:
            lines.append("Repairs made to the input:")
            lines += [f"  • {n}" for n in notes]
        else:
            lines.append("Repairs made to the input: none")
        if self.last_polish is not None:
            p = self.last_polish
            lines += ["", f"Last polish: {p.result.iterations} iterations in {p.seconds:.2f} s "
                          f"(set-up {p.setup_seconds:.2f} s), "
                          f"edge error {p.error_before:.2f}% → {p.error_after:.2f}%"]
        return "\n".join(lines)

    def show_mesh_info(self) -> None:
        """File > Mesh Info: counts and repairs, in a non-modal box."""
        box = QtWidgets.QMessageBox(QtWidgets.QMessageBox.Icon.Information, "Mesh info", self.mesh_info_text(),
                                    QtWidgets.QMessageBox.StandardButton.Ok, self)
        box.setAttribute(QtCore.Qt.WidgetAttribute.WA_DeleteOnClose)
        box.setModal(False)
        self._info_box = box
        box.show()

    def show_about(self) -> None:
        QtWidgets.QMessageBox.about(
            self, "About hybridedit",
            "hybridedit: interactive as-rigid-as-possible editing of large meshes through a QEM cage\n"
            "(the hybrid method of Borosán, Howard, Zhang and Nealen, Eurographics 2010).\n\n"
            "Pick an ROI (green) and a handle (orange) on the cage, then drag the handle.")

    # ================================================================== closing
    def closeEvent(self, ev: QtGui.QCloseEvent) -> None:  # noqa: N802
        self.settle_timer.stop()
        self.cancel_polish()
        if self.polish_worker is not None:
            self.polish_worker.wait(30000)
        if self.worker is not None:
            self.worker.cancel()
            self.worker.wait(30000)
        self.status_timer.stop()
        self.view.close()
        super().closeEvent(ev)
