"""Products of a few long rows, in one pass and one order, on the calling thread.

What a quasi-Newton history needs every iteration: the inner products of its ~20 stored rows
with a few new ones (:func:`gram`) and a combination of its rows (:func:`combine`). BLAS does
the first as a (20, N) x (N, 3) product whose packing costs 3x one pass over the rows (2.6 ms
against 0.8 ms at N = 90K), and either call may spread over threads, which beside a busy core
waits for a time slice. These kernels read each row once in column blocks and run serially, so
the same rows give the same sums bit for bit.

Examples
--------
>>> A = np.arange(6.0).reshape(2, 3); V = np.ones((1, 3))
>>> gram(A, V, np.zeros((2, 1))).ravel().tolist()
[3.0, 12.0]
>>> combine(np.array([1.0, -1.0]), A, np.zeros(3)).tolist()
[-3.0, -3.0, -3.0]
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["gram", "combine"]

#: columns a block spans: a block of every row (20 x 8 KB) stays in a core's L2 while it is used
_BLOCK = 1024


@njit(cache=True, fastmath={"reassoc", "contract"}, boundscheck=False)
def _gram(A, V, out):  # pragma: no cover - compiled
    R, N = A.shape
    C = V.shape[0]
    acc = np.zeros((R, C))
    for j0 in range(0, N, _BLOCK):
        j1 = min(j0 + _BLOCK, N)
        for r in range(R):
            x = A[r, j0:j1]
            for c in range(C):
                y = V[c, j0:j1]
                s = 0.0
                for j in range(j1 - j0):  # (reassociated into vector lanes: one fixed order)
                    s += x[j] * y[j]
                acc[r, c] += s
    out[:, :] = acc


@njit(cache=True, boundscheck=False)
def _combine(g, A, out):  # pragma: no cover - compiled
    R, N = A.shape
    for j0 in range(0, N, _BLOCK):
        j1 = min(j0 + _BLOCK, N)
        o = out[j0:j1]
        o[:] = 0.0
        r = 0
        while r + 4 <= R:  # four rows a sweep of the block
            x0, x1, x2, x3 = A[r, j0:j1], A[r + 1, j0:j1], A[r + 2, j0:j1], A[r + 3, j0:j1]
            g0, g1, g2, g3 = g[r], g[r + 1], g[r + 2], g[r + 3]
            for j in range(j1 - j0):
                o[j] += (g0 * x0[j] + g1 * x1[j]) + (g2 * x2[j] + g3 * x3[j])
            r += 4
        while r < R:
            x0, g0 = A[r, j0:j1], g[r]
            for j in range(j1 - j0):
                o[j] += g0 * x0[j]
            r += 1


def gram(A: np.ndarray, V: np.ndarray, out: np.ndarray) -> np.ndarray:
    """``A @ V.T`` into ``out``: (r, c) float64 inner products of the rows of (r, N) ``A`` with
    those of (c, N) ``V`` (both float64, rows contiguous); returns ``out``.

    Examples
    --------
    >>> gram(np.eye(2), np.array([[2.0, 3.0]]), np.zeros((2, 1))).ravel().tolist()
    [2.0, 3.0]
    """
    _gram(A, V, out)
    return out


def combine(g: np.ndarray, A: np.ndarray, out: np.ndarray) -> np.ndarray:
    """``g @ A`` into ``out``: the (N,) float64 combination of the rows of (r, N) ``A`` (rows
    contiguous) with the (r,) weights ``g``; returns ``out``.

    Examples
    --------
    >>> combine(np.array([2.0]), np.array([[1.0, 2.0]]), np.zeros(2)).tolist()
    [2.0, 4.0]
    """
    _combine(g, A, out)
    return out
