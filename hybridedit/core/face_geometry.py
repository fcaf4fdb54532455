"""The geometry of a triangle mesh's faces: their normals and areas, the area and the signed volume
it encloses, its centre of mass, each computed by one rule.

A face's vector is the cross product of its two edges from its first corner, ``(p1 - p0) x (p2 -
p0)``: the normal's direction (outward for a counter-clockwise face), twice the face's area as its
length. Every caller (the cage's shells and pieces, STL's facet normals, the batch's centre of
mass) takes it from :func:`face_vectors` in plain numpy; a compiled kernel that walks the faces
itself (:mod:`hybridedit.core.up_axis`) takes the same product, in the same order, from
:func:`face_vector`, so both give the same bits.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["face_vectors", "face_vector", "face_normals", "face_areas", "surface_area", "signed_volume",
           "centre_of_mass"]


def face_vectors(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Each triangle's ``(p1 - p0) x (p2 - p0)``: along its normal, twice its area long.

    Parameters
    ----------
    vertices : (n, 3) float64 array
    faces : (m, 3) int array

    Returns
    -------
    (m, 3) float64 array

    Examples
    --------
    >>> face_vectors(np.array([[0.0, 0, 0], [2, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]])).tolist()
    [[0.0, 0.0, 2.0]]
    """
    v, f = vertices, faces
    return np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])


@njit(cache=True, inline="always")
def face_vector(v, f, t):
    """:func:`face_vectors` of face ``t`` alone, (x, y, z), for a compiled kernel's own loop over
    the faces (the same products and differences, in the same order: the same bits)."""
    a, b, c = f[t, 0], f[t, 1], f[t, 2]
    ux, uy, uz = v[b, 0] - v[a, 0], v[b, 1] - v[a, 1], v[b, 2] - v[a, 2]
    wx, wy, wz = v[c, 0] - v[a, 0], v[c, 1] - v[a, 1], v[c, 2] - v[a, 2]
    return uy * wz - uz * wy, uz * wx - ux * wz, ux * wy - uy * wx


def face_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Each triangle's unit normal, (m, 3); zero for a face of no area.

    Examples
    --------
    >>> face_normals(np.array([[0.0, 0, 0], [2, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2], [0, 0, 1]])).tolist()
    [[0.0, 0.0, 1.0], [0.0, 0.0, 0.0]]
    """
    n = face_vectors(vertices, faces)
    length = np.linalg.norm(n, axis=1, keepdims=True)
    return np.divide(n, length, out=np.zeros_like(n), where=length > 0)


def face_areas(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Each triangle's area, (m,) float64."""
    return 0.5 * np.linalg.norm(face_vectors(vertices, faces), axis=1)


def surface_area(vertices: np.ndarray, faces: np.ndarray) -> float:
    """The total area of the triangles.

    Examples
    --------
    >>> surface_area(np.array([[0.0, 0, 0], [2, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]))
    1.0
    """
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int64).reshape(-1, 3)
    return 0.5 * float(_length_sum(v, f))


@njit(cache=True)
def _length_sum(v, f):  # pragma: no cover - compiled
    """The sum of the faces' :func:`face_vector` lengths, in blocks of 1024 (each sum a block's or
    the blocks', short enough to round little), without the (m, 3) temporaries numpy's way made:
    0.45 s of a 690K scan's cage build."""
    total = 0.0
    for t0 in range(0, f.shape[0], 1024):
        part = 0.0
        for t in range(t0, min(t0 + 1024, f.shape[0])):
            x, y, z = face_vector(v, f, t)
            part += np.sqrt(x * x + y * y + z * z)
        total += part
    return total


def signed_volume(vertices: np.ndarray, faces: np.ndarray) -> float:
    """The volume a closed, consistently oriented surface encloses: positive when its faces turn
    outward, negative when inward. Summed about the vertices' mean, not the origin, so that a shape
    far from the origin loses no precision.

    Examples
    --------
    >>> v = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> round(signed_volume(v, np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])), 12)
    0.166666666667
    """
    v, f = vertices, faces
    c = v.mean(axis=0)
    p0, p1, p2 = (v[f[:, k]] - c for k in range(3))
    return float(np.einsum("ij,ij->i", p0, np.cross(p1, p2)).sum()) / 6.0


def centre_of_mass(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """The area-weighted centroid of a surface, (3,); the vertex mean if it has no area.

    Parameters
    ----------
    vertices : (n, 3) float64
    faces : (m, 3) int64
    """
    area = face_areas(vertices, faces)
    total = float(area.sum())
    if not total > 0 or not np.isfinite(total):
        return vertices.mean(axis=0)
    return (vertices[faces].mean(axis=1) * area[:, None]).sum(axis=0) / total
