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

import numba
import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from .mesh import Mesh, MeshError

__all__ = ["cage_source", "close_holes", "box_cage", "plural", "MERGE_TOLERANCE"]

#: vertices closer than this fraction of the bounding-box diagonal are merged
MERGE_TOLERANCE = 1e-9


def plural(n: int, word: str, many: str | None = None) -> str:
    """'1 face', '3 faces'."""
    return f"{n:,} {word if n == 1 else (many or word + 's')}"


def _diagonal(v: np.ndarray) -> float:
    if len(v) == 0:
        return 0.0
    return float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))


def _group_rows(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Group equal rows of an (n, k) int64 array.

    Returns (first, group): ``first`` holds the index of each group's first row, in
    input order; ``group[i]`` is the group of row i (groups numbered in order of
    first occurrence).
    """
    n = len(keys)
    if n == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    order = np.lexsort(keys.T[::-1])  # stable: equal rows keep input order
    ks = keys[order]
    start = np.ones(n, dtype=bool)
    start[1:] = np.any(ks[1:] != ks[:-1], axis=1)
    gid_sorted = np.cumsum(start) - 1
    first_sorted = order[start]  # first occurrence of each group
    rank = np.empty(len(first_sorted), dtype=np.int64)
    by_first = np.argsort(first_sorted, kind="stable")
    rank[by_first] = np.arange(len(first_sorted))
    group = np.empty(n, dtype=np.int64)
    group[order] = rank[gid_sorted]
    return first_sorted[by_first], group


def merge_close_vertices(vertices: np.ndarray, faces: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray, int]:
    """Merge vertices that fall in the same cell of a grid of spacing ``tol``.

    Only referenced vertices are kept. Returns (vertices, faces, merged) where
    ``merged`` counts referenced vertices that were folded into another one.
    """
    used_mask = np.zeros(len(vertices), dtype=bool)
    used_mask[faces.ravel()] = True
    used = np.flatnonzero(used_mask)
    v = vertices[used]
    lo = v.min(axis=0) if len(v) else np.zeros(3)
    if tol > 0:
        key = np.floor((v - lo) / tol).astype(np.int64)
    else:
        key = (v + 0.0).view(np.int64)  # exact equality (-0.0 == 0.0)
    first, group = _group_rows(key)
    remap = np.full(len(vertices), -1, dtype=np.int64)
    remap[used] = group
    return v[first], remap[faces], int(len(v) - len(first))


def _half_edge_keys(f: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    a = f.ravel()
    b = f[:, [1, 2, 0]].ravel()
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    return lo * n + hi, a < b, np.repeat(np.arange(len(f)), 3)


def _drop_nonmanifold(f: np.ndarray, n: int) -> tuple[np.ndarray, int]:
    """Drop faces (latest first) until no edge is used by more than two faces."""
    dropped = 0
    for _ in range(10):
        key, _, face = _half_edge_keys(f, n)
        order = np.argsort(key, kind="stable")
        ks = key[order]
        start = np.ones(len(ks), dtype=bool)
        start[1:] = ks[1:] != ks[:-1]
        group_start = np.maximum.accumulate(np.where(start, np.arange(len(ks)), 0))
        rank = np.arange(len(ks)) - group_start  # 0, 1, 2, ... within an edge
        bad_faces = np.unique(face[order][rank >= 2])
        if bad_faces.size == 0:
            break
        keep = np.ones(len(f), dtype=bool)
        keep[bad_faces] = False
        f = f[keep]
        dropped += int(bad_faces.size)
    return f, dropped


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
    key, fwd, face = _half_edge_keys(f, n)
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
    # outward: positive signed volume per part (relative to its centroid, for precision)
    fc = (v[out[:, 0]] + v[out[:, 1]] + v[out[:, 2]]) / 3.0
    cen = np.stack([np.bincount(comp, fc[:, k], minlength=ncomp) for k in range(3)], axis=1)
    cen /= np.maximum(np.bincount(comp, minlength=ncomp), 1)[:, None]
    p0 = v[out[:, 0]] - cen[comp]
    p1 = v[out[:, 1]] - cen[comp]
    p2 = v[out[:, 2]] - cen[comp]
    vol = np.bincount(comp, np.einsum("ij,ij->i", p0, np.cross(p1, p2)), minlength=ncomp)
    inward = vol < 0
    if np.any(inward):
        sel = inward[comp]
        out[sel] = out[sel][:, [0, 2, 1]]
        fl ^= sel
    return out, int(np.count_nonzero(fl)), conflicts == 0


def cage_source(mesh: Mesh) -> tuple[Mesh, list[str]]:
    """A cleaned copy of ``mesh`` to simplify into a cage, and what was changed.

    Merges duplicate vertices (exactly or nearly equal positions, within
    :data:`MERGE_TOLERANCE` of the bounding-box diagonal), leaves out
    unreferenced vertices, drops degenerate (repeated-index or zero-area) and
    duplicate faces, drops faces beyond the second on non-manifold edges, and
    orients faces consistently per connected part (outward where a part
    encloses volume).  ``mesh`` is not modified.

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
    diag = _diagonal(v0[used])
    v, f, merged = merge_close_vertices(v0, f, MERGE_TOLERANCE * diag)
    if merged:
        notes.append(f"merged {plural(merged, 'duplicate vertex', 'duplicate vertices')}")
    # degenerate faces: repeated index, or zero area relative to the longest edge
    rep = (f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 2] == f[:, 0])
    p0, p1, p2 = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    area2 = np.linalg.norm(np.cross(p1 - p0, p2 - p0), axis=1)
    longest = np.max([np.einsum("ij,ij->i", d, d) for d in (p1 - p0, p2 - p1, p0 - p2)], axis=0)
    flat = area2 <= 1e-12 * longest
    bad = rep | flat
    if np.any(bad):
        f = f[~bad]
        notes.append(f"dropped {plural(int(bad.sum()), 'degenerate face')} (zero area or a repeated vertex)")
    if len(f) == 0:
        raise MeshError(f"{label}every face is degenerate (zero area); there is no surface to edit")
    # duplicate faces (same three vertices, either orientation): keep the first
    first, _ = _group_rows(np.sort(f, axis=1))
    if len(first) < len(f):
        notes.append(f"dropped {plural(len(f) - len(first), 'duplicate face')}")
        f = f[np.sort(first)]
    f, dropped = _drop_nonmanifold(f, len(v))
    if dropped:
        notes.append(f"dropped {plural(dropped, 'face')} at non-manifold edges (edges shared by more than two faces)")
    # compact again (merging and dropping can leave vertices unused)
    keep = np.zeros(len(v), dtype=bool)
    keep[f.ravel()] = True
    remap = np.cumsum(keep) - 1
    v, f = v[keep], remap[f]
    f, flipped, orientable = orient_faces(v, f)
    if flipped:
        notes.append(f"re-oriented {plural(flipped, 'face')}")
    if not orientable:
        notes.append("the surface is not orientable; some faces keep a conflicting orientation")
    n = len(v)
    g = sp.coo_matrix((np.ones(3 * len(f), dtype=np.int8), (f.ravel(), f[:, [1, 2, 0]].ravel())), shape=(n, n))
    parts, _ = connected_components(g, directed=False)
    if parts > 1:
        notes.append(f"{parts:,} disconnected parts")
    return Mesh(v, f, name=mesh.name), notes


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


def close_holes(cage: Mesh) -> tuple[Mesh, int]:
    """Close every hole: each loop of unmatched half-edges gets a centroid vertex
    and a fan of triangles with the orientation that balances the loop.

    Returns the closed mesh and the number of holes closed.
    """
    f = cage.faces
    n = cage.n_vertices
    a = f.ravel()
    b = f[:, [1, 2, 0]].ravel()
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    key = lo * max(n, 1) + hi
    uniq, inv = np.unique(key, return_inverse=True)
    bal = np.bincount(inv.reshape(-1), weights=np.where(a < b, 1, -1), minlength=len(uniq)).astype(np.int64)
    bad = np.flatnonzero(bal != 0)
    if bad.size == 0:
        return cage, 0
    s, e = [], []
    for k in bad.tolist():
        u, w = int(uniq[k] // n), int(uniq[k] % n)
        c = int(bal[k])
        # c > 0: u->w is unmatched c times; c < 0: w->u is
        for _ in range(abs(c)):
            s.append(u if c > 0 else w)
            e.append(w if c > 0 else u)
    cycles = _walk_cycles(np.asarray(s), np.asarray(e))
    v = [cage.vertices]
    new_faces = [f]
    nv = n
    holes = 0
    for cyc in cycles:
        if len(cyc) < 3:
            continue
        holes += 1
        ring = np.asarray(cyc)
        v.append(cage.vertices[ring].mean(axis=0)[None])
        nxt = np.roll(ring, -1)
        new_faces.append(np.stack([nxt, ring, np.full(len(ring), nv)], axis=1))
        nv += 1
    return Mesh(np.vstack(v), np.vstack(new_faces), name=cage.name), holes


def box_cage(vertices: np.ndarray, pad: float = 0.05) -> Mesh:
    """A box around the points, padded by ``pad`` of the bounding-box diagonal
    (at least that fraction of the largest extent on every side): 8 vertices, 12
    outward triangles."""
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
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
