"""Plausible random poses: limbs found at the shape's extremities, each swung about its joint.

A shape's :class:`Skeleton` is found once, on its cage: the cage vertex nearest the shape's centre
of mass, the extremities as geodesic farthest points from it (farthest-point sampling over the cage's
edge graph, the links between cage parts included), and the geodesic distances from each extremity.
A pose (:func:`draw_pose`) picks 1 to ``handles`` extremities; each one's region of interest is a
geodesic neighbourhood of it (a random fraction of its distance to the centre), its handle the inner
quarter of that neighbourhood, and its joint where the region meets the fixed part of the shape. The
handle turns about the joint's centre, about a random axis, by a random angle within
``max_degrees``: ARAP bends the region in between. The pose is an :class:`~hybridedit.Edit` (shape
vertex indices, one step with its iterations and cage), so ``hybridedit deform`` replays it.

Every random number comes from :func:`pose_rng`, derived from the seed, the input's content hash and
the pose index alone, never from a worker or the order poses run in.

Examples
--------
>>> a, b = pose_rng(7, "ab" * 32, 3), pose_rng(7, "ab" * 32, 3)
>>> float(a.random()) == float(b.random()) != float(pose_rng(7, "ab" * 32, 4).random())
True
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import dijkstra

from ..core.index_sets import unique_in_range, unique_sorted

__all__ = ["Skeleton", "find_skeleton", "draw_pose", "pose_rng", "MAX_EXTREMITIES", "MIN_SPREAD",
           "ROI_FRACTION", "HANDLE_FRACTION"]

#: most extremities a shape's skeleton keeps
MAX_EXTREMITIES = 8
#: an extremity is kept while it lies at least this fraction of the largest centre distance from the
#: centre and every extremity found before it (a ball has a few, a creature one per limb)
MIN_SPREAD = 0.3
#: a region of interest's geodesic radius, as a fraction of its extremity's distance to the centre
ROI_FRACTION = (0.35, 0.6)
#: a handle's radius, as a fraction of its region's
HANDLE_FRACTION = 0.25


def pose_rng(seed: int, content_hash: str, index: int) -> np.random.Generator:
    """The random generator of pose ``index`` of the input whose content hash is ``content_hash``.

    Parameters
    ----------
    seed : int
        The batch's seed (>= 0).
    content_hash : str
        The input file's SHA-256, hex.
    index : int
        The pose index (>= 0).

    Returns
    -------
    numpy.random.Generator
        PCG64, seeded from (seed, hash, index) only.
    """
    words = [int(seed), *(int(content_hash[i:i + 8], 16) for i in range(0, len(content_hash), 8)), int(index)]
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(words)))


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


def _edge_graph(vertices: np.ndarray, edges: np.ndarray) -> sp.csr_matrix:
    """The symmetric (c, c) graph of ``edges`` weighted by their lengths."""
    n = len(vertices)
    if len(edges) == 0:
        return sp.csr_matrix((n, n))
    length = np.linalg.norm(vertices[edges[:, 0]] - vertices[edges[:, 1]], axis=1)
    length = np.maximum(length, 1e-12 * max(float(length.max()), 1e-300))  # 0 would mean "no edge"
    g = sp.coo_matrix((length, (edges[:, 0], edges[:, 1])), shape=(n, n)).tocsr()
    return (g + g.T).tocsr()


def centre_of_mass(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """The area-weighted centroid of a surface, (3,); the vertex mean if it has no area.

    Parameters
    ----------
    vertices : (n, 3) float64
    faces : (m, 3) int64
    """
    t = vertices[faces]
    area = 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1)
    total = float(area.sum())
    if not total > 0 or not np.isfinite(total):
        return vertices.mean(axis=0)
    return (t.mean(axis=1) * area[:, None]).sum(axis=0) / total


def find_skeleton(cage_vertices: np.ndarray, cage_edges: np.ndarray, centre_point: np.ndarray) -> Skeleton:
    """The centre and extremities of a shape, on its cage.

    Parameters
    ----------
    cage_vertices : (c, 3) float64
        The cage at rest.
    cage_edges : (e, 2) int64
        The cage's edges (the links between its parts included).
    centre_point : (3,) float64
        The shape's centre of mass.

    Returns
    -------
    Skeleton
        With no extremity when the cage has a single vertex reachable from the centre.
    """
    v = np.asarray(cage_vertices, dtype=np.float64)
    graph = _edge_graph(v, np.asarray(cage_edges, dtype=np.int64).reshape(-1, 2))
    centre = int(np.argmin(np.linalg.norm(v - np.asarray(centre_point, dtype=np.float64), axis=1)))
    from_centre = dijkstra(graph, indices=centre)
    reachable = np.isfinite(from_centre)
    largest = float(from_centre[reachable].max()) if reachable.any() else 0.0
    nearest = np.where(reachable, from_centre, -np.inf)  # distance to the centre and the extremities so far
    found: list[int] = []
    rows: list[np.ndarray] = []
    while len(found) < MAX_EXTREMITIES and largest > 0:
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


@dataclass(frozen=True)
class Limb:
    """One handle of a drawn pose, in shape vertex indices (h handle and r region vertices).

    Attributes
    ----------
    extremity : int
        Its cage vertex.
    handle : (h,) int64
    region : (r,) int64
        The region of interest (handle included).
    joint : (3,) float64
        The centre of the region's border with the fixed part: the rotation's centre.
    axis : (3,) float64 unit vector
    degrees : float
    """

    extremity: int
    handle: np.ndarray
    region: np.ndarray
    joint: np.ndarray
    axis: np.ndarray
    degrees: float


def _joint(region: np.ndarray, edges: np.ndarray, vertices: np.ndarray) -> np.ndarray | None:
    """The mean position of the region's vertices with an edge out of it ((n,) bool ``region``), or
    None when it has no border (it is the whole part)."""
    a, b = region[edges[:, 0]], region[edges[:, 1]]
    border = unique_in_range(np.concatenate([edges[a & ~b, 0], edges[b & ~a, 1]]), len(region))
    return vertices[border].mean(axis=0) if border.size else None


def draw_limbs(skeleton: Skeleton, rng: np.random.Generator, *, dominant: np.ndarray, vertices: np.ndarray,
               edges: np.ndarray, handles: int, max_degrees: float) -> list[Limb]:
    """Draw one pose's limbs: which extremities, how far each region reaches, each rotation.

    Parameters
    ----------
    skeleton : Skeleton
    rng : numpy.random.Generator
        The pose's (:func:`pose_rng`); every draw takes the same numbers from it.
    dominant : (n,) int64
        The cage vertex each shape vertex depends on most (its role follows that vertex's).
    vertices : (n, 3) float64
        The shape at rest.
    edges : (e, 2) int64
        The shape's edges.
    handles : int
        Most limbs moved.
    max_degrees : float
        Largest rotation angle.

    Returns
    -------
    list of Limb
        1 to ``handles`` limbs with disjoint regions (a region that would overlap an earlier one
        is left out); empty when the skeleton has no extremity.
    """
    k = len(skeleton.extremities)
    if k == 0:
        return []
    count = int(rng.integers(1, min(handles, k) + 1))
    chosen = rng.choice(k, size=count, replace=False)
    taken = np.zeros(len(vertices), dtype=bool)
    limbs: list[Limb] = []
    for j in chosen:
        radius = float(rng.uniform(*ROI_FRACTION)) * float(skeleton.reach[j])
        axis = rng.normal(size=3)
        degrees = float(rng.uniform(-max_degrees, max_degrees))
        d = skeleton.distances[j]
        region = (d <= radius)[dominant]
        handle = np.flatnonzero((d <= HANDLE_FRACTION * radius)[dominant])
        norm = float(np.linalg.norm(axis))
        if handle.size == 0 or not region.any() or (region & taken).any() or not norm > 0:
            continue
        joint = _joint(region, edges, vertices)
        if joint is None:
            continue
        taken |= region
        limbs.append(Limb(int(skeleton.extremities[j]), handle, np.flatnonzero(region), joint, axis / norm,
                          degrees))
    return limbs


def draw_pose(skeleton: Skeleton, rng: np.random.Generator, *, dominant: np.ndarray, vertices: np.ndarray,
              edges: np.ndarray, handles: int, max_degrees: float, iterations: int, cage: dict,
              fingerprint: dict):
    """Draw one pose as an edit (see :func:`draw_limbs` for the draw itself).

    Parameters
    ----------
    skeleton, rng, dominant, vertices, edges, handles, max_degrees
        As :func:`draw_limbs`.
    iterations : int
        ARAP iterations the step records (its settle).
    cage : dict
        ``{"size": ..., "vertices": ...}``, the cage the pose is made on.
    fingerprint : dict
        The mesh's fingerprint (:func:`hybridedit.fileio.editfile.mesh_fingerprint`).

    Returns
    -------
    Edit or None
        One step in shape space: each limb a handle group rotating about its joint, the union of
        the regions the region of interest; None when no limb could be drawn.
    """
    from ..fileio.editfile import Edit, HandleEdit

    limbs = draw_limbs(skeleton, rng, dominant=dominant, vertices=vertices, edges=edges, handles=handles,
                       max_degrees=max_degrees)
    if not limbs:
        return None
    groups = [HandleEdit(limb.handle, translate=np.zeros(3),
                         rotate={"axis": limb.axis, "degrees": limb.degrees, "center": limb.joint})
              for limb in limbs]
    region = unique_sorted(np.concatenate([limb.region for limb in limbs]))
    return Edit(handles=groups, roi=region, space="shape", iterations=int(iterations), cage=dict(cage),
                mesh=fingerprint)
