"""How the window shows the shape and how the mouse acts on it: the mode, the selection tool and the
brush, the cage wireframe, the stretch map, the look (texture, colours, plain), anti-aliasing, the
camera's views and the shape's up axis.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol, runtime_checkable

from qtpy import QtCore, QtWidgets

from ...fileio.up_axes import remember_up_axis, shape_key
from ..input.mouse_gestures import CAMERA, DRAG, POSE, RECTANGLE, SELECT
from .interfaces import ActionChecks, Named
from .slot_errors import guarded

if TYPE_CHECKING:
    from ..model.session import Session
    from ..render.scene import Scene


@runtime_checkable
class Mouse(Protocol):
    """The view controller as the view options see it: the mode, the tool, the brush."""

    @property
    def mode(self) -> str: ...
    def set_mode(self, mode: str) -> None: ...
    def set_tool(self, tool: str) -> None: ...
    def set_brush_radius(self, radius: float) -> None: ...


@runtime_checkable
class Joints(Protocol):
    """The Pose tool as the view options see it: ``[`` / ``]`` move the joint of the limb shown."""

    def move_joint(self, steps: int) -> None: ...


@runtime_checkable
class ViewWidget(Protocol):
    """The 3D view as the view options see it (:class:`~..render.view.View`)."""

    @property
    def antialiasing(self) -> bool | None: ...
    def request_render(self) -> None: ...
    def set_antialiasing(self, on: bool) -> None: ...
    def setFocus(self, reason: QtCore.Qt.FocusReason) -> None: ...  # noqa: N802 (Qt's name)


@runtime_checkable
class Measures(Protocol):
    """The scene's upkeep as the view options see it: the stretch map, measured when it is shown."""

    def measure(self, everything: bool | None = None) -> None: ...


@runtime_checkable
class Settles(Protocol):
    """The pose side as the view options see it: a settle under way completed before the look changes."""

    def finish_settle(self) -> None: ...


@runtime_checkable
class Says(Protocol):
    """The status bar as the view options see it (and where an unexpected error goes:
    :func:`~.slot_errors.guarded`)."""

    def message(self, text: str) -> None: ...
    def show_error(self, title: str, text: str) -> None: ...


@runtime_checkable
class OptionsHost(Protocol):
    """What :class:`ViewOptions` asks of the window (:class:`~.main_window.MainWindow`)."""

    @property
    def session(self) -> Session | None: ...
    @property
    def controller(self) -> Mouse: ...
    @property
    def scene(self) -> Scene: ...
    @property
    def view(self) -> ViewWidget: ...
    @property
    def sync(self) -> Measures: ...
    @property
    def posing(self) -> Settles: ...
    @property
    def status(self) -> Says: ...
    @property
    def files(self) -> Named: ...
    @property
    def actions_(self) -> ActionChecks: ...
    @property
    def limb_posing(self) -> Joints: ...


class ViewOptions:
    """The Mode and View menus' settings of a :class:`~.main_window.MainWindow`: they set the view
    controller, the scene and the view, and keep the actions checked to match.

    Parameters
    ----------
    window : the window, as far as the view options need it (:class:`OptionsHost`).

    Attributes
    ----------
    brush_spin : the toolbar's brush radius box ([ and ] change it).
    """

    def __init__(self, window: OptionsHost) -> None:
        self.w = window
        self.brush_spin = QtWidgets.QSpinBox()
        self.brush_spin.setRange(3, 400)
        self.brush_spin.setValue(30)
        self.brush_spin.setSuffix(" px")
        self.brush_spin.setToolTip("Brush radius ([ and ] change it)")
        self.brush_spin.valueChanged.connect(lambda v: self.w.controller.set_brush_radius(v))

    # ------------------------------------------------------------------ the mouse
    def set_mode(self, mode: str) -> None:
        """What a left drag does: ``CAMERA``, ``SELECT``, ``DRAG`` or ``POSE`` (:mod:`..input.mouse_gestures`)."""
        w = self.w
        w.controller.set_mode(mode)
        w.actions_[f"mode_{mode}"].setChecked(True)
        w.status.message({CAMERA: "Camera mode: left drag rotates the view",
                          SELECT: "Select mode: left drag selects (Shift adds, Ctrl removes); R / H switch ROI / "
                                  "handle",
                          DRAG: "Drag mode: left drag moves the handle in the view plane; the gizmo rotates it",
                          POSE: "Pose mode: hover a limb to see its joint, drag to turn it about the joint (Shift: "
                                "move it); [ ] or the wheel move the joint"}[mode])

    def set_tool(self, tool: str) -> None:
        """The selection tool: ``RECTANGLE`` or ``BRUSH``."""
        self.w.controller.set_tool(tool)
        self.w.actions_["tool_rect" if tool == RECTANGLE else "tool_brush"].setChecked(True)

    def scale_brush(self, factor: float) -> None:
        """The brush radius times ``factor`` (Mode ▸ Bigger / Smaller Brush); in Pose mode the same keys move
        the joint of the limb shown (bigger: toward the body)."""
        if self.w.controller.mode == POSE:
            self.w.limb_posing.move_joint(1 if factor > 1 else -1)
            return
        self.brush_spin.setValue(int(round(self.brush_spin.value() * factor)))

    def focus_view(self) -> None:
        """The keyboard back to the 3D view (after a toolbar box), so the single-key shortcuts work again."""
        self.w.view.setFocus(QtCore.Qt.FocusReason.OtherFocusReason)

    # ------------------------------------------------------------------ what is drawn
    def toggle_cage(self) -> None:
        """View ▸ Show Cage Wireframe."""
        w = self.w
        w.scene.set_cage_visible(w.actions_["show_cage"].isChecked())
        w.view.request_render()

    def toggle_points(self) -> None:
        """View ▸ Show Cage Points."""
        w = self.w
        w.scene.set_points_visible(w.actions_["show_points"].isChecked())
        w.view.request_render()

    def toggle_points_dragging(self) -> None:
        """View ▸ Hide Points While Dragging."""
        self.w.scene.set_hide_points_dragging(self.w.actions_["hide_points_dragging"].isChecked())

    def toggle_stretch(self) -> None:
        """View ▸ Stretch Map."""
        w = self.w
        w.scene.set_stretch_visible(w.actions_["stretch"].isChecked())
        w.sync.measure(everything=True)
        w.view.request_render()

    def set_look_mode(self, mode: str) -> None:
        """Draw the shape with its texture, its file's colours, or plain (View menu)."""
        w = self.w
        s = w.session
        if s is None or mode not in w.scene.look_modes():
            w.actions_.refresh()
            return
        w.posing.finish_settle()
        w.scene.set_look_mode(mode)
        s.look_mode = w.scene.look_mode
        w.view.request_render()
        w.actions_.refresh()

    def toggle_antialias(self) -> None:
        """View ▸ Anti-aliasing."""
        self.w.view.set_antialiasing(self.w.actions_["antialias"].isChecked())

    def on_rendered(self, seconds: float) -> None:
        """A render: View ▸ Anti-aliasing shows what the view has (it chooses after its first frame: off
        with software OpenGL)."""
        w = self.w
        a = w.actions_["antialias"]
        if w.view.antialiasing is not None and a.isChecked() != w.view.antialiasing:
            a.setChecked(w.view.antialiasing)

    # ------------------------------------------------------------------ the camera
    def reset_camera(self) -> None:
        """View ▸ Frame Shape: the whole shape in sight, from the front, slightly turned."""
        self.w.scene.reset_camera()
        self.w.view.request_render()

    def set_view(self, view: str) -> None:
        """Look at the shape from one side (front, back, right, left, top, bottom), its up axis up."""
        w = self.w
        if w.session is None:
            return
        w.scene.set_view(view)
        w.view.request_render()
        w.status.message(f"{view.capitalize()} view ({w.session.up_axis} up; View ▸ Up Axis changes it)")

    @guarded
    def set_up_axis(self, axis: str) -> None:
        """The shape's up axis: the views follow it, and it is remembered for this shape (the next time it
        opens this way up)."""
        w = self.w
        s = w.session
        if s is None:
            w.actions_.refresh()
            return
        s.up_axis = w.scene.up_axis = axis
        if s.shape_key is None:
            s.shape_key = shape_key(s.mesh)
        kept = remember_up_axis(s.shape_key, axis)
        w.scene.reset_camera()
        w.view.request_render()
        w.actions_.refresh()
        w.status.message(f"{axis} is up for {w.files.document_name or 'this shape'}"
                         + (" (remembered: it opens this way next time)" if kept else
                            " (not remembered: the cache folder cannot be written)"))
