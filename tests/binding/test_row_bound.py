"""Every binding row keeps at most MAX_ROW = 12 coordinates, on every kind of shape, and a row cut to
that bound keeps the binding's two promises: it sums to 1 (partition of unity) and reproduces its
point from the cage vertices it keeps (linear precision). Rows the truncation rule keeps within the
bound are its own (rescaled to sum to 1, not refitted), so linear precision is checked on the cut
rows only."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import hybridedit as he
import hybridedit.binding.bind as bind_module
from hybridedit.binding.bind import bind
from hybridedit.binding.truncation import MAX_ROW, REFIT_GROWTH, _cap_rows, cap_rows

import wild_corpus
from shapes import bumpy_blob, icosphere


def thin_ellipsoid() -> tuple[he.Mesh, he.Mesh]:
    """A closed thin shape (a boot's sole, a blade: 2 x 0.16 x 0.7) in a coarse cage of its own
    shape 15% larger: the cage's two sides are close to every point, and nearly every row the rule
    keeps is wider than the bound (17 coordinates on average)."""
    axes = np.array([1.0, 0.08, 0.35])
    s, c = icosphere(4), icosphere(2)
    return he.Mesh(s.vertices * axes, s.faces, name="thin"), he.Mesh(c.vertices * axes * 1.15, c.faces)


def many_parts() -> he.Mesh:
    """A blob cut into four open parts with a small closed sphere beside them (five pieces)."""
    cut = wild_corpus.cut_into_parts(bumpy_blob(4), 4)
    ball = icosphere(2, radius=0.3)
    v = np.vstack([cut.vertices, ball.vertices + [0.0, 0.0, 1.6]])
    return he.Mesh(v, np.vstack([cut.faces, ball.faces + cut.n_vertices]), name="parts")


def open_sheet(n: int = 60) -> he.Mesh:
    """An open wavy square sheet (a terrain, a cloth), n x n vertices."""
    u, w = (a.ravel() for a in np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n), indexing="ij"))
    v = np.stack([u, w, 0.08 * np.sin(6 * u) * np.cos(4 * w)], axis=1)
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    return he.Mesh(v, np.vstack([np.stack([a, b, c], 1), np.stack([a, c, d], 1)]), name="sheet")


@pytest.fixture
def cut_rows(monkeypatch):
    """The rows the binding cuts, as (points, cage vertices, rows before, rows after) for every call of
    cap_rows in the pipeline."""
    seen = []

    def recording(M, points, cage_vertices, cap=MAX_ROW):
        out = cap_rows(M, points, cage_vertices, cap)
        seen.append((np.asarray(points), np.asarray(cage_vertices), M, out))
        return out

    monkeypatch.setattr(bind_module, "cap_rows", recording)
    return seen


def check_binding(M, diag: float, cut_rows, cap: int = MAX_ROW) -> int:
    """Asserts the bound, partition of unity, and linear precision of the cut rows; returns how many
    rows were cut. ``diag``: the size linear precision is measured against."""
    assert np.diff(M.indptr).max() <= cap
    assert np.abs(np.asarray(M.sum(axis=1)).ravel() - 1.0).max() <= 1e-12
    assert np.all(np.isfinite(M.data))
    n_cut = 0
    for points, cage_vertices, before, after in cut_rows:
        wide = np.diff(before.indptr) > cap
        n_cut += int(wide.sum())
        assert np.array_equal(np.diff(after.indptr)[wide], np.full(wide.sum(), cap))
        err = np.abs(after[wide] @ cage_vertices - points[wide]).max(initial=0.0)
        assert err <= 1e-9 * diag, err / diag
        weight = np.asarray(abs(after[wide]).sum(axis=1)).ravel()
        assert np.all(weight <= REFIT_GROWTH * np.asarray(abs(before[wide]).sum(axis=1)).ravel())
        narrow = ~wide
        assert (abs(after[narrow] - before[narrow]) > 0).nnz == 0  # the rule's own rows, untouched
    return n_cut


def test_a_thin_closed_shape_binds_within_the_bound_with_linear_precision(cut_rows):
    mesh, cage = thin_ellipsoid()
    M = bind(mesh.vertices, cage)
    n_cut = check_binding(M, mesh.bbox_diagonal(), cut_rows)
    assert n_cut > 0.9 * mesh.n_vertices  # (the bound is what shapes this binding)
    # every row here is cut or the rule's own; the cut ones reproduce the shape
    whole = bind(mesh.vertices, cage, max_row=None)
    wide = np.diff(whole.indptr) > MAX_ROW
    assert np.abs(M[wide] @ cage.vertices - mesh.vertices[wide]).max() <= 1e-9 * mesh.bbox_diagonal()


@pytest.mark.parametrize("make", [many_parts, open_sheet], ids=["many parts", "open sheet"])
def test_the_pipeline_binds_every_shape_within_the_bound(make, cut_rows):
    mesh = make()
    rig = he.build_rig(mesh, cage_size=0.05)
    n_cut = check_binding(rig.M, mesh.bbox_diagonal(), cut_rows)
    assert n_cut > 0  # (these shapes have rows the rule keeps wider)


def test_the_exact_and_flat_methods_are_bound_too(cut_rows):
    mesh, cage = thin_ellipsoid()
    pts = mesh.vertices[::7]
    for method in ("exact", "flat"):
        cut_rows.clear()
        M = bind(pts, cage, method=method)
        assert check_binding(M, mesh.bbox_diagonal(), cut_rows) > 0


def kernel(M, points, cage, cap):
    """_cap_rows called directly: (counts, indices, data) of the capped rows."""
    counts = np.empty(M.shape[0], dtype=np.int64)
    nnz = int(np.minimum(np.diff(M.indptr), cap).sum())
    out_i = np.empty(nnz, dtype=M.indices.dtype)
    out_d = np.empty(nnz)
    k = _cap_rows(M.indptr.astype(np.int64), M.indices, M.data, cap, 0.5, points, cage, counts, out_i, out_d)
    return counts, out_i[:k], out_d[:k]


def test_the_kernel_cuts_a_row_of_20_to_12_and_keeps_its_precision():
    rng = np.random.default_rng(3)
    cage = rng.normal(size=(30, 3))
    cols = np.sort(rng.choice(30, 20, replace=False))
    w = rng.random(20) + 0.05
    w[[2, 9]] = -0.2  # signed, as outside a fold of the cage
    w /= w.sum()
    row = np.zeros(30)
    row[cols] = w
    M = sp.csr_matrix(row[None, :])
    x = M @ cage
    counts, idx, data = kernel(M, x, cage, 12)
    assert counts.tolist() == [12]
    assert np.array_equal(idx, np.sort(cols[np.argsort(-np.abs(w), kind="stable")[:12]]))  # the 12 largest
    assert abs(data.sum() - 1.0) <= 1e-14
    assert np.abs(data @ cage[idx] - x[0]).max() <= 1e-14 * np.abs(cage).max()
    # the least change from the kept coordinates, each relative to its size, that meets both: what the
    # 4 x 4 normal equations give
    w0 = row[idx]
    D = np.diag(np.abs(w0))
    A = np.vstack([np.ones(12), cage[idx].T])
    b = np.concatenate([[1.0], x[0]])
    assert np.allclose(data, w0 + D @ A.T @ np.linalg.solve(A @ D @ A.T, b - A @ w0), rtol=0, atol=1e-13)


def row_above_a_plane(*, seed: int, thickness: float):
    """(cage (16, 3) about the plane z = 0, ``thickness`` its vertices' spread across it; a row's 16
    positive coordinates w (16,) summing to 1; x (1, 3) the point they bind lifted 0.3 off the plane)."""
    rng = np.random.default_rng(seed)
    cage = np.column_stack([rng.normal(size=(16, 2)), thickness * rng.normal(size=16)])
    w = rng.random(16) + 0.1
    w /= w.sum()
    return cage, w, (w @ cage)[None, :] + [0.0, 0.0, 0.3]


def test_the_kernel_fits_flat_kept_vertices_in_their_plane():
    """Kept cage vertices all in the plane z = 0 and a point above it: no weights reproduce its height;
    the row sums to 1 and reproduces x and y."""
    cage, w, x = row_above_a_plane(seed=4, thickness=0.0)
    counts, idx, data = kernel(sp.csr_matrix(w[None, :]), x, cage, 12)
    assert counts.tolist() == [12] and abs(data.sum() - 1.0) <= 1e-14
    assert np.abs(data @ cage[idx] - x[0])[:2].max() <= 1e-14


def test_the_kernel_gives_up_a_direction_rather_than_blow_a_row_up():
    """Kept cage vertices nearly flat (1e-3 thick) and a point well off their plane: reproducing its
    height would take coordinates in the hundreds; the row stays within REFIT_GROWTH of its weight and
    reproduces the point in the plane but for that direction's tilt."""
    cage, w, x = row_above_a_plane(seed=5, thickness=1e-3)
    counts, idx, data = kernel(sp.csr_matrix(w[None, :]), x, cage, 12)
    assert counts.tolist() == [12] and abs(data.sum() - 1.0) <= 1e-14
    assert np.abs(data).sum() <= REFIT_GROWTH * np.abs(w).sum()
    err = np.abs(data @ cage[idx] - x[0])[:2].max()  # (the flat direction is tilted by about 1e-3)
    rescaled = row_of(w, idx) / row_of(w, idx).sum()
    assert err <= 1e-4 and err < 1e-2 * np.abs(rescaled @ cage - x[0])[:2].max()


def row_of(w, idx):
    """``w`` with only the entries ``idx`` kept."""
    out = np.zeros_like(w)
    out[idx] = w[idx]
    return out
