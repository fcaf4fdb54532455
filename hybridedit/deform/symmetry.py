"""Mirror symmetry: the plane, the vertex map across it, mirrored transforms.

A :class:`Mirror` of a shape reflects across a plane (through the centre of the
shape's bounding box, normal to an axis, or any point and normal), maps every
vertex to the vertex nearest its reflection, and measures how far the shape is
from being symmetric (the largest distance between a reflected vertex and its
match, as a fraction of the bounding-box diagonal).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from .selection import SelectionError
from ..core.bounds import points_box

AXES = {"x": 0, "y": 1, "z": 2}

#: A shape whose reflected vertices are farther than this (fraction of the
#: bounding-box diagonal) from a vertex of the shape is not symmetric enough.
TOLERANCE = 0.01


def reflection(point: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """The (4, 4) reflection across the plane through ``point`` with ``normal``."""
    n = np.asarray(normal, dtype=np.float64).reshape(3)
    n = n / np.linalg.norm(n)
    p = np.asarray(point, dtype=np.float64).reshape(3)
    S = np.eye(4)
    S[:3, :3] -= 2.0 * np.outer(n, n)
    S[:3, 3] = 2.0 * float(p @ n) * n
    return S


class Mirror:
    """Reflection of a shape onto itself.

    Parameters
    ----------
    vertices : (n, 3) float64 array
    plane : "x", "y", "z" (through the bounding-box centre, normal to that axis)
        or (point (3,), normal (3,)).
    tolerance : float
        Largest asymmetry accepted, as a fraction of the bounding-box diagonal.

    Attributes
    ----------
    point, normal : (3,) float64, the plane (normal of unit length)
    S : (4, 4) float64, the reflection
    map : (n,) int64, the vertex nearest each vertex's reflection
    asymmetry : float, max |S x_i - x_map(i)| / diagonal

    Raises
    ------
    SelectionError
        A malformed plane, or a shape farther from symmetric than ``tolerance``.

    Examples
    --------
    >>> v = np.array([[-1.0, 0, 0], [1.0, 0, 0], [0, 1.0, 0]])
    >>> Mirror(v, "x").map.tolist()
    [1, 0, 2]
    """

    def __init__(self, vertices: np.ndarray, plane, *, tolerance: float = TOLERANCE) -> None:
        v = np.asarray(vertices, dtype=np.float64)
        lo, hi = points_box(v)
        diag = float(np.linalg.norm(hi - lo)) or 1.0
        if isinstance(plane, str):
            if plane.lower() not in AXES:
                raise SelectionError(f"symmetry must be \"x\", \"y\", \"z\", a (point, normal) pair or None, "
                                     f"got {plane!r}")
            normal = np.zeros(3)
            normal[AXES[plane.lower()]] = 1.0
            point = 0.5 * (lo + hi)
            self.spec: object = plane.lower()
        else:
            try:
                point, normal = (np.asarray(a, dtype=np.float64).reshape(3) for a in plane)
            except (TypeError, ValueError):
                raise SelectionError("symmetry must be \"x\", \"y\", \"z\", a (point, normal) pair or None") from None
            if not (np.all(np.isfinite(point)) and np.all(np.isfinite(normal)) and np.linalg.norm(normal) > 0):
                raise SelectionError("the symmetry plane needs a finite point and a nonzero finite normal")
            self.spec = {"point": point.tolist(), "normal": normal.tolist()}
        self.normal = normal / np.linalg.norm(normal)
        self.point = point
        self.S = reflection(point, self.normal)
        reflected = v @ self.S[:3, :3].T + self.S[:3, 3]
        dist, idx = cKDTree(v).query(reflected)
        self.map = idx.astype(np.int64)
        self.asymmetry = float(dist.max(initial=0.0)) / diag
        if self.asymmetry > tolerance:
            raise SelectionError(
                f"the shape is not symmetric across this plane: a mirrored vertex is {self.asymmetry:.2%} "
                f"of the diagonal from the nearest vertex (at most {tolerance:.2%} is accepted)"
            )

    def mirrored(self, T: np.ndarray) -> np.ndarray:
        """The transform S T S that the mirror image of a handle moved by ``T`` follows."""
        return self.S @ np.asarray(T, dtype=np.float64) @ self.S

    def symmetric_part(self, T: np.ndarray) -> np.ndarray:
        """The nearest rigid transform that commutes with the reflection.

        For a handle that straddles the plane: its rotation keeps only the part
        about the plane's normal and its translation only the part in the plane
        (measured at the plane's point), so the handle stays symmetric.
        """
        T = np.asarray(T, dtype=np.float64)
        n, p = self.normal, self.point
        rv = Rotation.from_matrix(T[:3, :3]).as_rotvec()
        R = Rotation.from_rotvec(float(rv @ n) * n).as_matrix()
        moved = T[:3, :3] @ p + T[:3, 3] - p
        t = moved - float(moved @ n) * n
        out = np.eye(4)
        out[:3, :3] = R
        out[:3, 3] = p - R @ p + t
        return out
