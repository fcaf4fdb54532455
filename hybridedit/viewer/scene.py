"""The 3D scene: smooth-shaded shape, cage wireframe, coloured cage points, gizmo.

Works on any pyvista plotter (the window's ``QtInteractor`` or an off-screen
``pyvista.Plotter`` for screenshots). The actors are built once per loaded
shape; every frame only rewrites their point arrays in place.

Layers: the shape and the depth-tested cage wireframe are drawn in the main
renderer; a second renderer on layer 1 (same camera, cleared depth) draws on
top of everything: a faint copy of the wireframe (so hidden cage edges show
through), the cage points (all selectable, so all visible) and the gizmo.
"""

from __future__ import annotations

import numpy as np
import pyvista as pv
from numba import njit
from vtkmodules.vtkCommonCore import vtkLookupTable
from vtkmodules.vtkRenderingAnnotation import vtkScalarBarActor
from vtkmodules.vtkRenderingCore import vtkRenderer

from ..mesh import unique_edges
from .gizmo import Gizmo

BACKGROUND_TOP = (0.93, 0.94, 0.96)
BACKGROUND_BOTTOM = (0.62, 0.66, 0.72)
SHAPE_COLOR = np.array([226, 210, 184], dtype=np.float64)
CAGE_COLOR = (0.0, 0.55, 0.62)
STATE_COLORS = np.array([
    [40, 95, 220],   # FIXED: blue
    [60, 190, 70],   # FREE (in the ROI): green
    [255, 115, 20],  # HANDLE: orange
], dtype=np.uint8)
SHAPE_TINT = np.array([0.12, 0.35, 0.60])
POINT_ALPHA = np.array([[170, 30], [255, 70], [255, 70]], dtype=np.uint8)
"""Cage point opacity per state (rows FIXED, FREE, HANDLE), facing / facing away from the camera."""
"""How strongly each state's colour tints the shape vertices it dominates."""
STRETCH_MAX = 20.0
"""Top of the stretch map's colour scale, in percent of relative edge-length change (clipped above)."""


def stretch_lookup_table(top: float = STRETCH_MAX) -> vtkLookupTable:
    """Blue (no stretch) through green and yellow to red (``top`` percent or more)."""
    lut = vtkLookupTable()
    lut.SetNumberOfTableValues(256)
    lut.SetHueRange(0.66, 0.0)
    lut.SetSaturationRange(0.85, 0.85)
    lut.SetValueRange(0.95, 0.95)
    lut.SetTableRange(0.0, top)
    lut.Build()
    return lut


@njit(cache=True)
def _vertex_normals(V, F, out):
    """Area-weighted unit vertex normals of triangles F over points V, written into out."""
    n = V.shape[0]
    acc = np.zeros((n, 3))
    for f in range(F.shape[0]):
        i, j, k = F[f, 0], F[f, 1], F[f, 2]
        ax, ay, az = V[j, 0] - V[i, 0], V[j, 1] - V[i, 1], V[j, 2] - V[i, 2]
        bx, by, bz = V[k, 0] - V[i, 0], V[k, 1] - V[i, 1], V[k, 2] - V[i, 2]
        nx, ny, nz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
        for v in (i, j, k):
            acc[v, 0] += nx
            acc[v, 1] += ny
            acc[v, 2] += nz
    for v in range(n):
        L = np.sqrt(acc[v, 0] ** 2 + acc[v, 1] ** 2 + acc[v, 2] ** 2)
        if L > 0.0:
            out[v, 0], out[v, 1], out[v, 2] = acc[v, 0] / L, acc[v, 1] / L, acc[v, 2] / L
        else:
            out[v, 0], out[v, 1], out[v, 2] = 0.0, 0.0, 0.0


def vertex_normals(V: np.ndarray, faces: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """Area-weighted unit vertex normals (n, 3), written into ``out`` (float32 or float64) when given."""
    V = np.ascontiguousarray(V, dtype=np.float64)
    if out is None:
        out = np.empty((len(V), 3))
    _vertex_normals(V, np.ascontiguousarray(faces, dtype=np.int64), out)
    return out


def shape_tint(states: np.ndarray, dominant: np.ndarray) -> np.ndarray:
    """Per shape vertex RGB (uint8): the base colour tinted by its dominant cage vertex's state."""
    s = np.asarray(states)[dominant]
    w = SHAPE_TINT[s][:, None]
    rgb = (1.0 - w) * SHAPE_COLOR + w * STATE_COLORS[s].astype(np.float64)
    return np.clip(np.rint(rgb), 0, 255).astype(np.uint8)


def _array_modified(poly: pv.PolyData, name: str) -> None:
    poly.GetPointData().GetArray(name).Modified()


class Scene:
    """The actors of one loaded shape on a pyvista plotter.

    Parameters
    ----------
    plotter : a pyvista plotter (``pyvistaqt.QtInteractor`` or ``pyvista.Plotter``).
    """

    def __init__(self, plotter) -> None:
        self.pl = plotter
        self.renderer = plotter.renderer
        self.renderer.set_background(BACKGROUND_BOTTOM, top=BACKGROUND_TOP)
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
        self.shape: pv.PolyData | None = None
        self.cage_poly: pv.PolyData | None = None
        self.points_poly: pv.PolyData | None = None
        self._cage_faces = np.zeros((0, 3), dtype=np.int64)
        self._cage_pos = np.zeros((0, 3))
        self._cage_normals: np.ndarray | None = None
        self._states = np.zeros(0, dtype=np.int64)
        self._actors: list = []
        self._overlay_actors: list = []
        self.cage_visible = True
        self.stretch_visible = False
        self.stretch_lut = stretch_lookup_table()
        bar = vtkScalarBarActor()
        bar.SetLookupTable(self.stretch_lut)
        bar.SetTitle("edge stretch %")
        bar.SetNumberOfLabels(5)
        bar.SetLabelFormat("%.0f")
        bar.SetMaximumWidthInPixels(70)
        bar.SetMaximumHeightInPixels(320)
        bar.SetPosition(0.9, 0.08)
        bar.SetWidth(0.08)
        bar.SetHeight(0.45)
        for tp in (bar.GetTitleTextProperty(), bar.GetLabelTextProperty()):
            tp.SetColor(0.1, 0.1, 0.12)
            tp.SetShadow(False)
            tp.SetItalic(False)
        bar.SetVisibility(False)
        bar.SetPickable(False)
        self.stretch_bar = bar
        self.overlay.AddViewProp(bar)

    # ------------------------------------------------------------------ building
    def clear(self) -> None:
        """Remove the actors of the current shape."""
        for a in self._actors:
            self.renderer.RemoveActor(a)
        for a in self._overlay_actors:
            self.overlay.RemoveActor(a)
        self._actors, self._overlay_actors = [], []
        self.gizmo.remove()
        self.shape = self.cage_poly = self.points_poly = None

    def load(self, shape_vertices: np.ndarray, faces: np.ndarray, cage_vertices: np.ndarray,
             cage_faces: np.ndarray, states: np.ndarray, dominant: np.ndarray) -> None:
        """Build the actors for a shape and its cage (replacing any previous ones).

        Parameters
        ----------
        shape_vertices : (n, 3) current shape; faces : (m, 3) its triangles.
        cage_vertices : (c, 3) current cage pose; cage_faces : (k, 3).
        states : (c,) cage vertex states; dominant : (n,) dominant cage vertex per shape vertex.
        """
        self.clear()
        self._faces = np.ascontiguousarray(faces, dtype=np.int64)
        self._dominant = np.asarray(dominant)

        V = np.asarray(shape_vertices, dtype=np.float64)
        shape = pv.PolyData(V.astype(np.float32), faces=np.hstack(
            [np.full((len(faces), 1), 3, dtype=np.int64), self._faces]).ravel())
        shape.point_data["Normals"] = vertex_normals(V, self._faces).astype(np.float32)
        shape.GetPointData().SetActiveNormals("Normals")
        shape.point_data["tint"] = shape_tint(states, self._dominant)
        shape.point_data["stretch"] = np.zeros(len(V), dtype=np.float32)
        shape.point_data.active_scalars_name = "tint"
        self.shape = shape
        mapper = pv.DataSetMapper(shape)
        mapper.SetColorModeToDirectScalars()
        mapper.SetScalarModeToUsePointData()
        mapper.scalar_visibility = True
        self.shape_mapper = mapper
        actor = pv.Actor(mapper=mapper)
        actor.prop.interpolation = "gouraud"
        actor.prop.ambient = 0.18
        actor.prop.diffuse = 0.85
        actor.prop.specular = 0.08
        actor.prop.specular_power = 20.0
        actor.SetPickable(False)
        self.shape_actor = actor
        self.renderer.AddActor(actor)
        self._actors.append(actor)

        edges = unique_edges(cage_faces)
        P = np.asarray(cage_vertices, dtype=np.float64).astype(np.float32)
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

        pts = pv.PolyData(P.copy())
        pts.verts = np.hstack([np.ones((len(P), 1), dtype=np.int64), np.arange(len(P))[:, None]]).ravel()
        rgba = np.full((len(P), 4), 255, dtype=np.uint8)
        rgba[:, :3] = STATE_COLORS[np.asarray(states)]
        pts.point_data["state"] = rgba
        pts.point_data.active_scalars_name = "state"
        self._cage_faces = np.ascontiguousarray(cage_faces, dtype=np.int64)
        self._cage_pos = np.asarray(cage_vertices, dtype=np.float64).copy()
        self._cage_normals = None
        self._states = np.asarray(states, dtype=np.int64).copy()
        self.points_poly = pts
        pmapper = pv.DataSetMapper(pts)
        pmapper.SetColorModeToDirectScalars()
        pmapper.scalar_visibility = True
        pactor = pv.Actor(mapper=pmapper)
        pactor.prop.render_points_as_spheres = True
        pactor.prop.point_size = 8.0 if len(P) <= 400 else (6.0 if len(P) <= 1500 else 5.0)
        pactor.prop.lighting = False
        pactor.SetPickable(False)
        self.overlay.AddActor(pactor)
        self.points_actor = pactor
        self._overlay_actors += [ghost, pactor]

        lo, hi = V.min(axis=0), V.max(axis=0)
        self.gizmo.build(0.12 * float(np.linalg.norm(hi - lo)))
        self.set_cage_visible(self.cage_visible)
        self.set_stretch_visible(self.stretch_visible)

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

    # ------------------------------------------------------------------ updates
    def update_shape(self, V: np.ndarray) -> None:
        """Write new shape positions (n, 3) and normals into the shape actor, in place."""
        if self.shape is None:
            return
        pts = self.shape.points
        pts[:] = V
        self.shape.GetPoints().Modified()
        normals = self.shape.point_data["Normals"]
        vertex_normals(V, self._faces, out=normals)
        _array_modified(self.shape, "Normals")

    def update_cage(self, P: np.ndarray) -> None:
        """Write a new cage pose (c, 3) into the wireframe and the points, in place."""
        if self.cage_poly is None:
            return
        for poly in (self.cage_poly, self.points_poly):
            poly.points[:] = P
            poly.GetPoints().Modified()
        self._cage_pos[:] = P
        self._cage_normals = None

    def update_states(self, states: np.ndarray) -> None:
        """Recolour the cage points and the shape tint for new cage vertex states."""
        if self.shape is None:
            return
        s = np.asarray(states)
        self._states = s.astype(np.int64)
        self.points_poly.point_data["state"][:, :3] = STATE_COLORS[s]
        _array_modified(self.points_poly, "state")
        self.shape.point_data["tint"][:] = shape_tint(s, self._dominant)
        _array_modified(self.shape, "tint")

    def update_stretch(self, percent: np.ndarray) -> None:
        """Write per shape vertex stretch values (n,), in percent, for the stretch map."""
        if self.shape is None:
            return
        self.shape.point_data["stretch"][:] = percent
        _array_modified(self.shape, "stretch")

    def set_stretch_visible(self, visible: bool) -> None:
        """Colour the shape by the "stretch" array with a colour bar, or back to the selection tint."""
        self.stretch_visible = bool(visible)
        self.stretch_bar.SetVisibility(self.stretch_visible and self.shape is not None)
        if self.shape is None:
            return
        m = self.shape_mapper
        if self.stretch_visible:
            self.shape.point_data.active_scalars_name = "stretch"
            m.SetLookupTable(self.stretch_lut)
            m.SetUseLookupTableScalarRange(True)
            m.SetColorModeToMapScalars()
        else:
            self.shape.point_data.active_scalars_name = "tint"
            m.SetColorModeToDirectScalars()
        m.Modified()

    def set_cage_visible(self, visible: bool) -> None:
        """Show or hide the cage wireframe and points."""
        self.cage_visible = bool(visible)
        for a in ("cage_front", "cage_ghost", "points_actor"):
            actor = getattr(self, a, None)
            if actor is not None and self.cage_poly is not None:
                actor.SetVisibility(self.cage_visible)

    # ------------------------------------------------------------------ camera
    def reset_camera(self, tilted: bool = True) -> None:
        """Frame the shape: a front view (looking down -Z, Y up), slightly turned when ``tilted``."""
        if self.shape is None:
            return
        self.renderer.view_xy(render=False)
        cam = self.renderer.GetActiveCamera()
        if tilted:
            cam.Elevation(12.0)
            cam.Azimuth(-18.0)
            cam.OrthogonalizeViewUp()
        self.renderer.ResetCamera(self.shape.bounds)
        cam.Zoom(1.1)

    def _before_render(self, *_args) -> None:
        self._fade_back_points()
        self._fit_clipping()

    def _fade_back_points(self) -> None:
        """Cage points facing away from the camera are drawn faintly (all stay selectable)."""
        if self.points_poly is None or not self.cage_visible:
            return
        if self._cage_normals is None:
            self._cage_normals = vertex_normals(self._cage_pos, self._cage_faces)
        cam = self.renderer.GetActiveCamera()
        if cam.GetParallelProjection():
            facing = self._cage_normals @ -np.asarray(cam.GetDirectionOfProjection()) > 0
        else:
            to_cam = np.asarray(cam.GetPosition()) - self._cage_pos
            facing = np.einsum("ij,ij->i", self._cage_normals, to_cam) > 0
        alpha = POINT_ALPHA[self._states, np.where(facing, 0, 1)]
        rgba = self.points_poly.point_data["state"]
        if not np.array_equal(rgba[:, 3], alpha):
            rgba[:, 3] = alpha
            _array_modified(self.points_poly, "state")

    def _fit_clipping(self) -> None:
        """Clipping range covering both renderers' props (the overlay shares the camera)."""
        b = np.array(self.renderer.ComputeVisiblePropBounds())
        o = np.array(self.overlay.ComputeVisiblePropBounds())
        if o[0] <= o[1]:
            if b[0] > b[1]:
                b = o
            else:
                b[0::2] = np.minimum(b[0::2], o[0::2])
                b[1::2] = np.maximum(b[1::2], o[1::2])
        if b[0] <= b[1]:
            self.renderer.ResetCameraClippingRange(*b)

    def composite_matrix(self) -> np.ndarray:
        """The camera's world -> NDC matrix for the current view, (4, 4)."""
        cam = self.renderer.GetActiveCamera()
        m = cam.GetCompositeProjectionTransformMatrix(self.renderer.GetTiledAspectRatio(), -1, 1)
        return pv.array_from_vtkmatrix(m)

    def display_size(self) -> tuple[int, int]:
        """The view's size in display pixels."""
        w, h = self.renderer.GetSize()
        return int(w), int(h)
