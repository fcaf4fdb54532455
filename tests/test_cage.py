import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

from hybridedit.cage import build_cage, cage_vertex_target, clean_surface
from hybridedit.mesh import Mesh, MeshError

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


# ------------------------------------------------------------------ repairs (hybridedit.repair)

from hybridedit.mvc import check_closed  # noqa: E402
from hybridedit.repair import box_cage, cage_source, close_holes  # noqa: E402


def closed_and_outward(c: Mesh) -> None:
    check_closed(c.faces)
    t = trimesh.Trimesh(c.vertices, c.faces, process=False)
    assert t.volume > 0


def test_clean_shape_needs_no_repair(blob):
    src, notes = cage_source(blob)
    assert notes == []
    assert np.array_equal(src.vertices, blob.vertices) and np.array_equal(src.faces, blob.faces)
    said = []
    build_cage(blob, 0.05, notes=said)
    assert said == []


def test_cage_source_repairs_and_says_so():
    s = trimesh.creation.icosphere(subdivisions=2)
    v, f = np.asarray(s.vertices), np.asarray(s.faces)
    n = len(v)
    v2 = np.vstack([v, v[:3] + 1e-13, [[7.0, 7.0, 7.0]]])  # near-duplicates and a stray vertex
    f2 = f.copy()
    first = f2[:, 0] < 3
    f2[first, 0] += n  # faces that start at vertex 0, 1 or 2 use its near-copy instead
    f2[10:30] = f2[10:30, ::-1]  # 20 faces flipped
    f2 = np.vstack([f2, f2[:2], [[1, 1, 2]]])  # duplicate faces and a repeated index
    src, notes = cage_source(Mesh(v2, f2))
    unused = 1 + len(np.setdiff1d([0, 1, 2], f2))  # the stray one and originals no face uses now
    assert notes == [
        f"ignored {unused} unreferenced vertices for the cage (they still follow the deformation)",
        f"merged {3 - (unused - 1)} duplicate vertices",
        "dropped 1 degenerate face (zero area or a repeated vertex)",
        "dropped 2 duplicate faces",
        "re-oriented 20 faces",
    ]
    assert src.n_vertices == n and src.n_faces == len(f)
    closed_and_outward(src)


def test_orientation_per_component_and_outward():
    a = trimesh.creation.icosphere(subdivisions=1)
    b = trimesh.creation.box()
    v = np.vstack([a.vertices, b.vertices + [5, 0, 0]])
    f = np.vstack([a.faces[:, ::-1], b.faces + len(a.vertices)])  # the sphere inside out
    src, notes = cage_source(Mesh(v, f))
    assert notes == [f"re-oriented {len(a.faces)} faces", "2 disconnected parts"]
    closed_and_outward(src)
    assert trimesh.Trimesh(src.vertices, src.faces).split(only_watertight=False)[0].volume > 0


def test_nonmanifold_edges_are_dropped():
    b = trimesh.creation.box()
    v = np.vstack([b.vertices, [[0.0, 0.0, 3.0]]])
    e = b.faces[0]
    f = np.vstack([b.faces, [[e[0], e[1], 8]], [[e[1], e[0], 8]]])
    src, notes = cage_source(Mesh(v, f))
    assert notes == ["dropped 1 duplicate face",  # the second fin face has the first one's vertices
                     "dropped 1 face at non-manifold edges (edges shared by more than two faces)"]
    check_closed(src.faces)


def test_all_degenerate_is_a_clear_error():
    v = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]], float)
    with pytest.raises(MeshError, match="line: every face is degenerate"):
        cage_source(Mesh(v, [[0, 1, 2], [1, 2, 3]], name="line"))


def test_holes_are_closed_with_the_loop_orientation():
    s = trimesh.creation.icosphere(subdivisions=3)
    c = s.triangles_center
    keep = (c[:, 2] < 0.8) & (c[:, 0] < 0.85)
    open_mesh = clean_surface(s.vertices, s.faces[keep])
    closed, holes = close_holes(open_mesh)
    assert holes == 2
    assert closed.n_vertices == open_mesh.n_vertices + 2
    closed_and_outward(closed)
    said = []
    cage = build_cage(Mesh(s.vertices, s.faces[keep]), 60, notes=said)
    assert said[-1] == "closed 2 holes in the cage"
    closed_and_outward(cage)


@pytest.mark.parametrize("scale", [1e-8, 1.0, 1e8])
def test_cage_at_any_scale(scale):
    b = bumpy_blob(3)
    m = Mesh(b.vertices * scale + 3 * scale, b.faces)
    said = []
    c = build_cage(m, 80, notes=said)
    assert said == [] and abs(c.n_vertices - 80) <= 2
    closed_and_outward(c)


def test_small_and_flat_shapes_get_a_cage():
    said = []
    c = build_cage(Mesh(trimesh.creation.box().vertices, trimesh.creation.box().faces), 50, notes=said)
    assert said == ["the mesh has only 8 usable vertices; the cage uses all of them instead of 50",
                    "the mesh is small: it is its own cage"]
    assert c.n_vertices == 8
    closed_and_outward(c)
    said = []
    tri = Mesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float), [[0, 1, 2]])
    c = build_cage(tri, 0.05, notes=said)
    assert said == ["the mesh is an open surface: its cage is a thin closed shell around it"]
    closed_and_outward(c)
    assert c.n_vertices == 6  # a prism around the triangle
    assert np.all(c.vertices.min(axis=0) < tri.vertices.min(axis=0))
    assert np.all(c.vertices.max(axis=0) > tri.vertices.max(axis=0))
    said = []
    g = trimesh.creation.box(extents=(1, 1, 1e-9))  # a flat plate: its closed cage has no volume
    c = build_cage(Mesh(g.vertices, g.faces), 8, notes=said)
    closed_and_outward(c)


def test_box_cage_is_closed_and_outward():
    c = box_cage(np.random.default_rng(0).random((20, 3)))
    closed_and_outward(c)
    assert c.n_vertices == 8 and c.n_faces == 12
