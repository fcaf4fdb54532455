"""Vertex normals: the one rule the window shades with and the files are saved with.

A vertex's normal is the sum, over the triangle corners at it, of the triangle's unit normal times
the corner's angle, made unit length (angle-weighted normals, Thürmer and Wüthrich 1998, as Blender
and trimesh compute them): unlike area weights they do not change when a surface is tessellated
differently, so a fan of thin triangles does not pull the normal its way. A vertex whose corners sum
to zero (on no triangle, or on degenerate ones only) has the zero normal.

The same compiled kernels serve three callers:

- :func:`grouped_normals`, the normals of groups of corners (a file's own normal indices: OBJ
  ``vn``, glTF's split vertices), and :func:`vertex_normals`, one group per vertex: what the
  writers save;
- :func:`face_terms` and :func:`write_vertex_normals`, the normals of some vertices of a large shape, in parallel from
  :data:`hybridedit.core.parallel.THRESHOLDS` ``["normals"]`` vertices: the window's whole-shape update;
- :func:`accumulate_corners` and :func:`write_unit_rows`, a region's faces added to its corners in
  one serial pass: the window's per-frame update of the region a drag moves.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .parallel import pick
from .twins import twins

__all__ = ["vertex_normals", "grouped_normals", "face_terms", "write_vertex_normals",
           "accumulate_corners", "write_unit_rows"]


# atan(t) on [0, 1] as an odd polynomial, |error| <= 2e-8 rad (Abramowitz and Stegun 4.4.49): a
# corner's angle is a weight, and libm's atan2 made the window's per-frame normals 5-8 times slower
_ATAN = (0.9999993329, -0.3332985605, 0.1994653599, -0.1390853351, 0.0964200441, -0.0559098861,
         0.0218612288, -0.0040540580)


@njit(cache=True, inline="always")
def _atan01(t):
    u = t * t
    p = _ATAN[7]
    for c in (_ATAN[6], _ATAN[5], _ATAN[4], _ATAN[3], _ATAN[2], _ATAN[1], _ATAN[0]):
        p = p * u + c
    return p * t


@njit(cache=True, inline="always")
def _angle(y, x):
    """atan2(y, x) for y >= 0, in [0, pi] (to 2e-8 rad): the angle between two vectors whose cross
    product has length ``y`` and whose dot product is ``x``."""
    ax = abs(x)
    if y == 0.0 and ax == 0.0:
        return 0.0
    a = _atan01(y / ax) if ax >= y else 0.5 * np.pi - _atan01(ax / y)
    return np.pi - a if x < 0.0 else a


@njit(cache=True, inline="always")
def _face_terms(V, F, f):
    """The unit normal of triangle ``f`` and the angles at its three corners (zeros when degenerate)."""
    i, j, k = F[f, 0], F[f, 1], F[f, 2]
    ax, ay, az = V[j, 0] - V[i, 0], V[j, 1] - V[i, 1], V[j, 2] - V[i, 2]  # i -> j
    bx, by, bz = V[k, 0] - V[i, 0], V[k, 1] - V[i, 1], V[k, 2] - V[i, 2]  # i -> k
    cx, cy, cz = V[k, 0] - V[j, 0], V[k, 1] - V[j, 1], V[k, 2] - V[j, 2]  # j -> k
    nx = ay * bz - az * by
    ny = az * bx - ax * bz
    nz = ax * by - ay * bx
    L = np.sqrt(nx * nx + ny * ny + nz * nz)  # twice the area: |cross| at every corner
    if not L > 1e-300:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    wi = _angle(L, ax * bx + ay * by + az * bz)
    wj = _angle(L, -(ax * cx + ay * cy + az * cz))
    wk = _angle(L, bx * cx + by * cy + bz * cz)
    return nx / L, ny / L, nz / L, wi, wj, wk


@njit(cache=True, inline="always")
def _store_unit(x, y, z, out, v):
    """out[v] = (x, y, z) made unit length, or 0 for a vector of no length."""
    L = np.sqrt(x * x + y * y + z * z)
    if L > 1e-300:
        out[v, 0], out[v, 1], out[v, 2] = x / L, y / L, z / L
    else:
        out[v, 0], out[v, 1], out[v, 2] = 0.0, 0.0, 0.0


@njit(cache=True, inline="always")
def _write_unit(acc, a, out, v):
    _store_unit(acc[a, 0], acc[a, 1], acc[a, 2], out, v)


@njit(cache=True)
def accumulate_corners(V, F, groups, acc):
    """Add each triangle's unit normal times each corner's angle to the corner's group (serial).

    Parameters
    ----------
    V : (n, 3) float array
    F : (m, 3) int array
    groups : (m, 3) int array
        The row of ``acc`` each corner adds to (``F`` itself for vertex normals); -1 adds nowhere.
    acc : (g, 3) float64 array
        Zeroed by the caller; the sums are added in place.
    """
    for f in range(F.shape[0]):
        nx, ny, nz, wi, wj, wk = _face_terms(V, F, f)
        for c, w in ((0, wi), (1, wj), (2, wk)):
            g = groups[f, c]
            if g >= 0 and w != 0.0:
                acc[g, 0] += nx * w
                acc[g, 1] += ny * w
                acc[g, 2] += nz * w


@njit(cache=True)
def write_unit_rows(acc, at, rows, out):
    """``out[rows[t]]`` = ``acc[at[t]]`` made unit length (zero where it sums to zero).

    Parameters
    ----------
    acc : (g, 3) float64 array, sums from :func:`accumulate_corners`
    at, rows : (k,) int arrays
    out : (n, 3) float array (float32 for a VTK buffer)
    """
    for t in range(rows.shape[0]):
        _write_unit(acc, at[t], out, rows[t])


@twins()
def _face_terms_twins(V, F, faces, ft):
    for t in prange(faces.shape[0]):
        f = faces[t]
        ft[f, 0], ft[f, 1], ft[f, 2], ft[f, 3], ft[f, 4], ft[f, 5] = _face_terms(V, F, f)


@njit(cache=True, inline="always")
def _gather_vertex(F, ft, vf_ptr, vf_idx, v, out):
    x = 0.0
    y = 0.0
    z = 0.0
    for p in range(vf_ptr[v], vf_ptr[v + 1]):
        f = vf_idx[p]
        w = ft[f, 3] if F[f, 0] == v else (ft[f, 4] if F[f, 1] == v else ft[f, 5])
        x += ft[f, 0] * w
        y += ft[f, 1] * w
        z += ft[f, 2] * w
    _store_unit(x, y, z, out, v)


@twins()
def _gather(F, ft, vf_ptr, vf_idx, verts, out):
    for t in prange(verts.shape[0]):
        _gather_vertex(F, ft, vf_ptr, vf_idx, verts[t], out)


def face_terms(V: np.ndarray, F: np.ndarray, faces: np.ndarray, ft: np.ndarray) -> None:
    """Each triangle's share of its corners' normals, for :func:`write_vertex_normals`.

    Parameters
    ----------
    V : (n, 3) float array; F : (m, 3) int64 triangles
    faces : (k,) int64, the rows of F to compute
    ft : (m, 6) float64; rows ``faces`` get the unit normal (3) and the angles at the three corners (3)
    """
    pick("normals", *_face_terms_twins, faces.shape[0])(V, F, faces, ft)


def write_vertex_normals(F: np.ndarray, ft: np.ndarray, vf_ptr: np.ndarray, vf_idx: np.ndarray,
                         verts: np.ndarray, out: np.ndarray) -> None:
    """Angle-weighted unit normals of the vertices ``verts`` into ``out``, each from its own triangles.

    Parameters
    ----------
    F : (m, 3) int64 triangles
    ft : (m, 6) float64, :func:`face_terms` of (at least) the triangles at ``verts``
    vf_ptr, vf_idx : (n + 1,) int64, (3 m,) int32 or int64, the triangles at each vertex (CSR)
    verts : (k,) int64; out : (n, 3) float array, rows ``verts`` written
    """
    pick("normals", *_gather, verts.shape[0])(F, ft, vf_ptr, vf_idx, verts, out)


def grouped_normals(vertices: np.ndarray, triangles: np.ndarray, groups: np.ndarray,
                    n_groups: int) -> tuple[np.ndarray, np.ndarray]:
    """Angle-weighted normals of groups of triangle corners.

    Parameters
    ----------
    vertices : (n, 3) float64 array
    triangles : (m, 3) int64 array
    groups : (m, 3) int64 array
        The group (e.g. the OBJ ``vn`` index) of each corner; -1 for none.
    n_groups : int

    Returns
    -------
    normals : (n_groups, 3) float64 array
        Unit normals; zero rows where ``valid`` is False.
    valid : (n_groups,) bool array
        The group has corners with a nonzero summed normal.

    Examples
    --------
    >>> V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]); F = np.array([[0, 1, 2]])
    >>> n, ok = grouped_normals(V, F, np.array([[0, 0, -1]]), 2); n.tolist(), ok.tolist()
    ([[0.0, 0.0, 1.0], [0.0, 0.0, 0.0]], [True, False])
    """
    V = np.ascontiguousarray(vertices, dtype=np.float64)
    F = np.ascontiguousarray(triangles, dtype=np.int64)
    acc = np.zeros((int(n_groups), 3))
    accumulate_corners(V, F, np.ascontiguousarray(groups, dtype=np.int64), acc)
    normals = np.zeros_like(acc)
    rows = np.arange(len(acc), dtype=np.int64)
    write_unit_rows(acc, rows, rows, normals)
    return normals, np.any(normals != 0.0, axis=1)


def vertex_normals(vertices: np.ndarray, triangles: np.ndarray, *, out: np.ndarray | None = None) -> np.ndarray:
    """Angle-weighted unit vertex normals, (n, 3) (zero for a vertex on no triangle), into ``out`` when given.

    Examples
    --------
    >>> V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [5, 5, 5]]); F = np.array([[0, 1, 2]])
    >>> vertex_normals(V, F).tolist()
    [[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]]
    """
    normals, _ = grouped_normals(vertices, triangles, triangles, len(vertices))
    if out is None:
        return normals
    out[:] = normals
    return out
