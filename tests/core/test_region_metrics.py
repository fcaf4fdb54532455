"""The window's per-frame kernels: updating only the moving region gives the whole-mesh results."""

from __future__ import annotations

import contextlib

import numpy as np
import pytest

from hybridedit.core.mesh import edge_stretch, rrms_edge_error, vertex_stretch
from hybridedit.core.normals import vertex_normals
from hybridedit.core.parallel import all_parallel
from hybridedit.core.region_metrics import ShapeMetrics

from shapes import capsule_blob


@pytest.fixture(scope="module")
def make_blob():
    return capsule_blob


def reference_normals(V, F):
    """Angle-weighted vertex normals in plain numpy (arccos of the corners' unit edges)."""
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    fn /= np.linalg.norm(fn, axis=1, keepdims=True)
    acc = np.zeros_like(V)
    for k in range(3):
        u = V[F[:, (k + 1) % 3]] - V[F[:, k]]
        w = V[F[:, (k + 2) % 3]] - V[F[:, k]]
        cos = np.einsum("ij,ij->i", u, w) / np.linalg.norm(u, axis=1) / np.linalg.norm(w, axis=1)
        np.add.at(acc, F[:, k], fn * np.arccos(np.clip(cos, -1, 1))[:, None])
    return acc / np.linalg.norm(acc, axis=1, keepdims=True)


@pytest.mark.slow
@pytest.mark.parametrize("parallel", [False, True])
def test_region_updates_equal_whole_mesh_results(make_blob, parallel):
    with all_parallel() if parallel else contextlib.nullcontext():
        _region_updates_equal_whole_mesh_results(make_blob)


def _region_updates_equal_whole_mesh_results(make_blob):
    m = make_blob(3)
    rest, F = m.vertices, m.faces
    sm = ShapeMetrics(rest, F)
    pts = np.zeros((len(rest), 3), dtype=np.float32)
    nrm = np.zeros((len(rest), 3), dtype=np.float32)
    st = np.zeros(len(rest), dtype=np.float32)
    sm.write_points(rest, pts, everything=True)
    sm.write_normals(rest, nrm, everything=True)
    assert sm.update_error(rest, everything=True) == 0.0
    moving = np.flatnonzero(rest[:, 0] > 0.8)
    sm.set_moving(moving)
    rng = np.random.default_rng(1)
    V = rest.copy()
    for _ in range(3):  # several frames, each moving only the region
        V[moving] += 0.03 * rng.standard_normal((len(moving), 3))
        sm.write_points(V, pts)
        sm.write_normals(V, nrm)
        err = sm.update_error(V)
        sm.write_stretch(st)
    assert pts.dtype == np.float32 and np.array_equal(pts, V.astype(np.float32))
    np.testing.assert_allclose(nrm, reference_normals(V, F), atol=1e-6)
    np.testing.assert_allclose(nrm, vertex_normals(V, F), atol=1e-6)
    assert err == pytest.approx(rrms_edge_error(rest, V, sm.edges), rel=1e-9)
    np.testing.assert_allclose(st, 100 * vertex_stretch(len(V), sm.edges, edge_stretch(rest, V, sm.edges)),
                               rtol=1e-5, atol=1e-5)
    # the region is what a change of the moving vertices can reach, and no more
    assert set(sm.normal_vertices) == set(F[np.isin(F, moving).any(axis=1)].ravel())
    assert set(sm.moving_edges) == set(np.flatnonzero(np.isin(sm.edges, moving).any(axis=1)))


def test_region_with_a_vertex_on_no_face_and_a_pose_changed_outside(make_blob):
    """The region's normals read the pose around it afresh each frame; a moving vertex that no face
    uses gets a zero normal (as over the whole shape) instead of reading past the region."""
    m = make_blob(2)
    rest = np.vstack([m.vertices, [[9.0, 9.0, 9.0]]])  # one more vertex, on no face
    F = m.faces
    sm = ShapeMetrics(rest, F)
    nrm = np.zeros((len(rest), 3), dtype=np.float32)
    sm.write_normals(rest, nrm, everything=True)
    lone = len(rest) - 1
    moving = np.append(np.flatnonzero(rest[:-1, 1] > 0.5), lone)
    sm.set_moving(moving)
    V = rest.copy()
    V[rest[:, 1] <= 0.5] *= 1.1  # the vertices around the region moved too (e.g. a polish shown meanwhile)
    V[moving] += [0.1, -0.2, 0.05]
    sm.write_normals(V, nrm)
    ref = vertex_normals(V, F[:, :])[sm.normal_vertices[sm.normal_vertices != lone]]
    np.testing.assert_allclose(nrm[sm.normal_vertices[sm.normal_vertices != lone]], ref, atol=1e-6)
    assert np.all(nrm[lone] == 0.0)


def test_region_index_sets_equal_sorting_ones(monkeypatch):
    """The rows touching a region (a mask) and the renumbering (a table or a search) give what the
    sorting code they replace gave, repeated corners included."""
    from hybridedit.core import region_metrics as rm
    from hybridedit.core.topology import incidence

    rng = np.random.default_rng(3)
    n = 300
    faces = rng.integers(0, n, (900, 3))
    faces[5] = [7, 7, 9]  # a corner repeated
    ptr, rows = incidence(faces, n)  # (tested in test_topology)
    verts = np.unique(rng.integers(0, n, 40))
    expected = np.unique(np.concatenate([rows[ptr[v]:ptr[v + 1]] for v in verts]))
    assert np.array_equal(rm._touching(ptr, rows, verts, len(faces)), expected)
    assert rm._touching(ptr, rows, verts[:0], len(faces)).size == 0
    vertices = np.unique(faces[expected])
    for share in (0.0, 1.0):  # always the table, always the search
        monkeypatch.setattr(rm, "MASK_SHARE", share)
        local = rm._renumbered(vertices, faces[expected], n)
        assert local.dtype == np.int32 and np.array_equal(vertices[local], faces[expected])
