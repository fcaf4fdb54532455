"""Tests of the truncated binding matrix (hybridedit.binding)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp
import trimesh

from hybridedit.binding import MIN_KEPT_SUM, bind, truncate_rows
from hybridedit.mesh import Mesh
from hybridedit.mvc import mean_value_coordinates

MESHES = Path(__file__).resolve().parents[2] / "shared" / "meshes"
ARMADILLO = MESHES / "armadillo43k.obj"


# ---------------------------------------------------------------------------
# Reference truncation
# ---------------------------------------------------------------------------


def reference_truncate(row, t):
    """The paper's rule with a full sort: returns the kept column indices."""
    a = np.abs(row)
    budget = t * a.sum()
    order = np.argsort(a, kind="stable")
    cum = np.cumsum(a[order])
    n_drop = int(np.searchsorted(cum, budget, side="right"))
    kept = np.sort(order[n_drop:])
    if not row[kept].sum() >= MIN_KEPT_SUM:
        return np.flatnonzero(row)  # safeguard: keep the whole row
    return kept


def random_rows(rng, n, c, neg_frac=0.3):
    """Rows summing to 1 with heavy-tailed magnitudes and some negatives."""
    mag = rng.pareto(1.2, size=(n, c)) * 10.0 ** rng.uniform(-4, 0, size=(n, c))
    sign = np.where(rng.random((n, c)) < neg_frac, -0.3, 1.0)
    rows = mag * sign
    rows[rng.random((n, c)) < 0.05] = 0.0  # exact zeros too
    return rows / rows.sum(axis=1, keepdims=True)


def csr_rows(M):
    for i in range(M.shape[0]):
        lo, hi = M.indptr[i], M.indptr[i + 1]
        yield M.indices[lo:hi], M.data[lo:hi]


@pytest.mark.parametrize("t", [0.0, 0.01, 0.03, 0.1, 0.3])
def test_truncate_rows_matches_full_sort_reference(t):
    rng = np.random.default_rng(int(t * 1000))
    dense = random_rows(rng, 300, 257)
    before = dense.copy()
    M = truncate_rows(dense, t)
    np.testing.assert_array_equal(dense, before)  # input untouched
    assert isinstance(M, sp.csr_matrix) and M.shape == dense.shape and M.dtype == np.float64
    assert M.has_sorted_indices
    for i, (cols, vals) in enumerate(csr_rows(M)):
        row = dense[i]
        assert np.all(np.diff(cols) > 0)
        np.testing.assert_array_equal(cols, reference_truncate(row, t))
        # Magnitude kept and exact renormalization.
        assert np.abs(row[cols]).sum() >= (1 - t) * np.abs(row).sum() * (1 - 1e-14)
        assert abs(vals.sum() - 1.0) <= 1e-12
        # Kept values are the original ones rescaled by one common factor.
        np.testing.assert_allclose(vals, row[cols] / row[cols].sum(), rtol=1e-13)


def test_truncate_rows_zero_truncation_reproduces_dense():
    rng = np.random.default_rng(1)
    dense = random_rows(rng, 50, 40)
    M = truncate_rows(dense, 0.0)
    assert M.nnz == np.count_nonzero(dense)
    np.testing.assert_allclose(M.toarray(), dense, rtol=1e-14, atol=0)


def test_truncate_rows_drops_small_tail_of_mvc_like_rows():
    # Coordinates decaying like 1 / distance^2: most of the row is a tail.
    c = 5000
    d = np.linspace(0.1, 3.0, c)
    row = 1.0 / d**2
    row /= row.sum()
    M = truncate_rows(row[None, :], 0.03)
    cols, vals = next(csr_rows(M))
    np.testing.assert_array_equal(cols, reference_truncate(row, 0.03))
    assert len(cols) < c
    assert cols.max() == len(cols) - 1  # the largest ones (nearest) are kept


def test_truncate_rows_safeguard_keeps_rows_dominated_by_cancellation():
    # Two large opposite entries plus a tail of small positive ones holding all
    # of the row's signed sum: the plain rule would keep [5, -5], which sums
    # to 0 and cannot be renormalized.
    row = np.concatenate([[5.0, -5.0], np.full(50, 0.02)])
    M = truncate_rows(row[None, :], 0.3)
    cols, vals = next(csr_rows(M))
    assert len(cols) == len(row)
    np.testing.assert_allclose(vals, row, rtol=1e-15)


def test_truncate_rows_validation():
    with pytest.raises(ValueError):
        truncate_rows(np.ones(3), 0.03)
    with pytest.raises(ValueError):
        truncate_rows(np.array([[np.nan, 1.0]]), 0.03)
    for bad in (-0.01, 1.0, 1.5, float("nan"), "x"):
        with pytest.raises(ValueError):
            truncate_rows(np.eye(3), bad)


# ---------------------------------------------------------------------------
# bind()
# ---------------------------------------------------------------------------


def bumpy_shape_and_cage():
    """A bumpy closed shape and a coarser cage around it (always available)."""
    shape = trimesh.creation.icosphere(subdivisions=4)
    v = np.asarray(shape.vertices)
    r = 1.0 + 0.15 * np.sin(4 * v[:, 0]) * np.sin(3 * v[:, 1] + 1.0) * np.cos(2 * v[:, 2])
    shape_v = v * r[:, None]
    cage = trimesh.creation.icosphere(subdivisions=2, radius=1.25)
    return shape_v, Mesh(np.asarray(cage.vertices), np.asarray(cage.faces))


def test_bind_exact_equals_dense_coordinates():
    pts, cage = bumpy_shape_and_cage()
    pts = pts[::7]
    M = bind(pts, cage, truncation=0.0)
    dense = mean_value_coordinates(pts, cage.vertices, cage.faces)
    np.testing.assert_allclose(M.toarray(), dense, rtol=1e-14, atol=1e-17)
    diag = cage.bbox_diagonal()
    assert np.abs(M @ cage.vertices - pts).max() <= 1e-8 * diag


def test_bind_chunking_does_not_change_the_result():
    pts, cage = bumpy_shape_and_cage()
    pts = pts[::20]
    a = bind(pts, cage, truncation=0.03)
    b = bind(pts, cage, truncation=0.03, chunk_size=7)
    c = bind(pts, cage, truncation=0.03, chunk_size=1)
    for other in (b, c):
        np.testing.assert_array_equal(a.indptr, other.indptr)
        np.testing.assert_array_equal(a.indices, other.indices)
        np.testing.assert_array_equal(a.data, other.data)


def test_bind_truncated_properties_bumpy_sphere():
    pts, cage = bumpy_shape_and_cage()
    t = 0.03
    M = bind(pts, cage, truncation=t)
    exact = mean_value_coordinates(pts, cage.vertices, cage.faces)
    check_truncated(M, exact, t)
    check_error_bound(M, exact, cage.vertices, pts, t)


def check_error_bound(M, exact, cage_v, pts, t):
    """|M x - x| <= t * S / s * max_j |p_j - x| for every row.

    With sum_j lambda_j (p_j - x) = 0, the truncated row (kept entries over
    their sum s) gives M x - x = -(1/s) sum_dropped lambda_j (p_j - x), and the
    dropped magnitude is at most t * S.
    """
    err = np.linalg.norm(M @ cage_v - pts, axis=1)
    S = np.abs(exact).sum(axis=1)
    kept = np.asarray((M != 0).multiply(exact).sum(axis=1)).ravel()
    reach = np.linalg.norm(cage_v[None, :, :] - pts[:, None, :], axis=2).max(axis=1)
    bound = t * S / kept * reach
    assert np.all(err <= bound * (1 + 1e-9) + 1e-12), (err / bound).max()
    return err


def check_truncated(M, exact, t):
    n, c = exact.shape
    assert isinstance(M, sp.csr_matrix) and M.shape == (n, c) and M.dtype == np.float64
    assert M.has_sorted_indices
    np.testing.assert_allclose(np.asarray(M.sum(axis=1)).ravel(), 1.0, rtol=0, atol=1e-12)
    mag = np.abs(exact).sum(axis=1)
    for i, (cols, _) in enumerate(csr_rows(M)):
        assert np.all(np.diff(cols) > 0)
        assert np.abs(exact[i, cols]).sum() >= (1 - t) * mag[i] * (1 - 1e-12)
        # The dropped entries are no larger than the kept ones.
        dropped = np.setdiff1d(np.arange(c), cols)
        if len(dropped) and len(cols):
            assert np.abs(exact[i, dropped]).max() <= np.abs(exact[i, cols]).min()


@pytest.mark.skipif(not ARMADILLO.exists(), reason=f"{ARMADILLO} not available")
def test_bind_real_simplified_mesh():
    import fast_simplification

    m = trimesh.load(ARMADILLO, process=False)
    v = np.asarray(m.vertices, dtype=float)
    f = np.asarray(m.faces, dtype=np.int64)
    cv, cf = fast_simplification.simplify(v, f, target_reduction=1.0 - 300.0 / len(v))
    cage = Mesh(cv, cf)
    pts = v[:: max(1, len(v) // 1500)]
    diag = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))

    exact = bind(pts, cage, truncation=0.0)
    assert np.abs(exact @ cv - pts).max() <= 1e-8 * diag

    t = 0.03
    M = bind(pts, cage, truncation=t)
    check_truncated(M, exact.toarray(), t)
    nnz = np.diff(M.indptr)
    assert nnz.mean() < 0.1 * cage.n_vertices
    err = check_error_bound(M, exact.toarray(), cv, pts, t)
    print(
        f"\narmadillo, cage {cage.n_vertices} vertices, {len(pts)} points, truncation {t}: "
        f"nnz/row mean {nnz.mean():.1f} max {nnz.max()}, "
        f"|M@cage - points| / diag: rms {np.sqrt(np.mean(err**2)) / diag:.2e} "
        f"max {err.max() / diag:.2e}"
    )


def test_bind_moves_with_the_cage_rigidly():
    # Rows sum to 1 and reproduce the points approximately, so a rigid motion
    # of the cage moves the bound points by the same motion, up to the
    # truncation error, rotated.
    pts, cage = bumpy_shape_and_cage()
    pts = pts[::9]
    M = bind(pts, cage, truncation=0.05)
    rng = np.random.default_rng(3)
    q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    shift = np.array([3.0, -1.0, 2.0])
    base = M @ cage.vertices
    moved = M @ (cage.vertices @ q.T + shift)
    np.testing.assert_allclose(moved, base @ q.T + shift, atol=1e-12)


def test_bind_validation():
    pts, cage = bumpy_shape_and_cage()
    with pytest.raises(ValueError, match="points"):
        bind(np.zeros((4, 2)), cage)
    with pytest.raises(ValueError, match="finite"):
        bind(np.array([[0.0, np.inf, 0.0]]), cage)
    with pytest.raises(ValueError, match="no faces"):
        bind(pts[:3], Mesh(cage.vertices, np.zeros((0, 3), dtype=np.int64)))
    for bad in (-0.1, 1.0, 2.0, float("nan")):
        with pytest.raises(ValueError, match="truncation"):
            bind(pts[:3], cage, truncation=bad)
    for bad in (0, -3, 2.5):
        with pytest.raises(ValueError, match="chunk_size"):
            bind(pts[:3], cage, chunk_size=bad)
    with pytest.raises(ValueError, match="closed"):
        bind(pts[:3], Mesh(cage.vertices, cage.faces[1:]))
    empty = bind(np.zeros((0, 3)), cage)
    assert empty.shape == (0, cage.n_vertices) and empty.nnz == 0


def test_bind_reports_progress_and_can_be_cancelled():
    pts, cage = bumpy_shape_and_cage()
    pts = pts[::10]
    seen = []
    bind(pts, cage, chunk_size=20, progress=seen.append)
    assert seen[0] == 0.0 and seen[-1] == 1.0
    assert np.all(np.diff(seen) > 0) and len(seen) == 1 + -(-len(pts) // 20)

    class Stop(Exception):
        pass

    def cancel(fraction):
        if fraction > 0.3:
            raise Stop

    with pytest.raises(Stop):
        bind(pts, cage, chunk_size=20, progress=cancel)
