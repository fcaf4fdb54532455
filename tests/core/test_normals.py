"""One vertex-normal rule for the window and the files: angle-weighted, unit."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from hybridedit.core.normals import (accumulate_corners, face_terms, grouped_normals, vertex_normals,
                                     write_unit_rows, write_vertex_normals)
from hybridedit.core.parallel import all_parallel
from shapes import icosphere


def _incidence(F, n):
    rows = np.repeat(np.arange(len(F)), 3)
    order = np.argsort(F.ravel(), kind="stable")
    ptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(F.ravel(), minlength=n), out=ptr[1:])
    return ptr, rows[order].astype(np.int64)


def test_a_sphere_normals_point_outward():
    m = icosphere(3)
    n = vertex_normals(m.vertices, m.faces)
    radial = m.vertices / np.linalg.norm(m.vertices, axis=1, keepdims=True)
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0)
    assert np.min(np.einsum("ij,ij->i", n, radial)) > 0.999


def test_tessellation_does_not_pull_the_normal():
    """A corner of a cube: three faces, one of them cut into a fan of thin triangles. Angle weights
    give the same normal (the diagonal) however that face is cut; area weights would not."""
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0], [0.5, 1, 0], [1, 0.5, 0]])
    one = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2]])
    fan = np.array([[0, 2, 5], [0, 5, 4], [0, 4, 6], [0, 6, 1], [0, 1, 3], [0, 3, 2]])
    a = vertex_normals(V, one)[0]
    b = vertex_normals(V, fan)[0]
    assert np.allclose(a, b, atol=1e-12)
    assert np.allclose(a, -np.ones(3) / np.sqrt(3), atol=1e-12)  # outward of the corner


def test_rigid_motion_rotates_the_normals_and_unused_vertices_get_zero():
    m = icosphere(2)
    V = np.vstack([m.vertices, [[3.0, 3.0, 3.0]]])
    R = Rotation.from_rotvec([0.3, -1.1, 0.4]).as_matrix()
    n0 = vertex_normals(V, m.faces)
    n1 = vertex_normals(V @ R.T + [5.0, -2.0, 1.0], m.faces)
    assert np.allclose(n1[:-1], n0[:-1] @ R.T, atol=1e-12)
    assert np.all(n0[-1] == 0.0)


def test_degenerate_triangles_add_nothing():
    m = icosphere(1)
    V = np.vstack([m.vertices, m.vertices[:1]])  # a copy of vertex 0
    sliver = np.array([[0, len(V) - 1, 1]])  # zero area: 0 and its copy coincide
    assert np.allclose(vertex_normals(V, np.vstack([m.faces, sliver]))[:-1], vertex_normals(V, m.faces)[:-1])


@pytest.mark.slow
@pytest.mark.parametrize("parallel", [False, True])
def test_the_gather_the_scatter_and_the_groups_agree(parallel):
    m = icosphere(3)
    rng = np.random.default_rng(0)
    V = m.vertices + 0.05 * rng.standard_normal(m.vertices.shape)
    F = m.faces.astype(np.int64)
    ref = vertex_normals(V, F)
    ptr, idx = _incidence(F, len(V))
    ft = np.zeros((len(F), 6))
    out = np.zeros((len(V), 3), dtype=np.float32)
    verts = np.arange(len(V), dtype=np.int64)
    with all_parallel() if parallel else _nothing():
        face_terms(V, F, np.arange(len(F), dtype=np.int64), ft)
        write_vertex_normals(F, ft, ptr, idx, verts, out)
    assert np.allclose(out, ref, atol=1e-6)
    acc = np.zeros((len(V), 3))
    accumulate_corners(V, F, F, acc)
    out2 = np.zeros((len(V), 3))
    write_unit_rows(acc, verts, verts, out2)
    assert np.allclose(out2, ref, atol=1e-12)
    # one group per vertex is vertex_normals; all corners in one group is the mean direction
    n, ok = grouped_normals(V, F, F, len(V))
    assert np.array_equal(n, ref) and ok.all()
    n1, ok1 = grouped_normals(V, F, np.zeros_like(F), 1)
    assert ok1[0] and np.isclose(np.linalg.norm(n1[0]), 1.0)


def test_the_corner_angles_are_those_of_the_triangle():
    rng = np.random.default_rng(3)
    V = rng.standard_normal((300, 3))
    F = rng.permutation(300).reshape(100, 3).astype(np.int64)
    F = np.vstack([F, [[0, 1, 0]]])  # degenerate: no normal, no angles
    ft = np.zeros((len(F), 6))
    face_terms(V, F, np.arange(len(F), dtype=np.int64), ft)
    for c in range(3):
        u = V[F[:-1, (c + 1) % 3]] - V[F[:-1, c]]
        w = V[F[:-1, (c + 2) % 3]] - V[F[:-1, c]]
        truth = np.arctan2(np.linalg.norm(np.cross(u, w), axis=1), np.einsum("ij,ij->i", u, w))
        assert np.abs(ft[:-1, 3 + c] - truth).max() < 1e-7
    assert np.allclose(np.linalg.norm(ft[:-1, :3], axis=1), 1.0)
    assert np.all(ft[-1] == 0.0)


class _nothing:
    def __enter__(self):
        return self

    def __exit__(self, *a):
        return False
