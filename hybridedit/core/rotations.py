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


@njit(cache=True)
def _rotation_svd(a, out):
    u, s, vt = np.linalg.svd(a)
    r = u @ vt
    if _det3(r) < 0.0:
        u[:, 2] = -u[:, 2]
        r = u @ vt
    out[:, :] = r


@njit(cache=True)
def closest_rotation(a: np.ndarray, out: np.ndarray) -> None:
    """Write to ``out`` the rotation R maximizing trace(R^T a).

    Scaled Newton iteration for the polar factor (quadratic convergence, a few
    dozen flops a step, no allocation); falls back to an SVD when ``a`` is near
    singular or a reflection (det <= 0), where the polar factor is not the
    closest rotation.

    Parameters
    ----------
    a : (3, 3) float64 array
    out : (3, 3) float64 array, written
    """
    x00, x01, x02 = a[0, 0], a[0, 1], a[0, 2]
    x10, x11, x12 = a[1, 0], a[1, 1], a[1, 2]
    x20, x21, x22 = a[2, 0], a[2, 1], a[2, 2]
    nrm = (x00 * x00 + x01 * x01 + x02 * x02 + x10 * x10 + x11 * x11 + x12 * x12
           + x20 * x20 + x21 * x21 + x22 * x22)
    if nrm == 0.0:
        for i in range(3):
            for j in range(3):
                out[i, j] = 1.0 if i == j else 0.0
        return
    if _det3(a) <= 1e-6 * nrm * np.sqrt(nrm):
        _rotation_svd(a, out)
        return
    for _ in range(40):
        # cofactor matrix c = det(x) * inverse transpose of x
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
        # Frobenius-norm scaling: g^2 = |x^-T| / |x|
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
        x00, x01, x02 = y00, y01, y02
        x10, x11, x12 = y10, y11, y12
        x20, x21, x22 = y20, y21, y22
        if change < 1e-18:  # the step just taken was ~1e-9: x is now exact to ~1e-18
            break
    out[0, 0], out[0, 1], out[0, 2] = x00, x01, x02
    out[1, 0], out[1, 1], out[1, 2] = x10, x11, x12
    out[2, 0], out[2, 1], out[2, 2] = x20, x21, x22


@njit(cache=True, parallel=True)
def closest_rotations(a: np.ndarray, out: np.ndarray) -> None:
    """Batched :func:`closest_rotation`: a and out are (k, 3, 3) float64."""
    for k in prange(a.shape[0]):
        closest_rotation(a[k], out[k])
