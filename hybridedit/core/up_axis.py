"""Which way is up for a shape: guessed from the file and the geometry.

The window opens a shape standing the right way up, and its front, side and top views
follow that axis. glTF says it in its specification (+Y up). Otherwise the geometry
tells, when it can: an open scan (a statue scanned on its base, a terrain) has its
outward normals summing to the side it is open away from, which is up; a closed shape
is up the way it rests on a table (:mod:`hybridedit.core.resting`: on a flat base, on
its feet; never on its side across its mirror plane). Nothing telling: +Y, the
convention of most scans and of this window. What the user chooses (View ▸ Up Axis) is
remembered per shape by :mod:`hybridedit.fileio.up_axes`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numba import njit

from .bounds import points_box
from .face_geometry import face_vector
from .mesh import Mesh
from .resting import BAND, resting_up

AXES = ("+Y", "+Z", "-Y", "-Z", "+X", "-X")
"""The up axes a shape can have."""
DEFAULT = "+Y"
#: An open shape's outward normals must sum to at least this fraction of its area to tell which way is up.
OPEN_SHARE = 0.01
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
    # the bottom of the box along each axis of AXES, as the height measured along it
    bottom = np.array([lo[1], lo[2], -hi[1], -hi[2], lo[0], -hi[0]]) + BAND * extent
    total, summed, moment, on_table = _face_sums(v, f, bottom)
    if total <= 0:
        return DEFAULT
    if np.linalg.norm(summed) > OPEN_SHARE * total and np.max(np.abs(summed)) > 0.7 * np.linalg.norm(summed):
        return _name(summed)  # open: the normals sum to the side it is open away from
    return resting_up(v, on_table / total, moment / total, AXES) or DEFAULT


@njit(cache=True)
def _face_sums(v, f, bottom):
    """One pass over the faces: their total area, their area-weighted normals summed (3,), their
    area-weighted centres summed (3,), and for each axis of :data:`AXES` (6,) the area of the faces
    whose centre lies below ``bottom`` of it (heights measured along the axis)."""
    total = 0.0
    summed = np.zeros(3)
    moment = np.zeros(3)
    on_table = np.zeros(6)
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
        centre = ((v[a, 0] + v[b, 0] + v[c, 0]) / 3.0, (v[a, 1] + v[b, 1] + v[c, 1]) / 3.0,
                  (v[a, 2] + v[b, 2] + v[c, 2]) / 3.0)
        for d in range(3):
            moment[d] += area * centre[d]
        for k in range(6):
            if sign[k] * centre[coord[k]] <= bottom[k]:
                on_table[k] += area
    return total, summed, moment, on_table
