"""The shape drawn as one plain-coloured actor per vertex role: fixed, free, and each handle group.

The selection shows on the shape as colour: the fixed region tinted blue, each
handle group in its own colour, the free region in the shape's colour. A
per-vertex colour array on one actor would show the same, but with software
OpenGL an extra per-vertex attribute makes every frame about 7% slower
(benchmarks/window_fps.py).
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

from ...deform.roles import FIXED, FREE
from ...core.index_sets import unique_in_range, unique_sorted
from ...core.row_copy import copy_rows

DISABLE_SHIFT_SCALE = 0
"""vtkOpenGLVertexBufferObject::DISABLE_SHIFT_SCALE: no bounds rescan of the points at every upload."""


def face_roles(faces: np.ndarray, roles: np.ndarray) -> np.ndarray:
    """The part each face is drawn in: its vertices' common role, or FREE when they differ.

    Parameters
    ----------
    faces : (m, 3) int triangles.
    roles : (n,) int vertex roles (:mod:`hybridedit.deform.roles`: FIXED, FREE, or handle group g's g + 1).

    Returns
    -------
    (m,) int64 role of each face.

    Examples
    --------
    >>> face_roles(np.array([[0, 1, 2], [1, 2, 3]]), np.array([-1, -1, -1, 1]))
    array([-1,  0])
    """
    roles = np.asarray(roles)
    small = np.int16 if roles.size == 0 or max(-int(roles.min()), int(roles.max())) < 2**15 else np.int64
    r = roles.astype(small)[np.asarray(faces)]  # (2 bytes a corner: 132 MB at 11M, not 528)
    same = (r[:, 0] == r[:, 1]) & (r[:, 1] == r[:, 2])
    return np.where(same, r[:, 0], FREE).astype(np.int64)


#: How much of a role's tint shows on a texture or on the file's colours (the rest is the asset's own):
#: enough to read which region is held or moved, little enough to leave the asset readable. At 0.25 a
#: texel keeps at least 81% of each channel under any role's tint (yellow's blue; 74% at 0.35), and the
#: tint multiplies, so the texture's own contrast is kept.
TINT_ON_ASSET = 0.25


def _tinted(colour: np.ndarray, amount: float) -> np.ndarray:
    """A colour (3,) uint8 moved ``amount`` of the way from white towards ``colour``, as [0, 1] floats:
    the factor VTK multiplies a texture by."""
    c = np.asarray(colour, dtype=np.float64) / 255.0
    return 1.0 - amount * (1.0 - c)


class _Part:
    """One role's (and one material's) faces with the points they use (local numbering) and its actor.

    A local point shows one shape vertex (``vertices``); where a texture's seam splits a
    vertex, several local points show the same one.
    """

    def __init__(self, role: int, face_rows: np.ndarray, faces: np.ndarray, source: np.ndarray | None,
                 colour: np.ndarray, *, uv: np.ndarray | None = None, colors: np.ndarray | None = None,
                 texture=None, on_asset: bool = False) -> None:
        self.role = role
        self.face_rows = face_rows  # (f,) rows of the drawn triangles (the shape's, or the render mesh's)
        used = unique_in_range(faces, int(faces.max()) + 1 if faces.size else 0)  # render points of these faces
        #: (k,) global shape vertex of each local point (repeats where a seam splits a vertex)
        self.vertices = used if source is None else source[used]
        order = np.arange(len(used)) if source is None else np.argsort(self.vertices, kind="stable")
        self._order, self._sorted = order, self.vertices[order]
        local_of = np.full(int(used[-1]) + 1 if len(used) else 0, -1, dtype=np.int64)
        local_of[used] = np.arange(len(used))
        poly = pv.PolyData()
        poly.points = np.zeros((len(used), 3), dtype=np.float32)
        # VTK's connectivity straight from the (f, 3) local triangles, which it shares (kept here): the
        # padded legacy form pyvista's ``faces`` takes is converted cell by cell (9 s at 11M)
        self._triangles = np.ascontiguousarray(local_of[faces])
        poly.polys = pv.CellArray.from_regular_cells(self._triangles)
        poly.point_data["Normals"] = np.zeros((len(used), 3), dtype=np.float32)
        poly.GetPointData().SetActiveNormals("Normals")
        if uv is not None:
            poly.active_texture_coordinates = np.ascontiguousarray(uv[used], dtype=np.float32)
        if colors is not None:  # the file's colours, with the role's tint blended in (set once)
            c = colors[self.vertices].astype(np.float64)
            if on_asset:
                c = c * _tinted(colour, TINT_ON_ASSET)
            poly.point_data["rgb"] = np.clip(np.rint(c), 0, 255).astype(np.uint8)
        poly.point_data["stretch"] = np.zeros(len(used), dtype=np.float32)
        poly.point_data.active_scalars_name = "stretch"
        self.poly = poly
        self.points = poly.points  # the float32 buffers VTK draws from, written in place
        self.normals = poly.point_data["Normals"]
        self.stretch = poly.point_data["stretch"]
        self.has_colors = colors is not None
        self.texture = texture
        mapper = vtkPolyDataMapper()
        mapper.SetInputData(poly)
        mapper.SetVBOShiftScaleMethod(DISABLE_SHIFT_SCALE)
        mapper.SetScalarModeToUsePointData()
        mapper.SetColorModeToMapScalars()
        mapper.SetInterpolateScalarsBeforeMapping(False)
        mapper.SetUseLookupTableScalarRange(True)
        actor = pv.Actor(mapper=mapper)
        if on_asset:  # a texture or the file's colours: the tint only shades them
            actor.prop.color = tuple(_tinted(colour, TINT_ON_ASSET))
        else:
            actor.prop.color = tuple(np.asarray(colour, dtype=np.float64) / 255.0)
        actor.prop.interpolation = "gouraud"
        actor.prop.ambient = 0.18
        actor.prop.diffuse = 0.85
        actor.prop.specular = 0.08
        actor.prop.specular_power = 20.0
        if texture is not None:
            actor.texture = texture
        actor.SetPickable(False)
        self.mapper, self.actor = mapper, actor
        self.set_changed(None)

    def set_changed(self, rows: np.ndarray | None) -> None:
        """The global rows a frame rewrites (None: all): ``changed_rows`` (j,) and their ``changed_local``
        (a row shown by several local points appears once for each)."""
        if rows is None:
            self.changed_rows, self.changed_local = self.vertices, np.arange(len(self.vertices))
            return
        rows = np.asarray(rows, dtype=np.int64)
        lo = np.searchsorted(self._sorted, rows, side="left")
        count = np.searchsorted(self._sorted, rows, side="right") - lo
        total = int(count.sum())
        start = np.repeat(lo - (np.cumsum(count) - count), count)
        self.changed_local = self._order[start + np.arange(total)]
        self.changed_rows = np.repeat(rows, count)

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
    look : :class:`~.look.Look`, optional
        What the file says the shape looks like (textures, material colours, vertex colours).
    mode : "texture", "colors" or "plain" (see :mod:`.look`); "plain" without a look.

    With a texture the parts are the look's render mesh (the shape split at the texture's
    seams), one part per role and material; each part shows its role as a light tint of the
    asset (:data:`TINT_ON_ASSET`). The full-mesh buffers stay per shape vertex.
    """

    def __init__(self, renderer, faces: np.ndarray, n: int, colour_of, lut, *, look=None,
                 mode: str = "plain") -> None:
        self.renderer = renderer
        self.faces = np.ascontiguousarray(faces, dtype=np.int64)
        self.n = int(n)
        self.colour_of = colour_of
        self.lut = lut
        self.look = look
        self.mode = mode if look is not None and mode in look.modes() else "plain"
        self._textures: dict[int, object] = {}
        self.parts: list[_Part] = []
        self.stretch_visible = False
        self._changed: np.ndarray | None = None

    @property
    def changed(self) -> np.ndarray | None:
        """The (k,) sorted global rows a frame rewrites, as :meth:`set_changed` was last given them
        (None: all of them)."""
        return self._changed

    def _texture(self, m: int):
        """The VTK texture of material ``m`` (made once), or None."""
        if m < 0 or self.look.materials[m].image is None:
            return None
        if m not in self._textures:
            img = self.look.materials[m].image
            tex = pv.Texture(np.ascontiguousarray(img[::-1]))  # VTK's rows go bottom up
            tex.interpolate = True
            tex.mipmap = False
            tex.repeat = True
            self._textures[m] = tex
        return self._textures[m]

    def set_roles(self, roles: np.ndarray, points: np.ndarray, normals: np.ndarray, stretch: np.ndarray) -> None:
        """Split the faces by ``roles`` ((n,) int) and fill the parts from the full-mesh buffers
        ``points``, ``normals`` ((n, 3) float32) and ``stretch`` ((n,) float32)."""
        look, mode = self.look, self.mode
        if mode == "texture":
            faces, source, material = look.triangles, look.source, look.material
            fr = face_roles(source[faces], roles)
        else:
            faces, source, material = self.faces, None, np.full(len(self.faces), -1, dtype=np.int64)
            fr = face_roles(faces, roles)
        self.remove()
        # one part per role and material: roles from FIXED up, materials from -1 (none) up
        key = (fr - FIXED) * (len(look.materials) + 1 if look is not None else 1) + (material + 1)
        for k in unique_sorted(key).tolist():
            rows = np.flatnonzero(key == k)
            role, m = int(fr[rows[0]]), int(material[rows[0]])
            colour = self.colour_of(np.array([role]))[0]
            if mode == "texture":
                mat = look.materials[m] if m >= 0 else None
                tex = self._texture(m)
                base = np.asarray(mat.color[:3] if mat is not None else (1.0, 1.0, 1.0), dtype=np.float64)
                part = _Part(role, rows, faces[rows], source, colour, uv=look.uv if tex is not None else None,
                             texture=tex, on_asset=True)
                if tex is None:  # a material with a colour and no image: its colour, tinted
                    part.actor.prop.color = tuple(base * np.asarray(part.actor.prop.color))
            elif mode == "colors":
                part = _Part(role, rows, faces[rows], None, colour, colors=look.colors, on_asset=True)
            else:
                part = _Part(role, rows, faces[rows], None, colour)
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
        """The stretch map's colours on a part, or its own look (texture, the file's colours, or plain)."""
        m = part.mapper
        m.SetLookupTable(self.lut)
        if self.stretch_visible or not part.has_colors:
            part.poly.point_data.active_scalars_name = "stretch"
            m.SetScalarModeToUsePointData()
            m.SetColorModeToMapScalars()
            m.SetScalarVisibility(self.stretch_visible)
        else:  # the file's colours, as they are
            part.poly.point_data.active_scalars_name = "rgb"
            m.SetScalarModeToUsePointData()
            m.SetColorModeToDirectScalars()
            m.SetScalarVisibility(True)
        if part.texture is not None:
            part.actor.texture = None if self.stretch_visible else part.texture
        m.Modified()

    def face_colours(self) -> np.ndarray:
        """The colour each face is drawn in (without the stretch map), (m, 3) uint8 (plain mode)."""
        out = np.zeros((len(self.faces), 3), dtype=np.uint8)
        for part in self.parts:
            out[part.face_rows] = np.rint(np.asarray(part.actor.GetProperty().GetColor()) * 255.0).astype(np.uint8)
        return out

    def drawn_faces(self) -> np.ndarray:
        """How many parts draw each face (of the render mesh in texture mode), (m,) int (1 everywhere
        when the split is right)."""
        count = np.zeros(len(self.look.triangles) if self.mode == "texture" else len(self.faces), dtype=np.int64)
        for part in self.parts:
            np.add.at(count, part.face_rows, 1)
        return count

    def drawn_points(self, normals: bool = False) -> np.ndarray:
        """Each vertex's position (or normal) as the parts draw it, (n, 3) float32.

        NaN for a vertex no part uses, and where two parts, or two points of one part (the
        copies a texture's seam makes), draw it differently.
        """
        out = np.full((self.n, 3), np.nan, dtype=np.float32)
        seen = np.zeros(self.n, dtype=bool)
        for part in self.parts:
            vals = part.normals if normals else part.points
            v = part.vertices
            vs, xs = part._sorted, vals[part._order]
            split_apart = vs[1:][(vs[1:] == vs[:-1]) & np.any(xs[1:] != xs[:-1], axis=1)]
            clash = seen[v] & np.any(out[v] != vals, axis=1)
            out[v] = vals
            out[v[clash]] = np.nan
            out[split_apart] = np.nan
            seen[v] = True
        return out
