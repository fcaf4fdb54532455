"""The side a closed shape rests on when put on a table: its up axis, snapped to the six axes.

A shape made to stand (a statue on its base, a creature on its feet, a boat on its keel) was modelled
standing along one of its axes. For each of the six axes taken as up, the shape is put on a table with
that axis up and scored by how well it rests there: the share of its area lying on the table (a flat
base, flat soles) times how far its centre (of area) is inside its support polygon relative to its
height (the tangent of the angle it tips over at; 0 when it falls). The pose of the highest score wins
when it is clearly ahead of the next. The axis across the shape's plane of mirror symmetry is never up
(a horse or a boat is mirrored left to right: lying on its side puts that plane flat; it is the pose
physics prefers for a long shape on thin legs, not the one it was made in; Fu et al. 2008, "Upright
orientation of man-made objects", weigh symmetry and stability the same way). The points are
subsampled (:data:`SAMPLE`) for the convex hull and the symmetry: on an 11M-vertex shape the test
costs what one pass over its faces does, plus about 0.05 s.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull, QhullError, cKDTree

#: Points of the shape used for its convex hull and its symmetry (drawn from its vertices, fixed seed).
SAMPLE = 20_000
#: On the table: the area within this fraction of the shape's extent from its lowest point ...
BAND = 0.01
#: ... and the support polygon: the hull's points within this fraction (a scan's soles are uneven).
SUPPORT = 0.02
#: The points reflected to look for a mirror plane (a share of :data:`SAMPLE`, each looked up among all).
PROBES = 4_000
#: A mirror plane: the reflected points within this fraction of the extent of the shape, on average ...
MIRROR = 0.03
#: ... and at most this fraction of the next-best axis' error.
MIRROR_LEAD = 0.5
#: The best pose must score this many times the next to be chosen.
LEAD = 1.5


def resting_up(vertices: np.ndarray, contact: np.ndarray, centre: np.ndarray,
               axes: tuple[str, ...]) -> str | None:
    """The up axis the shape rests on (see the module's description), or None when no pose is clear.

    Parameters
    ----------
    vertices : (n, 3) float64 array, the shape's points.
    contact : (6,) float array, for each axis of ``axes``: the share of the shape's area within
        :data:`BAND` of its lowest point along it (on the table, that axis up).
    centre : (3,) float array, the shape's centre of area.
    axes : the six axis names ("+Y", "-X", ...), in the order of ``contact``.
    """
    v = vertices if len(vertices) <= SAMPLE else vertices[np.random.default_rng(0).integers(0, len(vertices), SAMPLE)]
    lo, hi = v.min(axis=0), v.max(axis=0)
    extent = float(np.max(hi - lo))
    if extent <= 0:
        return None
    try:
        hull = v[ConvexHull(v).vertices]
    except (QhullError, ValueError):
        return None  # flat or degenerate: no resting pose tells
    side = _mirror_axis(v, 0.5 * (lo + hi), extent)
    score = {}
    for k, axis in enumerate(axes):
        d = "XYZ".index(axis[1])
        if d == side:
            continue
        u = np.zeros(3)
        u[d] = 1.0 if axis[0] == "+" else -1.0
        score[axis] = contact[k] * max(_tipping(hull, centre, u, SUPPORT * extent), 0.0)
    ranked = sorted(score.values(), reverse=True)
    if ranked[0] <= 0 or ranked[0] < LEAD * ranked[1]:
        return None
    return max(score, key=score.get)


def _tipping(hull: np.ndarray, centre: np.ndarray, up: np.ndarray, band: float) -> float:
    """Tangent of the angle the shape tips over at, resting with ``up`` up: the distance of its centre
    inside the support polygon (the hull points within ``band`` of the table) over its height."""
    h = hull @ up
    low = float(h.min())
    d = int(np.argmax(np.abs(up)))
    flat = [i for i in range(3) if i != d]
    foot = hull[h <= low + band][:, flat]
    try:
        eq = ConvexHull(foot).equations  # (inside: n . x + c <= 0)
    except (QhullError, ValueError):
        return -1.0  # resting on a point or an edge
    inside = -float(np.max(eq[:, :2] @ centre[flat] + eq[:, 2]))
    return inside / max(float(centre @ up) - low, 1e-300)


def _mirror_axis(v: np.ndarray, middle: np.ndarray, extent: float) -> int:
    """The coordinate (0, 1, 2) across the shape's plane of mirror symmetry through its box's middle,
    or -1 when none is clear."""
    tree = cKDTree(v)
    error = np.empty(3)
    for d in range(3):
        r = v[:: max(1, len(v) // PROBES)].copy()
        r[:, d] = 2.0 * middle[d] - r[:, d]
        error[d] = tree.query(r)[0].mean() / extent
    best, second = np.sort(error)[:2]
    return int(np.argmin(error)) if best < MIRROR and best <= MIRROR_LEAD * second else -1
