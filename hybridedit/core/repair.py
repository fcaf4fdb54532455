"""Repairs of a private copy of the shape, used only to build the cage.

The shape itself is never changed: its vertices and faces are written back in
the order they were read, and the binding covers every input vertex (mean value
coordinates are defined for any point, so duplicated or unreferenced vertices
need no special care).  The cage, however, must be a closed, consistently
oriented surface, and quadric simplification works best on a clean manifold
input.  :func:`cage_source` makes that input and says, in plain words, what it
had to change; :func:`close_holes` closes what simplification leaves open.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from .bounds import points_box
from .index_sets import unique_sorted
from .mesh import Mesh, MeshError
from .topology import (connected_parts, degenerate_faces, edge_balance, edge_index, group_rows, half_edges,
                       oriented_rim, repeats_a_face, weld)

__all__ = ["CageSource", "cage_source", "repaired_source", "close_holes", "box_cage", "plural", "MERGE_TOLERANCE"]

#: vertices closer than this fraction of the bounding-box diagonal are merged
MERGE_TOLERANCE = 1e-9


def plural(n: int, word: str, many: str | None = None) -> str:
    """'1 face', '3 faces'."""
    return f"{n:,} {word if n == 1 else (many or word + 's')}"


def _diagonal(v: np.ndarray) -> float:
    if len(v) == 0:
        return 0.0
    lo, hi = points_box(v)
    return float(np.linalg.norm(hi - lo))


def _split_nonmanifold(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray, int, int]:
    """Separate the sheets that meet at edges shared by more than two faces, so that a closed surface
    pinched along an edge (two solids touching along it) stays closed, instead of dropping faces there.

    Around such an edge the faces are sorted by angle; each face opens towards one side of the
    rotation (its solid's inside, behind its normal), and a face opening forwards is paired with the
    next face opening backwards, as brackets are matched: two faces of one sheet, the inside between
    them. A face left without a partner (a fin standing on a surface) is dropped. Then every vertex of
    such an edge is given a copy for each further sheet meeting there (the faces around it that the
    pairs and the ordinary edges do not join).

    Returns
    -------
    v : (n + k, 3) the vertices, the k copies appended
    f : (m', 3) the faces
    split : how many edges had their sheets separated
    dropped : how many faces were dropped (fins)
    """
    n = len(v)
    if len(f) == 0 or np.bincount(edge_index(f, n)[1]).max() <= 2:  # (linear time: the usual case, none)
        return v, f, 0, 0
    key, fwd, face = half_edges(f, n)
    order = np.argsort(key, kind="stable")
    ks = key[order]
    start = np.flatnonzero(np.r_[True, ks[1:] != ks[:-1]])
    count = np.diff(np.r_[start, len(ks)])
    wide = np.flatnonzero(count > 2)
    if wide.size == 0:
        return v, f, 0, 0
    # the face pairs that join across each edge: every two-face edge, and the matched pairs of wide ones
    joined: dict[int, list[tuple[int, int]]] = {}
    drop: set[int] = set()
    for g in wide:
        hs = order[start[g]:start[g] + count[g]]
        k = int(ks[start[g]])
        joined[k], unpaired = _pair_sheets(v, f, n, k, face[hs], fwd[hs])
        drop.update(unpaired)
    keep = np.ones(len(f), dtype=bool)
    keep[list(drop)] = False
    v, out = _separate_sheets(v, f, n, keep, joined, order, ks, start, count, face)
    return v, out[keep], sum(len(p) > 1 for p in joined.values()), len(drop)


def _pair_sheets(v: np.ndarray, f: np.ndarray, n: int, k: int, faces_here: np.ndarray,
                 forward: np.ndarray) -> tuple[list[tuple[int, int]], list[int]]:
    """The faces around the wide edge of key ``k`` (``a * n + b``), paired as brackets by angle.

    Parameters
    ----------
    v : (n, 3) float64, f : (m, 3) int64
    faces_here : (h,) int64 the faces of the edge's half-edges; forward : (h,) bool, a half-edge a -> b

    Returns
    -------
    pairs : the (face, face) pairs of one sheet across the edge
    unpaired : the faces left without a partner (fins, to drop)
    """
    a, b = k // n, k % n
    axis = v[b] - v[a]
    axis = axis / (np.linalg.norm(axis) or 1.0)
    third = np.array([int(x) for t in faces_here for x in f[t] if x != a and x != b][: len(faces_here)])
    w = v[third] - v[a]
    w -= np.outer(w @ axis, axis)
    ref = w[0] / (np.linalg.norm(w[0]) or 1.0)
    angle = np.arctan2(w @ np.cross(axis, ref), w @ ref)
    # a face with the half-edge a -> b and its third corner at angle phi has its normal along
    # axis x wing, the way the angle grows: its inside (behind the normal) lies behind it in angle;
    # with b -> a, ahead
    opens_ahead = ~forward
    ring = np.argsort(angle, kind="stable")
    step = np.where(opens_ahead[ring], 1, -1)
    first = int(np.argmin(np.cumsum(step))) + 1  # brackets on a circle: start where none is left open
    pairs, stack = [], []
    for i in np.roll(ring, -first):
        if opens_ahead[i]:
            stack.append(i)
        elif stack:
            pairs.append((stack.pop(), i))
    paired = {x for p in pairs for x in p}
    unpaired = [int(faces_here[i]) for i in range(len(faces_here)) if i not in paired]
    return [(int(faces_here[p]), int(faces_here[q])) for p, q in pairs], unpaired


def _separate_sheets(v: np.ndarray, f: np.ndarray, n: int, keep: np.ndarray,
                     joined: dict[int, list[tuple[int, int]]], order: np.ndarray, ks: np.ndarray,
                     start: np.ndarray, count: np.ndarray, face: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every vertex of a wide edge given a copy for each further sheet meeting there: the groups of
    its kept faces that the pairs ``joined`` and the two-face edges do not join.

    ``order``, ``ks``, ``start``, ``count`` and ``face`` are the half-edges sorted by key (as in
    :func:`_split_nonmanifold`). Returns the vertices (copies appended) and all the faces (not only
    the kept ones) with the copies in place.
    """
    touched = unique_sorted(np.concatenate([[k // n, k % n] for k in joined]))
    extra: list[np.ndarray] = []
    out = f.copy()
    nxt = n
    near = np.flatnonzero(np.isin(f, touched).any(axis=1) & keep)  # the faces around them, once
    ranks = {int(ks[g]): g for g in start[np.isin(ks[start] // n, touched) | np.isin(ks[start] % n, touched)]}
    for x in touched.tolist():
        around = near[np.any(f[near] == x, axis=1)].tolist()
        parent = {t: t for t in around}

        def root(t):
            while parent[t] != t:
                parent[t] = parent[parent[t]]
                t = parent[t]
            return t

        for t in around:
            for y in f[t]:
                if y == x:
                    continue
                k = min(x, int(y)) * n + max(x, int(y))
                if k in joined:
                    links = joined[k]
                else:
                    g0 = ranks[k]  # (the position of the edge's first half-edge in the sorted order)
                    c = int(count[np.searchsorted(start, g0)])
                    hs = order[g0:g0 + c]
                    links = [(int(face[hs[0]]), int(face[hs[1]]))] if c == 2 else []
                for p, q in links:
                    if p in parent and q in parent:
                        parent[root(p)] = root(q)
        groups: dict[int, list[int]] = {}
        for t in around:
            groups.setdefault(root(t), []).append(t)
        for members in list(groups.values())[1:]:
            for t in members:
                out[t][f[t] == x] = nxt
            extra.append(v[x])
            nxt += 1
    if extra:
        v = np.vstack([v, np.array(extra)])
    return v, out


@numba.njit(cache=True)
def _orient_bfs(indptr, nbr, rel, m, flip, comp):  # pragma: no cover - compiled
    queue = np.empty(m, dtype=np.int64)
    ncomp = 0
    conflicts = 0
    for s in range(m):
        if comp[s] >= 0:
            continue
        comp[s] = ncomp
        flip[s] = 0
        head = 0
        tail = 1
        queue[0] = s
        while head < tail:
            f = queue[head]
            head += 1
            for k in range(indptr[f], indptr[f + 1]):
                g = nbr[k]
                want = flip[f] ^ rel[k]
                if comp[g] < 0:
                    comp[g] = ncomp
                    flip[g] = want
                    queue[tail] = g
                    tail += 1
                elif flip[g] != want:
                    conflicts += 1
        ncomp += 1
    return ncomp, conflicts


def orient_faces(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, int, bool]:
    """Orient faces consistently across manifold edges, outward per closed-ish part.

    Returns (faces, number of faces flipped, orientable).
    """
    m, n = len(f), len(v)
    if m == 0:
        return f, 0, True
    key, fwd, face = half_edges(f, n)
    order = np.argsort(key, kind="stable")
    ks = key[order]
    same_next = ks[1:] == ks[:-1]
    # an edge used by exactly two faces: pair (i, i+1) in sorted order
    pair = np.zeros(len(ks), dtype=bool)
    pair[:-1] = same_next
    if len(ks) > 2:
        pair[:-1] &= np.concatenate([[True], ~same_next[:-1]])
        pair[:-2] &= ~same_next[1:]
    i = np.flatnonzero(pair)
    f1, f2 = face[order[i]], face[order[i + 1]]
    r = (fwd[order[i]] == fwd[order[i + 1]]).astype(np.int8)  # same direction: one must flip
    ok = f1 != f2
    f1, f2, r = f1[ok], f2[ok], r[ok]
    rows = np.concatenate([f1, f2])
    cols = np.concatenate([f2, f1])
    rr = np.concatenate([r, r])
    srt = np.argsort(rows, kind="stable")
    indptr = np.zeros(m + 1, dtype=np.int64)
    np.cumsum(np.bincount(rows, minlength=m), out=indptr[1:])
    flip = np.zeros(m, dtype=np.int8)
    comp = np.full(m, -1, dtype=np.int64)
    ncomp, conflicts = _orient_bfs(indptr, cols[srt].astype(np.int64), rr[srt], m, flip, comp)
    out = f.copy()
    fl = flip.astype(bool)
    out[fl] = out[fl][:, [0, 2, 1]]
    # outward: positive signed volume per part
    out, sel = _outward(v, out, comp)
    fl ^= sel
    return out, int(np.count_nonzero(fl)), conflicts == 0


def cage_source(mesh: Mesh) -> tuple[Mesh, list[str]]:
    """A cleaned copy of ``mesh`` to simplify into a cage, and what was changed.

    Merges duplicate vertices (exactly or nearly equal positions, within
    :data:`MERGE_TOLERANCE` of the bounding-box diagonal), leaves out
    unreferenced vertices, drops degenerate faces (the rule of
    :func:`hybridedit.core.topology.degenerate_faces`) and duplicate faces, drops
    faces beyond the second on non-manifold edges, and orients faces
    consistently per connected part (outward where a part encloses volume).
    ``mesh`` is not modified.

    Returns
    -------
    clean : Mesh
        The cage source (compact vertex numbering).
    notes : list of str
        One plain sentence per kind of change, e.g. "merged 12 duplicate
        vertices"; empty when nothing needed repair.

    Raises
    ------
    MeshError
        When nothing usable is left (every face is degenerate).
    """
    src = repaired_source(mesh)
    return src.mesh, src.notes


@dataclass(frozen=True)
class CageSource:
    """What :func:`repaired_source` made of a shape.

    Attributes
    ----------
    mesh : Mesh
        The cleaned copy (k vertices, all used by a face). When nothing needed
        repair it shares its arrays with the input: read it, do not modify it.
    notes : list of str
        What was changed, in plain words.
    vertex_map : (n,) int64
        The vertex of ``mesh`` each input vertex was merged into, -1 for input
        vertices that no kept face uses.
    part_labels : (k,) int64
        The connected part of each vertex of ``mesh`` (0 .. parts - 1).
    parts : int
    closed : bool
        True when the whole surface is known to be closed, edge-manifold and
        consistently oriented (the fast path); False when that is not known.
    """

    mesh: Mesh
    notes: list[str]
    vertex_map: np.ndarray
    part_labels: np.ndarray
    parts: int
    closed: bool


def repaired_source(mesh: Mesh) -> CageSource:
    """:func:`cage_source`, with where each input vertex went and the parts."""
    label = f"{mesh.name}: " if mesh.name else ""
    notes: list[str] = []
    v0, f = mesh.vertices, mesh.faces
    if len(f) == 0:
        raise MeshError(f"{label}the mesh has no faces")
    used = np.zeros(len(v0), dtype=bool)
    used[f.ravel()] = True
    unref = int(len(v0) - np.count_nonzero(used))
    if unref:
        notes.append(f"ignored {plural(unref, 'unreferenced vertex', 'unreferenced vertices')} for the cage "
                     "(they still follow the deformation)")
    rim = oriented_rim(f, len(v0))
    intact = rim is not None and not np.any(degenerate_faces(v0, f))
    if intact and rim.any():
        # open (a scan with holes): the full pass would change nothing unless a face repeats or
        # two rim vertices merge (a seam split into two rims; inside the surface, as on a closed
        # one, coincident vertices are not merged); it costs 5x the checks (2.3 s at 690K)
        intact = not repeats_a_face(f, len(v0)) and not _rim_merges(v0, used, rim, MERGE_TOLERANCE)
    if intact:
        # an edge-manifold, consistently oriented surface without degenerate faces:
        # only compaction and the outward orientation of each part are left to do
        # (no copy of a large mesh when every vertex is used, the usual case)
        if unref:
            remap = np.cumsum(used) - 1
            remap[~used] = -1
            v, f = v0[used], remap[f]
        else:
            remap, v = np.arange(len(v0), dtype=np.int64), v0
        parts, labels = connected_parts(f, len(v))
        f, flipped_mask = _outward(v, f, labels[f[:, 0]])
        flipped = int(np.count_nonzero(flipped_mask))
        if flipped:
            notes.append(f"re-oriented {plural(flipped, 'face')}")
        if parts > 1:
            notes.append(f"{parts:,} disconnected parts")
        return CageSource(Mesh(v, f, name=mesh.name), notes, remap, labels, parts, not rim.any())
    return _repaired_in_full(mesh, notes, used)


def _repaired_in_full(mesh: Mesh, notes: list[str], used: np.ndarray) -> CageSource:
    """The whole repair pass of :func:`repaired_source` (``notes`` so far, ``used`` (n,) bool the
    vertices a face uses)."""
    label = f"{mesh.name}: " if mesh.name else ""
    v0, f = mesh.vertices, mesh.faces
    diag = _diagonal(v0[used])
    v, f, vmap, merged = weld(v0, f, MERGE_TOLERANCE * diag)
    if merged:
        notes.append(f"merged {plural(merged, 'duplicate vertex', 'duplicate vertices')}")
    bad = degenerate_faces(v, f)
    if np.any(bad):
        f = f[~bad]
        notes.append(f"dropped {plural(int(bad.sum()), 'degenerate face')} (zero area or a repeated vertex)")
    if len(f) == 0:
        raise MeshError(f"{label}every face is degenerate (zero area); there is no surface to edit")
    # duplicate faces (same three vertices, either orientation): keep the first (grouped only when there
    # are any: the quick test is a sort of one key a face)
    if repeats_a_face(f, len(v)):
        first, _ = group_rows(np.sort(f, axis=1))
        notes.append(f"dropped {plural(len(f) - len(first), 'duplicate face')}")
        f = f[np.sort(first)]
    v, f, split, dropped = _split_nonmanifold(v, f)
    if split:
        notes.append(f"separated the sheets meeting at {plural(split, 'non-manifold edge')} (edges shared by more "
                     "than two faces)")
    if dropped:
        notes.append(f"dropped {plural(dropped, 'face')} standing alone at non-manifold edges (fins)")
    # compact again (merging and dropping can leave vertices unused)
    keep = np.zeros(len(v), dtype=bool)
    keep[f.ravel()] = True
    remap = np.cumsum(keep) - 1
    remap[~keep] = -1
    v, f = v[keep], remap[f]
    vmap = np.where(vmap >= 0, remap[np.maximum(vmap, 0)], -1)
    f, flipped, orientable = orient_faces(v, f)
    if flipped:
        notes.append(f"re-oriented {plural(flipped, 'face')}")
    if not orientable:
        notes.append("the surface is not orientable; some faces keep a conflicting orientation")
    parts, labels = connected_parts(f, len(v))
    if parts > 1:
        notes.append(f"{parts:,} disconnected parts")
    return CageSource(Mesh(v, f, name=mesh.name), notes, vmap, labels, parts, False)


def _rim_merges(v: np.ndarray, used: np.ndarray, rim: np.ndarray, tolerance: float) -> bool:
    """Two rim vertices (``rim`` (n,) bool) fall in one cell of :func:`weld`'s grid (spacing
    ``tolerance`` of the used vertices' diagonal, from their lowest corner)."""
    lo, hi = points_box(v[used])
    tol = tolerance * float(np.linalg.norm(hi - lo))
    if not tol > 0:
        return True  # (a shape of no extent: the full pass says what it is)
    key = np.floor((v[rim] - lo) / tol).astype(np.int64)
    return len(np.unique(key, axis=0)) < len(key)


def _outward(v: np.ndarray, f: np.ndarray, part_of_face: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Flip the parts of a consistently oriented surface whose signed volume (about
    the part's mean vertex, for precision) is negative; returns the faces and the (m,)
    mask of flipped ones."""
    ncomp = int(part_of_face.max()) + 1 if len(part_of_face) else 0
    f = np.ascontiguousarray(f, dtype=np.int64)
    part_of_face = np.ascontiguousarray(part_of_face, dtype=np.int64)
    vol = np.zeros(ncomp)
    _part_volumes(np.ascontiguousarray(v, dtype=np.float64), f, part_of_face, ncomp, vol)
    sel = (vol < 0)[part_of_face]
    if not np.any(sel):
        return f, sel
    out = f.copy()
    out[sel] = out[sel][:, [0, 2, 1]]
    return out, sel


@numba.njit(cache=True)
def _part_volumes(v, f, part, ncomp, vol):  # pragma: no cover - compiled
    """Six times the signed volume of each part, about the mean of its face corners."""
    cen = np.zeros((ncomp, 3))
    cnt = np.zeros(ncomp)
    for i in range(f.shape[0]):
        p = part[i]
        for j in range(3):
            for k in range(3):
                cen[p, k] += v[f[i, j], k]
        cnt[p] += 3.0
    for p in range(ncomp):
        for k in range(3):
            cen[p, k] /= max(cnt[p], 1.0)
    for i in range(f.shape[0]):
        p = part[i]
        ax = v[f[i, 0], 0] - cen[p, 0]
        ay = v[f[i, 0], 1] - cen[p, 1]
        az = v[f[i, 0], 2] - cen[p, 2]
        bx = v[f[i, 1], 0] - cen[p, 0]
        by = v[f[i, 1], 1] - cen[p, 1]
        bz = v[f[i, 1], 2] - cen[p, 2]
        cx = v[f[i, 2], 0] - cen[p, 0]
        cy = v[f[i, 2], 1] - cen[p, 1]
        cz = v[f[i, 2], 2] - cen[p, 2]
        vol[p] += ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx)


def _walk_cycles(starts: np.ndarray, ends: np.ndarray) -> list[list[int]]:
    """Split directed edges (in-degree = out-degree everywhere) into closed walks."""
    out: dict[int, list[int]] = {}
    for k, a in enumerate(starts.tolist()):
        out.setdefault(a, []).append(k)
    used = np.zeros(len(starts), dtype=bool)
    cycles = []
    for k0 in range(len(starts)):
        if used[k0]:
            continue
        cyc = []
        k = k0
        while not used[k]:
            used[k] = True
            cyc.append(int(starts[k]))
            nxt = out.get(int(ends[k]), [])
            while nxt and used[nxt[-1]]:
                nxt.pop()
            if not nxt:
                break
            k = nxt.pop()
        cycles.append(cyc)
    return cycles


def hole_loops(faces: np.ndarray, n_vertices: int) -> list[np.ndarray]:
    """The loops of unmatched half-edges (the rims of holes), each as the vertex
    indices in the order that balances the loop (the orientation a closing fan needs).

    Parameters
    ----------
    faces : (m, 3) int array
    n_vertices : int

    Returns
    -------
    list of (k,) int64 arrays, k >= 3
    """
    n = max(int(n_vertices), 1)
    uniq, bal = edge_balance(faces, n)
    bad = np.flatnonzero(bal != 0)
    if bad.size == 0:
        return []
    u, w, c = uniq[bad] // n, uniq[bad] % n, bal[bad]
    reps = np.abs(c)
    # c > 0: u->w is unmatched c times; c < 0: w->u is (the loop runs against it)
    s = np.repeat(np.where(c > 0, u, w), reps)
    e = np.repeat(np.where(c > 0, w, u), reps)
    return [np.asarray(cyc, dtype=np.int64) for cyc in _walk_cycles(s, e) if len(cyc) >= 3]


def close_holes(cage: Mesh, loops: list[np.ndarray] | None = None) -> tuple[Mesh, int]:
    """Close every hole: each loop of unmatched half-edges gets a centroid vertex
    and a fan of triangles with the orientation that balances the loop.

    ``loops`` are the mesh's :func:`hole_loops` when the caller has them. Returns the closed
    mesh and the number of holes closed.
    """
    loops = hole_loops(cage.faces, cage.n_vertices) if loops is None else loops
    if not loops:
        return cage, 0
    centres, fans = hole_fans(cage, loops)
    return Mesh(np.vstack([cage.vertices, centres]), np.vstack([cage.faces, fans]), name=cage.name), len(loops)


def hole_fans(cage: Mesh, loops: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The fans :func:`close_holes` adds: (h, 3) float64 the loops' centroids (the mesh's new
    vertices n .. n + h - 1) and (k, 3) int64 the triangles, one per loop edge."""
    nv = cage.n_vertices
    centres = np.array([cage.vertices[ring].mean(axis=0) for ring in loops]).reshape(-1, 3)
    fans = [np.stack([np.roll(ring, -1), ring, np.full(len(ring), nv + i)], axis=1) for i, ring in enumerate(loops)]
    return centres, (np.vstack(fans) if fans else np.zeros((0, 3), dtype=np.int64))


def box_cage(vertices: np.ndarray, pad: float = 0.05) -> Mesh:
    """A box around the points, padded by ``pad`` of the bounding-box diagonal
    (at least that fraction of the largest extent on every side): 8 vertices, 12
    outward triangles."""
    lo, hi = points_box(vertices)
    d = float(np.linalg.norm(hi - lo))
    if not d > 0:
        d = max(1.0, float(np.abs(lo).max()) * 1e-6)
    lo, hi = lo - pad * d, hi + pad * d
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    faces = np.array([
        [0, 1, 3], [0, 3, 2],  # x = lo
        [4, 6, 7], [4, 7, 5],  # x = hi
        [0, 4, 5], [0, 5, 1],  # y = lo
        [2, 3, 7], [2, 7, 6],  # y = hi
        [0, 2, 6], [0, 6, 4],  # z = lo
        [1, 5, 7], [1, 7, 3],  # z = hi
    ])
    return Mesh(corners, faces, name="cage")
