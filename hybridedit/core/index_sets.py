"""Sets of vertex indices: sorted and distinct, made by a mask where sorting would cost more.

A selection at 11M vertices holds millions of indices. Indices known to lie in ``[0, n)`` are made
distinct and sorted by one pass over an ``n``-long mask; fewer of them, or values of any range,
by one sort (:func:`unique_sorted`). All give what ``np.unique`` gives.

Not ``np.unique`` itself for a plain set of integers: from numpy 2.3 it hashes them, which is
fast for few distinct values but 15-40x slower than a sort for millions of distinct indices
(``np.union1d`` and ``np.setdiff1d`` call it too). With ``return_index``, ``return_inverse`` or
``return_counts`` it still sorts.

Examples
--------
>>> unique_sorted(np.array([5, 1, 5, 3]))
array([1, 3, 5])
>>> unique_in_range(np.array([5, 1, 5, 3]), 8)
array([1, 3, 5])
>>> union_in_range(np.array([4, 0]), np.array([2, 4]), 8)
array([0, 2, 4])
>>> difference_in_range(np.array([4, 0, 2]), np.array([2, 7]), 8)
array([0, 4])
"""

from __future__ import annotations

import numpy as np

__all__ = ["unique_sorted", "unique_in_range", "union_in_range", "difference_in_range"]

#: at least this share of ``n`` indices: a mask (one pass over n) beats a sort (k log k)
MASK_SHARE = 1 / 64


def unique_sorted(values: np.ndarray) -> np.ndarray:
    """The sorted distinct values of ``values`` (flattened), by one sort: ``np.unique(values)``.

    Parameters
    ----------
    values : array of integers (any shape, any range).

    Returns
    -------
    (m,) sorted, distinct, of the input's dtype.

    Examples
    --------
    >>> unique_sorted(np.array([[2, 0], [2, 7]]))
    array([0, 2, 7])
    """
    a = np.sort(np.asarray(values).ravel())
    if a.size < 2:
        return a
    keep = np.empty(a.size, dtype=bool)
    keep[0] = True
    np.not_equal(a[1:], a[:-1], out=keep[1:])
    return a[keep]


def unique_in_range(indices: np.ndarray, n: int) -> np.ndarray:
    """The sorted distinct values of ``indices``, all in ``[0, n)`` (not checked).

    Parameters
    ----------
    indices : (k,) int array
    n : int

    Returns
    -------
    (m,) int64, sorted, distinct: ``np.unique(indices)``.
    """
    idx = np.asarray(indices).ravel()
    if idx.size < MASK_SHARE * n:
        return unique_sorted(idx).astype(np.int64, copy=False)
    mask = np.zeros(n, dtype=bool)
    mask[idx] = True
    return np.flatnonzero(mask)


def union_in_range(a: np.ndarray, b: np.ndarray, n: int) -> np.ndarray:
    """The sorted distinct values of ``a`` and ``b``, all in ``[0, n)``: ``np.union1d(a, b)``.

    Parameters
    ----------
    a, b : (k,) and (l,) int arrays
    n : int

    Returns
    -------
    (m,) int64
    """
    return unique_in_range(np.concatenate([np.asarray(a).ravel(), np.asarray(b).ravel()]), n)


def difference_in_range(a: np.ndarray, b: np.ndarray, n: int) -> np.ndarray:
    """The sorted distinct values of ``a`` not in ``b``, all in ``[0, n)``: ``np.setdiff1d(a, b)``.

    Parameters
    ----------
    a, b : (k,) and (l,) int arrays
    n : int

    Returns
    -------
    (m,) int64
    """
    a = np.asarray(a).ravel()
    b = np.asarray(b).ravel()
    if a.size < MASK_SHARE * n:
        a = unique_sorted(a)
        return a[~np.isin(a, b)].astype(np.int64, copy=False)
    mask = np.zeros(n, dtype=bool)
    mask[a] = True
    mask[b] = False
    return np.flatnonzero(mask)
