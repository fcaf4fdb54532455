"""The edges of a triangle mesh and their ARAP weights: uniform, or cotangent.

They sit in core, below the floors that use them: the rig (binding) checks a cached cage's
weights when it loads it and hands the same arrays to its editor's ARAP solver (deform).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .mesh import unique_edges
from .topology import edge_index

__all__ = ["WEIGHTS", "COT_MAX", "COT_FLOOR", "edge_weights", "corner_cotangent"]

WEIGHTS = ("uniform", "cotangent")


def edge_weights(vertices: np.ndarray, faces: np.ndarray, kind: str = "uniform") -> tuple[np.ndarray, np.ndarray]:
    """Edges of a triangle mesh and their ARAP weights.

    Parameters
    ----------
    vertices : (n, 3) float64 array
    faces : (m, 3) int64 array
    kind : "uniform" (w_ij = 1, the hybrid paper's choice) or "cotangent"
        (w_ij = (cot a + cot b) / 2, clamped below at :data:`COT_FLOOR` so the
        Laplacian stays positive definite on obtuse triangles; a corner's cotangent
        is bounded by :data:`COT_MAX`, so that a zero-area face, e.g. at a pole whose
        copies of one point a file keeps apart, gives a stiff but finite weight).

    Returns
    -------
    edges : (e, 2) int64 array, column 0 < column 1
    weights : (e,) float64 array, all positive
    """
    if kind not in WEIGHTS:
        raise ValueError(f"weights must be one of {WEIGHTS}, got {kind!r}")
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if kind == "uniform":
        edges = unique_edges(f)
        return edges, np.ones(len(edges))
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    cot = np.empty(f.size)
    _corner_cotangents(v, np.ascontiguousarray(f), cot)
    edges, inverse = edge_index(f, len(v))
    w = np.bincount(inverse, weights=cot, minlength=len(edges))
    return edges, np.maximum(w, COT_FLOOR)


#: The least cotangent weight of an edge: a thousandth of an edge's between two equilateral
#: triangles (1/sqrt(3)), so that the Laplacian stays positive definite on obtuse triangles. A
#: cotangent weight has no unit (it does not scale with the shape), so one constant serves every
#: shape, and a block of a shape's rows needs nothing from the others.
COT_FLOOR = 1e-3 / np.sqrt(3.0)


#: Largest magnitude of a corner's cotangent (an angle of about 6e-4 degrees): the cotangent of a
#: zero-area face's corners is unbounded, and a weight of 1e300 overflows the factorization.
COT_MAX = 1e5


@njit(cache=True, nogil=True)
def _corner_cotangents(v, f, out):  # pragma: no cover - compiled
    """out[3t + c] = :func:`corner_cotangent` of half-edge c of face t."""
    for t in range(f.shape[0]):
        for c in range(3):
            out[3 * t + c] = corner_cotangent(v, f, t, c)


@njit(cache=True, inline="always")
def corner_cotangent(v, f, t, c):  # pragma: no cover - compiled
    """Half the cotangent of the angle opposite half-edge c of face t (a -> b, b -> c, c -> a),
    its magnitude at most COT_MAX / 2 (a degenerate corner)."""
    a, b, o = f[t, c], f[t, (c + 1) % 3], f[t, (c + 2) % 3]
    ea0, ea1, ea2 = v[a, 0] - v[o, 0], v[a, 1] - v[o, 1], v[a, 2] - v[o, 2]
    eb0, eb1, eb2 = v[b, 0] - v[o, 0], v[b, 1] - v[o, 1], v[b, 2] - v[o, 2]
    cx = ea1 * eb2 - ea2 * eb1
    cy = ea2 * eb0 - ea0 * eb2
    cz = ea0 * eb1 - ea1 * eb0
    cross = np.sqrt(cx * cx + cy * cy + cz * cz)
    dot = ea0 * eb0 + ea1 * eb1 + ea2 * eb2
    if dot == 0.0:
        return 0.0  # (a right angle, or a side of no length: no angle to speak of)
    if abs(dot) >= COT_MAX * cross:
        return 0.5 * COT_MAX if dot > 0.0 else -0.5 * COT_MAX
    return 0.5 * dot / cross
