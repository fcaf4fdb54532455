"""Tests for hybridedit.core.meshinfo."""

from __future__ import annotations

import json

import numpy as np
import pytest

from hybridedit.core.mesh import Mesh
from hybridedit.core.meshinfo import edge_face_counts, format_report, mesh_report


def octasphere(levels: int = 2) -> Mesh:
    """A closed, outward-oriented sphere: an octahedron subdivided ``levels`` times."""
    verts = [np.array(p, dtype=float) for p in
             [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]]
    faces = [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4),
             (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)]
    for _ in range(levels):
        cache: dict[tuple[int, int], int] = {}

        def mid(a: int, b: int) -> int:
            key = (min(a, b), max(a, b))
            if key not in cache:
                p = verts[a] + verts[b]
                verts.append(p / np.linalg.norm(p))
                cache[key] = len(verts) - 1
            return cache[key]

        faces = [t for a, b, c in faces
                 for t in ((a, mid(a, b), mid(c, a)), (b, mid(b, c), mid(a, b)),
                           (c, mid(c, a), mid(b, c)), (mid(a, b), mid(b, c), mid(c, a)))]
    return Mesh(np.array(verts), np.array(faces), name="sphere")


def grid(n: int) -> Mesh:
    """An open n x n square grid of 2 n^2 triangles in the z = 0 plane."""
    ij = np.array([(i, j) for j in range(n + 1) for i in range(n + 1)], dtype=float)
    v = np.column_stack([ij, np.zeros(len(ij))])
    faces = []
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i
            b, c, d = a + 1, a + n + 1, a + n + 2
            faces += [(a, b, d), (a, d, c)]
    return Mesh(v, np.array(faces), name="grid")


def test_closed_sphere() -> None:
    mesh = octasphere(2)
    r = mesh_report(mesh)
    assert r["vertices"] == 66 and r["faces"] == 128
    assert r["components"] == 1
    assert r["boundary_edges"] == 0 and r["nonmanifold_edges"] == 0
    assert r["unreferenced_vertices"] == 0 and r["degenerate_faces"] == 0
    assert r["closed"] is True
    assert r["bbox_min"] == [-1.0, -1.0, -1.0] and r["bbox_max"] == [1.0, 1.0, 1.0]
    assert r["bbox_diagonal"] == pytest.approx(2 * 3 ** 0.5)
    assert r["name"] == "sphere"
    json.dumps(r)  # plain Python values only


def test_open_grid_boundary() -> None:
    r = mesh_report(grid(5))
    assert r["boundary_edges"] == 4 * 5
    assert r["closed"] is False and r["components"] == 1 and r["nonmanifold_edges"] == 0


def test_sphere_with_a_hole() -> None:
    mesh = octasphere(1)
    r = mesh_report(Mesh(mesh.vertices, mesh.faces[1:]))
    assert r["boundary_edges"] == 3 and r["closed"] is False and r["unreferenced_vertices"] == 0


def test_two_components_and_unreferenced_vertex() -> None:
    a, b = octasphere(1), grid(2)
    v = np.vstack([a.vertices, b.vertices + 5, [[9.0, 9.0, 9.0]]])
    f = np.vstack([a.faces, b.faces + a.n_vertices])
    r = mesh_report(Mesh(v, f))
    assert r["components"] == 2  # the lone vertex is not a component
    assert r["unreferenced_vertices"] == 1
    assert r["boundary_edges"] == 8
    assert r["bbox_max"] == [9.0, 9.0, 9.0]


def test_faces_touching_at_a_vertex_are_one_component() -> None:
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0.0]])
    r = mesh_report(Mesh(v, np.array([[0, 1, 2], [0, 3, 4]])))
    assert r["components"] == 1 and r["boundary_edges"] == 6


def test_nonmanifold_edge() -> None:
    # three triangles sharing the edge 0-1
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1.0]])
    mesh = Mesh(v, np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]]))
    r = mesh_report(mesh)
    assert r["nonmanifold_edges"] == 1
    assert r["boundary_edges"] == 6
    assert r["closed"] is False
    edges, counts = edge_face_counts(mesh.faces, mesh.n_vertices)
    assert dict(zip(map(tuple, edges.tolist()), counts.tolist()))[(0, 1)] == 3


def test_degenerate_faces() -> None:
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0], [1e-9, 1e-9, 0]])
    faces = np.array([
        [0, 1, 2],  # fine
        [0, 1, 1],  # repeated index
        [0, 1, 3],  # collinear: zero area
        [0, 4, 2],  # tiny but not zero area
    ])
    r = mesh_report(Mesh(v, faces))
    assert r["degenerate_faces"] == 2


def test_repeated_index_face_uses_its_edge_once() -> None:
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]])
    edges, counts = edge_face_counts(np.array([[0, 1, 2], [0, 0, 1]]), 3)
    assert edges.tolist() == [[0, 1], [0, 2], [1, 2]]
    assert counts.tolist() == [2, 1, 1]
    assert mesh_report(Mesh(v, np.array([[0, 0, 0]])))["boundary_edges"] == 0


def test_empty_mesh() -> None:
    r = mesh_report(Mesh(np.zeros((2, 3)), np.zeros((0, 3), dtype=np.int64)))
    assert r["faces"] == 0 and r["components"] == 0 and r["unreferenced_vertices"] == 2
    assert r["closed"] is False


def test_format_report() -> None:
    text = format_report(mesh_report(grid(3)))
    lines = text.splitlines()
    assert lines[0] == "grid"
    assert any(line.split() == ["vertices", "16"] for line in lines)
    assert any(line.split()[:3] == ["boundary", "edges", "12"] and "open mesh" in line
               for line in lines)
    assert lines[-1].split() == ["closed", "no"]
    closed = format_report(mesh_report(octasphere(3)))
    assert "258" in closed and closed.splitlines()[-1].split() == ["closed", "yes"]
    assert "(-1, -1, -1) to (1, 1, 1)" in closed
