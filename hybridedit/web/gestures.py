"""Mouse gestures of the browser editor: rectangle and brush selections and a handle drag, as the
window does them.

The browser's mouse reaches the server as VTK interactor events (display pixels, origin
bottom-left, as :func:`~hybridedit.viewer.model.picking.project_points` gives them);
:class:`Gestures` turns them into calls on the session. In Select mode a rectangle, or a brush
stroke, takes the cage points under it into the target (the ROI or the handle; Shift adds, Ctrl
removes): the surface in sight and the part it lies in through its thickness
(:func:`~hybridedit.viewer.model.surface_pick.surface_under`, with the window's depth buffer), so a
leg picked from the front is taken whole, as in the window; one undo step a gesture. A drag in
Drag mode moves the handle: along an arrow of the gizmo or round one of its rings when the press is
on one (:func:`~hybridedit.viewer.model.gizmo.part_transform`), else in the view plane through the
handle's centroid (:func:`~hybridedit.viewer.model.gizmo.screen_plane_translation`); settled at release.
In Pose mode the limb under the mouse (the engine's :meth:`~hybridedit.HybridEditor.limb_at` of the cage
point there) is shown with its joint as the mouse hovers (:meth:`Gestures.hover`; ``[`` / ``]`` move the
joint), a press makes it the selection, and the drag turns it about its joint
(:func:`~hybridedit.viewer.model.gizmo.swept_rotation`; with Shift it moves), as the window's Pose tool.
No Qt, no editing logic of its own.
"""

from __future__ import annotations

import time

import numpy as np

from ..deform.selection import SelectionError
from ..viewer.model import gizmo as gz
from ..deform.skeleton import edge_graph
from ..viewer.model.picking import (ADD, CLICK_PIXELS, DEPTH_TOLERANCE, PICK_PIXELS, REPLACE, brush_hits,
                                    in_sight, nearest_hit, op_from_modifiers, project_points, rectangle_hits,
                                    stroke_hits, surface_point)
from ..viewer.model.limb_joints import LimbJoints
from ..viewer.model.selection_masks import HANDLE, ROI
from ..viewer.model.surface_pick import surface_under

CAMERA, SELECT, DRAG, POSE = "camera", "select", "drag", "pose"
"""The modes: the mouse turns the camera, selects cage points, drags the handle, or turns a limb."""

RECTANGLE, BRUSH = "rectangle", "brush"
"""The selection tools (the window's X and B)."""

BRUSH_PIXELS = 30.0
"""The brush's radius to begin with, in display pixels (the window's); ``[`` and ``]`` scale it."""


class Gestures:
    """The select and drag gestures on one session and its scene.

    Parameters
    ----------
    session : the :class:`~hybridedit.viewer.model.session.Session` edited.
    scene : the :class:`~hybridedit.viewer.render.scene.Scene` it is drawn in (its camera's matrices).
    depth : the :class:`~hybridedit.viewer.render.depth_grab.DepthGrab` of the scene's shape layer: a
        selection takes only the cage points in sight, as the window's does (None: every point in front).

    Attributes
    ----------
    mode : CAMERA, SELECT, DRAG or POSE.
    target : ROI or HANDLE, what a selection takes into.
    tool : RECTANGLE or BRUSH, how a selection is drawn.
    brush_radius : the brush's radius in display pixels.
    select_through : a selection takes every cage point under it in front of the camera, hidden or not
        (the window's Select Through, Blender's X-ray).
    message : the latest thing to say in the status line (an error, a refused drag), or "".
    frame_ms : the engine's time a frame of the last drag (the mean of its frames), or None before one.
    shown_limb : the limb shown under the mouse in Pose mode, or None.
    """

    def __init__(self, session, scene, depth=None) -> None:
        self.session = session
        self.scene = scene
        self.depth = depth
        self.mode = CAMERA
        self.target = ROI
        self.tool = RECTANGLE
        self.brush_radius = BRUSH_PIXELS
        self.select_through = False
        self.message = ""
        self.frame_ms: float | None = None
        self._frame_s = [0.0, 0]  # (seconds, frames) of the drag under way
        self._start: tuple[float, float] | None = None
        self._last: tuple[float, float] | None = None
        self._op = REPLACE
        self._display: np.ndarray | None = None
        self._front: np.ndarray | None = None
        self._seen: np.ndarray | None = None
        self._graph = None
        self._graph_key: tuple[np.ndarray, np.ndarray] | None = None
        self._view_depth: np.ndarray | None = None
        self._center: np.ndarray | None = None
        self._composite: np.ndarray | None = None
        self._size: tuple[int, int] | None = None
        self._T0 = np.eye(4)
        self._dragging = False
        self._part: gz.Part | None = None
        self._grab: np.ndarray | None = None
        self._turn = False  # a Pose drag turns the limb (without Shift) rather than moving it
        self.joints = LimbJoints()
        self.shown_limb = None

    @property
    def busy(self) -> bool:
        """A gesture is under way (between press and release)."""
        return self._start is not None

    def scale_brush(self, factor: float) -> None:
        """The brush's radius times ``factor``, kept within 3-400 pixels (the window's ``[`` and ``]``)."""
        self.brush_radius = float(min(max(self.brush_radius * factor, 3.0), 400.0))

    def press(self, x: float, y: float, shift: bool, ctrl: bool) -> bool:
        """Left button down at display point (x, y); True when the shape or the selection changed (a drag
        began, a brush's first dab took cage points)."""
        if self.mode == CAMERA:
            return False
        C, size = self.scene.composite_matrix(), self.scene.display_size()
        self._start, self._composite, self._size = (float(x), float(y)), C, size
        self._last = self._start
        self.message = ""
        if self.mode == SELECT:
            self._op = op_from_modifiers(shift, ctrl)
            s = self.session
            P = s.cage_positions
            self._display, self._front = project_points(P, C, size)
            self._seen = self._in_sight(P, C, size)
            self._view_depth = self.scene.along_sight(P)
            if self._graph_key is None or not (np.array_equal(self._graph_key[0], P)
                                               and np.array_equal(self._graph_key[1], s.editor.cage_edges)):
                self._graph_key = (P.copy(), s.editor.cage_edges.copy())
                self._graph = edge_graph(P, s.editor.cage_edges)
            s.selection.begin_stroke(self.target)
            if self.tool == BRUSH:
                return self._dab(brush_hits(self._display, self._front, self._start, self.brush_radius))
            return False
        s = self.session
        pivot = None
        if self.mode == POSE:
            pivot = self._grab_limb(self._start)
            if pivot is None:
                self._start = None
                return False
            part = None
        else:
            part = self.scene.gizmo.hit(self._start, C, size)  # (the gizmo is shown in Drag mode only)
        try:
            self._T0 = s.begin_drag()
        except SelectionError as e:
            self.message = str(e)
            self._start = None
            self.scene.pivot.place(None)
            return False
        self._center = s.handle_centroid() if pivot is None else pivot
        self._turn = pivot is not None and not shift
        self._part, self._grab = part, None
        if part is not None and part.kind == "rotate":
            self._grab = gz.grab_direction(self._start, self._center, part.axis,
                                           gz.RING_RATIO * self.scene.gizmo.length, C, size)
        self._dragging = True
        self._frame_s = [0.0, 0]
        self.scene.set_dragging(True)
        self.scene.set_moving(s.moving_vertices())
        return True

    def move(self, x: float, y: float) -> bool:
        """The mouse moved with the button down; True when the shape (a drag frame) or the selection (a
        brush stroke) changed."""
        if self._start is not None and self.mode == SELECT and self.tool == BRUSH:
            last, self._last = self._last, (float(x), float(y))
            return self._dab(stroke_hits(self._display, self._front, last, self._last, self.brush_radius))
        if not self._dragging:
            return False
        t0 = time.perf_counter()
        self.session.drag_to(self._transform(x, y) @ self._T0)
        self._frame_s[0] += time.perf_counter() - t0
        self._frame_s[1] += 1
        return True

    def release(self, x: float, y: float) -> bool:
        """Left button up: the selection taken (one undo step), or the drag settled and recorded; True when
        anything changed."""
        start, self._start = self._start, None
        if start is None:
            return False
        if self.mode == SELECT:
            if self.tool == RECTANGLE:
                self._select(start, (float(x), float(y)))
            return self._end_select()
        if not self._dragging:
            return False
        s = self.session
        self._dragging = False
        seconds, frames = self._frame_s
        if frames:
            self.frame_ms = 1e3 * seconds / frames
        self._frame_s = [0.0, 0]
        self.scene.set_dragging(False)
        self.scene.pivot.place(None)
        if self.mode == POSE:
            self.message = ""
        s.drag_to(self._transform(x, y, start) @ self._T0)
        if not np.all(np.isfinite(s.shape_positions)):
            s.cancel_drag()
            self.message = "The deformation became non-finite; the drag was undone."
            return True
        s.end_drag()
        s.finish_settle()  # the settle at release (what hybridedit deform replays), and its undo step
        return True

    def hover(self, x: float, y: float) -> bool:
        """The mouse is over display point (x, y) with no button down: in Pose mode the limb there is shown
        (what a drag will hold, bend and turn, and its joint); True when the view changed."""
        if self.mode != POSE or self.busy:
            return False
        self._composite, self._size = self.scene.composite_matrix(), self.scene.display_size()
        limb = self.joints.limb_at(self.session.editor, self._cage_point_at((float(x), float(y))))
        if limb is self.shown_limb:
            return False
        self.shown_limb = limb
        self.show_limb()
        return True

    def show_limb(self) -> None:
        """Draw the limb shown (its roles and joint), or the selection's roles and no joint."""
        s, scene, limb = self.session, self.scene, self.shown_limb
        if limb is None:
            scene.pivot.place(None)
            scene.update_roles(s.selection.cage_roles(), s.selection.shape_roles())
            return
        pose = self.joints.parts(limb, s.cage_positions)
        roles = pose.cage_roles
        scene.update_roles(roles, s.editor.shape_roles(roles))
        scene.pivot.place(pose.joint, s.cage_positions[pose.extremity])

    def move_joint(self, steps: int) -> bool:
        """``]`` / ``[`` in Pose mode: the shown limb's joint ``steps`` notches toward the body (+) or the tip
        (-); False when no limb is shown."""
        if self.shown_limb is None or self.busy:
            return False
        at = self.joints.move(self.shown_limb, steps)
        self.show_limb()
        self.message = f"Joint at {at:.0%} of the limb's length from its tip ([ ] move it)"
        return True

    def _cage_point_at(self, at: tuple[float, float]) -> int | None:
        """The cage point of the surface under display point ``at`` (nearest in space to the surface point
        the depth buffer shows there, else the nearest in sight within a few pixels), or None."""
        P = self.session.cage_positions
        d = self.depth
        if d is not None:
            if not d.current():
                d.ren_win.Render()
            if d.current():
                point = surface_point(at, d)
                if point is not None:
                    return int(np.argmin(np.sum((P - point) ** 2, axis=1)))
        display, front = project_points(P, self._composite, self._size)
        self._display = display
        hit = nearest_hit(display, self._in_sight(P, self._composite, self._size), at, PICK_PIXELS)
        return int(np.flatnonzero(hit)[0]) if hit.any() else None

    def _grab_limb(self, at: tuple[float, float]) -> np.ndarray | None:
        """A press in Pose mode: the limb under ``at`` becomes the selection (one undo step) and its joint
        (3,) is returned; None, and said why, when no limb is there."""
        s = self.session
        limb = self.joints.limb_at(s.editor, self._cage_point_at(at))
        self.shown_limb = None
        if limb is None:
            self.message = ("No limb there: the Pose tool turns a limb (an arm, a leg, a tail, a head) about its "
                            "joint")
            return None
        pose = self.joints.parts(limb, s.cage_positions)
        s.selection.replace(pose.cage_roi, pose.cage_handle, "pose limb")
        self.scene.pivot.place(pose.joint, s.cage_positions[pose.extremity])
        self.message = "Turning the limb about its joint (Shift+drag moves it); release to settle"
        return np.asarray(pose.joint, dtype=np.float64)

    def _in_sight(self, P: np.ndarray, C: np.ndarray, size: tuple[int, int]) -> np.ndarray:
        """(c,) the cage points a selection may take: those in front and in sight."""
        d = self.depth
        if d is None:
            return self._front
        if not d.current():
            d.ren_win.Render()  # (once: the depth of the view as it is now)
        if not d.current():
            return self._front
        return in_sight(P, self._display, self._front, d, C, size, DEPTH_TOLERANCE * self.scene.cage_spacing)

    def _taken(self, hits: np.ndarray) -> np.ndarray:
        """What a rectangle or brush takes of its ``hits`` (the points under it, in front of the camera): those
        in sight and the parts they lie in, through their thickness (the window's rule)."""
        if self.select_through or self.depth is None:
            return hits & self._front  # (no depth buffer: every point in front, as Select Through takes)
        thick = self.session.selection.cage_thickness()
        return surface_under(hits, hits & self._seen, self._graph, thick, depth=self._view_depth)

    def _dab(self, hits: np.ndarray) -> bool:
        """A brush dab; a replacing stroke replaces with its first dab that takes a cage point and adds the
        rest to it (a stroke over empty space changes nothing). True when it took any."""
        taken = self._taken(hits)
        if not taken.any():
            return False
        self.session.selection.stroke(taken, self._op)
        if self._op == REPLACE:
            self._op = ADD
        return True

    def _select(self, start: tuple[float, float], end: tuple[float, float]) -> None:
        """The rectangle (or click) of a gesture, taken into the stroke."""
        display = self._display
        if max(abs(end[0] - start[0]), abs(end[1] - start[1])) <= CLICK_PIXELS:
            hits = nearest_hit(display, self._front if self.select_through else self._seen, start, PICK_PIXELS)
            if not hits.any():
                self.message = "No cage point there: the selection is kept"
                return
            self.session.selection.stroke(hits, self._op)
            return
        self.session.selection.stroke(self._taken(rectangle_hits(display, self._front, start, end)), self._op)

    def _end_select(self) -> bool:
        """The gesture's one undo step; what to say when it emptied its target or a drag would tear."""
        sel = self.session.selection
        target = self.target
        if not sel.end_stroke():
            return False
        if not sel.mask(target).any():
            self.message = f"{'ROI' if target == ROI else 'Handle'} cleared (Ctrl+Z restores it)"
        else:
            self.message = sel.tearing_warning() or ""
        return True

    def _transform(self, x: float, y: float, start: tuple[float, float] | None = None) -> np.ndarray:
        """(4, 4) the handle's move since the press at ``start`` (default: this gesture's): along or round
        the gizmo's part pressed, else the mouse's in the view plane through the handle."""
        start, now = start or self._start, (float(x), float(y))
        if self._turn:
            return gz.swept_rotation(start, now, self._center, self._composite, self._size)
        if self._part is not None:
            return gz.part_transform(self._part, start, now, self._center, self.scene.gizmo.length, self._grab,
                                     self._composite, self._size)
        D = np.eye(4)
        D[:3, 3] = gz.screen_plane_translation(start, now, self._center, self._composite, self._size)
        return D


__all__ = ["BRUSH", "CAMERA", "DRAG", "Gestures", "HANDLE", "POSE", "RECTANGLE", "ROI", "SELECT"]
