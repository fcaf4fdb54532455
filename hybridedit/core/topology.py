"""Mesh topology in one place: edge keys, closedness, welding, connected parts, degenerate faces.

Every module that asks "is this surface closed?", "which faces are degenerate?",
"which vertices coincide?" or "which parts are connected?" asks it here, so that
the cage, the repair pass and ``hybridedit info`` agree on the answer.
"""

from __future__ import annotations

import numba
import numpy as np

from .parallel import pick
from .twins import twins
from .bounds import points_box

__all__ = [
    "DEGENERATE_RATIO",
    "check_closed",
    "connected_parts",
    "degenerate_faces",
    "edge_balance",
    "edge_face_counts",
    "edges_by_first_use",
    "vertices_by_first_use",
    "edge_index",
    "group_rows",
    "incidence",
    "half_edges",
    "is_closed_oriented",
    "oriented_rim",
    "weld",
]

#: A face is degenerate when it repeats a vertex index or when twice its area is at
#: most this fraction of its longest edge squared (its height is below this fraction
#: of its longest edge): a needle or a flattened triangle that has no direction.
DEGENERATE_RATIO = 1e-12


def half_edges(faces: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The 3m half-edges of the faces, face by face (a->b, b->c, c->a).

    Parameters
    ----------
    faces : (m, 3) int array
    n_vertices : int
        All indices are below it.

    Returns
    -------
    key : (3m,) int64, the undirected edge key ``min * n + max``
    forward : (3m,) bool, True where the half-edge runs from the lower index to the higher
    face : (3m,) int64, the face of each half-edge
    """
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    a = f.ravel()
    b = f[:, [1, 2, 0]].ravel()
    n = max(int(n_vertices), 1)
    return np.minimum(a, b) * n + np.maximum(a, b), a < b, np.repeat(np.arange(len(f), dtype=np.int64), 3)


def edge_index(faces: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """The undirected edges of the faces and, for each half-edge, its edge, in linear time.

    What ``np.unique(min(a, b) * n + max(a, b), return_inverse=True)`` gives for
    the half-edges a->b (face by face: a->b, b->c, c->a), without sorting 3m keys:
    the half-edges are bucketed by their lower vertex and each (small) bucket is
    ordered by the higher one. Self-loops (a face repeating an index) are edges
    (a, a) as there.

    Parameters
    ----------
    faces : (m, 3) int array
    n_vertices : int
        All indices are below it.

    Returns
    -------
    edges : (e, 2) int64, rows sorted, column 0 <= column 1
    inverse : (3m,) int64, the row of ``edges`` of each half-edge

    Examples
    --------
    >>> edges, inverse = edge_index(np.array([[0, 1, 2], [2, 1, 3]]), 4)
    >>> edges.tolist(), inverse.tolist()
    ([[0, 1], [0, 2], [1, 2], [1, 3], [2, 3]], [0, 2, 1, 2, 3, 4])
    """
    f = np.ascontiguousarray(np.asarray(faces, dtype=np.int64).reshape(-1, 3))
    if f.size == 0:
        return np.zeros((0, 2), dtype=np.int64), np.zeros(0, dtype=np.int64)
    n = max(int(n_vertices), int(f.max()) + 1)
    # each bucket holds its half-edges' higher vertex beside the half-edge itself (a bucket's sort
    # then reads them in order, not scattered through a shape-sized array), narrow where they fit
    far = np.empty(f.size, dtype=np.int32 if n < 2**31 else np.int64)
    half = np.empty(f.size, dtype=np.int32 if f.size < 2**31 else np.int64)
    return _edge_index(f, n, far, half)


@numba.njit(cache=True, nogil=True)
def _edge_index(f, n, far, half):  # pragma: no cover - compiled
    h = 3 * f.shape[0]
    start = np.zeros(n + 1, dtype=np.int64)
    for t in range(f.shape[0]):
        for c in range(3):
            start[min(f[t, c], f[t, (c + 1) % 3]) + 1] += 1
    for i in range(n):
        start[i + 1] += start[i]
    pos = start[:-1].copy()
    for t in range(f.shape[0]):  # by lower vertex, half-edge order kept within a bucket
        for c in range(3):
            a, b = f[t, c], f[t, (c + 1) % 3]
            lo = min(a, b)
            far[pos[lo]] = max(a, b)
            half[pos[lo]] = 3 * t + c
            pos[lo] += 1
    count = np.zeros(n + 1, dtype=np.int64)
    for v in range(n):
        s, t = start[v], start[v + 1]
        if t - s > 32:  # a vertex of high degree: a stable sort of its bucket
            o = np.argsort(far[s:t], kind="mergesort")
            far[s:t], half[s:t] = far[s:t][o], half[s:t][o]
        else:  # insertion sort (stable) of the few half-edges at a vertex
            for i in range(s + 1, t):
                x, k = far[i], half[i]
                j = i - 1
                while j >= s and far[j] > x:
                    far[j + 1], half[j + 1] = far[j], half[j]
                    j -= 1
                far[j + 1], half[j + 1] = x, k
        u = 0
        for i in range(s, t):
            if i == s or far[i] != far[i - 1]:
                u += 1
        count[v + 1] = count[v] + u
    edges = np.empty((count[n], 2), dtype=np.int64)
    inverse = np.empty(h, dtype=np.int64)
    for v in range(n):
        e = count[v] - 1
        for i in range(start[v], start[v + 1]):
            if i == start[v] or far[i] != far[i - 1]:
                e += 1
                edges[e, 0] = v
                edges[e, 1] = far[i]
            inverse[half[i]] = e
    return edges, inverse


def edges_by_first_use(faces: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The undirected edges of the faces numbered in the order the half-edges first use them.

    What ``np.unique`` of the edge keys ``min(a, b) * n + max(a, b)`` with ``return_index`` and
    ``return_inverse``, renumbered by first occurrence, gives, in linear time
    (:func:`edge_index`, then one pass over the half-edges a->b, b->c, c->a face by face).

    Parameters
    ----------
    faces : (m, 3) int array
    n_vertices : int
        All indices are below it.

    Returns
    -------
    edges : (e, 2) int64, column 0 <= column 1, edge k the k-th to be used
    face_edges : (m, 3) int64, the edge of each half-edge
    first : (e,) int64, increasing: the half-edge (3 t + c) that first uses each edge

    Examples
    --------
    >>> edges, face_edges, first = edges_by_first_use(np.array([[2, 1, 0], [1, 2, 3]]), 4)
    >>> edges.tolist(), face_edges.tolist(), first.tolist()
    ([[1, 2], [0, 1], [0, 2], [2, 3], [1, 3]], [[0, 1, 2], [0, 3, 4]], [0, 1, 2, 4, 5])
    """
    f = np.ascontiguousarray(np.asarray(faces, dtype=np.int64).reshape(-1, 3))
    sorted_edges, inverse = edge_index(f, n_vertices)
    return _by_first_use(sorted_edges, inverse, f.shape[0])


@numba.njit(cache=True, nogil=True)
def _by_first_use(sorted_edges, inverse, m):  # pragma: no cover - compiled
    e = sorted_edges.shape[0]
    rank = np.full(e, -1, dtype=np.int64)
    first = np.empty(e, dtype=np.int64)
    edges = np.empty((e, 2), dtype=np.int64)
    face_edges = np.empty((m, 3), dtype=np.int64)
    k = 0
    for h in range(3 * m):
        q = inverse[h]
        if rank[q] < 0:
            rank[q] = k
            first[k] = h
            edges[k, 0] = sorted_edges[q, 0]
            edges[k, 1] = sorted_edges[q, 1]
            k += 1
        face_edges[h // 3, h % 3] = rank[q]
    return edges, face_edges, first


def vertices_by_first_use(faces: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """The vertices the faces use, in the order the corners first use them, in linear time: what
    ``np.unique(faces.ravel(), return_index=True)`` gives, ordered by first occurrence.

    Parameters
    ----------
    faces : (m, 3) int array
    n_vertices : int
        All indices are below it.

    Returns
    -------
    used : (u,) int64, the used vertices by first use
    first : (u,) int64, increasing: the corner (3 t + c) that first uses each

    Examples
    --------
    >>> used, first = vertices_by_first_use(np.array([[2, 1, 0], [1, 2, 3]]), 5)
    >>> used.tolist(), first.tolist()
    ([2, 1, 0, 3], [0, 1, 2, 5])
    """
    f = np.ascontiguousarray(np.asarray(faces, dtype=np.int64).reshape(-1, 3))
    return _vertices_by_first_use(f.ravel(), int(n_vertices))


@numba.njit(cache=True, nogil=True)
def _vertices_by_first_use(corners, n):  # pragma: no cover - compiled
    seen = np.zeros(n, dtype=np.bool_)
    used = np.empty(min(n, corners.shape[0]), dtype=np.int64)
    first = np.empty(used.shape[0], dtype=np.int64)
    k = 0
    for h in range(corners.shape[0]):
        v = corners[h]
        if not seen[v]:
            seen[v] = True
            used[k] = v
            first[k] = h
            k += 1
    return used[:k].copy(), first[:k].copy()


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
    n = max(int(n_vertices), 1)
    a = f.ravel()
    b = f[:, [1, 2, 0]].ravel()
    keep = a != b
    # a face with exactly two distinct indices yields the same edge twice
    equal_pairs = ((f[:, 0] == f[:, 1]).astype(np.int64) + (f[:, 1] == f[:, 2]) + (f[:, 2] == f[:, 0]))
    twice = np.repeat(equal_pairs == 1, 3) & keep
    if twice.any():
        rows = np.flatnonzero(twice).reshape(-1, 2)
        keep[rows[:, 1]] = False
    edges, inverse = edge_index(f, n)
    counts = np.bincount(inverse[keep], minlength=len(edges))
    used = counts > 0  # self-loops and the second copy of a doubled edge are not counted
    return edges[used], counts[used].astype(np.int64)


def edge_balance(faces: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """Per undirected edge, how many more times it is used low->high than high->low.

    A closed, consistently oriented surface has balance 0 on every edge; a hole's
    rim has +-1.

    Returns
    -------
    keys : (e,) int64 sorted undirected edge keys (``min * n + max``)
    balance : (e,) int64
    """
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    n = max(int(n_vertices), 1)
    edges, inverse = edge_index(f, n)
    forward = f.ravel() < f[:, [1, 2, 0]].ravel()
    bal = np.bincount(inverse, weights=np.where(forward, 1, -1), minlength=len(edges))
    return edges[:, 0] * n + edges[:, 1], bal.astype(np.int64)


def check_closed(faces: np.ndarray) -> None:
    """Raise ``ValueError`` unless the triangles form a closed, oriented surface.

    Closed here means that every undirected edge is used as often in one
    direction as in the other, which is what makes mean value coordinates
    reproduce linear functions (non-manifold edges are fine as long as they
    balance).

    Parameters
    ----------
    faces : (m, 3) int array
    """
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if f.size == 0:
        raise ValueError("the cage has no faces")
    if np.any((f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 2] == f[:, 0])):
        raise ValueError("the cage has a face with a repeated vertex index")
    n = int(f.max()) + 1
    keys, bal = edge_balance(f, n)
    bad = np.flatnonzero(bal != 0)
    if bad.size:
        k = int(keys[bad[0]])
        raise ValueError(
            f"the cage is not a closed, consistently oriented surface: {bad.size} edge(s) "
            f"are unbalanced, e.g. edge ({k // n}, {k % n})"
        )


def is_closed_oriented(faces: np.ndarray, n_vertices: int) -> bool:
    """True when every directed edge is used exactly once and its reverse exactly once.

    That is a closed, edge-manifold, consistently oriented surface (a linear-time check: no
    repair needed; :func:`oriented_rim` with no rim).

    Parameters
    ----------
    faces : (m, 3) int array
    n_vertices : int
    """
    rim = oriented_rim(faces, n_vertices)
    return rim is not None and not rim.any()


def oriented_rim(faces: np.ndarray, n_vertices: int) -> np.ndarray | None:
    """The rim of an edge-manifold, consistently oriented surface, open or closed.

    Every directed edge used at most once means at most two faces an edge, turned against each
    other: what a scan with holes and a closed surface both are, and what the repair pass would
    leave as it is (a linear-time check, like :func:`is_closed_oriented`).

    Parameters
    ----------
    faces : (m, 3) int array
    n_vertices : int

    Returns
    -------
    (n,) bool, the vertices with an outgoing edge no face matches (the holes' rims: all False for
    a closed surface), or None when some directed edge is used twice, a face repeats a vertex or
    there is no face.

    Examples
    --------
    >>> oriented_rim(np.array([[0, 1, 2], [0, 2, 3]]), 4).tolist()
    [True, True, True, True]
    >>> oriented_rim(np.array([[0, 1, 2], [0, 1, 3]]), 4) is None  # (0 -> 1 twice)
    True
    """
    f = np.ascontiguousarray(faces, dtype=np.int64).reshape(-1, 3)
    if len(f) == 0 or int(f.min()) < 0:
        return None
    n = max(int(n_vertices), int(f.max()) + 1)
    # each vertex's outgoing half-edges by a counting sort: numpy's bincount counts them, and the
    # heads are narrow where they fit (the 66M half-edges of an 11M shape in 264 MB, not 528: this
    # pass and the next are bound by memory)
    start = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(f.ravel(), minlength=n), out=start[1:])
    out = np.empty(3 * len(f), dtype=np.int32 if n < 2**31 else np.int64)
    if not _outgoing(f, start, out):
        return None
    bad = np.zeros(n, dtype=np.bool_)
    rim = np.zeros(n, dtype=np.bool_)
    pick("faces", *_rims, len(f))(start, out, bad, rim)
    return None if bad.any() else rim[:int(n_vertices)]


@numba.njit(cache=True, inline="always")
def _rim_at(a, start, out, bad, rim):
    """bad[a] when a half-edge a -> b is there twice or b -> a more than once; rim[a] when some
    a -> b has no b -> a."""
    for k in range(start[a], start[a + 1]):
        b = out[k]
        for k2 in range(k + 1, start[a + 1]):
            if out[k2] == b:
                bad[a] = True
                return
        back = 0
        for k2 in range(start[b], start[b + 1]):
            if out[k2] == a:
                back += 1
        if back > 1:
            bad[a] = True
            return
        if back == 0:
            rim[a] = True


@twins()
def _rims(start, out, bad, rim):  # pragma: no cover - compiled
    for a in numba.prange(bad.shape[0]):
        _rim_at(a, start, out, bad, rim)


@numba.njit(cache=True)
def _outgoing(f, start, out):  # pragma: no cover - compiled
    """Each vertex's outgoing half-edges' heads into ``out`` (3 m,), grouped by vertex as
    ``start`` (n + 1,) counts them; False for a face repeating an index."""
    head = start[:-1].copy()
    for i in range(f.shape[0]):
        for j in range(3):
            a = f[i, j]
            b = f[i, (j + 1) % 3]
            if a == b:
                return False
            out[head[a]] = b
            head[a] += 1
    return True


@twins()
def _degenerate(v, f, ratio, out):  # pragma: no cover - compiled
    for i in numba.prange(f.shape[0]):
        _degenerate_one(v, f, ratio, out, i)


@numba.njit(cache=True, inline="always")
def _degenerate_one(v, f, ratio, out, i):  # pragma: no cover - compiled
    i0, i1, i2 = f[i, 0], f[i, 1], f[i, 2]
    if i0 == i1 or i1 == i2 or i2 == i0:
        out[i] = True
        return
    ax = v[i1, 0] - v[i0, 0]
    ay = v[i1, 1] - v[i0, 1]
    az = v[i1, 2] - v[i0, 2]
    bx = v[i2, 0] - v[i0, 0]
    by = v[i2, 1] - v[i0, 1]
    bz = v[i2, 2] - v[i0, 2]
    cx = ay * bz - az * by
    cy = az * bx - ax * bz
    cz = ax * by - ay * bx
    area2 = np.sqrt(cx * cx + cy * cy + cz * cz)
    la = ax * ax + ay * ay + az * az
    lb = bx * bx + by * by + bz * bz
    dx, dy, dz = bx - ax, by - ay, bz - az
    lc = dx * dx + dy * dy + dz * dz
    longest = max(la, max(lb, lc))
    # NaN compares false: a face with a non-finite corner counts as degenerate
    out[i] = not (area2 > ratio * longest)


def degenerate_faces(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Which faces are degenerate: a repeated index, or twice the area at most
    :data:`DEGENERATE_RATIO` times the longest edge squared.

    Parameters
    ----------
    vertices : (n, 3) float array
    faces : (m, 3) int array

    Returns
    -------
    (m,) bool
    """
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int64).reshape(-1, 3)
    out = np.zeros(len(f), dtype=bool)
    if len(f):
        # below THRESHOLDS["faces"] on one thread: starting the pool costs more than the work
        pick("faces", *_degenerate, len(f))(v, f, DEGENERATE_RATIO, out)
    return out


def group_rows(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Group equal rows of an (n, k) int64 array.

    Returns
    -------
    first : (g,) int64, the index of each group's first row, in input order
    group : (n,) int64, the group of each row (groups numbered in order of first occurrence)
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


def incidence(items: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """CSR of which rows of ``items`` touch each of ``n`` keys, by a counting sort (linear).

    Parameters
    ----------
    items : (m, k) int array, every value in ``[0, n)`` (vertex indices of faces or edges, or a
        (m, 1) column of bucket numbers).
    n : int, the number of keys.

    Returns
    -------
    ptr : (n + 1,) int64 pointers.
    rows : (m k,) int32 below 2**31 rows (half the memory: 264 MB of the faces' at 11M), else
        int64; each key's rows in increasing order.

    Examples
    --------
    >>> ptr, rows = incidence(np.array([[0, 1, 2], [2, 1, 3]]), 4)
    >>> ptr.tolist(), rows.tolist()
    ([0, 1, 3, 5, 6], [0, 0, 1, 0, 1, 1])
    """
    ptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(items.ravel(), minlength=n), out=ptr[1:])
    rows = np.empty(items.size, dtype=np.int32 if len(items) < 2**31 else np.int64)
    _fill_incidence(np.ascontiguousarray(items), ptr, rows)
    return ptr, rows


@numba.njit(cache=True)
def _fill_incidence(items, ptr, rows):
    at = ptr[:-1].copy()
    for i in range(items.shape[0]):
        for j in range(items.shape[1]):
            v = items[i, j]
            rows[at[v]] = i
            at[v] += 1


def weld(vertices: np.ndarray, faces: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Merge the referenced vertices that fall in the same cell of a grid of spacing ``tol``.

    ``tol = 0`` merges exactly equal positions only (-0.0 equals 0.0).

    Parameters
    ----------
    vertices : (n, 3) float array
    faces : (m, 3) int array
    tol : float >= 0

    Returns
    -------
    vertices : (k, 3) the kept vertices (first of each group, in input order)
    faces : (m, 3) int64 faces on them
    remap : (n,) int64, the kept vertex of each input vertex, -1 for unreferenced ones
    merged : int, referenced vertices folded into another one
    """
    v0 = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    used_mask = np.zeros(len(v0), dtype=bool)
    used_mask[f.ravel()] = True
    used = np.flatnonzero(used_mask)
    v = v0[used]
    lo = points_box(v)[0] if len(v) else np.zeros(3)
    if tol > 0:
        key = np.floor((v - lo) / tol).astype(np.int64)
    else:
        key = (v + 0.0).view(np.int64)
    first, group = group_rows(key)
    remap = np.full(len(v0), -1, dtype=np.int64)
    remap[used] = group
    return v[first], remap[f], remap, int(len(v) - len(first))


def connected_parts(faces: np.ndarray, n_vertices: int) -> tuple[int, np.ndarray]:
    """Connected parts of a surface (faces sharing a vertex are connected).

    Parameters
    ----------
    faces : (m, 3) int array
    n_vertices : int

    Returns
    -------
    count : int, the number of parts (unreferenced vertices form none)
    labels : (n,) int64, the part of each vertex numbered 0..count-1 in order of
        first vertex, -1 for vertices no face uses
    """
    f = np.ascontiguousarray(faces, dtype=np.int64).reshape(-1, 3)
    n = int(n_vertices)
    labels = np.full(n, -1, dtype=np.int64)
    if len(f) == 0 or n == 0:
        return 0, labels
    return int(_parts(f, labels)), labels


@numba.njit(cache=True)
def _find(parent, a):  # pragma: no cover - compiled
    while parent[a] != a:
        parent[a] = parent[parent[a]]
        a = parent[a]
    return a


@numba.njit(cache=True)
def _parts(f, labels):  # pragma: no cover - compiled
    """Union-find over the face edges; labels numbered by first vertex, -1 unused."""
    n = labels.shape[0]
    parent = np.arange(n)
    used = np.zeros(n, dtype=np.bool_)
    for i in range(f.shape[0]):
        r0 = _find(parent, f[i, 0])
        used[f[i, 0]] = True
        for j in range(1, 3):
            used[f[i, j]] = True
            r = _find(parent, f[i, j])
            if r != r0:
                if r < r0:
                    parent[r0] = r
                    r0 = r
                else:
                    parent[r] = r0
    count = 0
    number = np.full(n, -1, dtype=np.int64)
    for a in range(n):
        if used[a]:
            r = _find(parent, a)
            if number[r] < 0:
                number[r] = count
                count += 1
            labels[a] = number[r]
    return count


def repeats_a_face(f: np.ndarray, n: int) -> bool:
    """Whether two faces use the same three vertices (either orientation); a quick
    one-key sort where the vertex count allows it (the usual case: no repeat).

    Parameters
    ----------
    f : (m, 3) int array of faces; n : the vertex count (every index below it)
    """
    if n >= 2_097_152:  # n**3 would overflow int64
        return True
    key = np.sort(f, axis=1)
    key = np.sort((key[:, 0] * n + key[:, 1]) * n + key[:, 2])
    return bool(np.any(key[1:] == key[:-1]))
