"""The per-face pieces of mean value coordinates that the three kernels share.

:mod:`hybridedit.binding.mvc_exact` sums every face per point, :mod:`hybridedit.binding.mvc_flat`
and :mod:`hybridedit.binding.mvc_tree` evaluate only the faces near a batch of points exactly;
all of them take from here:

* the branch-free arctangent of the edge angles (``_atan2_pos``: ``math.atan2`` is a libm
  call that blocks vectorization);
* the plane pass (``1 / (2 Delta_f)`` per face, ``_plane_pass``) and the on-cage cases
  (``_near_faces``): a point within ``1e-12`` of the cage's diagonal from a cage vertex gets
  that vertex's unit row, within ``1e-12`` of a face (plane and closed triangle) its
  barycentric coordinates in that face (which covers edges); a face whose plane holds the
  point outside the triangle contributes nothing (its contribution vanishes in the limit),
  and a face seen at a grazing angle from outside its triangle is dropped as well;
* the exact weights one face gives its three vertices, for one point (:func:`exact_face`)
  or across the lanes of a batch (:func:`compile_exact_face_lanes`);
* the tolerances of the on-cage cases (:func:`tolerances`).

The formulas are those of the module docstring of :mod:`hybridedit.binding.mvc_exact`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["VERTEX_EPS", "PLANE_EPS", "NEAR_EPS", "RHO_RATIO", "atan2_pos_array", "exact_face",
           "exact_face_lanes_py", "compile_exact_face_lanes", "near_block", "tolerances"]

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
        b0, b1, b2, h0, h1, h2 = _projection(x0, x1, x2, vx, vy, vz, i0, i1, i2, nx, ny, nz, area2)
        rho = max(-h0, max(-h1, -h2))  # > 0 iff outside
        if adist <= eps_plane:
            if rho <= eps_plane:
                _on_cage_row(x0, x1, x2, vx, vy, vz, i0, i1, i2, b0, b1, b2, h0, h1, h2, eps_v,
                             eps_plane, row)
                return True
            fq[f] = 0.0
        elif adist <= RHO_RATIO * rho:
            fq[f] = 0.0
    return False


#: :func:`near_face_case`: the face is evaluated (its exact weights, as for any near face)
NEAR_EVALUATED = 0
#: the face's contribution vanishes for this point (the flat kernel zeroes its ``fq``)
NEAR_DROPPED = 1
#: the point is on the cage (on this face's closed triangle)
NEAR_ON_CAGE = 2


@njit(cache=True, fastmath=False, error_model="numpy", inline="always")
def near_face_case(x0, x1, x2, verts_t, i0, i1, i2, nx, ny, nz, area2, dist, eps_plane):
    """What the rules of :func:`_near_faces` make of face (i0, i1, i2) for a point at signed
    distance ``dist`` (within ``eps_near``) of its plane: :data:`NEAR_ON_CAGE`,
    :data:`NEAR_DROPPED` or :data:`NEAR_EVALUATED`, one face and one point at a time (the
    hierarchical kernel's lanes)."""
    adist = abs(dist)
    _, _, _, h0, h1, h2 = _projection(x0, x1, x2, verts_t[0], verts_t[1], verts_t[2], i0, i1, i2, nx, ny, nz,
                                      area2)
    rho = max(-h0, max(-h1, -h2))  # > 0 iff outside
    if adist <= eps_plane:
        return NEAR_ON_CAGE if rho <= eps_plane else NEAR_DROPPED
    return NEAR_DROPPED if adist <= RHO_RATIO * rho else NEAR_EVALUATED


@njit(cache=True, fastmath=False, error_model="numpy", inline="always")
def _projection(x0, x1, x2, vx, vy, vz, i0, i1, i2, nx, ny, nz, area2):
    """Where x projects onto the plane of face (i0, i1, i2) (unit normal n, twice the area ``area2``).

    Returns ``(b0, b1, b2, h0, h1, h2)``: the barycentric coordinates of the projection and
    its signed distances to the lines of the edges opposite each vertex (positive inside).
    """
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
    return b0, b1, b2, b0 * area2 / l0, b1 * area2 / l1, b2 * area2 / l2


@njit(cache=True, fastmath=False, error_model="numpy", inline="always")
def _on_cage_row(x0, x1, x2, vx, vy, vz, i0, i1, i2, b0, b1, b2, h0, h1, h2, eps_v, eps_plane, row):
    """The row of a point on face (i0, i1, i2) (see :func:`_projection` for b and h): the unit
    row of the nearest of its vertices within ``eps_v``, else its barycentric coordinates, an
    edge line within ``eps_plane`` counting as that edge."""
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
    for j in range(vx.shape[0]):
        row[j] = 0.0
    if best >= 0:
        row[best] = 1.0
        return
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
