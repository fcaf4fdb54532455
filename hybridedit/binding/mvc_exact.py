"""The exact 3D mean value coordinates with respect to a closed triangle cage.

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
from numba import njit, prange

__all__ = ["CageData", "prepare_cage", "compute_into", "as_points", "morton_order",
           "n_blocks", "exact_face", "exact_face_lanes_py", "compile_exact_face_lanes",
           "near_block",
           "tolerances"]

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


def n_blocks(n: int) -> int:
    """Parallel blocks for ``n`` rows (a few per thread, to balance the load)."""
    threads = numba.get_num_threads()
    return max(1, min(n, 8 * threads))


def compute_into(points: np.ndarray, cage: CageData, out: np.ndarray) -> None:
    """Exact coordinates of ``points`` (n, 3) written into ``out`` (n, c) float64.

    ``points`` must be finite, C-contiguous float64 and ``out`` C-contiguous;
    rows are overwritten. Internal helper shared with :mod:`hybridedit.binding.bind`.
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
        n_blocks(n),
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
# One face at a time (the near faces of the fast kernels)
# ---------------------------------------------------------------------------


@njit(cache=True, fastmath=False, error_model="numpy", inline="always")
def _face_weights(x0, x1, x2, p0x, p0y, p0z, p1x, p1y, p1z, p2x, p2y, p2z, q):
    """Exact weights / distances that face (p0, p1, p2) gives its vertices at x.

    ``q = 1 / (2 Delta_f)`` as computed by ``_plane_pass``; the formulas of
    ``_edge_pass`` and ``_face_pass`` with the edges taken in face order.
    """
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
    return ((c12x * mx + c12y * my + c12z * mz) * q, (c20x * mx + c20y * my + c20z * mz) * q,
            (c01x * mx + c01y * my + c01z * mz) * q)


@njit(cache=True, fastmath=False, error_model="numpy")
def exact_face(x0, x1, x2, verts_t, s0, s1, s2, i0, i1, i2, q, acc):
    """Add the exact weights / distances of face (i0, i1, i2) to ``acc[s0, s1, s2]``.

    ``q = 1 / (2 Delta_f)`` as computed by ``_plane_pass`` (0 for a face that
    ``_near_faces`` dropped).
    """
    w0, w1, w2 = _face_weights(x0, x1, x2, verts_t[0, i0], verts_t[1, i0], verts_t[2, i0],
                               verts_t[0, i1], verts_t[1, i1], verts_t[2, i1],
                               verts_t[0, i2], verts_t[1, i2], verts_t[2, i2], q)
    acc[s0] += w0
    acc[s1] += w1
    acc[s2] += w2


def exact_face_lanes_py(X, verts_t, planes, i0, i1, i2, f, W):
    """``W[k, l]`` = exact weight / distance that face f gives its vertex k at lane l.

    The arithmetic of ``_plane_pass`` and :func:`exact_face`, vectorized
    over the lanes (columns of ``X``, (3, lanes)). Lanes within ``eps_near``
    of the face's plane must be handled by the scalar path instead (their
    values here are meaningless).

    A plain Python function: each kernel module compiles its own copy with
    :func:`compile_exact_face_lanes` (called from another module's compiled
    code, the loop runs about 1.5 times slower).
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
        w0, w1, w2 = _face_weights(x0, x1, x2, p0x, p0y, p0z, p1x, p1y, p1z, p2x, p2y, p2z, q)
        W0[l] = w0
        W1[l] = w1
        W2[l] = w2


def compile_exact_face_lanes():
    """A compiled :func:`exact_face_lanes_py` for the calling module's kernels."""
    return njit(cache=True, fastmath=False, error_model="numpy")(exact_face_lanes_py)


@njit(cache=True, fastmath=False, error_model="numpy")
def near_block(x0, x1, x2, verts_t, face_idx, planes, fq, eps_v, eps_plane, eps_near, f0, f1,
               row):
    """``_plane_pass`` then ``_near_faces`` on faces [f0, f1) (compiled once, not inlined).

    ``fq[f]`` is left as the exact kernel uses it (0 for dropped faces);
    returns True if the point is on the cage (``row`` then written).
    """
    _plane_pass(x0, x1, x2, planes, fq, eps_near, f0, f1)
    return _near_faces(x0, x1, x2, verts_t, face_idx, planes, fq, eps_v, eps_plane, eps_near,
                       f0, f1, row)


def tolerances(scale: float) -> tuple[float, float, float]:
    """The on-cage tolerances (vertex, plane, near) for a cage of diagonal ``scale``."""
    s = scale if scale > 0 else 1.0
    return VERTEX_EPS * s, PLANE_EPS * s, NEAR_EPS * s
