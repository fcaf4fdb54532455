"""A first, linear-time simplification of a big surface: quadric vertex clustering.

fast-simplification's quadric edge collapses cost about 2 us a face on one core (the 11M
armadillo's halves: 27-36 s on two cores), whatever the target. Most of those collapses take the
surface from millions of faces to near the cage's size, where a collapse decides little. Vertex
clustering (Lindstrom, "Out-of-core simplification of large polygonal models", SIGGRAPH 2000) does
that part in a few passes over the faces: the vertices are grouped by the cell of a uniform grid
they fall in, each group becomes one vertex at the point its faces' plane quadrics put it, and a
face whose corners fall in fewer than three groups disappears. Quadric edge collapses then take the
clustered surface to the cage (:mod:`hybridedit.cage.simplify`).

Two rules keep the clustered surface what the cage build needs:

* the vertices of a cell are grouped by the side they face as well (the dominant axis of their
  normal and its sign): the two sides of a part thinner than a cell (an ear, a finger, a fin) stay
  apart instead of meeting in one vertex;
* only faces with a repeated group and pairs of one triangle in both orientations are removed.
  Both remove boundary in cancelling pairs, so a closed surface stays closed in the sense of
  :func:`hybridedit.core.topology.check_closed` (every edge used as often each way), the property
  mean value coordinates need, whatever the clusters.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..core.bounds import points_box
from ..core.face_geometry import face_vector

__all__ = ["CLUSTER_FACTOR", "CLUSTER_FLOOR", "CLUSTER_MIN_FACES", "FLOOR_FACTOR", "cluster_surface",
           "clustered_size", "clusters_first", "simplified_sizes"]

#: surfaces of at least this many faces are clustered first (the 2.77M armadillo's 5.5M faces
#: simplify in 6-8 s on two cores; the 690K's 1.4M in under 2 s, where the grid's passes gain little)
CLUSTER_MIN_FACES = 2_000_000
#: the clustered surface has about this many times the cage's vertices (:func:`clustered_size`):
#: quadric collapses then choose the cage's last third (from 5x, the 11M armadillo's cage took 24 s
#: instead of 15, its edits' edge error the same to 2%)
CLUSTER_FACTOR = 1.5
#: ... but at least this many vertices, or :data:`FLOOR_FACTOR` times the cage's when that is fewer: a
#: coarser grid loses a small part's features (the 43K many-part scan's pieces clustered to 1.5x their
#: cages edit 7.5% worse than without the pass, to 5x as well)
CLUSTER_FLOOR = 50_000
FLOOR_FACTOR = 5


def clustered_size(target_vertices: int) -> int:
    """The vertices a surface whose cage has ``target_vertices`` is clustered to (:data:`CLUSTER_FACTOR`
    times them, not below :data:`CLUSTER_FLOOR` or :data:`FLOOR_FACTOR` times them when that is fewer).

    Examples
    --------
    >>> clustered_size(138_371), clustered_size(20_000), clustered_size(2_000)  # 2.77M at 5%, ...
    (207556, 50000, 10000)
    """
    t = int(target_vertices)
    return max(int(CLUSTER_FACTOR * t), min(FLOOR_FACTOR * t, CLUSTER_FLOOR))


#: average grid cells a plane through the grid crosses per cell face of area (|nx| + |ny| + |nz|
#: averaged over directions): the grid's spacing for a wanted number of occupied cells
_CELLS_PER_AREA = 1.5


def clusters_first(n_faces: int, target_vertices: int) -> bool:
    """Whether a surface of ``n_faces`` faces simplified to ``target_vertices`` is clustered first
    (:func:`cluster_surface`): a big surface, and a target well below the clustered size.

    Examples
    --------
    >>> clusters_first(5_534_848, 138_371), clusters_first(1_383_712, 34_592)  # 2.77M, 690K armadillo
    (True, False)
    """
    return n_faces >= CLUSTER_MIN_FACES and clustered_size(target_vertices) * 4 <= n_faces


def simplified_sizes(n_vertices: int, n_faces: int, target_vertices: int) -> tuple[int, int]:
    """(vertices, faces) about the size of the surface quadric collapses start from: the clustered
    surface's when :func:`clusters_first`, else the surface's own (what a helper process of
    :mod:`hybridedit.cage.qem` grows its buffers to).

    Examples
    --------
    >>> simplified_sizes(2_767_426, 5_534_848, 138_371), simplified_sizes(691_858, 1_383_712, 34_592)
    ((207556, 415112), (691858, 1383712))
    """
    if not clusters_first(n_faces, target_vertices):
        return int(n_vertices), int(n_faces)
    k = clustered_size(target_vertices)
    return k, int(round(k * n_faces / max(n_vertices, 1)))


def cluster_surface(vertices: np.ndarray, faces: np.ndarray, target_vertices: int
                    ) -> tuple[np.ndarray, np.ndarray]:
    """The surface clustered to about ``target_vertices`` vertices, or the input when that would
    not simplify it.

    Parameters
    ----------
    vertices : (n, 3) float array
        Finite positions.
    faces : (m, 3) int array
        Triangles on ``vertices``.
    target_vertices : int
        The vertex count wanted (met within about 30%: the grid's spacing comes from the surface's
        area).

    Returns
    -------
    vertices : (k, 3) float64
        One per group of vertices, each at the minimum of its faces' quadrics (held within a
        cell's size of the group's mean).
    faces : (t, 3) int32
        The faces whose corners fall in three groups, less pairs of one triangle in both
        orientations. Every edge of a closed input is used as often each way after as before.

    Examples
    --------
    >>> import trimesh
    >>> s = trimesh.creation.icosphere(6)
    >>> v, f = cluster_surface(s.vertices, s.faces, 4000)
    >>> 2800 < len(v) < 5600
    True
    """
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int64).reshape(-1, 3)
    target = int(target_vertices)
    if target < 4 or len(f) < 4 or 2 * target >= len(v):
        return v, f.astype(np.int32)
    lo, hi = points_box(v)
    normals, area = _vertex_normals(v, f)
    if not area > 0.0:
        return v, f.astype(np.int32)
    h = float(np.sqrt(_CELLS_PER_AREA * area / target))
    dims = np.maximum(np.floor((hi - lo) / h).astype(np.int64) + 1, 1)
    if float(np.prod(dims.astype(np.float64))) * 6 >= 2.0**62:
        return v, f.astype(np.int32)
    key = _cell_keys(v, normals, lo, h, dims)
    groups, group_of = np.unique(key, return_inverse=True)
    k = len(groups)
    if 2 * k >= len(v):
        return v, f.astype(np.int32)
    group_of = group_of.reshape(-1).astype(np.int64)
    quad = np.zeros((k, 13))
    _accumulate(v, f, group_of, quad)
    points = np.empty((k, 3))
    _place(quad, h, points)
    mapped = group_of[f]
    kept = mapped[(mapped[:, 0] != mapped[:, 1]) & (mapped[:, 1] != mapped[:, 2]) & (mapped[:, 2] != mapped[:, 0])]
    kept = _without_opposite_pairs(kept, k)
    used = np.zeros(k, dtype=bool)
    used[kept.reshape(-1)] = True
    remap = np.cumsum(used) - 1
    return points[used], remap[kept].astype(np.int32)


def _vertex_normals(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, float]:
    """(n, 3) area-weighted vertex normals (not normalized) and the surface's area."""
    out = np.zeros_like(v)
    area = _normals_and_area(v, f, out)
    return out, float(area)


@njit(cache=True)
def _normals_and_area(v, f, out):  # pragma: no cover - compiled
    area = 0.0
    for t in range(f.shape[0]):
        a, b, c = f[t, 0], f[t, 1], f[t, 2]
        nx, ny, nz = face_vector(v, f, t)
        area += 0.5 * np.sqrt(nx * nx + ny * ny + nz * nz)
        for q in (a, b, c):
            out[q, 0] += nx
            out[q, 1] += ny
            out[q, 2] += nz
    return area


@njit(cache=True, parallel=True)
def _keys(v, normals, lo, h, dims, out):  # pragma: no cover - compiled
    for r in prange(v.shape[0]):
        i = min(int((v[r, 0] - lo[0]) / h), dims[0] - 1)
        j = min(int((v[r, 1] - lo[1]) / h), dims[1] - 1)
        k = min(int((v[r, 2] - lo[2]) / h), dims[2] - 1)
        ax = 0
        best = abs(normals[r, 0])
        for d in (1, 2):
            if abs(normals[r, d]) > best:
                best = abs(normals[r, d])
                ax = d
        side = 2 * ax + (1 if normals[r, ax] > 0.0 else 0)
        out[r] = ((i * dims[1] + j) * dims[2] + k) * 6 + side


def _cell_keys(v: np.ndarray, normals: np.ndarray, lo: np.ndarray, h: float, dims: np.ndarray) -> np.ndarray:
    """(n,) int64: each vertex's grid cell and the side its normal faces, as one number."""
    out = np.empty(len(v), dtype=np.int64)
    _keys(v, normals, lo, h, dims, out)
    return out


@njit(cache=True)
def _accumulate(v, f, group_of, quad):  # pragma: no cover - compiled
    """Per group: its faces' area-weighted plane quadrics (A: 6, b: 3, rows 0-8), its vertices'
    position sum (9-11) and count (12)."""
    for t in range(f.shape[0]):
        a, b, c = f[t, 0], f[t, 1], f[t, 2]
        nx, ny, nz = face_vector(v, f, t)
        s = np.sqrt(nx * nx + ny * ny + nz * nz)
        if s == 0.0:
            continue
        w = 0.5 * s
        nx, ny, nz = nx / s, ny / s, nz / s
        d = -(nx * v[a, 0] + ny * v[a, 1] + nz * v[a, 2])
        for q in (a, b, c):
            g = group_of[q]
            quad[g, 0] += w * nx * nx
            quad[g, 1] += w * nx * ny
            quad[g, 2] += w * nx * nz
            quad[g, 3] += w * ny * ny
            quad[g, 4] += w * ny * nz
            quad[g, 5] += w * nz * nz
            quad[g, 6] += w * nx * d
            quad[g, 7] += w * ny * d
            quad[g, 8] += w * nz * d
    for r in range(v.shape[0]):
        g = group_of[r]
        quad[g, 9] += v[r, 0]
        quad[g, 10] += v[r, 1]
        quad[g, 11] += v[r, 2]
        quad[g, 12] += 1.0


@njit(cache=True, parallel=True)
def _place(quad, h, out):  # pragma: no cover - compiled
    """Each group's point: the minimum of its quadric, pulled towards its mean in the directions the
    quadric leaves free (a flat group: along its plane), and its mean if that lands more than a
    cell away."""
    for g in prange(quad.shape[0]):
        q = quad[g]
        cnt = max(q[12], 1.0)
        mx, my, mz = q[9] / cnt, q[10] / cnt, q[11] / cnt
        lam = 1e-3 * (q[0] + q[3] + q[5]) + 1e-300
        a00, a01, a02, a11, a12, a22 = q[0] + lam, q[1], q[2], q[3] + lam, q[4], q[5] + lam
        # right-hand side -b + lam * mean
        r0 = -q[6] + lam * mx
        r1 = -q[7] + lam * my
        r2 = -q[8] + lam * mz
        c00 = a11 * a22 - a12 * a12
        c01 = a02 * a12 - a01 * a22
        c02 = a01 * a12 - a02 * a11
        det = a00 * c00 + a01 * c01 + a02 * c02
        x, y, z = mx, my, mz
        if det > 0.0:
            c11 = a00 * a22 - a02 * a02
            c12 = a01 * a02 - a00 * a12
            c22 = a00 * a11 - a01 * a01
            x = (c00 * r0 + c01 * r1 + c02 * r2) / det
            y = (c01 * r0 + c11 * r1 + c12 * r2) / det
            z = (c02 * r0 + c12 * r1 + c22 * r2) / det
            if (x - mx) ** 2 + (y - my) ** 2 + (z - mz) ** 2 > h * h or not (x == x and y == y and z == z):
                x, y, z = mx, my, mz
        out[g, 0] = x
        out[g, 1] = y
        out[g, 2] = z


def _without_opposite_pairs(f: np.ndarray, k: int) -> np.ndarray:
    """The faces less pairs of one triangle (the same three groups) in both orientations; of a
    triangle used more often one way than the other, the surplus stays."""
    if not len(f):
        return f
    s = np.sort(f, axis=1)
    key = (s[:, 0] * k + s[:, 1]) * k + s[:, 2] if float(k) ** 3 < 2.0**62 else None
    if key is None:
        _, inverse = np.unique(s, axis=0, return_inverse=True)
        key = inverse.reshape(-1).astype(np.int64)
    # +1 when the face's order is an even rotation of its sorted order
    even = (((f[:, 0] == s[:, 0]) & (f[:, 1] == s[:, 1])) | ((f[:, 1] == s[:, 0]) & (f[:, 2] == s[:, 1]))
            | ((f[:, 2] == s[:, 0]) & (f[:, 0] == s[:, 1])))
    order = np.argsort(key, kind="stable")
    keep = np.ones(len(f), dtype=bool)
    _cancel_pairs(key[order], even[order], order, keep)
    return f[keep]


@njit(cache=True)
def _cancel_pairs(key, even, order, keep):  # pragma: no cover - compiled
    """In each run of one key (faces sorted by key), drop as many faces of each orientation as
    the other has."""
    n = key.shape[0]
    i = 0
    while i < n:
        j = i + 1
        while j < n and key[j] == key[i]:
            j += 1
        if j - i > 1:
            pos = 0
            for t in range(i, j):
                if even[t]:
                    pos += 1
            neg = (j - i) - pos
            drop_pos = min(pos, neg)
            drop_neg = drop_pos
            for t in range(i, j):
                if even[t] and drop_pos > 0:
                    keep[order[t]] = False
                    drop_pos -= 1
                elif not even[t] and drop_neg > 0:
                    keep[order[t]] = False
                    drop_neg -= 1
        i = j
