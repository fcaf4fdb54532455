"""SPDSolver: CHOLMOD (simplicial or supernodal, chosen by size) and scipy give the same solutions."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from hybridedit import linsolve
from hybridedit.arap import edge_weights, laplacian
from hybridedit.linsolve import SPDSolver, cholmod_available

from shapes import bumpy_blob


def _system(seed=0):
    m = bumpy_blob(3)
    e, w = edge_weights(m.vertices, m.faces, "cotangent")
    L = laplacian(m.n_vertices, e, w).tocsr()
    keep = np.flatnonzero(m.vertices[:, 0] > -1.0)  # the others held: a Dirichlet block, SPD
    A = L[keep][:, keep].tocsc()
    b = np.random.default_rng(seed).normal(size=(keep.size, 3))
    return A, b


@pytest.mark.skipif(not cholmod_available(), reason="scikit-sparse not installed")
def test_simplicial_and_supernodal_factors_solve_alike():
    A, b = _system()
    xs = SPDSolver(A, "cholmod", simplicial=True).solve(b)
    xn = SPDSolver(A, "cholmod", simplicial=False).solve(b)
    assert np.abs(A @ xs - b).max() < 1e-10 * np.abs(b).max()
    assert np.abs(xs - xn).max() < 1e-10 * np.abs(xn).max()
    assert np.abs(SPDSolver(A, "cholmod").solve(b[:, 0]) - xs[:, 0]).max() < 1e-10 * np.abs(xs).max()


@pytest.mark.skipif(not cholmod_available(), reason="scikit-sparse not installed")
def test_the_default_factor_is_simplicial_up_to_a_size(monkeypatch):
    A, b = _system(1)
    assert SPDSolver(A).simplicial
    monkeypatch.setattr(linsolve, "SIMPLICIAL_MAX", A.shape[0] - 1)
    big = SPDSolver(A)
    assert not big.simplicial
    assert SPDSolver(A, simplicial=True).simplicial  # an explicit choice is kept
    assert np.abs(big.solve(b) - SPDSolver(A, "scipy").solve(b)).max() < 1e-9


def test_an_empty_system_and_a_non_square_one():
    assert SPDSolver(sp.csc_matrix((0, 0))).solve(np.zeros((0, 3))).shape == (0, 3)
    with pytest.raises(ValueError):
        SPDSolver(sp.csc_matrix(np.ones((2, 3))))
