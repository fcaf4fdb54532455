"""3D mean value coordinates with respect to a closed triangle cage.

Implements the coordinates of Ju, Schaefer and Warren, "Mean value coordinates
for closed triangular meshes" (SIGGRAPH 2005) as a compiled, multi-threaded
kernel.

For a point ``x`` and a cage vertex ``p_j`` let ``a_j = p_j - x``,
``d_j = |a_j|`` and ``u_j = a_j / d_j``. A cage triangle ``(p0, p1, p2)``
projects onto the unit sphere around ``x`` as a spherical triangle whose mean
vector (the integral of the unit normal over it) is

    m = 1/2 * sum over the edges a->b, in the face's vertex order, of
        theta_ab * (u_a x u_b) / |u_a x u_b|,

``theta_ab`` being the angle between ``u_a`` and ``u_b``. Writing ``m`` in the
basis ``u0, u1, u2`` gives the face's weights ``w_i = (n_jk . m) / (n_jk . u_i)``,
``n_jk`` the normal of the edge opposite vertex ``i``, and the face adds
``w_i / d_i`` to the coordinate of vertex ``i``. The sum over all faces,
normalized to 1, is the coordinate vector. Since the unit normals of a closed
surface integrate to zero over the sphere, the coordinates reproduce linear
functions exactly. A global flip of the face orientation flips every ``m`` and
every weight, so it cancels in the normalization.

Implementation notes
--------------------
* With ``(i, j, k)`` cyclic, ``(a_j x a_k) . a_i = det(a0, a1, a2) = Delta``,
  and ``w_i / d_i = ((a_j x a_k) . m) / Delta``: no per-vertex distance or unit
  vector is needed. ``Delta = -dist * |N_f|`` comes from the signed distance of
  ``x`` to the face plane and the precomputed face normal ``N_f``; this is
  accurate close to the plane, where a triple product would cancel, and all
  three weights of a face share it.
* The angle and the cross product of an edge do not depend on the face, so
  they are computed once per unique cage edge (each edge is shared by two
  faces), which halves the transcendental work. The angle is
  ``atan2(|a_a x a_b|, a_a . a_b)`` evaluated by a branch-free, full-precision
  arctangent written for this module (``_atan2_pos``, checked against
  ``numpy.arctan2`` in the tests), so that the per-edge loop vectorizes.
* Per point, the loops over faces (plane distances) and over edges run on
  contiguous arrays only and vectorize; the loop that combines the edges of
  each face is scalar. Faces are kept in a spatially coherent order and
  edges numbered by first use, so its indexed loads stay close in memory.
* Special cases, with tolerances relative to the cage's bounding-box
  diagonal: a point within ``1e-12`` of a cage vertex gets the unit vector of
  that vertex; a point within ``1e-12`` of a face (plane and closed triangle)
  gets the barycentric coordinates of that face, which covers points on
  edges; a face whose plane holds the point outside the triangle contributes
  nothing (its contribution vanishes in the limit); a face seen at a grazing
  angle from outside its triangle is dropped as well (see ``_near_faces``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from llvmlite import ir
from numba import njit, prange, types
from numba.core import cgutils
from numba.extending import intrinsic

__all__ = ["CageData", "FastCageData", "prepare_cage", "prepare_fast_cage",
           "mean_value_coordinates", "check_closed"]

#: Relative tolerance (w.r.t. the cage's bounding-box diagonal) under which a
#: point is taken to lie on a cage vertex.
VERTEX_EPS = 1e-12
#: Relative tolerance (w.r.t. the cage's bounding-box diagonal) under which a
#: point is taken to lie in the plane of a face.
PLANE_EPS = 1e-12
#: Relative tolerance (w.r.t. the cage's bounding-box diagonal) under which a
#: face plane is checked for a grazing view (see ``_near_faces``).
NEAR_EPS = 1e-8
#: Elevation ratio |dist| / rho below which a face seen at a grazing angle
#: from outside its triangle is dropped (see ``_near_faces``).
RHO_RATIO = 1e-8
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


def check_closed(faces: np.ndarray) -> None:
    """Raise ``ValueError`` unless the triangles form a closed, oriented surface.

    Closed here means that every undirected edge is used as often in one
    direction as in the other, which is what makes the mean value
    coordinates reproduce linear functions (non-manifold edges are fine as long
    as they balance).
    """
    f = np.asarray(faces, dtype=np.int64)
    if f.size == 0:
        raise ValueError("the cage has no faces")
    a = np.concatenate([f[:, 0], f[:, 1], f[:, 2]])
    b = np.concatenate([f[:, 1], f[:, 2], f[:, 0]])
    lo = np.minimum(a, b)
    hi = np.maximum(a, b)
    if np.any(lo == hi):
        raise ValueError("the cage has a face with a repeated vertex index")
    key = lo * (int(f.max()) + 1) + hi
    sign = np.where(a < b, 1, -1)
    uniq, inv = np.unique(key, return_inverse=True)
    balance = np.bincount(inv.ravel(), weights=sign, minlength=len(uniq))
    bad = np.flatnonzero(balance != 0)
    if bad.size:
        k = int(uniq[bad[0]])
        n = int(f.max()) + 1
        raise ValueError(
            f"the cage is not a closed, consistently oriented surface: {bad.size} edge(s) "
            f"are unbalanced, e.g. edge ({k // n}, {k % n})"
        )


def _morton_order(points: np.ndarray) -> np.ndarray:
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

    order = _morton_order(v[f].mean(axis=1))
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


# ---------------------------------------------------------------------------
# Arctangent
# ---------------------------------------------------------------------------
# math.atan2 is a libm call (~25 ns here) that blocks vectorization of the
# edge loop, so the angle uses this branch-free version instead. The argument
# t = min(|y|, |x|) / max(|y|, |x|) in [0, 1] is reduced with
# atan(t) = atan(T) + atan((t - T) / (1 + t T)) about T in {0, tan(pi/8), 1}
# to |z| <= tan(pi/16), where atan(z) = z + z^3 P(z^2). P is a degree-7
# Chebyshev interpolant of (atan(z) - z) / z^3 on z^2 in [0, tan^2(pi/16)]
# fitted for this module from the alternating Taylor series; its error is
# below 1e-17 there, and the result is within about 1 ulp of atan2 (checked
# against numpy.arctan2 in the tests).

_P0 = -0.3333333333333333
_P1 = 0.19999999999993162
_P2 = -0.14285714282963005
_P3 = 0.11111110635293751
_P4 = -0.09090866734486287
_P5 = 0.07690218100816135
_P6 = -0.0660891182031359
_P7 = 0.050399515893581645
_TAN_PI_16 = 0.198912367379658
_TAN_3PI_16 = 0.6681786379192989
_TAN_PI_8 = 0.41421356237309503
_ATAN_TAN_PI_8 = 0.39269908169872414  # atan of the double _TAN_PI_8
_PI_4 = 0.7853981633974483
_PI_2_HI = 1.5707963267948966
_PI_2_LO = 6.123233995736766e-17
_PI_HI = 3.141592653589793
_PI_LO = 1.2246467991473532e-16
_R_MAX = 1e300


@njit(cache=True, fastmath=False, error_model="numpy", inline="always")
def _atan2_pos(y, x):
    """atan2(y, x) for y >= 0, in [0, pi]; branch-free so loops vectorize."""
    ax = abs(x)
    swap = y > ax
    num = min(y, ax)
    den = max(y, ax)
    k1 = num > _TAN_PI_16 * den
    k2 = num > _TAN_3PI_16 * den
    tk = 1.0 if k2 else (_TAN_PI_8 if k1 else 0.0)
    base = _PI_4 if k2 else (_ATAN_TAN_PI_8 if k1 else 0.0)
    z = (num - tk * den) / (den + tk * num)
    s = z * z
    p = _P7
    p = p * s + _P6
    p = p * s + _P5
    p = p * s + _P4
    p = p * s + _P3
    p = p * s + _P2
    p = p * s + _P1
    p = p * s + _P0
    a = base + (z + z * s * p)
    a = ((_PI_2_HI - a) + _PI_2_LO) if swap else a
    return ((_PI_HI - a) + _PI_LO) if x < 0.0 else a


@njit(cache=True, fastmath=False, error_model="numpy")
def atan2_pos_array(y, x):
    """:func:`_atan2_pos` applied elementwise to two 1D arrays (for tests)."""
    out = np.empty(y.shape[0])
    for i in range(y.shape[0]):
        out[i] = _atan2_pos(y[i], x[i])
    return out


# ---------------------------------------------------------------------------
# Kernels
# ---------------------------------------------------------------------------
# Per point, and per tile of FACE_TILE faces (with the edges those faces use
# first), the work is split into three loops so that the two expensive ones
# run on contiguous arrays only (no indexed loads), which lets LLVM vectorize
# them:
#   1. faces: signed plane distance -> 1 / (2 Delta_f), Delta_f the triple
#      product det(p0 - x, p1 - x, p2 - x) = -dist |N_f|;
#   2. edges: C_e = (p_a - x) x (p_b - x) and theta_e / |C_e|;
#   3. faces again (indexed loads of the edge data, scalar): the face's mean
#      vector m (times 2) = sum of s_e theta_e / |C_e| C_e and its vertex
#      weights.
# With a_i = p_i - x the weight that face f gives vertex i, divided by
# d_i = |a_i| (the form that enters the coordinates), is
#     w_i / d_i = ((a_j x a_k) . m) / Delta_f,   (i, j, k) cyclic,
# because w_i = (n_jk . m) / (n_jk . u_i) with n_jk the unit normal of
# a_j x a_k and (a_j x a_k) . a_i = Delta_f. No per-vertex distance is needed.


@njit(cache=True, fastmath=False, error_model="numpy", inline="always")
def _plane_pass(x0, x1, x2, planes, fq, eps_near, f0, f1):
    """fq[f] = 1 / (2 Delta_f) for f in [f0, f1).

    Returns how many of those faces have |dist| <= eps_near.
    """
    # 0-based loops over contiguous slices: with an offset index numba must
    # allow for negative indices, which stops LLVM from vectorizing.
    nx = planes[0, f0:f1]
    ny = planes[1, f0:f1]
    nz = planes[2, f0:f1]
    off = planes[3, f0:f1]
    area2 = planes[4, f0:f1]
    q_out = fq[f0:f1]
    near = 0
    for f in range(nx.shape[0]):
        dist = nx[f] * x0 + ny[f] * x1 + nz[f] * x2 - off[f]
        a2 = area2[f]
        near += 1 if (abs(dist) <= eps_near and a2 > 0.0) else 0
        q = -0.5 / (dist * a2)
        q_out[f] = q if a2 > 0.0 else 0.0
    return near


@njit(cache=True, fastmath=False, error_model="numpy", inline="always")
def _edge_pass(x0, x1, x2, edge_points, es, e0, e1):
    """For e in [e0, e1): es[0:3, e] = (p_a - x) x (p_b - x), es[3, e] = theta / |that|.

    The cross product is evaluated as (p_a - x) x (p_b - p_a) with the edge
    vector precomputed, which keeps it accurate for points far from a short
    edge (the plain form cancels there).
    """
    pax = edge_points[0, e0:e1]
    pay = edge_points[1, e0:e1]
    paz = edge_points[2, e0:e1]
    evx = edge_points[3, e0:e1]
    evy = edge_points[4, e0:e1]
    evz = edge_points[5, e0:e1]
    ecx = es[0, e0:e1]
    ecy = es[1, e0:e1]
    ecz = es[2, e0:e1]
    er = es[3, e0:e1]
    for e in range(pax.shape[0]):
        ax = pax[e] - x0
        ay = pay[e] - x1
        az = paz[e] - x2
        ex = evx[e]
        ey = evy[e]
        ez = evz[e]
        bx = ax + ex
        by = ay + ey
        bz = az + ez
        cx = ay * ez - az * ey
        cy = az * ex - ax * ez
        cz = ax * ey - ay * ex
        cl = math.sqrt(cx * cx + cy * cy + cz * cz)
        dt = ax * bx + ay * by + az * bz
        r = _atan2_pos(cl, dt) / cl
        ecx[e] = cx
        ecy[e] = cy
        ecz[e] = cz
        # cl == 0 (inf or nan above): the point is on the edge's line, where
        # the edge adds nothing (theta = 0) or the point is on the edge,
        # which the caller has handled.
        er[e] = r if r <= _R_MAX else 0.0


@njit(cache=True, fastmath=False, error_model="numpy", inline="always")
def _face_pass(face_idx, fq, es, acc, f0, f1):
    """Accumulate the weights / distances of faces [f0, f1) into ``acc``."""
    ecx = es[0]
    ecy = es[1]
    ecz = es[2]
    er = es[3]
    fqs = fq[f0:f1]
    idx = face_idx[f0:f1]
    for f in range(fqs.shape[0]):
        q = fqs[f]
        i0 = idx[f, 0]
        i1 = idx[f, 1]
        i2 = idx[f, 2]
        e01 = idx[f, 3]
        e12 = idx[f, 4]
        e20 = idx[f, 5]
        # +1 where the face runs along the edge from the lower vertex id.
        s01 = 1.0 if i0 < i1 else -1.0
        s12 = 1.0 if i1 < i2 else -1.0
        s20 = 1.0 if i2 < i0 else -1.0
        c01x = ecx[e01]
        c01y = ecy[e01]
        c01z = ecz[e01]
        c12x = ecx[e12]
        c12y = ecy[e12]
        c12z = ecz[e12]
        c20x = ecx[e20]
        c20y = ecy[e20]
        c20z = ecz[e20]
        k01 = s01 * er[e01]
        k12 = s12 * er[e12]
        k20 = s20 * er[e20]
        mx = k01 * c01x + k12 * c12x + k20 * c20x
        my = k01 * c01y + k12 * c12y + k20 * c20y
        mz = k01 * c01z + k12 * c12z + k20 * c20z
        acc[i0] += s12 * (c12x * mx + c12y * my + c12z * mz) * q
        acc[i1] += s20 * (c20x * mx + c20y * my + c20z * mz) * q
        acc[i2] += s01 * (c01x * mx + c01y * my + c01z * mz) * q


@njit(cache=True, fastmath=False, error_model="numpy", inline="always")
def _near_faces(x0, x1, x2, verts_t, face_idx, planes, fq, eps_v, eps_plane, eps_near,
                f0, f1, row):
    """Handle a point within ``eps_near`` of the planes of some of faces [f0, f1).

    For each such face:

    * within ``eps_plane`` of the plane and of the closed triangle: the point
      is on the cage. Write the unit row of a vertex within ``eps_v`` or else
      the barycentric coordinates in that face (which covers edges), and
      return True;
    * within ``eps_plane`` of the plane but outside the triangle: the face's
      contribution vanishes in the limit, zero its ``fq``;
    * otherwise, with the projection outside the triangle, at a distance
      ``rho`` from it (measured to the farthest violated edge line) and
      ``|dist| <= RHO_RATIO * rho``: zero its ``fq`` too. The face then sees
      the point at a grazing angle: its exact contribution is of order
      ``|dist| / rho``, while evaluating it would cost a cancellation error of
      order ``1e-16 * rho / |dist|``; the ratio 1e-8 balances the two.

    Returns False unless the row was written.
    """
    vx = verts_t[0]
    vy = verts_t[1]
    vz = verts_t[2]
    nv = vx.shape[0]
    for f in range(f0, f1):
        area2 = planes[4, f]
        if area2 == 0.0:
            continue
        nx = planes[0, f]
        ny = planes[1, f]
        nz = planes[2, f]
        dist = nx * x0 + ny * x1 + nz * x2 - planes[3, f]
        adist = abs(dist)
        if adist > eps_near:
            continue
        i0 = face_idx[f, 0]
        i1 = face_idx[f, 1]
        i2 = face_idx[f, 2]
        # Barycentric coordinates of the projection onto the plane.
        qx = x0 - vx[i0]
        qy = x1 - vy[i0]
        qz = x2 - vz[i0]
        e1x = vx[i1] - vx[i0]
        e1y = vy[i1] - vy[i0]
        e1z = vz[i1] - vz[i0]
        e2x = vx[i2] - vx[i0]
        e2y = vy[i2] - vy[i0]
        e2z = vz[i2] - vz[i0]
        b1 = (nx * (qy * e2z - qz * e2y) + ny * (qz * e2x - qx * e2z)
              + nz * (qx * e2y - qy * e2x)) / area2
        b2 = (nx * (e1y * qz - e1z * qy) + ny * (e1z * qx - e1x * qz)
              + nz * (e1x * qy - e1y * qx)) / area2
        b0 = 1.0 - b1 - b2
        # b_i * |N| / |opposite edge| is the signed distance of the projection
        # to the line of the edge opposite vertex i (positive inside).
        l0 = math.sqrt((e2x - e1x) ** 2 + (e2y - e1y) ** 2 + (e2z - e1z) ** 2)
        l1 = math.sqrt(e2x * e2x + e2y * e2y + e2z * e2z)
        l2 = math.sqrt(e1x * e1x + e1y * e1y + e1z * e1z)
        h0 = b0 * area2 / l0
        h1 = b1 * area2 / l1
        h2 = b2 * area2 / l2
        rho = max(-h0, max(-h1, -h2))  # > 0 iff outside
        if adist <= eps_plane:
            if rho <= eps_plane:
                # On the cage: on a vertex of this face, or in the face.
                best = -1
                bestd = eps_v
                for i in (i0, i1, i2):
                    dx = vx[i] - x0
                    dy = vy[i] - x1
                    dz = vz[i] - x2
                    d = math.sqrt(dx * dx + dy * dy + dz * dz)
                    if d <= bestd:
                        bestd = d
                        best = i
                for j in range(nv):
                    row[j] = 0.0
                if best >= 0:
                    row[best] = 1.0
                    return True
                # Within eps_plane of an edge line counts as on that edge.
                c0 = b0 if h0 > eps_plane else 0.0
                c1 = b1 if h1 > eps_plane else 0.0
                c2 = b2 if h2 > eps_plane else 0.0
                t = c0 + c1 + c2
                if not t > 0.0:  # a triangle no wider than eps_plane
                    c0 = max(b0, 0.0)
                    c1 = max(b1, 0.0)
                    c2 = max(b2, 0.0)
                    t = c0 + c1 + c2
                row[i0] = c0 / t
                row[i1] = c1 / t
                row[i2] = c2 / t
                return True
            fq[f] = 0.0
        elif adist <= RHO_RATIO * rho:
            fq[f] = 0.0
    return False


@njit(cache=True, fastmath=False, error_model="numpy", inline="always")
def _mvc_point(x0, x1, x2, verts_t, face_idx, planes, edge_points, face_tiles, edge_tiles,
               eps_v, eps_plane, eps_near, fq, es, acc, row):
    """Exact coordinates of one point into ``row`` (length c, overwritten).

    The faces are processed in tiles (``face_tiles``), each with the edges
    first used by it (``edge_tiles``), so that the data a tile produces is
    consumed while still in cache. ``fq`` (f,), ``es`` (4, e) and ``acc``
    (c,) are scratch; ``row`` is written once at the end.
    """
    nv = row.shape[0]
    for j in range(nv):
        acc[j] = 0.0
    for t in range(face_tiles.shape[0] - 1):
        f0 = face_tiles[t]
        f1 = face_tiles[t + 1]
        near = _plane_pass(x0, x1, x2, planes, fq, eps_near, f0, f1)
        if near > 0:
            if _near_faces(x0, x1, x2, verts_t, face_idx, planes, fq, eps_v, eps_plane,
                           eps_near, f0, f1, acc):
                for j in range(nv):
                    row[j] = acc[j]
                return
        _edge_pass(x0, x1, x2, edge_points, es, edge_tiles[t], edge_tiles[t + 1])
        _face_pass(face_idx, fq, es, acc, f0, f1)
    # Normalize; four partial sums (one running sum is latency bound).
    t0 = 0.0
    t1 = 0.0
    t2 = 0.0
    t3 = 0.0
    n4 = nv - nv % 4
    for j in range(0, n4, 4):
        t0 += acc[j]
        t1 += acc[j + 1]
        t2 += acc[j + 2]
        t3 += acc[j + 3]
    for j in range(n4, nv):
        t0 += acc[j]
    inv = 1.0 / ((t0 + t1) + (t2 + t3))
    for j in range(nv):
        row[j] = acc[j] * inv


@njit(cache=True, fastmath=False, error_model="numpy", parallel=True)
def _mvc_dense_kernel(points, verts_t, face_idx, planes, edge_points, face_tiles, edge_tiles,
                      eps_v, eps_plane, eps_near, out, n_blocks):
    """out[i] = coordinates of points[i]; points split into n_blocks parallel blocks."""
    n = points.shape[0]
    nf = face_idx.shape[0]
    ne = edge_points.shape[1]
    nv = out.shape[1]
    for blk in prange(n_blocks):
        start = (blk * n) // n_blocks
        stop = ((blk + 1) * n) // n_blocks
        if stop <= start:
            continue
        fq = np.empty(nf)
        es = np.empty((4, ne))
        acc = np.empty(nv)
        for i in range(start, stop):
            _mvc_point(points[i, 0], points[i, 1], points[i, 2], verts_t, face_idx, planes,
                       edge_points, face_tiles, edge_tiles, eps_v, eps_plane, eps_near,
                       fq, es, acc, out[i])


def _n_blocks(n: int) -> int:
    threads = numba.get_num_threads()
    return max(1, min(n, 8 * threads))


def compute_into(points: np.ndarray, cage: CageData, out: np.ndarray) -> None:
    """Exact coordinates of ``points`` (n, 3) written into ``out`` (n, c) float64.

    ``points`` must be finite, C-contiguous float64 and ``out`` C-contiguous;
    rows are overwritten. Internal helper shared with :mod:`hybridedit.binding`.
    """
    n = points.shape[0]
    if n == 0:
        return
    scale = cage.scale if cage.scale > 0 else 1.0
    _mvc_dense_kernel(
        points,
        cage.vertices_t,
        cage.face_idx,
        cage.planes,
        cage.edge_points,
        cage.face_tiles,
        cage.edge_tiles,
        VERTEX_EPS * scale,
        PLANE_EPS * scale,
        NEAR_EPS * scale,
        out,
        _n_blocks(n),
    )


def as_points(points: np.ndarray) -> np.ndarray:
    """``points`` as a C-contiguous finite (n, 3) float64 array, or ValueError."""
    p = np.asarray(points)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"points must be an (n, 3) array, got shape {p.shape}")
    if not (np.issubdtype(p.dtype, np.floating) or np.issubdtype(p.dtype, np.integer)):
        raise ValueError(f"points must be numeric, got dtype {p.dtype}")
    p = np.ascontiguousarray(p, dtype=np.float64)
    if not np.all(np.isfinite(p)):
        bad = int(np.flatnonzero(~np.all(np.isfinite(p), axis=1))[0])
        raise ValueError(f"points must be finite; point {bad} is {p[bad].tolist()}")
    return p


# ---------------------------------------------------------------------------
# Fast method: exact near field, quadrature far field
# ---------------------------------------------------------------------------
# With phi_i the hat function of cage vertex i, the weight that face f gives
# vertex i (the kernel's w_i / d_i above) is the surface integral
#     W_i^f(x) = integral over f of phi_i(p) * n_f . (p - x) / |p - x|^4 dA,
# n_f the unit normal of the face's vertex order; n_f . (p - x) = off_f - n_f . x
# is constant over the face. For a face far from x compared with its size the
# integrand is smooth and a quadrature is accurate: the fast method replaces
# g(p) = 1 / |p - x|^4 by its quadratic interpolant through the face's three
# vertices and three edge midpoints, which integrates exactly against phi_i:
#     W_i^f ~= A_f (off_f - n_f . x) / 60 * (3 g_i - 4 g_jk + 8 T - S),
# S the sum of g over the face's vertices, T over its edge midpoints and g_jk
# the value at the midpoint of the edge opposite i. The values of g are
# computed once per point per cage vertex and per edge; no angle is needed.
# Its relative error per face is of order (r_f / distance)^3.
#
# Points are sorted along a Morton curve and processed in batches of LANES
# consecutive points ("lanes"); the far-field loops are vectorized over the
# lanes. Faces are grouped in blocks of FAST_BLOCK consecutive faces (Morton
# order). A face f is "near" a batch when some point of the batch is closer
# than ``far_ratio * r_f`` to its centroid, r_f the largest distance from the
# centroid to the face's vertices (tested per block first, then per face).
# Near faces are evaluated exactly (vectorized over the lanes, with the
# exact kernel's scalar path and special cases for points within NEAR_EPS of
# a near face's plane, i.e. on or next to the cage), all others by the
# quadrature. The decisions depend on the batch, hence (within the
# quadrature's error) on the other points of the call, never on how a call
# is chunked.
#
# The far field is evaluated in single precision, relative to the batch's
# centre and with coordinates scaled to the cage's diagonal: it needs a
# relative accuracy of about 1e-7, far below the quadrature's own error, and
# single precision halves the data its loops move and doubles their width.
# Near weights, sums and rows are double precision.
#
# The quadrature breaks the exact linear precision of the coordinates a
# little (sum_i W_i (p_i - x) = r != 0, |r| about 1e-6 of the row's scale).
# With ``correct`` it is restored per point by adding mu_i * b . (p_i - x) to
# the weights, mu_i = |far-field weight of i|, where the 3-vector b solves
# sum_i mu_i (p_i - x)(p_i - x)^T b = -r; rows then reproduce linear
# functions to rounding, as the exact ones do. Binding applies it when the
# rows are kept whole (truncation 0); truncated rows skip it (it costs about
# 20% and changes rows by ~1e-5 of their magnitude, far below what the
# truncation drops).

#: Points per batch of the fast kernel (the length of its vectorized loops).
LANES = 32
#: Faces per block (the unit of the first near/far test).
FAST_BLOCK = 32
#: Default ratio of distance to face size beyond which a face is integrated
#: by quadrature (see the section comment).
FAR_RATIO = 3.0
#: A linear precision correction that would change a row by more than this
#: fraction of its magnitude is not applied (an ill-conditioned far field).
MAX_CORRECTION = 1e-2


@dataclass(frozen=True)
class FastCageData:
    """Cage arrays of the fast method (built by :func:`prepare_fast_cage`).

    Coordinates are ``(p - origin) / unit``, ``origin`` the centre of the
    cage's bounding box and ``unit`` its diagonal (mean value coordinates
    are invariant under such a map). Cage vertices are renumbered internally
    by first use in the face order, so that the data of a tile of faces is
    close in memory; ``perm[k]`` is the caller's index of internal vertex
    ``k``.

    Attributes
    ----------
    exact : CageData
        The exact kernel's data in these coordinates (faces in kernel order).
    origin : (3,) float64
    unit : float
    perm, inv_perm : (c,) int64
    verts_t : (3, c) float64
        Vertices in internal order.
    mids_t : (3, e) float64
        Edge midpoints (edges as in ``exact.edges``).
    qcoef : (4, f) float64
        ``A_f (off_f - n_f . x) / 60 = q0 + q1 x + q2 y + q3 z``.
    far_idx : (f, 6) uint32
        Internal vertex ids, then the edge ids of the edges 01, 12, 20.
    face_geo : (4, f) float64
        Centroid and radius (largest centroid-vertex distance) of each face.
    tile_verts, tile_edges, tile_blocks : (t + 1,) int64
        Vertices, edges and blocks first used by each tile of ``exact.face_tiles``.
    block_faces : (nb + 1,) int64
    block_geo : (5, nb) float64
        Centre, spread (largest centre-to-face-centroid distance) and size
        (largest face radius) of each block.
    """

    exact: CageData
    origin: np.ndarray
    unit: float
    perm: np.ndarray
    inv_perm: np.ndarray
    verts_t: np.ndarray
    mids_t: np.ndarray
    qcoef: np.ndarray
    far_idx: np.ndarray
    face_geo: np.ndarray
    tile_verts: np.ndarray
    tile_edges: np.ndarray
    tile_blocks: np.ndarray
    block_faces: np.ndarray
    block_geo: np.ndarray

    @property
    def n_vertices(self) -> int:
        return self.exact.n_vertices

    @property
    def scale(self) -> float:
        return self.exact.scale


def prepare_fast_cage(cage_vertices: np.ndarray, cage_faces: np.ndarray) -> FastCageData:
    """Validate a cage and precompute the fast kernel's arrays (see :class:`FastCageData`)."""
    v = np.asarray(cage_vertices)
    origin = np.zeros(3)
    unit = 1.0
    if (v.ndim == 2 and v.shape[1] == 3 and v.shape[0] > 0 and np.issubdtype(v.dtype, np.number)
            and np.all(np.isfinite(v))):
        v = np.asarray(v, dtype=np.float64)
        origin = 0.5 * (v.min(axis=0) + v.max(axis=0))
        diag = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))
        unit = diag if diag > 0 else 1.0
        v = (v - origin) / unit
    ex = prepare_cage(v, cage_faces)  # validates
    f = ex.faces
    nf = len(f)
    c = ex.n_vertices
    # Internal vertex order: by first use in the kernel's face order.
    used, first = np.unique(f.ravel(), return_index=True)
    by_use = np.argsort(first, kind="stable")
    perm = np.concatenate([used[by_use], np.setdiff1d(np.arange(c), used)]).astype(np.int64)
    inv_perm = np.empty(c, dtype=np.int64)
    inv_perm[perm] = np.arange(c)
    first_face = np.sort(first) // 3
    tile_verts = np.searchsorted(first_face, ex.face_tiles, side="left").astype(np.int64)
    verts_t = np.ascontiguousarray(ex.vertices[perm].T)
    far_idx = np.concatenate([inv_perm[f], ex.face_idx[:, 3:].astype(np.int64)], axis=1)
    far_idx = np.ascontiguousarray(far_idx.astype(np.uint32))
    mids = 0.5 * (ex.vertices[ex.edges[:, 0]] + ex.vertices[ex.edges[:, 1]])
    mids_t = np.ascontiguousarray(mids.T)
    planes = ex.planes
    qcoef = np.empty((4, nf))
    qcoef[0] = planes[4] * planes[3] / 120.0  # planes[4] is twice the area
    qcoef[1:4] = -planes[4] * planes[0:3] / 120.0
    tri = ex.vertices[f]
    cen = tri.mean(axis=1)
    rad = np.linalg.norm(tri - cen[:, None, :], axis=2).max(axis=1)
    face_geo = np.ascontiguousarray(np.concatenate([cen.T, rad[None]]))
    # Blocks of FAST_BLOCK faces (a divisor of FACE_TILE: tiles hold whole blocks).
    block_faces = np.unique(np.append(np.arange(0, nf, FAST_BLOCK), nf)).astype(np.int64)
    nb = len(block_faces) - 1
    tile_blocks = np.searchsorted(block_faces, ex.face_tiles, side="left").astype(np.int64)
    bid = np.arange(nf) // FAST_BLOCK
    cnt = np.bincount(bid, minlength=nb).astype(np.float64)
    bc = np.stack([np.bincount(bid, weights=cen[:, k], minlength=nb) for k in range(3)]) / cnt
    spread = np.zeros(nb)
    np.maximum.at(spread, bid, np.linalg.norm(cen - bc.T[bid], axis=1))
    size = np.zeros(nb)
    np.maximum.at(size, bid, rad)
    block_geo = np.ascontiguousarray(np.concatenate([bc, spread[None], size[None]]))
    return FastCageData(
        exact=ex, origin=origin, unit=unit, perm=perm, inv_perm=inv_perm, verts_t=verts_t,
        mids_t=mids_t,
        qcoef=np.ascontiguousarray(qcoef), far_idx=far_idx, face_geo=face_geo,
        tile_verts=tile_verts, tile_edges=ex.edge_tiles, tile_blocks=tile_blocks,
        block_faces=block_faces, block_geo=block_geo,
    )


_F0 = np.float32(0.0)
#: Cap of 1 / |p - x|^4 in the far field (lengths in units of the cage's
#: diagonal; float32 overflows beyond 3.4e38). A face is far only from points
#: at least (far_ratio - 1) r_f from its vertices, so the cap is reached only
#: by faces smaller than about 1e-8 of the cage; it keeps inf * 0 out of the
#: sums.
_G_MAX = np.float32(1e30)


# The loops over a batch's lanes are written as explicit SIMD code (LLVM IR
# through numba's ``intrinsic``): numba cannot tell LLVM that the rows a loop
# reads and writes do not overlap, and the run-time overlap checks LLVM then
# inserts before every such loop cost more than the loop itself. Every
# operation is the plain IEEE one, in the order written (no fused
# multiply-add, no reassociation), as in the rest of this module.

#: float32 values per vector of the lane loops (LANES must be a multiple).
_VW = 16
assert LANES % _VW == 0


def _vec_helpers(builder):
    """The float32 vector type of the lane loops, a splat and a constant maker."""
    vt = ir.VectorType(ir.FloatType(), _VW)

    def splat(x):
        zero = ir.Constant(ir.IntType(32), 0)
        v = builder.insert_element(ir.Constant(vt, ir.Undefined), x, zero)
        mask = ir.Constant(ir.VectorType(ir.IntType(32), _VW), [0] * _VW)
        return builder.shuffle_vector(v, v, mask)

    def const(x):
        return ir.Constant(vt, [float(x)] * _VW)

    return vt, splat, const


def _row_data(context, builder, ty, value):
    ary = context.make_array(ty)(context, builder, value)
    return ary.data, cgutils.unpack_tuple(builder, ary.shape, 1)[0]


_F32_ROW = types.Array(types.float32, 1, "C")


@intrinsic
def _far_rows(typingctx, Y0, Y1, Y2, G0, G1, G2, M01, M12, M20, A0, A1, A2, q0, q1, q2, q3):
    """A_k[l] += q(l) * (3 G_k[l] - 4 M_opp(k)[l] + 8 (M01 + M12 + M20)[l] - (G0 + G1 + G2)[l]).

    All rows float32 of the same length (a multiple of _VW), ``q(l) = q0 +
    q1 Y0[l] + q2 Y1[l] + q3 Y2[l]`` (float32 scalars): the quadrature weights
    of one face for every lane (see the section comment).
    """
    sig = types.void(*([_F32_ROW] * 12), types.float32, types.float32, types.float32,
                     types.float32)

    def codegen(context, builder, sig, args):
        vt, splat, const = _vec_helpers(builder)
        ptrs = []
        for k in range(12):
            data, n = _row_data(context, builder, sig.args[k], args[k])
            ptrs.append(data)
        q = [splat(a) for a in args[12:16]]
        c3, c4, c8 = const(3.0), const(4.0), const(8.0)
        fa, fm, fs = builder.fadd, builder.fmul, builder.fsub
        nvec = builder.udiv(n, ir.Constant(n.type, _VW))
        with cgutils.for_range(builder, nvec) as loop:
            off = builder.mul(loop.index, ir.Constant(n.type, _VW))
            vptr = [builder.bitcast(builder.gep(p, [off]), vt.as_pointer()) for p in ptrs]
            y0, y1, y2, g0, g1, g2, m01, m12, m20, a0, a1, a2 = [
                builder.load(p, align=4) for p in vptr]
            qq = fa(fa(fa(q[0], fm(q[1], y0)), fm(q[2], y1)), fm(q[3], y2))
            base = fs(fm(c8, fa(fa(m01, m12), m20)), fa(fa(g0, g1), g2))
            a0 = fa(a0, fm(qq, fa(fs(fm(c3, g0), fm(c4, m12)), base)))
            a1 = fa(a1, fm(qq, fa(fs(fm(c3, g1), fm(c4, m20)), base)))
            a2 = fa(a2, fm(qq, fa(fs(fm(c3, g2), fm(c4, m01)), base)))
            for p, v in zip(vptr[9:], (a0, a1, a2)):
                builder.store(v, p, align=4)
        return context.get_dummy_value()

    return sig, codegen


@intrinsic
def _g_row(typingctx, Y0, Y1, Y2, G, px, py, pz):
    """G[l] = min(1 / r2^2, _G_MAX), r2 = |(px, py, pz) - (Y0, Y1, Y2)[l]|^2 (float32 rows)."""
    sig = types.void(*([_F32_ROW] * 4), types.float32, types.float32, types.float32)

    def codegen(context, builder, sig, args):
        vt, splat, const = _vec_helpers(builder)
        ptrs = []
        for k in range(4):
            data, n = _row_data(context, builder, sig.args[k], args[k])
            ptrs.append(data)
        p = [splat(a) for a in args[4:7]]
        one, gmax = const(1.0), const(float(_G_MAX))
        fa, fm, fs = builder.fadd, builder.fmul, builder.fsub
        nvec = builder.udiv(n, ir.Constant(n.type, _VW))
        with cgutils.for_range(builder, nvec) as loop:
            off = builder.mul(loop.index, ir.Constant(n.type, _VW))
            vptr = [builder.bitcast(builder.gep(q, [off]), vt.as_pointer()) for q in ptrs]
            y0, y1, y2 = [builder.load(q, align=4) for q in vptr[:3]]
            dx = fs(p[0], y0)
            dy = fs(p[1], y1)
            dz = fs(p[2], y2)
            r2 = fa(fa(fm(dx, dx), fm(dy, dy)), fm(dz, dz))
            g = builder.fdiv(one, fm(r2, r2))
            # min(g, gmax) as numpy's min: g if g < gmax (nan stays nan).
            lt = builder.fcmp_ordered(">", g, gmax)
            builder.store(builder.select(lt, gmax, g), vptr[3], align=4)
        return context.get_dummy_value()

    return sig, codegen


@njit(cache=True, fastmath=False, error_model="numpy", inline="always")
def _g_pass(Y, cx, cy, cz, pts_t, g, v0, v1):
    """g[v, l] = 1 / |pts_t[:, v] - c - Y[:, l]|^4 (capped) for v in [v0, v1), every lane l.

    ``Y`` (3, lanes) float32 holds the lanes' points relative to ``c``.
    """
    Y0 = Y[0]
    Y1 = Y[1]
    Y2 = Y[2]
    for v in range(v0, v1):
        _g_row(Y0, Y1, Y2, g[v], np.float32(pts_t[0, v] - cx), np.float32(pts_t[1, v] - cy),
               np.float32(pts_t[2, v] - cz))


@njit(cache=True, fastmath=False, error_model="numpy", inline="always")
def _far_face(Y, cx, cy, cz, qcoef, far_idx, gv, ge, accf, f):
    """Quadrature weights of face f for every lane, added to ``accf`` (float32)."""
    q1 = qcoef[1, f]
    q2 = qcoef[2, f]
    q3 = qcoef[3, f]
    q0 = np.float32(qcoef[0, f] + q1 * cx + q2 * cy + q3 * cz)
    i0 = far_idx[f, 0]
    i1 = far_idx[f, 1]
    i2 = far_idx[f, 2]
    _far_rows(Y[0], Y[1], Y[2], gv[i0], gv[i1], gv[i2], ge[far_idx[f, 3]], ge[far_idx[f, 4]],
              ge[far_idx[f, 5]], accf[i0], accf[i1], accf[i2], q0, np.float32(q1),
              np.float32(q2), np.float32(q3))


@njit(cache=True, fastmath=False, error_model="numpy")
def _exact_face(x0, x1, x2, verts_t, s0, s1, s2, i0, i1, i2, q, acc):
    """Add the exact weights / distances of face (i0, i1, i2) to ``acc[s0, s1, s2]``.

    ``q = 1 / (2 Delta_f)`` as computed by ``_plane_pass``; the same formulas
    as ``_edge_pass`` and ``_face_pass`` with the edges taken in face order.
    """
    p0x = verts_t[0, i0]
    p0y = verts_t[1, i0]
    p0z = verts_t[2, i0]
    p1x = verts_t[0, i1]
    p1y = verts_t[1, i1]
    p1z = verts_t[2, i1]
    p2x = verts_t[0, i2]
    p2y = verts_t[1, i2]
    p2z = verts_t[2, i2]
    a0x = p0x - x0
    a0y = p0y - x1
    a0z = p0z - x2
    a1x = p1x - x0
    a1y = p1y - x1
    a1z = p1z - x2
    a2x = p2x - x0
    a2y = p2y - x1
    a2z = p2z - x2
    # c_ab = a_a x a_b, evaluated as a_a x (p_b - p_a).
    e01x = p1x - p0x
    e01y = p1y - p0y
    e01z = p1z - p0z
    e12x = p2x - p1x
    e12y = p2y - p1y
    e12z = p2z - p1z
    e20x = p0x - p2x
    e20y = p0y - p2y
    e20z = p0z - p2z
    c01x = a0y * e01z - a0z * e01y
    c01y = a0z * e01x - a0x * e01z
    c01z = a0x * e01y - a0y * e01x
    c12x = a1y * e12z - a1z * e12y
    c12y = a1z * e12x - a1x * e12z
    c12z = a1x * e12y - a1y * e12x
    c20x = a2y * e20z - a2z * e20y
    c20y = a2z * e20x - a2x * e20z
    c20z = a2x * e20y - a2y * e20x
    l01 = math.sqrt(c01x * c01x + c01y * c01y + c01z * c01z)
    l12 = math.sqrt(c12x * c12x + c12y * c12y + c12z * c12z)
    l20 = math.sqrt(c20x * c20x + c20y * c20y + c20z * c20z)
    r01 = _atan2_pos(l01, a0x * a1x + a0y * a1y + a0z * a1z) / l01
    r12 = _atan2_pos(l12, a1x * a2x + a1y * a2y + a1z * a2z) / l12
    r20 = _atan2_pos(l20, a2x * a0x + a2y * a0y + a2z * a0z) / l20
    r01 = r01 if r01 <= _R_MAX else 0.0
    r12 = r12 if r12 <= _R_MAX else 0.0
    r20 = r20 if r20 <= _R_MAX else 0.0
    mx = r01 * c01x + r12 * c12x + r20 * c20x
    my = r01 * c01y + r12 * c12y + r20 * c20y
    mz = r01 * c01z + r12 * c12z + r20 * c20z
    acc[s0] += (c12x * mx + c12y * my + c12z * mz) * q
    acc[s1] += (c20x * mx + c20y * my + c20z * mz) * q
    acc[s2] += (c01x * mx + c01y * my + c01z * mz) * q


@njit(cache=True, fastmath=False, error_model="numpy")
def _exact_face_lanes(X, verts_t, planes, i0, i1, i2, f, W):
    """``W[k, l]`` = exact weight / distance that face f gives its vertex k at lane l.

    The arithmetic of ``_plane_pass`` and ``_exact_face``, vectorized over
    the lanes. Lanes within ``eps_near`` of the face's plane must be handled
    by the scalar path instead (their values here are meaningless).
    """
    nx = planes[0, f]
    ny = planes[1, f]
    nz = planes[2, f]
    off = planes[3, f]
    area2 = planes[4, f]
    p0x = verts_t[0, i0]
    p0y = verts_t[1, i0]
    p0z = verts_t[2, i0]
    p1x = verts_t[0, i1]
    p1y = verts_t[1, i1]
    p1z = verts_t[2, i1]
    p2x = verts_t[0, i2]
    p2y = verts_t[1, i2]
    p2z = verts_t[2, i2]
    e01x = p1x - p0x
    e01y = p1y - p0y
    e01z = p1z - p0z
    e12x = p2x - p1x
    e12y = p2y - p1y
    e12z = p2z - p1z
    e20x = p0x - p2x
    e20y = p0y - p2y
    e20z = p0z - p2z
    X0 = X[0]
    X1 = X[1]
    X2 = X[2]
    W0 = W[0]
    W1 = W[1]
    W2 = W[2]
    for l in range(X.shape[1]):
        x0 = X0[l]
        x1 = X1[l]
        x2 = X2[l]
        dist = nx * x0 + ny * x1 + nz * x2 - off
        q = -0.5 / (dist * area2)
        q = q if area2 > 0.0 else 0.0
        a0x = p0x - x0
        a0y = p0y - x1
        a0z = p0z - x2
        a1x = p1x - x0
        a1y = p1y - x1
        a1z = p1z - x2
        a2x = p2x - x0
        a2y = p2y - x1
        a2z = p2z - x2
        c01x = a0y * e01z - a0z * e01y
        c01y = a0z * e01x - a0x * e01z
        c01z = a0x * e01y - a0y * e01x
        c12x = a1y * e12z - a1z * e12y
        c12y = a1z * e12x - a1x * e12z
        c12z = a1x * e12y - a1y * e12x
        c20x = a2y * e20z - a2z * e20y
        c20y = a2z * e20x - a2x * e20z
        c20z = a2x * e20y - a2y * e20x
        l01 = math.sqrt(c01x * c01x + c01y * c01y + c01z * c01z)
        l12 = math.sqrt(c12x * c12x + c12y * c12y + c12z * c12z)
        l20 = math.sqrt(c20x * c20x + c20y * c20y + c20z * c20z)
        r01 = _atan2_pos(l01, a0x * a1x + a0y * a1y + a0z * a1z) / l01
        r12 = _atan2_pos(l12, a1x * a2x + a1y * a2y + a1z * a2z) / l12
        r20 = _atan2_pos(l20, a2x * a0x + a2y * a0y + a2z * a0z) / l20
        r01 = r01 if r01 <= _R_MAX else 0.0
        r12 = r12 if r12 <= _R_MAX else 0.0
        r20 = r20 if r20 <= _R_MAX else 0.0
        mx = r01 * c01x + r12 * c12x + r20 * c20x
        my = r01 * c01y + r12 * c12y + r20 * c20y
        mz = r01 * c01z + r12 * c12z + r20 * c20z
        W0[l] = (c12x * mx + c12y * my + c12z * mz) * q
        W1[l] = (c20x * mx + c20y * my + c20z * mz) * q
        W2[l] = (c01x * mx + c01y * my + c01z * mz) * q


@njit(cache=True, fastmath={"reassoc", "nsz"}, error_model="numpy")
def _finish_row(w, nacc, near_list, n_slots, verts_t, x0, x1, x2, correct, row):
    """``row`` = normalized far weights ``w`` plus near weights ``nacc[k]`` at ``near_list[k]``.

    With ``correct``, applies the linear precision correction of the section
    comment with mu_j = |w_j| (the far weights). ``row`` may be ``w``.
    Compiled with reassociation allowed, so that the sums vectorize: the
    result is deterministic but may differ in the last bits from the order
    written.
    """
    c = w.shape[0]
    vx = verts_t[0]
    vy = verts_t[1]
    vz = verts_t[2]
    s = 0.0
    sabs = 0.0
    for k in range(n_slots):
        s += nacc[k]
        sabs += abs(nacc[k])
    if not correct:
        for j in range(c):
            s += w[j]
        inv = 1.0 / s
        for j in range(c):
            row[j] = w[j] * inv
        for k in range(n_slots):
            row[near_list[k]] += nacc[k] * inv
        return
    rx = 0.0
    ry = 0.0
    rz = 0.0
    for k in range(n_slots):
        j = near_list[k]
        rx += nacc[k] * (vx[j] - x0)
        ry += nacc[k] * (vy[j] - x1)
        rz += nacc[k] * (vz[j] - x2)
    m0 = 0.0
    mx = 0.0
    my = 0.0
    mz = 0.0
    mxx = 0.0
    mxy = 0.0
    mxz = 0.0
    myy = 0.0
    myz = 0.0
    mzz = 0.0
    for j in range(c):
        wj = w[j]
        mu = abs(wj)
        ax = vx[j] - x0
        ay = vy[j] - x1
        az = vz[j] - x2
        s += wj
        sabs += mu
        rx += wj * ax
        ry += wj * ay
        rz += wj * az
        m0 += mu
        max_ = mu * ax
        may = mu * ay
        maz = mu * az
        mx += max_
        my += may
        mz += maz
        mxx += max_ * ax
        mxy += max_ * ay
        mxz += max_ * az
        myy += may * ay
        myz += may * az
        mzz += maz * az
    # Solve M b = -r (M symmetric positive semi-definite) by the adjugate.
    c00 = myy * mzz - myz * myz
    c01 = mxz * myz - mxy * mzz
    c02 = mxy * myz - mxz * myy
    c11 = mxx * mzz - mxz * mxz
    c12 = mxy * mxz - mxx * myz
    c22 = mxx * myy - mxy * mxy
    det = mxx * c00 + mxy * c01 + mxz * c02
    tr = mxx + myy + mzz
    bx = 0.0
    by = 0.0
    bz = 0.0
    if tr > 0.0 and det > 1e-12 * tr * tr * tr:
        inv = -1.0 / det
        bx = (c00 * rx + c01 * ry + c02 * rz) * inv
        by = (c01 * rx + c11 * ry + c12 * rz) * inv
        bz = (c02 * rx + c12 * ry + c22 * rz) * inv
        # sum_j |mu_j b . a_j| <= sqrt(sum_j mu_j) sqrt(b^T M b), b^T M b = -b . r
        btmb = -(bx * rx + by * ry + bz * rz)
        if not (m0 * btmb <= (MAX_CORRECTION * sabs) ** 2):
            bx = 0.0
            by = 0.0
            bz = 0.0
    inv = 1.0 / (s + bx * mx + by * my + bz * mz)
    for j in range(c):
        wj = w[j]
        row[j] = (wj + abs(wj) * (bx * (vx[j] - x0) + by * (vy[j] - x1) + bz * (vz[j] - x2))) * inv
    for k in range(n_slots):
        row[near_list[k]] += nacc[k] * inv


@njit(cache=True, fastmath=False, error_model="numpy")
def _near_block(x0, x1, x2, verts_t, face_idx, planes, fq, eps_v, eps_plane, eps_near, f0, f1,
                row):
    """``_plane_pass`` then ``_near_faces`` on faces [f0, f1) (compiled once, not inlined)."""
    _plane_pass(x0, x1, x2, planes, fq, eps_near, f0, f1)
    return _near_faces(x0, x1, x2, verts_t, face_idx, planes, fq, eps_v, eps_plane, eps_near,
                       f0, f1, row)


@njit(cache=True, fastmath=False, error_model="numpy")
def _fast_batch(X, x_center, x_radius, dest, cg, eps_v, eps_plane, eps_near, far_ratio, correct,
                sc, wk):
    """Rows of one batch of points (internal column order) into the scratch ``tf``.

    ``cg`` is :func:`_cage_arrays`, ``sc`` :func:`fast_scratch` (worker
    ``wk``'s part is used). On return ``tf[l]`` holds the row of every lane
    with ``dest[l] >= 0``. ``accf``, ``near_v`` and ``nacc`` must be zero on
    entry and are left zero; ``near_v[j]`` is 1 + the slot of vertex j in
    ``nacc`` once a near face uses it (``near_list`` lists them by slot).
    """
    (verts_t, mids_t, qcoef, far_idx, planes, face_geo, tile_verts, tile_edges, tile_blocks,
     block_faces, block_geo) = cg
    Y = sc[0][wk]
    gv = sc[1][wk]
    ge = sc[2][wk]
    accf = sc[3][wk]
    fq = sc[4][wk]
    far = sc[5][wk]
    nearf = sc[6][wk]
    snapped = sc[7][wk]
    near_v = sc[8][wk]
    near_list = sc[9][wk]
    nacc = sc[10][wk]
    tf = sc[11][wk]
    wl = sc[12][wk]
    scalar = sc[13][wk]
    c = verts_t.shape[1]
    nb = block_geo.shape[1]
    nl = X.shape[1]
    cx = x_center[0]
    cy = x_center[1]
    cz = x_center[2]
    for l in range(nl):
        Y[0, l] = np.float32(X[0, l] - cx)
        Y[1, l] = np.float32(X[1, l] - cy)
        Y[2, l] = np.float32(X[2, l] - cz)
    for k in range(nb):
        dx = block_geo[0, k] - cx
        dy = block_geo[1, k] - cy
        dz = block_geo[2, k] - cz
        thr = block_geo[3, k] + far_ratio * block_geo[4, k] + x_radius
        far[k] = dx * dx + dy * dy + dz * dz > thr * thr
    for l in range(nl):
        snapped[l] = dest[l] < 0  # inactive lanes skip the exact work
    n_slots = 0
    for t in range(tile_verts.shape[0] - 1):
        _g_pass(Y, cx, cy, cz, verts_t, gv, tile_verts[t], tile_verts[t + 1])
        _g_pass(Y, cx, cy, cz, mids_t, ge, tile_edges[t], tile_edges[t + 1])
        for k in range(tile_blocks[t], tile_blocks[t + 1]):
            f0 = block_faces[k]
            f1 = block_faces[k + 1]
            block_far = far[k]
            n_near = 0
            for f in range(f0, f1):
                is_near = False
                if not block_far:
                    dx = face_geo[0, f] - cx
                    dy = face_geo[1, f] - cy
                    dz = face_geo[2, f] - cz
                    thr = far_ratio * face_geo[3, f] + x_radius
                    # (not > rather than <=: with an infinite ratio a face
                    # of zero size gives nan, and is near)
                    is_near = not (dx * dx + dy * dy + dz * dz > thr * thr)
                nearf[f - f0] = is_near
                if is_near:
                    n_near += 1
                    for m in range(3):
                        v = far_idx[f, m]
                        if near_v[v] == 0:
                            near_list[n_slots] = v
                            n_slots += 1
                            near_v[v] = n_slots
                else:
                    _far_face(Y, cx, cy, cz, qcoef, far_idx, gv, ge, accf, f)
            if n_near == 0:
                continue
            # Lanes within eps_near of the plane of a near face take the
            # scalar path with the exact kernel's special cases; the others
            # get the near faces' weights from the vectorized loop below.
            for l in range(nl):
                scalar[l] = snapped[l]
                if snapped[l]:
                    continue
                x0 = X[0, l]
                x1 = X[1, l]
                x2 = X[2, l]
                for f in range(f0, f1):
                    if nearf[f - f0] and planes[4, f] > 0.0:
                        dist = (planes[0, f] * x0 + planes[1, f] * x1 + planes[2, f] * x2
                                - planes[3, f])
                        if abs(dist) <= eps_near:
                            scalar[l] = True
                            break
                if not scalar[l]:
                    continue
                # On the cage: the row is final (written to tf[l], which the
                # transposition below then leaves alone).
                if _near_block(x0, x1, x2, verts_t, far_idx, planes, fq, eps_v, eps_plane,
                               eps_near, f0, f1, tf[l]):
                    snapped[l] = True
                    continue
                acc = nacc[l]
                for f in range(f0, f1):
                    if nearf[f - f0]:
                        _exact_face(x0, x1, x2, verts_t, near_v[far_idx[f, 0]] - 1,
                                    near_v[far_idx[f, 1]] - 1, near_v[far_idx[f, 2]] - 1,
                                    far_idx[f, 0], far_idx[f, 1], far_idx[f, 2], fq[f], acc)
            for f in range(f0, f1):
                if not nearf[f - f0]:
                    continue
                i0 = far_idx[f, 0]
                i1 = far_idx[f, 1]
                i2 = far_idx[f, 2]
                _exact_face_lanes(X, verts_t, planes, i0, i1, i2, f, wl)
                s0 = near_v[i0] - 1
                s1 = near_v[i1] - 1
                s2 = near_v[i2] - 1
                for l in range(nl):
                    if not scalar[l]:
                        nacc[l, s0] += wl[0, l]
                        nacc[l, s1] += wl[1, l]
                        nacc[l, s2] += wl[2, l]
    # Transpose the far weights to one row per lane, in blocks of accf that
    # stay in cache, and clear accf for the next batch.
    for j0 in range(0, c, 64):
        j1 = min(c, j0 + 64)
        for l in range(nl):
            if not snapped[l]:
                tfl = tf[l]
                for j in range(j0, j1):
                    tfl[j] = np.float64(accf[j, l])
        accf[j0:j1, :] = _F0
    for l in range(nl):
        if not snapped[l]:
            _finish_row(tf[l], nacc[l], near_list, n_slots, verts_t, X[0, l], X[1, l], X[2, l],
                        correct, tf[l])
        nacc[l, :n_slots] = 0.0
    for k in range(n_slots):
        near_v[near_list[k]] = 0


# Row truncation (the rule is described in hybridedit.binding): the fast
# kernel can truncate every row while it is still in cache and store only
# the kept entries, instead of writing dense rows to memory first.


@njit(cache=True, fastmath=False, error_model="numpy")
def _select_row(row, truncation, surv, vals):
    """The entries of ``row`` that truncation keeps (the row is not modified).

    The rule and its stages are described in :mod:`hybridedit.binding`.

    Returns ``(n_drop, n_live, order, dropped)``: the kept entries are
    ``surv[order[k]]`` for ``n_drop <= k < n_live``. ``n_live`` is -1 if the
    row holds an inf or nan. ``surv`` (int64) and ``vals`` (float64), both
    at least as long as the row, are scratch.
    """
    c = row.shape[0]
    # Row magnitude with four partial sums (a single running sum is bound by
    # the latency of the additions).
    m0 = 0.0
    m1 = 0.0
    m2 = 0.0
    m3 = 0.0
    c4 = c - c % 4
    for j in range(0, c4, 4):
        m0 += abs(row[j])
        m1 += abs(row[j + 1])
        m2 += abs(row[j + 2])
        m3 += abs(row[j + 3])
    for j in range(c4, c):
        m0 += abs(row[j])
    mag = (m0 + m1) + (m2 + m3)
    if not (mag < np.inf):
        return 0, -1, np.empty(0, dtype=np.int64), 0.0  # inf or nan in the row
    budget = truncation * mag
    # Stage 1: entries of magnitude <= budget / c are always dropped.
    small = budget / c
    n_surv = 0
    for j in range(c):
        # Branch-free compaction: always write, advance only for survivors.
        surv[n_surv] = j
        n_surv += 1 if abs(row[j]) > small else 0
    kept_mag = 0.0
    for k in range(n_surv):
        a = abs(row[surv[k]])
        vals[k] = a
        kept_mag += a
    dropped = max(0.0, mag - kept_mag)
    # Stage 1b: the same argument on the survivors with what is left of the
    # budget: those of magnitude <= left / n_live total at most ``left`` and
    # are the smallest survivors. Repeat while it drops something; each round
    # moves the still-live entries to the front of surv/vals.
    n_live = n_surv
    while n_live > 0:
        tau = (budget - dropped) / n_live
        k = 0
        gone = 0.0
        for m in range(n_live):
            a = vals[m]
            if a <= tau:
                gone += a
            else:
                # Swap it down to slot k; slots k..m-1 hold dropped entries.
                jj = surv[m]
                surv[m] = surv[k]
                vals[m] = vals[k]
                surv[k] = jj
                vals[k] = a
                k += 1
        if k == n_live:
            break
        dropped += gone
        n_live = k
    # Stage 2: sort what is left, smallest first, and drop while the budget
    # allows.
    order = np.argsort(vals[:n_live], kind="mergesort")
    n_drop = 0
    for k in range(n_live):
        a = vals[order[k]]
        if dropped + a <= budget:
            dropped += a
            n_drop += 1
        else:
            break
    return n_drop, n_live, order, dropped


@njit(cache=True, fastmath=False, error_model="numpy")
def _truncate_row_sparse(row, truncation, min_kept_sum, col_of_slot, surv, vals, out_cols,
                         out_vals):
    """Truncate ``row`` (not modified) into sorted ``out_cols`` / ``out_vals``; return nnz.

    Entry ``j`` of the row is column ``col_of_slot[j]`` of the result. The
    same entries and values as ``hybridedit.binding._truncate_row``. Returns
    -1 if the row holds an inf or nan, and -2 (outputs unusable) if more than
    ``len(out_cols)`` entries are kept.
    """
    c = row.shape[0]
    cap = out_cols.shape[0]
    n_drop, n_live, order, dropped = _select_row(row, truncation, surv, vals)
    if n_live < 0:
        return -1
    kept_sum = 0.0
    for k in range(n_drop, n_live):
        kept_sum += row[surv[order[k]]]
    scale = 1.0
    if kept_sum >= min_kept_sum:
        n_keep = n_live - n_drop
        if n_keep > cap:
            return -2
        for k in range(n_keep):
            # order[n_drop + k] is read before order[k] is written (k <= n_drop + k).
            j = surv[order[n_drop + k]]
            order[k] = col_of_slot[j]
            vals[k] = row[j]
        scale = 1.0 / kept_sum
    else:
        # Safeguard (see module docstring): keep every nonzero, unscaled.
        n_keep = 0
        for j in range(c):
            if row[j] != 0.0:
                n_keep += 1
        if n_keep > cap:
            return -2
        order = np.empty(n_keep, dtype=np.int64)
        n_keep = 0
        for j in range(c):
            if row[j] != 0.0:
                order[n_keep] = col_of_slot[j]
                vals[n_keep] = row[j]
                n_keep += 1
    srt = np.argsort(order[:n_keep])
    for k in range(n_keep):
        m = srt[k]
        out_cols[k] = order[m]
        out_vals[k] = vals[m] * scale
    return n_keep


@njit(cache=True, fastmath=False, error_model="numpy", parallel=True)
def _fast_kernel(bx, bsph, dest, cg, eps_v, eps_plane, eps_near, far_ratio, correct, sc, dense,
                 out, truncation, min_kept_sum, col_of_slot, counts, cols, vals):
    """Rows of every batch; lane ``l`` of batch ``b`` goes to row ``r = dest[b, l]`` if >= 0.

    With ``dense``, the row (internal column order) is copied to ``out[r]``;
    otherwise it is truncated into ``counts[r]``, ``cols[r]``, ``vals[r]``
    (see :func:`_truncate_row_sparse`; columns are ``col_of_slot[j]``).
    """
    nbatch = bx.shape[0]
    n_workers = sc[0].shape[0]
    c = col_of_slot.shape[0]
    for wk in prange(n_workers):
        tf = sc[11][wk]
        surv = np.empty(c, dtype=np.int64)
        work = np.empty(c)
        for b in range((wk * nbatch) // n_workers, ((wk + 1) * nbatch) // n_workers):
            _fast_batch(bx[b], bsph[b, 0:3], bsph[b, 3], dest[b], cg, eps_v, eps_plane,
                        eps_near, far_ratio, correct, sc, wk)
            for l in range(bx.shape[2]):
                r = dest[b, l]
                if r < 0:
                    continue
                if dense:
                    out[r, :] = tf[l]
                else:
                    counts[r] = _truncate_row_sparse(tf[l], truncation, min_kept_sum, col_of_slot,
                                                     surv, work, cols[r], vals[r])


def _cage_arrays(cage: FastCageData) -> tuple:
    """The cage arrays the fast kernels take, as one tuple."""
    return (cage.verts_t, cage.mids_t, cage.qcoef, cage.far_idx, cage.exact.planes, cage.face_geo,
            cage.tile_verts, cage.tile_edges, cage.tile_blocks, cage.block_faces, cage.block_geo)


def fast_scratch(cage: FastCageData, n_workers: int | None = None) -> tuple:
    """Work arrays of the fast kernels for ``n_workers`` parallel workers.

    Reusable across calls (the kernels leave the arrays that must start at
    zero zeroed); about ``40 * LANES * (vertices + edges)`` bytes per worker.
    """
    if n_workers is None:
        n_workers = 2 * numba.get_num_threads()
    w = max(1, int(n_workers))
    c = cage.n_vertices
    ne = cage.mids_t.shape[1]
    nf = cage.far_idx.shape[0]
    nb = cage.block_geo.shape[1]
    return (
        np.empty((w, 3, LANES), dtype=np.float32),  # 0 Y: lanes relative to the batch centre
        np.empty((w, c, LANES), dtype=np.float32),  # 1 gv: 1/|p - x|^4 at vertices
        np.empty((w, ne, LANES), dtype=np.float32),  # 2 ge: ... at edge midpoints
        np.zeros((w, c, LANES), dtype=np.float32),  # 3 accf: far weights
        np.empty((w, nf)),  # 4 fq: 1 / (2 Delta_f) of the exact kernel
        np.empty((w, nb), dtype=np.bool_),  # 5 far: block decisions
        np.empty((w, FAST_BLOCK), dtype=np.bool_),  # 6 nearf: face decisions in a block
        np.empty((w, LANES), dtype=np.bool_),  # 7 snapped (or inactive) lanes
        np.zeros((w, c), dtype=np.uint32),  # 8 near_v: slot + 1 of near vertices
        np.empty((w, c), dtype=np.int64),  # 9 near_list: near vertices by slot
        np.zeros((w, LANES, c)),  # 10 nacc: near weights by slot
        np.empty((w, LANES, c)),  # 11 tf: the rows
        np.empty((w, 3, LANES)),  # 12 wl: a near face's weights per lane
        np.empty((w, LANES), dtype=np.bool_),  # 13 scalar: lanes on the scalar path
    )


def fast_destinations(plan: "FastPlan", start: int, stop: int) -> tuple[int, int, np.ndarray]:
    """Batches ``k0:k1`` covering sorted positions [start, stop) and where their lanes go.

    ``dest[b, l]`` is the output row (``position - start``) of lane ``l`` of
    batch ``k0 + b``, or -1 outside [start, stop).
    """
    stop = min(stop, plan.n_points)
    k0 = start // LANES
    k1 = -(-stop // LANES)
    pos = np.arange(k0 * LANES, k1 * LANES, dtype=np.int64)
    dest = np.where((pos >= start) & (pos < stop), pos - start, -1).reshape(k1 - k0, LANES)
    return k0, k1, dest


def fast_tolerances(cage: FastCageData) -> tuple[float, float, float]:
    """The exact kernel's on-cage tolerances in the fast method's coordinates."""
    scale = cage.scale if cage.scale > 0 else 1.0
    return VERTEX_EPS * scale, PLANE_EPS * scale, NEAR_EPS * scale


@dataclass(frozen=True)
class FastPlan:
    """Points of one fast computation, sorted and cut into batches (:func:`plan_fast`).

    ``order[k]`` is the caller's index of the point at sorted position ``k``;
    batch ``b`` holds sorted positions ``b * LANES`` to ``b * LANES + LANES - 1``
    (the last batch is padded with copies of the last point).
    """

    order: np.ndarray
    bx: np.ndarray  # (nbatch, 3, LANES), in the cage's coordinates (FastCageData)
    bsph: np.ndarray  # (nbatch, 4): centre and radius of each batch

    @property
    def n_points(self) -> int:
        return int(self.order.shape[0])


def plan_fast(points: np.ndarray, cage: FastCageData) -> FastPlan:
    """Sort ``points`` (finite, (n, 3)) along a Morton curve and cut them into batches."""
    n = points.shape[0]
    if n == 0:
        return FastPlan(np.zeros(0, dtype=np.int64), np.zeros((0, 3, LANES)), np.zeros((0, 4)))
    order = _morton_order(points).astype(np.int64)
    nbatch = -(-n // LANES)
    pos = np.minimum(np.arange(nbatch * LANES), n - 1)
    pb = ((points[order[pos]] - cage.origin) / cage.unit).reshape(nbatch, LANES, 3)
    center = 0.5 * (pb.min(axis=1) + pb.max(axis=1))
    radius = np.linalg.norm(pb - center[:, None, :], axis=2).max(axis=1)
    bx = np.ascontiguousarray(pb.transpose(0, 2, 1))
    bsph = np.ascontiguousarray(np.concatenate([center, radius[:, None]], axis=1))
    return FastPlan(order=order, bx=bx, bsph=bsph)


def compute_fast_sorted(plan: FastPlan, cage: FastCageData, start: int, stop: int,
                        out: np.ndarray, far_ratio: float = FAR_RATIO,
                        correct: bool = True, scratch: tuple | None = None) -> None:
    """Fast coordinates of sorted positions [start, stop) into ``out[0:stop - start]``.

    Columns are in the cage's internal vertex order (``cage.perm``). The row
    of a point does not depend on ``start`` and ``stop``. ``scratch`` is
    :func:`fast_scratch` (made here if not given). Internal helper shared
    with :mod:`hybridedit.binding`.
    """
    if min(stop, plan.n_points) <= start:
        return
    _run_fast_kernel(plan, cage, start, stop, far_ratio, correct, scratch, out=out)


def _run_fast_kernel(plan, cage, start, stop, far_ratio, correct, scratch, out=None,
                     truncation=0.0, min_kept_sum=0.0, counts=None, cols=None, vals=None):
    """Run ``_fast_kernel`` on sorted positions [start, stop): dense rows into
    ``out`` if given, else truncated rows into ``counts`` / ``cols`` / ``vals``."""
    k0, k1, dest = fast_destinations(plan, start, stop)
    if scratch is None:
        scratch = fast_scratch(cage, min(k1 - k0, 2 * numba.get_num_threads()))
    eps_v, eps_plane, eps_near = fast_tolerances(cage)
    dense = out is not None
    if dense:
        counts = np.empty(0, dtype=np.int64)
        cols = np.empty((0, 1), dtype=np.int32)
        vals = np.empty((0, 1))
    else:
        out = np.empty((0, 1))
    _fast_kernel(plan.bx[k0:k1], plan.bsph[k0:k1], dest, _cage_arrays(cage), eps_v, eps_plane,
                 eps_near, float(far_ratio), bool(correct), scratch, dense, out, float(truncation),
                 float(min_kept_sum), cage.perm, counts, cols, vals)


def compute_fast_truncated(plan: "FastPlan", cage: "FastCageData", start: int, stop: int,
                           truncation: float, min_kept_sum: float, counts: np.ndarray,
                           cols: np.ndarray, vals: np.ndarray, far_ratio: float = FAR_RATIO,
                           scratch: tuple | None = None) -> None:
    """Fast coordinates of sorted positions [start, stop), truncated as they are made.

    Row ``r = position - start`` gets ``counts[r]`` entries in ``cols[r]``
    (caller's column indices, sorted) and ``vals[r]``, or ``counts[r] = -1``
    (not finite) or -2 (more entries kept than ``cols.shape[1]``). The rows
    are the uncorrected ones (see the section comment). Internal helper of
    :mod:`hybridedit.binding`.
    """
    if min(stop, plan.n_points) <= start:
        return
    _run_fast_kernel(plan, cage, start, stop, far_ratio, False, scratch, truncation=truncation,
                     min_kept_sum=min_kept_sum, counts=counts, cols=cols, vals=vals)


def check_far_ratio(far_ratio: float) -> float:
    """``far_ratio`` as a float >= 1 (``inf`` allowed: everything exact), or ValueError."""
    try:
        r = float(far_ratio)
    except (TypeError, ValueError):
        raise ValueError(f"far_ratio must be a number >= 1, got {far_ratio!r}") from None
    if not r >= 1.0:
        raise ValueError(f"far_ratio must be a number >= 1, got {far_ratio!r}")
    return r


def mean_value_coordinates(points: np.ndarray, cage_vertices: np.ndarray,
                           cage_faces: np.ndarray, method: str = "exact",
                           far_ratio: float = FAR_RATIO) -> np.ndarray:
    """Un-truncated mean value coordinates of points w.r.t. a closed cage.

    Parameters
    ----------
    points : (n, 3) array
    cage_vertices : (c, 3) array
    cage_faces : (f, 3) int array
        A closed, consistently oriented triangle surface (either orientation).
    method : "exact" or "fast"
        "exact" evaluates every face exactly; "fast" integrates faces farther
        than ``far_ratio`` times their size by quadrature (see the section
        "Fast method" of this module), within about 1e-5 of the row's
        magnitude of the exact coordinates at the default ratio.
    far_ratio : float >= 1
        Only for "fast" (``inf`` makes it exact).

    Returns
    -------
    (n, c) float64 array
        Row ``i`` holds the coordinates of ``points[i]``; every row sums to 1 and
        ``coords @ cage_vertices`` reproduces ``points`` (to rounding, with
        either method).
    """
    p = as_points(points)
    if method == "exact":
        cage = prepare_cage(cage_vertices, cage_faces)
        check_closed(cage.faces)
        out = np.empty((p.shape[0], cage.n_vertices))
        compute_into(p, cage, out)
        return out
    if method != "fast":
        raise ValueError(f"method must be 'exact' or 'fast', got {method!r}")
    ratio = check_far_ratio(far_ratio)
    fast = prepare_fast_cage(cage_vertices, cage_faces)
    check_closed(fast.exact.faces)
    plan = plan_fast(p, fast)
    buf = np.empty((p.shape[0], fast.n_vertices))
    compute_fast_sorted(plan, fast, 0, p.shape[0], buf, ratio)
    out = np.empty_like(buf)
    out[np.ix_(plan.order, fast.perm)] = buf
    return out
