"""A mesh file as a document: the engine's :class:`Mesh` plus everything else the file holds.

The engine works on positions and a triangulation. A :class:`Document` keeps,
beside that :class:`Mesh`, what a writer needs to give the file back with new
positions: the format module's own record of the file (``native``), the
original polygons, per-vertex colours, whether the file carries normals, and an
inventory of everything else (texture coordinates, materials, custom
properties, ...) so that a conversion can name what the target cannot hold.

Normals are never carried over from the file: writers recompute them from the
deformed surface with :func:`grouped_normals`, keeping the file's own grouping
(one normal per vertex stays smooth; normals split at hard edges stay split).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from .mesh import Mesh

__all__ = ["Document", "grouped_normals", "moved_vertices", "vertex_normals"]


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
        Per-vertex RGBA in [0, 1].
    normals : bool
        The file carries normals (writers recompute them).
    extras : dict of str to int
        What else the file holds, by a plain name, with how many
        (``{"texture coordinates": 3225, "material references": 1}``).
    path : Path or None
        The file it was read from (files it refers to are found next to it).
    """

    mesh: Mesh
    format: str = ""
    native: Any = None
    polygons: tuple[np.ndarray, np.ndarray] | None = None
    colors: np.ndarray | None = None
    normals: bool = False
    extras: dict[str, int] = field(default_factory=dict)
    path: Path | None = None

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


def moved_vertices(rest: np.ndarray, current: np.ndarray) -> np.ndarray:
    """(n,) bool: the rows of ``current`` that differ from ``rest`` (both (n, 3))."""
    return np.any(rest != current, axis=1)


def _corner_weighted_normals(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Unit face normal of each triangle times the angle at each corner, (m, 3, 3)."""
    p = vertices[triangles]  # (m, 3, 3)
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    length = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.divide(n, length, out=np.zeros_like(n), where=length > 0)
    angles = np.empty(triangles.shape)
    for c in range(3):
        a = p[:, (c + 1) % 3] - p[:, c]
        b = p[:, (c + 2) % 3] - p[:, c]
        cos = np.einsum("ij,ij->i", a, b)
        sin = np.linalg.norm(np.cross(a, b), axis=1)
        angles[:, c] = np.arctan2(sin, cos)
    return n[:, None, :] * angles[:, :, None]


def grouped_normals(vertices: np.ndarray, triangles: np.ndarray, groups: np.ndarray,
                    n_groups: int) -> tuple[np.ndarray, np.ndarray]:
    """Angle-weighted normals of groups of triangle corners.

    Parameters
    ----------
    vertices : (n, 3) float64 array
    triangles : (m, 3) int64 array
    groups : (m, 3) int64 array
        The group (e.g. the OBJ ``vn`` index) of each corner; -1 for none.
    n_groups : int

    Returns
    -------
    normals : (n_groups, 3) float64 array
        Unit normals; zero rows where ``valid`` is False.
    valid : (n_groups,) bool array
        The group has corners with a nonzero summed normal.
    """
    w = _corner_weighted_normals(vertices, triangles).reshape(-1, 3)
    g = groups.reshape(-1)
    keep = g >= 0
    out = np.zeros((n_groups, 3))
    for axis in range(3):
        out[:, axis] = np.bincount(g[keep], weights=w[keep, axis], minlength=n_groups)
    length = np.linalg.norm(out, axis=1)
    valid = length > 1e-300
    out[valid] /= length[valid, None]
    out[~valid] = 0.0
    return out, valid


def vertex_normals(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Angle-weighted unit vertex normals, (n, 3) float64 (zero for unused vertices)."""
    normals, _ = grouped_normals(vertices, triangles, triangles, len(vertices))
    return normals
