"""The cage laid out for the mean value coordinate kernels: one job, :func:`prepare_cage`.

The three kernels (:mod:`hybridedit.binding.mvc_exact`, :mod:`hybridedit.binding.mvc_flat`,
:mod:`hybridedit.binding.mvc_tree`) read a cage as :class:`CageData`: faces in a spatially
coherent (Morton) order, unique edges numbered by first use, face planes and tiles of
faces that fit in cache. :func:`morton_order` also sorts the points of the fast kernels.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["CageData", "FACE_TILE", "morton_order", "prepare_cage"]

#: Faces per tile of the per-point loops (keeps a tile's data in cache).
FACE_TILE = 512


@dataclass(frozen=True)
class CageData:
    """Cage arrays laid out for the kernels (built by :func:`prepare_cage`).

    Faces are stored in a spatially coherent order (Morton order of their
    centroids) and edges are numbered by first use in that order, so the
    per-face loop reads edge data that is close in memory. Vertex indices are
    the caller's.

    Attributes
    ----------
    vertices : (c, 3) float64
    vertices_t : (3, c) float64
        The same, transposed.
    faces : (f, 3) int64
        The caller's faces, in kernel order (``faces[k] = input[face_order[k]]``).
    face_order : (f,) int64
    edges : (e, 2) int64
        Unique undirected edges, column 0 < column 1.
    face_idx : (f, 6) uint32
        Vertex ids ``i0, i1, i2`` then the ids of the edges ``(i0, i1)``,
        ``(i1, i2)``, ``(i2, i0)``.
    planes : (5, f) float64
        Unit normal (3 rows), offset ``n . p0`` and ``|N_f|`` (twice the area).
        Degenerate faces have an all-zero column and are ignored.
    edge_points : (6, e) float64
        Position of the lower endpoint and the edge vector (higher - lower)
        of every edge.
    face_tiles : (t + 1,) int64
        Faces ``face_tiles[k]:face_tiles[k + 1]`` form tile ``k``.
    edge_tiles : (t + 1,) int64
        Edges ``edge_tiles[k]:edge_tiles[k + 1]`` are those first used by
        tile ``k`` (edges are numbered by first use, so these are ranges).
    scale : float
        Bounding-box diagonal of the cage.
    """

    vertices: np.ndarray
    vertices_t: np.ndarray
    faces: np.ndarray
    face_order: np.ndarray
    edges: np.ndarray
    face_idx: np.ndarray
    planes: np.ndarray
    edge_points: np.ndarray
    face_tiles: np.ndarray
    edge_tiles: np.ndarray
    scale: float

    @property
    def n_vertices(self) -> int:
        return int(self.vertices.shape[0])

    @property
    def n_faces(self) -> int:
        return int(self.faces.shape[0])

    @property
    def n_edges(self) -> int:
        return int(self.edges.shape[0])


def morton_order(points: np.ndarray) -> np.ndarray:
    """Indices sorting ``points`` (k, 3) along a 3D Morton (Z-order) curve."""
    lo = points.min(axis=0)
    ext = points.max(axis=0) - lo
    ext[ext <= 0] = 1.0
    q = np.clip(((points - lo) / ext * 1023.0).astype(np.int64), 0, 1023).astype(np.uint64)
    code = np.zeros(len(points), dtype=np.uint64)
    for bit in range(10):
        for axis in range(3):
            code |= ((q[:, axis] >> np.uint64(bit)) & np.uint64(1)) << np.uint64(3 * bit + axis)
    return np.argsort(code, kind="stable")


def prepare_cage(cage_vertices: np.ndarray, cage_faces: np.ndarray) -> CageData:
    """Validate a cage and precompute the kernel's arrays (see :class:`CageData`)."""
    v = np.asarray(cage_vertices)
    f = np.asarray(cage_faces)
    if v.ndim != 2 or v.shape[1] != 3 or v.shape[0] == 0:
        raise ValueError(f"cage vertices must be a non-empty (c, 3) array, got shape {v.shape}")
    v = np.ascontiguousarray(v, dtype=np.float64)
    if not np.all(np.isfinite(v)):
        raise ValueError("cage vertices must be finite")
    if f.ndim != 2 or f.shape[1] != 3 or f.shape[0] == 0:
        raise ValueError(f"cage faces must be a non-empty (f, 3) array, got shape {f.shape}")
    if not np.issubdtype(f.dtype, np.integer):
        raise ValueError(f"cage faces must hold integer vertex indices, got dtype {f.dtype}")
    f = f.astype(np.int64)
    nv = len(v)
    if f.min() < 0 or f.max() >= nv:
        raise ValueError(
            f"cage face indices must lie in [0, {nv - 1}], found {int(f.min())}..{int(f.max())}"
        )
    if nv >= 2**31 or len(f) >= 2**31:
        raise ValueError("cage too large for the kernels (2^31 elements)")

    order = morton_order(v[f].mean(axis=1))
    f = f[order]
    nf = len(f)

    # Unique undirected edges, numbered by first use in face order.
    a = f.ravel()
    b = f[:, [1, 2, 0]].ravel()
    key = np.minimum(a, b) * nv + np.maximum(a, b)
    uniq, first, inv = np.unique(key, return_index=True, return_inverse=True)
    rank = np.empty(len(uniq), dtype=np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(len(uniq))
    edges = np.empty((len(uniq), 2), dtype=np.int64)
    edges[rank, 0] = uniq // nv
    edges[rank, 1] = uniq % nv
    face_edges = rank[inv.ravel()].reshape(nf, 3)
    face_idx = np.ascontiguousarray(np.concatenate([f, face_edges], axis=1).astype(np.uint32))
    # Tiles of faces, and the range of edges each tile uses first.
    face_tiles = np.unique(np.append(np.arange(0, nf, FACE_TILE), nf)).astype(np.int64)
    first_use_face = np.sort(first) // 3  # face of each edge's first use, by edge id
    edge_tiles = np.searchsorted(first_use_face, face_tiles, side="left").astype(np.int64)

    p0, p1, p2 = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    normal = np.cross(p1 - p0, p2 - p0)
    area2 = np.linalg.norm(normal, axis=1)
    longest = np.max(
        np.stack([
            np.linalg.norm(p1 - p0, axis=1),
            np.linalg.norm(p2 - p1, axis=1),
            np.linalg.norm(p0 - p2, axis=1),
        ]),
        axis=0,
    )
    # Degenerate (needle or repeated-vertex) faces project to zero area on
    # every sphere: they carry no weight.
    ok = area2 > 1e-14 * longest * longest
    planes = np.zeros((5, nf))
    n = normal[ok] / area2[ok, None]
    planes[0:3, ok] = n.T
    planes[3, ok] = np.einsum("ij,ij->i", n, p0[ok])
    planes[4, ok] = area2[ok]
    pa = v[edges[:, 0]]
    pb = v[edges[:, 1]]
    edge_points = np.ascontiguousarray(np.concatenate([pa.T, (pb - pa).T]))
    scale = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))
    return CageData(
        vertices=v,
        vertices_t=np.ascontiguousarray(v.T),
        faces=f,
        face_order=order,
        edges=edges,
        face_idx=face_idx,
        planes=np.ascontiguousarray(planes),
        edge_points=edge_points,
        face_tiles=face_tiles,
        edge_tiles=edge_tiles,
        scale=scale,
    )
