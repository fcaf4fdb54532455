"""The 3D scene: the smooth-shaded shape, the selection as a tint on it, a few cage points, the gizmo.

Works on any pyvista plotter (the window's ``QtInteractor`` or an off-screen
``pyvista.Plotter`` for screenshots). The actors are built once per loaded
shape; every frame only rewrites the moving part of their point arrays in
place (:mod:`hybridedit.core.region_metrics`).

What is drawn: the shape, tinted blue where it is held fixed and orange where
it is a handle (the faces whose vertices share one of the engine's vertex roles;
one plain-coloured actor per role, :mod:`.shape_parts`); cage points only where
they help (the ROI and the handle, and all points near the cursor in Select
mode), a dense ROI's thinned out on screen (:mod:`.point_thinning`), none while
dragging unless asked (View > Show Cage Points, Hide Points While Dragging);
the cage wireframe on request (View > Show Cage Wireframe). The colours
are :mod:`.palette`'s.

Layers: the shape and the depth-tested cage wireframe are drawn in the main
renderer; a second renderer on layer 1 (same camera, cleared depth) draws on
top of everything: a faint copy of the wireframe (so hidden cage edges show
through), the cage points and the gizmo.
"""

from __future__ import annotations

import time

import numpy as np
import pyvista as pv
from vtkmodules.vtkRenderingCore import vtkRenderer

from ...core.mesh import unique_edges
from ...deform.roles import FIXED, FREE
from ..model.gizmo import RING_RATIO
from .gizmo_actors import Gizmo
from .pivot_marker import PivotMarker
from .palette import (
    BACKGROUND, CAGE_COLOR, POINT_ALPHA, ROLE_COLORS, SHAPE_COLOR, role_rows, shape_tint, stretch_colour_bar,
    stretch_lookup_table,
)
from ...core.bounds import points_box
from ...core.facing import front_direction
from ...core.region_metrics import ShapeMetrics
from .point_thinning import CELL_WIDTHS, THIN_FROM, one_per_cell
from .shape_parts import ShapeParts


def _union(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    return np.minimum(a[0], b[0]), np.maximum(a[1], b[1])


def _array_modified(poly: pv.PolyData, name: str) -> None:
    poly.GetPointData().GetArray(name).Modified()


POINT_PIXELS = (2.0, 8.0)
"""Smallest and largest drawn size of a cage point, in pixels."""
POINT_SPACING = 0.4
"""A cage point is drawn this fraction of the cage's median edge wide (as seen on screen): dots with room
between them, so that the ROI of a dense cage (25,000 points) tints the surface instead of hiding it."""


VIEWS = ("front", "back", "right", "left", "top", "bottom")
"""The sides the shape can be looked at from (View menu; numpad 1, 3, 7, with Ctrl the opposite side)."""


def view_directions(up: str, view: str, front: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(direction from the shape to the camera, the camera's up) of a view of a shape with ``up`` up
    whose front faces ``front`` (default: :func:`hybridedit.core.facing.conventional_front`); its right
    is up x front."""
    from ...core.facing import conventional_front
    from ...core.up_axis import axis_vector

    u = axis_vector(up)
    front = conventional_front(up) if front is None else front
    right = np.cross(u, front)
    return {"front": (front, u), "back": (-front, u), "right": (right, u), "left": (-right, u),
            "top": (u, -front), "bottom": (-u, front)}[view]


class Scene:
    """The actors of one loaded shape on a pyvista plotter.

    Parameters
    ----------
    plotter : a pyvista plotter (the view's :class:`~.view.ScenePlotter` or an off-screen ``pyvista.Plotter``).
    """

    def __init__(self, plotter) -> None:
        self.pl = plotter
        self.renderer = plotter.renderer
        self.renderer.set_background(BACKGROUND)
        # one light at the camera: cheap per pixel (software OpenGL) and it lights what you look at
        self.renderer.remove_all_lights()
        self.renderer.add_light(pv.Light(light_type="headlight"))
        ren_win = plotter.render_window
        ren_win.SetNumberOfLayers(2)
        self.overlay = vtkRenderer()
        self.overlay.SetLayer(1)
        self.overlay.InteractiveOff()
        self.overlay.SetActiveCamera(self.renderer.GetActiveCamera())
        # translucent lines and points need no order-independent transparency (extra full-window passes)
        self.overlay.SetUseDepthPeeling(False)
        self.overlay.SetUseOIT(False)
        self.renderer.SetUseOIT(False)
        ren_win.AddRenderer(self.overlay)
        self.renderer.AddObserver("StartEvent", self._before_render)
        self.gizmo = Gizmo(self.overlay)
        self.pivot = PivotMarker(self.overlay)  # the Pose tool's joint
        self.shape: pv.PolyData | None = None
        self.parts: ShapeParts | None = None
        self.look = None  # what the file says the shape looks like (.look.Look), or None
        self._shape_roles = np.zeros(0, dtype=np.int8)
        self._shape_bounds = self._next_bounds = points_box(np.zeros((0, 3)))
        self._still_bounds: tuple[np.ndarray, np.ndarray] | None = None  # the vertices a drag leaves
        self.cage_poly: pv.PolyData | None = None
        self.points_poly: pv.PolyData | None = None
        self.points_actor: pv.Actor | None = None
        #: the shape's up axis ("+Y", "+Z", ...: :data:`hybridedit.core.up_axis.AXES`); the views follow it
        self.up_axis = "+Y"
        self._front: tuple[str, np.ndarray] | None = None  # (up axis, the front it tells) of this shape
        self._cage_faces = np.zeros((0, 3), dtype=np.int64)
        self._cage_pos = np.zeros((0, 3))
        self._cage_bounds: tuple[np.ndarray, np.ndarray] | None = None
        self._cage_normals: np.ndarray | None = None
        self._cage_roles = np.zeros(0, dtype=np.int64)
        self._actors: list = []
        self._overlay_actors: list = []
        self.cage_visible = False
        self.metrics: ShapeMetrics | None = None
        self.cage_spacing = 0.0
        self._near = np.zeros(0, dtype=bool)
        self._shown_points = np.zeros(0, dtype=np.int64)
        self._drawn_points = np.zeros(0, dtype=np.int64)
        #: View > Show Cage Points; View > Hide Points While Dragging; a drag under way (:meth:`set_dragging`)
        self.points_visible = True
        self.hide_points_dragging = True
        self.dragging = False
        self.stretch_visible = False
        self.stretch_lut = stretch_lookup_table()
        self.stretch_bar = stretch_colour_bar(self.stretch_lut)
        self.overlay.AddViewProp(self.stretch_bar)

    # ------------------------------------------------------------------ building
    def clear(self) -> None:
        """Remove the actors of the current shape."""
        for a in self._actors:
            self.renderer.RemoveActor(a)
        for a in self._overlay_actors:
            self.overlay.RemoveActor(a)
        self._actors, self._overlay_actors = [], []
        if self.parts is not None:
            self.parts.remove()
            self.parts = None
        self.gizmo.remove()
        self.pivot.place(None)
        self.shape = self.cage_poly = self.points_poly = self.points_actor = None
        self.metrics = None
        self.look = None
        self._front = None

    def show_preview(self, vertices: np.ndarray, faces: np.ndarray) -> None:
        """Show a shape read but not yet bound (its cage and binding are being built): plain, flat shaded,
        framed with its up axis (:attr:`up_axis`) up; replaced by :meth:`load`. Only the camera works on it.

        Parameters
        ----------
        vertices : (n, 3) float; faces : (m, 3) int
        """
        self.clear()
        V = np.ascontiguousarray(vertices, dtype=np.float32)
        poly = pv.PolyData.from_regular_faces(V, np.ascontiguousarray(faces, dtype=np.int64))
        mapper = pv.DataSetMapper(poly)
        mapper.scalar_visibility = False
        actor = pv.Actor(mapper=mapper)
        actor.prop.color = tuple(SHAPE_COLOR / 255.0)
        actor.SetPickable(False)
        self.renderer.AddActor(actor)
        self._actors.append(actor)
        self.shape = poly
        self.points32 = poly.points
        self._shape_bounds = self._next_bounds = self._cage_bounds = points_box(self.points32)
        self._still_bounds = None
        self.reset_camera()

    def load(self, metrics: ShapeMetrics, shape_vertices: np.ndarray, cage_vertices: np.ndarray,
             cage_faces: np.ndarray, cage_roles: np.ndarray, shape_roles: np.ndarray, *, look=None,
             mode: str | None = None) -> None:
        """Build the actors for a shape and its cage (replacing any previous ones).

        Parameters
        ----------
        metrics : the shape's :class:`~hybridedit.core.region_metrics.ShapeMetrics` (faces, and what a drag moves).
        shape_vertices : (n, 3) current shape.
        cage_vertices : (c, 3) current cage pose; cage_faces : (k, 3).
        cage_roles : (c,) cage vertex roles; shape_roles : (n,) shape vertex roles
            (:mod:`hybridedit.deform.roles`: FIXED, FREE, a handle group's).
        look : :class:`~.look.Look` or None, what the file says the shape looks like.
        mode : "texture", "colors" or "plain"; default: what the file has (the look's default).
        """
        self.clear()
        self.metrics = metrics
        V = np.ascontiguousarray(shape_vertices, dtype=np.float64)
        self._build_shape(V, shape_roles, look, mode)
        cage = self._build_wireframe(cage_vertices, cage_faces)
        self._build_points(cage, cage_vertices, cage_faces, cage_roles)
        lo, hi = V.min(axis=0), V.max(axis=0)
        self.gizmo.build(0.12 * float(np.linalg.norm(hi - lo)))
        self.pivot.build(0.01 * float(np.linalg.norm(hi - lo)))
        self.set_cage_visible(self.cage_visible)
        self.set_stretch_visible(self.stretch_visible)

    def _build_shape(self, V: np.ndarray, shape_roles: np.ndarray, look, mode: str | None) -> None:
        """The full-mesh buffers of the shape V (n, 3) and the parts that draw it (:meth:`load`)."""
        shape = pv.PolyData()
        shape.points = V.astype(np.float32)
        normals = np.zeros((len(V), 3), dtype=np.float32)
        self.metrics.write_normals(V, normals, everything=True)
        shape.point_data["Normals"] = normals
        shape.point_data["stretch"] = np.zeros(len(V), dtype=np.float32)
        # the full-mesh buffers the window writes (float32, in place); the parts draw copies of them
        self.shape = shape
        self.points32 = shape.points
        self.normals32 = shape.point_data["Normals"]
        self.stretch32 = shape.point_data["stretch"]
        assert self.points32.dtype == np.float32 and self.normals32.dtype == np.float32
        self.look = look
        if mode is None:
            mode = look.default_mode if look is not None else "plain"
        self.parts = self._make_parts(mode)
        self._shape_roles = np.asarray(shape_roles).copy()
        self.parts.set_roles(shape_roles, self.points32, self.normals32, self.stretch32)
        self._shape_bounds = self._next_bounds = points_box(self.points32)
        self._still_bounds = None

    def _make_parts(self, mode: str) -> ShapeParts:
        """The shape's parts drawn in ``mode``, with no role split yet (:meth:`ShapeParts.set_roles`)."""
        parts = ShapeParts(self.renderer, self.metrics.faces, len(self.points32), shape_tint, self.stretch_lut,
                           look=self.look, mode=mode)
        parts.stretch_visible = self.stretch_visible
        return parts

    def _build_wireframe(self, cage_vertices: np.ndarray, cage_faces: np.ndarray) -> pv.PolyData:
        """The cage's edges, drawn depth-tested and faintly on top (:meth:`load`); returns their polydata."""
        edges = unique_edges(cage_faces)
        P = np.asarray(cage_vertices, dtype=np.float64).astype(np.float32)
        #: median cage edge length: how far from the surface cage points lie is a fraction of it
        self.cage_spacing = float(np.median(np.linalg.norm(P[edges[:, 0]] - P[edges[:, 1]], axis=1))) \
            if len(edges) else 0.0
        cage = pv.PolyData(P.copy())
        cage.lines = np.hstack([np.full((len(edges), 1), 2, dtype=np.int64), edges]).ravel()
        self.cage_poly = cage
        front = self._line_actor(cage, opacity=0.6, width=1.0)
        front.mapper.SetResolveCoincidentTopologyToPolygonOffset()
        front.mapper.SetRelativeCoincidentTopologyLineOffsetParameters(0, -4)
        self.renderer.AddActor(front)
        ghost = self._line_actor(cage, opacity=0.2, width=1.0)
        self.overlay.AddActor(ghost)
        self.cage_front, self.cage_ghost = front, ghost
        self._actors.append(front)
        self._overlay_actors.append(ghost)
        return cage

    def _build_points(self, cage: pv.PolyData, cage_vertices: np.ndarray, cage_faces: np.ndarray,
                      cage_roles: np.ndarray) -> None:
        """The cage points, coloured by role, on the wireframe's point buffer (:meth:`load`)."""
        pts = pv.PolyData()
        pts.SetPoints(cage.GetPoints())  # one cage pose buffer for the wireframe and the points
        self._cage_points32 = cage.points  # (a view of it, written in place)
        rgba = np.full((cage.n_points, 4), 255, dtype=np.uint8)
        rgba[:, :3] = ROLE_COLORS[role_rows(cage_roles)]
        pts.point_data["role"] = rgba
        pts.point_data.active_scalars_name = "role"
        self._rgba = pts.point_data["role"]  # (a view of the drawn colours, written in place)
        self._cage_faces = np.ascontiguousarray(cage_faces, dtype=np.int64)
        self._cage_pos = np.asarray(cage_vertices, dtype=np.float64).copy()
        self._cage_metrics = ShapeMetrics(self._cage_pos, self._cage_faces)  # (its vertex-face incidence)
        # the frame thread's own copy: its normals buffer is not shared with the UI thread's
        self._cage_metrics_frames = ShapeMetrics(self._cage_pos, self._cage_faces)
        self._cage_normals = None
        self._cage_bounds = points_box(self._cage_pos)
        self._cage_roles = np.asarray(cage_roles, dtype=np.int64).copy()
        self._near = np.zeros(cage.n_points, dtype=bool)
        self._shown_points = np.zeros(0, dtype=np.int64)
        self._drawn_points = np.zeros(0, dtype=np.int64)
        self.points_poly = pts
        pmapper = pv.DataSetMapper(pts)
        pmapper.SetColorModeToDirectScalars()
        pmapper.scalar_visibility = True
        pactor = pv.Actor(mapper=pmapper)
        pactor.prop.render_points_as_spheres = True
        pactor.prop.point_size = POINT_PIXELS[1]  # (fitted to the cage's spacing on screen before each render)
        pactor.prop.lighting = False
        pactor.SetPickable(False)
        self.overlay.AddActor(pactor)
        self.points_actor = pactor
        self._overlay_actors.append(pactor)
        self._update_point_cells()
        self._show_points_actor()

    @staticmethod
    def _line_actor(poly: pv.PolyData, opacity: float, width: float) -> pv.Actor:
        mapper = pv.DataSetMapper(poly)
        mapper.scalar_visibility = False
        actor = pv.Actor(mapper=mapper)
        actor.prop.color = CAGE_COLOR
        actor.prop.opacity = opacity
        actor.prop.line_width = width
        actor.prop.lighting = False
        actor.SetPickable(False)
        return actor

    # ------------------------------------------------------------------ which cage points are drawn
    @property
    def shown_points(self) -> np.ndarray:
        """Indices of the cage points shown: the ROI, the handle and those near the cursor, (k,) int64
        (a dense ROI's are thinned on screen when drawn: :attr:`drawn_points`)."""
        return self._shown_points

    @property
    def drawn_points(self) -> np.ndarray:
        """Indices of the cage points the last frame drew: :attr:`shown_points` with a dense ROI thinned
        out on screen (:mod:`.point_thinning`), (d,) int64."""
        return self._drawn_points

    @property
    def points_drawn(self) -> bool:
        """The cage points actor is drawn: Show Cage Points on, and no drag under way that hides it."""
        return self.points_actor is not None and bool(self.points_actor.GetVisibility())

    def _update_point_cells(self) -> None:
        """The points shown are the ROI, the handle and those near the cursor: all drawn until the next
        frame thins them (:meth:`_draw_point_cells`)."""
        show = np.flatnonzero((self._cage_roles != FIXED) | self._near)
        if np.array_equal(show, self._shown_points) and np.array_equal(show, self._drawn_points) \
                and self.points_poly.n_verts == len(show):
            return
        self._shown_points = show
        self._set_point_cells(show)

    def _set_point_cells(self, idx: np.ndarray) -> None:
        if not (np.array_equal(idx, self._drawn_points) and self.points_poly.n_verts == len(idx)):
            self._drawn_points = idx
            self.points_poly.verts = np.column_stack([np.ones(len(idx), dtype=np.int64), idx]).ravel()

    def _draw_point_cells(self, facing: np.ndarray) -> np.ndarray:
        """Draw :attr:`shown_points`, a dense ROI's thinned out on screen, points facing the camera kept
        first (``facing``: (k,) bool, of the shown points); returns which of them are drawn, (k,) bool."""
        show = self._shown_points
        drawn = np.ones(len(show), dtype=bool)
        roi = (self._cage_roles[show] == FREE) & ~self._near[show]
        if np.count_nonzero(roi) > THIN_FROM:
            rows = np.flatnonzero(roi)
            rows = rows[np.argsort(~facing[rows], kind="stable")]  # facing first, then by index
            C = self.composite_matrix()
            X = self._cage_pos[show[rows]] @ C[:3, :3].T + C[:3, 3]
            wh = np.asarray(self.display_size(), dtype=np.float64)
            ndc = X[:, :2] / np.maximum(self._cage_pos[show[rows]] @ C[3, :3] + C[3, 3], 1e-300)[:, None]
            kept = one_per_cell((ndc + 1.0) * 0.5 * wh, CELL_WIDTHS * self.point_pixels())
            drawn[rows[~kept]] = False
        self._set_point_cells(show[drawn])
        return drawn

    def set_points_visible(self, visible: bool) -> None:
        """View > Show Cage Points: draw the ROI, handle and nearby cage points, or none."""
        self.points_visible = bool(visible)
        self._show_points_actor()

    def set_hide_points_dragging(self, hide: bool) -> None:
        """View > Hide Points While Dragging: a drag under way draws no cage points (the pose in full view)."""
        self.hide_points_dragging = bool(hide)
        self._show_points_actor()

    def set_dragging(self, dragging: bool) -> None:
        """A drag began (True) or ended (False): the points hide meanwhile when :attr:`hide_points_dragging`."""
        self.dragging = bool(dragging)
        self._show_points_actor()

    def _show_points_actor(self) -> None:
        if self.points_actor is not None:
            self.points_actor.SetVisibility(self.points_visible and not (self.dragging and self.hide_points_dragging))

    def set_points_near(self, near: np.ndarray | None) -> bool:
        """Also draw the cage points of the (c,) mask ``near`` (None: none); True when that changed."""
        if self.points_poly is None:
            return False
        m = np.zeros(len(self._cage_roles), dtype=bool) if near is None else np.asarray(near, dtype=bool)
        if np.array_equal(m, self._near):
            return False
        self._near = m
        self._update_point_cells()
        return True

    # ------------------------------------------------------------------ updates
    def set_moving(self, moving: np.ndarray | None) -> None:
        """The shape vertices the next drags can move ((k,) int; None: all): only they are rewritten."""
        if self.metrics is not None:
            self.metrics.set_moving(moving)
            self.parts.set_changed(None if moving is None else self.metrics.normal_vertices)
            self._still_bounds = None
            if moving is not None:
                in_motion = np.zeros(len(self.points32), dtype=bool)
                in_motion[self.metrics.moving] = True
                self._still_bounds = points_box(self.points32, skip=in_motion)

    def update_shape(self, V: np.ndarray, *, everything: bool = False) -> tuple[float, float]:
        """Write shape positions (n, 3) and their normals into the buffers VTK draws, in place.

        Only the moving region (:meth:`set_moving`) unless ``everything``. Returns the
        seconds spent on (normals, writing the points and telling VTK).
        """
        if self.shape is None:
            return 0.0, 0.0
        normals_s, points_s = self.write_shape(V, everything=everything)
        return normals_s, points_s + self.show_shape(everything=everything)

    def write_shape(self, V: np.ndarray, *, everything: bool = False) -> tuple[float, float]:
        """The half of :meth:`update_shape` that may run on a worker thread (no VTK calls): positions
        and normals into the full-mesh float32 buffers. Returns seconds for (normals, points)."""
        t0 = time.perf_counter()
        self.metrics.write_points(V, self.points32, everything=everything)
        if everything or self._still_bounds is None:
            self._next_bounds = points_box(self.points32)
        else:
            self._next_bounds = _union(self._still_bounds, self.metrics.moving_box(self.points32))
        t1 = time.perf_counter()
        self.metrics.write_normals(V, self.normals32, everything=everything)
        return time.perf_counter() - t1, t1 - t0

    def show_shape(self, *, everything: bool = False) -> float:
        """The other half (UI thread): the changed rows into the drawn parts; returns its seconds."""
        t0 = time.perf_counter()
        self.shape.GetPoints().Modified()
        self._shape_bounds = self._next_bounds
        self.parts.copy_rows(self.points32, self.normals32, everything=everything)
        return time.perf_counter() - t0

    def cage_geometry(self, P: np.ndarray) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray]]:
        """The vertex normals ((c, 3) float32) and bounds of a cage pose P (c, 3), for
        :meth:`update_cage`: the part of it that may run on the frame thread (no VTK calls)."""
        normals = np.zeros((len(P), 3), dtype=np.float32)
        self._cage_metrics_frames.write_normals(P, normals, everything=True)
        return normals, points_box(P)

    def update_cage(self, P: np.ndarray, geometry=None) -> None:
        """Write a new cage pose (c, 3) into the wireframe and the points, in place; ``geometry``
        is its :meth:`cage_geometry` when the frame thread made it (else it is made when needed)."""
        if self.cage_poly is None:
            return
        self._cage_points32[:] = P
        self.cage_poly.GetPoints().Modified()  # (the points' too: they share it)
        self._cage_pos[:] = P
        self._cage_normals, self._cage_bounds = (None, None) if geometry is None else geometry

    def update_roles(self, cage_roles: np.ndarray, shape_roles: np.ndarray) -> None:
        """New selection: recolour the cage points by their (c,) roles and tint the shape by its (n,) roles."""
        if self.shape is None:
            return
        self._cage_roles = np.asarray(cage_roles).astype(np.int64)
        self._rgba[:, :3] = ROLE_COLORS[role_rows(self._cage_roles)]
        _array_modified(self.points_poly, "role")
        self._update_point_cells()
        shape_roles = np.asarray(shape_roles)
        if shape_roles.shape == self._shape_roles.shape and np.array_equal(shape_roles, self._shape_roles):
            return  # the shape's tint is as it was (undo of a drag, a refresh): its parts stay (8 s at 11M)
        self._shape_roles = shape_roles.copy()
        self.parts.set_roles(shape_roles, self.points32, self.normals32, self.stretch32)

    @property
    def look_mode(self) -> str:
        """How the shape is drawn: "texture", "colors" or "plain"."""
        return "plain" if self.parts is None else self.parts.mode

    def look_modes(self) -> tuple[str, ...]:
        """The modes the loaded shape can be drawn in (what its file has, and "plain")."""
        return ("plain",) if self.look is None else self.look.modes()

    def set_look_mode(self, mode: str) -> None:
        """Draw the shape with its texture, its file's colours, or plain (a mode it has)."""
        if self.parts is None or mode not in self.look_modes() or mode == self.parts.mode:
            return
        changed = self.parts.changed
        self.parts.remove()
        self.parts = self._make_parts(mode)
        self.parts.set_changed(changed)
        self.parts.set_roles(self._shape_roles, self.points32, self.normals32, self.stretch32)

    def stretch_modified(self) -> None:
        """The stretch buffer (:attr:`stretch32`) was written."""
        if self.parts is not None:
            self.parts.copy_stretch(self.stretch32)

    def set_stretch_visible(self, visible: bool) -> None:
        """Colour the shape by the "stretch" array with a colour bar, or back to the selection tint."""
        self.stretch_visible = bool(visible)
        self.stretch_bar.SetVisibility(self.stretch_visible and self.shape is not None)
        if self.shape is None:
            return
        self.parts.set_stretch_visible(self.stretch_visible)

    def set_cage_visible(self, visible: bool) -> None:
        """Show or hide the cage wireframe (the ROI and handle points stay)."""
        self.cage_visible = bool(visible)
        for a in ("cage_front", "cage_ghost"):
            actor = getattr(self, a, None)
            if actor is not None and self.cage_poly is not None:
                actor.SetVisibility(self.cage_visible)

    # ------------------------------------------------------------------ camera
    def reset_camera(self, tilted: bool = True) -> None:
        """Frame the shape: a front view, slightly turned when ``tilted``."""
        self.set_view("front", tilted=tilted)

    def set_view(self, view: str, *, tilted: bool = False) -> None:
        """Look at the whole shape from one side (:data:`VIEWS`), as Blender's numpad views do, with
        :attr:`up_axis` up on screen (the top and bottom views: the front down on screen); its front is
        the side :func:`hybridedit.core.facing.front_direction` tells."""
        if view not in VIEWS:
            raise ValueError(f"view must be one of {VIEWS}, got {view!r}")
        if self.shape is None:
            return
        if self._front is None or self._front[0] != self.up_axis:  # (told once per shape and up axis)
            self._front = (self.up_axis, front_direction(self.points32, self.up_axis))
        direction, screen_up = view_directions(self.up_axis, view, self._front[1])
        cam = self.renderer.GetActiveCamera()
        lo, hi = points_box(self.points32)
        centre = 0.5 * (lo + hi)
        distance = max(float(np.linalg.norm(hi - lo)), 1e-9) * 2.0
        cam.SetFocalPoint(*centre)
        cam.SetPosition(*(centre + distance * direction))
        cam.SetViewUp(*screen_up)
        self.renderer.camera_set = True  # (else pyvista puts its own default view in place at the first render)
        if tilted:
            cam.Elevation(12.0)
            cam.Azimuth(-18.0)
            cam.OrthogonalizeViewUp()
        self.renderer.ResetCamera(self.shape.bounds)
        cam.Zoom(1.1)

    def _before_render(self, *_args) -> None:
        self._fade_back_points()
        self._fit_clipping()
        self._fit_point_size()

    def point_pixels(self) -> float:
        """The cage points' drawn size in pixels: :data:`POINT_SPACING` of the cage's median edge as seen at
        the camera's focal distance, within :data:`POINT_PIXELS` (a dense cage must not hide the surface)."""
        if self.cage_spacing <= 0:
            return POINT_PIXELS[1]
        cam = self.renderer.GetActiveCamera()
        h = max(self.display_size()[1], 1)
        if cam.GetParallelProjection():
            per_unit = h / max(2.0 * cam.GetParallelScale(), 1e-300)
        else:
            per_unit = h / max(2.0 * cam.GetDistance() * np.tan(np.radians(cam.GetViewAngle() / 2.0)), 1e-300)
        return float(np.clip(np.round(2.0 * POINT_SPACING * self.cage_spacing * per_unit) / 2.0, *POINT_PIXELS))

    def _fit_point_size(self) -> None:
        if self.points_actor is not None:
            size = self.point_pixels()
            if self.points_actor.prop.point_size != size:
                self.points_actor.prop.point_size = size

    def _fade_back_points(self) -> None:
        """Cage points facing away from the camera are drawn faintly (Select Through takes the hidden ones);
        a dense ROI is thinned out on screen, those facing the camera kept first."""
        shown = self._shown_points
        if self.points_poly is None or not self.points_drawn:
            return
        if len(shown) == 0:
            self._draw_point_cells(np.zeros(0, dtype=bool))
            return
        if self._cage_normals is None:
            self._cage_normals = np.zeros((len(self._cage_pos), 3), dtype=np.float32)
            self._cage_metrics.write_normals(self._cage_pos, self._cage_normals, everything=True)
        cam = self.renderer.GetActiveCamera()
        normals = self._cage_normals[shown]
        if cam.GetParallelProjection():
            facing = normals @ -np.asarray(cam.GetDirectionOfProjection()) > 0
        else:
            facing = np.einsum("ij,ij->i", normals, np.asarray(cam.GetPosition()) - self._cage_pos[shown]) > 0
        drawn = self._draw_point_cells(facing)
        shown, facing = shown[drawn], facing[drawn]
        alpha = POINT_ALPHA[role_rows(self._cage_roles[shown], len(POINT_ALPHA)), np.where(facing, 0, 1)]
        if not np.array_equal(self._rgba[shown, 3], alpha):  # (only the drawn points' opacity matters)
            self._rgba[shown, 3] = alpha
            _array_modified(self.points_poly, "role")

    def _fit_clipping(self) -> None:
        """Clipping range covering everything drawn: the shape, the cage and the gizmo (the overlay
        shares the camera). From bounds kept up to date by the updates, not from a scan of the
        props' points at every frame (VTK's ComputeVisiblePropBounds: about 3.5 ms a frame at 173K)."""
        if self.shape is None:
            return
        if self._cage_bounds is None:
            self._cage_bounds = points_box(self._cage_pos)
        b = _union(self._shape_bounds, self._cage_bounds)
        g = self.gizmo
        if g.visible:
            r = 1.1 * g.length * max(1.0, RING_RATIO)
            b = _union(b, (g.center - r, g.center + r))
        lo, hi = b
        self.renderer.ResetCameraClippingRange(lo[0], hi[0], lo[1], hi[1], lo[2], hi[2])

    def composite_matrix(self) -> np.ndarray:
        """The camera's world -> NDC matrix for the current view, (4, 4)."""
        cam = self.renderer.GetActiveCamera()
        m = cam.GetCompositeProjectionTransformMatrix(self.renderer.GetTiledAspectRatio(), -1, 1)
        return pv.array_from_vtkmatrix(m)

    def along_sight(self, points: np.ndarray) -> np.ndarray:
        """(k,) how far each of ``points`` (k, 3) lies along the camera's line of sight (world units): which
        part of a selection lies behind another."""
        cam = self.renderer.GetActiveCamera()
        ahead = np.asarray(cam.GetDirectionOfProjection(), dtype=np.float64)
        return (np.asarray(points, dtype=np.float64) - np.asarray(cam.GetPosition(), dtype=np.float64)) @ ahead

    def display_size(self) -> tuple[int, int]:
        """The view's size in display pixels."""
        w, h = self.renderer.GetSize()
        return int(w), int(h)
