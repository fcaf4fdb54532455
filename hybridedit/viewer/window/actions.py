"""The window's actions and where they show: the menus, the toolbar, and which actions are enabled.

Every command of the window is a ``QAction`` in ``actions_`` (by name), made here one menu at a
time; :data:`MENUS` lays out the menu bar; the toolbar holds the most used actions and the brush
and cage size boxes. What each action does is the window's (its other mixins and helpers).
"""

from __future__ import annotations

from typing import Callable

from qtpy import QtCore, QtGui, QtWidgets

from ...core.up_axis import AXES
from .cage_size_box import CageSizeControl
from ..input.mouse_gestures import BRUSH, CAMERA, DRAG, RECTANGLE, SELECT
from ..render.scene import VIEWS
from ..model.selection_masks import HANDLE, ROI

MENUS: dict[str, list] = {
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
"""The menu bar: each menu's actions by name, None a separator, (title, names) a submenu."""

EXCLUSIVE = (("mode_camera", "mode_select", "mode_drag"), ("target_roi", "target_handle"),
             ("tool_rect", "tool_brush"))
"""The checkable actions of which one is on at a time."""

VIEWPOINTS = (("front", "&Front", 1, False), ("back", "&Back", 1, True), ("right", "&Right", 3, False),
              ("left", "&Left", 3, True), ("top", "&Top", 7, False), ("bottom", "B&ottom", 7, True))
"""View ▸ Viewpoint: (view, menu text, numpad digit, with Ctrl), as in Blender."""

LOOKS = (("texture", "&Texture", "Alt+1", "Show the file's textures and material colours"),
         ("colors", "&Colours", "Alt+2", "Show the file's vertex colours"),
         ("plain", "&Plain", "Alt+3", "Show the shape's form alone, in one colour"))
"""View ▸ Texture / Colours / Plain: (mode, menu text, shortcut, tip)."""


class ActionsMixin:
    """The actions, menus and toolbar of a :class:`~.main_window.MainWindow` (a mixin).

    The actions call the window's commands; :meth:`_update_actions` enables and checks them from
    the ``session``, the build ``jobs`` and the ``scene``.
    """

    def _action(self, name: str, text: str, slot: Callable | None = None,
                shortcut: str | QtGui.QKeySequence | None = None, checkable: bool = False, tip: str = "",
                short: str = "") -> QtGui.QAction:
        """Make the action ``actions_[name]`` (``short``: its toolbar text) and add it to the window."""
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
        """Every action, menu by menu (the Shortcuts dialog lists them in this order)."""
        self._file_actions()
        self._edit_actions()
        self._select_actions()
        self._mode_actions()
        self._view_actions()
        self._cage_and_help_actions()
        for names in EXCLUSIVE:
            g = QtGui.QActionGroup(self)
            g.setExclusive(True)
            for n in names:
                g.addAction(self.actions_[n])
        self.actions_["mode_camera"].setChecked(True)
        self.actions_["target_roi"].setChecked(True)
        self.actions_["tool_rect"].setChecked(True)

    def _file_actions(self) -> None:
        A, Seq = self._action, QtGui.QKeySequence
        A("open", "&Open…", self.files.open_dialog, Seq.StandardKey.Open, tip="Open a mesh (OBJ, PLY, STL, OFF)")
        A("save", "&Save", self.files.save, Seq.StandardKey.Save, tip="Save the deformed mesh")
        A("save_as", "Save &As…", self.files.save_as_dialog, "Ctrl+Shift+S", tip="Save the deformed mesh to a new file")
        A("load_edit", "&Load Edit…", self.files.load_edit_dialog, "Ctrl+L", tip="Load a JSON edit file and apply it")
        A("save_edit", "Save &Edit…", self.files.save_edit_dialog, "Ctrl+E",
          tip="Save the selection and the handle transform as a JSON edit file (for hybridedit deform)")
        A("screenshot", "Save Screens&hot…", self.files.screenshot_dialog, tip="Save the 3D view as a PNG image")
        A("mesh_info", "Mesh &Info…", self.dialogs.mesh_info,
          tip="Vertex, face and cage counts; repairs made to the input")
        A("quit", "&Quit", self.close, Seq.StandardKey.Quit, tip="Quit")

    def _edit_actions(self) -> None:
        A = self._action
        A("undo", "&Undo", self.undo, "Ctrl+Z", tip="Undo the last selection or drag", short="Undo")
        A("redo", "&Redo", self.redo, "Ctrl+Shift+Z", tip="Redo", short="Redo")
        A("reset_pose", "Reset &Pose", self.reset_pose, "Ctrl+R", tip="Back to the rest pose (keeps the selection)",
          short="Reset")
        settle = A("settle", "Settle on Release", self._toggle_settle, checkable=True,
                   tip="On release, solve the final transform from the selection's start pose with the batch "
                       "settings, so the window shows what 'hybridedit deform' computes")
        settle.setChecked(True)
        pol = A("polish", "Polish on Release", self._toggle_polish, checkable=True,
                tip="After a drag, run full-resolution ARAP on the edited region in the background until it "
                    "converges and show the result; the next edit starts from it, and a saved edit replays it")
        pol.setChecked(True)

    def _select_actions(self) -> None:
        A = self._action
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

    def _mode_actions(self) -> None:
        A = self._action
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

    def _view_actions(self) -> None:
        A = self._action
        A("show_cage", "Show Cage &Wireframe", self._toggle_cage, "W", checkable=True,
          tip="Show the cage wireframe (the ROI and handle cage points are always shown)", short="Cage")
        A("stretch", "S&tretch Map", self._toggle_stretch, "T", checkable=True,
          tip="Colour the shape by the relative edge-length change against the rest shape (0 to 20 %)",
          short="Stretch")
        A("messages", "&Messages", lambda: self.status.toggle_log(), checkable=True,
          tip="Show every message of this session, with its time")
        A("reset_camera", "&Frame Shape", self.reset_camera, "F", tip="Reset the camera to show the whole shape")
        self._viewpoint_actions()
        up_group = QtGui.QActionGroup(self)
        for axis in AXES:
            a = A(f"up_{axis}", f"{axis} Up", lambda ax=axis: self.set_up_axis(ax), checkable=True,
                  tip=f"The shape's up axis is {axis}: the views follow it; remembered for this shape")
            up_group.addAction(a)
        group = QtGui.QActionGroup(self)
        for mode, text, key, tip in LOOKS:
            a = A(f"look_{mode}", text, lambda m=mode: self._set_look_mode(m), key, checkable=True, tip=tip)
            group.addAction(a)
        A("antialias", "&Anti-aliasing", self._toggle_antialias, checkable=True,
          tip="Multisample anti-aliasing (off by default with software OpenGL, where it is slow)")

    def _viewpoint_actions(self) -> None:
        """View ▸ Viewpoint: a numpad digit (with Ctrl the opposite side), the digit row too."""
        Kp = QtCore.Qt.KeyboardModifier.KeypadModifier
        for view, text, digit, ctrl in VIEWPOINTS:
            key = QtCore.Qt.Key(int(QtCore.Qt.Key.Key_0) + digit)
            mods = QtCore.Qt.KeyboardModifier.ControlModifier if ctrl else QtCore.Qt.KeyboardModifier.NoModifier
            a = self._action(f"view_{view}", f"{text} View", lambda v=view: self.set_view(v), None,
                             tip=f"Look at the shape from its {view} (numpad {'Ctrl+' if ctrl else ''}{digit}, "
                                 "as in Blender; the digit row too)")
            a.setShortcuts([QtGui.QKeySequence(QtCore.QKeyCombination(mods | Kp, key)),
                            QtGui.QKeySequence(QtCore.QKeyCombination(mods, key))])
            a.setToolTip(f"{text.replace('&', '')} View ({a.shortcut().toString()})")

    def _cage_and_help_actions(self) -> None:
        A = self._action
        A("rebuild", "Re&build Cage", self.rebuild, "Ctrl+B", tip="Build the cage and binding again at the chosen size",
          short="Rebuild")
        A("cancel_job", "Cancel", self.cancel_job, "Esc", tip="Cancel the cage build")
        A("shortcuts", "&Shortcuts…", self.dialogs.shortcuts, QtGui.QKeySequence.StandardKey.HelpContents,
          tip="List the shortcuts")
        A("howto", "&How to Edit…", self.dialogs.howto, tip="The editing workflow in a few steps")
        A("about", "&About", self.dialogs.about)

    def _make_menus(self) -> None:
        """The menu bar, as :data:`MENUS` lays it out."""
        mb = self.menuBar()
        a = self.actions_
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

    def _update_actions(self) -> None:
        """Enable, check and name the actions as the session, the build and the scene are now."""
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
