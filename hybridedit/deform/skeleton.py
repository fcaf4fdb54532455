"""A shape's limb skeleton, found on its cage: its centre, its extremities and its joints.

The centre is the cage vertex nearest the shape's centre of mass; the extremities are geodesic
farthest points from it (farthest-point sampling over the cage's edge graph, the links between
cage parts included), and the geodesic distances from each extremity to every cage vertex say
how far along its limb a vertex lies. A limb's joint is where a region around an extremity
meets the rest of the shape (:func:`joint_centre`). ``hybridedit batch`` draws its random poses
on it (:mod:`hybridedit.batching.poses`); it is the engine's, below the batch, for any caller that
poses a shape by its limbs.

Examples
--------
Three limbs from a centre vertex (0), two of length 2 and one of length 1:

>>> v = np.array([[0.0, 0, 0], [2, 0, 0], [0, 2, 0], [-1, 0, 0]])
>>> s = find_skeleton(v, np.array([[0, 1], [0, 2], [0, 3]]), centre_point=np.zeros(3))
>>> s.centre, s.extremities.tolist(), s.reach.tolist()
(0, [1, 2, 3], [2.0, 2.0, 1.0])
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import dijkstra

from ..core.index_sets import unique_in_range, unique_sorted

__all__ = ["Skeleton", "edge_graph", "find_skeleton", "joint_centre", "MAX_EXTREMITIES", "MIN_SPREAD"]

#: most extremities a shape's skeleton keeps
MAX_EXTREMITIES = 8
#: an extremity is kept while it lies at least this fraction of the largest centre distance from the
#: centre and every extremity found before it (a ball has a few, a creature one per limb)
MIN_SPREAD = 0.3


@dataclass(frozen=True)
class Skeleton:
    """Where a shape can be posed from, on its cage (c cage vertices, k extremities).

    Attributes
    ----------
    centre : int
        The cage vertex nearest the shape's centre of mass.
    extremities : (k,) int64
        Cage vertices at the shape's extremities, farthest first.
    reach : (k,) float64
        Each extremity's geodesic distance to the centre.
    distances : (k, c) float64
        Geodesic distance from each extremity to every cage vertex (inf: another part).
    """

    centre: int
    extremities: np.ndarray
    reach: np.ndarray
    distances: np.ndarray


def edge_graph(points: np.ndarray, edges: np.ndarray) -> sp.csr_matrix:
    """The symmetric (c, c) graph of a cage's ``edges`` weighted by their lengths at ``points``
    (the skeleton's geodesic distances, the window's selection growing along the surface).

    Parameters
    ----------
    points : (c, 3) float64
        The cage, as posed now.
    edges : (e, 2) int
        Its edges (in either direction, repeats allowed: each edge counts once).

    Returns
    -------
    (c, c) scipy.sparse.csr_matrix
        Both directions of every edge; a zero-length edge weighs a tiny positive length (a stored zero
        would mean no edge).

    Examples
    --------
    >>> g = edge_graph(np.array([[0.0, 0, 0], [3, 4, 0]]), np.array([[0, 1]]))
    >>> g[0, 1], g[1, 0]
    (np.float64(5.0), np.float64(5.0))
    """
    p = np.asarray(points, dtype=np.float64)
    n = len(p)
    e = np.sort(np.asarray(edges, dtype=np.int64).reshape(-1, 2), axis=1)
    key = unique_sorted(e[:, 0] * n + e[:, 1])  # each edge once (a repeat would be summed into a longer one)
    e = np.stack([key // max(n, 1), key % max(n, 1)], axis=1)
    if len(e) == 0:
        return sp.csr_matrix((n, n))
    length = np.linalg.norm(p[e[:, 0]] - p[e[:, 1]], axis=1)
    length = np.maximum(length, 1e-12 * max(float(length.max()), 1e-300))
    g = sp.coo_matrix((length, (e[:, 0], e[:, 1])), shape=(n, n)).tocsr()
    return (g + g.T).tocsr()


def find_skeleton(cage_vertices: np.ndarray, cage_edges: np.ndarray, centre_point: np.ndarray, *,
                  max_extremities: int = MAX_EXTREMITIES) -> Skeleton:
    """The centre and extremities of a shape, on its cage.

    Parameters
    ----------
    cage_vertices : (c, 3) float64
        The cage at rest.
    cage_edges : (e, 2) int64
        The cage's edges (the links between its parts included).
    centre_point : (3,) float64
        The shape's centre of mass.
    max_extremities : int
        Most extremities kept (the farthest first, so a larger count only adds to a smaller one's).

    Returns
    -------
    Skeleton
        With no extremity when the cage has a single vertex reachable from the centre.
    """
    v = np.asarray(cage_vertices, dtype=np.float64)
    graph = edge_graph(v, cage_edges)
    centre = int(np.argmin(np.linalg.norm(v - np.asarray(centre_point, dtype=np.float64), axis=1)))
    from_centre = dijkstra(graph, indices=centre)
    reachable = np.isfinite(from_centre)
    largest = float(from_centre[reachable].max()) if reachable.any() else 0.0
    nearest = np.where(reachable, from_centre, -np.inf)  # distance to the centre and the extremities so far
    found: list[int] = []
    rows: list[np.ndarray] = []
    while len(found) < int(max_extremities) and largest > 0:
        i = int(np.argmax(nearest))
        if not nearest[i] >= MIN_SPREAD * largest:
            break
        d = dijkstra(graph, indices=i)
        found.append(i)
        rows.append(d)
        nearest = np.where(reachable, np.minimum(nearest, d), -np.inf)
    ext = np.asarray(found, dtype=np.int64)
    distances = np.vstack(rows) if rows else np.zeros((0, len(v)))
    return Skeleton(centre, ext, from_centre[ext].astype(np.float64), distances)


def joint_centre(region: np.ndarray, edges: np.ndarray, vertices: np.ndarray) -> np.ndarray | None:
    """Where a limb's region meets the rest of the shape: the mean position of the region's vertices
    with an edge out of it.

    Parameters
    ----------
    region : (n,) bool
        The shape vertices of the region (e.g. those within a geodesic radius of an extremity).
    edges : (e, 2) int64
        The shape's edges.
    vertices : (n, 3) float64
        The shape at rest.

    Returns
    -------
    (3,) float64, or None
        None when the region has no border (it is a whole part of the shape).
    """
    a, b = region[edges[:, 0]], region[edges[:, 1]]
    border = unique_in_range(np.concatenate([edges[a & ~b, 0], edges[b & ~a, 1]]), len(region))
    return vertices[border].mean(axis=0) if border.size else None
