"""Which way is up for a shape: guessed from the file and the geometry.

The window opens a shape standing the right way up, and its front, side and top views
follow that axis. glTF says it in its specification (+Y up). Otherwise the geometry
tells, when it can: an open scan (a statue scanned on its base, a terrain) has its
outward normals summing to the side it is open away from, which is up; a closed shape
standing on a flat base has a flat patch of faces at one end of its bounding box facing
down. Nothing telling: +Y, the convention of most scans and of this window. What the
user chooses (View ▸ Up Axis) is remembered per shape by :mod:`hybridedit.fileio.up_axes`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numba import njit

from .face_geometry import face_vector
from .mesh import Mesh
from .bounds import points_box

AXES = ("+Y", "+Z", "-Y", "-Z", "+X", "-X")
"""The up axes a shape can have."""
DEFAULT = "+Y"
#: An open shape's outward normals must sum to at least this fraction of its area to tell which way is up.
OPEN_SHARE = 0.01
#: A flat base: faces within this angle of facing straight down ...
FLAT_DEGREES = 10.0
#: ... within this fraction of the extent from the bottom of the bounding box ...
FLAT_BAND = 0.01
#: ... covering at least this fraction of the shape's area.
FLAT_SHARE = 0.03
#: File suffixes whose format fixes the up axis.
FORMAT_UP = {".glb": "+Y", ".gltf": "+Y"}


def axis_vector(axis: str) -> np.ndarray:
    """(3,) float64 unit vector of an axis name ("+Y", "-Z", ...).

    Raises
    ------
    ValueError
        Not one of :data:`AXES`.
    """
    if axis not in AXES:
        raise ValueError(f"up axis must be one of {AXES}, got {axis!r}")
    v = np.zeros(3)
    v["XYZ".index(axis[1])] = 1.0 if axis[0] == "+" else -1.0
    return v


def _name(v: np.ndarray) -> str:
    k = int(np.argmax(np.abs(v)))
    return ("+" if v[k] > 0 else "-") + "XYZ"[k]


def guess_up_axis(mesh: Mesh, *, path: str | Path | None = None) -> str:
    """The up axis a shape most likely has (see the module's description).

    Parameters
    ----------
    mesh : Mesh
        The shape (n vertices, m triangles).
    path : the file it was read from (its format may say), optional.

    Returns
    -------
    str, one of :data:`AXES`.

    Examples
    --------
    >>> guess_up_axis(he.read_mesh("statue_on_its_base.ply"))  # doctest: +SKIP
    '+Z'
    """
    if path is not None and Path(path).suffix.lower() in FORMAT_UP:
        return FORMAT_UP[Path(path).suffix.lower()]
    v = np.ascontiguousarray(mesh.vertices, dtype=np.float64)
    f = np.ascontiguousarray(mesh.faces, dtype=np.int64)
    if len(f) == 0:
        return DEFAULT
    lo, hi = points_box(v)
    extent = max(float(np.max(hi - lo)), 1e-300)
    # the bottom of the box along each axis, as the height measured down it goes
    bottom = np.array([lo[1], lo[2], -hi[1], -hi[2], lo[0], -hi[0]]) + FLAT_BAND * extent
    total, summed, flat = _face_sums(v, f, bottom, np.cos(np.radians(FLAT_DEGREES)))
    if total <= 0:
        return DEFAULT
    if np.linalg.norm(summed) > OPEN_SHARE * total and np.max(np.abs(summed)) > 0.7 * np.linalg.norm(summed):
        return _name(summed)  # open: the normals sum to the side it is open away from
    best = int(np.argmax(flat))  # (the first of equal areas, in the order of AXES)
    if flat[best] > 0 and flat[best] > FLAT_SHARE * total:
        return AXES[best]
    return DEFAULT


@njit(cache=True)
def _face_sums(v, f, bottom, cos):
    """One pass over the faces: their total area, their area-weighted normals summed (3,), and for
    each axis of :data:`AXES` (6,) the area of the faces facing down it (within ``cos``) whose
    centre lies below ``bottom`` of it (heights measured along the axis)."""
    total = 0.0
    summed = np.zeros(3)
    flat = np.zeros(6)
    # (the coordinate and the sign of each axis of AXES: +Y +Z -Y -Z +X -X)
    coord = (1, 2, 1, 2, 0, 0)
    sign = (1.0, 1.0, -1.0, -1.0, 1.0, -1.0)
    for t in range(f.shape[0]):
        a, b, c = f[t, 0], f[t, 1], f[t, 2]
        cx, cy, cz = face_vector(v, f, t)
        nx, ny, nz = 0.5 * cx, 0.5 * cy, 0.5 * cz
        area = np.sqrt(nx * nx + ny * ny + nz * nz)
        total += area
        summed[0] += nx
        summed[1] += ny
        summed[2] += nz
        if area <= 0.0:
            continue
        n = (nx / area, ny / area, nz / area)
        for k in range(6):
            d = coord[k]
            facing_down = -sign[k] * n[d]
            height = sign[k] * (v[a, d] + v[b, d] + v[c, d]) / 3.0
            if facing_down > cos and height <= bottom[k]:
                flat[k] += area
    return total, summed, flat
