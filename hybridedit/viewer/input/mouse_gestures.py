"""Mouse handling on the 3D view: rubber band and brush selection, gizmo and screen-plane drags.

An event filter on the view takes the left button in the Select, Drag and Pose
modes (and on the gizmo in the Camera and Drag modes); everything else goes on to
VTK's camera style (left: rotate in Camera mode, middle: pan, right / wheel:
zoom; Alt + left rotates in any mode). Key events never reach VTK: the window's
shortcuts handle the keyboard.

The controller turns gestures into calls on a :class:`SelectionHandler`, a :class:`DragHandler` and
a :class:`PoseHandler`.

In Pose mode (as Blender's Pose brush) the limb under the cursor is shown; a drag on it makes it the
selection and turns it about its joint in the view plane by the angle the cursor sweeps round the
joint (Shift at the press: moves it in the view plane instead); the wheel over it moves the joint
along it.

Selection takes the surface the user points at: for the rectangle and the brush,
the part they are drawn over (what they see of it, not a sliver of another part
beside it), grown along the surface through its thickness
(:func:`~..model.surface_pick.surface_under`: the back of an arm drawn over from
the front), so that a limb picked from one side moves whole. A part hidden
behind another or only overlapping it on screen (a hind leg behind a front leg)
is not taken, unless
:attr:`ViewController.select_through` is on (Blender's X-ray); a click takes the
nearest point in sight. Whether a point is in sight is decided once per
gesture from the depth buffer of the shape's layer (:class:`~..render.depth_grab.DepthGrab`,
read with the frame the view shows anyway) by
:func:`~..model.picking.visible_points`. A click (the rectangle tool, moved at most
:data:`CLICK_PIXELS`) takes the nearest cage point within :data:`PICK_PIXELS`;
on empty space it changes nothing. A rectangle drawn over empty space in
replace mode empties the target, as in Blender (the window says that Ctrl+Z
restores it). A brush stroke that replaces replaces with its first dab that
touches a cage point: a stroke over empty space changes nothing.
"""

from __future__ import annotations

import time
from typing import Protocol, runtime_checkable

import numpy as np
from qtpy import QtCore, QtGui

from ...deform.skeleton import edge_graph
from ..model import gizmo as gz
from ..model.picking import (
    ADD, CLICK_PIXELS, DEPTH_TOLERANCE, PICK_PIXELS, REPLACE, brush_hits, in_sight, nearest_hit,
    op_from_modifiers, project_points, rectangle_hits, stroke_hits, surface_point,
)
from ..model.surface_pick import surface_under
from ..render.scene import Scene
from ..render.view import OutlineOverlay, View

CAMERA, SELECT, DRAG, POSE = "camera", "select", "drag", "pose"
MODES = (CAMERA, SELECT, DRAG, POSE)
RECTANGLE, BRUSH = "rectangle", "brush"
NEAR_PIXELS = 60.0
"""In Select mode the cage points within this many pixels of the cursor are drawn."""
TOOLS = (RECTANGLE, BRUSH)


@runtime_checkable
class SelectionHandler(Protocol):
    """What the controller's selection gestures call (the window's :class:`~..window.selecting.Selecting`)."""

    def cage_points(self) -> np.ndarray | None: ...
    def cage_edges(self) -> np.ndarray | None: ...
    def cage_thickness(self) -> np.ndarray | None: ...  # (c,) how thick the part is at each cage point
    def begin_select(self) -> bool: ...
    def select_hits(self, hits: np.ndarray, op: str) -> None: ...
    def end_select(self) -> None: ...
    def missed(self) -> None: ...  # a click took no cage point: the selection stays


@runtime_checkable
class DragHandler(Protocol):
    """What the controller's drag gestures call (the window's :class:`~.drags.DragFrames`)."""

    def handle_center(self) -> np.ndarray | None: ...
    def begin(self) -> bool: ...
    def move(self, D: np.ndarray) -> None: ...
    def end(self) -> None: ...


@runtime_checkable
class PoseHandler(Protocol):
    """What the Pose mode's gestures call (the window's :class:`~..window.limb_posing.LimbPosing`)."""

    def hover(self, cage_vertex: int | None) -> bool: ...  # show the limb there (None: none); True: one shown
    def grab(self, cage_vertex: int | None) -> np.ndarray | None: ...  # the limb there made the selection; its pivot
    def move_joint(self, steps: int) -> None: ...  # the joint of the limb shown, along it (+: toward the body)


class Gesture:
    """State of one left-button gesture."""

    def __init__(self, kind: str, start_qt: QtCore.QPointF, start: tuple[float, float]) -> None:
        self.kind = kind            # "rectangle", "brush", "gizmo", "plane", "pose"
        self.start_qt = start_qt    # widget coordinates
        self.start = start          # display coordinates
        self.last = start
        self.op = REPLACE
        self.shift = False  # (a Pose drag with Shift moves the limb instead of turning it)
        self.part: gz.Part | None = None
        self.center = np.zeros(3)
        self.grab: np.ndarray | None = None
        self.composite = np.eye(4)
        self.size = (1, 1)
        self.display: np.ndarray | None = None
        self.front: np.ndarray | None = None  # in front of the camera
        self.in_front: np.ndarray | None = None  # in front of the camera and takeable (in sight, or select through)
        self.graph = None  # its edge graph (a part is taken through its thickness along the surface)
        self.thick: np.ndarray | None = None  # how thick the part is at each cage point
        self.depth: np.ndarray | None = None  # how far each cage point lies along the line of sight


class ViewController(QtCore.QObject):
    """Interprets mouse events on the view for the current mode and tool.

    Parameters
    ----------
    view : the 3D view widget; scene : its actors.
    selection : what the selection gestures call (:class:`SelectionHandler`).
    drags : what the drag gestures call (:class:`DragHandler`).
    poses : what the Pose mode's gestures call (:class:`PoseHandler`); None: no Pose mode.
    """

    def __init__(self, view: View, scene: Scene, selection: SelectionHandler, drags: DragHandler,
                 poses: PoseHandler | None = None) -> None:
        super().__init__(view)
        self.view = view
        self.scene = scene
        self.selection = selection
        self.drags = drags
        self.poses = poses
        self._limb_shown = False  # Pose mode: a limb is shown under the cursor
        self.mode = CAMERA
        self.target_color = QtGui.QColor(60, 190, 70)
        self.tool = RECTANGLE
        self.brush_radius = 30.0  # widget pixels
        self.gesture: Gesture | None = None
        self.select_through = False
        """Rectangle, brush and click take the cage points hidden behind the shape too (Blender's X-ray)."""
        self.visibility_seconds = 0.0  # duration of the last visibility test (with a render when one was needed)
        self._visible: tuple[int, np.ndarray, np.ndarray] | None = None  # (depth serial, cage points, mask)
        self._hover_pos: QtCore.QPointF | None = None
        self._graph_cache: tuple | None = None  # (edges, cage pose, edge graph)
        self._passthrough = False
        self.rubber = OutlineOverlay(view, circle=False)
        view.depth.key_fn = self._view_key
        view.depth.on_grab = lambda: QtCore.QTimer.singleShot(0, self._rehover)
        view.installEventFilter(self)
        self.set_mode(CAMERA)

    # ------------------------------------------------------------------ settings
    @property
    def busy(self) -> bool:
        """A gesture is under way (undo and the like must wait)."""
        return self.gesture is not None

    def set_mode(self, mode: str) -> None:
        if mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}")
        self.cancel()
        self.mode = mode
        cursors = {
            CAMERA: QtCore.Qt.CursorShape.ArrowCursor,
            SELECT: QtCore.Qt.CursorShape.CrossCursor,
            DRAG: QtCore.Qt.CursorShape.SizeAllCursor,
            POSE: QtCore.Qt.CursorShape.PointingHandCursor,
        }
        self.view.setCursor(cursors[mode])
        self.view.brush.hide()
        # the frames shown in Select and Pose mode keep the depth up to date (what is in sight, under the cursor)
        self.view.depth.wanted = mode in (SELECT, POSE)
        self.scene.gizmo.suppress(mode == POSE)
        if mode != POSE and self.poses is not None and self._limb_shown:
            self._limb_shown = self.poses.hover(None)
        if self.scene.set_points_near(None):
            self.view.request_render()
        if self.scene.gizmo.set_hover(None):
            self.view.request_render()

    def set_tool(self, tool: str) -> None:
        if tool not in TOOLS:
            raise ValueError(f"tool must be one of {TOOLS}")
        self.cancel()
        self.tool = tool
        if tool != BRUSH:
            self.view.brush.hide()

    def set_select_through(self, on: bool) -> None:
        """Take the hidden cage points too (True) or only those in sight (False)."""
        self.select_through = bool(on)
        if self._hover_pos is not None:
            self._show_points_near(self._hover_pos)

    def set_brush_radius(self, radius: float) -> None:
        self.brush_radius = float(min(max(radius, 3.0), 400.0))
        if self.view.brush.isVisible():
            self.view.brush.show_at(self.view.brush.center, self.brush_radius, self.target_color)

    def cancel(self) -> None:
        """Abort a selection gesture in progress (drags are finished, not undone)."""
        g = self.gesture
        if g is None:
            return
        self.gesture = None
        self.rubber.hide()
        if g.kind in ("gizmo", "plane"):
            self.drags.end()
        elif g.kind == "brush":
            self.selection.end_select()

    # ------------------------------------------------------------------ events
    def eventFilter(self, obj: QtCore.QObject, ev: QtCore.QEvent) -> bool:  # noqa: N802
        t = ev.type()
        E = QtCore.QEvent.Type
        if t in (E.KeyPress, E.KeyRelease):
            return True  # no VTK key bindings; the window's shortcuts have run already
        if t == E.MouseButtonPress:
            return self._press(ev)
        if t == E.MouseMove:
            return self._move(ev)
        if t == E.MouseButtonRelease:
            return self._release(ev)
        if t == E.MouseButtonDblClick:
            return ev.button() == QtCore.Qt.MouseButton.LeftButton and self.mode != CAMERA
        if t == E.Wheel and self.mode == POSE and self._limb_shown and self.gesture is None:
            steps = 1 if ev.angleDelta().y() > 0 else -1 if ev.angleDelta().y() < 0 else 0
            if steps:
                self.poses.move_joint(steps)  # (over a limb the wheel moves its joint; elsewhere it zooms)
            return True
        if t == E.Leave:
            self._hover_pos = None
            self.view.brush.hide()
            self._show_points_near(None)
            if self._limb_shown and self.gesture is None:
                self._limb_shown = self.poses.hover(None)
        return False

    # ------------------------------------------------------------------ what is in sight
    def _view_key(self):
        """What the depth of the shape's layer depends on: the camera, the view size and the shape's pose."""
        shape = self.scene.shape
        if shape is None:
            return None
        cam = self.scene.renderer.GetActiveCamera()
        return (cam.GetPosition(), cam.GetFocalPoint(), cam.GetViewUp(), cam.GetViewAngle(),
                cam.GetParallelScale(), cam.GetParallelProjection(), self.scene.display_size(),
                id(shape), shape.GetPoints().GetMTime())

    def takeable(self, P: np.ndarray, C: np.ndarray, size: tuple[int, int], display: np.ndarray,
                 in_front: np.ndarray, render: bool = True) -> np.ndarray | None:
        """Which cage points (P, projected to ``display``, ``in_front``) a selection may take: those in
        sight, or all in front of the camera with Select Through. With ``render`` the view renders once
        now when the depth on hand is out of date; without, None is returned then."""
        if self.select_through:
            return in_front
        t0 = time.perf_counter()
        depth = self.view.fresh_depth() if render else self.view.depth
        if depth is None or not depth.current():
            return None
        cached = self._visible
        if cached is not None and cached[0] == depth.serial and np.array_equal(cached[1], P):
            return in_front & cached[2]
        vis = in_sight(P, display, in_front, depth, C, size, DEPTH_TOLERANCE * self.scene.cage_spacing)
        self._visible = (depth.serial, np.array(P, copy=True), vis)
        self.visibility_seconds = time.perf_counter() - t0
        return in_front & vis

    def _graph(self, P: np.ndarray):
        """The cage's edge graph at its pose ``P`` (kept while the pose and the edges stay)."""
        edges = self.selection.cage_edges()
        if edges is None:
            return None
        cached = self._graph_cache
        if cached is None or not np.array_equal(cached[0], edges) or not np.array_equal(cached[1], P):
            cached = self._graph_cache = (edges, np.array(P, copy=True), edge_graph(P, edges))
        return cached[2]

    def _matrices(self) -> tuple[np.ndarray, tuple[int, int]]:
        return self.scene.composite_matrix(), self.scene.display_size()

    def _press(self, ev: QtGui.QMouseEvent) -> bool:
        if ev.button() != QtCore.Qt.MouseButton.LeftButton:
            return self.gesture is not None  # other buttons are ignored during a gesture
        if self.gesture is not None:
            return True
        mods = ev.modifiers()
        if mods & QtCore.Qt.KeyboardModifier.AltModifier:
            self._passthrough = True
            return False
        pos = ev.position()
        d = self.view.to_display(pos)
        C, size = self._matrices()
        if self.mode in (CAMERA, DRAG):
            part = self.scene.gizmo.hit(d, C, size)
            if part is not None:
                return self._start_drag("gizmo", pos, d, C, size, part)
        if self.mode == SELECT:
            return self._start_select(pos, d, C, size, mods)
        if self.mode == POSE and self.poses is not None:
            return self._start_pose(pos, d, C, size, bool(mods & QtCore.Qt.KeyboardModifier.ShiftModifier))
        if self.mode == DRAG:
            return self._start_drag("plane", pos, d, C, size, None)
        self._passthrough = True
        return False

    def _start_select(self, pos: QtCore.QPointF, d: tuple[float, float], C: np.ndarray,
                      size: tuple[int, int], mods) -> bool:
        P = self.selection.cage_points()
        if P is None or not self.selection.begin_select():
            return True
        g = Gesture(self.tool, pos, d)
        g.op = op_from_modifiers(bool(mods & QtCore.Qt.KeyboardModifier.ShiftModifier),
                                 bool(mods & QtCore.Qt.KeyboardModifier.ControlModifier))
        g.composite, g.size = C, size
        g.display, g.front = project_points(P, C, size)
        take = self.takeable(P, C, size, g.display, g.front)
        g.in_front = g.front if take is None else take  # (no depth to be had: everything in front)
        g.graph, g.thick = self._graph(P), self.selection.cage_thickness()
        g.depth = self.scene.along_sight(P)
        self.gesture = g
        if g.kind != RECTANGLE:  # (the rectangle is shown once the mouse moves: a click shows none)
            r = self.brush_radius * self.view.devicePixelRatioF()
            self._dab(g, self._taken(g, brush_hits(g.display, g.front, d, r)))
            self.view.brush.show_at(pos, self.brush_radius, self.target_color)
        return True

    def _taken(self, g: Gesture, hits: np.ndarray) -> np.ndarray:
        """What a rectangle or brush gesture takes of its ``hits`` (every point in it, in front of the camera):
        with Select Through all, else those in sight and the parts they lie in, through their thickness."""
        if self.select_through or g.graph is None or g.thick is None:
            return hits & g.in_front
        return surface_under(hits, hits & g.in_front, g.graph, g.thick, depth=g.depth)

    def _dab(self, g: Gesture, hits: np.ndarray) -> None:
        """Apply a brush dab. A replacing stroke replaces with its first dab that touches a cage point
        and adds the rest to it: a stroke over empty space changes nothing."""
        if not hits.any():
            return
        self.selection.select_hits(hits, g.op)
        if g.op == REPLACE:
            g.op = ADD

    def _start_drag(self, kind: str, pos: QtCore.QPointF, d: tuple[float, float], C: np.ndarray,
                    size: tuple[int, int], part: gz.Part | None) -> bool:
        if not self.drags.begin():  # the window explains why (e.g. an empty handle)
            return True
        center = self.drags.handle_center()
        if center is None:
            self.drags.end()
            return True
        g = Gesture(kind, pos, d)
        g.part, g.composite, g.size = part, C, size
        g.center = np.asarray(center, dtype=np.float64)
        if part is not None and part.kind == "rotate":
            g.grab = gz.grab_direction(d, g.center, part.axis, gz.RING_RATIO * self.scene.gizmo.length, C, size)
        self.gesture = g
        return True

    def _start_pose(self, pos: QtCore.QPointF, d: tuple[float, float], C: np.ndarray, size: tuple[int, int],
                    shift: bool) -> bool:
        """A press in Pose mode: the limb under the cursor becomes the selection, and a drag turns it about its
        joint (moves it with ``shift``)."""
        pivot = self.poses.grab(self.cage_vertex_at(d))
        if pivot is None:  # (the window says why)
            return True
        self._limb_shown = False
        if not self.drags.begin():
            return True
        g = Gesture("pose", pos, d)
        g.composite, g.size, g.shift = C, size, shift
        g.center = np.asarray(pivot, dtype=np.float64)
        self.gesture = g
        return True

    def cage_vertex_at(self, d: tuple[float, float], render: bool = True) -> int | None:
        """The cage point of the surface under display point ``d``: nearest (in space) to the surface point
        the depth buffer shows there, else the nearest cage point in sight within :data:`PICK_PIXELS`;
        None over empty space (or, without ``render``, when the depth on hand is out of date)."""
        P = self.selection.cage_points()
        if P is None:
            return None
        depth = self.view.fresh_depth() if render else self.view.depth
        if depth is None or not depth.current():
            return None
        at = surface_point(d, depth)
        if at is not None:
            return int(np.argmin(np.sum((P - at) ** 2, axis=1)))
        C, size = self._matrices()
        display, front = project_points(P, C, size)
        take = self.takeable(P, C, size, display, front, render=render)
        hit = nearest_hit(display, front if take is None else take, d, PICK_PIXELS * self.view.devicePixelRatioF())
        return int(np.flatnonzero(hit)[0]) if hit.any() else None

    def _move(self, ev: QtGui.QMouseEvent) -> bool:
        pos = ev.position()
        g = self.gesture
        if g is None:
            if ev.buttons() == QtCore.Qt.MouseButton.NoButton:
                self._hover(pos)
            return False
        d = self.view.to_display(pos)
        if g.kind == RECTANGLE:
            self.rubber.setGeometry(QtCore.QRect(g.start_qt.toPoint(), pos.toPoint()).normalized())
            if not self.rubber.isVisible() and not self._is_click(g, d):
                self.rubber.show()
        elif g.kind == BRUSH:
            r = self.brush_radius * self.view.devicePixelRatioF()
            self._dab(g, self._taken(g, stroke_hits(g.display, g.front, g.last, d, r)))
            self.view.brush.show_at(pos, self.brush_radius, self.target_color)
        else:
            self.drags.move(self._drag_transform(g, d))
        g.last = d
        return True

    def _is_click(self, g: Gesture, d: tuple[float, float]) -> bool:
        """The mouse is still within :data:`CLICK_PIXELS` of where the gesture started."""
        return max(abs(d[0] - g.start[0]), abs(d[1] - g.start[1])) <= CLICK_PIXELS * self.view.devicePixelRatioF()

    def _drag_transform(self, g: Gesture, d: tuple[float, float]) -> np.ndarray:
        if g.kind == "pose" and not g.shift:
            return gz.swept_rotation(g.start, d, g.center, g.composite, g.size)
        if g.kind == "gizmo":
            return gz.part_transform(g.part, g.start, d, g.center, self.scene.gizmo.length, g.grab,
                                     g.composite, g.size)
        t = gz.screen_plane_translation(g.start, d, g.center, g.composite, g.size)
        D = np.eye(4)
        D[:3, 3] = t
        return D

    def _release(self, ev: QtGui.QMouseEvent) -> bool:
        if ev.button() != QtCore.Qt.MouseButton.LeftButton:
            return self.gesture is not None
        if self._passthrough:
            self._passthrough = False
            return False
        g = self.gesture
        if g is None:
            return self.mode != CAMERA
        pos = ev.position()
        d = self.view.to_display(pos)
        self.gesture = None
        if g.kind == RECTANGLE:
            self.rubber.hide()
            if self._is_click(g, d):
                hit = nearest_hit(g.display, g.in_front, g.start, PICK_PIXELS * self.view.devicePixelRatioF())
                if hit.any():
                    self.selection.select_hits(hit, g.op)
                else:  # a click on empty space: the selection stays
                    self.selection.missed()
            else:
                self.selection.select_hits(self._taken(g, rectangle_hits(g.display, g.front, g.start, d)), g.op)
            self.selection.end_select()
        elif g.kind == BRUSH:
            self.selection.end_select()
        else:
            if d != g.last:
                self.drags.move(self._drag_transform(g, d))
            self.drags.end()
        self._hover(pos)
        return True

    def _show_points_near(self, pos: QtCore.QPointF | None) -> None:
        """In Select mode, draw the cage points near the cursor (the others only when selected)."""
        near = None
        if pos is not None and self.mode == SELECT:
            P = self.selection.cage_points()
            if P is not None:
                C, size = self._matrices()
                display, front = project_points(P, C, size)
                take = self.takeable(P, C, size, display, front, render=False)
                if take is None:  # the depth is read with the next frame, then these are shown again
                    take = front
                    self.view.request_render()
                r = max(NEAR_PIXELS, 1.5 * self.brush_radius) * self.view.devicePixelRatioF()
                near = brush_hits(display, front, self.view.to_display(pos), r)
                graph = None if self.select_through else self._graph(P)
                thick = None if graph is None else self.selection.cage_thickness()
                near = near & take if thick is None else surface_under(near, near & take, graph, thick,
                                                                       depth=self.scene.along_sight(P))
        if self.scene.set_points_near(near):
            self.view.request_render()

    def _hover_limb(self, pos: QtCore.QPointF) -> None:
        """Pose mode: show the limb under the cursor (the depth on hand read; a frame reads it when stale)."""
        if self.poses is None:
            return
        d = self.view.to_display(pos)
        i = self.cage_vertex_at(d, render=False)
        if i is None and not self.view.depth.current():
            self.view.request_render()  # (the depth comes with it, then _rehover)
            return
        self._limb_shown = self.poses.hover(i)

    def _rehover(self) -> None:
        """The depth was read: show the cage points near the cursor that a selection would take."""
        if self._hover_pos is not None and self.gesture is None and self.mode == SELECT:
            self._show_points_near(self._hover_pos)
        elif self._hover_pos is not None and self.gesture is None and self.mode == POSE:
            self._hover_limb(self._hover_pos)

    def _hover(self, pos: QtCore.QPointF) -> None:
        self._hover_pos = QtCore.QPointF(pos)
        self._show_points_near(pos)
        if self.mode == SELECT and self.tool == BRUSH:
            self.view.brush.show_at(pos, self.brush_radius, self.target_color)
            return
        if self.mode == POSE:
            self._hover_limb(pos)
            return
        part = None
        if self.mode != SELECT:
            C, size = self._matrices()
            part = self.scene.gizmo.hit(self.view.to_display(pos), C, size)
        if self.scene.gizmo.set_hover(part):
            self.view.request_render()
