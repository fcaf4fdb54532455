"""Which side of a shape the first camera looks at: its front, given its up axis.

Seen from the front a shape shows its broad side: the camera looks along the horizontal axis of the
shorter extent, at the face of the bounding box spanned by the up axis and the longest horizontal
extent (a biped from the front, as wide as its shoulders; a horse or a cow from the side). Of the two
ends of that axis the front is the one the shape's upper half leans to over its lower half (a head,
arms, claws reach forward); of horizontal extents alike, the axis it leans along is the one looked
along. When the lean is slight, the convention holds: a shape with +Y (or +-X) up faces +Z, with +Z up -Y and with -Z up +Y
(Blender's front view, Z up, looks along +Y), on that axis, else its right (up x front).
"""

from __future__ import annotations

import numpy as np

from .bounds import points_box
from .up_axis import axis_vector

#: Points looked at (every k-th vertex): the front of an 11M-vertex shape is told in milliseconds.
SAMPLE = 200_000
#: The horizontal extents are alike when the shorter is at least this fraction of the longer.
ALIKE = 0.8
#: The upper half leans to one end when its centre is this fraction of the extent off the lower half's.
LEAN = 0.01


def conventional_front(up: str) -> np.ndarray:
    """(3,) unit vector the front of a shape with ``up`` up faces by convention (see the module)."""
    u = axis_vector(up)
    return np.array([0.0, 0, 1]) if up[1] in "XY" else np.array([0.0, -u[2], 0])


def front_direction(vertices: np.ndarray, up: str) -> np.ndarray:
    """(3,) unit vector from the shape towards the camera of its front view (see the module).

    Parameters
    ----------
    vertices : (n, 3) float array, the shape's points.
    up : its up axis, one of :data:`hybridedit.core.up_axis.AXES`.
    """
    u = axis_vector(up)
    front = conventional_front(up)
    v = np.asarray(vertices)[:: max(1, len(vertices) // SAMPLE)]
    if len(v) == 0:
        return front
    lo, hi = (np.asarray(b, dtype=np.float64) for b in points_box(v))
    size = hi - lo
    d_up, d_front = int(np.argmax(np.abs(u))), int(np.argmax(np.abs(front)))
    (a, b) = [d for d in range(3) if d != d_up]
    middle = 0.5 * (lo + hi)
    extent = max(float(np.max(size)), 1e-300)
    height = v @ u - middle @ u
    above, below = height > 1e-9 * extent, height < -1e-9 * extent  # (points on the middle: neither)
    lean = np.mean(v[above], axis=0) - np.mean(v[below], axis=0) if above.any() and below.any() else np.zeros(3)
    leaning = np.abs(lean) > LEAN * extent
    short, long_ = (a, b) if size[a] <= size[b] else (b, a)
    if size[short] >= ALIKE * size[long_]:  # alike: the axis it leans along, else the convention's
        short = max((a, b), key=lambda d: abs(lean[d])) if leaning[a] or leaning[b] else d_front
    direction = front if short == d_front else np.cross(u, front)
    if leaning[short]:
        direction = np.zeros(3)
        direction[short] = np.sign(lean[short])
    return direction
