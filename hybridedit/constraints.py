"""The seam between constrained and free shape vertices.

Constrained shape vertices are placed exactly (fixed: where they were; handle:
at their group's transform of where they were). The cage vertices their rows
lean on are not all held, so near the border of the region of interest the cage
would carry a constrained vertex slightly off its target: a small mismatch that
varies smoothly along the border (the drift and handle error of a plain
x' = M y'). The constraint removes it, and the free vertices take the harmonic
extension of that correction (the smoothest field that equals the correction on
the seam and vanishes on the vertices that do not move), so the surface stays
smooth across the seam.

Roles are small integers, the same for shape and cage vertices:
``-1`` fixed, ``0`` free, ``k + 1`` handle group ``k``.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .linsolve import SPDSolver

FIXED = -1
FREE = 0


class SeamSpread:
    """Harmonic extension of the seam's correction over the free moving vertices.

    Parameters
    ----------
    laplacian : (n, n) sparse shape Laplacian (positive weights).
    free : (f,) int64 free shape vertices that move (the unknowns).
    seam : (s,) int64 constrained shape vertices whose correction can be nonzero.

    Every other vertex counts as a boundary with no correction. Factored once
    (per selection); :meth:`correction` is two triangular solves.

    Examples
    --------
    >>> L = sp.csr_matrix(np.array([[1.0, -1, 0], [-1, 2, -1], [0, -1, 1]]))
    >>> s = SeamSpread(L, np.array([1]), np.array([0]))
    >>> s.correction(np.array([[2.0, 0, 0]])).round(6).tolist()  # halfway to the far end
    [[1.0, 0.0, 0.0]]
    """

    def __init__(self, laplacian: sp.spmatrix, free: np.ndarray, seam: np.ndarray) -> None:
        self.free = np.asarray(free, dtype=np.int64)
        self.seam = np.asarray(seam, dtype=np.int64)
        self._solver = None
        if self.free.size and self.seam.size:
            L = sp.csr_matrix(laplacian)
            rows = L[self.free]
            K = rows[:, self.free].tocsc()
            # a free part with no boundary at all (a loose part carried by its host)
            # gets no correction rather than a singular system
            K = K + sp.eye(K.shape[0], format="csc") * (1e-9 * max(float(K.diagonal().mean()), 1e-300))
            self._solver = SPDSolver(K)
            self._coupling = rows[:, self.seam].tocsr()

    def correction(self, mismatch: np.ndarray) -> np.ndarray:
        """(f, 3) correction of the free vertices for the seam's (s, 3) ``mismatch``."""
        if self._solver is None:
            return np.zeros((self.free.size, 3))
        return self._solver.solve(-(self._coupling @ mismatch))
