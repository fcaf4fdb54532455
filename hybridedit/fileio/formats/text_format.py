"""Compiled text of a plain file's rows: OBJ face lines (``f 1/2/3 ...``) written straight into a
byte buffer, the same bytes Python's %-formatting gives, many times faster.

Pure compute (numba); the format modules call it per chunk of rows and report progress between.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["face_lines"]


@njit(cache=True, inline="always")
def _int_width(x):
    """Number of decimal digits of ``x`` (int64 >= 0)."""
    n = 1
    while x >= 10:
        x //= 10
        n += 1
    return n


@njit(cache=True, inline="always")
def _put_int(out, at, x):
    """Write ``x`` (int64 >= 0) in decimal at ``out[at:]`` (uint8); returns the index after it."""
    n = _int_width(x)
    end = at + n
    for i in range(end - 1, at - 1, -1):
        out[i] = 48 + x % 10
        x //= 10
    return end


@njit(cache=True)
def _face_lines(counts, table, style):
    n_faces = counts.shape[0]
    m = table.shape[1]
    size = 0
    for c in range(table.shape[0]):  # "a", "a/b", "a//c", "a/b/c" and one space or line end
        size += _int_width(table[c, 0]) + 1
        if m >= 2:
            if style == 1:
                size += 2 + _int_width(table[c, 1])
            elif table[c, 1] != 0:
                size += 1 + _int_width(table[c, 1])
            elif m == 3:
                size += 1
            if m == 3:
                size += 1 + _int_width(table[c, 2])
    size += 2 * n_faces  # "f " of each line
    out = np.empty(size, dtype=np.uint8)
    at = 0
    c = 0
    for f in range(n_faces):
        out[at] = 102  # f
        out[at + 1] = 32
        at += 2
        for j in range(counts[f]):
            at = _put_int(out, at, table[c, 0])
            if m >= 2:
                if style == 1:  # a//n
                    out[at] = 47
                    out[at + 1] = 47
                    at = _put_int(out, at + 2, table[c, 1])
                elif table[c, 1] != 0:
                    out[at] = 47
                    at = _put_int(out, at + 1, table[c, 1])
                elif m == 3:  # a corner without texture coordinates: a//n
                    out[at] = 47
                    at += 1
                if m == 3:
                    out[at] = 47
                    at = _put_int(out, at + 1, table[c, 2])
            out[at] = 10 if j == counts[f] - 1 else 32
            at += 1
            c += 1
    return out


def face_lines(counts: np.ndarray, table: np.ndarray, normals_only: bool = False) -> np.ndarray:
    """The OBJ face lines of polygons, as ``"f " + " ".join(corners) + "\\n"`` each.

    Parameters
    ----------
    counts : (p,) int64 array
        Corners of each polygon (>= 1).
    table : (sum(counts), m) int64 array, m in 1..3, every value >= 0
        Each corner's numbers (1-based): the vertex; then either its texture coordinate (0: none)
        and, when m is 3, its normal; or, with ``normals_only`` (m is 2), its normal.
    normals_only : bool
        Corners are written ``v//n`` (no texture coordinates).

    Returns
    -------
    (bytes,) uint8 array
        The lines' text. A corner is ``v``, ``v/t``, ``v/t/n`` or ``v//n``; a texture
        coordinate of 0 is left out (``v``, ``v//n``): the text of ``"%d/%d/%d"``-formatting
        with ``/0/`` made ``//`` and a trailing ``/0`` dropped.
    """
    counts = np.ascontiguousarray(counts, dtype=np.int64)
    table = np.ascontiguousarray(table, dtype=np.int64)
    if table.ndim != 2 or not 1 <= table.shape[1] <= 3 or (normals_only and table.shape[1] != 2):
        raise ValueError("face_lines: table must be (corners, 1..3), (corners, 2) with normals_only")
    if int(counts.sum()) != len(table):
        raise ValueError("face_lines: counts do not add up to the table's rows")
    return _face_lines(counts, table, 1 if normals_only else 0)
