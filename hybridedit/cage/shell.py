"""Open surfaces: telling a sheet from a scan with holes, and the thin closed shell around a sheet.

A part with holes whose rim encloses about as much as the part itself and that is flat once
closed (a sheet, a terrain, a cloth, a relief) has no volume to close: :func:`is_sheet` says
so, and :func:`thicken` wraps it in a thin closed shell, whose top and bottom vertices
:func:`shell_pairs` recognises (for the ARAP links of :mod:`hybridedit.cage.links`).
"""

from __future__ import annotations

import numpy as np

from ..core.face_geometry import face_vectors, signed_volume, surface_area
from ..core.mesh import Mesh
from .clean import clean_surface, is_usable_piece

__all__ = ["MAX_CAP_SHARE", "MIN_ROUNDNESS", "SHELL_HALF_THICKNESS", "cap_share", "is_sheet", "shell_pairs",
           "thicken"]

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
#: half the thickness of the shell cage of an open surface, in mean cage edge lengths: mean value
#: coordinates of a point between the layers reach about 6 half-thicknesses along the shell before
#: the truncation drops the rest, so a thin shell keeps rows local (mountain, 5% cage: 7 coordinates
#: a vertex at 0.05, 326 at 1)
SHELL_HALF_THICKNESS = 0.05


def is_sheet(part: Mesh, loops: list[np.ndarray] | None = None) -> bool:
    """An open part that gets a thin shell rather than its holes closed: closing its holes
    adds at least :data:`MAX_CAP_SHARE` of its area and leaves it less than
    :data:`MIN_ROUNDNESS` round.

    Parameters
    ----------
    part : Mesh
        A connected part with holes.
    loops : list of (k,) int64, optional
        Its :func:`~hybridedit.core.repair.hole_loops`, when the caller has them.
    """
    from ..core.repair import close_holes, hole_loops

    loops = hole_loops(part.faces, part.n_vertices) if loops is None else loops
    return cap_share(part, loops) >= MAX_CAP_SHARE and _roundness(close_holes(part, loops)[0]) < MIN_ROUNDNESS


def _roundness(closed: Mesh) -> float:
    """Isoperimetric quotient 36 pi V^2 / A^3 of a closed surface: 1 for a sphere,
    about 0.5 for a cube, 0 for a flat one."""
    vol = signed_volume(closed.vertices, closed.faces)
    area = surface_area(closed.vertices, closed.faces)
    if not (area > 0 and np.isfinite(vol)):
        return 0.0
    return 36.0 * np.pi * vol * vol / area ** 3


def cap_share(part: Mesh, loops: list[np.ndarray] | None = None) -> float:
    """The area that closing an open part's holes with fans adds, as a share of its own area: small
    for a scan with holes (0.01 for the armadillo with five holes punched), about 1 for a sheet or a
    terrain (0.81 for the shared mountain); inf for a part of no area. ``loops``: its
    :func:`~hybridedit.core.repair.hole_loops`, when the caller has them."""
    from ..core.repair import hole_fans, hole_loops

    area = surface_area(part.vertices, part.faces)
    if not area > 0:
        return np.inf
    loops = hole_loops(part.faces, part.n_vertices) if loops is None else loops
    centres, fans = hole_fans(part, loops)
    return surface_area(np.vstack([part.vertices, centres]), fans) / area


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
    fn = face_vectors(v, f)  # area-weighted
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
    if not is_usable_piece(shell):
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
