"""Sparse symmetric positive definite solves: CHOLMOD, with scipy as a fallback."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

try:  # scikit-sparse >= 0.5 has cho_factor returning a factor with .solve
    from sksparse.cholmod import cho_factor as _cho_factor  # type: ignore[attr-defined]

    _CHOLMOD = "new"
except ImportError:  # pragma: no cover - depends on the installed version
    try:
        from sksparse.cholmod import cholesky as _cholesky  # scikit-sparse 0.4.x

        _CHOLMOD = "old"
    except ImportError:
        _CHOLMOD = ""


def cholmod_available() -> bool:
    """True when scikit-sparse's CHOLMOD can be used."""
    return bool(_CHOLMOD)


def _mode_option(factor, simplicial: bool) -> dict:
    """{"mode": "simplicial"} when asked for and the factorization takes it."""
    import inspect

    if not simplicial:
        return {}
    try:
        takes = "mode" in inspect.signature(factor).parameters
    except (TypeError, ValueError):  # a compiled function without a signature: try it
        takes = True
    return {"mode": "simplicial"} if takes else {}


#: Largest system factored simplicial by default. The systems solved every frame are mesh
#: Laplacians (the cage's, the edited region's), whose simplicial solves are 2-5x faster than
#: supernodal ones at every size measured (a 2,925-unknown cage block 0.30 -> 0.07 ms with 3
#: right-hand sides, a 170K-vertex shape 50 -> 20 ms) at about the same factorization time; from
#: several hundred thousand unknowns the supernodal factorization is faster (690K: 6.3 s against
#: 7.7 s) and is kept.
SIMPLICIAL_MAX = 200_000


class SPDSolver:
    """A factored sparse SPD matrix A, reused for many right-hand sides.

    Parameters
    ----------
    A : (k, k) scipy sparse matrix, symmetric positive definite
    backend : "auto", "cholmod" or "scipy"
        "auto" uses CHOLMOD when scikit-sparse is installed, else SuperLU.
    simplicial : bool or None
        Ask CHOLMOD for a simplicial factor (True) or a supernodal one (False); None (the
        default) chooses: simplicial up to :data:`SIMPLICIAL_MAX` unknowns.
    """

    def __init__(self, A: sp.spmatrix, backend: str = "auto", *, simplicial: bool | None = None) -> None:
        A = sp.csc_matrix(A, dtype=np.float64)
        if A.shape[0] != A.shape[1]:
            raise ValueError(f"matrix must be square, got {A.shape}")
        if backend == "auto":
            backend = "cholmod" if _CHOLMOD else "scipy"
        self.backend = backend
        self.shape = A.shape
        if simplicial is None:
            simplicial = A.shape[0] <= SIMPLICIAL_MAX
        #: the factor asked of CHOLMOD is simplicial (not supernodal); unused by the scipy backend
        self.simplicial = bool(simplicial)
        if A.shape[0] == 0:
            self._solve = lambda b: np.zeros_like(b)
        elif backend == "cholmod":
            if not _CHOLMOD:
                raise RuntimeError("scikit-sparse (CHOLMOD) is not installed")
            # simplicial: a sparser factor whose solves are ~3x faster for the
            # surface-like systems solved every frame (measured at 173K vertices)
            if _CHOLMOD == "new":
                f = _cho_factor(A, **_mode_option(_cho_factor, simplicial))
                self._solve = f.solve
            else:
                f = _cholesky(A, **_mode_option(_cholesky, simplicial))
                self._solve = f.solve_A
        elif backend == "scipy":
            from scipy.sparse.linalg import splu

            lu = splu(A)
            self._solve = lu.solve
        else:
            raise ValueError(f"unknown backend {backend!r}")

    def solve(self, b: np.ndarray) -> np.ndarray:
        """Solve A x = b for b of shape (k,) or (k, r) float64."""
        b = np.asarray(b, dtype=np.float64)
        x = self._solve(np.asfortranarray(b) if b.ndim == 2 else b)
        return np.asarray(x)
