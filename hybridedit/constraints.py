"""The seam between constrained and free shape vertices.

Constrained shape vertices are placed exactly (fixed: where they were; handle:
at their group's transform of where they were). The cage vertices their rows
lean on are not all held, so near the border of the region of interest the cage
would carry a constrained vertex slightly off its target: a small mismatch
that varies smoothly along the border. The constraint removes it, and free
vertices within a band of the border take the same correction, fading to none
across the band, so the surface stays smooth across the seam.

Roles are small integers, the same for shape and cage vertices:
``-1`` fixed, ``0`` free, ``k + 1`` handle group ``k``.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

FIXED = -1
FREE = 0

#: Width of the band, in mean cage edge lengths.
BAND = 1.5


def seam_band(points: np.ndarray, seam: np.ndarray, seam_roles: np.ndarray, free: np.ndarray, width: float):
    """Free vertices near the seam and the weight of each seam vertex's mismatch they take.

    Parameters
    ----------
    points : (n, 3) float64 shape positions (distances are measured here)
    seam : (s,) int64 constrained shape vertices whose mismatch can be nonzero
    seam_roles : (s,) int roles of the seam vertices
    free : (f,) int64 free shape vertices that may take a correction
    width : float, band width (> 0)

    Returns
    -------
    band : (b,) int64, the free vertices within ``width`` of the seam
    nearest : (b, r) int64, per role present on the seam, index into ``seam`` of
        the nearest seam vertex of that role
    weight : (b, r) float64, smoothstep(1 - distance / width): 1 at the seam,
        0 at the band's edge (0 where that role's seam is farther than ``width``)

    A band vertex's correction is ``sum_r weight[b, r] * mismatch[nearest[b, r]]``.

    Examples
    --------
    >>> p = np.array([[0.0, 0, 0], [1.0, 0, 0], [2.0, 0, 0]])
    >>> band, nearest, w = seam_band(p, np.array([0]), np.array([-1]), np.array([1, 2]), 1.5)
    >>> band.tolist(), nearest.tolist()
    ([1], [[0]])
    """
    seam = np.asarray(seam, dtype=np.int64)
    free = np.asarray(free, dtype=np.int64)
    labels = np.unique(seam_roles)
    if seam.size == 0 or free.size == 0 or not width > 0:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 1), dtype=np.int64), np.zeros((0, 1))
    dist = np.full((free.size, labels.size), np.inf)
    nearest = np.zeros((free.size, labels.size), dtype=np.int64)
    for k, lab in enumerate(labels):
        own = np.flatnonzero(seam_roles == lab)
        d, i = cKDTree(points[seam[own]]).query(points[free], distance_upper_bound=width)
        ok = np.isfinite(d)
        dist[ok, k] = d[ok]
        nearest[ok, k] = own[i[ok]]
    near = np.isfinite(dist).any(axis=1)
    t = np.clip(1.0 - dist[near] / width, 0.0, 1.0)
    return free[near], nearest[near], t * t * (3.0 - 2.0 * t)
