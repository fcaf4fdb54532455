"""How a shape's file says it looks: textures, material colours and vertex colours, ready to draw.

VTK draws one texture coordinate per point, while a file gives one per polygon
corner (OBJ's ``vt`` indices, PLY's per-face ``texcoord`` lists): the shape's
vertices are split only where the corners of one vertex have different
coordinates (the texture's seams) into a render mesh whose points each know the
shape vertex they show (``source``). A drag then gathers positions and normals
for the moved rows only, from the welded shape (normals computed there, so a
seam never shows as a crease); coordinates, colours and images are set once.

No Qt or VTK here; images are decoded with Pillow (a pyvista dependency).

Modes: ``"texture"`` (each material's image, or its colour), ``"colors"`` (the
file's per-vertex colours), ``"plain"`` (one colour: the shape's form alone).
"""

from __future__ import annotations

import io
from dataclasses import dataclass, field

import numpy as np

from ...fileio.document import Document

MODES = ("texture", "colors", "plain")


@dataclass(eq=False)
class LookMaterial:
    """One material as drawn: ``color`` (4,) float RGBA in [0, 1]; ``image`` (h, w, 3 or 4) uint8 or None."""

    name: str
    color: tuple[float, float, float, float] = (1.0, 1.0, 1.0, 1.0)
    image: np.ndarray | None = None


@dataclass(eq=False)
class Look:
    """A shape's render mesh with its texture coordinates, materials and colours.

    Attributes
    ----------
    source : (k,) int64
        The shape vertex each render point shows (the first n are 0..n-1).
    triangles : (t, 3) int64
        Render point indices (the file's polygons, fan-triangulated).
    material : (t,) int64
        Index into ``materials`` of each triangle, -1 for none.
    uv : (k, 2) float32 or None
        Texture coordinates, (0, 0) at the image's bottom left.
    materials : list of LookMaterial
    colors : (n, 3) uint8 or None
        Per shape vertex colours (the file's), or None.
    notes : list of str
        What could not be shown (an image that would not decode), in plain words.
    """

    source: np.ndarray
    triangles: np.ndarray
    material: np.ndarray
    uv: np.ndarray | None = None
    materials: list[LookMaterial] = field(default_factory=list)
    colors: np.ndarray | None = None
    notes: list[str] = field(default_factory=list)

    @classmethod
    def plain(cls, mesh, *, notes: list[str] | None = None) -> "Look":
        """A look with nothing but the shape (drawn plain), e.g. to carry a note."""
        return cls(source=np.arange(mesh.n_vertices, dtype=np.int64), triangles=mesh.faces.astype(np.int64),
                   material=np.full(len(mesh.faces), -1, dtype=np.int64), notes=list(notes or []))

    @property
    def has_texture(self) -> bool:
        """Texture coordinates and at least one material with an image."""
        return self.uv is not None and any(m.image is not None for m in self.materials)

    @property
    def has_materials(self) -> bool:
        return bool(self.materials) and bool(np.any(self.material >= 0))

    @property
    def has_colors(self) -> bool:
        return self.colors is not None

    def modes(self) -> tuple[str, ...]:
        """The modes this look can be drawn in ("plain" always)."""
        out = []
        if self.has_texture or self.has_materials:
            out.append("texture")
        if self.has_colors:
            out.append("colors")
        return tuple(out) + ("plain",)

    @property
    def default_mode(self) -> str:
        """What the file has: its texture (or material colours), else its vertex colours, else plain."""
        return self.modes()[0]


def decode_image(data: bytes) -> np.ndarray:
    """(h, w, 3 or 4) uint8 pixels of a PNG or JPEG file's bytes, top row first.

    Raises
    ------
    ValueError
        The bytes are not an image Pillow can read.
    """
    from PIL import Image

    try:
        with Image.open(io.BytesIO(data)) as im:
            im = im.convert("RGBA" if im.mode in ("RGBA", "LA", "P") else "RGB")
            return np.asarray(im, dtype=np.uint8).copy()
    except Exception as e:  # noqa: BLE001 -- any decoder failure is a note, not a crash
        raise ValueError(f"not an image Pillow can read ({e.__class__.__name__})") from None


def shown_look(document: Document) -> Look | None:
    """The look the window shows a document with: :func:`look_of`, or, when its textures or colours cannot
    be read, a plain look whose note says why (the shape still opens)."""
    try:
        return look_of(document)
    except Exception as e:  # noqa: BLE001 -- the shape opens plain, and the note says why
        return Look.plain(document.mesh, notes=[f"its textures and colours are not shown: {e}"])


def look_of(document: Document) -> Look | None:
    """The look of a document, or None when it has neither texture coordinates, materials nor colours.

    Parameters
    ----------
    document : the file as read (:func:`hybridedit.read_document`).

    Returns
    -------
    Look or None
    """
    mesh = document.mesh
    n = mesh.n_vertices
    colors = None
    if document.colors is not None and len(document.colors) == n:
        colors = np.clip(np.rint(np.asarray(document.colors)[:, :3] * 255.0), 0, 255).astype(np.uint8)
    tex = document.textures()
    has_uv = tex is not None and tex.uv is not None and tex.corner_uv is not None and np.any(tex.corner_uv >= 0)
    has_mat = tex is not None and bool(tex.materials) and tex.face_material is not None
    if not (has_uv or has_mat) and colors is None:
        return None
    if not (has_uv or has_mat):
        return Look(source=np.arange(n, dtype=np.int64), triangles=mesh.faces.astype(np.int64),
                    material=np.full(len(mesh.faces), -1, dtype=np.int64), colors=colors)
    counts, flat = document.polygon_lists()
    if has_uv:
        source, uv, corner = tex.vertex_split(n, flat)
    else:
        source, uv, corner = np.arange(n, dtype=np.int64), None, np.asarray(flat, dtype=np.int64)
    triangles = document.fan_triangles(corner)
    polygon = document.fan_triangles(np.repeat(np.arange(len(counts)), counts))[:, 0]
    material = np.full(len(triangles), -1, dtype=np.int64)
    if has_mat and len(tex.face_material) == len(counts):
        material = np.asarray(tex.face_material, dtype=np.int64)[polygon]
    notes: list[str] = []
    materials = []
    for m in (tex.materials if tex is not None else []):
        image = None
        if m.image is None and m.image_name:
            notes.append(f"the texture of material {m.name!r} ({m.image_name}) is not shown: the file is not there")
        if m.image is not None:
            try:
                image = decode_image(m.image)
            except ValueError as e:
                notes.append(f"the texture of material {m.name!r} ({m.image_name or 'embedded'}) is not shown: {e}")
        materials.append(LookMaterial(m.name, tuple(float(c) for c in m.color), image))
    return Look(source=source.astype(np.int64), triangles=triangles.astype(np.int64), material=material,
                uv=None if uv is None else np.ascontiguousarray(uv, dtype=np.float32), materials=materials,
                colors=colors, notes=notes)
