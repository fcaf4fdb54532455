"""The handle gizmo's geometry and drag math: three arrows (translate along X/Y/Z), three rings
(rotate about X/Y/Z) and the centre (move in the view plane).

Plain numpy on the camera's composite projection matrix, in VTK display pixels
(origin bottom-left, y up), so it is testable without a window; the actors that
draw the gizmo are :class:`~hybridedit.viewer.render.gizmo_actors.Gizmo`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...core.transforms import rigid_transform
from .picking import project_points, unproject

AXES = np.eye(3)
RING_SAMPLES = 96
RING_RATIO = 0.7
"""Ring radius as a fraction of the arrow length."""
MIN_AXIS_PIXELS = 12.0
"""An arrow drawn shorter than this on screen cannot be dragged (it points at the viewer)."""


@dataclass(frozen=True)
class Part:
    """A grabbable part of the gizmo: ``kind`` is "move" or "rotate" with ``axis`` 0, 1 or 2,
    or "free" (the center: move parallel to the view plane, ``axis`` -1)."""

    kind: str
    axis: int


def ring_points(center: np.ndarray, axis: int, radius: float, samples: int = RING_SAMPLES) -> np.ndarray:
    """(samples, 3) points of the circle of ``radius`` about world axis ``axis`` through ``center``."""
    u = AXES[(axis + 1) % 3]
    v = AXES[(axis + 2) % 3]
    t = np.linspace(0.0, 2.0 * np.pi, samples, endpoint=False)
    return np.asarray(center) + radius * (np.cos(t)[:, None] * u + np.sin(t)[:, None] * v)


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance from 2D point p to each 2D segment a[i]-b[i]."""
    ab = b - a
    L2 = np.sum(ab * ab, axis=1)
    t = np.where(L2 > 0, np.sum((p - a) * ab, axis=1) / np.where(L2 > 0, L2, 1.0), 0.0)
    t = np.clip(t, 0.0, 1.0)
    q = a + t[:, None] * ab
    return np.linalg.norm(p - q, axis=1)


def hit_test(mouse: tuple[float, float], center: np.ndarray, length: float, composite: np.ndarray,
             size: tuple[int, int], tolerance: float = 8.0) -> Part | None:
    """The gizmo part under the mouse (closest within ``tolerance`` pixels), or None.

    The center (within ``1.5 * tolerance``) is the "free" part; arrows drawn
    shorter than ``MIN_AXIS_PIXELS`` (pointing at the viewer) cannot be grabbed.

    Parameters
    ----------
    mouse : display pixel (x, y).
    center : (3,) gizmo origin in world coordinates.
    length : arrow length in world units (rings have radius ``RING_RATIO * length``).
    composite : (4, 4) world -> NDC matrix; size : (width, height) in pixels.
    """
    m = np.asarray(mouse, dtype=np.float64)
    c = np.asarray(center, dtype=np.float64)
    best: tuple[float, Part] | None = None
    tips, front = project_points(c + length * AXES, composite, size)
    c2, c_front = project_points(c[None], composite, size)
    if not c_front[0]:
        return None
    if float(np.linalg.norm(m - c2[0, :2])) <= 1.5 * tolerance:
        return Part("free", -1)
    for i in range(3):
        if front[i] and np.linalg.norm(tips[i, :2] - c2[0, :2]) >= MIN_AXIS_PIXELS:
            d = float(_segment_distance(m, c2[:, :2], tips[i:i + 1, :2])[0])
            if d <= tolerance and (best is None or d < best[0]):
                best = (d, Part("move", i))
        ring, rf = project_points(ring_points(c, i, RING_RATIO * length), composite, size)
        a = ring[:, :2]
        b = np.roll(a, -1, axis=0)
        ok = rf & np.roll(rf, -1)
        if ok.any():
            d = float(_segment_distance(m, a[ok], b[ok]).min())
            if d <= tolerance and (best is None or d < best[0] - 1.0):
                best = (d, Part("rotate", i))
    return None if best is None else best[1]


def axis_translation(start: tuple[float, float], now: tuple[float, float], center: np.ndarray,
                     axis: int, length: float, composite: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """World translation along ``axis`` for a mouse move from ``start`` to ``now``.

    The mouse motion is projected onto the axis as drawn on screen, so the
    handle follows the cursor along the arrow.
    """
    c = np.asarray(center, dtype=np.float64)
    a = AXES[axis]
    p, _ = project_points(np.stack([c, c + length * a]), composite, size)
    v = (p[1, :2] - p[0, :2]) / length  # pixels per world unit along the axis
    v2 = float(v @ v)
    if np.sqrt(v2) * length < MIN_AXIS_PIXELS:  # the axis points (nearly) at the viewer
        return np.zeros(3)
    d = np.asarray(now, dtype=np.float64) - np.asarray(start, dtype=np.float64)
    return a * float(d @ v) / v2


def grab_direction(mouse: tuple[float, float], center: np.ndarray, axis: int, radius: float,
                   composite: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """Unit vector from the center to the ring point nearest to the mouse (on screen)."""
    ring = ring_points(center, axis, radius)
    p, front = project_points(ring, composite, size)
    d = np.linalg.norm(p[:, :2] - np.asarray(mouse, dtype=np.float64), axis=1)
    d[~front] = np.inf
    k = int(np.argmin(d))
    u = ring[k] - np.asarray(center, dtype=np.float64)
    return u / np.linalg.norm(u)


def swept_degrees(start, now, at) -> float:
    """The angle (degrees, in (-180, 180], counter-clockwise positive) the mouse sweeps round display
    point ``at`` from ``start`` to ``now``.

    Examples
    --------
    >>> swept_degrees((1, 0), (0, 1), (0, 0)), round(swept_degrees((-1, 1), (-1, -1), (0, 0)), 9)
    (90.0, 90.0)
    """
    s = np.asarray(start, dtype=np.float64) - np.asarray(at, dtype=np.float64)
    n = np.asarray(now, dtype=np.float64) - np.asarray(at, dtype=np.float64)
    return float(np.degrees(np.angle(np.exp(1j * (np.arctan2(n[1], n[0]) - np.arctan2(s[1], s[0]))))))


def ring_angle(start: tuple[float, float], now: tuple[float, float], center: np.ndarray, axis: int,
               radius: float, grab: np.ndarray, composite: np.ndarray, size: tuple[int, int]) -> float:
    """Rotation angle (degrees, right-hand rule about world ``axis``) for a mouse move along a ring.

    The mouse motion is projected onto the ring's tangent at the grabbed point
    (``grab``, from :func:`grab_direction`), so dragging along the ring turns it
    under the cursor. When the tangent points at the viewer the angle around the
    projected center is used instead.
    """
    c = np.asarray(center, dtype=np.float64)
    a = AXES[axis]
    g = c + radius * np.asarray(grab, dtype=np.float64)
    t = np.cross(a, grab)
    eps = radius
    p, _ = project_points(np.stack([g, g + eps * t, c, c + a * radius]), composite, size)
    v = (p[1, :2] - p[0, :2]) / eps  # pixels per world unit along the tangent
    s = np.asarray(start, dtype=np.float64)
    n = np.asarray(now, dtype=np.float64)
    if float(np.linalg.norm(v)) * radius >= 4.0:
        arc = float((n - s) @ v) / float(v @ v)
        return float(np.degrees(arc / radius))
    ang = swept_degrees(s, n, p[2, :2])
    # counter-clockwise on screen is positive about an axis pointing at the viewer
    toward = p[3, 2] < p[2, 2]
    return float(ang if toward else -ang)


def screen_plane_translation(start: tuple[float, float], now: tuple[float, float], anchor: np.ndarray,
                             composite: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """World translation parallel to the view plane, at the depth of ``anchor``, for a mouse move."""
    p, _ = project_points(np.asarray(anchor, dtype=np.float64)[None], composite, size)
    z = float(p[0, 2])
    w0 = unproject(start[0], start[1], z, composite, size)
    w1 = unproject(now[0], now[1], z, composite, size)
    return w1 - w0


def part_transform(part: Part, start: tuple[float, float], now: tuple[float, float], center: np.ndarray,
                   length: float, grab: np.ndarray | None, composite: np.ndarray,
                   size: tuple[int, int]) -> np.ndarray:
    """The (4, 4) world transform a gizmo drag from ``start`` to ``now`` asks for."""
    if part.kind == "free":
        return rigid_transform(translate=screen_plane_translation(start, now, center, composite, size))
    if part.kind == "move":
        return rigid_transform(translate=axis_translation(start, now, center, part.axis, length, composite, size))
    radius = RING_RATIO * length
    g = grab if grab is not None else grab_direction(start, center, part.axis, radius, composite, size)
    deg = ring_angle(start, now, center, part.axis, radius, g, composite, size)
    return rigid_transform(axis=AXES[part.axis], degrees=deg, center=center)


def swept_rotation(start: tuple[float, float], now: tuple[float, float], pivot: np.ndarray,
                   composite: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """The (4, 4) world rotation about ``pivot``, in the view plane, by the angle the mouse swept around
    the pivot's place on screen from ``start`` to ``now`` (the Pose tool's drag: a limb turned about its
    joint follows the cursor round it, as Blender's Pose brush does).

    Counter-clockwise on screen is counter-clockwise as seen: about the line of sight through the pivot,
    pointing at the viewer. A mouse on the pivot itself turns nothing.

    Examples
    --------
    Seen from +Z (an orthographic view of the unit square), a quarter turn round the origin:

    >>> C = np.diag([1.0, 1.0, -1.0, 1.0])
    >>> T = swept_rotation((100, 50), (50, 100), np.zeros(3), C, (100, 100))
    >>> np.round(T[:3, :3] @ [1.0, 0, 0], 6).tolist()
    [0.0, 1.0, 0.0]
    """
    c = np.asarray(pivot, dtype=np.float64)
    p, _ = project_points(c[None], composite, size)
    at = p[0, :2]
    if not (np.hypot(*(np.asarray(start) - at)) > 0 and np.hypot(*(np.asarray(now) - at)) > 0):
        return np.eye(4)
    angle = swept_degrees(start, now, at)
    near = unproject(at[0], at[1], -1.0, composite, size)
    far = unproject(at[0], at[1], 1.0, composite, size)
    toward = near - far
    return rigid_transform(axis=toward / np.linalg.norm(toward), degrees=angle, center=c)
