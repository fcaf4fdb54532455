"""The control mesh: QEM simplification of the shape, cleaned to a valid surface."""

from __future__ import annotations

import numpy as np
import fast_simplification

from .mesh import Mesh, MeshError


def cage_vertex_target(n_vertices: int, size: int | float) -> int:
    """The cage vertex count asked for by ``size``.

    Parameters
    ----------
    n_vertices : int
        Vertex count of the shape.
    size : int or float
        An int is a vertex count; a float in (0, 1] is a fraction of ``n_vertices``.
    """
    if isinstance(size, (bool, np.bool_)):
        raise ValueError(f"cage size must be a vertex count or a fraction, got {size!r}")
    if isinstance(size, (int, np.integer)):
        target = int(size)
    else:
        frac = float(size)
        if not (0.0 < frac <= 1.0):
            raise ValueError(f"cage fraction must be in (0, 1], got {size!r}")
        target = int(round(frac * n_vertices))
    if target < 4:
        raise ValueError(f"a cage needs at least 4 vertices, asked for {target}")
    if target > n_vertices:
        raise ValueError(f"cage of {target} vertices asked for a shape of only {n_vertices}")
    return target


def build_cage(mesh: Mesh, size: int | float = 0.05) -> Mesh:
    """Simplify ``mesh`` with quadric error metrics to about ``size`` vertices.

    Parameters
    ----------
    mesh : Mesh
        The shape.
    size : int or float
        Target vertex count (int) or fraction of the shape's vertices (float).

    Returns
    -------
    Mesh
        The cage, with degenerate faces, coincident opposite face pairs and
        unreferenced vertices removed. Its vertex count is within a few percent of
        the target (QEM collapses edges, so the count is not exact).
    """
    target = cage_vertex_target(mesh.n_vertices, size)
    if target == mesh.n_vertices:
        return clean_surface(mesh.vertices.copy(), mesh.faces.copy())
    ratio = mesh.n_faces / max(mesh.n_vertices, 1)
    cage = None
    want_faces = max(4, int(round(target * ratio)))
    for _ in range(3):
        want_faces = min(want_faces, mesh.n_faces)
        v, f = fast_simplification.simplify(
            mesh.vertices, mesh.faces.astype(np.int32), target_count=want_faces, agg=7.0
        )
        cage = clean_surface(np.asarray(v, dtype=np.float64), np.asarray(f, dtype=np.int64))
        got = cage.n_vertices
        if abs(got - target) <= max(2, 0.02 * target) or got == 0:
            break
        want_faces = int(round(want_faces * target / got))
    assert cage is not None
    if cage.n_faces < 4:
        raise MeshError(
            f"{mesh.name or 'mesh'}: simplification to {target} vertices left no usable cage"
        )
    return cage


def clean_surface(vertices: np.ndarray, faces: np.ndarray) -> Mesh:
    """Remove what a simplifier can leave behind.

    Drops faces with a repeated index or zero area, duplicate faces, pairs of
    coincident faces of opposite orientation (zero-volume fins), and then
    vertices no face uses (indices are compacted, order kept).

    Parameters
    ----------
    vertices : (n, 3) float64 array
    faces : (m, 3) int array
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    while True:
        m0 = len(f)
        keep = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 2] != f[:, 0])
        f = f[keep]
        if len(f):
            a = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
            area2 = np.linalg.norm(a, axis=1)
            scale = np.ptp(v, axis=0).max() if len(v) else 1.0
            f = f[area2 > 1e-14 * scale * scale]
        if len(f):
            key = np.sort(f, axis=1)
            _, first, inverse, counts = np.unique(
                key, axis=0, return_index=True, return_inverse=True, return_counts=True
            )
            inverse = inverse.reshape(-1)
            # a vertex set used twice: same orientation is a duplicate (keep one),
            # opposite orientation is a fin (drop both)
            keep = np.zeros(len(f), dtype=bool)
            keep[first] = True
            multi = counts[inverse] > 1
            if np.any(multi):
                for g in np.unique(inverse[multi]):
                    idx = np.flatnonzero(inverse == g)
                    orient = [_parity(f[i]) for i in idx]
                    if len(set(orient)) > 1:
                        keep[idx] = False
            f = f[keep]
        if len(f) == m0:
            break
    used = np.zeros(len(v), dtype=bool)
    used[f.reshape(-1)] = True
    remap = np.cumsum(used) - 1
    return Mesh(v[used], remap[f])


def _parity(tri: np.ndarray) -> int:
    """+1 if the triangle's cyclic order is an even rotation of its sorted order."""
    a, b, c = (int(x) for x in tri)
    lo = min(a, b, c)
    while a != lo:
        a, b, c = b, c, a
    return 1 if b < c else -1
