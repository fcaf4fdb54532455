import numpy as np
import pytest

from hybridedit.core.mesh import Mesh, MeshError, edge_stretch, rrms_edge_error, unique_edges, vertex_stretch

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


def test_edge_error_stats_is_the_rrms_error_and_the_largest_stretch_at_once():
    import numpy as np

    from hybridedit.core.mesh import edge_error_stats, edge_stretch, rrms_edge_error

    rng = np.random.default_rng(3)
    v = rng.random((40, 3))
    v[7] = v[8]  # a zero-length edge: left out of both
    e = np.array([[i, (i + 1) % 40] for i in range(40)])
    d = v + 0.05 * rng.standard_normal((40, 3))
    rrms, worst = edge_error_stats(v, d, e)
    assert rrms == rrms_edge_error(v, d, e)
    assert worst == np.abs(edge_stretch(v, d, e)).max() * 100.0
    assert edge_error_stats(np.zeros((2, 3)), np.ones((2, 3)), np.array([[0, 1]])) == (0.0, 0.0)
