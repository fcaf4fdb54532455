"""The window's actions and where they show: the menus, the toolbar, and which actions are enabled.

Every command of the window is a ``QAction`` of the :class:`ActionSet` (by name), made here one menu
at a time; :data:`MENUS` lays out the menu bar; the toolbar holds the most used actions and the
brush and cage size boxes. What each action does is the collaborator's that the action calls.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import TYPE_CHECKING, Callable, Protocol, runtime_checkable

from qtpy import QtCore, QtGui, QtWidgets

from ...core.up_axis import AXES
from ..input.mouse_gestures import BRUSH, CAMERA, DRAG, POSE, RECTANGLE, SELECT
from ..model.selection_masks import HANDLE, ROI
from ..render.scene import VIEWS
from .interfaces import Busy

if TYPE_CHECKING:
    from ..model.session import Session

MENUS: dict[str, list] = {
    "&File": ["open", "save", "save_as", None, "load_edit", "save_edit", None, "screenshot", None,
              "mesh_info", None, "quit"],
    "&Edit": ["undo", "redo", None, "reset_pose", None, "settle", "polish"],
    "&Select": ["select_all", "invert_sel", None, "clear_sel", "clear_target", None, "select_through", None,
                "free_around_handle"],
    "&Mode": ["mode_camera", "mode_select", "mode_drag", "mode_pose", None, "target_roi", "target_handle", None,
              "new_group", "next_group", None, "mirror_x", "mirror_y", "mirror_z", None,
              "tool_rect", "tool_brush", "brush_bigger", "brush_smaller"],
    "&View": ["look_texture", "look_colors", "look_plain", None, "show_cage", "show_points", "hide_points_dragging", "stretch",
              "reset_camera",
              ("&Viewpoint", ["view_front", "view_back", "view_right", "view_left", "view_top", "view_bottom"]),
              ("&Up Axis", [f"up_{axis}" for axis in AXES]), "antialias", None, "messages"],
    "&Pose": ["keep_pose", None, "show_poses", "export_poses"],
    "&Cage": ["rebuild", "cancel_job"],
    "&Help": ["howto", "shortcuts", "about"],
}
"""The menu bar: each menu's actions by name, None a separator, (title, names) a submenu."""

EXCLUSIVE = (("mode_camera", "mode_select", "mode_drag", "mode_pose"), ("target_roi", "target_handle"),
             ("tool_rect", "tool_brush"))
"""The checkable actions of which one is on at a time."""

VIEWPOINTS = (("front", "&Front", 1, False), ("back", "&Back", 1, True), ("right", "&Right", 3, False),
              ("left", "&Left", 3, True), ("top", "&Top", 7, False), ("bottom", "B&ottom", 7, True))
"""View ▸ Viewpoint: (view, menu text, numpad digit, with Ctrl), as in Blender."""

LOOKS = (("texture", "&Texture", "Alt+1", "Show the file's textures and material colours"),
         ("colors", "&Colours", "Alt+2", "Show the file's vertex colours"),
         ("plain", "&Plain", "Alt+3", "Show the shape's form alone, in one colour"))
"""View ▸ Texture / Colours / Plain: (mode, menu text, shortcut, tip)."""


@runtime_checkable
class FileCommands(Protocol):
    """The File menu's commands (:class:`~.file_actions.FileActions`)."""

    def open_dialog(self) -> None: ...
    def save(self) -> bool: ...
    def save_as_dialog(self) -> bool: ...
    def load_edit_dialog(self) -> bool: ...
    def save_edit_dialog(self) -> bool: ...
    def screenshot_dialog(self) -> bool: ...


@runtime_checkable
class DialogCommands(Protocol):
    """The information dialogs (:class:`~.dialogs.InfoDialogs`)."""

    def mesh_info(self) -> object: ...
    def shortcuts(self) -> object: ...
    def howto(self) -> None: ...
    def about(self) -> None: ...


@runtime_checkable
class UndoCommandsLike(Protocol):
    """Edit ▸ Undo, Redo, Reset Pose, and the note that the history is full (:class:`~.undo_commands.UndoCommands`)."""

    def undo(self) -> None: ...
    def redo(self) -> None: ...
    def reset_pose(self) -> None: ...
    def note_dropped(self) -> None: ...


@runtime_checkable
class PoseToggles(Protocol):
    """Edit ▸ Settle on Release and Polish on Release (:class:`~.posing.Posing`)."""

    def toggle_settle(self) -> None: ...
    def toggle_polish(self) -> None: ...


@runtime_checkable
class SelectCommands(Protocol):
    """The Select menu, the target, mirror and handle groups (:class:`~.selecting.Selecting`)."""

    def selection_op(self, op: str) -> None: ...
    def toggle_select_through(self) -> None: ...
    def free_around_handles(self) -> None: ...
    def set_target(self, target: str) -> None: ...
    def toggle_mirror(self, axis: str) -> None: ...
    def new_group(self) -> None: ...
    def next_group(self) -> None: ...


@runtime_checkable
class ViewCommands(Protocol):
    """The Mode and View menus' settings (:class:`~.view_options.ViewOptions`), and the brush box."""

    @property
    def brush_spin(self) -> QtWidgets.QSpinBox: ...
    def set_mode(self, mode: str) -> None: ...
    def set_tool(self, tool: str) -> None: ...
    def scale_brush(self, factor: float) -> None: ...
    def focus_view(self) -> None: ...
    def toggle_cage(self) -> None: ...
    def toggle_points(self) -> None: ...
    def toggle_points_dragging(self) -> None: ...
    def toggle_stretch(self) -> None: ...
    def reset_camera(self) -> None: ...
    def set_view(self, view: str) -> None: ...
    def set_up_axis(self, axis: str) -> None: ...
    def set_look_mode(self, mode: str) -> None: ...
    def toggle_antialias(self) -> None: ...


@runtime_checkable
class PoseCommands(Protocol):
    """The Pose menu (:class:`~.pose_panel.PosePanel`): keep, the panel, export; and the panel listing
    the session's kept poses again."""

    def keep(self) -> bool: ...
    def toggle_panel(self) -> None: ...
    def export_dialog(self) -> bool: ...
    def refresh(self) -> None: ...


@runtime_checkable
class LoadCommands(Protocol):
    """Cage ▸ Rebuild and Cancel (:class:`~.shape_loading.ShapeLoading`)."""

    def rebuild(self) -> bool: ...
    def cancel_job(self) -> None: ...


@runtime_checkable
class LogCommands(Protocol):
    """View ▸ Messages (:class:`~.status_bar.StatusBar`)."""

    def toggle_log(self) -> None: ...


@runtime_checkable
class Looks(Protocol):
    """The scene as the actions see it: the looks the shape has, and the one drawn."""

    @property
    def look_mode(self) -> str: ...
    def look_modes(self) -> tuple[str, ...]: ...


@runtime_checkable
class CageBox(Protocol):
    """The cage size box as the toolbar sees it: a widget whose boxes hand the keyboard back."""

    @property
    def spin(self) -> QtWidgets.QDoubleSpinBox: ...
    @property
    def unit(self) -> QtWidgets.QComboBox: ...


@runtime_checkable
class ActionsHost(Protocol):
    """What :class:`ActionSet` asks of the window (:class:`~.main_window.MainWindow`): the collaborators
    its actions call, and what decides which are enabled."""

    @property
    def session(self) -> Session | None: ...
    @property
    def files(self) -> FileCommands: ...
    @property
    def dialogs(self) -> DialogCommands: ...
    @property
    def undo_commands(self) -> UndoCommandsLike: ...
    @property
    def posing(self) -> PoseToggles: ...
    @property
    def selecting(self) -> SelectCommands: ...
    @property
    def options(self) -> ViewCommands: ...
    @property
    def loading(self) -> LoadCommands: ...
    @property
    def pose_panel(self) -> PoseCommands: ...
    @property
    def status(self) -> LogCommands: ...
    @property
    def jobs(self) -> Busy: ...
    @property
    def scene(self) -> Looks: ...
    @property
    def cage_control(self) -> CageBox: ...


class ActionSet(Mapping):
    """The actions of a :class:`~.main_window.MainWindow` by name (a read-only mapping), its menu bar
    and its toolbar.

    The actions call the window's collaborators (what :class:`ActionsHost` names); :meth:`refresh`
    enables and checks them as the session, the build and the scene are now.

    Parameters
    ----------
    window : the window, as far as the actions need it (:class:`ActionsHost`).
    parent : the main window the actions, the menu bar and the toolbar belong to.
    """

    def __init__(self, window: ActionsHost, parent: QtWidgets.QMainWindow) -> None:
        self.w = window
        self.parent = parent
        self._actions: dict[str, QtGui.QAction] = {}
        self._make_actions()
        self._make_menus()
        self._make_toolbar()

    def __getitem__(self, name: str) -> QtGui.QAction:
        return self._actions[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._actions)

    def __len__(self) -> int:
        return len(self._actions)

    def _action(self, name: str, text: str, slot: Callable | None = None,
                shortcut: str | QtGui.QKeySequence | None = None, checkable: bool = False, tip: str = "",
                short: str = "") -> QtGui.QAction:
        """Make the action ``actions_[name]`` (``short``: its toolbar text) and add it to the window."""
        a = QtGui.QAction(text, self.parent)
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
        self.parent.addAction(a)
        self._actions[name] = a
        return a

    def _make_actions(self) -> None:
        """Every action, menu by menu (the Shortcuts dialog lists them in this order)."""
        self._file_actions()
        self._edit_actions()
        self._select_actions()
        self._mode_actions()
        self._view_actions()
        self._pose_actions()
        self._cage_and_help_actions()
        for names in EXCLUSIVE:
            g = QtGui.QActionGroup(self.parent)
            g.setExclusive(True)
            for n in names:
                g.addAction(self._actions[n])
        self._actions["mode_camera"].setChecked(True)
        self._actions["target_roi"].setChecked(True)
        self._actions["tool_rect"].setChecked(True)

    def _file_actions(self) -> None:
        A, Seq, files = self._action, QtGui.QKeySequence, self.w.files
        A("open", "&Open…", files.open_dialog, Seq.StandardKey.Open, tip="Open a mesh (OBJ, PLY, STL, OFF)")
        A("save", "&Save", files.save, Seq.StandardKey.Save, tip="Save the deformed mesh")
        A("save_as", "Save &As…", files.save_as_dialog, "Ctrl+Shift+S", tip="Save the deformed mesh to a new file")
        A("load_edit", "&Load Edit…", files.load_edit_dialog, "Ctrl+L", tip="Load a JSON edit file and apply it")
        A("save_edit", "Save &Edit…", files.save_edit_dialog, "Ctrl+E",
          tip="Save the selection and the handle transform as a JSON edit file (for hybridedit deform)")
        A("screenshot", "Save Screens&hot…", files.screenshot_dialog, tip="Save the 3D view as a PNG image")
        A("mesh_info", "Mesh &Info…", self.w.dialogs.mesh_info,
          tip="Vertex, face and cage counts; repairs made to the input")
        A("quit", "&Quit", self.parent.close, Seq.StandardKey.Quit, tip="Quit")

    def _edit_actions(self) -> None:
        A, edits, posing = self._action, self.w.undo_commands, self.w.posing
        A("undo", "&Undo", edits.undo, "Ctrl+Z", tip="Undo the last selection or drag", short="Undo")
        A("redo", "&Redo", edits.redo, "Ctrl+Shift+Z", tip="Redo", short="Redo")
        A("reset_pose", "Reset &Pose", edits.reset_pose, "Ctrl+R", tip="Back to the rest pose (keeps the selection)",
          short="Reset")
        settle = A("settle", "Settle on Release", posing.toggle_settle, checkable=True,
                   tip="On release, solve the final transform from the selection's start pose with the batch "
                       "settings, so the window shows what 'hybridedit deform' computes")
        settle.setChecked(True)
        pol = A("polish", "Polish on Release", posing.toggle_polish, checkable=True,
                tip="After a drag, run full-resolution ARAP on the edited region in the background until it "
                    "converges and show the result; the next edit starts from it, and a saved edit replays it")
        pol.setChecked(True)

    def _select_actions(self) -> None:
        A, sel = self._action, self.w.selecting
        A("select_all", "Select &All", lambda: sel.selection_op("all"), "Ctrl+A",
          tip="Select every cage vertex (current target)")
        A("clear_sel", "&Clear All", lambda: sel.selection_op("clear_all"), "Ctrl+Shift+A",
          tip="Empty the ROI and every handle group (one undo step)")
        A("clear_target", "Clear &Target", lambda: sel.selection_op("clear"), "Alt+A",
          tip="Empty the current target only: the ROI, or the active handle group")
        A("select_through", "Select &Through", sel.toggle_select_through, "Alt+Z", checkable=True,
          tip="Rectangle, brush and click also take the cage points hidden behind another part "
              "(Blender's X-ray); off, the part drawn over, through its thickness", short="Through")
        A("invert_sel", "&Invert Selection", lambda: sel.selection_op("invert"), "Ctrl+I",
          tip="Invert the current target (ROI or handle)")
        A("free_around_handle", "&Free Around Handle", sel.free_around_handles, "Shift+F",
          tip="Free the held cage points where a handle touches them (they join the ROI), so that a drag "
              "bends the shape there instead of tearing it", short="Free")

    def _mode_actions(self) -> None:
        A, sel, opt = self._action, self.w.selecting, self.w.options
        A("mode_camera", "&Camera Mode", lambda: opt.set_mode(CAMERA), "C", checkable=True,
          tip="Left drag rotates the view", short="Camera")
        A("mode_select", "&Select Mode", lambda: opt.set_mode(SELECT), "S", checkable=True,
          tip="Left drag selects cage vertices (Shift adds, Ctrl removes)", short="Select")
        A("mode_drag", "&Drag Mode", lambda: opt.set_mode(DRAG), "D", checkable=True,
          tip="Left drag moves the handle parallel to the view", short="Drag")
        A("mode_pose", "&Pose Mode", lambda: opt.set_mode(POSE), "P", checkable=True,
          tip="Hover a limb to see its joint; left drag turns it about the joint (Shift: moves it); "
              "[ ] or the wheel move the joint", short="Pose")
        A("target_roi", "Target &ROI", lambda: sel.set_target(ROI), "R", checkable=True,
          tip="Selections change the region of interest (green)", short="ROI")
        A("target_handle", "Target &Handle", lambda: sel.set_target(HANDLE), "H", checkable=True,
          tip="Selections change the handle (orange)", short="Handle")
        for axis in "xyz":
            A(f"mirror_{axis}", f"&Mirror {axis.upper()}", lambda a=axis: sel.toggle_mirror(a),
              "Shift+" + axis.upper() if axis == "x" else None, checkable=True,
              tip=f"Mirror the selection across the shape's middle plane normal to {axis.upper()}: the mirrored "
                  "handle follows the mirrored drag (as Blender's X-mirror)", short=f"Mirror {axis.upper()}")
        A("new_group", "&New Handle Group", sel.new_group, "Ctrl+G",
          tip="Start another handle group (its own colour and transform); select its cage points next",
          short="New group")
        A("next_group", "Ne&xt Handle Group", sel.next_group, "G",
          tip="Make the next handle group the one that selections and drags act on", short="Next group")
        A("tool_rect", "Rec&tangle", lambda: opt.set_tool(RECTANGLE), "X", checkable=True,
          tip="Rubber-band rectangle selection", short="Rect")
        A("tool_brush", "&Brush", lambda: opt.set_tool(BRUSH), "B", checkable=True, tip="Brush selection")
        A("brush_bigger", "Bigger Brush", lambda: opt.scale_brush(1.25), "]",
          tip="Enlarge the brush (Pose mode: the joint toward the body)")
        A("brush_smaller", "Smaller Brush", lambda: opt.scale_brush(0.8), "[",
          tip="Shrink the brush (Pose mode: the joint toward the tip)")

    def _view_actions(self) -> None:
        A, opt = self._action, self.w.options
        A("show_cage", "Show Cage &Wireframe", opt.toggle_cage, "W", checkable=True,
          tip="Show the cage wireframe (the ROI and handle cage points: Show Cage Points)", short="Cage")
        A("show_points", "Show Cage &Points", opt.toggle_points, "V", checkable=True,
          tip="Show the ROI and handle cage points (a dense ROI thinned out on screen); off, the shape alone")
        A("hide_points_dragging", "&Hide Points While Dragging", opt.toggle_points_dragging, checkable=True,
          tip="While a drag is under way no cage point is drawn: the pose in full view")
        self._actions["show_points"].setChecked(True)
        self._actions["hide_points_dragging"].setChecked(True)
        A("stretch", "S&tretch Map", opt.toggle_stretch, "T", checkable=True,
          tip="Colour the shape by the relative edge-length change against the rest shape (0 to 20 %)",
          short="Stretch")
        # (the status bar is made after the toolbar, for the keyboard focus order: looked up when triggered)
        A("messages", "&Messages", lambda: self.w.status.toggle_log(), checkable=True,
          tip="Show every message of this session, with its time")
        A("reset_camera", "&Frame Shape", opt.reset_camera, "F", tip="Reset the camera to show the whole shape")
        self._viewpoint_actions()
        up_group = QtGui.QActionGroup(self.parent)
        for axis in AXES:
            a = A(f"up_{axis}", f"{axis} Up", lambda ax=axis: opt.set_up_axis(ax), checkable=True,
                  tip=f"The shape's up axis is {axis}: the views follow it; remembered for this shape")
            up_group.addAction(a)
        group = QtGui.QActionGroup(self.parent)
        for mode, text, key, tip in LOOKS:
            a = A(f"look_{mode}", text, lambda m=mode: opt.set_look_mode(m), key, checkable=True, tip=tip)
            group.addAction(a)
        A("antialias", "&Anti-aliasing", opt.toggle_antialias, checkable=True,
          tip="Multisample anti-aliasing (off by default with software OpenGL, where it is slow)")

    def _viewpoint_actions(self) -> None:
        """View ▸ Viewpoint: a numpad digit (with Ctrl the opposite side), the digit row too."""
        Kp = QtCore.Qt.KeyboardModifier.KeypadModifier
        for view, text, digit, ctrl in VIEWPOINTS:
            key = QtCore.Qt.Key(int(QtCore.Qt.Key.Key_0) + digit)
            mods = QtCore.Qt.KeyboardModifier.ControlModifier if ctrl else QtCore.Qt.KeyboardModifier.NoModifier
            a = self._action(f"view_{view}", f"{text} View", lambda v=view: self.w.options.set_view(v), None,
                             tip=f"Look at the shape from its {view} (numpad {'Ctrl+' if ctrl else ''}{digit}, "
                                 "as in Blender; the digit row too)")
            a.setShortcuts([QtGui.QKeySequence(QtCore.QKeyCombination(mods | Kp, key)),
                            QtGui.QKeySequence(QtCore.QKeyCombination(mods, key))])
            a.setToolTip(f"{text.replace('&', '')} View ({a.shortcut().toString()})")

    def _pose_actions(self) -> None:
        A, panel = self._action, self.w.pose_panel
        A("keep_pose", "&Keep Pose", panel.keep, "K",
          tip="Keep the pose on display in the pose library (the Poses panel), to go on from it later or "
              "export it: as Blender's shape keys", short="Keep")
        A("show_poses", "&Poses Panel", panel.toggle_panel, checkable=True,
          tip="Show the kept poses: double-click one to go on from it; rename, delete, reorder, export")
        A("export_poses", "&Export Poses…", panel.export_dialog,
          tip="Write the kept poses to one file: glTF morph targets (.glb) or USD blend shapes (.usda, .usdc)")

    def _cage_and_help_actions(self) -> None:
        A, dialogs = self._action, self.w.dialogs
        A("rebuild", "Re&build Cage", self.w.loading.rebuild, "Ctrl+B",
          tip="Build the cage and binding again at the chosen size", short="Rebuild")
        A("cancel_job", "Cancel", self.w.loading.cancel_job, "Esc", tip="Cancel the cage build")
        A("shortcuts", "&Shortcuts…", dialogs.shortcuts, QtGui.QKeySequence.StandardKey.HelpContents,
          tip="List the shortcuts")
        A("howto", "&How to Edit…", dialogs.howto, tip="The editing workflow in a few steps")
        A("about", "&About", dialogs.about)

    def _make_menus(self) -> None:
        """The menu bar, as :data:`MENUS` lays it out."""
        mb = self.parent.menuBar()
        a = self._actions
        for title, names in MENUS.items():
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
        """The toolbar: mode, target, groups and mirror, selection tools and the brush radius, the cage size,
        undo."""
        tb = self.parent.addToolBar("Tools")
        tb.setObjectName("tools")
        tb.setMovable(False)
        a, opt = self._actions, self.w.options
        tb.addWidget(QtWidgets.QLabel(" Mode "))
        for n in ("mode_camera", "mode_select", "mode_drag", "mode_pose"):
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
        tb.addWidget(opt.brush_spin)
        tb.addAction(a["select_through"])
        tb.addSeparator()
        tb.addWidget(QtWidgets.QLabel(" Cage "))
        cage = self.w.cage_control
        tb.addWidget(cage)
        # the boxes hand the keyboard back to the view when done, so the single-key shortcuts work again
        cage.spin.editingFinished.connect(opt.focus_view)
        cage.unit.activated.connect(lambda *_: opt.focus_view())
        opt.brush_spin.editingFinished.connect(opt.focus_view)
        tb.addAction(a["rebuild"])
        tb.addAction(a["show_cage"])
        tb.addSeparator()
        for n in ("undo", "redo", "reset_pose"):
            tb.addAction(a[n])

    def refresh(self) -> None:
        """Enable, check and name the actions as the session, the build and the scene are now."""
        a = self._actions
        s = self.w.session
        h = s.history if s else None
        a["undo"].setEnabled(bool(h and h.can_undo()))
        a["redo"].setEnabled(bool(h and h.can_redo()))
        a["undo"].setText(f"&Undo {h.undo_label()}" if h and h.can_undo() else "&Undo")
        a["redo"].setText(f"&Redo {h.redo_label()}" if h and h.can_redo() else "&Redo")
        self.w.undo_commands.note_dropped()  # (once a session: its history is full, the oldest steps go)
        busy = self.w.jobs.busy
        for n in ("open", "rebuild", "load_edit"):
            a[n].setEnabled(not busy)
        for n in ("save", "save_as", "save_edit", "reset_pose", "select_all", "clear_sel", "clear_target", "invert_sel",
                  "free_around_handle", "screenshot", "mesh_info"):
            a[n].setEnabled(s is not None)
        a["cancel_job"].setEnabled(busy)
        a["keep_pose"].setEnabled(s is not None)
        a["export_poses"].setEnabled(s is not None and len(s.poses) > 0)
        self.w.pose_panel.refresh()  # (another shape, an edit file or a recovery: its kept poses listed)
        scene = self.w.scene
        modes = scene.look_modes() if s is not None else ("plain",)
        for mode in ("texture", "colors", "plain"):  # what the shape's file has, and how it is drawn
            a[f"look_{mode}"].setEnabled(s is not None and mode in modes)
            a[f"look_{mode}"].setChecked(s is not None and scene.look_mode == mode)
        for axis in "xyz":  # the session's mirror, also after undo and redo (none on show: the choice stays)
            if s is not None:
                a[f"mirror_{axis}"].setChecked(s.selection.symmetry == axis)
        for axis in AXES:
            a[f"up_{axis}"].setEnabled(s is not None)
            a[f"up_{axis}"].setChecked(s is not None and s.up_axis == axis)
        for view in VIEWS:
            a[f"view_{view}"].setEnabled(s is not None)
