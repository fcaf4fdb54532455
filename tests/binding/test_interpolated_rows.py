"""Rows interpolated from seeds' (hybridedit.binding.interpolated_rows): the seeds are a maximal
independent set, the rows keep the binding's invariants, and an edit on them is as good as on
bound rows."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from hybridedit import HybridEditor, build_rig, read_mesh, rrms_edge_error
from hybridedit.binding import assemble
from hybridedit.binding import interpolated_rows as ir
from hybridedit.binding.bind import bind
from hybridedit.binding.truncation import MAX_ROW
from hybridedit.core.parallel import all_parallel
from support.edits import canonical_edit


def _shares_a_face(faces: np.ndarray, n: int) -> sp.csr_matrix:
    f = np.asarray(faces)
    a = np.concatenate([f[:, 0], f[:, 1], f[:, 2], f[:, 1], f[:, 2], f[:, 0]])
    b = np.concatenate([f[:, 1], f[:, 2], f[:, 0], f[:, 0], f[:, 1], f[:, 2]])
    return sp.csr_matrix((np.ones(a.size), (a, b)), shape=(n, n))


def test_seeds_are_a_maximal_independent_set(blob):
    seed = ir.seed_vertices(blob.n_vertices, blob.faces)
    A = _shares_a_face(blob.faces, blob.n_vertices)
    seeds_next_to = A @ seed.astype(float)
    assert not np.any(seeds_next_to[seed] > 0)  # no two seeds share a face
    assert np.all(seeds_next_to[~seed] > 0)  # every other vertex shares one with a seed
    assert 0.15 < seed.mean() < 0.4


def test_a_vertex_on_no_face_is_a_seed():
    seed = ir.seed_vertices(5, np.array([[0, 1, 2]]))
    assert seed.tolist() == [True, False, False, True, True]


@pytest.fixture(scope="module")
def armadillo_rigs(armadillo_path):
    """The armadillo's rig with every row bound and with interpolated rows, on the same cage."""
    shape = read_mesh(armadillo_path)
    bound = build_rig(shape, cage_size=0.05)
    mp = pytest.MonkeyPatch()
    mp.setattr(ir, "INTERPOLATE_FROM", 0)
    try:
        made = build_rig(shape, cage=bound.cage)
    finally:
        mp.undo()
    return shape, bound, made


def test_interpolated_rows_keep_the_bindings_invariants(armadillo_rigs):
    shape, bound, made = armadillo_rigs
    M, M0 = made.M, bound.M
    assert M.shape == M0.shape and M.has_sorted_indices
    np.testing.assert_allclose(np.asarray(M.sum(axis=1)).ravel(), 1.0, atol=1e-12)  # partition of unity
    assert np.diff(M.indptr).max() <= MAX_ROW and M.nnz / M.shape[0] <= 1.25 * M0.nnz / M0.shape[0]
    seed = ir.seed_vertices(shape.n_vertices, shape.faces)
    # a seed's row is the row the bind gives it (the seeds bound on their own)
    assert (M[seed] != bind(shape.vertices[seed], made.cage)).nnz == 0
    # a row reproduces its point to about its distance from its seeds (the 43K scan: a median of a
    # quarter of an edge, 3.4 times the bound rows'; the residual keeps the rest pose exact)
    err = np.linalg.norm(M @ made.cage.vertices - shape.vertices, axis=1)
    err0 = np.linalg.norm(M0 @ bound.cage.vertices - shape.vertices, axis=1)
    edge = np.mean(np.linalg.norm(np.diff(shape.vertices[shape.edges()], axis=1)[:, 0], axis=1))
    assert np.median(err) < 0.5 * edge and np.max(err) < np.max(err0) + 3.0 * edge


def test_an_edit_on_interpolated_rows_is_exact_and_as_good_as_on_bound_rows(armadillo_rigs):
    shape, bound, made = armadillo_rigs
    handle, roi, T = canonical_edit(shape)
    errors = []
    for rig in (bound, made):
        ed = HybridEditor(rig)
        np.testing.assert_array_equal(ed.deformed_vertices, shape.vertices)  # the rest pose, exactly
        ed.set_selection(handle, roi=roi)
        for _ in range(30):
            V = ed.drag(transform=T)
        fixed = np.setdiff1d(np.arange(shape.n_vertices), roi)
        np.testing.assert_array_equal(V[fixed], shape.vertices[fixed])
        np.testing.assert_allclose(V[handle], shape.vertices[handle] @ T[:3, :3].T + T[:3, 3], atol=1e-12)
        errors.append(rrms_edge_error(shape.vertices, V, shape.edges()))
    assert errors[1] <= 1.05 * errors[0]


def test_the_twins_and_the_threshold(blob, monkeypatch):
    parts = assemble.cage_parts(blob, 0.2)
    cage = parts.cage

    def rows(seeds):
        return bind(blob.vertices[seeds], cage)

    serial = ir.interpolated_binding(blob.vertices, blob.faces, rows, cage_vertices=cage.vertices, truncation=0.03)
    with all_parallel():
        parallel = ir.interpolated_binding(blob.vertices, blob.faces, rows, cage_vertices=cage.vertices,
                                           truncation=0.03)
    assert (serial != parallel).nnz == 0
    # below the threshold every vertex is bound; from it, the rows are interpolated
    whole = assemble._bind_shape(blob, parts, 0.03, lambda fraction: None)
    assert (whole != bind(blob.vertices, cage)).nnz == 0
    monkeypatch.setattr(ir, "INTERPOLATE_FROM", blob.n_vertices)
    assert (assemble._bind_shape(blob, parts, 0.03, lambda fraction: None) != serial).nnz == 0
    assert (serial != whole).nnz > 0


def test_the_short_row_rule_is_the_bindings_rule():
    from hybridedit.binding.truncation import MIN_KEPT_SUM, keep_row

    rng = np.random.default_rng(7)
    for trial in range(400):
        q = int(rng.integers(1, 30))
        row = rng.dirichlet(np.full(q, 0.3)) if trial % 3 else rng.normal(size=q) / q + 1.0 / q
        row[rng.random(q) < 0.1] = 0.0
        kidx, kvals = np.empty(q, dtype=np.int64), np.empty(q)
        m, scale = ir._keep(row.copy(), q, 0.03, kvals, kidx)
        surv, vals, idx = np.empty(q, dtype=np.int64), np.empty(q), np.empty(q, dtype=np.int64)
        m0, scale0 = keep_row(row, 0.03, MIN_KEPT_SUM, 0.0, surv, vals, idx)
        assert m == m0 and sorted(kidx[:m]) == sorted(idx[:m0])
        assert scale == pytest.approx(scale0, rel=1e-12)
