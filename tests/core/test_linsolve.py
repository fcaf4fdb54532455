"""SPDSolver: every backend (scikit-sparse's CHOLMOD, cholespy's CHOLMOD, SuperLU) gives the same
solutions; HYBRIDEDIT_SOLVER forces one; the choice is reported."""

from __future__ import annotations

import subprocess
import sys
import warnings

import numpy as np
import pytest
import scipy.sparse as sp

from hybridedit.core import linsolve
from hybridedit.deform.arap import edge_weights, laplacian
from hybridedit.core.linsolve import BACKENDS, SPDSolver, available_backends, cholmod_available

from shapes import bumpy_blob

needs_sksparse = pytest.mark.skipif("cholmod" not in available_backends(), reason="scikit-sparse not installed")


def _system(seed=0):
    m = bumpy_blob(3)
    e, w = edge_weights(m.vertices, m.faces, "cotangent")
    L = laplacian(m.n_vertices, e, w).tocsr()
    keep = np.flatnonzero(m.vertices[:, 0] > -1.0)  # the others held: a Dirichlet block, SPD
    A = L[keep][:, keep].tocsc()
    b = np.random.default_rng(seed).normal(size=(keep.size, 3))
    return A, b


def _installed(name):
    if name not in available_backends():
        pytest.skip(f"{linsolve.PACKAGES[name]} not installed")


@pytest.mark.parametrize("name", BACKENDS)
def test_each_backend_forced_gives_the_same_solution(monkeypatch, name):
    """HYBRIDEDIT_SOLVER forces each backend in turn; all agree with a dense solve to 1e-10."""
    _installed(name)
    A, b = _system()
    want = np.linalg.solve(A.toarray(), b)
    monkeypatch.setenv("HYBRIDEDIT_SOLVER", name)
    assert linsolve.backend_name() == name
    s = SPDSolver(A)
    assert s.backend == name
    scale = np.abs(want).max()
    for rhs, ref in ((b, want), (np.asfortranarray(b), want), (b[:, 1], want[:, 1]), (b[:, :1], want[:, :1])):
        x = s.solve(rhs)
        assert x.shape == rhs.shape
        assert np.abs(x - ref).max() < 1e-10 * scale
    assert np.abs(A @ s.solve(b) - b).max() < 1e-10 * np.abs(b).max()


def test_all_installed_backends_agree_with_each_other():
    A, b = _system(2)
    xs = {name: SPDSolver(A, name).solve(b) for name in available_backends()}
    ref = xs["superlu"]
    for name, x in xs.items():
        assert np.abs(x - ref).max() < 1e-10 * np.abs(ref).max(), name


@needs_sksparse
def test_simplicial_and_supernodal_factors_solve_alike():
    A, b = _system()
    xs = SPDSolver(A, "cholmod", simplicial=True).solve(b)
    xn = SPDSolver(A, "cholmod", simplicial=False).solve(b)
    assert np.abs(A @ xs - b).max() < 1e-10 * np.abs(b).max()
    assert np.abs(xs - xn).max() < 1e-10 * np.abs(xn).max()
    assert np.abs(SPDSolver(A, "cholmod").solve(b[:, 0]) - xs[:, 0]).max() < 1e-10 * np.abs(xs).max()


@needs_sksparse
def test_the_default_factor_is_simplicial_up_to_a_size(monkeypatch):
    A, b = _system(1)
    monkeypatch.delenv("HYBRIDEDIT_SOLVER", raising=False)
    assert SPDSolver(A).simplicial
    monkeypatch.setattr(linsolve, "SIMPLICIAL_MAX", A.shape[0] - 1)
    big = SPDSolver(A)
    assert big.backend == "cholmod" and not big.simplicial
    assert SPDSolver(A, simplicial=True).simplicial  # an explicit choice is kept
    assert np.abs(big.solve(b) - SPDSolver(A, "scipy").solve(b)).max() < 1e-9


def test_the_best_installed_backend_runs_by_default(monkeypatch):
    monkeypatch.delenv("HYBRIDEDIT_SOLVER", raising=False)
    best = available_backends()[0]
    assert linsolve.backend_name() == best
    A, _ = _system()
    assert SPDSolver(A).backend == best
    # cholespy is a required dependency: a CHOLMOD is always there
    assert cholmod_available() and best in ("cholmod", "cholespy")
    assert "cholespy" in available_backends()


def test_a_forced_backend_that_is_missing_is_an_error_not_a_substitute(monkeypatch):
    A, _ = _system()
    monkeypatch.setattr(linsolve, "_CHOLMOD", "")
    monkeypatch.setenv("HYBRIDEDIT_SOLVER", "cholmod")
    with pytest.raises(RuntimeError, match="scikit-sparse"):
        SPDSolver(A)
    monkeypatch.setenv("HYBRIDEDIT_SOLVER", "umfpack")
    with pytest.raises(ValueError, match="HYBRIDEDIT_SOLVER"):
        linsolve.backend_name()
    monkeypatch.delenv("HYBRIDEDIT_SOLVER")
    # asked for CHOLMOD by name (the engine's older callers) without scikit-sparse: cholespy's CHOLMOD
    assert SPDSolver(A, "cholmod").backend == "cholespy"
    with pytest.raises(ValueError, match="unknown backend"):
        SPDSolver(A, "umfpack")


def test_superlu_is_the_last_resort_with_a_one_time_note(monkeypatch):
    A, b = _system()
    monkeypatch.setattr(linsolve, "_CHOLMOD", "")
    monkeypatch.setattr(linsolve, "_cholespy", None)
    monkeypatch.setattr(linsolve, "_noted_superlu", False)
    monkeypatch.delenv("HYBRIDEDIT_SOLVER", raising=False)
    assert available_backends() == ("superlu",) and not cholmod_available()
    with pytest.warns(linsolve.SuperLUFallbackWarning, match="SuperLU"):
        s = SPDSolver(A)
    assert s.backend == "superlu"
    assert np.abs(A @ s.solve(b) - b).max() < 1e-10 * np.abs(b).max()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        SPDSolver(A)  # once only
    assert "no CHOLMOD" in linsolve.backend_description()


def test_the_description_names_the_backend_and_its_package(monkeypatch):
    monkeypatch.setenv("HYBRIDEDIT_SOLVER", "superlu")
    d = linsolve.backend_description()
    assert d.startswith("superlu (SuperLU via scipy ") and "forced by HYBRIDEDIT_SOLVER" in d
    monkeypatch.setenv("HYBRIDEDIT_SOLVER", "cholespy")
    assert linsolve.backend_description().startswith("cholespy (CHOLMOD via cholespy 2.")


@pytest.mark.slow
def test_the_engine_runs_on_each_backend_alike():
    """The same drag on each backend (a fresh process each, HYBRIDEDIT_SOLVER set): the same pose."""
    code = (
        "import sys, numpy as np; sys.path.insert(0, 'tests')\n"
        "from shapes import bumpy_blob\n"
        "from hybridedit import HybridEditor\nfrom hybridedit.core import linsolve\n"
        "m = bumpy_blob(3); x = m.vertices[:, 0]\n"
        "ed = HybridEditor(m, 120)\n"
        "ed.set_selection(np.flatnonzero(x > 0.6), roi=np.flatnonzero(x > 0.0))\n"
        "V = ed.pose(translate=(0, 0.3, 0))\n"
        "sys.stdout.buffer.write(linsolve.backend_name().encode().ljust(16) + np.ascontiguousarray(V).tobytes())\n"
    )
    import os

    from shapes import REPO as root
    poses = {}
    for name in available_backends():
        env = dict(os.environ, HYBRIDEDIT_SOLVER=name)
        out = subprocess.run([sys.executable, "-c", code], cwd=root, env=env, capture_output=True, timeout=300)
        assert out.returncode == 0, out.stderr.decode()[-2000:]
        assert out.stdout[:16].decode().strip() == name
        poses[name] = np.frombuffer(out.stdout[16:], dtype=np.float64)
    ref = poses["superlu"]
    for name, V in poses.items():
        assert np.abs(V - ref).max() < 1e-10, name


def test_an_empty_system_and_a_non_square_one():
    assert SPDSolver(sp.csc_matrix((0, 0))).solve(np.zeros((0, 3))).shape == (0, 3)
    with pytest.raises(ValueError):
        SPDSolver(sp.csc_matrix(np.ones((2, 3))))
