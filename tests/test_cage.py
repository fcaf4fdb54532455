import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

from hybridedit.cage import build_cage, cage_vertex_target, clean_surface
from hybridedit.mesh import Mesh

from conftest import bumpy_blob


@pytest.mark.parametrize("size, target", [(400, 400), (0.05, 128), (0.1, 256)])
def test_cage_size_and_validity(blob, size, target):
    c = build_cage(blob, size)
    assert abs(c.n_vertices - target) <= max(2, 0.02 * target)
    t = trimesh.Trimesh(c.vertices, c.faces, process=False)
    assert t.is_watertight and t.is_winding_consistent
    assert t.volume > 0  # outward orientation kept
    assert t.euler_number == 2
    # the cage stays close to the shape
    d = cKDTree(blob.vertices).query(c.vertices)[0]
    assert d.max() < 0.05 * blob.bbox_diagonal()


def test_clean_surface_removes_fins_duplicates_and_degenerates():
    s = trimesh.creation.box()
    v = np.vstack([s.vertices, [[9.0, 9.0, 9.0]]])  # an unreferenced vertex
    f = s.faces.copy()
    extra = np.array([
        [0, 1, 8],  # references the stray vertex ... and a fin with its opposite below
        [1, 0, 8],
        [2, 2, 3],  # repeated index
        f[0],  # duplicate face
    ])
    out = clean_surface(v, np.vstack([f, extra]))
    assert out.n_faces == len(f)
    assert out.n_vertices == 8
    t = trimesh.Trimesh(out.vertices, out.faces, process=False)
    assert t.is_watertight and np.isclose(t.volume, 1.0)


def test_zero_area_faces_are_dropped():
    v = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0]], float)
    out = clean_surface(v, np.array([[0, 1, 2], [0, 1, 3]]))
    assert out.n_faces == 1


def test_bad_sizes(blob):
    with pytest.raises(ValueError, match="at least 4"):
        cage_vertex_target(100, 2)
    with pytest.raises(ValueError, match="only"):
        cage_vertex_target(100, 500)
    with pytest.raises(ValueError, match="fraction"):
        cage_vertex_target(100, 1.5)
    with pytest.raises(ValueError):
        cage_vertex_target(100, True)
    assert cage_vertex_target(1000, 0.05) == 50
