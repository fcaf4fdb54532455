"""Closest rotations of 3x3 matrices (the ARAP local step), compiled with numba."""

from __future__ import annotations

import numpy as np
from numba import njit, prange


@njit(cache=True, inline="always")
def _det3(a):
    return (
        a[0, 0] * (a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1])
        - a[0, 1] * (a[1, 0] * a[2, 2] - a[1, 2] * a[2, 0])
        + a[0, 2] * (a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0])
    )


@njit(cache=True, inline="always")
def _jacobi_pair(spp, sqq, spq, srp, srq, v, p, q):
    """One Jacobi rotation zeroing S[p, q] of a symmetric 3x3 S (r the third index): returns the
    new S[p, p], S[q, q], S[r, p], S[r, q]; turns columns p and q of ``v`` with it."""
    theta = (sqq - spp) / (2.0 * spq)
    t = 1.0 / (abs(theta) + np.sqrt(theta * theta + 1.0))
    if theta < 0.0:
        t = -t
    c = 1.0 / np.sqrt(t * t + 1.0)
    s = t * c
    for k in range(3):
        a = v[k, p]
        b = v[k, q]
        v[k, p] = c * a - s * b
        v[k, q] = s * a + c * b
    return spp - t * spq, sqq + t * spq, c * srp - s * srq, s * srp + c * srq


@njit(cache=True)
def _rotation_jacobi(a, out):
    """The closest rotation by a singular value decomposition a = U diag(s) V^T made from the
    eigenvectors V of a^T a (cyclic Jacobi: a few dozen flops a sweep, no allocation):
    R = u1 v1^T + u2 v2^T + (u1 x u2)(v1 x v2)^T, the two largest singular directions and their
    cross products, which is U diag(1, 1, det(U V^T)) V^T, right also for a reflection and for a
    near-planar matrix (rank 2). ``out`` (3, 3) is written; ``a`` is read first."""
    nrm = 0.0
    for i in range(3):
        for j in range(3):
            nrm += a[i, j] * a[i, j]
    f = 1.0 / np.sqrt(nrm)  # (a scaled to unit norm: no underflow in a^T a)
    b00, b01, b02 = f * a[0, 0], f * a[0, 1], f * a[0, 2]
    b10, b11, b12 = f * a[1, 0], f * a[1, 1], f * a[1, 2]
    b20, b21, b22 = f * a[2, 0], f * a[2, 1], f * a[2, 2]
    s00 = b00 * b00 + b10 * b10 + b20 * b20
    s11 = b01 * b01 + b11 * b11 + b21 * b21
    s22 = b02 * b02 + b12 * b12 + b22 * b22
    s01 = b00 * b01 + b10 * b11 + b20 * b21
    s02 = b00 * b02 + b10 * b12 + b20 * b22
    s12 = b01 * b02 + b11 * b12 + b21 * b22
    v = out  # (the eigenvectors are built in ``out``: a is in b now)
    for i in range(3):
        for j in range(3):
            v[i, j] = 1.0 if i == j else 0.0
    for _ in range(20):
        if s01 * s01 + s02 * s02 + s12 * s12 <= 1e-34 * (s00 * s00 + s11 * s11 + s22 * s22):
            break
        if s01 != 0.0:
            s00, s11, s02, s12 = _jacobi_pair(s00, s11, s01, s02, s12, v, 0, 1)
            s01 = 0.0
        if s02 != 0.0:
            s00, s22, s01, s12 = _jacobi_pair(s00, s22, s02, s01, s12, v, 0, 2)
            s02 = 0.0
        if s12 != 0.0:
            s11, s22, s01, s02 = _jacobi_pair(s11, s22, s12, s01, s02, v, 1, 2)
            s12 = 0.0
    # the two largest eigenvalues' vectors
    i1, i2 = 0, 1
    if s11 > s00:
        i1, i2 = 1, 0
    d1 = s11 if i1 == 1 else s00
    d2 = s00 if i1 == 1 else s11
    if s22 > d1:
        i2, i1 = i1, 2
    elif s22 > d2:
        i2 = 2
    x0, x1, x2 = v[0, i1], v[1, i1], v[2, i1]
    y0, y1, y2 = v[0, i2], v[1, i2], v[2, i2]
    # u1 = b v1 / |b v1|
    p0 = b00 * x0 + b01 * x1 + b02 * x2
    p1 = b10 * x0 + b11 * x1 + b12 * x2
    p2 = b20 * x0 + b21 * x1 + b22 * x2
    g = 1.0 / np.sqrt(p0 * p0 + p1 * p1 + p2 * p2)
    p0, p1, p2 = g * p0, g * p1, g * p2
    # u2 = b v2, made orthogonal to u1, unit (any unit normal to u1 when a has rank 1)
    q0 = b00 * y0 + b01 * y1 + b02 * y2
    q1 = b10 * y0 + b11 * y1 + b12 * y2
    q2 = b20 * y0 + b21 * y1 + b22 * y2
    h = p0 * q0 + p1 * q1 + p2 * q2
    q0, q1, q2 = q0 - h * p0, q1 - h * p1, q2 - h * p2
    qn = q0 * q0 + q1 * q1 + q2 * q2
    if qn <= 1e-30:
        if abs(p0) < 0.6:
            q0, q1, q2 = 0.0, -p2, p1  # u1 x e0
        else:
            q0, q1, q2 = p2, 0.0, -p0  # u1 x e1
        qn = q0 * q0 + q1 * q1 + q2 * q2
    g = 1.0 / np.sqrt(qn)
    q0, q1, q2 = g * q0, g * q1, g * q2
    # third columns: u3 = u1 x u2, v3 = v1 x v2
    r0, r1, r2 = p1 * q2 - p2 * q1, p2 * q0 - p0 * q2, p0 * q1 - p1 * q0
    z0, z1, z2 = x1 * y2 - x2 * y1, x2 * y0 - x0 * y2, x0 * y1 - x1 * y0
    out[0, 0] = p0 * x0 + q0 * y0 + r0 * z0
    out[0, 1] = p0 * x1 + q0 * y1 + r0 * z1
    out[0, 2] = p0 * x2 + q0 * y2 + r0 * z2
    out[1, 0] = p1 * x0 + q1 * y0 + r1 * z0
    out[1, 1] = p1 * x1 + q1 * y1 + r1 * z1
    out[1, 2] = p1 * x2 + q1 * y2 + r1 * z2
    out[2, 0] = p2 * x0 + q2 * y0 + r2 * z0
    out[2, 1] = p2 * x1 + q2 * y1 + r2 * z1
    out[2, 2] = p2 * x2 + q2 * y2 + r2 * z2


#: most scaled Newton steps taken towards a polar factor
NEWTON_STEPS = 40


@njit(cache=True, inline="always")
def by_svd(a) -> bool:
    """True when the closest rotation to the (3, 3) ``a`` is not the limit of the Newton
    iteration for its polar factor: ``a`` is zero (the identity is taken), near singular or a
    reflection (det <= 0). Those are solved by :func:`rotation_by_svd`."""
    nrm = (a[0, 0] * a[0, 0] + a[0, 1] * a[0, 1] + a[0, 2] * a[0, 2] + a[1, 0] * a[1, 0] + a[1, 1] * a[1, 1]
           + a[1, 2] * a[1, 2] + a[2, 0] * a[2, 0] + a[2, 1] * a[2, 1] + a[2, 2] * a[2, 2])
    return nrm == 0.0 or _det3(a) <= 1e-6 * nrm * np.sqrt(nrm)


@njit(cache=True)
def rotation_by_svd(a: np.ndarray, out: np.ndarray) -> None:
    """The closest rotation to a (3, 3) ``a`` for which :func:`by_svd` holds, into ``out`` (which
    may be ``a``): the identity for a zero matrix, else by Jacobi sweeps."""
    nrm = 0.0
    for i in range(3):
        for j in range(3):
            nrm += a[i, j] * a[i, j]
    if nrm == 0.0:
        for i in range(3):
            for j in range(3):
                out[i, j] = 1.0 if i == j else 0.0
        return
    _rotation_jacobi(a, out)


@njit(cache=True)
def closest_rotation(a: np.ndarray, out: np.ndarray) -> None:
    """Write to ``out`` the rotation R maximizing trace(R^T a).

    Scaled Newton iteration for the polar factor (quadratic convergence, a few
    dozen flops a step: :func:`polar_lanes` with one lane); when ``a`` is near singular or a
    reflection (det <= 0), where the polar factor is not the closest rotation, a
    singular value decomposition by Jacobi sweeps (:func:`_rotation_jacobi`; on a
    QEM cage's near-planar vertex rings that is a tenth of the ARAP local step's
    matrices, and LAPACK's SVD took half its time).

    Parameters
    ----------
    a : (3, 3) float64 array
    out : (3, 3) float64 array, written
    """
    if by_svd(a):
        rotation_by_svd(a, out)
        return
    x = np.empty((9, LANES))
    done = np.ones(LANES)
    done[0] = 0.0
    for i in range(3):
        for j in range(3):
            x[3 * i + j, 0] = a[i, j]
    polar_lanes(x, done, 1)  # (one lane: the same steps as 32 side by side)
    for i in range(3):
        for j in range(3):
            out[i, j] = x[3 * i + j, 0]


#: matrices whose Newton steps :func:`polar_lanes` takes side by side. The loop over them compiles
#: to vector instructions (each lane's arithmetic is the scalar one, so every result is bitwise
#: :func:`closest_rotation`'s); below about 16 lanes LLVM keeps it scalar. In lanes of 32 a matrix
#: takes a fifth of its time alone (the 690K armadillo's cage covariances, one thread); 64 gain nothing.
LANES = 32


@njit(cache=True, error_model="numpy")
def _newton_lanes_step(x, done, nl):
    """One scaled Newton step (as in :func:`closest_rotation`) of the lanes l < nl of x (9, LANES),
    the row-major entries of a matrix per column, whose ``done[l]`` is 0; a lane whose step changed
    it by less than 1e-9 gets ``done[l] = 1``. Returns True when every lane is done."""
    for l in range(nl):
        x00 = x[0, l]
        x01 = x[1, l]
        x02 = x[2, l]
        x10 = x[3, l]
        x11 = x[4, l]
        x12 = x[5, l]
        x20 = x[6, l]
        x21 = x[7, l]
        x22 = x[8, l]
        c00 = x11 * x22 - x12 * x21
        c01 = x12 * x20 - x10 * x22
        c02 = x10 * x21 - x11 * x20
        c10 = x02 * x21 - x01 * x22
        c11 = x00 * x22 - x02 * x20
        c12 = x01 * x20 - x00 * x21
        c20 = x01 * x12 - x02 * x11
        c21 = x02 * x10 - x00 * x12
        c22 = x00 * x11 - x01 * x10
        dx = x00 * c00 + x01 * c01 + x02 * c02
        inv = 1.0 / dx
        nx = (x00 * x00 + x01 * x01 + x02 * x02 + x10 * x10 + x11 * x11 + x12 * x12
              + x20 * x20 + x21 * x21 + x22 * x22)
        nc = (c00 * c00 + c01 * c01 + c02 * c02 + c10 * c10 + c11 * c11 + c12 * c12
              + c20 * c20 + c21 * c21 + c22 * c22)
        g = np.sqrt(np.sqrt(nc * inv * inv / nx))
        ga = 0.5 * g
        gb = 0.5 * inv / g
        y00 = ga * x00 + gb * c00
        y01 = ga * x01 + gb * c01
        y02 = ga * x02 + gb * c02
        y10 = ga * x10 + gb * c10
        y11 = ga * x11 + gb * c11
        y12 = ga * x12 + gb * c12
        y20 = ga * x20 + gb * c20
        y21 = ga * x21 + gb * c21
        y22 = ga * x22 + gb * c22
        change = ((y00 - x00) ** 2 + (y01 - x01) ** 2 + (y02 - x02) ** 2
                  + (y10 - x10) ** 2 + (y11 - x11) ** 2 + (y12 - x12) ** 2
                  + (y20 - x20) ** 2 + (y21 - x21) ** 2 + (y22 - x22) ** 2)
        keep = done[l] != 0.0  # (selects, not branches: the loop stays one vector loop)
        x[0, l] = x00 if keep else y00
        x[1, l] = x01 if keep else y01
        x[2, l] = x02 if keep else y02
        x[3, l] = x10 if keep else y10
        x[4, l] = x11 if keep else y11
        x[5, l] = x12 if keep else y12
        x[6, l] = x20 if keep else y20
        x[7, l] = x21 if keep else y21
        x[8, l] = x22 if keep else y22
        done[l] = 1.0 if (keep or change < 1e-18) else 0.0
    left = 0.0
    for l in range(nl):
        left += 1.0 - done[l]
    return left == 0.0


@njit(cache=True)
def polar_lanes(x: np.ndarray, done: np.ndarray, nl: int) -> None:
    """Polar factors of up to :data:`LANES` matrices at once, in place.

    Parameters
    ----------
    x : (9, LANES) float64 array
        Column l < nl holds a matrix's entries in row-major order; a column whose ``done`` is 0
        must not satisfy :func:`by_svd` (its polar factor is its closest rotation). Overwritten by
        the factors, each bitwise what :func:`closest_rotation` gives (the same steps).
    done : (LANES,) float64 array
        1.0 for a column to leave as it is (a matrix solved otherwise), 0.0 for one to solve;
        all 1.0 on return.
    nl : int
        Columns in use.

    Examples
    --------
    >>> x = np.zeros((9, LANES)); x[[0, 4, 8], 0] = 2.0
    >>> done = np.ones(LANES); done[0] = 0.0
    >>> polar_lanes(x, done, 1); x[:, 0].tolist()
    [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    """
    for _ in range(NEWTON_STEPS):
        if _newton_lanes_step(x, done, nl):
            return
    done[:nl] = 1.0


@njit(cache=True, inline="always")
def rotations_in_place(m, rows, r0, nl, x, done, elsewhere):
    """Each (3, 3) matrix ``m[rows[r0 + l]]``, l < nl <= :data:`LANES`, replaced by its closest
    rotation: bitwise :func:`closest_rotation`'s, the polar factors side by side
    (:func:`polar_lanes`), the others by SVD. ``x`` (9, LANES), ``done`` and ``elsewhere``
    (LANES,) float64 are work arrays."""
    for l in range(nl):
        r = m[rows[r0 + l]]
        if by_svd(r):
            rotation_by_svd(r, r)
            done[l] = 1.0
        else:
            for p in range(3):
                for q in range(3):
                    x[3 * p + q, l] = r[p, q]
            done[l] = 0.0
        elsewhere[l] = done[l]
    polar_lanes(x, done, nl)
    for l in range(nl):
        if elsewhere[l] == 0.0:
            r = m[rows[r0 + l]]
            for p in range(3):
                for q in range(3):
                    r[p, q] = x[3 * p + q, l]


@njit(cache=True, parallel=True)
def closest_rotations(a: np.ndarray, out: np.ndarray) -> None:
    """Batched :func:`closest_rotation` (in lanes, :func:`rotations_in_place`): a and out are
    (k, 3, 3) float64; ``out`` may be ``a``."""
    out[:] = a
    rows = np.arange(a.shape[0])
    for b in prange((a.shape[0] + LANES - 1) // LANES):
        r0 = b * LANES
        rotations_in_place(out, rows, r0, min(LANES, a.shape[0] - r0), np.empty((9, LANES)), np.empty(LANES),
                           np.empty(LANES))
