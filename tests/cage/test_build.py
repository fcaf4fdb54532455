import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

from hybridedit.cage.build import build_cage
from hybridedit.cage.clean import clean_surface
from hybridedit.core.mesh import Mesh, MeshError

from shapes import bumpy_blob


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


def test_a_cage_size_is_checked_by_one_rule_wherever_it_comes_from(blob):
    """The engine, the command line and the window's box read a size by the same rule (defaults)."""
    import argparse

    from hybridedit.cli import parse_cage_size
    from hybridedit.defaults import check_cage_size

    for bad, words in ((2, "at least 4"), (1.5, "fraction"), (0.0, "fraction"),
                       (True, "cage_size must be a vertex count"), ("many", "cage_size must be a vertex count"),
                       ("3", "cage_size must be")):
        with pytest.raises(ValueError, match=words):
            check_cage_size(bad)
        with pytest.raises(ValueError, match=words):
            build_cage(blob, bad)
    # a size written as text (a config file's, a form's) is read as the command line reads it
    assert check_cage_size("5%") == parse_cage_size("5%") == 0.05 and check_cage_size("2000") == 2000
    for text, want in (("5%", 0.05), ("2000", 2000), ("0.25", 0.25)):
        assert parse_cage_size(text) == want and type(parse_cage_size(text)) is type(want)
    for text in ("3", "150%", "many"):
        with pytest.raises(argparse.ArgumentTypeError):
            parse_cage_size(text)


# ------------------------------------------------------------------ repairs (hybridedit.core.repair)

from hybridedit.core.topology import check_closed  # noqa: E402
from hybridedit.core.repair import box_cage, cage_source, close_holes  # noqa: E402


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


def test_a_fin_on_an_edge_is_dropped():
    b = trimesh.creation.box()
    v = np.vstack([b.vertices, [[0.0, 0.0, 3.0]]])
    e = b.faces[0]
    f = np.vstack([b.faces, [[e[0], e[1], 8]], [[e[1], e[0], 8]]])
    src, notes = cage_source(Mesh(v, f))
    assert notes == ["dropped 1 duplicate face",  # the second fin face has the first one's vertices
                     "dropped 1 face standing alone at non-manifold edges (fins)"]
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


# ------------------------------------------------------------------ parts, sheets, tiny meshes

from hybridedit import HybridEditor  # noqa: E402
from hybridedit.binding.assemble import cage_and_binding  # noqa: E402
from hybridedit.cage.links import cage_links  # noqa: E402
from hybridedit.cage.parts import cage_parts  # noqa: E402
from hybridedit.cage.shell import shell_pairs, thicken  # noqa: E402
from hybridedit.core.mesh import edge_stretch  # noqa: E402
from hybridedit.core.topology import connected_parts  # noqa: E402


def _sphere(center, radius, sub=2):
    s = trimesh.creation.icosphere(subdivisions=sub, radius=radius)
    return np.asarray(s.vertices) + np.asarray(center, float), np.asarray(s.faces)


def _union(*parts):
    vs, fs, k = [], [], 0
    for v, f in parts:
        vs.append(v)
        fs.append(f + k)
        k += len(v)
    return Mesh(np.vstack(vs), np.vstack(fs))


def _sheet(n=24, size=120.0):
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1))
    v = np.column_stack([i.ravel() * size / n, j.ravel() * size / n, np.zeros((n + 1) ** 2)])
    a = (j[:-1, :-1] * (n + 1) + i[:-1, :-1]).ravel()
    return Mesh(v, np.concatenate([np.stack([a, a + 1, a + n + 2], 1), np.stack([a, a + n + 2, a + n + 1], 1)]))


def _drag(mesh, handle, fixed, move, frames=15, size=0.05):
    ed = HybridEditor(mesh, size)
    ed.set_selection(handle, fixed=fixed)
    for _ in range(frames):
        V = ed.drag(translate=move)
    return ed, V


def _winding(points, cage):
    from hybridedit.cage.links import _winding as w
    return w(points, cage.vertices, cage.faces)


def test_each_part_is_bound_only_to_its_own_cage_piece():
    a, b = _sphere([0, 0, 0], 1.0), _sphere([1.2, 0, 0], 1.0)  # overlapping
    m = _union(a, b)
    parts = cage_parts(m, 0.05)
    assert len(parts.offsets) == 3 and parts.kinds == ("simplified", "simplified")
    cage, M = cage_and_binding(m, 0.05)
    check_closed(cage.faces)
    na = len(a[0])
    piece = np.searchsorted(parts.offsets, M.tocoo().col, side="right") - 1
    assert np.array_equal(piece, (M.tocoo().row >= na).astype(int))  # block-diagonal
    assert np.allclose(np.asarray(M.sum(axis=1)).ravel(), 1.0)
    assert np.abs(M @ cage.vertices - m.vertices).max() < 0.05 * m.bbox_diagonal()


def test_overlapping_spheres_do_not_spike():
    a, b = _sphere([0, 0, 0], 1.0), _sphere([1.2, 0, 0], 1.0)
    m = _union(a, b)
    x = m.vertices[:, 0]
    diag = m.bbox_diagonal()
    handle = np.flatnonzero((x < -0.7) & (np.arange(m.n_vertices) < len(a[0])))
    _, V = _drag(m, handle, np.flatnonzero(x > 1.9), (0, 0.15 * diag, 0))
    d = np.linalg.norm(V - m.vertices, axis=1)
    assert d.max() <= 1.05 * 0.15 * diag  # no vertex moves further than the handle


def _two_scales():
    big, small = _sphere([0, 0, 0], 1.0, sub=3), _sphere([1.5, 0, 0], 0.001, sub=3)
    return _union(big, small), len(big[0]), Mesh(*small)


def test_a_small_part_beside_a_big_one_gets_the_cage_and_binding_it_would_have_alone():
    m, nb, small = _two_scales()
    cage, M = cage_and_binding(m, 0.05)
    alone_cage, alone_M = cage_and_binding(small, 0.05)
    k = alone_cage.n_vertices
    assert np.array_equal(cage.vertices[-k:], alone_cage.vertices)
    assert np.array_equal(cage.faces[-len(alone_cage.faces):] - (cage.n_vertices - k), alone_cage.faces)
    assert abs(M[nb:, -k:] - alone_M).max() == 0 and M[nb:, :-k].nnz == 0 and M[:nb, -k:].nnz == 0
    assert len(cage_links(cage)) == 0  # 0.5 m apart: neither holds the other


def test_parts_of_very_different_sizes_deform_at_their_own_scale():
    m, nb, small = _two_scales()
    s = np.arange(nb, m.n_vertices)
    y = m.vertices[s, 1]
    move = (0.0002, 0, 0)
    _, V = _drag(m, s[y > 0.0005], np.concatenate([np.arange(nb), s[y < -0.0005]]), move)
    ya = small.vertices[:, 1]
    _, V2 = _drag(small, np.flatnonzero(ya > 0.0005), np.flatnonzero(ya < -0.0005), move)
    assert np.allclose(V[:nb], m.vertices[:nb])  # the big sphere, all fixed, does not move
    # the small sphere deforms as it does alone
    assert np.abs(V[nb:] - V2).max() < 1e-3 * np.abs(V2 - small.vertices).max()


def test_a_loose_small_part_follows_its_host_and_a_part_with_no_host_stays():
    head, eye = _sphere([0, 0, 0], 1.0, sub=3), _sphere([0, 0.6, 0.3], 0.15)
    far = _sphere([5, 0, 0], 0.5)
    m = _union(head, eye, far)
    nh, ne = len(head[0]), len(eye[0])
    y = m.vertices[:nh, 1]
    ed, V = _drag(m, np.flatnonzero(y > 0.8), np.flatnonzero(y < -0.3), (0, 0, 0.3))  # no refusal
    d = V - m.vertices
    eye_d = d[nh:nh + ne].mean(axis=0)
    from scipy.spatial import cKDTree
    near = cKDTree(m.vertices[:nh]).query(m.vertices[nh:nh + ne].mean(axis=0), k=20)[1]
    host_d = d[near].mean(axis=0)
    assert eye_d @ host_d / (np.linalg.norm(eye_d) * np.linalg.norm(host_d)) > 0.95  # same way
    assert 0.5 < np.linalg.norm(eye_d) / np.linalg.norm(host_d) < 1.5  # about as far
    assert np.abs(d[nh + ne:]).max() < 1e-12  # the far sphere: no constraint, no host: it stays


def test_a_small_part_inside_or_against_a_bigger_one_is_linked_to_it():
    head, eye = _sphere([0, 0, 0], 1.0), _sphere([0, 0.6, 0.3], 0.15, sub=1)
    button = _sphere([0, 0, 1.05], 0.1, sub=1)  # touching the head from outside
    far = _sphere([5, 0, 0], 0.3, sub=1)  # no host
    m = _union(head, eye, button, far)
    cage, _ = cage_and_binding(m, 0.05)
    links = cage_links(cage)
    assert links.shape[1] == 2 and np.all(links[:, 0] < links[:, 1])
    count, labels = connected_parts(cage.faces, cage.n_vertices)
    assert count == 4
    # the head (the largest piece) carries the eye and the button; the far sphere is left alone
    import scipy.sparse as sps
    from scipy.sparse.csgraph import connected_components as cc
    e = np.vstack([links, cage.faces[:, [0, 1]], cage.faces[:, [1, 2]]])
    g = sps.coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(cage.n_vertices,) * 2)
    _, joined = cc(g, directed=False)
    piece_of = [labels[np.argmin(np.linalg.norm(cage.vertices - c, axis=1))]
                for c in ([0, 1, 0], [0, 0.6, 0.3], [0, 0, 1.05], [5, 0, 0])]
    first = [np.flatnonzero(labels == p)[0] for p in piece_of]
    assert joined[first[0]] == joined[first[1]] == joined[first[2]]
    assert joined[first[3]] != joined[first[0]]
    # every vertex of the eye is tied to a head vertex
    eye_v = np.flatnonzero(labels == piece_of[1])
    assert np.all(np.isin(eye_v, links.ravel()))


def test_one_closed_part_has_no_links(blob):
    cage, _ = cage_and_binding(blob, 200)
    assert cage_links(cage).shape == (0, 2)


def test_an_open_sheet_gets_a_thin_closed_shell_and_bends_smoothly():
    m = _sheet(24)
    said = []
    parts = cage_parts(m, 0.2, notes=said)
    assert parts.kinds == ("shell",)
    assert said == ["the mesh is an open surface: its cage is a thin closed shell around it"]
    cage = parts.cage
    check_closed(cage.faces)
    inner = np.all((m.vertices[:, :2] > 10) & (m.vertices[:, :2] < 110), axis=1)
    assert np.all(np.abs(_winding(m.vertices[inner], cage) - 1.0) < 1e-6)  # the sheet is inside its shell
    assert np.ptp(cage.vertices[:, 2]) < 0.2 * np.ptp(m.vertices[:, 0])  # thin, not a box
    k = cage.n_vertices // 2
    assert np.array_equal(shell_pairs(cage.faces, 0, cage.n_vertices), np.stack([np.arange(k), np.arange(k) + k], 1))
    assert len(cage_links(cage)) == k  # the layers are tied through
    x = m.vertices[:, 0]
    diag = m.bbox_diagonal()
    ed, V = _drag(m, np.flatnonzero(x > 110), np.flatnonzero(x < 40), (0, 0, 0.15 * diag), size=0.2)
    assert np.allclose(np.asarray(ed.M.sum(axis=1)).ravel(), 1.0)
    t = trimesh.Trimesh(V, m.faces, process=False)
    mid = m.vertices[m.faces[t.face_adjacency].reshape(len(t.face_adjacency), -1)].mean(axis=1)[:, 0]
    inside = (mid > 45) & (mid < 100)  # the free band, away from the seams with the handle and the fixed part
    assert np.degrees(t.face_adjacency_angles[inside].max()) < 10  # no kinks
    assert np.abs(edge_stretch(m.vertices, V, m.edges())).max() < 0.15
    assert V[x > 110, 2].min() > 0.1 * diag  # the free end went up


def test_a_scan_with_holes_gets_its_holes_closed():
    s = trimesh.creation.icosphere(subdivisions=3)
    v = np.asarray(s.vertices) * [2, 1, 1]
    c = v[s.faces].mean(axis=1)
    keep = ~((np.linalg.norm(c - [0, 0, 1], axis=1) < 0.3) | (np.linalg.norm(c - [1, 0.6, 0.6], axis=1) < 0.3))
    m = Mesh(v, np.asarray(s.faces)[keep])
    said = []
    parts = cage_parts(m, 0.1, notes=said)
    # fans close the holes (those simplification left), not a shell
    assert parts.kinds in (("holes closed",), ("simplified",))
    check_closed(parts.cage.faces)
    x = v[:, 0]
    diag = m.bbox_diagonal()
    _, V = _drag(m, np.flatnonzero(x > 1.6), np.flatnonzero(x < -1.0), (0, 0.15 * diag, 0), size=0.1)
    assert np.all(np.isfinite(V))
    used = np.unique(m.faces)
    assert np.abs(edge_stretch(v, V, m.edges())).max() < 0.5
    lifted = np.intersect1d(np.flatnonzero(x > 1.6), used)
    assert (V - v)[lifted, 1].min() > 0.1 * diag


def test_a_thickened_triangle_is_a_closed_prism_around_it():
    tri = Mesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float), [[0, 1, 2]])
    shell = thicken(tri, 0.1)
    check_closed(shell.faces)
    assert shell.n_vertices == 6 and shell.n_faces == 8
    assert np.all(np.abs(_winding(np.array([[0.2, 0.2, 0.0], [0.01, 0.01, 0.0]]), shell) - 1) < 1e-9)
    assert thicken(Mesh(np.zeros((3, 3)), [[0, 1, 2]])) is None  # nothing to thicken


@pytest.mark.parametrize("kind", ["cube", "sphere42"])
def test_a_tiny_mesh_is_its_own_cage_and_is_edited(kind):
    if kind == "cube":
        b = trimesh.creation.box()
        m = Mesh(np.asarray(b.vertices), np.asarray(b.faces))
    else:
        s = trimesh.creation.icosphere(subdivisions=1)
        m = Mesh(np.asarray(s.vertices), np.asarray(s.faces))
    ed = HybridEditor(m)  # the default 5%: 0 vertices for the cube, 2 for the sphere
    assert ed.cage.n_vertices == m.n_vertices
    assert abs(ed.M - __import__("scipy").sparse.identity(m.n_vertices)).max() < 1e-9  # bound to itself
    v = m.vertices
    top = int(np.argmax(v @ [1, 1, 1]))
    ed.set_selection([top], fixed=np.flatnonzero(v @ [1, 1, 1] < 0))
    for _ in range(10):
        V = ed.drag(translate=(0, 0.2, 0))
    assert np.allclose(V[top], v[top] + [0, 0.2, 0])
    assert np.allclose(V[v @ [1, 1, 1] < 0], v[v @ [1, 1, 1] < 0])


def test_many_small_parts_are_bound_each_to_its_own_piece():
    rng = np.random.default_rng(1)
    parts = [_sphere([0, 0, 0], 1.0)]
    for _ in range(120):  # debris: tiny loose triangles around a scan
        parts.append((rng.uniform(-1.5, 1.5, 3) + rng.normal(0, 0.01, (3, 3)), np.array([[0, 1, 2]])))
    parts.append(_sphere([3, 0, 0], 0.05, sub=1))  # and a small closed part: its own cage
    m = _union(*parts)
    pieces = cage_parts(m, 0.05)
    assert pieces.kinds == ("simplified",) + ("shell",) * 120 + ("own",)
    cage, M = cage_and_binding(m, 0.05)
    coo = M.tocoo()
    piece_of_col = np.searchsorted(pieces.offsets, coo.col, side="right") - 1
    assert np.array_equal(piece_of_col, pieces.owner[coo.row])  # block-diagonal
    assert np.allclose(np.asarray(M.sum(axis=1)).ravel(), 1.0)
    near = np.abs(M @ cage.vertices - m.vertices).max(axis=1)
    sizes = np.array([np.ptp(p[0], axis=0).max() for p in parts])
    assert np.all(near <= 0.05 * np.repeat(sizes, [len(p[0]) for p in parts]))  # each at its own scale


def test_simplified_pieces_are_in_morton_order_and_a_part_that_is_its_own_cage_keeps_its_order():
    from hybridedit.core.spatial_order import morton_order

    m = _union(_sphere([0, 0, 0], 1.0, sub=4), _sphere([3, 0, 0], 0.05, sub=1))
    parts = cage_parts(m, 0.05)
    assert parts.kinds == ("simplified", "own")
    o = parts.offsets
    big = parts.cage.vertices[o[0]:o[1]]
    assert np.array_equal(morton_order(big), np.arange(len(big)))
    small = parts.cage.vertices[o[1]:o[2]]
    assert np.array_equal(small, m.vertices[m.vertices[:, 0] > 2])  # the part's own vertices, as given
    faces = parts.cage.faces[parts.cage.faces.max(1) < o[1]]  # the reordered piece is still the sphere's cage
    t = trimesh.Trimesh(big, faces, process=False)
    assert t.is_watertight and t.is_winding_consistent and abs(t.volume - 4 / 3 * np.pi) < 0.15
