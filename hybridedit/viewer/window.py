"""The main window: menus, toolbar, status bar; it wires Qt to the session.

The editing state (selection, pose, polished pose, undo) lives in
:class:`~.session.Session`; file actions in :mod:`.files`; cage and binding
builds in :mod:`.building`; a drag's frames and settle in :mod:`.dragging`;
polish scheduling in :mod:`.polishing`; the information dialogs in
:mod:`.dialogs`; the drawing in :mod:`.scene`; mouse gestures in
:mod:`.interaction`.
"""

from __future__ import annotations

import functools
import os
import time
from pathlib import Path
from typing import TYPE_CHECKING, Callable

import numpy as np
from qtpy import QtCore, QtGui, QtWidgets

from ..defaults import CAGE_SIZE
from ..deform.editor import SelectionError
from ..core.up_axis import AXES, remember_up_axis, shape_key
from ..deform.roles import FREE, handle as handle_role
from .building import BuildJobs
from .cagesize import CageSizeControl
from .dialogs import InfoDialogs
from .files import FileActions, dropped_path
from .dragging import DragFrames
from .framethread import FrameThread
from .interaction import BRUSH, CAMERA, DRAG, RECTANGLE, SELECT, ViewController
from .polishing import PolishScheduler
from .scene import ROLE_COLOR_NAMES, ROLE_COLORS, VIEWS, Scene, role_rows
from .selectionstate import HANDLE, ROI
from .session import Session
from .statusfield import MessageLine, StatusField, StatusRow
from .view import View
from .worker import BuildResult, BuildWorker, PolishOutcome

if TYPE_CHECKING:
    from ..core.mesh import Mesh


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

    Attributes
    ----------
    session : the shape being edited, or None.
    files : the file actions (:class:`~.files.FileActions`).
    jobs : the cage and binding builds (:class:`~.building.BuildJobs`).
    dialogs : the information dialogs (:class:`~.dialogs.InfoDialogs`).
    dragging : the drags' frames and settle (:class:`~.dragging.DragFrames`).
    polisher : polish on release (:class:`~.polishing.PolishScheduler`).
    modified : the pose on display is not saved (shown as ``*`` in the title).
    """

    def __init__(self, cage_size: int | float = CAGE_SIZE) -> None:
        super().__init__()
        self.session: Session | None = None
        self.last_error: str | None = None
        self.modified = False
        self._saved_pose: np.ndarray | None = None  # the pose last saved or opened (see pose_saved)
        #: while a new shape read is shown and its cage is built: (the session put aside,) (see preview_shape)
        self._aside: tuple[Session | None] | None = None
        self._previewed: Mesh | None = None  # the shape shown by preview_shape
        self.settle_on_release = True
        self.last_polish: PolishOutcome | None = None
        self._error_box: QtWidgets.QMessageBox | None = None
        self._rrms_full = True  # the next measure must walk every edge (the pose changed outside a drag)
        self._generation = -1  # the session's engine generation the scene shows
        # each helper takes the window as the narrow protocol it declares (FileHost, BuildHost, InfoSource,
        # DragHost) and, where it draws, the scene and the view themselves
        self.files = FileActions(self, parent=self)
        self.jobs = BuildJobs(self, parent=self)
        self.jobs.busy_changed.connect(lambda _busy: self._update_actions())
        self.dialogs = InfoDialogs(self, parent=self)
        self.polisher = PolishScheduler(self)
        self.polisher.succeeded.connect(self._polish_succeeded)
        self.polisher.failed.connect(lambda m: self.message(f"Polish failed: {m}"))
        self.update_title()

        self.view = View(self)
        self.setCentralWidget(self.view)
        self.scene = Scene(self.view.plotter)
        self.dragging = DragFrames(self, self.scene, self.view, parent=self)
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
        A("open", "&Open…", self.files.open_dialog, Seq.StandardKey.Open, tip="Open a mesh (OBJ, PLY, STL, OFF)")
        A("save", "&Save", self.files.save, Seq.StandardKey.Save, tip="Save the deformed mesh")
        A("save_as", "Save &As…", self.files.save_as_dialog, "Ctrl+Shift+S", tip="Save the deformed mesh to a new file")
        A("load_edit", "&Load Edit…", self.files.load_edit_dialog, "Ctrl+L", tip="Load a JSON edit file and apply it")
        A("save_edit", "Save &Edit…", self.files.save_edit_dialog, "Ctrl+E",
          tip="Save the selection and the handle transform as a JSON edit file (for hybridedit deform)")
        A("screenshot", "Save Screens&hot…", self.files.screenshot_dialog, tip="Save the 3D view as a PNG image")
        A("quit", "&Quit", self.close, Seq.StandardKey.Quit, tip="Quit")
        A("undo", "&Undo", self.undo, "Ctrl+Z", tip="Undo the last selection or drag", short="Undo")
        A("redo", "&Redo", self.redo, "Ctrl+Shift+Z", tip="Redo", short="Redo")
        A("reset_pose", "Reset &Pose", self.reset_pose, "Ctrl+R", tip="Back to the rest pose (keeps the selection)",
          short="Reset")
        A("select_all", "Select &All", lambda: self._selection_op("all"), "Ctrl+A",
          tip="Select every cage vertex (current target)")
        A("clear_sel", "&Clear All", lambda: self._selection_op("clear_all"), "Ctrl+Shift+A",
          tip="Empty the ROI and every handle group (one undo step)")
        A("clear_target", "Clear &Target", lambda: self._selection_op("clear"), "Alt+A",
          tip="Empty the current target only: the ROI, or the active handle group")
        A("select_through", "Select &Through", self._toggle_select_through, "Alt+Z", checkable=True,
          tip="Rectangle, brush and click also take the cage points hidden behind another part "
              "(Blender's X-ray); off, the part drawn over, through its thickness", short="Through")
        A("invert_sel", "&Invert Selection", lambda: self._selection_op("invert"), "Ctrl+I",
          tip="Invert the current target (ROI or handle)")
        settle = A("settle", "Settle on Release", self._toggle_settle, checkable=True,
                   tip="On release, solve the final transform from the selection's start pose with the batch "
                       "settings, so the window shows what 'hybridedit deform' computes")
        settle.setChecked(True)
        pol = A("polish", "Polish on Release", self._toggle_polish, checkable=True,
                tip="After a drag, run full-resolution ARAP on the edited region in the background until it "
                    "converges and show the result; the next edit starts from it, and a saved edit replays it")
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
        for axis in "xyz":
            A(f"mirror_{axis}", f"&Mirror {axis.upper()}", lambda a=axis: self._toggle_mirror(a),
              "Shift+" + axis.upper() if axis == "x" else None, checkable=True,
              tip=f"Mirror the selection across the shape's middle plane normal to {axis.upper()}: the mirrored "
                  "handle follows the mirrored drag (as Blender's X-mirror)", short=f"Mirror {axis.upper()}")
        A("new_group", "&New Handle Group", self.new_group, "Ctrl+G",
          tip="Start another handle group (its own colour and transform); select its cage points next",
          short="New group")
        A("next_group", "Ne&xt Handle Group", self.next_group, "G",
          tip="Make the next handle group the one that selections and drags act on", short="Next group")
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
        A("messages", "&Messages", self._toggle_messages, checkable=True,
          tip="Show every message of this session, with its time")
        A("mesh_info", "Mesh &Info…", self.dialogs.mesh_info,
          tip="Vertex, face and cage counts; repairs made to the input")
        A("reset_camera", "&Frame Shape", self.reset_camera, "F", tip="Reset the camera to show the whole shape")
        Kp = QtCore.Qt.KeyboardModifier.KeypadModifier
        for view, text, digit, ctrl in (("front", "&Front", 1, False), ("back", "&Back", 1, True),
                                        ("right", "&Right", 3, False), ("left", "&Left", 3, True),
                                        ("top", "&Top", 7, False), ("bottom", "B&ottom", 7, True)):
            key = QtCore.Qt.Key(int(QtCore.Qt.Key.Key_0) + digit)
            mods = QtCore.Qt.KeyboardModifier.ControlModifier if ctrl else QtCore.Qt.KeyboardModifier.NoModifier
            a = A(f"view_{view}", f"{text} View", lambda v=view: self.set_view(v), None,
                  tip=f"Look at the shape from its {view} (numpad {'Ctrl+' if ctrl else ''}{digit}, as in Blender; "
                      "the digit row too)")
            a.setShortcuts([QtGui.QKeySequence(QtCore.QKeyCombination(mods | Kp, key)),
                            QtGui.QKeySequence(QtCore.QKeyCombination(mods, key))])
            a.setToolTip(f"{text.replace('&', '')} View ({a.shortcut().toString()})")
        up_group = QtGui.QActionGroup(self)
        for axis in AXES:
            a = A(f"up_{axis}", f"{axis} Up", lambda ax=axis: self.set_up_axis(ax), checkable=True,
                  tip=f"The shape's up axis is {axis}: the views follow it; remembered for this shape")
            up_group.addAction(a)
        group = QtGui.QActionGroup(self)
        for mode, text, key, tip in (
                ("texture", "&Texture", "Alt+1", "Show the file's textures and material colours"),
                ("colors", "&Colours", "Alt+2", "Show the file's vertex colours"),
                ("plain", "&Plain", "Alt+3", "Show the shape's form alone, in one colour")):
            a = A(f"look_{mode}", text, lambda m=mode: self._set_look_mode(m), key, checkable=True, tip=tip)
            group.addAction(a)
        A("antialias", "&Anti-aliasing", self._toggle_antialias, checkable=True,
          tip="Multisample anti-aliasing (off by default with software OpenGL, where it is slow)")
        A("rebuild", "Re&build Cage", self.rebuild, "Ctrl+B", tip="Build the cage and binding again at the chosen size",
          short="Rebuild")
        A("cancel_job", "Cancel", self.cancel_job, "Esc", tip="Cancel the cage build")
        A("shortcuts", "&Shortcuts…", self.dialogs.shortcuts, Seq.StandardKey.HelpContents,
          tip="List the shortcuts")
        A("howto", "&How to Edit…", self.dialogs.howto, tip="The editing workflow in a few steps")
        A("about", "&About", self.dialogs.about)
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
            "&Edit": ["undo", "redo", None, "reset_pose", None, "settle", "polish"],
            "&Select": ["select_all", "invert_sel", None, "clear_sel", "clear_target", None, "select_through"],
            "&Mode": ["mode_camera", "mode_select", "mode_drag", None, "target_roi", "target_handle", None,
                      "new_group", "next_group", None, "mirror_x", "mirror_y", "mirror_z", None,
                      "tool_rect", "tool_brush", "brush_bigger", "brush_smaller"],
            "&View": ["look_texture", "look_colors", "look_plain", None, "show_cage", "stretch", "reset_camera",
                      ("&Viewpoint", ["view_front", "view_back", "view_right", "view_left", "view_top", "view_bottom"]),
                      ("&Up Axis", [f"up_{axis}" for axis in AXES]), "antialias", None, "messages"],
            "&Cage": ["rebuild", "cancel_job"],
            "&Help": ["howto", "shortcuts", "about"],
        }
        for title, names in menus.items():
            m = mb.addMenu(title)
            for n in names:
                if n is None:
                    m.addSeparator()
                elif isinstance(n, tuple):  # a submenu
                    sub = m.addMenu(n[0])
                    for k in n[1]:
                        sub.addAction(a[k])
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
        tb.addAction(a["new_group"])
        tb.addAction(a["next_group"])
        tb.addAction(a["mirror_x"])
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
        tb.addAction(a["select_through"])
        tb.addSeparator()
        tb.addWidget(QtWidgets.QLabel(" Cage "))
        self.cage_control = CageSizeControl(lambda: self.session.mesh.n_vertices if self.session else None)
        tb.addWidget(self.cage_control)
        # the boxes hand the keyboard back to the view when done, so the single-key shortcuts work again
        self.cage_control.spin.editingFinished.connect(self._focus_view)
        self.cage_control.unit.activated.connect(lambda *_: self._focus_view())
        self.brush_spin.editingFinished.connect(self._focus_view)
        tb.addAction(a["rebuild"])
        tb.addAction(a["show_cage"])
        tb.addSeparator()
        for n in ("undo", "redo", "reset_pose"):
            tb.addAction(a[n])

    def _make_statusbar(self) -> None:
        sb = self.statusBar()
        # the latest message on two lines, cut with "…" when longer: whole in its tooltip, and a click shows
        # the message log (View > Messages keeps them all); its size never changes with the text
        self.message_label = MessageLine(2, hint="Click for every message (View ▸ Messages)")
        self.message_label.clicked.connect(self._show_messages)
        sb.addWidget(self.message_label, 1)
        # fields of fixed size: a new frame rate or edge error while dragging re-lays nothing out; the row
        # shows those that fit its width, by priority (edge error, selection, sizes, timing), never one over
        # another; the build's progress bar and Cancel button come first
        self.time_label = StatusField(template="00 fps · engine 00.0 ms · render 000 ms")
        self.size_label = StatusField("no shape")
        self.sel_label = StatusField()
        self.error_label = StatusField(template="edge error 00.00 %")
        # (the row takes no more than what fits beside the message at its narrowest: the rest is the message's)
        self.status_row = StatusRow(reserve=lambda: self.message_label.minimumWidth() + 40)
        for priority, w in ((4, self.time_label), (3, self.size_label), (2, self.sel_label), (1, self.error_label)):
            self.status_row.add(w, priority)
        self.jobs.place_in(self.status_row)  # the build's progress bar and Cancel button
        sb.addPermanentWidget(self.status_row)
        self.log = QtWidgets.QPlainTextEdit()
        self.log.setReadOnly(True)
        self.log.setMaximumBlockCount(2000)
        dock = QtWidgets.QDockWidget("Messages", self)
        dock.setObjectName("messages")
        dock.setWidget(self.log)
        dock.visibilityChanged.connect(lambda v: self.actions_["messages"].setChecked(v))
        self.addDockWidget(QtCore.Qt.DockWidgetArea.BottomDockWidgetArea, dock)
        dock.hide()
        self.log_dock = dock

    # ================================================================== messages
    def show_error(self, title: str, text: str) -> None:
        """Tell the user about a problem (a non-blocking window-modal message box, and the message log)."""
        self.last_error = text
        box = QtWidgets.QMessageBox(QtWidgets.QMessageBox.Icon.Warning, title, text,
                                    QtWidgets.QMessageBox.StandardButton.Ok, self)
        box.setAttribute(QtCore.Qt.WidgetAttribute.WA_DeleteOnClose)
        self._error_box = box
        box.open()
        self.message(f"{title}: {text}" if text else title)

    def confirm(self, title: str, text: str) -> bool:
        """Ask a yes/no question (No is the default)."""
        Btn = QtWidgets.QMessageBox.StandardButton
        r = QtWidgets.QMessageBox.question(self, title, text, Btn.Yes | Btn.No, Btn.No)
        return r == Btn.Yes

    def message(self, text: str) -> None:
        """Show a message in the status bar until the next one (or until it is out of date): what fits in two
        lines, the rest cut with "…" and whole in its tooltip; and log it."""
        self.message_label.setText(text)
        if text:
            self.log.appendPlainText(f"{time.strftime('%H:%M:%S')}  {text}")

    def current_message(self) -> str:
        return self.message_label.text()

    def clear_message(self) -> None:
        """The state changed: the message on show may no longer be true."""
        self.message_label.setText("")

    # ================================================================== unsaved changes
    def set_modified(self, modified: bool) -> None:
        """The pose on display is (not) saved; ``False`` also remembers it as the saved pose, so that undo and
        redo back to it clear the title's ``*`` again."""
        if not modified:
            self._saved_pose = self._pose_reference()
        if bool(modified) == self.modified:
            return  # (every drag frame says so: no window-title event each time)
        self.modified = bool(modified)
        self.setWindowModified(self.modified)

    def _pose_reference(self) -> np.ndarray | None:
        """The pose on display, as an array to compare with later: the undo history's own copy of it when it
        has one (no copy made), else a copy."""
        s = self.session
        if s is None:
            return None
        shown = s.shown_positions
        kept = getattr(getattr(s.history.current, "engine", None), "shape", None)
        return kept if kept is not None and np.array_equal(kept, shown) else shown.copy()

    def pose_saved(self) -> bool:
        """The pose on display is the one last saved (or opened)."""
        s, ref = self.session, self._saved_pose
        return s is not None and ref is not None and ref.shape == s.shown_positions.shape and \
            np.array_equal(ref, s.shown_positions)

    def update_title(self) -> None:
        """The title names the shape's file (the one last saved to by Save As, else the one opened), with
        ``*`` while the pose on display is not saved."""
        name = self.files.document_name
        self.setWindowTitle("hybridedit" if name is None else f"hybridedit — {name}[*]")
        self.setWindowModified(self.modified)

    # ================================================================== cage size control
    def cage_size(self) -> int | float:
        """The cage size set in the toolbar: an int vertex count or a float fraction."""
        return self.cage_control.value()

    def set_cage_size(self, size: int | float, *, of_shape: bool = False) -> None:
        """Show ``size`` in the toolbar; ``of_shape``: it is the size of the cage on display (a vertex count
        of that kind is not carried over to another shape: see :mod:`.building`)."""
        self.cage_control.set_value(size, of_shape=of_shape)

    def cage_size_of_shape(self) -> bool:
        """The toolbar shows the cage size of the shape on display, not a size chosen since."""
        return self.cage_control.of_shape

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
        active = self.session.active if self.session is not None else 0
        rgb = ROLE_COLORS[role_rows(FREE if target == ROI else handle_role(active))]
        self.controller.target_color = QtGui.QColor(int(rgb[0]), int(rgb[1]), int(rgb[2]))

    def _set_tool(self, tool: str) -> None:
        self.controller.set_tool(tool)
        self.actions_["tool_rect" if tool == RECTANGLE else "tool_brush"].setChecked(True)

    def _scale_brush(self, factor: float) -> None:
        self.brush_spin.setValue(int(round(self.brush_spin.value() * factor)))

    def _toggle_cage(self) -> None:
        self.scene.set_cage_visible(self.actions_["show_cage"].isChecked())
        self.view.request_render()

    def _set_look_mode(self, mode: str) -> None:
        """Draw the shape with its texture, its file's colours, or plain (View menu)."""
        s = self.session
        if s is None or mode not in self.scene.look_modes():
            self._update_actions()
            return
        self.finish_settle()
        self.scene.set_look_mode(mode)
        s.look_mode = self.scene.look_mode
        self.view.request_render()
        self._update_actions()

    def _toggle_antialias(self) -> None:
        self.view.set_antialiasing(self.actions_["antialias"].isChecked())

    def _toggle_settle(self) -> None:
        self.settle_on_release = self.actions_["settle"].isChecked()
        if self.session is not None:
            self.session.settle_on_release = self.settle_on_release

    def _toggle_polish(self) -> None:
        self.polisher.enabled = self.actions_["polish"].isChecked()
        if not self.polisher.enabled:
            # the polish only: switching it off changes neither the pose nor the selection, so a settle
            # under way goes on
            self.polisher.cancel()

    @guarded
    def _toggle_mirror(self, axis: str) -> None:
        """Mirror the selection across ``axis`` (or stop); a shape not symmetric enough is refused in words."""
        s = self.session
        on = self.actions_[f"mirror_{axis}"].isChecked()
        for other in "xyz":
            if other != axis:
                self.actions_[f"mirror_{other}"].setChecked(False)
        if s is None:
            return
        self.settle_and_stop_polish()
        before = s.symmetry
        try:
            s.set_symmetry(axis if on else None)  # a shape too asymmetric is refused here, nothing changed
            if s.handle.any():
                s.apply_selection()  # the mirrored selection is drawn on both sides at once
        except SelectionError as e:
            if s.symmetry != before:
                s.undo()  # back to the selection before the toggle
            self.actions_[f"mirror_{axis}"].setChecked(before == axis)
            self.show_error(f"Cannot mirror across {axis.upper()}", str(e))
            return
        self._refresh_selection()
        self._update_actions()
        self.message(f"Mirror {axis.upper()}: the selection and the drag are mirrored across the shape's middle plane"
                     if on else "Mirror off")

    def _group_name(self) -> str:
        """The active group in words: "handle group 2 of 3 (magenta)"."""
        s = self.session
        return f"handle group {s.active + 1} of {s.n_groups} ({ROLE_COLOR_NAMES[role_rows(handle_role(s.active))]})"

    @guarded
    def new_group(self) -> None:
        """Start a new handle group and select its cage points next (Handle target, Select mode)."""
        s = self.session
        if s is None or self.controller.busy:
            return
        # only the polish is dropped here, not the whole guard: a new, empty group moves no point and selects
        # none, and Session.new_group completes a settle under way itself (the settle timer's next tick then
        # shows the final pose and may start a polish: after_drag)
        self.polisher.cancel()
        if not s.new_group():
            self.message("The current handle group is still empty: select its cage points first")
            return
        self._set_target(HANDLE)
        self._refresh_selection()
        self._update_actions()
        self.message(f"New {self._group_name()}: select its cage points (Select mode, Handle target)")

    @guarded
    def next_group(self) -> None:
        s = self.session
        if s is None or self.controller.busy:
            return
        s.next_group()
        self._set_target(self.target)
        self._refresh_selection()
        self.message(f"Now {self._group_name()}: selections and drags act on it")

    def _toggle_messages(self) -> None:
        self.log_dock.setVisible(self.actions_["messages"].isChecked())

    def _show_messages(self) -> None:
        """A click on the status bar's message: the message log, its latest line in sight."""
        self.log_dock.show()
        self.log.verticalScrollBar().setValue(self.log.verticalScrollBar().maximum())

    def _focus_view(self) -> None:
        self.view.setFocus(QtCore.Qt.FocusReason.OtherFocusReason)

    def _toggle_stretch(self) -> None:
        self.scene.set_stretch_visible(self.actions_["stretch"].isChecked())
        self.measure(everything=True)
        self.view.request_render()

    def reset_camera(self) -> None:
        self.scene.reset_camera()
        self.view.request_render()

    def set_view(self, view: str) -> None:
        """Look at the shape from one side (front, back, right, left, top, bottom), its up axis up."""
        if self.session is None:
            return
        self.scene.set_view(view)
        self.view.request_render()
        self.message(f"{view.capitalize()} view ({self.session.up_axis} up; View ▸ Up Axis changes it)")

    @guarded
    def set_up_axis(self, axis: str) -> None:
        """The shape's up axis: the views follow it, and it is remembered for this shape (the next time it
        opens this way up)."""
        s = self.session
        if s is None:
            self._update_actions()
            return
        s.up_axis = self.scene.up_axis = axis
        if s.shape_key is None:
            s.shape_key = shape_key(s.mesh)
        kept = remember_up_axis(s.shape_key, axis)
        self.scene.reset_camera()
        self.view.request_render()
        self._update_actions()
        self.message(f"{axis} is up for {self.files.document_name or 'this shape'}"
                     + (" (remembered: it opens this way next time)" if kept else
                        " (not remembered: the cache folder cannot be written)"))
    # ================================================================== loading (the build jobs of .building)
    @property
    def worker(self) -> BuildWorker | None:
        """The cage and binding build running now, or None."""
        return self.jobs.worker

    @guarded
    def open_path(self, path: str | os.PathLike) -> bool:
        """Read a mesh and build its cage and binding in the worker thread (asks first if the pose is unsaved)."""
        return self.jobs.open_file(path)

    def open_mesh(self, mesh: Mesh, path: Path | None = None) -> bool:
        """Build an already loaded shape (used by tests and scripts)."""
        return self.jobs.open_mesh(mesh, path)

    @guarded
    def rebuild(self) -> bool:
        """Build the cage and binding again at the toolbar's size; selection, pose and undo history carry over."""
        return self.jobs.rebuild()

    def cancel_job(self) -> None:
        """Cancel the cage and binding build under way; the shape on display stays."""
        self.jobs.cancel()

    def preview_shape(self, mesh: Mesh, look, up: tuple[str, bool, str]) -> None:
        """A new shape is read: show it at once, plain, its up axis up, while its cage and binding are built.
        The camera works on it; editing waits for the build. The shape on display before is put aside,
        and comes back if the build is cancelled or fails."""
        if self._aside is None:
            self._aside = (self.session,)
        self._previewed = mesh
        self.controller.cancel()
        self.session = None
        self.scene.up_axis = up[0]
        self.scene.show_preview(mesh.vertices, mesh.faces)
        self.size_label.setText(f"shape {_fmt(mesh.n_vertices)} v / {_fmt(mesh.n_faces)} f · cage …")
        self.sel_label.setText("")
        self.error_label.setText("")
        self._update_actions()
        self.view.request_render()
        self.message("The shape is read: turn it and look while its cage and binding are built; editing starts "
                     "when they are done.")

    def end_preview(self) -> None:
        """The build shown by :meth:`preview_shape` did not finish: the shape on display before is back."""
        if self._aside is None:
            return
        (s,), self._aside = self._aside, None
        self._previewed = None
        self.session = s
        if s is not None:
            self._show_engine()
        else:
            self.scene.clear()
            self._update_labels()
            self.view.request_render()
        self._update_actions()

    def install_build(self, result: BuildResult) -> tuple[bool, str | None]:
        """Show a finished build: a new session for a new shape, or the edit carried over to the new cage.

        Returns
        -------
        rebuilt : the build was a new cage for the shape being edited.
        note : what carrying the edit over said (rebuilds), or why Mirror is off for a new shape, or None.
        """
        req = result.request
        ed = result.editor
        self.controller.cancel()
        self.settle_and_stop_polish()
        # a settle the session completed by itself leaves the timer running: its tick would show (and polish)
        # the pose after the build is on display
        self.settle_timer.stop()
        note = None
        self._aside = None  # (a shape put aside for this one's preview: replaced)
        if req.rebuild and self.session is not None and self.session.mesh is result.mesh:
            note = self.session.adopt(ed, req.cage_size)
            rebuilt = True
        else:
            session, note = self._new_session(ed, req)
            session.look = result.look  # what the file says the shape looks like (None: plain)
            if result.up is not None:  # which way is up: remembered for this shape, or guessed
                session.up_axis, _, session.shape_key = result.up
            if result.look is not None and result.look.notes:
                note = "; ".join(([note] if note else []) + result.look.notes)
            self.session = session
            self.polisher.forget_shape()
            self.files.forget_paths()
            self.set_modified(False)
            rebuilt = False
        self.session.settle_on_release = self.settle_on_release
        self.last_polish = None
        previewed, self._previewed = self._previewed, None
        self._show_engine()
        if not rebuilt and result.mesh is not previewed:  # (a shape shown while built keeps the user's camera)
            self.scene.reset_camera()
        self.update_title()
        self._update_actions()
        return rebuilt, note

    def _new_session(self, ed, req) -> tuple[Session, str | None]:
        """A session for a newly opened shape, mirrored as the Mode menu says when the shape allows it;
        and a sentence when it does not."""
        axis = next((a for a in "xyz" if self.actions_[f"mirror_{a}"].isChecked()), None)
        if axis is not None:
            try:
                return Session(ed, path=req.path, cage_size=req.cage_size, symmetry=axis), None
            except SelectionError as e:
                self.actions_[f"mirror_{axis}"].setChecked(False)
                return Session(ed, path=req.path, cage_size=req.cage_size), f"Mirror {axis.upper()} is off: {e}"
        return Session(ed, path=req.path, cage_size=req.cage_size), None

    def _show_engine(self) -> None:
        """(Re)build the scene for the session's engine (a new shape, a rebuild, or undo across one)."""
        s = self.session
        self._generation = s.generation
        self.set_cage_size(s.cage_size, of_shape=True)
        self.scene.up_axis = s.up_axis
        self.scene.load(s.metrics, s.shown_positions, s.cage_positions, s.editor.cage.faces, s.cage_roles(),
                        s.shape_roles(), look=s.look, mode=s.look_mode)
        s.look_mode = self.scene.look_mode
        self.scene.gizmo.place(s.handle_centroid())
        self._rrms_full = True
        self.measure()
        self._update_labels()
        self.view.request_render()

    # ================================================================== Handler (called by the view controller)
    # cage_points and handle_center complete the settle only, not the guard: they read the pose and change
    # nothing (cage_points also runs on every mouse move in Select mode, to draw the points near the cursor,
    # which must not stop a polish); a gesture cancels the polish when it begins (begin_select, begin_drag)
    def cage_points(self) -> np.ndarray | None:
        self.finish_settle()
        return None if self.session is None else self.session.cage_positions

    def cage_edges(self) -> np.ndarray | None:
        """(e, 2) the cage's edges (a selection takes the part it is drawn over through its thickness)."""
        return None if self.session is None else self.session.editor.cage_edges

    def handle_center(self) -> np.ndarray | None:
        self.finish_settle()
        return None if self.session is None else self.session.handle_centroid()

    def begin_select(self) -> bool:
        self.settle_and_stop_polish()
        if self.session is None:
            return False
        self._stroke_target = self.target
        self.session.begin_stroke(self.target)
        return True

    def select_hits(self, hits: np.ndarray, op: str) -> None:
        if self.session is None:
            return
        self.session.stroke(hits, op)
        self._refresh_selection()

    def end_select(self) -> None:
        """A selection gesture ended: one undo step; a gesture that emptied its target says how to get it back."""
        s = self.session
        if s is None:
            return
        if s.end_stroke():
            target = getattr(self, "_stroke_target", self.target)
            if not s.mask(target).any():
                self.message(f"{self._target_name(target)} cleared (Ctrl+Z restores it)")
            elif not self._warn_if_tearing():
                self.clear_message()
        self._refresh_selection()
        self._update_actions()

    def _warn_if_tearing(self) -> bool:
        """Say so (and return True) when a handle group touches held cage points with nothing free between
        them: a drag would tear the shape there (:meth:`Session.tearing`)."""
        s = self.session
        tears = s.tearing() if s is not None and s.all_handles.any() and s.roi.any() else {}
        if not tears:
            return False
        g, n = max(tears.items(), key=lambda kv: kv[1])
        who = f"Handle group {g + 1}" if s.n_groups > 1 else "The handle"
        self.message(f"{who} touches the held part at {n} cage point{'s' if n != 1 else ''} with nothing free "
                     "between them: a drag tears the shape there (the back of a limb left out of the ROI?). Take "
                     "the ROI around the handle (R, Shift+drag), or select through (Alt+Z).")
        return True

    def begin_drag(self) -> bool:
        return self.dragging.begin()

    def drag(self, D: np.ndarray) -> None:
        self.dragging.move(D)

    def end_drag(self) -> None:
        self.dragging.end()

    @property
    def frames(self) -> FrameThread:
        """The drag frames' thread."""
        return self.dragging.frames

    @property
    def settle_timer(self) -> QtCore.QTimer:
        """The timer that settles the pose in slices after a drag."""
        return self.dragging.settle_timer

    def finish_settle(self) -> None:
        """Complete a drag frame or a settle under way now (before anything reads or changes the pose)."""
        self.dragging.finish()

    def settle_and_stop_polish(self) -> None:
        """The guard before anything that changes the pose or the selection (undo, a gesture, an edit file, ...).

        Completes a drag frame or a settle under way (:meth:`finish_settle`; a settle completed here shows
        its pose and may start a polish), then cancels any polish running or queued: its result would be
        of a pose or a selection that is gone. The places that do only one of the two say why.
        """
        self.finish_settle()
        self.polisher.cancel()

    def after_drag(self) -> None:
        """A drag ended and settled: show the final pose, and polish it when that is on."""
        self._refresh_pose()
        self._update_actions()
        if self.session is not None and self.polisher.start(self.session):
            self.time_label.setText("polishing…")

    # ================================================================== polish on release (worker thread)
    @property
    def polished(self) -> np.ndarray | None:
        """The polished pose on display, or None."""
        return None if self.session is None else self.session.polished

    def drop_polished(self) -> None:
        """A drag starts: the pose on display (polished or not, the engine's own) is no longer called polished."""
        s = self.session
        if s is not None:
            s.polished = None

    def _polish_succeeded(self, out: PolishOutcome) -> None:
        s = self.session
        if s is None:
            return
        self.last_polish = out
        s.adopt_polish(out.request.job, out.result)  # the engine's pose from now on: the next edit starts from it
        self.scene.update_shape(s.shown_positions, everything=True)
        self._pose_shown_changed()
        self.view.request_render()
        r = out.result
        self._update_actions()
        self.message(f"polished: {r.iterations} iterations, edge error {out.error_before:.2f}% → "
                     f"{out.error_after:.2f}% ({out.seconds:.2f} s); Ctrl+Z undoes the polish")

    # ================================================================== edge error and stretch map
    def _pose_shown_changed(self) -> None:
        """The shape on display changed outside a drag: edge error and stretch map are measured again."""
        self._rrms_full = True
        self.measure()

    def measure(self, everything: bool | None = None) -> None:
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
        self._show_error_value(s.metrics.update_error(s.shown_positions, everything=full))
        if self.scene.stretch_visible:
            s.metrics.write_stretch(self.scene.stretch32, everything=full)
            self.scene.stretch_modified()
            self.view.request_render()

    def _show_error_value(self, err: float) -> None:
        self.dragging.error = None
        polished = self.session is not None and self.session.polished is not None
        self.error_label.setText(f"edge error {err:.2f} %{' (polished)' if polished else ''}")

    # ================================================================== refresh
    def _refresh_pose(self) -> None:
        self.frames.flush()
        s = self.session
        if s is None:
            return
        self.scene.update_shape(s.shown_positions, everything=True)
        self.scene.update_cage(s.cage_positions)
        self.scene.gizmo.place(s.handle_centroid())
        self._pose_shown_changed()
        self.view.request_render()

    def _refresh_selection(self) -> None:
        self.frames.flush()
        s = self.session
        if s is None:
            return
        self.scene.update_roles(s.cage_roles(), s.shape_roles())
        self.scene.gizmo.place(s.handle_centroid())
        self._update_labels()
        self.view.request_render()

    def refresh_all(self) -> None:
        """Show the session's whole state again (after undo, redo, loading an edit, ...)."""
        self.frames.flush()
        s = self.session
        if s is not None and s.generation != self._generation:
            self._show_engine()  # undo or redo went across a rebuild: the other cage
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
        h = s.all_handles
        n_roi = int(np.count_nonzero(s.roi & ~h))
        n_h = int(np.count_nonzero(s.handle))
        n_f = int(np.count_nonzero(~s.roi & ~h))
        group = f" (group {s.active + 1} of {s.n_groups})" if s.n_groups > 1 else ""
        self.sel_label.setText(f"ROI {n_roi} · handle {n_h}{group} · fixed {n_f}")

    def _on_rendered(self, seconds: float) -> None:
        a = self.actions_["antialias"]
        if self.view.antialiasing is not None and a.isChecked() != self.view.antialiasing:
            a.setChecked(self.view.antialiasing)

    def _tick(self) -> None:
        if self.dragging.error is not None:
            self._show_error_value(self.dragging.error)  # (which clears it)
        if self.session is None or self.session.settling:
            return
        if self.polisher.busy:
            self.time_label.setText("polishing…")
            return
        self.time_label.setText(self.timing_text())

    def timing_text(self) -> str:
        """Frames of a drag shown per second first (what the eye gets), then the engine's and the render's
        share; a brush stroke or a turn of the camera renders too, but that rate is not a drag's: "idle"."""
        dragging = time.perf_counter() - self.dragging.frame_shown_at <= 1.0
        fps = self.view.display_fps() if dragging else 0.0
        parts = [f"{fps:.0f} fps" if fps > 0 else "idle"]
        if self.dragging.engine_ms > 0:
            parts.append(f"engine {self.dragging.engine_ms:.1f} ms")
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
        busy = self.jobs.busy
        for n in ("open", "rebuild", "load_edit"):
            a[n].setEnabled(not busy)
        for n in ("save", "save_as", "save_edit", "reset_pose", "select_all", "clear_sel", "clear_target", "invert_sel",
                  "screenshot", "mesh_info"):
            a[n].setEnabled(s is not None)
        a["cancel_job"].setEnabled(busy)
        modes = self.scene.look_modes() if s is not None else ("plain",)
        for mode in ("texture", "colors", "plain"):  # what the shape's file has, and how it is drawn
            a[f"look_{mode}"].setEnabled(s is not None and mode in modes)
            a[f"look_{mode}"].setChecked(s is not None and self.scene.look_mode == mode)
        for axis in "xyz":  # the session's mirror, also after undo and redo (none on show: the choice stays)
            if s is not None:
                a[f"mirror_{axis}"].setChecked(s.symmetry == axis)
        for axis in AXES:
            a[f"up_{axis}"].setEnabled(s is not None)
            a[f"up_{axis}"].setChecked(s is not None and s.up_axis == axis)
        for view in VIEWS:
            a[f"view_{view}"].setEnabled(s is not None)

    # ================================================================== edit actions
    @guarded
    def undo(self) -> None:
        if self.session is None or self.controller.busy:
            return
        self.settle_and_stop_polish()
        label = self.session.history.undo_label()
        if self.session.undo():
            self.set_modified(not self.pose_saved())
            self.refresh_all()
            self.message(f"Undid: {label}")

    @guarded
    def redo(self) -> None:
        if self.session is None or self.controller.busy:
            return
        self.settle_and_stop_polish()
        label = self.session.history.redo_label()
        if self.session.redo():
            self.set_modified(not self.pose_saved())
            self.refresh_all()
            self.message(f"Redid: {label}")

    @guarded
    def reset_pose(self) -> None:
        if self.session is None or self.controller.busy:
            return
        self.settle_and_stop_polish()
        self.session.reset_pose()
        self.set_modified(not self.pose_saved())
        self.refresh_all()
        self.message("Back to the rest pose")

    def _target_name(self, target: str) -> str:
        s = self.session
        if target == ROI:
            return "ROI"
        return f"Handle group {s.active + 1}" if s is not None and s.n_groups > 1 else "Handle"

    def _selection_op(self, op: str) -> None:
        """Select all / invert / clear the current target, or clear everything ("clear_all"): one undo step."""
        s = self.session
        if s is None or self.controller.busy:
            return
        self.settle_and_stop_polish()
        if op == "clear_all":
            changed = s.clear_all()
            said = "Selection cleared: the ROI and every handle group (Ctrl+Z restores them)"
        else:
            changed = {"all": s.select_all, "clear": s.clear, "invert": s.invert}[op](self.target)
            said = f"{self._target_name(self.target)} cleared (Ctrl+Z restores it)" if op == "clear" else ""
        if op == "clear_all" and changed:
            self._set_target(self.target)  # (back to one handle group: its colour)
        if changed and said:
            self.message(said)
        elif op in ("clear", "clear_all") and not changed:
            self.message("Nothing to clear")
        elif not self._warn_if_tearing():
            self.clear_message()
        self._refresh_selection()
        self._update_actions()

    def _toggle_select_through(self) -> None:
        on = self.actions_["select_through"].isChecked()
        self.controller.set_select_through(on)
        self.message("Select Through: rectangle, brush and click also take the cage points hidden behind the shape"
                     if on else "Select Through off: the part drawn over is taken through its thickness, not what "
                                "another part hides")

    # ================================================================== drag and drop
    def dragEnterEvent(self, ev: QtGui.QDragEnterEvent) -> None:  # noqa: N802
        if dropped_path(ev.mimeData()) is not None:
            ev.acceptProposedAction()
        else:
            ev.ignore()

    def dragMoveEvent(self, ev: QtGui.QDragMoveEvent) -> None:  # noqa: N802
        if dropped_path(ev.mimeData()) is not None:
            ev.acceptProposedAction()

    @guarded
    def dropEvent(self, ev: QtGui.QDropEvent) -> None:  # noqa: N802
        p = dropped_path(ev.mimeData())
        if p is None:
            ev.ignore()
            return
        ev.acceptProposedAction()
        # let the drop finish before any question is asked
        if p.suffix.lower() == ".json":
            QtCore.QTimer.singleShot(0, lambda: self.files.load_edit_from(p))
        else:
            QtCore.QTimer.singleShot(0, lambda: self.open_path(p))

    # ================================================================== closing
    def closeEvent(self, ev: QtGui.QCloseEvent) -> None:  # noqa: N802
        if not self.files.keep_work("quitting"):
            ev.ignore()
            return
        self.dragging.stop()
        self.polisher.wait()
        self.jobs.wait()
        self.status_timer.stop()
        self.view.close()
        super().closeEvent(ev)
