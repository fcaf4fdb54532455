"""Mouse gestures of the browser editor: a rectangle selection and a handle drag, as the window does them.

The browser's mouse reaches the server as VTK interactor events (display pixels, origin
bottom-left, as :func:`~hybridedit.viewer.model.picking.project_points` gives them);
:class:`Gestures` turns them into calls on the session: a rectangle in Select mode takes
the cage points in it into the target (the ROI or the handle, Shift adds, Ctrl removes),
only the points in sight, as the window's does (its depth buffer); a drag in Drag mode moves the
handle in the view plane through the handle's centroid
(:func:`~hybridedit.viewer.model.gizmo.screen_plane_translation`), settled at release.
No Qt, no editing logic of its own.
"""

from __future__ import annotations

import numpy as np

from ..deform.selection import SelectionError
from ..viewer.model.gizmo import screen_plane_translation
from ..viewer.model.picking import (CLICK_PIXELS, DEPTH_TOLERANCE, PICK_PIXELS, in_sight, nearest_hit,
                                    op_from_modifiers, project_points, rectangle_hits)
from ..viewer.model.selection_masks import HANDLE, ROI

CAMERA, SELECT, DRAG = "camera", "select", "drag"
"""The modes: the mouse turns the camera, selects cage points, or drags the handle."""


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
    mode : CAMERA, SELECT or DRAG.
    target : ROI or HANDLE, what a selection takes into.
    message : the latest thing to say in the status line (an error, a refused drag), or "".
    """

    def __init__(self, session, scene, depth=None) -> None:
        self.session = session
        self.scene = scene
        self.depth = depth
        self.mode = CAMERA
        self.target = ROI
        self.message = ""
        self._start: tuple[float, float] | None = None
        self._op = "replace"
        self._display: np.ndarray | None = None
        self._front: np.ndarray | None = None
        self._center: np.ndarray | None = None
        self._composite: np.ndarray | None = None
        self._size: tuple[int, int] | None = None
        self._T0 = np.eye(4)
        self._dragging = False

    @property
    def busy(self) -> bool:
        """A gesture is under way (between press and release)."""
        return self._start is not None

    def press(self, x: float, y: float, shift: bool, ctrl: bool) -> None:
        """Left button down at display point (x, y)."""
        if self.mode == CAMERA:
            return
        C, size = self.scene.composite_matrix(), self.scene.display_size()
        self._start, self._composite, self._size = (float(x), float(y)), C, size
        self.message = ""
        if self.mode == SELECT:
            self._op = op_from_modifiers(shift, ctrl)
            P = self.session.cage_positions
            self._display, self._front = project_points(P, C, size)
            self._front = self._in_sight(P, C, size)
            return
        s = self.session
        try:
            self._T0 = s.begin_drag()
        except SelectionError as e:
            self.message = str(e)
            self._start = None
            return
        self._center = s.handle_centroid()
        self._dragging = True
        self.scene.set_dragging(True)
        self.scene.set_moving(s.moving_vertices())

    def move(self, x: float, y: float) -> bool:
        """The mouse moved with the button down; True when the shape changed (a drag frame)."""
        if not self._dragging:
            return False
        self.session.drag_to(self._transform(x, y) @ self._T0)
        return True

    def release(self, x: float, y: float) -> bool:
        """Left button up: the selection taken, or the drag settled and recorded; True when anything changed."""
        start, self._start = self._start, None
        if start is None:
            return False
        if self.mode == SELECT or not self._dragging:
            return self._select(start, (float(x), float(y)))
        s = self.session
        self._dragging = False
        self.scene.set_dragging(False)
        s.drag_to(self._transform(x, y, start) @ self._T0)
        if not np.all(np.isfinite(s.shape_positions)):
            s.cancel_drag()
            self.message = "The deformation became non-finite; the drag was undone."
            return True
        s.end_drag()
        s.finish_settle()  # the settle at release (what hybridedit deform replays), and its undo step
        return True

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

    def _select(self, start: tuple[float, float], end: tuple[float, float]) -> bool:
        display, front = self._display, self._front
        if max(abs(end[0] - start[0]), abs(end[1] - start[1])) <= CLICK_PIXELS:
            hits = nearest_hit(display, front, start, PICK_PIXELS)
            if not hits.any():
                self.message = "No cage point there: the selection is kept"
                return False
        else:
            hits = rectangle_hits(display, front, start, end)
        return self.session.selection.select(self.target, hits, self._op)

    def _transform(self, x: float, y: float, start: tuple[float, float] | None = None) -> np.ndarray:
        """(4, 4) the handle's move since the press at ``start`` (default: this gesture's): the mouse's, in
        the view plane through the handle."""
        D = np.eye(4)
        D[:3, 3] = screen_plane_translation(start or self._start, (float(x), float(y)), self._center,
                                            self._composite, self._size)
        return D


__all__ = ["CAMERA", "DRAG", "Gestures", "HANDLE", "ROI", "SELECT"]
