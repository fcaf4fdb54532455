"""The shape drawn as one plain-coloured actor per vertex role: fixed, free, and each handle group.

The selection shows on the shape as colour: the fixed region tinted blue, each
handle group in its own colour, the free region in the shape's colour. A
per-vertex colour array on one actor would show the same, but with software
OpenGL an extra per-vertex attribute makes every frame about 7% slower
(benchmarks/window_fps.py; the 173K armadillo: 76 ms against 71 ms plain).
One actor per role, each in a single colour, costs nothing extra: the faces are
split between the actors, and each actor holds only the points its faces use,
so a drag re-uploads only the points of the parts it moves.

A face belongs to the part of its vertices' common role; a face whose vertices
differ in role is drawn in the shape's colour, so the colours change along
face edges.

The full-mesh buffers (points, normals, stretch) stay the truth the window
writes; :meth:`ShapeParts.copy_rows` copies what changed into the parts.
"""

from __future__ import annotations

import numpy as np
import pyvista as pv
from vtkmodules.vtkRenderingCore import vtkPolyDataMapper

from .regional import copy_rows

DISABLE_SHIFT_SCALE = 0
"""vtkOpenGLVertexBufferObject::DISABLE_SHIFT_SCALE: no bounds rescan of the points at every upload."""


def face_roles(faces: np.ndarray, roles: np.ndarray) -> np.ndarray:
    """The part each face is drawn in: its vertices' common role, or 0 (free) when they differ.

    Parameters
    ----------
    faces : (m, 3) int triangles.
    roles : (n,) int vertex roles: -1 fixed, 0 free, g + 1 in handle group g.

    Returns
    -------
    (m,) int64 role of each face.

    Examples
    --------
    >>> face_roles(np.array([[0, 1, 2], [1, 2, 3]]), np.array([-1, -1, -1, 1]))
    array([-1,  0])
    """
    r = np.asarray(roles, dtype=np.int64)[np.asarray(faces)]
    same = (r[:, 0] == r[:, 1]) & (r[:, 1] == r[:, 2])
    return np.where(same, r[:, 0], 0)


class _Part:
    """One role's faces with the points they use (local numbering) and its actor."""

    def __init__(self, role: int, face_rows: np.ndarray, faces: np.ndarray, n: int, colour: np.ndarray) -> None:
        self.role = role
        self.face_rows = face_rows  # (f,) rows of the shape's faces drawn here
        used = np.zeros(n, dtype=bool)
        used[faces] = True
        self.vertices = np.flatnonzero(used)  # (k,) global index of each local point
        self.local = np.full(n, -1, dtype=np.int64)  # (n,) local index of each global vertex, -1 if not here
        self.local[self.vertices] = np.arange(len(self.vertices))
        poly = pv.PolyData()
        poly.points = np.zeros((len(self.vertices), 3), dtype=np.float32)
        poly.faces = np.column_stack([np.full(len(faces), 3, dtype=np.int64), self.local[faces]]).ravel()
        poly.point_data["Normals"] = np.zeros((len(self.vertices), 3), dtype=np.float32)
        poly.GetPointData().SetActiveNormals("Normals")
        poly.point_data["stretch"] = np.zeros(len(self.vertices), dtype=np.float32)
        poly.point_data.active_scalars_name = "stretch"
        self.poly = poly
        self.points = poly.points  # the float32 buffers VTK draws from, written in place
        self.normals = poly.point_data["Normals"]
        self.stretch = poly.point_data["stretch"]
        mapper = vtkPolyDataMapper()
        mapper.SetInputData(poly)
        mapper.SetVBOShiftScaleMethod(DISABLE_SHIFT_SCALE)
        mapper.SetScalarModeToUsePointData()
        mapper.SetColorModeToMapScalars()
        mapper.SetInterpolateScalarsBeforeMapping(False)
        mapper.SetUseLookupTableScalarRange(True)
        actor = pv.Actor(mapper=mapper)
        actor.prop.color = tuple(np.asarray(colour, dtype=np.float64) / 255.0)
        actor.prop.interpolation = "gouraud"
        actor.prop.ambient = 0.18
        actor.prop.diffuse = 0.85
        actor.prop.specular = 0.08
        actor.prop.specular_power = 20.0
        actor.SetPickable(False)
        self.mapper, self.actor = mapper, actor
        self.set_changed(None)

    def set_changed(self, rows: np.ndarray | None) -> None:
        """The global rows a frame rewrites (None: all): ``changed_rows`` (j,) and their ``changed_local``."""
        if rows is None:
            self.changed_rows, self.changed_local = self.vertices, np.arange(len(self.vertices))
            return
        loc = self.local[rows]
        keep = loc >= 0
        self.changed_rows, self.changed_local = rows[keep], loc[keep]

    def copy(self, points: np.ndarray, normals: np.ndarray, everything: bool) -> None:
        if everything:
            self.points[:] = points[self.vertices]
            self.normals[:] = normals[self.vertices]
        elif len(self.changed_rows):
            copy_rows(points, self.changed_rows, self.points, self.changed_local)
            copy_rows(normals, self.changed_rows, self.normals, self.changed_local)
        else:
            return
        self.poly.GetPoints().Modified()
        self.poly.GetPointData().GetArray("Normals").Modified()


class ShapeParts:
    """The shape's actors, one per role present (see the module's description).

    Parameters
    ----------
    renderer : the vtkRenderer to draw in.
    faces : (m, 3) int triangles of the shape; n : its vertex count.
    colour_of : callable mapping an (r,) int array of roles to (r, 3) uint8 colours.
    lut : the stretch map's lookup table.
    """

    def __init__(self, renderer, faces: np.ndarray, n: int, colour_of, lut) -> None:
        self.renderer = renderer
        self.faces = np.ascontiguousarray(faces, dtype=np.int64)
        self.n = int(n)
        self.colour_of = colour_of
        self.lut = lut
        self.parts: list[_Part] = []
        self.stretch_visible = False
        self._changed: np.ndarray | None = None

    def set_roles(self, roles: np.ndarray, points: np.ndarray, normals: np.ndarray, stretch: np.ndarray) -> None:
        """Split the faces by ``roles`` ((n,) int) and fill the parts from the full-mesh buffers
        ``points``, ``normals`` ((n, 3) float32) and ``stretch`` ((n,) float32)."""
        fr = face_roles(self.faces, roles)
        kinds = np.unique(fr)
        colours = self.colour_of(kinds)
        self.remove()
        for role, colour in zip(kinds.tolist(), colours):
            rows = np.flatnonzero(fr == role)
            part = _Part(int(role), rows, self.faces[rows], self.n, colour)
            part.set_changed(self._changed)
            part.copy(points, normals, everything=True)
            part.stretch[:] = stretch[part.vertices]
            self._set_stretch(part)
            self.renderer.AddActor(part.actor)
            self.parts.append(part)

    def remove(self) -> None:
        """Take the actors out of the renderer."""
        for part in self.parts:
            self.renderer.RemoveActor(part.actor)
        self.parts = []

    def set_changed(self, rows: np.ndarray | None) -> None:
        """The (k,) sorted global rows a frame rewrites (None: all of them)."""
        self._changed = None if rows is None else np.asarray(rows, dtype=np.int64)
        for part in self.parts:
            part.set_changed(self._changed)

    def copy_rows(self, points: np.ndarray, normals: np.ndarray, *, everything: bool = False) -> None:
        """Copy the changed rows (all rows when ``everything``) of the full-mesh buffers into the parts."""
        for part in self.parts:
            part.copy(points, normals, everything)

    def copy_stretch(self, stretch: np.ndarray) -> None:
        """Copy the full-mesh stretch buffer ((n,) float32) into the parts."""
        for part in self.parts:
            part.stretch[:] = stretch[part.vertices]
            part.poly.GetPointData().GetArray("stretch").Modified()

    def set_stretch_visible(self, visible: bool) -> None:
        """Colour every part by its stretch values (through the lookup table), or plainly by role."""
        self.stretch_visible = bool(visible)
        for part in self.parts:
            self._set_stretch(part)

    def _set_stretch(self, part: _Part) -> None:
        m = part.mapper
        m.SetLookupTable(self.lut)
        m.SetScalarVisibility(self.stretch_visible)
        m.Modified()

    def face_colours(self) -> np.ndarray:
        """The colour each face is drawn in (without the stretch map), (m, 3) uint8."""
        out = np.zeros((len(self.faces), 3), dtype=np.uint8)
        for part in self.parts:
            out[part.face_rows] = np.rint(np.asarray(part.actor.GetProperty().GetColor()) * 255.0).astype(np.uint8)
        return out

    def drawn_faces(self) -> np.ndarray:
        """How many parts draw each face, (m,) int (1 everywhere when the split is right)."""
        count = np.zeros(len(self.faces), dtype=np.int64)
        for part in self.parts:
            np.add.at(count, part.face_rows, 1)
        return count

    def drawn_points(self, normals: bool = False) -> np.ndarray:
        """Each vertex's position (or normal) as the parts draw it, (n, 3) float32.

        NaN for a vertex no part uses, and where two parts draw it differently.
        """
        out = np.full((self.n, 3), np.nan, dtype=np.float32)
        seen = np.zeros(self.n, dtype=bool)
        for part in self.parts:
            vals = part.normals if normals else part.points
            v = part.vertices
            clash = seen[v] & np.any(out[v] != vals, axis=1)
            out[v] = vals
            out[v[clash]] = np.nan
            seen[v] = True
        return out
