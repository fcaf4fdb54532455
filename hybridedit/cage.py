"""The control mesh: QEM simplification of the shape, cleaned to a valid surface."""

from __future__ import annotations

import numpy as np
import fast_simplification

from .mesh import Mesh


def cage_vertex_target(n_vertices: int, size: int | float) -> int:
    """The cage vertex count asked for by ``size``.

    Parameters
    ----------
    n_vertices : int
        Vertex count of the shape.
    size : int or float
        An int is a vertex count; a float in (0, 1] is a fraction of ``n_vertices``.
    """
    if isinstance(size, (bool, np.bool_)):
        raise ValueError(f"cage size must be a vertex count or a fraction, got {size!r}")
    if isinstance(size, (int, np.integer)):
        target = int(size)
    else:
        frac = float(size)
        if not (0.0 < frac <= 1.0):
            raise ValueError(f"cage fraction must be in (0, 1], got {size!r}")
        target = int(round(frac * n_vertices))
    if target < 4:
        raise ValueError(f"a cage needs at least 4 vertices, asked for {target}")
    if target > n_vertices:
        raise ValueError(f"cage of {target} vertices asked for a shape of only {n_vertices}")
    return target


def build_cage(mesh: Mesh, size: int | float = 0.05, notes: list[str] | None = None) -> Mesh:
    """Simplify ``mesh`` with quadric error metrics to about ``size`` vertices.

    The shape is first cleaned on a private copy (:func:`hybridedit.repair.cage_source`:
    duplicate vertices merged, degenerate, duplicate and non-manifold faces dropped,
    orientation made consistent); the simplified result is cleaned again and its
    holes closed, so the cage is always a closed, consistently oriented surface.
    A shape too small or too flat for that gets a box around it as the cage.

    Parameters
    ----------
    mesh : Mesh
        The shape (not modified).
    size : int or float
        Target vertex count (int) or fraction of the shape's vertices (float).
        A count larger than the shape's is clamped to what it has.
    notes : list of str, optional
        Plain-word sentences about every repair and adjustment are appended here.

    Returns
    -------
    Mesh
        The cage, with degenerate faces, coincident opposite face pairs and
        unreferenced vertices removed. Its vertex count is within a few percent of
        the target (QEM collapses edges, so the count is not exact), plus one
        vertex per closed hole.

    Raises
    ------
    ValueError
        A malformed ``size``.
    MeshError
        A shape with no usable face (every face degenerate).
    """
    from .repair import box_cage, cage_source, close_holes, plural

    said: list[str] = [] if notes is None else notes
    if isinstance(size, (bool, np.bool_)):
        raise ValueError(f"cage size must be a vertex count or a fraction, got {size!r}")
    if isinstance(size, (int, np.integer)):
        if int(size) < 4:
            raise ValueError(f"a cage needs at least 4 vertices, asked for {int(size)}")
    src, repairs = cage_source(mesh)
    said.extend(repairs)
    n = src.n_vertices
    if isinstance(size, (int, np.integer)):
        target = int(size)
    else:
        target = cage_vertex_target(max(mesh.n_vertices, 4), size) if mesh.n_vertices >= 4 else 4
        target = max(target, 4)
    if target > n:
        if n >= 4:
            said.append(f"the mesh has only {plural(n, 'usable vertex', 'usable vertices')}; "
                        f"the cage uses all of them instead of {target:,}")
        target = n
    if n < 4 or src.n_faces < 2:
        said.append(f"the mesh is too small for a simplified cage ({plural(n, 'vertex', 'vertices')}); "
                    "using a box around it as the cage")
        return box_cage(mesh.vertices)
    if target >= n:
        cage = clean_surface(src.vertices.copy(), src.faces.copy())
    else:
        cage = _simplify(src, target)
    if cage.n_faces >= 1:
        cage, holes = close_holes(cage)
        if holes:
            said.append(f"closed {plural(holes, 'hole')} in the cage")
        cage = clean_surface(cage.vertices, cage.faces)
    if not _usable(cage):
        said.append("the simplified cage is flat or degenerate; using a box around the shape as the cage")
        return box_cage(mesh.vertices)
    return cage


def cage_and_binding(
    mesh: Mesh,
    size: int | float = 0.05,
    *,
    truncation: float = 0.03,
    cage: Mesh | None = None,
    binding=None,
    notes: list[str] | None = None,
    timings: dict | None = None,
    progress=None,
):
    """The cage of ``mesh`` and the binding of its vertices to it.

    Parameters
    ----------
    mesh : Mesh
        The shape (n vertices), not modified.
    size : int or float
        Cage vertex count (int) or fraction of the shape's vertices (float).
    truncation : float
        Fraction of each row's coordinate magnitude dropped.
    cage : Mesh, optional
        Use this cage instead of simplifying the shape.
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

    from .binding import bind
    from .mesh import MeshError
    from .repair import box_cage

    say = progress or (lambda stage, fraction: None)
    said: list[str] = [] if notes is None else notes
    t0 = time.perf_counter()
    built = cage is None
    if cage is None:
        say("building the cage", 0.0)
        cage = build_cage(mesh, size, notes=said)
        say("building the cage", 1.0)
    t1 = time.perf_counter()
    if binding is None:
        say("binding", 0.0)

        def bind_to(c: Mesh):
            return bind(mesh.vertices, c, truncation=truncation, progress=lambda fraction: say("binding", fraction))

        try:
            binding = bind_to(cage)
        except ValueError as e:
            if not built:
                raise MeshError(f"{mesh.name or 'mesh'}: cannot bind to its cage: {e}") from None
            said.append(f"could not bind to the simplified cage ({e}); using a box around the shape as the cage")
            cage = box_cage(mesh.vertices)
            try:
                binding = bind_to(cage)
            except ValueError as e2:
                raise MeshError(f"{mesh.name or 'mesh'}: cannot bind to its cage: {e2}") from None
    if timings is not None:
        timings["cage_seconds"] = t1 - t0
        timings["bind_seconds"] = time.perf_counter() - t1
    return cage, sp.csr_matrix(binding, dtype=np.float64)


def cage_links(cage: Mesh) -> np.ndarray:
    """Extra ARAP edges that tie separate parts of the cage to the part holding them.

    Parameters
    ----------
    cage : Mesh

    Returns
    -------
    (k, 2) int64 array of cage vertex pairs (column 0 < column 1); empty when the
    cage is one connected surface.
    """
    return np.zeros((0, 2), dtype=np.int64)


def _simplify(src: Mesh, target: int) -> Mesh:
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
    unit = (src.vertices - center) / scale
    for _ in range(3):
        want_faces = min(want_faces, src.n_faces)
        v, f = fast_simplification.simplify(
            unit, src.faces.astype(np.int32), target_count=want_faces, agg=7.0
        )
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
    from .mvc import check_closed

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

    Drops faces with a repeated index or zero area, duplicate faces, pairs of
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
        keep = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 2] != f[:, 0])
        f = f[keep]
        if len(f):
            a = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
            area2 = np.linalg.norm(a, axis=1)
            scale = np.ptp(v, axis=0).max() if len(v) else 1.0
            f = f[area2 > 1e-14 * scale * scale]
        if len(f):
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
