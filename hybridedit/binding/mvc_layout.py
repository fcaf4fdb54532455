"""The arrays the mean value coordinate kernels read: the cage and the points laid out for them.

The exact kernel (:mod:`hybridedit.binding.mvc_exact`) reads a cage as :class:`CageData`
(:func:`prepare_cage`): faces in a spatially coherent (Morton) order, unique edges numbered
by first use, face planes and tiles of faces that fit in cache. The fast kernels
(:mod:`hybridedit.binding.mvc_flat`, :mod:`hybridedit.binding.mvc_tree`) read it as
:class:`FastCageData` (:func:`prepare_fast_cage`: the same in the cage's unit box, with the
far field's quadrature data), and the points as a :class:`FastPlan` (:func:`plan_fast`:
sorted along a Morton curve, cut into batches of :data:`LANES`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit, prange

from ..core.index_sets import difference_in_range, unique_sorted
from ..core.parallel import pick
from ..core.twins import twins
from ..core.spatial_order import morton_order
from ..core.topology import edges_by_first_use, vertices_by_first_use

__all__ = ["CageData", "FACE_TILE", "FAST_BLOCK", "FastCageData", "FastPlan", "LANES", "fast_destinations",
           "plan_fast", "plan_groups", "prepare_cage", "prepare_fast_cage"]

#: Faces per tile of the per-point loops (keeps a tile's data in cache).
FACE_TILE = 512
#: Points per batch of the fast kernel (the length of its vectorized loops).
LANES = 32
#: Faces per block (the unit of the first near/far test).
FAST_BLOCK = 32


@dataclass(frozen=True)
class CageData:
    """Cage arrays laid out for the kernels (built by :func:`prepare_cage`).

    Faces are stored in a spatially coherent order (Morton order of their
    centroids) and edges are numbered by first use in that order, so the
    per-face loop reads edge data that is close in memory. Vertex indices are
    the caller's.

    Attributes
    ----------
    vertices : (c, 3) float64
    vertices_t : (3, c) float64
        The same, transposed.
    faces : (f, 3) int64
        The caller's faces, in kernel order (``faces[k] = input[face_order[k]]``).
    face_order : (f,) int64
    edges : (e, 2) int64
        Unique undirected edges, column 0 < column 1.
    face_idx : (f, 6) uint32
        Vertex ids ``i0, i1, i2`` then the ids of the edges ``(i0, i1)``,
        ``(i1, i2)``, ``(i2, i0)``.
    planes : (5, f) float64
        Unit normal (3 rows), offset ``n . p0`` and ``|N_f|`` (twice the area).
        Degenerate faces have an all-zero column and are ignored.
    edge_points : (6, e) float64
        Position of the lower endpoint and the edge vector (higher - lower)
        of every edge.
    face_tiles : (t + 1,) int64
        Faces ``face_tiles[k]:face_tiles[k + 1]`` form tile ``k``.
    edge_tiles : (t + 1,) int64
        Edges ``edge_tiles[k]:edge_tiles[k + 1]`` are those first used by
        tile ``k`` (edges are numbered by first use, so these are ranges).
    scale : float
        Bounding-box diagonal of the cage.
    """

    vertices: np.ndarray
    vertices_t: np.ndarray
    faces: np.ndarray
    face_order: np.ndarray
    edges: np.ndarray
    face_idx: np.ndarray
    planes: np.ndarray
    edge_points: np.ndarray
    face_tiles: np.ndarray
    edge_tiles: np.ndarray
    scale: float

    @property
    def n_vertices(self) -> int:
        return int(self.vertices.shape[0])

    @property
    def n_faces(self) -> int:
        return int(self.faces.shape[0])

    @property
    def n_edges(self) -> int:
        return int(self.edges.shape[0])


@njit(cache=True, nogil=True)
def _edge_points(v, edges):  # pragma: no cover - compiled
    """(6, e): each edge's first end (rows 0-2) and its vector to the other (rows 3-5)."""
    out = np.empty((6, edges.shape[0]))
    for k in range(edges.shape[0]):
        a, b = edges[k, 0], edges[k, 1]
        for d in range(3):
            out[d, k] = v[a, d]
            out[3 + d, k] = v[b, d] - v[a, d]
    return out


def prepare_cage(cage_vertices: np.ndarray, cage_faces: np.ndarray) -> CageData:
    """Validate a cage and precompute the kernel's arrays (see :class:`CageData`)."""
    v = np.asarray(cage_vertices)
    f = np.asarray(cage_faces)
    if v.ndim != 2 or v.shape[1] != 3 or v.shape[0] == 0:
        raise ValueError(f"cage vertices must be a non-empty (c, 3) array, got shape {v.shape}")
    v = np.ascontiguousarray(v, dtype=np.float64)
    if not np.all(np.isfinite(v)):
        raise ValueError("cage vertices must be finite")
    if f.ndim != 2 or f.shape[1] != 3 or f.shape[0] == 0:
        raise ValueError(f"cage faces must be a non-empty (f, 3) array, got shape {f.shape}")
    if not np.issubdtype(f.dtype, np.integer):
        raise ValueError(f"cage faces must hold integer vertex indices, got dtype {f.dtype}")
    f = f.astype(np.int64)
    nv = len(v)
    if f.min() < 0 or f.max() >= nv:
        raise ValueError(
            f"cage face indices must lie in [0, {nv - 1}], found {int(f.min())}..{int(f.max())}"
        )
    if nv >= 2**31 or len(f) >= 2**31:
        raise ValueError("cage too large for the kernels (2^31 elements)")

    order = morton_order(v[f].mean(axis=1), bits=10, per_axis=True)
    f = f[order]
    nf = len(f)

    # Unique undirected edges, numbered by first use in face order.
    edges, face_edges, first = edges_by_first_use(f, nv)
    face_idx = np.ascontiguousarray(np.concatenate([f, face_edges], axis=1).astype(np.uint32))
    # Tiles of faces, and the range of edges each tile uses first.
    face_tiles = unique_sorted(np.append(np.arange(0, nf, FACE_TILE), nf)).astype(np.int64)
    first_use_face = first // 3  # face of each edge's first use, by edge id
    edge_tiles = np.searchsorted(first_use_face, face_tiles, side="left").astype(np.int64)

    p0, p1, p2 = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    normal = np.cross(p1 - p0, p2 - p0)
    area2 = np.linalg.norm(normal, axis=1)
    longest = np.max(
        np.stack([
            np.linalg.norm(p1 - p0, axis=1),
            np.linalg.norm(p2 - p1, axis=1),
            np.linalg.norm(p0 - p2, axis=1),
        ]),
        axis=0,
    )
    # Degenerate (needle or repeated-vertex) faces project to zero area on
    # every sphere: they carry no weight.
    ok = area2 > 1e-14 * longest * longest
    planes = np.zeros((5, nf))
    n = normal[ok] / area2[ok, None]
    planes[0:3, ok] = n.T
    planes[3, ok] = np.einsum("ij,ij->i", n, p0[ok])
    planes[4, ok] = area2[ok]
    edge_points = _edge_points(v, edges)
    scale = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))
    return CageData(
        vertices=v,
        vertices_t=np.ascontiguousarray(v.T),
        faces=f,
        face_order=order,
        edges=edges,
        face_idx=face_idx,
        planes=np.ascontiguousarray(planes),
        edge_points=edge_points,
        face_tiles=face_tiles,
        edge_tiles=edge_tiles,
        scale=scale,
    )


@dataclass(frozen=True)
class FastCageData:
    """Cage arrays of the fast method (built by :func:`prepare_fast_cage`).

    Coordinates are ``(p - origin) / unit``, ``origin`` the centre of the
    cage's bounding box and ``unit`` its diagonal (mean value coordinates
    are invariant under such a map). Cage vertices are renumbered internally
    by first use in the face order, so that the data of a tile of faces is
    close in memory; ``perm[k]`` is the caller's index of internal vertex
    ``k``.

    Attributes
    ----------
    exact : CageData
        The exact kernel's data in these coordinates (faces in kernel order).
    origin : (3,) float64
    unit : float
    perm, inv_perm : (c,) int64
    verts_t : (3, c) float64
        Vertices in internal order.
    mids_t : (3, e) float64
        Edge midpoints (edges as in ``exact.edges``).
    qcoef : (4, f) float64
        ``A_f (off_f - n_f . x) / 60 = q0 + q1 x + q2 y + q3 z``.
    far_idx : (f, 6) uint32
        Internal vertex ids, then the edge ids of the edges 01, 12, 20.
    face_geo : (4, f) float64
        Centroid and radius (largest centroid-vertex distance) of each face.
    tile_verts, tile_edges, tile_blocks : (t + 1,) int64
        Vertices, edges and blocks first used by each tile of ``exact.face_tiles``.
    block_faces : (nb + 1,) int64
    block_geo : (5, nb) float64
        Centre, spread (largest centre-to-face-centroid distance) and size
        (largest face radius) of each block.
    """

    exact: CageData
    origin: np.ndarray
    unit: float
    perm: np.ndarray
    inv_perm: np.ndarray
    verts_t: np.ndarray
    mids_t: np.ndarray
    qcoef: np.ndarray
    far_idx: np.ndarray
    face_geo: np.ndarray
    tile_verts: np.ndarray
    tile_edges: np.ndarray
    tile_blocks: np.ndarray
    block_faces: np.ndarray
    block_geo: np.ndarray

    @property
    def n_vertices(self) -> int:
        return self.exact.n_vertices

    @property
    def scale(self) -> float:
        return self.exact.scale


def prepare_fast_cage(cage_vertices: np.ndarray, cage_faces: np.ndarray) -> FastCageData:
    """Validate a cage and precompute the fast kernel's arrays (see :class:`FastCageData`)."""
    v = np.asarray(cage_vertices)
    origin = np.zeros(3)
    unit = 1.0
    if (v.ndim == 2 and v.shape[1] == 3 and v.shape[0] > 0 and np.issubdtype(v.dtype, np.number)
            and np.all(np.isfinite(v))):
        v = np.asarray(v, dtype=np.float64)
        origin = 0.5 * (v.min(axis=0) + v.max(axis=0))
        diag = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))
        unit = diag if diag > 0 else 1.0
        v = (v - origin) / unit
    ex = prepare_cage(v, cage_faces)  # validates
    f = ex.faces
    nf = len(f)
    c = ex.n_vertices
    # Internal vertex order: by first use in the kernel's face order.
    used, first = vertices_by_first_use(f, c)
    perm = np.concatenate([used, difference_in_range(np.arange(c), used, c)]).astype(np.int64)
    inv_perm = np.empty(c, dtype=np.int64)
    inv_perm[perm] = np.arange(c)
    first_face = first // 3
    tile_verts = np.searchsorted(first_face, ex.face_tiles, side="left").astype(np.int64)
    verts_t = np.ascontiguousarray(ex.vertices[perm].T)
    far_idx = np.concatenate([inv_perm[f], ex.face_idx[:, 3:].astype(np.int64)], axis=1)
    far_idx = np.ascontiguousarray(far_idx.astype(np.uint32))
    mids = 0.5 * (ex.vertices[ex.edges[:, 0]] + ex.vertices[ex.edges[:, 1]])
    mids_t = np.ascontiguousarray(mids.T)
    planes = ex.planes
    qcoef = np.empty((4, nf))
    qcoef[0] = planes[4] * planes[3] / 120.0  # planes[4] is twice the area
    qcoef[1:4] = -planes[4] * planes[0:3] / 120.0
    tri = ex.vertices[f]
    cen = tri.mean(axis=1)
    rad = np.linalg.norm(tri - cen[:, None, :], axis=2).max(axis=1)
    face_geo = np.ascontiguousarray(np.concatenate([cen.T, rad[None]]))
    # Blocks of FAST_BLOCK faces (a divisor of FACE_TILE: tiles hold whole blocks).
    block_faces = unique_sorted(np.append(np.arange(0, nf, FAST_BLOCK), nf)).astype(np.int64)
    nb = len(block_faces) - 1
    tile_blocks = np.searchsorted(block_faces, ex.face_tiles, side="left").astype(np.int64)
    bid = np.arange(nf) // FAST_BLOCK
    cnt = np.bincount(bid, minlength=nb).astype(np.float64)
    bc = np.stack([np.bincount(bid, weights=cen[:, k], minlength=nb) for k in range(3)]) / cnt
    spread = np.zeros(nb)
    np.maximum.at(spread, bid, np.linalg.norm(cen - bc.T[bid], axis=1))
    size = np.zeros(nb)
    np.maximum.at(size, bid, rad)
    block_geo = np.ascontiguousarray(np.concatenate([bc, spread[None], size[None]]))
    return FastCageData(
        exact=ex, origin=origin, unit=unit, perm=perm, inv_perm=inv_perm, verts_t=verts_t,
        mids_t=mids_t,
        qcoef=np.ascontiguousarray(qcoef), far_idx=far_idx, face_geo=face_geo,
        tile_verts=tile_verts, tile_edges=ex.edge_tiles, tile_blocks=tile_blocks,
        block_faces=block_faces, block_geo=block_geo,
    )


@dataclass(frozen=True)
class FastPlan:
    """Points of one fast computation, sorted and cut into batches (:func:`plan_fast`).

    ``order[k]`` is the caller's index of the point at sorted position ``k``;
    batch ``b`` holds sorted positions ``b * LANES`` to ``b * LANES + LANES - 1``
    (the last batch is padded with copies of the last point).
    """

    order: np.ndarray
    bx: np.ndarray  # (nbatch, 3, LANES), in the cage's coordinates (FastCageData)
    bsph: np.ndarray  # (nbatch, 4): centre and radius of each batch

    @property
    def n_points(self) -> int:
        return int(self.order.shape[0])


def plan_fast(points: np.ndarray, cage: FastCageData) -> FastPlan:
    """Sort ``points`` (finite, (n, 3)) along a Morton curve and cut them into batches."""
    n = points.shape[0]
    if n == 0:
        return FastPlan(np.zeros(0, dtype=np.int64), np.zeros((0, 3, LANES)), np.zeros((0, 4)))
    order = morton_order(points, bits=10, per_axis=True)
    nbatch = -(-n // LANES)
    pos = np.minimum(np.arange(nbatch * LANES), n - 1)
    return FastPlan(order=order, **_batches(points, order[pos].reshape(nbatch, LANES), cage))


@njit(cache=True, inline="always")
def _batch_at(b, points, idx, origin, unit, min_radius, bx, bsph):
    """Batch b's lanes (points ``idx[b]`` in the cage's unit box) into ``bx[b]``, its sphere (about
    its box's centre, radius at least ``min_radius``) into ``bsph[b]``."""
    lo0 = lo1 = lo2 = np.inf
    hi0 = hi1 = hi2 = -np.inf
    for ln in range(idx.shape[1]):
        i = idx[b, ln]
        x = (points[i, 0] - origin[0]) / unit
        y = (points[i, 1] - origin[1]) / unit
        z = (points[i, 2] - origin[2]) / unit
        bx[b, 0, ln] = x
        bx[b, 1, ln] = y
        bx[b, 2, ln] = z
        lo0, hi0 = min(lo0, x), max(hi0, x)
        lo1, hi1 = min(lo1, y), max(hi1, y)
        lo2, hi2 = min(lo2, z), max(hi2, z)
    c0 = 0.5 * (lo0 + hi0)
    c1 = 0.5 * (lo1 + hi1)
    c2 = 0.5 * (lo2 + hi2)
    r = 0.0
    for ln in range(idx.shape[1]):
        d0 = bx[b, 0, ln] - c0
        d1 = bx[b, 1, ln] - c1
        d2 = bx[b, 2, ln] - c2
        r = max(r, math.sqrt(d0 * d0 + d1 * d1 + d2 * d2))
    bsph[b, 0] = c0
    bsph[b, 1] = c1
    bsph[b, 2] = c2
    bsph[b, 3] = max(r, min_radius)


@twins()
def _batches_twins(points, idx, origin, unit, min_radius, bx, bsph):  # pragma: no cover - compiled
    for b in prange(idx.shape[0]):
        _batch_at(b, points, idx, origin, unit, min_radius, bx, bsph)


def _batches(points: np.ndarray, idx: np.ndarray, cage: FastCageData, min_radius: float = 0.0) -> dict:
    """``bx`` and ``bsph`` of :class:`FastPlan` for batches of the (n, 3) ``points`` at ``idx``
    (nbatch, LANES): each batch's sphere about its box's centre, of radius at least ``min_radius``.
    One compiled pass (numpy's gather, box and norms took 2 s for the 11M armadillo's points)."""
    nbatch = idx.shape[0]
    bx = np.empty((nbatch, 3, LANES))
    bsph = np.empty((nbatch, 4))
    p = np.ascontiguousarray(points, dtype=np.float64)
    origin = np.ascontiguousarray(cage.origin, dtype=np.float64)
    pick("copy", *_batches_twins, nbatch * LANES)(
        p, np.ascontiguousarray(idx, dtype=np.int64), origin, float(cage.unit), float(min_radius), bx, bsph)
    return {"bx": bx, "bsph": bsph}


def plan_groups(points: np.ndarray, cage: FastCageData, radius: float) -> tuple[FastPlan, np.ndarray]:
    """A plan whose batches hold only points near each other: along the Morton curve, a batch
    takes the next point while it lies within ``radius`` (in the cage's unit box, as
    :attr:`FastPlan.bsph`) of the batch's first point and the batch has room; its unused lanes
    repeat its last point, and its sphere's radius is at least ``radius``. For rows that batches
    of Morton neighbours, spread wide, left undecided (see :func:`hybridedit.binding.bind.bind`).

    Returns
    -------
    plan : FastPlan
        ``order`` (nbatch * LANES,): the point at each sorted position (repeated in unused lanes).
    position : (k,) int64
        The sorted position whose row is point i's.
    """
    k = points.shape[0]
    if k == 0:
        return FastPlan(np.zeros(0, dtype=np.int64), np.zeros((0, 3, LANES)), np.zeros((0, 4))), np.zeros(0, np.int64)
    curve = morton_order(points, bits=10, per_axis=True)
    pu = (points[curve] - cage.origin) / cage.unit  # (as _batch_at places them)
    starts = []
    i = 0
    while i < k:  # (a few thousand points at most: the rows left undecided)
        starts.append(i)
        d = np.linalg.norm(pu[i:i + LANES] - pu[i], axis=1)
        far = np.flatnonzero(d > radius)
        i += int(far[0]) if far.size else min(LANES, k - i)
    first = np.asarray(starts, dtype=np.int64)
    size = np.diff(np.append(first, k))
    nbatch = first.size
    lane = np.minimum(np.arange(LANES)[None, :], size[:, None] - 1)
    at = first[:, None] + lane  # (nbatch, LANES) curve positions
    # each batch's sphere at least ``radius``: the hierarchy's tests then separate nodes from it as
    # from a typical batch of the first pass, and its far field is as accurate
    plan = FastPlan(order=curve[at].ravel(), **_batches(points, curve[at], cage, radius))
    position = np.empty(k, dtype=np.int64)
    batch = np.repeat(np.arange(nbatch), size)
    position[curve] = batch * LANES + (np.arange(k) - first[batch])
    return plan, position


def fast_destinations(plan: "FastPlan", start: int, stop: int) -> tuple[int, int, np.ndarray]:
    """Batches ``k0:k1`` covering sorted positions [start, stop) and where their lanes go.

    ``dest[b, l]`` is the output row (``position - start``) of lane ``l`` of
    batch ``k0 + b``, or -1 outside [start, stop).
    """
    stop = min(stop, plan.n_points)
    k0 = start // LANES
    k1 = -(-stop // LANES)
    pos = np.arange(k0 * LANES, k1 * LANES, dtype=np.int64)
    dest = np.where((pos >= start) & (pos < stop), pos - start, -1).reshape(k1 - k0, LANES)
    return k0, k1, dest
