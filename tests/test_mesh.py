import numpy as np
import pytest

from hybridedit.mesh import Mesh, MeshError, edge_stretch, rrms_edge_error, unique_edges, vertex_stretch

from shapes import icosphere


def test_uniform_scaling_gives_known_errors():
    s = icosphere(2)
    e = s.edges()
    assert np.isclose(rrms_edge_error(s.vertices, 1.1 * s.vertices, e), 10.0)
    st = edge_stretch(s.vertices, 1.1 * s.vertices, e)
    assert np.allclose(st, 0.1)
    assert np.allclose(vertex_stretch(s.n_vertices, e, st), 0.1)
    R = np.linalg.qr(np.random.default_rng(0).normal(size=(3, 3)))[0]
    assert rrms_edge_error(s.vertices, s.vertices @ R.T + 5, e) < 1e-12


def test_edges_of_a_closed_mesh():
    s = icosphere(1)
    e = unique_edges(s.faces)
    assert len(e) == 3 * s.n_faces // 2 and np.all(e[:, 0] < e[:, 1])


def test_mesh_validation():
    with pytest.raises(MeshError, match="must lie in"):
        Mesh(np.zeros((3, 3)), [[0, 1, 3]])
    with pytest.raises(MeshError, match=r"\(n, 3\)"):
        Mesh(np.zeros((3, 2)), [[0, 1, 2]])
    with pytest.raises(MeshError, match="integers"):
        Mesh(np.zeros((3, 3)), [[0, 1, 1.5]])
    m = Mesh(np.zeros((3, 3)), np.zeros((0, 3)))
    assert m.n_faces == 0 and m.faces.dtype == np.int64
