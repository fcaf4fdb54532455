"""The cage source's repairs (hybridedit.core.repair): a closed surface stays closed."""

from __future__ import annotations

import numpy as np
import trimesh

from hybridedit.core.mesh import Mesh
from hybridedit.core.repair import repaired_source
from hybridedit.core.topology import is_closed_oriented


def welded(*parts) -> Mesh:
    t = trimesh.util.concatenate(list(parts))
    t.merge_vertices()
    return Mesh(np.asarray(t.vertices, dtype=np.float64), np.asarray(t.faces))


def test_two_solids_touching_along_an_edge_stay_two_closed_solids():
    """Two boxes sharing an edge (four faces on it): their sheets are separated, no face is dropped, and
    the cage source is two closed parts, as the two solids are."""
    a = trimesh.creation.box(bounds=[[0, 0, 0], [1, 1, 1]])
    b = trimesh.creation.box(bounds=[[1, 1, 0], [2, 2, 1]])
    mesh = welded(a, b)
    src = repaired_source(mesh)
    assert src.mesh.n_faces == mesh.n_faces  # nothing dropped
    assert src.parts == 2 and is_closed_oriented(src.mesh.faces, src.mesh.n_vertices)
    assert any("separated the sheets meeting at 1 non-manifold edge" in n for n in src.notes)
    # every input vertex still maps to a vertex at its place
    assert np.allclose(src.mesh.vertices[src.vertex_map], mesh.vertices)


def test_three_solids_around_one_edge_and_a_fin():
    """Three wedges around one edge (six faces on it) come apart into three closed solids; a fin (a lone
    triangle on a sphere's edge) is dropped and the sphere stays closed."""
    wedges = []
    for k in range(3):
        angle = 2 * np.pi * k / 3
        c, s = np.cos(angle), np.sin(angle)
        c2, s2 = np.cos(angle + 1.5), np.sin(angle + 1.5)
        pts = np.array([[0, 0, 0], [c, s, 0], [c2, s2, 0], [0, 0, 1], [c, s, 1], [c2, s2, 1]], dtype=float)
        wedges.append(trimesh.convex.convex_hull(pts))
    src = repaired_source(welded(*wedges))
    assert src.parts == 3 and is_closed_oriented(src.mesh.faces, src.mesh.n_vertices)
    ball = trimesh.creation.icosphere(2)
    v, f = np.asarray(ball.vertices), np.asarray(ball.faces)
    fin = np.array([[f[0, 1], f[0, 0], len(v)]])
    tip = 1.5 * v[f[0, :2]].mean(axis=0)
    src = repaired_source(Mesh(np.vstack([v, tip]), np.vstack([f, fin])))
    assert src.mesh.n_faces == len(f) and src.parts == 1
    assert is_closed_oriented(src.mesh.faces, src.mesh.n_vertices)
    assert any("dropped 1 face standing alone" in n for n in src.notes)


def _holed_sphere(subdivisions: int = 3, holes=(0, 40, 200), offset=(0.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    s = trimesh.creation.icosphere(subdivisions=subdivisions)
    f = np.asarray(s.faces)
    drop = np.zeros(len(f), dtype=bool)
    for h in holes:  # the faces around vertex h
        drop |= (f == h).any(axis=1)
    return np.asarray(s.vertices) + offset, f[~drop]


def _same_source(a, b) -> None:
    assert np.array_equal(a.mesh.vertices, b.mesh.vertices) and np.array_equal(a.mesh.faces, b.mesh.faces)
    assert np.array_equal(a.vertex_map, b.vertex_map) and np.array_equal(a.part_labels, b.part_labels)
    assert (a.parts, a.notes, a.closed) == (b.parts, b.notes, b.closed)


def test_an_intact_open_surface_comes_out_as_the_whole_repair_pass_leaves_it():
    """An open scan's quick path (no weld, no orientation search) gives what the full pass gives:
    one holed part, two parts (one turned inside out) and an unused vertex."""
    from hybridedit.core.repair import _repaired_in_full

    v1, f1 = _holed_sphere()
    v2, f2 = _holed_sphere(2, holes=(5,), offset=(3.0, 0.0, 0.0))
    cases = [Mesh(v1, f1, name="holed"),
             Mesh(np.vstack([v1, v2]), np.vstack([f1, f2[:, ::-1] + len(v1)]), name="two parts, one inward"),
             Mesh(np.vstack([v1, [[9.0, 9.0, 9.0]]]), f1, name="an unused vertex")]
    for mesh in cases:
        quick = repaired_source(mesh)
        used = np.zeros(mesh.n_vertices, dtype=bool)
        used[mesh.faces.ravel()] = True
        notes = [n for n in quick.notes if n.startswith("ignored")]
        _same_source(quick, _repaired_in_full(mesh, notes, used))
        assert not quick.closed
    assert any(n.startswith("re-oriented") for n in repaired_source(cases[1]).notes)


def test_a_seam_split_into_two_rims_is_still_welded():
    """A closed sphere whose vertices along a seam are doubled (two rims on the same points, as a
    UV-split export gives) is welded back into a closed surface."""
    s = trimesh.creation.icosphere(subdivisions=3)
    v, f = np.asarray(s.vertices), np.asarray(s.faces).copy()
    side = v[f].mean(axis=1)[:, 0] > 0  # the faces of one half take copies of the seam's vertices
    seam = np.intersect1d(f[side].ravel(), f[~side].ravel())
    copy = np.full(len(v), -1)
    copy[seam] = len(v) + np.arange(seam.size)
    g = f[side]
    g[np.isin(g, seam)] = copy[g[np.isin(g, seam)]]
    f[side] = g
    src = repaired_source(Mesh(np.vstack([v, v[seam]]), f, name="seam"))
    assert any(n.startswith("merged") for n in src.notes)
    assert is_closed_oriented(src.mesh.faces, src.mesh.n_vertices)


def test_the_rim_is_the_holes_border_and_a_bad_surface_has_none():
    from hybridedit.core.topology import oriented_rim

    v, f = _holed_sphere(holes=(0,))
    rim = oriented_rim(f, len(v))
    full = np.asarray(trimesh.creation.icosphere(subdivisions=3).faces)
    around = np.unique(full[(full == 0).any(axis=1)])
    assert set(np.flatnonzero(rim)) == set(around) - {0}
    closed = np.asarray(trimesh.creation.icosphere(subdivisions=2).faces)
    assert not oriented_rim(closed, closed.max() + 1).any()
    flipped = closed.copy()
    flipped[0] = flipped[0, ::-1]
    assert oriented_rim(flipped, closed.max() + 1) is None
    fin = np.vstack([closed, [[closed[0, 0], closed[0, 1], closed.max() + 1]]])
    assert oriented_rim(fin, closed.max() + 2) is None
