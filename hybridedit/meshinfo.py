"""Summary statistics of a mesh, for checking input files (the CLI ``info`` command)."""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from .mesh import Mesh

__all__ = ["edge_face_counts", "format_report", "mesh_report"]


def edge_face_counts(faces: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """How many faces use each undirected edge.

    A face with a repeated index, such as (a, a, b), uses its edge a-b once;
    self-loop "edges" a-a are not counted.

    Parameters
    ----------
    faces : (m, 3) int array
    n_vertices : int
        Number of vertices; all indices must be below it.

    Returns
    -------
    edges : (e, 2) int64 array
        Unique undirected edges, rows sorted with column 0 < column 1.
    counts : (e,) int64 array
        Number of faces using each edge.
    """
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    a = f.ravel()
    b = f[:, [1, 2, 0]].ravel()
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    keep = lo != hi
    # a face with exactly two distinct indices yields the same edge twice
    equal_pairs = ((f[:, 0] == f[:, 1]).astype(np.int64) + (f[:, 1] == f[:, 2])
                   + (f[:, 2] == f[:, 0]))
    twice = np.repeat(equal_pairs == 1, 3) & keep
    if twice.any():
        rows = np.flatnonzero(twice).reshape(-1, 2)
        keep[rows[:, 1]] = False
    n = max(int(n_vertices), 1)
    keys, counts = np.unique(lo[keep] * n + hi[keep], return_counts=True)
    edges = np.stack([keys // n, keys % n], axis=1)
    return edges, counts.astype(np.int64)


def _degenerate(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(m,) bool: face repeats an index or has (numerically) zero area."""
    f0, f1, f2 = faces[:, 0], faces[:, 1], faces[:, 2]
    repeated = (f0 == f1) | (f1 == f2) | (f2 == f0)
    p0, p1, p2 = vertices[f0], vertices[f1], vertices[f2]
    twice_area = np.linalg.norm(np.cross(p1 - p0, p2 - p0), axis=1)
    longest_sq = np.max(
        [np.einsum("ij,ij->i", d, d) for d in (p1 - p0, p2 - p1, p0 - p2)], axis=0
    ) if len(faces) else np.zeros(0)
    # zero up to rounding: height below a few ulps of the longest edge
    flat = twice_area <= 4 * np.finfo(np.float64).eps * longest_sq
    return repeated | flat


def mesh_report(mesh: Mesh) -> dict[str, Any]:
    """Counts and checks that tell whether a mesh is fit for editing.

    Parameters
    ----------
    mesh : Mesh
        ``vertices`` (n, 3) float64, ``faces`` (m, 3) int64.

    Returns
    -------
    dict
        Plain Python values (JSON-serialisable):

        name : str
        vertices, faces : int
        components : int
            Connected components of the faces (faces sharing a vertex are
            connected); unreferenced vertices do not form components.
        boundary_edges : int
            Edges used by exactly one face.
        nonmanifold_edges : int
            Edges used by more than two faces.
        unreferenced_vertices : int
            Vertices used by no face.
        degenerate_faces : int
            Faces with a repeated index or zero area.
        bbox_min, bbox_max : list of 3 float
        bbox_diagonal : float
        closed : bool
            Has faces, no boundary edges and no non-manifold edges.
    """
    v, f = mesh.vertices, mesh.faces
    n, m = mesh.n_vertices, mesh.n_faces
    _, uses = edge_face_counts(f, n)
    boundary = int(np.count_nonzero(uses == 1))
    nonmanifold = int(np.count_nonzero(uses > 2))

    referenced = np.zeros(n, dtype=bool)
    referenced[f.ravel()] = True
    if m:
        rows = f.ravel()
        cols = f[:, [1, 2, 0]].ravel()
        graph = coo_matrix((np.ones(len(rows), dtype=np.int8), (rows, cols)), shape=(n, n))
        _, labels = connected_components(graph, directed=False)
        components = int(len(np.unique(labels[referenced])))
    else:
        components = 0

    lo, hi = mesh.bbox()
    return {
        "name": mesh.name,
        "vertices": n,
        "faces": m,
        "components": components,
        "boundary_edges": boundary,
        "nonmanifold_edges": nonmanifold,
        "unreferenced_vertices": int(n - np.count_nonzero(referenced)),
        "degenerate_faces": int(np.count_nonzero(_degenerate(v, f))),
        "bbox_min": [float(x) for x in lo],
        "bbox_max": [float(x) for x in hi],
        "bbox_diagonal": mesh.bbox_diagonal(),
        "closed": bool(m > 0 and boundary == 0 and nonmanifold == 0),
    }


def format_report(report: dict[str, Any]) -> str:
    """Human-readable multi-line text of a :func:`mesh_report` result.

    Lines that point at problems (boundary, non-manifold edges, unreferenced
    vertices, degenerate faces) get a short explanation when non-zero.
    """

    def vec(values: list[float]) -> str:
        return "(" + ", ".join(f"{x:.6g}" for x in values) + ")"

    notes = {
        "boundary_edges": "open mesh: it has holes or borders",
        "nonmanifold_edges": "edges shared by more than two faces",
        "unreferenced_vertices": "vertices that no face uses",
        "degenerate_faces": "faces with a repeated vertex or zero area",
    }
    rows = [
        ("vertices", f"{report['vertices']:,}"),
        ("faces", f"{report['faces']:,}"),
        ("components", f"{report['components']:,}"),
        ("boundary edges", f"{report['boundary_edges']:,}"),
        ("non-manifold edges", f"{report['nonmanifold_edges']:,}"),
        ("unreferenced vertices", f"{report['unreferenced_vertices']:,}"),
        ("degenerate faces", f"{report['degenerate_faces']:,}"),
        ("bounding box", f"{vec(report['bbox_min'])} to {vec(report['bbox_max'])}"),
        ("bbox diagonal", f"{report['bbox_diagonal']:.6g}"),
        ("closed", "yes" if report["closed"] else "no"),
    ]
    keys = [None, None, None, "boundary_edges", "nonmanifold_edges",
            "unreferenced_vertices", "degenerate_faces", None, None, None]
    width = max(len(label) for label, _ in rows)
    title = report.get("name") or "mesh"
    lines = [title]
    for (label, value), key in zip(rows, keys):
        line = f"  {label:<{width}}  {value}"
        if key is not None and report[key]:
            line += f"  ({notes[key]})"
        lines.append(line)
    return "\n".join(lines)
