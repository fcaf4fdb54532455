"""Cage points thinned out on screen: of many ROI points, at most one drawn per screen cell.

A dense ROI (thousands of cage points) drawn whole covers the surface it is on, and its silhouette
rims, where the points crowd on screen, become solid bands. Drawing at most one point per square
cell a few point widths wide keeps the ROI readable as a sprinkle over the surface; which points are
selected does not change, only which are drawn.
"""

from __future__ import annotations

import numpy as np

THIN_FROM = 300
"""ROI points drawn whole up to this many; above it they are thinned (:func:`one_per_cell`)."""
CELL_WIDTHS = 3.0
"""Side of a thinning cell, in drawn point widths: a point covers at most about 1/11 of its cell
(a disc of diameter 1 in a 3 x 3 square), so the surface stays visible between the points."""


def one_per_cell(display_xy: np.ndarray, cell: float) -> np.ndarray:
    """Which points to keep so that at most one lies in each ``cell`` x ``cell`` pixel square.

    Parameters
    ----------
    display_xy : (k, 2) float screen positions, in the order of preference (the first point of a
        cell is the one kept).
    cell : the squares' side in pixels (> 0).

    Returns
    -------
    (k,) bool: the points kept; deterministic for the same positions.

    Examples
    --------
    >>> one_per_cell(np.array([[0.5, 0.5], [1.0, 1.0], [5.0, 0.5]]), 3.0).tolist()
    [True, False, True]
    """
    xy = np.asarray(display_xy, dtype=np.float64)
    keep = np.zeros(len(xy), dtype=bool)
    if len(xy) == 0:
        return keep
    c = np.floor(xy / float(cell)).astype(np.int64)
    c -= c.min(axis=0)
    key = c[:, 0] * (int(c[:, 1].max()) + 1) + c[:, 1]
    _, first = np.unique(key, return_index=True)  # (the first occurrence: the preferred point)
    keep[first] = True
    return keep
