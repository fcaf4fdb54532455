"""What a view of a deforming shape needs each frame, for the region a drag can move (compiled kernels).

During a drag only the shape vertices the engine can move change
(``moving``); everything the window derives from the pose changes only near
them. :class:`ShapeMetrics` holds the index sets for one selection and the compiled
kernels update, in place (in parallel from the ``"window"`` size of
:data:`hybridedit.core.parallel.THRESHOLDS`, except the region's normals, which add each
face to its corners in one serial pass):

- the points written into the float32 VTK buffer (the moving rows only),
- the vertex normals (vertices of the faces that touch a moving vertex), by the rule files are
  saved with (:mod:`hybridedit.core.normals`),
- the relative RMS edge-length error (the terms of edges that touch a moving
  vertex; the others are summed once per selection),
- the stretch map (endpoints of those edges).

The normals and the edge error of a frame read the region's positions through a
compact copy: its vertices gathered once into a small array, and its faces and
edges numbered within it (made once per selection). Reading them scattered
through the whole shape missed the cache at every step: at 173K vertices with a
30% region, 11 ms a frame for the normals serially, 4.6 ms from the copy.

Pure compute (the window in :mod:`hybridedit.viewer` draws with it), so :mod:`hybridedit.warmup`
compiles these kernels with the engine's.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..core.bounds import grow_box
from ..core.index_sets import MASK_SHARE, union_in_range, unique_in_range
from ..core.mesh import unique_edges
from ..core.topology import incidence
from ..core.normals import accumulate_corners, face_terms, write_unit_rows, write_vertex_normals
from ..core.parallel import pick
from ..core.twins import Twins, twins
from ..core.row_copy import take_rows


@njit(cache=True, inline="always")
def _write_row(V, r, out):
    out[r, 0] = V[r, 0]
    out[r, 1] = V[r, 1]
    out[r, 2] = V[r, 2]


@twins()
def _write_rows(V, rows, out):
    for t in prange(rows.shape[0]):
        _write_row(V, rows[t], out)


@njit(cache=True)
def _rows_box(P, rows, box):
    for t in range(rows.shape[0]):
        grow_box(P, rows[t], box)


@njit(cache=True, inline="always")
def _edge_length(P, ends, t):
    """Length of edge ``ends[t]`` (two rows of P)."""
    a, b = ends[t, 0], ends[t, 1]
    dx, dy, dz = P[b, 0] - P[a, 0], P[b, 1] - P[a, 1], P[b, 2] - P[a, 2]
    return np.sqrt(dx * dx + dy * dy + dz * dz)


@twins()
def _lengths(P, ends, out):
    """Length of each edge ``ends[t]`` (rows of P) into ``out[t]``: no (e, 3) temporaries."""
    for t in prange(ends.shape[0]):
        out[t] = _edge_length(P, ends, t)


@njit(cache=True, inline="always")
def _edge_term(P, ends, rest_len, t, e, terms):
    l0 = rest_len[t]
    new = 0.0
    if l0 > 0.0:
        r = (_edge_length(P, ends, t) - l0) / l0
        new = r * r
    old = terms[e]
    terms[e] = new
    return new - old


@twins()
def _edge_terms(P, ends, rest_len, eidx, terms):
    """Squared relative length changes of the edges ``eidx`` into ``terms[eidx]``; returns the change of
    their sum. Edge ``eidx[t]`` joins rows ``ends[t]`` of P and had length ``rest_len[t]``."""
    delta = 0.0
    for t in prange(eidx.shape[0]):
        delta += _edge_term(P, ends, rest_len, t, eidx[t], terms)
    return delta


@njit(cache=True, inline="always")
def _stretch_of(terms, ve_ptr, ve_idx, v, out):
    s = 0.0
    n = ve_ptr[v + 1] - ve_ptr[v]
    for p in range(ve_ptr[v], ve_ptr[v + 1]):
        s += np.sqrt(terms[ve_idx[p]])
    out[v] = 100.0 * s / n if n > 0 else 0.0


@twins()
def _stretch(terms, ve_ptr, ve_idx, verts, out):
    for t in prange(verts.shape[0]):
        _stretch_of(terms, ve_ptr, ve_idx, verts[t], out)


def _pick(kernels: Twins, items: np.ndarray):
    return pick("window", *kernels, items.shape[0])


def _touching(ptr: np.ndarray, idx: np.ndarray, verts: np.ndarray, m: int) -> np.ndarray:
    """Sorted unique items (all in ``[0, m)``) of the CSR rows ``verts``: marked in an m-long mask
    by one pass over those rows."""
    mask = np.zeros(m, dtype=np.bool_)
    _mark_rows(ptr, idx, np.asarray(verts, dtype=np.int64), mask)
    return np.flatnonzero(mask)


@njit(cache=True)
def _mark_rows(ptr, idx, verts, mask):
    for t in range(verts.shape[0]):
        v = verts[t]
        for p in range(ptr[v], ptr[v + 1]):
            mask[idx[p]] = True


def _renumbered(vertices: np.ndarray, items: np.ndarray, n: int) -> np.ndarray:
    """``items`` (any shape; values in the sorted ``vertices``, all in ``[0, n)``) as positions in
    ``vertices``, int32: what ``np.searchsorted(vertices, items)`` gives, by a table when there
    are many."""
    if items.size < MASK_SHARE * n:
        return np.searchsorted(vertices, items).astype(np.int32)
    local = np.empty(n, dtype=np.int32)
    local[vertices] = np.arange(len(vertices), dtype=np.int32)
    return local[items]


class _Compact:
    """A moving region's own numbering, made once per selection: its vertices (those of the faces
    around the vertices whose normals change: (k,) sorted shape indices), those faces and the moving
    edges as rows of the compact positions P (k, 3), and the rows of P whose normals are written."""

    def __init__(self, metrics: "ShapeMetrics", normal_vertices: np.ndarray, moving_edges: np.ndarray) -> None:
        n = metrics.n
        faces = metrics.faces[_touching(metrics.vf_ptr, metrics.vf_idx, normal_vertices, len(metrics.faces))]
        self.vertices = union_in_range(faces, normal_vertices, n)  # (a vertex on no face keeps a zero normal)
        self.faces = _renumbered(self.vertices, faces, n)
        self.targets = _renumbered(self.vertices, normal_vertices, n).astype(np.int64)
        self.edges = _renumbered(self.vertices, metrics.edges[moving_edges], n)
        self.rest_len = np.ascontiguousarray(metrics.rest_len[moving_edges])
        self.P = np.empty((len(self.vertices), 3))
        self.acc = np.empty((len(self.vertices), 3))


class ShapeMetrics:
    """The per-frame quantities of one shape, updated for the moving region only.

    Parameters
    ----------
    rest : (n, 3) float64 rest positions; faces : (m, 3) int triangles.

    Attributes
    ----------
    edges : (e, 2) int64 unique edges.
    """

    def __init__(self, rest: np.ndarray, faces: np.ndarray) -> None:
        self.rest = np.ascontiguousarray(rest, dtype=np.float64)
        self.faces = np.ascontiguousarray(faces, dtype=np.int64)
        n = len(self.rest)
        self.n = n
        self.edges = unique_edges(self.faces)
        # (as mesh.edge_lengths, in one compiled pass: its (e, 3) temporaries took 11 s at 11M)
        self.rest_len = np.empty(len(self.edges))
        _pick(_lengths, self.edges)(self.rest, self.edges, self.rest_len)
        self.n_ok = int(np.count_nonzero(self.rest_len > 0))
        self.vf_ptr, self.vf_idx = incidence(self.faces, n)
        self.ve_ptr, self.ve_idx = incidence(self.edges, n)
        self.all_vertices = np.arange(n, dtype=np.int64)
        self.terms = np.zeros(len(self.edges))
        self.total = 0.0
        self.set_moving(None)

    def set_moving(self, moving: np.ndarray | None) -> None:
        """Restrict the updates to the shape vertices ``moving`` (k,) int (None: all of them)."""
        self._compact = None
        if moving is None:  # (the edges: all of them, numbered when a whole-shape pass needs them)
            self.moving = self.normal_vertices = self.stretch_vertices = self.all_vertices
            self.moving_edges = None
            return
        n = self.n
        self.moving = unique_in_range(np.asarray(moving, dtype=np.int64), n)
        moving_faces = _touching(self.vf_ptr, self.vf_idx, self.moving, len(self.faces))
        self.normal_vertices = unique_in_range(self.faces[moving_faces], n) if len(moving_faces) \
            else self.moving
        self.moving_edges = _touching(self.ve_ptr, self.ve_idx, self.moving, len(self.edges))
        self.stretch_vertices = unique_in_range(self.edges[self.moving_edges], n) if len(self.moving_edges) \
            else self.moving
        self._compact = _Compact(self, self.normal_vertices, self.moving_edges)

    # ------------------------------------------------------------------ updates (in place)
    def write_points(self, V: np.ndarray, out: np.ndarray, *, everything: bool = False) -> None:
        """Copy the moving rows of V (n, 3) into ``out`` (n, 3), e.g. a float32 VTK buffer."""
        rows = self.all_vertices if everything else self.moving
        _pick(_write_rows, rows)(V, rows, out)

    def moving_box(self, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi) (3,) float64 corners of the box around the moving rows of P (n, 3) (float32)."""
        box = np.empty((2, 3))
        box[0], box[1] = np.inf, -np.inf
        _rows_box(P, self.moving, box)
        return box[0], box[1]

    def write_normals(self, V: np.ndarray, out: np.ndarray, *, everything: bool = False) -> None:
        """Vertex normals of V (:mod:`hybridedit.core.normals`: angle-weighted, unit, the ones files are
        saved with) into ``out`` (n, 3) where the moving region changes them (every vertex with
        ``everything`` or when nothing restricts the updates)."""
        c = self._compact
        if everything or c is None:
            # unit normals and corner angles of every face: (m, 6) float64 for this pass only (1 GB at 11M)
            terms = np.empty((len(self.faces), 6))
            face_terms(V, self.faces, np.arange(len(self.faces)), terms)
            write_vertex_normals(self.faces, terms, self.vf_ptr, self.vf_idx, self.all_vertices, out)
            return
        take_rows(V, c.vertices, out=c.P)
        c.acc[:] = 0.0
        accumulate_corners(c.P, c.faces, c.faces, c.acc)
        write_unit_rows(c.acc, c.targets, self.normal_vertices, out)

    def update_error(self, V: np.ndarray, *, everything: bool = False) -> float:
        """The relative RMS edge-length error of V in percent (as :func:`hybridedit.core.mesh.rrms_edge_error`).

        The pose outside the moving region must be the one of the last call with ``everything``.
        """
        c = self._compact
        if everything:
            self.terms[:] = 0.0
            self.total = 0.0
        if everything or c is None:
            eidx = np.arange(len(self.edges))
            self.total += _pick(_edge_terms, eidx)(V, self.edges, self.rest_len, eidx, self.terms)
        else:
            eidx = self.moving_edges
            take_rows(V, c.vertices, out=c.P)
            self.total += _pick(_edge_terms, eidx)(c.P, c.edges, c.rest_len, eidx, self.terms)
        if self.n_ok == 0:
            return 0.0
        return float(np.sqrt(max(self.total, 0.0) / self.n_ok) * 100.0)

    def write_stretch(self, out: np.ndarray, *, everything: bool = False) -> None:
        """Per vertex mean |relative edge-length change| in percent into ``out`` (n,), from the
        terms of the last :meth:`update_error` (call it first with the same pose)."""
        verts = self.all_vertices if everything else self.stretch_vertices
        _pick(_stretch, verts)(self.terms, self.ve_ptr, self.ve_idx, verts, out)
