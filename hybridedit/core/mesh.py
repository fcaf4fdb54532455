"""The triangle mesh type shared by every part of hybridedit."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .bounds import points_box


class MeshError(ValueError):
    """A mesh is malformed or unusable; the message says what and where."""


@dataclass(eq=False)
class Mesh:
    """A triangle mesh.

    Attributes
    ----------
    vertices : (n, 3) float64 array
        Vertex positions.
    faces : (m, 3) int64 array
        Vertex indices of each triangle, counter-clockwise seen from outside.
    """

    vertices: np.ndarray
    faces: np.ndarray
    name: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        v = np.asarray(self.vertices, dtype=np.float64)
        f = np.asarray(self.faces)
        if f.size == 0:
            f = f.reshape(0, 3)
        if v.ndim != 2 or v.shape[1] != 3:
            raise MeshError(f"{self._label()}vertices must be an (n, 3) array, got shape {v.shape}")
        if f.ndim != 2 or f.shape[1] != 3:
            raise MeshError(f"{self._label()}faces must be an (m, 3) array, got shape {f.shape}")
        if f.size and not np.issubdtype(f.dtype, np.integer):
            if not np.all(np.equal(np.mod(f, 1), 0)):
                raise MeshError(f"{self._label()}face indices must be integers")
        f = f.astype(np.int64, copy=False)
        if f.size and (f.min() < 0 or f.max() >= len(v)):
            raise MeshError(
                f"{self._label()}face indices must lie in [0, {len(v) - 1}], "
                f"found {int(f.min())}..{int(f.max())}"
            )
        self.vertices = np.ascontiguousarray(v)
        self.faces = np.ascontiguousarray(f)

    def _label(self) -> str:
        return f"{self.name}: " if self.name else ""

    @property
    def n_vertices(self) -> int:
        return int(self.vertices.shape[0])

    @property
    def n_faces(self) -> int:
        return int(self.faces.shape[0])

    def copy(self, vertices: np.ndarray | None = None) -> "Mesh":
        """A copy, optionally with other vertex positions (same faces)."""
        v = self.vertices.copy() if vertices is None else vertices
        return Mesh(v, self.faces.copy(), name=self.name)

    def bbox(self) -> tuple[np.ndarray, np.ndarray]:
        """(min, max) corners, each a (3,) float64 array."""
        if self.n_vertices == 0:
            z = np.zeros(3)
            return z, z.copy()
        return points_box(self.vertices)

    def bbox_diagonal(self) -> float:
        """Length of the bounding-box diagonal."""
        lo, hi = self.bbox()
        return float(np.linalg.norm(hi - lo))

    def edges(self) -> np.ndarray:
        """Unique undirected edges, an (e, 2) int64 array with e[:, 0] < e[:, 1]."""
        return unique_edges(self.faces)


def unique_edges(faces: np.ndarray) -> np.ndarray:
    """Unique undirected edges of triangles.

    Parameters
    ----------
    faces : (m, 3) int array

    Returns
    -------
    (e, 2) int64 array, sorted rows with column 0 < column 1.
    """
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if f.size == 0:
        return np.zeros((0, 2), dtype=np.int64)
    from .topology import edge_index  # compiled: imported when first needed

    return edge_index(f, int(f.max()) + 1)[0]


def edge_lengths(vertices: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Length of each edge: (e,) float64 for (n, 3) vertices and (e, 2) edges."""
    return np.linalg.norm(vertices[edges[:, 1]] - vertices[edges[:, 0]], axis=1)


def rrms_edge_error(rest: np.ndarray, deformed: np.ndarray, edges: np.ndarray) -> float:
    """Relative RMS edge-length error in percent.

    sqrt(mean(((l' - l) / l)^2)) * 100 over edges of positive rest length.
    """
    return edge_error_stats(rest, deformed, edges)[0]


def edge_stretch(rest: np.ndarray, deformed: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Relative length change (l' - l) / l of each edge, (e,) float64 (0 for zero-length edges)."""
    return _stretch(edge_lengths(rest, edges), edge_lengths(deformed, edges))[0]


def edge_error_stats(rest: np.ndarray, deformed: np.ndarray, edges: np.ndarray) -> tuple[float, float]:
    """(:func:`rrms_edge_error`, the largest |:func:`edge_stretch`| in percent), from one
    computation of the edge lengths.

    Parameters
    ----------
    rest, deformed : (n, 3) float arrays
    edges : (e, 2) int array
    """
    stretch, ok = _stretch(edge_lengths(rest, edges), edge_lengths(deformed, edges))
    n_ok = int(np.count_nonzero(ok))
    if n_ok == 0:
        return 0.0, 0.0
    return (float(np.sqrt(np.dot(stretch, stretch) / n_ok) * 100.0),
            float(np.abs(stretch).max() * 100.0))


def _stretch(l0: np.ndarray, l1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(l1 - l0) / l0 per edge, 0 where l0 is not positive, and that mask of positive l0."""
    out = np.zeros(len(l0))
    ok = l0 > 0
    out[ok] = (l1[ok] - l0[ok]) / l0[ok]
    return out, ok


def vertex_stretch(n_vertices: int, edges: np.ndarray, stretch: np.ndarray) -> np.ndarray:
    """Per-vertex mean of |stretch| over incident edges, (n,) float64, for a colour map."""
    s = np.abs(stretch)
    total = np.bincount(edges[:, 0], s, n_vertices) + np.bincount(edges[:, 1], s, n_vertices)
    count = np.bincount(edges[:, 0], None, n_vertices) + np.bincount(edges[:, 1], None, n_vertices)
    return total / np.maximum(count, 1)
