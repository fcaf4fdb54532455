"""Extra ARAP edges between the pieces of a cage: :func:`cage_links`.

A piece inside or against a bigger one is tied to its host (found by winding numbers and
exact point-triangle distances), and a thin shell's two layers are tied together.
"""

from __future__ import annotations

import numpy as np

from ..core.mesh import Mesh
from ..core.topology import connected_parts
from .shell import shell_pairs

__all__ = ["HOST_REACH", "cage_links"]

#: a cage piece closer to a bigger one than this many of its own bounding-box
#: diagonals (or inside it) is carried along by it (see :func:`cage_links`)
HOST_REACH = 0.1


def cage_links(cage: Mesh) -> np.ndarray:
    """Extra ARAP edges that tie separate pieces of the cage together.

    * A piece that sits inside a bigger piece, or against it (closer to it than
      :data:`HOST_REACH` times its own bounding-box diagonal), is tied to it (its
      host: the smallest piece holding it, else the nearest): each of its vertices
      gets an edge to the nearest vertex of the host, so that ARAP carries it
      along with its host.
    * A thin shell (the cage of an open surface, :func:`hybridedit.cage.shell.thicken`) gets an edge
      between each top vertex and the bottom vertex below it, so that the shell
      bends as a plate rather than as two loose layers.

    A piece with neither a host nor a constraint is left to the solver to hold still.

    Parameters
    ----------
    cage : Mesh

    Returns
    -------
    (k, 2) int64 array of cage vertex pairs (column 0 < column 1), sorted and
    unique; empty when the cage is one connected surface that is not a shell.
    """
    from scipy.spatial import cKDTree

    v, f = cage.vertices, cage.faces
    count, labels = connected_parts(f, cage.n_vertices)
    links: list[np.ndarray] = []
    if count == 0:
        return np.zeros((0, 2), dtype=np.int64)
    order = np.argsort(labels, kind="stable")
    start = np.searchsorted(labels[order], np.arange(count + 1))
    f_lab = labels[f[:, 0]]
    f_order = np.argsort(f_lab, kind="stable")
    f_start = np.searchsorted(f_lab[f_order], np.arange(count + 1))
    verts = [order[start[p]:start[p + 1]] for p in range(count)]
    faces = [f[f_order[f_start[p]:f_start[p + 1]]] for p in range(count)]
    for p in range(count):
        vp = verts[p]
        if vp.size and vp[-1] - vp[0] + 1 == vp.size:  # a contiguous piece, as cage_parts lays them out
            links.append(shell_pairs(faces[p], int(vp[0]), int(vp.size)))
    if count > 1:
        lo = np.array([v[vp].min(axis=0) for vp in verts])
        hi = np.array([v[vp].max(axis=0) for vp in verts])
        diag = np.linalg.norm(hi - lo, axis=1)
        for p in range(count):
            reach = HOST_REACH * diag[p]
            bigger = (diag > diag[p]) | ((diag == diag[p]) & (np.arange(count) < p))
            near = bigger & np.all(lo <= hi[p] + reach, axis=1) & np.all(hi >= lo[p] - reach, axis=1)
            cand = np.flatnonzero(near)
            if cand.size == 0:
                continue
            pts = v[verts[p]]
            sample = pts[:: max(1, len(pts) // 32)]
            probe = np.vstack([pts.mean(axis=0)[None], sample[:: max(1, len(sample) // 8)]])
            host, best = -1, np.inf
            for h in cand[np.argsort(diag[cand])]:
                if _winding(probe, v, faces[h]).mean() > 0.5:  # inside it
                    host = int(h)
                    break
                d = _distance_to_surface(sample, v, faces[h])
                if d < best and d <= reach:
                    host, best = int(h), d
            if host >= 0:
                near_v = verts[host][cKDTree(v[verts[host]]).query(pts)[1]]
                links.append(np.stack([verts[p], near_v], axis=1))
    if not links:
        return np.zeros((0, 2), dtype=np.int64)
    e = np.sort(np.vstack(links).astype(np.int64), axis=1)
    e = e[e[:, 0] != e[:, 1]]
    return np.unique(e, axis=0)


def _winding(points: np.ndarray, v: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Generalised winding number of each point w.r.t. a closed triangle surface (k,)."""
    a = v[faces[:, 0]][None] - points[:, None]
    b = v[faces[:, 1]][None] - points[:, None]
    c = v[faces[:, 2]][None] - points[:, None]
    la, lb, lc = (np.linalg.norm(x, axis=2) for x in (a, b, c))
    det = np.einsum("pfi,pfi->pf", a, np.cross(b, c))
    den = (la * lb * lc + np.einsum("pfi,pfi->pf", a, b) * lc + np.einsum("pfi,pfi->pf", b, c) * la
           + np.einsum("pfi,pfi->pf", c, a) * lb)
    return np.arctan2(det, den).sum(axis=1) / (2.0 * np.pi)


def _distance_to_surface(points: np.ndarray, v: np.ndarray, faces: np.ndarray) -> float:
    """Smallest distance from the points to the triangles (exact point-triangle distances)."""
    best = np.inf
    p0, p1, p2 = v[faces[:, 0]], v[faces[:, 1]], v[faces[:, 2]]
    for x in points:
        best = min(best, float(np.sqrt(_point_triangle_sq(x, p0, p1, p2).min())))
    return best


def _point_triangle_sq(x: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Squared distance from one point x (3,) to each triangle (a, b, c) (m, 3)."""
    ab, ac = b - a, c - a
    n = np.cross(ab, ac)
    nn = np.einsum("ij,ij->i", n, n)
    ap = x - a
    # the projection falls inside the triangle: the distance to its plane
    w = np.einsum("ij,ij->i", np.cross(ab, ap), n)
    u = np.einsum("ij,ij->i", np.cross(ap, ac), n)
    inside = (u >= 0) & (w >= 0) & (u + w <= nn) & (nn > 0)
    plane = np.einsum("ij,ij->i", ap, n) ** 2 / np.where(nn > 0, nn, 1.0)
    best = np.where(inside, plane, np.inf)
    for p, q in ((a, b), (b, c), (c, a)):  # else the nearest point on an edge
        e = q - p
        ee = np.einsum("ij,ij->i", e, e)
        t = np.clip(np.einsum("ij,ij->i", x - p, e) / np.where(ee > 0, ee, 1.0), 0.0, 1.0)
        d = x - (p + t[:, None] * e)
        best = np.minimum(best, np.einsum("ij,ij->i", d, d))
    return best
