"""How the window shows the shape and how the mouse acts on it: the mode, the selection tool and the
brush, the cage wireframe, the stretch map, the look (texture, colours, plain), anti-aliasing, the
camera's views and the shape's up axis.
"""

from __future__ import annotations

from qtpy import QtCore

from ...core.up_axis import remember_up_axis, shape_key
from ..input.mouse_gestures import CAMERA, DRAG, RECTANGLE, SELECT
from .slot_errors import guarded


class ViewSettingsMixin:
    """The Mode and View menus' settings of a :class:`~.main_window.MainWindow` (a mixin): they set the
    view ``controller``, the ``scene`` and the ``view``, and keep the actions checked to match."""

    # ------------------------------------------------------------------ the mouse
    def set_mode(self, mode: str) -> None:
        """What a left drag does: ``CAMERA``, ``SELECT`` or ``DRAG`` (:mod:`..input.mouse_gestures`)."""
        self.controller.set_mode(mode)
        self.actions_[f"mode_{mode}"].setChecked(True)
        self.status.message({CAMERA: "Camera mode: left drag rotates the view",
                      SELECT: "Select mode: left drag selects (Shift adds, Ctrl removes); R / H switch ROI / handle",
                      DRAG: "Drag mode: left drag moves the handle in the view plane; the gizmo rotates it"}[mode])

    def _set_tool(self, tool: str) -> None:
        self.controller.set_tool(tool)
        self.actions_["tool_rect" if tool == RECTANGLE else "tool_brush"].setChecked(True)

    def _scale_brush(self, factor: float) -> None:
        self.brush_spin.setValue(int(round(self.brush_spin.value() * factor)))

    def _focus_view(self) -> None:
        self.view.setFocus(QtCore.Qt.FocusReason.OtherFocusReason)

    # ------------------------------------------------------------------ what is drawn
    def _toggle_cage(self) -> None:
        self.scene.set_cage_visible(self.actions_["show_cage"].isChecked())
        self.view.request_render()

    def _toggle_stretch(self) -> None:
        self.scene.set_stretch_visible(self.actions_["stretch"].isChecked())
        self.measure(everything=True)
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

    def _on_rendered(self, seconds: float) -> None:
        """A render: View ▸ Anti-aliasing shows what the view has (it chooses after its first frame: off
        with software OpenGL)."""
        a = self.actions_["antialias"]
        if self.view.antialiasing is not None and a.isChecked() != self.view.antialiasing:
            a.setChecked(self.view.antialiasing)

    # ------------------------------------------------------------------ the camera
    def reset_camera(self) -> None:
        """View ▸ Frame Shape: the whole shape in sight, from the front, slightly turned."""
        self.scene.reset_camera()
        self.view.request_render()

    def set_view(self, view: str) -> None:
        """Look at the shape from one side (front, back, right, left, top, bottom), its up axis up."""
        if self.session is None:
            return
        self.scene.set_view(view)
        self.view.request_render()
        self.status.message(f"{view.capitalize()} view ({self.session.up_axis} up; View ▸ Up Axis changes it)")

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
        self.status.message(f"{axis} is up for {self.files.document_name or 'this shape'}"
                     + (" (remembered: it opens this way next time)" if kept else
                        " (not remembered: the cache folder cannot be written)"))
