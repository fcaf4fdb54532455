"""The window's per-frame kernels: updating only the moving region gives the whole-mesh results."""

from __future__ import annotations

import numpy as np
import pytest

from hybridedit.mesh import edge_stretch, rrms_edge_error, vertex_stretch
from hybridedit.viewer import regional
from hybridedit.viewer.regional import ShapeMetrics, vertex_normals


def reference_normals(V, F):
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    acc = np.zeros_like(V)
    for k in range(3):
        np.add.at(acc, F[:, k], fn)
    return acc / np.linalg.norm(acc, axis=1, keepdims=True)


@pytest.mark.parametrize("parallel", [False, True])
def test_region_updates_equal_whole_mesh_results(make_blob, monkeypatch, parallel):
    if parallel:
        monkeypatch.setattr(regional, "PARALLEL_MIN", 0)
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
