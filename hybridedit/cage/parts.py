"""The shape cut into its connected parts, each simplified to a closed cage piece of its own.

:func:`cage_parts` repairs a private copy of the shape, shares the vertex budget among its
parts and makes one piece per part (:func:`_cage_piece`: a tiny part is its own cage, a
closed part is simplified by :mod:`hybridedit.cage.simplify`, a scan's holes are closed, a
sheet gets a thin shell from :mod:`hybridedit.cage.shell`), then lays the pieces out one
after the other in one cage (:class:`CageParts`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..core.mesh import Mesh
from ..core.spatial_order import morton_order
from ..defaults import CAGE_SIZE, check_cage_size
from .clean import clean_surface, is_usable_piece
from .cluster import simplified_sizes
from .qem import HalfWorker, start_worker
from .shell import is_sheet, thicken
from .simplify import simplify

__all__ = ["CageParts", "MIN_PART_CAGE", "OWN_CAGE_FRACTION", "REPAIR_SHARE", "cage_parts"]

#: a part whose cage would keep at least this fraction of its vertices is its own cage
OWN_CAGE_FRACTION = 0.75
#: the fewest vertices a simplified cage part gets (a smaller part is its own cage)
MIN_PART_CAGE = 32
#: progress share of the repair pass in the cage build (for the time-left estimate), as
#: measured at 690K-2.7M vertices
REPAIR_SHARE = 0.1


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
    # to be ready when the repair pass is done (see hybridedit.cage.qem), its buffers grown to the
    # surface quadric collapses will start from (the clustered surface of a big shape; none when
    # that is too near the cage's size to be split)
    wanted = _wanted(size, mesh.n_vertices)
    n_v, n_f = simplified_sizes(mesh.n_vertices, mesh.n_faces, wanted)
    worker = start_worker(n_f, int(round(wanted * mesh.n_faces / max(mesh.n_vertices, 1))), n_v)
    try:
        return _cage_parts(mesh, size, said, say, worker)
    finally:
        if worker is not None:
            worker.close()



def _cage_parts(mesh: Mesh, size: int | float, said: list[str], say: Callable[[float], None],
                worker: HalfWorker | None) -> CageParts:
    from ..core.repair import repaired_source

    source = repaired_source(mesh)
    say(REPAIR_SHARE)
    src, vmap = source.mesh, source.vertex_map
    said.extend(source.notes)
    n = src.n_vertices
    target = _target_count(size, n, said)
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
        pieces.append(_in_spatial_order(piece, kind))
        kinds.append(kind)
        done += part.n_vertices
        part_progress(1.0)
    _say_kinds(kinds, count, holes, said)
    offsets = np.zeros(count + 1, dtype=np.int64)
    offsets[1:] = np.cumsum([c.n_vertices for c in pieces])
    cage = Mesh(np.vstack([c.vertices for c in pieces]),
                np.vstack([c.faces + o for c, o in zip(pieces, offsets[:-1])]), name="cage")
    return CageParts(cage, offsets, _owners(mesh, src, vmap, count, labels), tuple(kinds))


def _wanted(size: int | float, n: int) -> int:
    """The vertex count a cage ``size`` asks of a surface of ``n`` vertices (not capped at ``n``)."""
    if isinstance(size, (int, np.integer)):
        return int(size)
    # a fraction of the surface's own vertices: an unwelded soup (each face with copies of its
    # corners) or a file full of duplicates gets the cage of the surface it is, not one 6x as dense
    return int(round(float(size) * n))


def _target_count(size: int | float, n: int, said: list[str]) -> int:
    """The cage's vertex count for a repaired surface of ``n`` vertices (said when capped at ``n``)."""
    from ..core.repair import plural

    target = _wanted(size, n)
    if target > n:
        said.append(f"the mesh has only {plural(n, 'usable vertex', 'usable vertices')}; "
                    f"the cage uses all of them instead of {target:,}")
        target = n
    return target


def _say_kinds(kinds: list[str], count: int, holes: int, said: list[str]) -> None:
    """Plain-word notes on the pieces not simply simplified, and on the holes closed."""
    from ..core.repair import plural

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


def _owners(mesh: Mesh, src: Mesh, vmap: np.ndarray, count: int, labels: np.ndarray) -> np.ndarray:
    """(n,) int64: the part of each shape vertex, its repaired vertex's (``vmap``), else its nearest
    repaired vertex's."""
    owner = np.zeros(mesh.n_vertices, dtype=np.int64)
    if count > 1:
        ok = vmap >= 0
        owner[ok] = labels[vmap[ok]]
        if not np.all(ok):
            from scipy.spatial import cKDTree

            owner[~ok] = labels[cKDTree(src.vertices).query(mesh.vertices[~ok])[1]]
    return owner


def _in_spatial_order(piece: Mesh, kind: str) -> Mesh:
    """The piece with its vertices in Morton order (:func:`hybridedit.core.spatial_order.morton_order`):
    the cage vertices a drag frees are then a few runs of rows, and a frame's gathers over them
    hit the cache. A shell keeps its layout (top vertex i, its bottom twin i + k:
    :func:`hybridedit.cage.shell.shell_pairs`): its top is ordered and the bottom follows. A part that is its own cage keeps the part's order (each shape
    vertex bound to its own cage vertex in the same order), and a box is 8 vertices."""
    if kind in ("own", "box"):
        return piece
    if kind == "shell":
        k = piece.n_vertices // 2
        top = morton_order(piece.vertices[:k])
        order = np.concatenate([top, top + k])
    else:
        order = morton_order(piece.vertices)
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    return Mesh(piece.vertices[order], rank[piece.faces], name=piece.name)


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
    from ..core.repair import close_holes, hole_loops

    own = want * 1.0 >= OWN_CAGE_FRACTION * part.n_vertices
    loops = [] if known_closed else hole_loops(part.faces, part.n_vertices)
    if loops and is_sheet(part, loops):
        return _shell_piece(part if own or want >= part.n_vertices else simplify(part, max(want // 2, 3)), part)
    piece = clean_surface(part.vertices, part.faces) if own else simplify(part, want, progress=progress, worker=worker)
    closed_holes = 0
    if piece.n_faces:
        piece, closed_holes = close_holes(piece)
        if closed_holes:  # the fans can add slivers; otherwise the piece is clean already
            piece = clean_surface(piece.vertices, piece.faces)
    if is_usable_piece(piece):
        return piece, "own" if own else ("holes closed" if closed_holes else "simplified"), closed_holes
    return _shell_piece(part if own else simplify(part, max(want // 2, 3)), part)


def _shell_piece(surface: Mesh, part: Mesh) -> tuple[Mesh, str, int]:
    """A thin shell around ``surface`` (the part or its simplification), else a box around the part."""
    from ..core.repair import box_cage

    shell = thicken(surface)
    if shell is not None:
        return shell, "shell", 0
    return box_cage(part.vertices), "box", 0
