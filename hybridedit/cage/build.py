"""The control mesh and the binding to it: one closed cage piece per connected part of the shape.

Each part is simplified by quadric error metrics to its share of the vertex budget
(a tiny part is its own cage, an open surface is wrapped in a thin closed shell), its
vertices are bound only to its own piece (M is block-diagonal over the parts), and
:func:`cage_links` ties a piece that sits inside or against a bigger one to it for ARAP.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import fast_simplification

from ..core.mesh import Mesh
from ..defaults import CAGE_SIZE, TRUNCATION, check_cage_size
from .qem import HalfWorker, presimplify, start_worker
from .qem_worker import AGGRESSIVENESS
from ..core.topology import check_closed, connected_parts, degenerate_faces, repeats_a_face


#: a part whose cage would keep at least this fraction of its vertices is its own cage
OWN_CAGE_FRACTION = 0.75
#: the fewest vertices a simplified cage part gets (a smaller part is its own cage)
MIN_PART_CAGE = 32
#: an open part whose holes, closed with fans, add less than this share of its area (a
#: scan with holes, a head open at the neck, a statue open at its base), or that closed is
#: at least :data:`MIN_ROUNDNESS` round (a bowl, a band of a body cut across), is simplified
#: and its cage's holes are closed: the cage stays a closed volume around the shape, where
#: mean value coordinates are positive and local. A part whose rim encloses about as much as
#: the part itself and that closed is flat (a sheet, a terrain, a cloth, a relief) has no
#: volume to close: it gets a thin closed shell
MAX_CAP_SHARE = 0.5
#: the isoperimetric quotient (36 pi V^2 / A^3: 1 for a ball, about 0.5 for a cube, 0 for
#: a flat plate) from which a closed part counts as round (see :data:`MAX_CAP_SHARE`)
MIN_ROUNDNESS = 0.2
#: a cage piece closer to a bigger one than this many of its own bounding-box
#: diagonals (or inside it) is carried along by it (see :func:`cage_links`)
HOST_REACH = 0.1
#: cage pieces of at most this many vertices are bound on one thread (see :func:`_bind_parts`)
SMALL_PIECE = 64
#: half the thickness of the shell cage of an open surface, in mean cage edge lengths: mean value
#: coordinates of a point between the layers reach about 6 half-thicknesses along the shell before
#: the truncation drops the rest, so a thin shell keeps rows local (mountain, 5% cage: 7 coordinates
#: a vertex at 0.05, 16 at 0.1, 70 at 0.25, 326 at 1)
SHELL_HALF_THICKNESS = 0.05
#: progress shares of the cage build (for the time-left estimate): the repair pass
#: takes about this much of it, and the two halves of a big part this much of the part's
#: simplification (the last pass takes the rest), as measured at 690K-2.7M vertices
REPAIR_SHARE = 0.1
HALVES_SHARE = 0.75


@dataclass(frozen=True)
class CageParts:
    """A cage made of one closed piece per connected part of the shape.

    Attributes
    ----------
    cage : Mesh
        All the pieces, piece k on cage vertices ``offsets[k]:offsets[k + 1]``.
    offsets : (P + 1,) int64
    owner : (n,) int64
        The piece each shape vertex is bound to (its own part's).
    kinds : tuple of str
        Per piece: "simplified", "own" (the part is its own cage), "holes
        closed", "shell" (an open surface thickened into a thin closed shell) or
        "box".
    """

    cage: Mesh
    offsets: np.ndarray
    owner: np.ndarray
    kinds: tuple[str, ...]


def build_cage(mesh: Mesh, size: int | float = CAGE_SIZE, notes: list[str] | None = None) -> Mesh:
    """The cage of ``mesh``: one closed piece per connected part (see :func:`cage_parts`).

    Parameters
    ----------
    mesh : Mesh
        The shape (not modified).
    size : int or float
        Target vertex count (int) or fraction of the shape's vertices (float).
    notes : list of str, optional
        Plain-word sentences about every repair and adjustment are appended here.

    Returns
    -------
    Mesh
        A closed, consistently oriented, outward surface (possibly of several pieces).
    """
    return cage_parts(mesh, size, notes=notes).cage


def cage_parts(
    mesh: Mesh,
    size: int | float = CAGE_SIZE,
    *,
    notes: list[str] | None = None,
    progress: Callable[[float], None] | None = None,
) -> CageParts:
    """Simplify each connected part of ``mesh`` to a closed cage piece of its own.

    The shape is first cleaned on a private copy
    (:func:`hybridedit.core.repair.cage_source`). The vertex budget ``size`` is shared
    among the parts in proportion to their vertex counts, with at least
    :data:`MIN_PART_CAGE` vertices a part; a part that its budget would hardly
    simplify (a tiny mesh, a button, an eye) is its own cage. A closed part is
    simplified by quadric error metrics (holes that simplification leaves are
    closed); an open part with small holes (a scan) gets them closed with fans; an
    open surface (a sheet, a cloth, a relief) is simplified and thickened into a
    thin closed shell around it, so that mean value coordinates are defined and
    smooth everywhere on it.

    Parameters
    ----------
    mesh : Mesh
        The shape (n vertices, not modified).
    size : int or float
        Target vertex count (int >= 4) or fraction in (0, 1] of the shape's vertices.
    notes : list of str, optional
        Plain-word sentences about repairs and adjustments are appended here.
    progress : callable(fraction), optional
        Called with the fraction of the parts' vertices done.

    Returns
    -------
    CageParts

    Raises
    ------
    ValueError
        A malformed ``size``.
    MeshError
        A shape with no usable face (every face degenerate).
    """
    said: list[str] = [] if notes is None else notes
    say = progress or (lambda fraction: None)
    size = check_cage_size(size)
    # a big shape is simplified in halves on two cores: the helper process starts now,
    # to be ready when the repair pass is done (see hybridedit.cage.qem)
    worker = start_worker(mesh.n_faces)
    try:
        return _cage_parts(mesh, size, said, say, worker)
    finally:
        if worker is not None:
            worker.close()


def _cage_parts(mesh: Mesh, size: int | float, said: list[str], say: Callable[[float], None],
                worker: HalfWorker | None) -> CageParts:
    from ..core.repair import plural, repaired_source

    source = repaired_source(mesh)
    say(REPAIR_SHARE)
    src, vmap = source.mesh, source.vertex_map
    said.extend(source.notes)
    n = src.n_vertices
    if isinstance(size, (int, np.integer)):
        target = int(size)
    else:
        # a fraction of the surface's own vertices: an unwelded soup (each face with copies of its
        # corners) or a file full of duplicates gets the cage of the surface it is, not one 6x as dense
        target = int(round(float(size) * n))
    if target > n:
        said.append(f"the mesh has only {plural(n, 'usable vertex', 'usable vertices')}; "
                    f"the cage uses all of them instead of {target:,}")
        target = n
    count, labels = source.parts, source.part_labels
    pieces: list[Mesh] = []
    kinds: list[str] = []
    done = 0
    holes = 0
    for part in _split_parts(src, count, labels):
        want = max(int(round(target * part.n_vertices / n)), MIN_PART_CAGE)

        def part_progress(fraction: float, base: int = done, size: int = part.n_vertices) -> None:
            finished = base + fraction * size
            say(1.0 if finished >= n else REPAIR_SHARE + (1.0 - REPAIR_SHARE) * finished / n)

        piece, kind, closed = _cage_piece(part, want, known_closed=source.closed, progress=part_progress,
                                          worker=worker)
        holes += closed
        pieces.append(piece)
        kinds.append(kind)
        done += part.n_vertices
        part_progress(1.0)
    what = {"own": ("is small: it is its own cage", "are small: they are their own cages"),
            "shell": ("is an open surface: its cage is a thin closed shell around it",
                      "are open surfaces: their cages are thin closed shells around them"),
            "box": ("is flat or degenerate: its cage is a box around it",
                    "are flat or degenerate: their cages are boxes around them")}
    for k, (one, many) in what.items():
        c = kinds.count(k)
        if c and count == 1:
            said.append(f"the mesh {one}")
        elif c:
            said.append(f"in the cage, {c:,} of the {count:,} parts {one if c == 1 else many}")
    if holes:
        said.append(f"closed {plural(holes, 'hole')} in the cage")
    offsets = np.zeros(count + 1, dtype=np.int64)
    offsets[1:] = np.cumsum([c.n_vertices for c in pieces])
    cage = Mesh(np.vstack([c.vertices for c in pieces]),
                np.vstack([c.faces + o for c, o in zip(pieces, offsets[:-1])]), name="cage")
    # the part of each shape vertex: its repaired vertex's, else its nearest repaired vertex's
    owner = np.zeros(mesh.n_vertices, dtype=np.int64)
    if count > 1:
        ok = vmap >= 0
        owner[ok] = labels[vmap[ok]]
        if not np.all(ok):
            from scipy.spatial import cKDTree

            owner[~ok] = labels[cKDTree(src.vertices).query(mesh.vertices[~ok])[1]]
    return CageParts(cage, offsets, owner, tuple(kinds))


def _split_parts(src: Mesh, count: int, labels: np.ndarray):
    """Each connected part of ``src`` as a mesh of its own (vertices in order), one at
    a time; a single part is ``src`` itself (no grouping, no copy)."""
    if count == 1:
        yield src
        return
    n = src.n_vertices
    v_order = np.argsort(labels, kind="stable")
    v_start = np.searchsorted(labels[v_order], np.arange(count + 1))
    f_label = labels[src.faces[:, 0]]
    f_order = np.argsort(f_label, kind="stable")
    f_start = np.searchsorted(f_label[f_order], np.arange(count + 1))
    local = np.empty(n, dtype=np.int64)  # each vertex's index within its part
    local[v_order] = np.arange(n) - v_start[labels[v_order]]
    for p in range(count):
        verts = v_order[v_start[p]:v_start[p + 1]]
        yield Mesh(src.vertices[verts], local[src.faces[f_order[f_start[p]:f_start[p + 1]]]])


def _cage_piece(part: Mesh, want: int, *, known_closed: bool = False,
                progress: Callable[[float], None] | None = None,
                worker: HalfWorker | None = None) -> tuple[Mesh, str, int]:
    """The closed cage piece of one connected part, how it was made, and how many holes it closed
    (``progress(fraction)`` is told how far the simplification of a big part is; ``worker``, a
    helper process started early, simplifies half of a big part)."""
    from ..core.repair import box_cage, close_holes, hole_loops

    own = want * 1.0 >= OWN_CAGE_FRACTION * part.n_vertices
    loops = [] if known_closed else hole_loops(part.faces, part.n_vertices)
    if loops and cap_share(part) >= MAX_CAP_SHARE and _roundness(close_holes(part)[0]) < MIN_ROUNDNESS:
        surface = part if own or want >= part.n_vertices else _simplify(part, max(want // 2, 3))
        shell = thicken(surface)
        if shell is not None:
            return shell, "shell", 0
        return box_cage(part.vertices), "box", 0
    piece = clean_surface(part.vertices, part.faces) if own else _simplify(part, want, progress=progress, worker=worker)
    closed_holes = 0
    if piece.n_faces:
        piece, closed_holes = close_holes(piece)
        if closed_holes:  # the fans can add slivers; otherwise the piece is clean already
            piece = clean_surface(piece.vertices, piece.faces)
    if _usable(piece):
        return piece, "own" if own else ("holes closed" if closed_holes else "simplified"), closed_holes
    shell = thicken(part if own else _simplify(part, max(want // 2, 3)))
    if shell is not None:
        return shell, "shell", 0
    return box_cage(part.vertices), "box", 0


def _area(mesh: Mesh) -> float:
    v, f = mesh.vertices, mesh.faces
    return 0.5 * float(np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1).sum())


def _roundness(closed: Mesh) -> float:
    """Isoperimetric quotient 36 pi V^2 / A^3 of a closed surface: 1 for a sphere,
    about 0.5 for a cube, 0 for a flat one."""
    v, f = closed.vertices, closed.faces
    c = v.mean(axis=0)
    p0, p1, p2 = (v[f[:, k]] - c for k in range(3))
    vol = float(np.einsum("ij,ij->i", p0, np.cross(p1, p2)).sum()) / 6.0
    area = _area(closed)
    if not (area > 0 and np.isfinite(vol)):
        return 0.0
    return 36.0 * np.pi * vol * vol / area ** 3


def cap_share(part: Mesh) -> float:
    """The area that closing an open part's holes with fans adds, as a share of its own area: small
    for a scan with holes (0.01 for the armadillo with five holes punched), about 1 for a sheet or a
    terrain (0.81 for the shared mountain); inf for a part of no area."""
    from ..core.repair import close_holes

    area = _area(part)
    if not area > 0:
        return np.inf
    return (_area(close_holes(part)[0]) - area) / area


def thicken(surface: Mesh, half_thickness: float | None = None) -> Mesh | None:
    """A thin closed shell around an open, consistently oriented surface.

    Each vertex is offset by +-h along its (area-weighted) normal; rim vertices
    are also pushed outward by h in the surface's tangent plane, so that the
    shell covers the surface's border; the two layers are joined along the rim
    by quads. Vertices are ``[top (k); bottom (k)]`` and faces ``[top (m);
    bottom (m); rim]``, bottom faces being the top ones reversed
    (:func:`shell_pairs` recognises this layout).

    Parameters
    ----------
    surface : Mesh (k vertices, m faces)
    half_thickness : float, optional
        h; by default :data:`SHELL_HALF_THICKNESS` times the mean edge length.

    Returns
    -------
    Mesh (2k vertices, outward), or None when the surface has no usable face.
    """
    from ..core.repair import hole_loops, orient_faces

    s = clean_surface(surface.vertices, surface.faces)
    if s.n_faces == 0:
        return None
    v = s.vertices
    f, _, _ = orient_faces(v, s.faces)
    k = len(v)
    fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])  # area-weighted
    vn = np.zeros_like(v)
    for j in range(3):
        np.add.at(vn, f[:, j], fn)
    total = fn.sum(axis=0)
    if not np.linalg.norm(total) > 0:
        total = fn[np.argmax(np.linalg.norm(fn, axis=1))]
    length = np.linalg.norm(vn, axis=1)
    weak = ~(length > 1e-12 * max(float(length.max()), 1e-300))
    vn[weak] = total
    vn /= np.linalg.norm(vn, axis=1)[:, None]
    edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    h = half_thickness
    if h is None:
        h = SHELL_HALF_THICKNESS * float(np.linalg.norm(v[edges[:, 0]] - v[edges[:, 1]], axis=1).mean())
    if not h > 0:
        return None
    loops = hole_loops(f, k)
    out = np.zeros_like(v)
    for ring in loops:  # outward in the tangent plane: the rim edge crossed with the normal
        nxt = np.roll(ring, -1)  # the surface has ring -> nxt, with itself on the left
        e = v[nxt] - v[ring]
        side = np.cross(e, vn[ring] + vn[nxt])
        np.add.at(out, ring, side)
        np.add.at(out, nxt, side)
    olen = np.linalg.norm(out, axis=1)
    rim = olen > 0
    out[rim] /= olen[rim, None]
    out -= np.einsum("ij,ij->i", out, vn)[:, None] * vn
    top = v + h * vn + h * out
    bottom = v - h * vn + h * out
    faces = [f, f[:, ::-1] + k]
    for ring in loops:
        # the top layer has x -> y and the bottom y' -> x': the rim quad runs y -> x -> x' -> y'
        x, y = ring, np.roll(ring, -1)
        faces.append(np.stack([y, x, x + k], axis=1))
        faces.append(np.stack([y, x + k, y + k], axis=1))
    shell = Mesh(np.vstack([top, bottom]), np.vstack(faces), name="cage")
    if not _usable(shell):
        return None
    return shell


def shell_pairs(faces: np.ndarray, start: int, count: int) -> np.ndarray:
    """Top/bottom vertex pairs of a cage piece laid out by :func:`thicken`.

    Parameters
    ----------
    faces : (m, 3) int array, the piece's faces (indices in ``[start, start + count)``)
    start, count : the piece's cage vertex range

    Returns
    -------
    (count // 2, 2) int64 pairs (top, bottom), or (0, 2) when the piece is not a shell.
    """
    none = np.zeros((0, 2), dtype=np.int64)
    k = count // 2
    if count % 2 or k < 3:
        return none
    f = np.asarray(faces, dtype=np.int64) - start
    top = f[np.all(f < k, axis=1)]
    m = len(top)
    if m == 0 or 2 * m > len(f) or not np.array_equal(f[m:2 * m], top[:, ::-1] + k) or not np.array_equal(f[:m], top):
        return none
    idx = np.arange(k, dtype=np.int64) + start
    return np.stack([idx, idx + k], axis=1)


def cage_and_binding(
    mesh: Mesh,
    size: int | float = CAGE_SIZE,
    *,
    truncation: float = TRUNCATION,
    cage: Mesh | None = None,
    binding=None,
    notes: list[str] | None = None,
    timings: dict | None = None,
    progress=None,
):
    """The cage of ``mesh`` and the binding of its vertices to it.

    Each connected part of the shape gets its own closed cage piece
    (:func:`cage_parts`) and its vertices are bound only to that piece, so M is
    block-diagonal over the parts: overlapping parts do not pull on each other's
    vertices, and a small part deforms at its own scale.
    :func:`cage_links` ties a piece that sits inside or against a bigger one to it.

    Parameters
    ----------
    mesh : Mesh
        The shape (n vertices), not modified.
    size : int or float
        Cage vertex count (int) or fraction of the shape's vertices (float).
    truncation : float
        Fraction of each row's coordinate magnitude dropped.
    cage : Mesh, optional
        Use this cage instead of simplifying the shape (all vertices are bound to all of it).
    binding : (n, c) sparse matrix, optional
        Use this binding (needs ``cage``).
    notes : list of str, optional
        Repairs and adjustments are appended here in plain words.
    timings : dict, optional
        ``cage_seconds`` and ``bind_seconds`` are set here.
    progress : callable(stage, fraction), optional

    Returns
    -------
    cage : Mesh (c vertices)
    M : (n, c) scipy.sparse.csr_matrix, rows summing to 1
    """
    import time

    import scipy.sparse as sp

    from ..binding.bind import bind
    from ..core.mesh import MeshError
    from ..core.repair import box_cage

    say = progress or (lambda stage, fraction: None)
    said: list[str] = [] if notes is None else notes
    t0 = time.perf_counter()
    if cage is None:
        say("building the cage", 0.0)
        parts = cage_parts(mesh, size, notes=said, progress=lambda fraction: say("building the cage", fraction))
        say("building the cage", 1.0)
    else:
        parts = CageParts(cage, np.array([0, cage.n_vertices]), np.zeros(mesh.n_vertices, dtype=np.int64),
                          ("given",))
    t1 = time.perf_counter()
    if binding is None:
        say("binding", 0.0)
        try:
            binding = _bind_parts(mesh, parts, truncation, lambda fraction: say("binding", fraction))
        except ValueError as e:
            if cage is not None:
                raise MeshError(f"{mesh.name or 'mesh'}: cannot bind to its cage: {e}") from None
            said.append(f"could not bind to the simplified cage ({e}); using a box around the shape as the cage")
            box = box_cage(mesh.vertices)
            parts = CageParts(box, np.array([0, 8]), np.zeros(mesh.n_vertices, dtype=np.int64), ("box",))
            try:
                binding = bind(mesh.vertices, box, truncation=truncation)
            except ValueError as e2:
                raise MeshError(f"{mesh.name or 'mesh'}: cannot bind to its cage: {e2}") from None
    if timings is not None:
        timings["cage_seconds"] = t1 - t0
        timings["bind_seconds"] = time.perf_counter() - t1
    return parts.cage, sp.csr_matrix(binding, dtype=np.float64)


def _bind_parts(mesh: Mesh, parts: CageParts, truncation: float, progress: Callable[[float], None]):
    """Bind the vertices of each part to its own cage piece: a block-diagonal (n, c) CSR matrix.

    A small piece (at most :data:`SMALL_PIECE` vertices: debris, a button, a tooth)
    is bound on one thread: starting the thread pool would cost more than the work
    (15 ms against 2 ms a piece on the development machine).
    """
    import numba
    import scipy.sparse as sp

    from ..binding.bind import bind

    P = len(parts.offsets) - 1
    if P == 1:
        return bind(mesh.vertices, parts.cage, truncation=truncation, progress=progress)
    n = mesh.n_vertices
    order = np.argsort(parts.owner, kind="stable")
    start = np.searchsorted(parts.owner[order], np.arange(P + 1))
    cf = parts.cage.faces
    face_piece = np.searchsorted(parts.offsets, cf[:, 0], side="right") - 1
    f_order = np.argsort(face_piece, kind="stable")
    f_start = np.searchsorted(face_piece[f_order], np.arange(P + 1))
    rows, cols, vals = [], [], []
    done = 0
    threads = numba.get_num_threads()
    try:
        for p in range(P):
            idx = order[start[p]:start[p + 1]]
            if idx.size == 0:
                continue
            o0, o1 = int(parts.offsets[p]), int(parts.offsets[p + 1])
            piece = Mesh(parts.cage.vertices[o0:o1], cf[f_order[f_start[p]:f_start[p + 1]]] - o0)
            base = done

            def part_progress(fraction: float, base: int = base, size: int = idx.size) -> None:
                progress((base + fraction * size) / n)

            numba.set_num_threads(1 if o1 - o0 <= SMALL_PIECE else threads)
            Mp = bind(mesh.vertices[idx], piece, truncation=truncation, progress=part_progress).tocoo()
            rows.append(idx[Mp.row])
            cols.append(Mp.col.astype(np.int64) + o0)
            vals.append(Mp.data)
            done += idx.size
    finally:
        numba.set_num_threads(threads)
    M = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(n, parts.cage.n_vertices))
    M.sort_indices()
    return M


def cage_links(cage: Mesh) -> np.ndarray:
    """Extra ARAP edges that tie separate pieces of the cage together.

    * A piece that sits inside a bigger piece, or against it (closer to it than
      :data:`HOST_REACH` times its own bounding-box diagonal), is tied to it (its
      host: the smallest piece holding it, else the nearest): each of its vertices
      gets an edge to the nearest vertex of the host, so that ARAP carries it
      along with its host.
    * A thin shell (the cage of an open surface, :func:`thicken`) gets an edge
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


def _simplify(src: Mesh, target: int, *, progress: Callable[[float], None] | None = None,
              worker: HalfWorker | None = None) -> Mesh:
    ratio = src.n_faces / max(src.n_vertices, 1)
    cage = None
    want_faces = max(4, int(round(target * ratio)))
    # the simplifier has absolute thresholds and loses precision far from the origin:
    # a shape of extreme size or offset is simplified centred and scaled to a unit
    # diagonal (shapes of ordinary size are simplified as they are)
    lo, hi = src.vertices.min(axis=0), src.vertices.max(axis=0)
    center = 0.5 * (lo + hi)
    scale = float(np.linalg.norm(hi - lo)) or 1.0
    if 1e-2 <= scale <= 1e4 and float(np.abs(center).max()) <= 1e3 * scale:
        center, scale = np.zeros(3), 1.0
        unit = src.vertices
    else:
        unit = (src.vertices - center) / scale
    # a big surface is first brought near the target on two cores (see hybridedit.cage.qem)
    base_v, base_f = presimplify(unit, src.faces, want_faces, worker=worker)
    if progress is not None and len(base_f) < src.n_faces:
        progress(HALVES_SHARE)
    for _ in range(3):
        want_faces = min(want_faces, len(base_f))
        v, f = fast_simplification.simplify(base_v, base_f, target_count=want_faces, agg=AGGRESSIVENESS)
        v = np.asarray(v, dtype=np.float64) * scale + center
        cage = clean_surface(v, np.asarray(f, dtype=np.int64))
        got = cage.n_vertices
        if abs(got - target) <= max(2, 0.02 * target) or got == 0:
            break
        want_faces = int(round(want_faces * target / got))
    assert cage is not None
    return cage


def _usable(cage: Mesh) -> bool:
    """Closed, oriented, with a volume that is not negligible for its size."""
    if cage.n_faces < 4:
        return False
    try:
        check_closed(cage.faces)
    except ValueError:
        return False
    v = cage.vertices
    c = v.mean(axis=0)
    p0, p1, p2 = (v[cage.faces[:, k]] - c for k in range(3))
    vol = float(np.einsum("ij,ij->i", p0, np.cross(p1, p2)).sum()) / 6.0
    d = float(np.linalg.norm(np.ptp(v, axis=0)))
    return bool(np.isfinite(vol) and vol > 1e-6 * d ** 3)


def clean_surface(vertices: np.ndarray, faces: np.ndarray) -> Mesh:
    """Remove what a simplifier can leave behind.

    Drops degenerate faces (:func:`hybridedit.core.topology.degenerate_faces`), duplicate faces, pairs of
    coincident faces of opposite orientation (zero-volume fins), and then
    vertices no face uses (indices are compacted, order kept).

    Parameters
    ----------
    vertices : (n, 3) float64 array
    faces : (m, 3) int array
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    while True:
        m0 = len(f)
        f = f[~degenerate_faces(v, f)]
        if len(f) and repeats_a_face(f, len(v)):
            key = np.sort(f, axis=1)
            _, first, inverse, counts = np.unique(
                key, axis=0, return_index=True, return_inverse=True, return_counts=True
            )
            inverse = inverse.reshape(-1)
            # a vertex set used twice: same orientation is a duplicate (keep one),
            # opposite orientation is a fin (drop both)
            keep = np.zeros(len(f), dtype=bool)
            keep[first] = True
            multi = counts[inverse] > 1
            if np.any(multi):
                for g in np.unique(inverse[multi]):
                    idx = np.flatnonzero(inverse == g)
                    orient = [_parity(f[i]) for i in idx]
                    if len(set(orient)) > 1:
                        keep[idx] = False
            f = f[keep]
        if len(f) == m0:
            break
    used = np.zeros(len(v), dtype=bool)
    used[f.reshape(-1)] = True
    remap = np.cumsum(used) - 1
    return Mesh(v[used], remap[f])


def _parity(tri: np.ndarray) -> int:
    """+1 if the triangle's cyclic order is an even rotation of its sorted order."""
    a, b, c = (int(x) for x in tri)
    lo = min(a, b, c)
    while a != lo:
        a, b, c = b, c, a
    return 1 if b < c else -1
