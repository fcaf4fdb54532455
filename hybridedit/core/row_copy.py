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
from numba import njit, prange

from .parallel import pick
from .twins import twins

__all__ = ["take_rows", "put_rows", "copy_rows", "rows_into", "copied"]


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


#: blocks of rows the parallel copy deals out (many, so that a thread held up faulting in pages
#: does not leave the other idle)
_COPY_BLOCKS = 64


@njit(cache=True, inline="always")
def _into_block(src, out, b, blocks):
    n = src.shape[0]
    for i in range(n * b // blocks, n * (b + 1) // blocks):
        out[i, 0] = src[i, 0]
        out[i, 1] = src[i, 1]
        out[i, 2] = src[i, 2]


@twins()
def _into(src, out):  # pragma: no cover - compiled
    for b in prange(_COPY_BLOCKS):
        _into_block(src, out, b, _COPY_BLOCKS)


def rows_into(src: np.ndarray, out: np.ndarray) -> None:
    """``out[...] = src`` for (n, 3) arrays, converting the values to ``out``'s type, on two threads
    from ``THRESHOLDS["copy"]`` rows: into new memory, the page faults are most of the cost, and two
    threads take them side by side. Compiled for float64 into float64 and for int32 records (any
    strides, unaligned: a binary PLY's mapped face lists) into int64; numpy does any other pair.

    Examples
    --------
    >>> out = np.empty((2, 3), dtype=np.int64); rows_into(np.arange(6, dtype=np.int32).reshape(2, 3), out)
    >>> out.tolist()
    [[0, 1, 2], [3, 4, 5]]
    """
    pair = (src.dtype, out.dtype)
    if src.ndim != 2 or src.shape[1] != 3 or out.shape != src.shape or not src.dtype.isnative \
            or pair not in ((np.dtype(np.float64), np.dtype(np.float64)), (np.dtype(np.int32), np.dtype(np.int64))):
        out[...] = src
        return
    pick("copy", *_into, src.shape[0])(src, out)


def copied(src: np.ndarray) -> np.ndarray:
    """A C-ordered copy of the (n, 3) float64 array ``src``, made by :func:`rows_into`."""
    out = np.empty(src.shape, dtype=src.dtype)
    rows_into(src, out)
    return out
