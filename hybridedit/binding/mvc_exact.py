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
  arctangent (``_atan2_pos`` of :mod:`hybridedit.binding.mvc_faces`, checked
  against ``numpy.arctan2`` in the tests), so that the per-edge loop vectorizes.
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
  angle from outside its triangle is dropped as well (see ``_near_faces`` in
  :mod:`hybridedit.binding.mvc_faces`, which holds what the three kernels share;
  the cage's layout is :mod:`hybridedit.binding.mvc_layout`).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import njit, prange

from .mvc_layout import CageData
from .mvc_faces import NEAR_EPS, PLANE_EPS, VERTEX_EPS, _R_MAX, _atan2_pos, _near_faces, _plane_pass

__all__ = ["compute_into", "as_points", "n_blocks"]


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
