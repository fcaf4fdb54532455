"""Rows of (n, 3) arrays copied by index (``src[rows]``, ``out[rows] = src``, ``dst[at] = src[rows]``),
compiled: numpy's fancy indexing of a few ten thousand rows of three numbers costs several times a
plain loop (the cage solve of an 11M-vertex shape gathers and writes its 44K free rows and 40K
handle rows every iteration; the window copies its moving region into the drawn parts).

Examples
--------
>>> src = np.arange(12.0).reshape(4, 3)
>>> take_rows(src, np.array([3, 1]))[:, 0].tolist()
[9.0, 3.0]
>>> out = np.zeros((4, 3)); put_rows(np.ones((2, 3)), np.array([0, 2]), out); out[:, 0].tolist()
[1.0, 0.0, 1.0, 0.0]
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["take_rows", "put_rows", "copy_rows"]


@njit(cache=True)
def _take(src, rows, out):  # pragma: no cover - compiled
    for t in range(rows.shape[0]):
        r = rows[t]
        out[t, 0] = src[r, 0]
        out[t, 1] = src[r, 1]
        out[t, 2] = src[r, 2]


@njit(cache=True)
def _put(src, rows, out):  # pragma: no cover - compiled
    for t in range(rows.shape[0]):
        r = rows[t]
        out[r, 0] = src[t, 0]
        out[r, 1] = src[t, 1]
        out[r, 2] = src[t, 2]


def take_rows(src: np.ndarray, rows: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """``src[rows]``: (k, 3) float64 rows ``rows`` ((k,) int64, in range: not checked) of the
    (n, 3) float64 ``src``, into ``out`` (k, 3) float64 when given (a buffer kept between calls),
    else a new C-ordered array; returns it."""
    if out is None:
        out = np.empty((rows.shape[0], 3))
    _take(src, rows, out)
    return out


def put_rows(src: np.ndarray, rows: np.ndarray, out: np.ndarray) -> None:
    """``out[rows] = src``: the (k, 3) float64 rows ``src`` (C or Fortran order, as a sparse
    solve gives them) into rows ``rows`` ((k,) int64, in range: not checked) of the (n, 3)
    float64 ``out``."""
    _put(src, rows, out)


@njit(cache=True)
def _copy_rows_serial(src, rows, dst, at):
    for t in range(rows.shape[0]):
        r, a = rows[t], at[t]
        dst[a, 0] = src[r, 0]
        dst[a, 1] = src[r, 1]
        dst[a, 2] = src[r, 2]


def copy_rows(src: np.ndarray, rows: np.ndarray, dst: np.ndarray, at: np.ndarray) -> None:
    """``dst[at] = src[rows]`` for (n, 3) float32 arrays and (k,) int64 indices, without temporaries.

    Examples
    --------
    >>> src = np.arange(12, dtype=np.float32).reshape(4, 3); dst = np.zeros((2, 3), np.float32)
    >>> copy_rows(src, np.array([3, 1]), dst, np.array([0, 1])); dst[:, 0].tolist()
    [9.0, 3.0]
    """
    _copy_rows_serial(src, np.asarray(rows, dtype=np.int64), dst, np.asarray(at, dtype=np.int64))
