"""Bounding boxes of point sets in one compiled pass.

numpy's ``P.min(axis=0)`` and ``P.max(axis=0)`` on an (n, 3) array walk it
column by column, strided, twice: 0.45 s for the 11M-vertex armadillo here,
against ~0.03 s for one pass over the rows. Every box of a shape-sized array
(the mesh's, the cage build's, the binding layout's, the window's) is made here.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def grow_box(P, r, box):
    """Grow ``box`` ((2, 3): lo, hi) by row ``r`` of ``P``; a NaN coordinate makes that axis NaN
    (numpy's rule for min and max)."""
    for d in range(3):
        x = P[r, d]
        if x < box[0, d]:
            box[0, d] = x
        if x > box[1, d]:
            box[1, d] = x
        if x != x:
            box[0, d] = x
            box[1, d] = x


@njit(cache=True)
def _box(P, skip, box):
    masked = skip.shape[0] > 0
    for r in range(P.shape[0]):
        if not (masked and skip[r]):
            grow_box(P, r, box)


def points_box(P: np.ndarray, *, skip: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) (3,) float64 corners of the box around the rows of P (k, 3) (any float type).

    Parameters
    ----------
    P : (k, 3) float array.
    skip : optional (k,) bool array, True for rows to leave out.

    Returns
    -------
    lo, hi : (3,) float64 arrays; an empty box (lo = inf, hi = -inf) when no row is left; NaN on
        an axis where a row left in has a NaN coordinate (as numpy's min and max).

    Examples
    --------
    >>> points_box(np.array([[0.0, 1, 2], [3, -1, 5]]))
    (array([ 0., -1.,  2.]), array([3., 1., 5.]))
    """
    box = np.empty((2, 3))
    box[0], box[1] = np.inf, -np.inf
    P = np.ascontiguousarray(P)
    if P.dtype.kind != "f":
        P = P.astype(np.float64)
    _box(P, np.zeros(0, dtype=np.bool_) if skip is None else skip, box)
    return box[0], box[1]
