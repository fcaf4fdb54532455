"""Summary statistics of a mesh, for checking input files (the CLI ``info`` command)."""

from __future__ import annotations

from typing import Any

import numpy as np

from .linsolve import backend_description
from .mesh import Mesh
from .topology import connected_parts, degenerate_faces, edge_face_counts

__all__ = ["edge_face_counts", "format_report", "mesh_report"]


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
            Faces with a repeated index or zero area
            (:func:`hybridedit.core.topology.degenerate_faces`).
        bbox_min, bbox_max : list of 3 float
        bbox_diagonal : float
        closed : bool
            Has faces, no boundary edges and no non-manifold edges.
        solver : str
            The sparse solver backend the engine would use here
            (:func:`hybridedit.core.linsolve.backend_description`).
    """
    v, f = mesh.vertices, mesh.faces
    n, m = mesh.n_vertices, mesh.n_faces
    _, uses = edge_face_counts(f, n)
    boundary = int(np.count_nonzero(uses == 1))
    nonmanifold = int(np.count_nonzero(uses > 2))

    referenced = np.zeros(n, dtype=bool)
    referenced[f.ravel()] = True
    components, _ = connected_parts(f, n)

    lo, hi = mesh.bbox()
    return {
        "name": mesh.name,
        "vertices": n,
        "faces": m,
        "components": components,
        "boundary_edges": boundary,
        "nonmanifold_edges": nonmanifold,
        "unreferenced_vertices": int(n - np.count_nonzero(referenced)),
        "degenerate_faces": int(np.count_nonzero(degenerate_faces(v, f))),
        "bbox_min": [float(x) for x in lo],
        "bbox_max": [float(x) for x in hi],
        "bbox_diagonal": mesh.bbox_diagonal(),
        "closed": bool(m > 0 and boundary == 0 and nonmanifold == 0),
        "solver": backend_description(),
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
    if report.get("solver"):  # the machine's, not the mesh's: before the verdict, which stays last
        rows.insert(-1, ("solver", str(report["solver"])))
        keys.insert(-1, None)
    width = max(len(label) for label, _ in rows)
    title = report.get("name") or "mesh"
    lines = [title]
    for (label, value), key in zip(rows, keys):
        line = f"  {label:<{width}}  {value}"
        if key is not None and report[key]:
            line += f"  ({notes[key]})"
        lines.append(line)
    return "\n".join(lines)
