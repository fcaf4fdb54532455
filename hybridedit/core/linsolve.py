"""Sparse symmetric positive definite solves: CHOLMOD (scikit-sparse or cholespy), SuperLU last.

Three backends factor the systems the engine solves (the cage's Laplacian block, the edited
region's Laplacian), best first:

``cholmod``
    CHOLMOD through scikit-sparse, where it is installed (``scripts/setup.sh`` builds it on
    Debian and Ubuntu): simplicial or supernodal as asked, the fastest factorization.
``cholespy``
    CHOLMOD through cholespy, a required dependency with wheels for Linux, macOS and Windows
    (CHOLMOD and its libraries inside the wheel): always simplicial with nested dissection,
    factoring about 3x slower than scikit-sparse, solving as fast.
``superlu``
    scipy's SuperLU, the last resort (an LU factorization: slower solves); used only when
    neither CHOLMOD is importable, with a one-time note.

``HYBRIDEDIT_SOLVER=cholmod|cholespy|superlu`` forces one (for tests and benchmarks); a forced
backend that is not installed is an error, never a silent substitution. :func:`backend_name`
says which one runs, :func:`backend_description` says it with the providing package's version.
"""

from __future__ import annotations

import os
import warnings

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

try:
    import cholespy as _cholespy
except ImportError:  # pragma: no cover - a required dependency; absent only in a broken install
    _cholespy = None

#: the backends, best first; HYBRIDEDIT_SOLVER takes one of these names
BACKENDS = ("cholmod", "cholespy", "superlu")
#: the package each backend comes from
PACKAGES = {"cholmod": "scikit-sparse", "cholespy": "cholespy", "superlu": "scipy"}
ENV = "HYBRIDEDIT_SOLVER"

_noted_superlu = False


class SuperLUFallbackWarning(UserWarning):
    """SuperLU is used because no CHOLMOD (scikit-sparse or cholespy) can be imported."""


def cholmod_available() -> bool:
    """True when a CHOLMOD factorization can be used (scikit-sparse's or cholespy's)."""
    return bool(_CHOLMOD) or _cholespy is not None


def available_backends() -> tuple[str, ...]:
    """The backends that can run in this process, best first."""
    have = {"cholmod": bool(_CHOLMOD), "cholespy": _cholespy is not None, "superlu": True}
    return tuple(b for b in BACKENDS if have[b])


def _canonical(name: str) -> str:
    name = name.strip().lower()
    return {"scipy": "superlu", "scikit-sparse": "cholmod", "sksparse": "cholmod"}.get(name, name)


def forced_backend() -> str | None:
    """The backend named by ``HYBRIDEDIT_SOLVER`` (None when unset or empty)."""
    value = os.environ.get(ENV, "").strip()
    if not value:
        return None
    name = _canonical(value)
    if name not in BACKENDS:
        raise ValueError(f"{ENV}={value!r}: expected one of {', '.join(BACKENDS)}")
    return name


def backend_name() -> str:
    """The backend that ``SPDSolver(A)`` uses here: the forced one, else the best installed."""
    forced = forced_backend()
    return forced if forced is not None else available_backends()[0]


def _version(package: str) -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(package)
    except PackageNotFoundError:
        return "?"


def backend_description(name: str | None = None) -> str:
    """One line naming the backend and its package, e.g. ``cholespy 2.2.0 (CHOLMOD, simplicial)``."""
    name = backend_name() if name is None else _canonical(name)
    what = {"cholmod": "CHOLMOD via scikit-sparse {v}", "cholespy": "CHOLMOD via cholespy {v}",
            "superlu": "SuperLU via scipy {v}"}[name]
    text = f"{name} ({what.format(v=_version(PACKAGES[name]))})"
    if forced_backend() is not None:
        text += f", forced by {ENV}"
    elif name == "superlu":
        text += ", no CHOLMOD installed"
    return text


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
#: supernodal ones at about the same factorization time; from several hundred thousand unknowns
#: the supernodal factorization is faster and is kept. (scikit-sparse only: cholespy is always
#: simplicial.)
SIMPLICIAL_MAX = 200_000


def _resolve(backend: str) -> str:
    """The backend to run for the constructor's ``backend`` argument."""
    if backend == "auto":
        return backend_name()
    name = _canonical(backend)
    if name not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r} (expected auto, {', '.join(BACKENDS)})")
    if name == "cholmod" and not _CHOLMOD and _cholespy is not None and forced_backend() != "cholmod":
        # asked for CHOLMOD by name without scikit-sparse: cholespy's CHOLMOD is the same
        # factorization (unless HYBRIDEDIT_SOLVER insists on scikit-sparse's: then the error below)
        return "cholespy"
    return name


def _superlu_note() -> None:
    global _noted_superlu
    if not _noted_superlu:
        _noted_superlu = True
        warnings.warn("hybridedit: no CHOLMOD (install cholespy, or scikit-sparse) - sparse systems are "
                      "factored with scipy's SuperLU, which is slower", SuperLUFallbackWarning, stacklevel=3)


class SPDSolver:
    """A factored sparse SPD matrix A, reused for many right-hand sides.

    Parameters
    ----------
    A : (k, k) scipy sparse matrix, symmetric positive definite
    backend : "auto", "cholmod", "cholespy" or "superlu" ("scipy" is "superlu")
        "auto": ``HYBRIDEDIT_SOLVER`` when set, else the best installed (see the module's
        docstring). "cholmod" asks for a CHOLMOD factorization: scikit-sparse's, or cholespy's
        when scikit-sparse is not installed (unless ``HYBRIDEDIT_SOLVER=cholmod`` insists).
        A backend that is not installed raises RuntimeError. :attr:`backend` is the one used.
    simplicial : bool or None
        Ask scikit-sparse's CHOLMOD for a simplicial factor (True) or a supernodal one (False);
        None (the default) chooses: simplicial up to :data:`SIMPLICIAL_MAX` unknowns. cholespy
        is always simplicial; SuperLU ignores it.
    """

    def __init__(self, A: sp.spmatrix, backend: str = "auto", *, simplicial: bool | None = None) -> None:
        A = sp.csc_matrix(A, dtype=np.float64)
        if A.shape[0] != A.shape[1]:
            raise ValueError(f"matrix must be square, got {A.shape}")
        backend = _resolve(backend)
        self.backend = backend
        self.shape = A.shape
        if simplicial is None:
            simplicial = A.shape[0] <= SIMPLICIAL_MAX
        if backend == "cholespy":
            simplicial = True
        #: the factor is simplicial (not supernodal); unused by SuperLU
        self.simplicial = bool(simplicial)
        #: an estimate of the factor's memory, bytes (its backend does not say): 4 nonzeros for each of A's
        #: (3.9 measured for a 50K-vertex region of the creature's Laplacian), a float64 and an int32 each;
        #: SuperLU's L and U, twice that
        self.nbytes = int(4 * A.nnz * 12 * (2 if backend == "superlu" else 1))
        if backend == "cholmod" and not _CHOLMOD:
            raise RuntimeError("the cholmod backend needs scikit-sparse, which is not installed "
                               f"(installed: {', '.join(available_backends())})")
        if backend == "cholespy" and _cholespy is None:
            raise RuntimeError("the cholespy backend needs cholespy, which is not installed "
                               f"(installed: {', '.join(available_backends())})")
        if A.shape[0] == 0:
            self._solve = lambda b: np.zeros_like(b)
        elif backend == "cholmod":
            # simplicial: a sparser factor whose solves are ~3x faster for the
            # surface-like systems solved every frame (measured at 173K vertices)
            if _CHOLMOD == "new":
                f = _cho_factor(A, **_mode_option(_cho_factor, simplicial))
                self._solve = f.solve
            else:
                f = _cholesky(A, **_mode_option(_cholesky, simplicial))
                self._solve = f.solve_A
        elif backend == "cholespy":
            self._solve = _cholespy_factor(A)
        else:
            if not cholmod_available():
                _superlu_note()
            from scipy.sparse.linalg import splu

            lu = splu(A)
            self._solve = lu.solve

    def solve(self, b: np.ndarray) -> np.ndarray:
        """Solve A x = b for b of shape (k,) or (k, r) float64."""
        b = np.asarray(b, dtype=np.float64)
        x = self._solve(np.asfortranarray(b) if b.ndim == 2 and self.backend != "cholespy" else b)
        return np.asarray(x)


def _cholespy_factor(A: sp.csc_matrix):
    """cholespy's factor of A (its lower triangle is what CHOLMOD reads) and a solve function."""
    lower = sp.tril(A, format="csc")
    lower.sort_indices()
    n = A.shape[0]
    f = _cholespy.CholeskySolverD(n, np.ascontiguousarray(lower.indptr, dtype=np.int32),
                                  np.ascontiguousarray(lower.indices, dtype=np.int32),
                                  np.ascontiguousarray(lower.data, dtype=np.float64), _cholespy.MatrixType.CSC)

    def solve(b: np.ndarray) -> np.ndarray:
        b = np.ascontiguousarray(b, dtype=np.float64)  # cholespy takes C-ordered (k,) or (k, r)
        x = np.empty_like(b)
        f.solve(b, x)
        return x

    return solve
