"""Tests of the truncated binding matrix (hybridedit.binding.bind)."""

from __future__ import annotations


import numpy as np
import pytest
import scipy.sparse as sp
import trimesh

from hybridedit.binding import mvc
from hybridedit.binding.bind import MIN_KEPT_SUM, bind, truncate_rows
from hybridedit.core.mesh import Mesh
from hybridedit.binding.mvc import mean_value_coordinates

from shapes import SHARED_MESHES

MESHES = SHARED_MESHES
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


def fast_dense(pts, cage, correct):
    """The fast method's rows as bind computes them (uncorrected when truncating)."""
    fc = mvc.prepare_fast_cage(cage.vertices, cage.faces)
    plan = mvc.plan_fast(np.ascontiguousarray(pts, dtype=float), fc)
    buf = np.empty((len(pts), cage.n_vertices))
    mvc.compute_fast_sorted(plan, fc, 0, len(pts), buf, correct=correct)
    out = np.empty_like(buf)
    out[np.ix_(plan.order, fc.perm)] = buf
    return out


def reference_rows(pts, cage, method, t):
    """The dense rows that bind(..., truncation=t, method=method) truncates."""
    if method == "exact":
        return mean_value_coordinates(pts, cage.vertices, cage.faces)
    return fast_dense(pts, cage, correct=(t == 0.0))


def test_bind_exact_equals_dense_coordinates():
    pts, cage = bumpy_shape_and_cage()
    pts = pts[::7]
    M = bind(pts, cage, truncation=0.0, method="exact")
    dense = mean_value_coordinates(pts, cage.vertices, cage.faces)
    np.testing.assert_allclose(M.toarray(), dense, rtol=1e-14, atol=1e-17)
    diag = cage.bbox_diagonal()
    assert np.abs(M @ cage.vertices - pts).max() <= 1e-8 * diag


def test_bind_fast_untruncated_is_close_to_exact_and_linearly_precise():
    pts, cage = bumpy_shape_and_cage()
    M = bind(pts, cage, truncation=0.0)  # the default method is "fast"
    fast = M.toarray()
    exact = mean_value_coordinates(pts, cage.vertices, cage.faces)
    np.testing.assert_allclose(fast.sum(axis=1), 1.0, rtol=0, atol=1e-12)
    diag = cage.bbox_diagonal()
    assert np.abs(M @ cage.vertices - pts).max() <= 1e-8 * diag
    err = np.abs(fast - exact).max(axis=1) / np.abs(exact).sum(axis=1)
    assert err.max() <= 1e-4, err.max()
    # It is the fast method's dense result, made sparse.
    np.testing.assert_allclose(fast, fast_dense(pts, cage, correct=True), rtol=1e-14, atol=1e-17)


@pytest.mark.parametrize("method", ["fast", "flat", "exact"])
def test_bind_chunking_does_not_change_the_result(method):
    pts, cage = bumpy_shape_and_cage()
    pts = pts[::20]
    a = bind(pts, cage, truncation=0.03, method=method, max_row=None)
    b = bind(pts, cage, truncation=0.03, chunk_size=7, method=method, max_row=None)
    c = bind(pts, cage, truncation=0.03, chunk_size=1, method=method, max_row=None)
    for other in (b, c):
        np.testing.assert_array_equal(a.indptr, other.indptr)
        np.testing.assert_array_equal(a.indices, other.indices)
        np.testing.assert_array_equal(a.data, other.data)


@pytest.mark.parametrize("method", ["flat", "exact"])
def test_bind_truncated_properties_bumpy_sphere(method):
    pts, cage = bumpy_shape_and_cage()
    t = 0.03
    M = bind(pts, cage, truncation=t, method=method, max_row=None)
    rows = reference_rows(pts, cage, method, t)
    check_truncated(M, rows, t)
    check_error_bound(M, rows, cage.vertices, pts, t)


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


@pytest.mark.slow
@pytest.mark.skipif(not ARMADILLO.exists(), reason=f"{ARMADILLO} not available")
@pytest.mark.parametrize("method", ["flat", "exact"])
def test_bind_real_simplified_mesh(method):
    import fast_simplification

    m = trimesh.load(ARMADILLO, process=False)
    v = np.asarray(m.vertices, dtype=float)
    f = np.asarray(m.faces, dtype=np.int64)
    cv, cf = fast_simplification.simplify(v, f, target_reduction=1.0 - 300.0 / len(v))
    cage = Mesh(cv, cf)
    pts = v[:: max(1, len(v) // 1500)]
    diag = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))

    whole = bind(pts, cage, truncation=0.0, method=method)
    assert np.abs(whole @ cv - pts).max() <= 1e-8 * diag

    t = 0.03
    M = bind(pts, cage, truncation=t, method=method, max_row=None)
    rows = reference_rows(pts, cage, method, t)
    check_truncated(M, rows, t)
    nnz = np.diff(M.indptr)
    assert nnz.mean() < 0.1 * cage.n_vertices
    err = check_error_bound(M, rows, cv, pts, t)
    print(
        f"\narmadillo, {method}, cage {cage.n_vertices} vertices, {len(pts)} points, truncation {t}: "
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
    M = bind(pts, cage, truncation=0.05, max_row=None)
    rng = np.random.default_rng(3)
    q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    shift = np.array([3.0, -1.0, 2.0])
    base = M @ cage.vertices
    moved = M @ (cage.vertices @ q.T + shift)
    np.testing.assert_allclose(moved, base @ q.T + shift, atol=1e-12)





def bumpy_capsule_and_cage():
    """A bumpy capsule along x (the shape) and a coarser capsule around it (the cage)."""

    def capsule(subdiv, radius, bumps):
        s = trimesh.creation.icosphere(subdivisions=subdiv)
        v = np.asarray(s.vertices).copy()
        x, y, z = v.T
        r = 1.0 + bumps * np.sin(6 * x) * np.cos(5 * y) * np.cos(3 * z)
        v = v * (radius * r)[:, None]
        v[:, 0] *= 3.0
        return v, np.asarray(s.faces)

    pts, _ = capsule(4, 1.0, 0.08)
    cv, cf = capsule(3, 1.2, 0.0)
    return pts, Mesh(cv, cf)


def bend(v, angle):
    """Bend along x: the +x half rotates about z through the origin, smoothly."""
    x = v[:, 0]
    a = angle * np.clip(x / x.max(), 0.0, 1.0) ** 2
    ca, sa = np.cos(a), np.sin(a)
    out = v.copy()
    out[:, 0] = ca * x - sa * v[:, 1]
    out[:, 1] = sa * x + ca * v[:, 1]
    return out


@pytest.mark.slow
def test_fast_binding_accuracy_against_exact():
    """The accuracy bar of the fast method, on a shape whose cage is well inside
    the quadrature's regime (most faces far from most points)."""
    pts, cage = bumpy_capsule_and_cage()
    diag = float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0)))
    # (a) un-truncated rows
    exact0 = bind(pts, cage, truncation=0.0, method="exact").toarray()
    fast0 = bind(pts, cage, truncation=0.0, method="fast").toarray()
    rel = np.abs(fast0 - exact0).max(axis=1) / np.abs(exact0).sum(axis=1)
    assert rel.max() <= 1e-4, rel.max()  # the bar is 1e-3
    # the fast method really took the quadrature for most faces: not identical
    assert rel.max() > 1e-9
    # linear precision, as with the exact coordinates
    assert np.abs(fast0 @ cage.vertices - pts).max() <= 1e-9 * diag
    # (b) truncated: the reconstruction error is the truncation's, within 5%
    t = 0.03
    Me = bind(pts, cage, truncation=t, method="exact", max_row=None)
    Mf = bind(pts, cage, truncation=t, method="fast", max_row=None)
    np.testing.assert_allclose(np.asarray(Mf.sum(axis=1)).ravel(), 1.0, rtol=0, atol=1e-12)
    err_e = np.linalg.norm(Me @ cage.vertices - pts, axis=1)
    err_f = np.linalg.norm(Mf @ cage.vertices - pts, axis=1)
    rms_e = np.sqrt(np.mean(err_e**2))
    rms_f = np.sqrt(np.mean(err_f**2))
    assert abs(rms_f - rms_e) <= 0.05 * rms_e, (rms_f, rms_e)
    assert err_f.max() <= 1.05 * err_e.max()
    # (c) the same cage deformation moves both bindings' points alike. Where
    # the two rows straddle the truncation threshold they keep different
    # entries; that difference is of the order of what truncation itself
    # moves a point (the last line), not of the quadrature's error.
    y = bend(cage.vertices, np.pi / 3)
    moved = np.linalg.norm(Mf @ y - Me @ y, axis=1)
    assert moved.max() <= 1e-3 * diag, moved.max() / diag
    assert np.sqrt(np.mean(moved**2)) <= 1e-4 * diag
    # un-truncated, the deformations agree to the quadrature's accuracy
    assert np.abs(fast0 @ y - exact0 @ y).max() <= 1e-5 * diag
    assert np.linalg.norm(Me @ y - exact0 @ y, axis=1).max() > 10 * moved.max()


def test_fast_truncating_kernel_matches_dense_truncation(monkeypatch):
    """bind's flat path truncates rows inside the kernel and stores them
    sparse; rows keeping more than binding.SPARSE_ROW_CAP entries go through
    the dense buffer. Either way: the same matrix as truncating the dense
    fast rows, including the safeguard rows of points far outside."""
    from hybridedit.binding import bind as binding

    pts, cage = bumpy_shape_and_cage()
    rng = np.random.default_rng(6)
    far_out = rng.standard_normal((40, 3))
    far_out *= rng.uniform(2.5, 30.0, size=(40, 1)) / np.linalg.norm(far_out, axis=1)[:, None]
    pts = np.concatenate([pts[::3], far_out])
    # The kernel sees the columns in the cage's internal order, which decides
    # between entries of exactly equal magnitude (this cage is symmetric).
    perm = mvc.prepare_fast_cage(cage.vertices, cage.faces).perm
    for t in (0.03, 0.9):
        rows = fast_dense(pts, cage, correct=False)
        want = truncate_rows(rows[:, perm], t).tocoo()
        want = sp.csr_matrix((want.data, (want.row, perm[want.col])), shape=rows.shape)
        want.sort_indices()
        got = bind(pts, cage, truncation=t, method="flat", max_row=None)
        for cap in (2, 7):
            monkeypatch.setattr(binding, "SPARSE_ROW_CAP", cap)
            narrow = bind(pts, cage, truncation=t, chunk_size=50, method="flat", max_row=None)
            monkeypatch.undo()
            assert np.count_nonzero(np.diff(narrow.indptr) > cap) > 10
            for other in (got, narrow):
                np.testing.assert_array_equal(other.indptr, want.indptr)
                np.testing.assert_array_equal(other.indices, want.indices)
                np.testing.assert_array_equal(other.data, want.data)
        if t == 0.9:
            # some rows hit the safeguard (kept whole, not rescaled)
            whole = np.diff(want.indptr) == np.count_nonzero(rows, axis=1)
            assert whole[-40:].any()


def test_fast_binding_far_ratio():
    pts, cage = bumpy_shape_and_cage()
    pts = pts[::5]
    exact = bind(pts, cage, truncation=0.0, method="exact").toarray()
    errs = []
    for ratio in (1.0, 2.0, 4.0):
        fast = bind(pts, cage, truncation=0.0, far_ratio=ratio).toarray()
        errs.append((np.abs(fast - exact).max(axis=1) / np.abs(exact).sum(axis=1)).max())
    assert errs[0] > errs[1] > errs[2]
    assert errs[0] <= 5e-2 and errs[1] <= 2e-3 and errs[2] <= 3e-5, errs
    # inf: every face exact
    every = bind(pts, cage, truncation=0.0, far_ratio=np.inf).toarray()
    np.testing.assert_allclose(every, exact, rtol=0, atol=1e-12 * np.abs(exact).max())


@pytest.mark.parametrize("method", ["fast", "exact"])
def test_bind_points_on_the_cage(method):
    _, cage = bumpy_shape_and_cage()
    v, f = cage.vertices, cage.faces
    rng = np.random.default_rng(4)
    sel = rng.choice(len(f), size=30, replace=False)
    b = rng.dirichlet([2.0, 2.0, 2.0], size=len(sel))
    on_faces = np.einsum("ij,ijk->ik", b, v[f[sel]])
    t = rng.uniform(0.1, 0.9, size=(20, 1))
    on_edges = (1 - t) * v[f[sel[:20], 0]] + t * v[f[sel[:20], 1]]
    pts = np.concatenate([v[:25], on_faces, on_edges])
    M = bind(pts, cage, truncation=0.0, method=method).toarray()
    np.testing.assert_array_equal(M[:25], np.eye(len(v))[:25])
    for k, (tri, bb) in enumerate(zip(f[sel], b)):
        row = M[25 + k]
        assert set(np.flatnonzero(row)) <= set(tri)
        np.testing.assert_allclose(row[tri], bb, rtol=0, atol=1e-12)
    for k in range(20):
        row = M[55 + k]
        a, bb = f[sel[k], 0], f[sel[k], 1]
        assert set(np.flatnonzero(row)) == {a, bb}
        np.testing.assert_allclose([row[a], row[bb]], [1 - t[k, 0], t[k, 0]], rtol=0, atol=1e-12)


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
    with pytest.raises(ValueError, match="closed"):
        bind(pts[:3], Mesh(cage.vertices, cage.faces[1:]), method="exact")
    with pytest.raises(ValueError, match="method"):
        bind(pts[:3], cage, method="approximate")
    for bad in (0.5, -1.0, float("nan"), "x"):
        with pytest.raises(ValueError, match="far_ratio"):
            bind(pts[:3], cage, far_ratio=bad)
    empty = bind(np.zeros((0, 3)), cage)
    assert empty.shape == (0, cage.n_vertices) and empty.nnz == 0


@pytest.mark.parametrize("method", ["fast", "exact"])
def test_bind_reports_progress_and_can_be_cancelled(method):
    pts, cage = bumpy_shape_and_cage()
    pts = pts[::10]
    seen = []
    bind(pts, cage, chunk_size=20, progress=seen.append, method=method)
    assert seen[0] == 0.0 and seen[-1] == 1.0
    assert np.all(np.diff(seen) > 0) and len(seen) == 1 + -(-len(pts) // 20)

    class Stop(Exception):
        pass

    def cancel(fraction):
        if fraction > 0.3:
            raise Stop

    with pytest.raises(Stop):
        bind(pts, cage, chunk_size=20, progress=cancel, method=method)


def test_dominant_cage_vertex_is_the_row_argmax_of_the_magnitudes():
    import scipy.sparse as sp

    from hybridedit.binding.bind import dominant_cage_vertex

    for seed in range(4):
        M = sp.random(500, 80, density=0.05, random_state=seed, format="csr")
        M.data -= 0.5  # negative coordinates too
        M = sp.vstack([M, sp.csr_matrix((1, 80)), sp.csr_matrix(([0.3, -0.3], ([0, 0], [7, 3])), (1, 80))]).tocsr()
        want = np.asarray(abs(M).argmax(axis=1)).ravel()  # scipy's (slow) definition; ties: lowest index
        assert np.array_equal(dominant_cage_vertex(M), want)
        assert dominant_cage_vertex(M)[-1] == 3 and dominant_cage_vertex(M)[-2] == 0


def test_rows_go_to_their_points_on_either_twin():
    from hybridedit.binding.bind import _assemble, _rows_to_points
    from hybridedit.core.parallel import all_parallel

    rng = np.random.default_rng(6)
    n, c = 500, 40
    counts = rng.integers(0, 5, n)
    later = rng.choice(n, 30, replace=False)  # rows a first pass leaves empty, made in parts of their own
    parts, start = [], 0
    for stop in (120, 121, 500):  # chunks of rows, one of a single row
        k = counts[start:stop].copy()
        k[np.isin(np.arange(start, stop), later)] = 0
        parts.append((np.arange(start, stop), k, rng.random(int(k.sum())),
                      rng.integers(0, c, int(k.sum())).astype(np.int32)))
        start = stop
    for half in (later[:10], later[10:]):
        k = counts[half]
        parts.append((half, k, rng.random(int(k.sum())), rng.integers(0, c, int(k.sum())).astype(np.int32)))
    row_of = rng.permutation(n)
    M = _assemble(parts, n, c, row_of)
    plain = _assemble(parts, n, c)
    assert np.array_equal(np.diff(plain.indptr), counts)
    for pos, k, data, idx in parts:  # each row where its part put it
        ptr = np.concatenate([[0], np.cumsum(k)])
        for j in np.flatnonzero(k):
            r = pos[j]
            assert np.array_equal(plain.data[plain.indptr[r]:plain.indptr[r + 1]], data[ptr[j]:ptr[j + 1]])
            assert np.array_equal(plain.indices[plain.indptr[r]:plain.indptr[r + 1]], idx[ptr[j]:ptr[j + 1]])
    P = sp.csr_matrix((np.ones(n), (row_of, np.arange(n))), shape=(n, n))
    assert abs(M - P @ plain).max() == 0 and np.array_equal(np.diff(M.indptr), counts[np.argsort(row_of)])
    with all_parallel():
        assert np.array_equal(_assemble(parts, n, c, row_of).data, M.data)
    for twin in _rows_to_points:
        data, idx = np.empty_like(plain.data), np.empty_like(plain.indices)
        twin(plain.indptr.astype(np.int64), plain.data, plain.indices, row_of, M.indptr, data, idx)
        assert np.array_equal(data, M.data) and np.array_equal(idx, M.indices)


def test_packed_rows_on_either_twin():
    from hybridedit.binding.bind import _pack_rows, _pack_rows_twins

    rng = np.random.default_rng(7)
    cols = rng.integers(0, 99, (50, 8)).astype(np.int32)
    vals = rng.random((50, 8))
    rows = rng.permutation(50)[:30]  # some rows of the buffers, in any order
    counts = rng.integers(0, 9, 30)
    counts[3] = 12  # too wide for the buffers: room left, filled by the caller
    ptr = np.concatenate([[0], np.cumsum(counts)])
    want = np.concatenate([vals[b, :k] if k <= 8 else np.full(k, -1.0) for b, k in zip(rows, counts)])
    for twin in _pack_rows_twins:
        data, idx = np.full(ptr[-1], -1.0), np.full(ptr[-1], -1, dtype=np.int32)
        twin(rows, ptr, counts, cols, vals, idx, data)
        assert np.array_equal(data, want)
        assert np.array_equal(idx[ptr[4]:ptr[5]], cols[rows[4], :counts[4]])
    data, idx = _pack_rows(counts[:3], cols, vals)  # rows 0, 1, 2 by default
    assert np.array_equal(data, np.concatenate([vals[r, :counts[r]] for r in range(3)]))


def test_rows_too_wide_for_the_first_pass_are_made_with_the_undecided_ones(monkeypatch):
    """The hierarchical kernel's first pass stores FIRST_PASS_ROW_CAP entries a row; wider rows are
    made after the last chunk, with the rows it left undecided, SPARSE_ROW_CAP wide."""
    from hybridedit.binding import bind as binding

    from hybridedit.cage.build import build_cage

    from shapes import bumpy_blob

    shape = bumpy_blob(4)
    pts, cage = shape.vertices, build_cage(shape, 0.1)  # a cage close to the shape: narrow rows
    flat = bind(pts, cage, truncation=0.03, method="flat", max_row=None)
    later = []
    real = binding._undecided_rows

    def counting(redo, *args):
        later.append(len(redo))
        return real(redo, *args)

    monkeypatch.setattr(binding, "_undecided_rows", counting)
    made = {}
    for cap in (256, 3):
        monkeypatch.setattr(binding, "FIRST_PASS_ROW_CAP", cap)
        later.clear()
        made[cap] = bind(pts, cage, truncation=0.03, chunk_size=64, max_row=None)
        made[cap, "later"] = sum(later)
    wide = np.diff(flat.indptr) > 3
    assert wide.sum() > 0.1 * len(pts) and made[256, "later"] < 0.1 * len(pts)
    assert made[3, "later"] >= 0.9 * wide.sum() + made[256, "later"]
    # as close to the flat kernel's rows as the first pass's own: the same kept entries for nearly
    # every row, and the same values there
    for M in (made[256], made[3]):
        same = [r for r in range(len(pts)) if np.array_equal(M[r].indices, flat[r].indices)]
        assert len(same) >= 0.9 * len(pts)
        assert abs(M[same] - flat[same]).max() <= 1e-4
        assert np.allclose(np.asarray(M.sum(axis=1)).ravel(), 1.0)


def test_rows_left_only_on_the_cage_skip_the_flat_kernel(monkeypatch):
    """Points on the cage's faces that the hierarchy leaves undecided get their face's row, the flat
    kernel's bitwise, without its pass over every face (or the second pass); with a point off the
    cage among them, only that point goes to the flat kernel, and theirs are the same rows."""
    from hybridedit.binding import bind as binding

    _, cage = bumpy_shape_and_cage()
    rng = np.random.default_rng(8)
    f = cage.faces[rng.choice(cage.n_faces, 40, replace=False)]
    on = np.einsum("ij,ijk->ik", rng.dirichlet([2.0, 2.0, 2.0], size=40), cage.vertices[f])
    calls = []
    real = binding._fast_truncated_chunk

    def counting(plan, *args):
        calls.append(plan.n_points)
        return real(plan, *args)

    monkeypatch.setattr(binding, "_fast_truncated_chunk", counting)
    M = bind(on, cage)
    assert calls == []
    monkeypatch.undo()
    assert abs(M - bind(on, cage, method="flat")).max() == 0
    want = np.zeros((40, cage.n_vertices))
    np.put_along_axis(want, f, 1.0, axis=1)
    assert np.array_equal(M.toarray() > 0, want > 0)  # (barycentric: the face's three vertices)
    # no second pass: every undecided row reaches the last step; a point inside is not on the cage
    monkeypatch.setattr(binding, "_fast_truncated_chunk", counting)
    monkeypatch.setattr(binding, "SECOND_THETAS", ())
    inside = np.vstack([on, [[0.05, 0.02, 0.01]]])
    mixed = bind(inside, cage)
    assert calls[-1] == 1  # the point inside alone
    assert abs(mixed[:40] - M).max() == 0
    assert abs(mixed[40] - bind(inside, cage, method="flat")[40]).max() <= 1e-4
