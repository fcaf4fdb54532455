"""The cage and the binding of a shape, assembled: :func:`cage_and_binding`.

Each connected part of the shape gets its own closed cage piece (:func:`hybridedit.cage.parts.cage_parts`)
and its vertices are bound only to that piece (M is block-diagonal over the parts); a shape whose
simplified cage cannot bind it gets a box around it instead. :func:`hybridedit.binding.rig.build_rig`
wraps this with the on-disk cache.
"""

from __future__ import annotations

import time
from typing import Callable

import numpy as np

from ..cage.parts import CageParts, cage_parts
from ..core.mesh import Mesh, MeshError
from ..defaults import CAGE_SIZE, TRUNCATION

__all__ = ["SMALL_PIECE", "cage_and_binding"]

#: cage pieces of at most this many vertices are bound on one thread (see :func:`_bind_parts`)
SMALL_PIECE = 64


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
    (:func:`hybridedit.cage.parts.cage_parts`) and its vertices are bound only to that piece, so M is
    block-diagonal over the parts: overlapping parts do not pull on each other's
    vertices, and a small part deforms at its own scale.
    :func:`hybridedit.cage.links.cage_links` ties a piece that sits inside or against a bigger one to it.

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
    import scipy.sparse as sp

    from ..core.repair import box_cage
    from .bind import bind  # (the binding kernels load with the first binding, not with the rig)

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
            binding = _bind_shape(mesh, parts, truncation, lambda fraction: say("binding", fraction))
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


def _bind_shape(mesh: Mesh, parts: CageParts, truncation: float, progress: Callable[[float], None]):
    """The binding of every vertex of ``mesh``: a shape of at least
    :data:`~hybridedit.binding.interpolated_rows.INTERPOLATE_FROM` vertices binds a quarter of them
    and interpolates the others' rows (:func:`~hybridedit.binding.interpolated_rows.interpolated_binding`)."""
    from .interpolated_rows import INTERPOLATE_FROM, interpolated_binding

    if mesh.n_vertices < INTERPOLATE_FROM:
        return _bind_parts(mesh.vertices, parts.owner, parts, truncation, progress)
    return interpolated_binding(
        mesh.vertices, mesh.faces,
        lambda seeds: _bind_parts(mesh.vertices[seeds], parts.owner[seeds], parts, truncation, progress),
        cage_vertices=parts.cage.vertices, truncation=truncation)


def _bind_parts(points: np.ndarray, owner: np.ndarray, parts: CageParts, truncation: float,
                progress: Callable[[float], None]):
    """Bind the (n, 3) ``points`` of each part (``owner``: (n,) each one's part) to its own cage
    piece: a block-diagonal (n, c) CSR matrix.

    A small piece (at most :data:`SMALL_PIECE` vertices: debris, a button, a tooth)
    is bound on one thread: starting the thread pool would cost more than the work
    (15 ms against 2 ms a piece on the development machine).
    """
    import numba
    import scipy.sparse as sp

    from .bind import bind

    P = len(parts.offsets) - 1
    if P == 1:
        return bind(points, parts.cage, truncation=truncation, progress=progress)
    n = len(points)
    order = np.argsort(owner, kind="stable")
    start = np.searchsorted(owner[order], np.arange(P + 1))
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
            Mp = bind(points[idx], piece, truncation=truncation, progress=part_progress).tocoo()
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
