"""The surface a selection gesture is drawn over: what it sees of one part, grown along the surface
through that part's thickness, never joined across air to another part that only overlaps on screen.

A rectangle or brush stroke over a front leg from the front sees the front of the leg, and maybe a
sliver of the hind leg peeking out beside it; the back of the leg lies in the gesture too, hidden
by the leg itself. What is taken (as ZBrush's topological masking and Maya's surface soft selection
do, on the cage):

1. the *pieces* of the seen surface: seen cage points joined by cage edges (through hidden points
   one edge from a seen one: the rim of a part, where visibility is noisy). Two parts that only
   overlap on screen are joined on the surface only through what the gesture does not see, so
   they are separate pieces;
2. the main pieces: the piece with the most seen points, and any other seen nearly as much
   (:data:`KEEP_SHARE`: two fingertips drawn over together) that does not lie behind it (the far
   front leg of a cow seen broadside, beside the near one), not a sliver of another part;
3. each main piece grown along the surface (geodesic distance on the cage graph) through the
   hidden points of the gesture within :data:`GROW` times the part's thickness at each seen point
   (:func:`thickness`, the shape's own, whatever the gesture's size) and a cage edge: the back of
   a limb is about a quarter of its circumference from its seen rim; the hind leg behind a front
   leg is a body's length away.

Pure numpy and scipy, no Qt or VTK.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components, dijkstra

from ...core.index_sets import unique_sorted
from ...deform.skeleton import edge_graph

__all__ = ["surface_under", "thickness", "KEEP_SHARE", "GROW"]

KEEP_SHARE = 0.5
"""A seen piece other than the largest is taken when it has at least this share of the largest's seen
points: two limbs drawn over together are, a sliver of another part seen beside a limb is not."""
GROW = 1.2
"""Hidden points are taken up to this many times the part's thickness along the surface from a seen
point. The back of a round limb of thickness D is pi D / 4 = 0.79 D from its seen rim, and a path
along cage edges zigzags; 1.2 D still stops a body's length short of another limb."""
NEIGHBOURS = 48
""":func:`thickness` looks for the far side of the part among this many nearest cage points (a limb's
cross-section on a cage has 8 to 16)."""


def thickness(points: np.ndarray, normals: np.ndarray, *, neighbours: int = NEIGHBOURS) -> np.ndarray:
    """How thick the part is at each cage point: the distance to the nearest point of its far side (a
    cage point facing away from it by more than 120 degrees, within 37 degrees of straight through
    the part).

    Parameters
    ----------
    points : (c, 3) float64
        The cage.
    normals : (c, 3) float64
        Its outward unit vertex normals.
    neighbours : int
        How many nearest points are looked through (:data:`NEIGHBOURS`).

    Returns
    -------
    (c,) float64
        Where no far side is among them (a thick body, an open sheet's edge), twice the distance
        to the farthest of them: at least that thick.

    Examples
    --------
    A tube of radius 1 is about 2 thick everywhere:

    >>> t = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    >>> tube = np.array([[np.cos(a), np.sin(a), z] for z in range(7) for a in t])
    >>> normals = tube * [1, 1, 0]
    >>> bool(np.all((thickness(tube, normals) > 1.7) & (thickness(tube, normals) <= 2.0)))
    True
    """
    from scipy.spatial import cKDTree

    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    n = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    if len(p) < 2:
        return np.zeros(len(p))
    k = min(int(neighbours) + 1, len(p))
    dist, idx = cKDTree(p).query(p, k=k)
    towards = p[idx] - p[:, None, :]  # (c, k, 3) from each point to its neighbours
    through = -np.einsum("ckd,cd->ck", towards, n)  # how far each lies straight through the part
    far_side = (np.einsum("ckd,cd->ck", n[idx], n) < -0.5) & (through >= 0.8 * dist) & (dist > 0)
    found = np.where(far_side, dist, np.inf).min(axis=1)
    return np.where(np.isfinite(found), found, 2.0 * dist[:, -1])


def surface_under(hits: np.ndarray, seen: np.ndarray, graph: sp.csr_matrix, thick: np.ndarray, *,
                  depth: np.ndarray | None = None, keep_share: float = KEEP_SHARE, grow: float = GROW) -> np.ndarray:
    """The cage points a gesture takes: the main pieces of the surface it sees, grown through their
    thickness (see the module's notes).

    Parameters
    ----------
    hits : (c,) bool
        The cage points in the gesture on screen (in front of the camera), seen or not.
    seen : (c,) bool
        Those in sight (only those among ``hits`` count).
    graph : (c, c) sparse
        The cage's edge graph, weighted by length (:func:`hybridedit.deform.skeleton.edge_graph`).
    thick : (c,) float64
        How thick the part is at each cage point (:func:`thickness`).
    depth : (c,) float64, optional
        How far each cage point lies along the line of sight (world units): a piece lying behind the
        largest by more than its thickness is another part, however much of it is seen. None: no
        piece is behind another.
    keep_share, grow : float
        :data:`KEEP_SHARE` and :data:`GROW`.

    Returns
    -------
    (c,) bool
        A subset of ``hits``: the seen points of the main pieces and the hidden points within ``grow``
        times a seen point's thickness (and a median cage edge) of it along the surface. Empty when
        nothing in the gesture is seen.

    Examples
    --------
    A tube of radius 1 seen from +y (its front half seen), and a second tube behind it on screen,
    joined to the first only at its far end:

    >>> t = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    >>> tube = np.array([[np.cos(a), np.sin(a), z] for z in range(7) for a in t])
    >>> ring = lambda z, k: 16 * z + k % 16
    >>> e = [[ring(z, k), ring(z, k + 1)] for z in range(7) for k in range(16)]
    >>> e += [[ring(z, k), ring(z + 1, k)] for z in range(6) for k in range(16)]
    >>> pts = np.vstack([tube, tube - [0, 6, 0]])
    >>> e = np.array(e + [[a + 112, b + 112] for a, b in e] + [[ring(6, 12), 112 + ring(6, 4)]])
    >>> seen = np.r_[tube[:, 1] >= 0, np.zeros(112, bool)]
    >>> took = surface_under(np.ones(224, bool), seen, edge_graph(pts, e), np.full(224, 2.0))
    >>> bool(took[:112].all()), bool(took[112:].any())  # the first tube whole, nothing of the second
    (True, False)
    """
    h = np.asarray(hits, dtype=bool)
    s = h & np.asarray(seen, dtype=bool)
    out = np.zeros_like(h)
    if not s.any():
        return out
    g = sp.csr_matrix(graph)
    # 1. the pieces: seen points and the hidden hits one edge from them, joined by edges among those
    near = s | (h & ((g @ s.astype(np.float64)) > 0))
    joined = sp.diags(near.astype(np.float64)) @ (g > 0).astype(np.float64) @ sp.diags(near.astype(np.float64))
    _, labels = connected_components(joined, directed=False)
    counts = np.bincount(labels[s], minlength=labels.max() + 1)
    # 2. the main pieces
    main = np.flatnonzero(counts >= max(keep_share * counts.max(), 1))
    if depth is not None and len(main) > 1:
        z = np.asarray(depth, dtype=np.float64)
        first = int(np.argmax(counts))
        ours = s & (labels == first)
        behind = float(np.median(z[ours])) + float(np.median(np.asarray(thick, dtype=np.float64)[ours]))
        main = np.array([k for k in main if k == first or np.median(z[s & (labels == k)]) <= behind], dtype=np.int64)
    seeds = s & np.isin(labels, main)
    out[seeds] = True
    # 3. grown along the surface through the hidden points of the gesture, each seen point as far as
    # its own thickness allows (seen points in bands of thickness within 25 % of each other, one search each)
    # (plus a median cage edge: a path along a coarse cage's edges runs up to an edge longer than the
    # surface's geodesic, and a cage edge on a thin part can be longer than the part is thick)
    reach = grow * np.asarray(thick, dtype=np.float64) + (float(np.median(g.data)) if g.nnz else 0.0)
    idx = np.flatnonzero(seeds & (reach > 0))
    if idx.size == 0:
        return out
    band = np.floor(np.log(reach[idx] / reach[idx].min()) / np.log(1.25)).astype(np.int64)
    for b in unique_sorted(band):
        these = idx[band == b]
        limit = float(reach[these].max())
        d = dijkstra(g, directed=False, indices=these, min_only=True, limit=limit)
        out |= h & (d <= limit)
    return out
