"""A mesh file as a document: the engine's :class:`Mesh` plus everything else the file holds.

The engine works on positions and a triangulation. A :class:`Document` keeps,
beside that :class:`Mesh`, what a writer needs to give the file back with new
positions: the format module's own record of the file (``native``), the
original polygons, per-vertex colours, whether the file carries normals, and an
inventory of everything else (texture coordinates, materials, custom
properties, ...) so that a conversion can name what the target cannot hold.

Normals are never carried over from the file: writers recompute them from the
deformed surface with :func:`hybridedit.core.normals.grouped_normals` (the rule the window shades
with), keeping the file's own grouping (one normal per vertex stays smooth; normals split at hard
edges stay split).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..core.mesh import Mesh

__all__ = ["Document", "Material", "Texturing", "moved_vertices"]


@dataclass(eq=False)
class Material:
    """A surface's look as every format that has materials can carry it.

    Attributes
    ----------
    name : str
    color : (4,) tuple of float
        Base (diffuse) colour RGBA in [0, 1]: OBJ's ``Kd`` and ``d``, glTF's
        ``baseColorFactor``.
    image : bytes or None
        The base colour texture's file bytes (PNG, JPEG): OBJ's ``map_Kd``,
        glTF's ``baseColorTexture``, PLY's ``TextureFile`` comment.
    image_name : str or None
        A file name for the image ("spot_texture.png").
    """

    name: str
    color: tuple[float, float, float, float] = (1.0, 1.0, 1.0, 1.0)
    image: bytes | None = None
    image_name: str | None = None


@dataclass(eq=False)
class Texturing:
    """Texture coordinates and materials of a document's polygons, format-neutral.

    Attributes
    ----------
    uv : (t, 2) float64 array or None
        Texture coordinates, (0, 0) at the image's bottom left (OBJ's and PLY's
        convention; glTF's v is flipped on reading and writing).
    corner_uv : (sum of polygon corner counts,) int64 array or None
        The ``uv`` row of each polygon corner (in :meth:`Document.polygon_lists`
        order), -1 for none.
    materials : list of Material
    face_material : (p,) int64 array or None
        The material of each polygon, -1 for none.
    """

    uv: np.ndarray | None = None
    corner_uv: np.ndarray | None = None
    materials: list[Material] = field(default_factory=list)
    face_material: np.ndarray | None = None

    def vertex_split(self, n: int, flat: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Vertices split where corners of one vertex have different coordinates (glTF, and
        PLY's per-vertex u v, keep one coordinate per vertex).

        Parameters
        ----------
        n : int
            The document's vertex count.
        flat : (sum of counts,) int64
            The polygons' vertices (:meth:`Document.polygon_lists`).

        Returns
        -------
        source : (k,) int64
            The document vertex of each split vertex; the first n are 0..n-1 in order
            (every document vertex, with its first corner's coordinates), then the copies.
        uv : (k, 2) float64
        corner : (sum of counts,) int64
            The split vertex of each polygon corner.
        """
        cuv = self.corner_uv if self.corner_uv is not None else np.full(len(flat), -1, dtype=np.int64)
        pairs, inverse = np.unique(np.stack([flat, cuv], axis=1), axis=0, return_inverse=True)
        inverse = inverse.reshape(-1)
        # the first pair of each vertex keeps the vertex's index; the others come after, in order
        first = np.r_[True, pairs[1:, 0] != pairs[:-1, 0]]
        index = np.empty(len(pairs), dtype=np.int64)
        index[first] = pairs[first, 0]
        extra = np.flatnonzero(~first)
        index[extra] = n + np.arange(len(extra))
        k = n + len(extra)
        source = np.arange(k, dtype=np.int64)
        source[index] = pairs[:, 0]
        uv_rows = np.full(k, -1, dtype=np.int64)
        uv_rows[index] = pairs[:, 1]
        uv = np.zeros((k, 2))
        if self.uv is not None:
            has = uv_rows >= 0
            uv[has] = self.uv[uv_rows[has]]
        return source, uv, index[inverse]


@dataclass(eq=False)
class Document:
    """A mesh as read from a file, ready to be written back with new positions.

    Attributes
    ----------
    mesh : Mesh
        What the engine edits: ``vertices`` (n, 3) float64 (the current
        positions) and ``faces`` (m, 3) int64.
    format : str
        The format it was read as, a registered extension without the dot
        (``"obj"``), or ``""`` for a bare mesh.
    native : object or None
        The format module's own record of the file (private to that module);
        None for a bare mesh.
    polygons : tuple of ((p,) int64, (sum,) int64) or None
        The file's faces before triangulation: corner counts and engine vertex
        indices, one polygon after another; None when the faces are ``mesh.faces``.
    colors : (n, 4) float64 array or None
        Per-vertex RGBA in [0, 1], display (sRGB-encoded) values as PLY, OBJ and
        OFF store them; formats that store linear ones (glTF's ``COLOR_0``, USD's
        ``displayColor``) convert as they read and write
        (:mod:`hybridedit.fileio.formats.srgb`); alpha is never converted.
    normals : bool
        The file carries normals (writers recompute them).
    extras : dict of str to int
        What else the file holds, by a plain name, with how many
        (``{"texture coordinates": 3225, "material references": 1}``).
    path : Path or None
        The file it was read from (files it refers to are found next to it).
    texturing : Texturing, a callable returning one (read when first asked for), or None
        Texture coordinates and materials, for a conversion: see :meth:`textures`.
    """

    mesh: Mesh
    format: str = ""
    native: Any = None
    polygons: tuple[np.ndarray, np.ndarray] | None = None
    colors: np.ndarray | None = None
    normals: bool = False
    extras: dict[str, int] = field(default_factory=dict)
    path: Path | None = None
    texturing: Any = None

    def textures(self) -> Texturing | None:
        """The document's :class:`Texturing` (texture coordinates and materials), or None.

        OBJ files read theirs (``vt`` indices, ``usemtl``, the ``.mtl`` and its images) only
        here, when a conversion asks: opening a mesh does not pay for it.
        """
        if callable(self.texturing):
            self.texturing = self.texturing()
        return self.texturing

    @classmethod
    def from_mesh(cls, mesh: Mesh) -> "Document":
        """A document holding nothing but ``mesh``."""
        return cls(mesh=mesh)

    def with_vertices(self, vertices: np.ndarray) -> "Document":
        """The same document with the engine's vertices at ``vertices`` ((n, 3) float64)."""
        v = np.asarray(vertices, dtype=np.float64)
        if v.shape != self.mesh.vertices.shape:
            raise ValueError(f"new positions have shape {v.shape}, the document's mesh "
                             f"{self.mesh.vertices.shape}")
        return replace(self, mesh=self.mesh.copy(v))

    def polygon_lists(self) -> tuple[np.ndarray, np.ndarray]:
        """(counts (p,), flat (sum,)) of the faces as the file has them (triangles if none)."""
        if self.polygons is not None:
            return self.polygons
        f = self.mesh.faces
        return np.full(len(f), 3, dtype=np.int64), f.reshape(-1)

    def fan_triangles(self, corners: np.ndarray | None = None) -> np.ndarray:
        """Per-corner values of the file's polygons, fan-triangulated in the engine's triangle
        order (the readers' own rule: ``mesh.faces`` for the corners' vertices).

        Parameters
        ----------
        corners : (sum of corner counts,) array, optional
            A value per polygon corner (:meth:`polygon_lists` order); default: the vertices.

        Returns
        -------
        (t, 3) array of those values, one row per triangle.

        Examples
        --------
        >>> quad = Mesh(np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]), [[0, 1, 2], [0, 2, 3]])
        >>> doc = Document(quad, polygons=(np.array([4]), np.arange(4)))
        >>> doc.fan_triangles(np.array([10, 11, 12, 13])).tolist()
        [[10, 11, 12], [10, 12, 13]]
        """
        from .formats.common import fan_triangles  # (the exchange package imports this module)

        counts, flat = self.polygon_lists()
        return fan_triangles(counts, flat if corners is None else corners)


def moved_vertices(rest: np.ndarray, current: np.ndarray) -> np.ndarray:
    """(n,) bool: the rows of ``current`` that differ from ``rest`` (both (n, 3))."""
    return np.any(rest != current, axis=1)
