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
