"""Screen-space selection: projection, rectangle and brush hit tests, set logic.

Pure numpy, no Qt or VTK, so it is unit-testable on its own.

Coordinates follow VTK's display convention: pixels, origin at the bottom-left
corner of the view, x to the right, y up. ``composite`` is the camera's
composite projection matrix (world -> normalized device coordinates, as from
``vtkCamera.GetCompositeProjectionTransformMatrix(aspect, -1, 1)``).
"""

from __future__ import annotations

import numpy as np

from ...deform.roles import FIXED, FREE, is_handle

REPLACE, ADD, REMOVE = "replace", "add", "remove"
OPS = (REPLACE, ADD, REMOVE)
CLICK_PIXELS = 4.0
"""A rectangle gesture that moves at most this many pixels is a click (the window's and the browser's)."""
PICK_PIXELS = 12.0
"""A click takes the nearest cage point within this many pixels of it."""
DEPTH_TOLERANCE = 0.5
"""A cage point still counts as in sight when the surface lies at most this many (median) cage edge
lengths in front of it along the line of sight: cage points lie near the surface, some slightly
inside (QEM places them within about 0.15 edge lengths of it along its normal on the creature and
the armadillo; seen at a slant the gap along the line of sight is longer)."""
DEPTH_RADIUS = 1
"""A point on the surface seen within this many pixels of it is in sight (see visible_points). Checked
against a ray cast to the creature from five directions: 0 pixels misses points in sight on the rims of
the silhouettes, and 2 pixels, taking the farthest depth around, takes points well behind the surface;
1 pixel is between (it misses under 1 % of the points the ray reaches)."""


def project_points(points: np.ndarray, composite: np.ndarray, size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Project world points to display pixels.

    Parameters
    ----------
    points : (k, 3) world coordinates.
    composite : (4, 4) world -> normalized device coordinates.
    size : (width, height) of the view in pixels.

    Returns
    -------
    display : (k, 3) float64, x and y in pixels and the NDC depth z in [-1, 1].
    in_front : (k,) bool, the point is in front of the camera (w > 0).
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    C = np.asarray(composite, dtype=np.float64)
    h = p @ C[:3, :3].T + C[:3, 3]
    w = p @ C[3, :3] + C[3, 3]
    in_front = w > 1e-12
    ws = np.where(in_front, w, 1.0)
    ndc = h / ws[:, None]
    out = np.empty_like(ndc)
    out[:, 0] = (ndc[:, 0] + 1.0) * 0.5 * size[0]
    out[:, 1] = (ndc[:, 1] + 1.0) * 0.5 * size[1]
    out[:, 2] = ndc[:, 2]
    return out, in_front


def unproject(x: float, y: float, z_ndc: float, composite: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """The world point at display pixel (x, y) and NDC depth ``z_ndc``; inverse of :func:`project_points`."""
    ndc = np.array([2.0 * x / size[0] - 1.0, 2.0 * y / size[1] - 1.0, z_ndc, 1.0])
    w = np.linalg.solve(np.asarray(composite, dtype=np.float64), ndc)
    return w[:3] / w[3]


def visible_points(display: np.ndarray, in_front: np.ndarray, depth: np.ndarray, origin: tuple[int, int],
                   composite: np.ndarray, size: tuple[int, int], tolerance: float, radius: int = 1) -> np.ndarray:
    """Which projected points are in sight: not hidden behind the surface of a rendered depth buffer.

    A point is in sight when the surface drawn at its pixel lies at most ``tolerance`` in front of it
    (or behind it, or there is none), or when within ``radius`` pixels the surface drawn passes
    within ``tolerance`` of it: a point on the surface near the rim of its silhouette, where its own
    pixel may show the surface much nearer (it slopes steeply there), is in sight; a point behind
    the rim of another part (a hind leg behind a front leg's outline, with the background beyond)
    is not.

    Parameters
    ----------
    display, in_front : the points projected by :func:`project_points` with ``composite`` and ``size``.
    depth : (h, w) window depth in [0, 1] (OpenGL's depth buffer: 0 the near plane, 1 the far plane
        and the background) of the display pixels from ``origin`` (x0, y0), row 0 at the bottom.
    tolerance : distance along the line of sight, in world units: cage points lie near the surface,
        some slightly inside.
    radius : how many pixels around a point to look for the surface through it.

    Returns
    -------
    (k,) bool: in front of the camera, on the depth image, and in sight. Points off the image
    (off screen) are not in sight.
    """
    d = np.asarray(display, dtype=np.float64)
    h, w = depth.shape
    xi = np.floor(d[:, 0]).astype(np.int64) - int(origin[0])
    yi = np.floor(d[:, 1]).astype(np.int64) - int(origin[1])
    on = np.asarray(in_front, dtype=bool) & (xi >= 0) & (xi < w) & (yi >= 0) & (yi < h)
    idx = np.flatnonzero(on)
    x, y = xi[idx], yi[idx]
    # the line of sight through each point: world(z) = (a + z b) / (alpha + z beta) for NDC depth z, so
    # |world(z1) - world(z2)| = |z1 - z2| |a beta - b alpha| / |(alpha + z1 beta)(alpha + z2 beta)|
    Ci = np.linalg.inv(np.asarray(composite, dtype=np.float64))
    nx = 2.0 * d[idx, 0] / size[0] - 1.0
    ny = 2.0 * d[idx, 1] / size[1] - 1.0
    a = np.outer(nx, Ci[:3, 0]) + np.outer(ny, Ci[:3, 1]) + Ci[:3, 3]
    alpha = nx * Ci[3, 0] + ny * Ci[3, 1] + Ci[3, 3]
    b, beta = Ci[:3, 2], Ci[3, 2]
    speed = np.linalg.norm(a * beta - b[None, :] * alpha[:, None], axis=1)
    zp = d[idx, 2]
    wp = alpha + zp * beta

    def gap(window_depth: np.ndarray) -> np.ndarray:
        """How far the surface at this window depth lies in front of the points (negative: behind)."""
        zs = 2.0 * window_depth.astype(np.float64) - 1.0
        return (zp - zs) * speed / np.abs(wp * (alpha + zs * beta))

    tol = float(tolerance)
    seen = gap(depth[y, x]) <= tol
    for dy in range(-radius, radius + 1):
        yy = np.clip(y + dy, 0, h - 1)
        for dx in range(-radius, radius + 1):
            if dx == 0 and dy == 0:
                continue
            zq = depth[yy, np.clip(x + dx, 0, w - 1)]
            seen |= (zq < 1.0) & (np.abs(gap(zq)) <= tol)
    out = np.zeros(len(d), dtype=bool)
    out[idx] = seen
    return out


def in_sight(points: np.ndarray, display: np.ndarray, in_front: np.ndarray, grab, composite: np.ndarray,
             size: tuple[int, int], tolerance: float) -> np.ndarray:
    """Which of ``points`` (projected to ``display``, ``in_front`` with ``composite`` and ``size``) are in
    sight in a depth buffer read by a :class:`~hybridedit.viewer.render.depth_grab.DepthGrab` (its
    ``depth``, ``origin``, ``composite`` and ``size``), by :func:`visible_points` within ``tolerance``
    (world units) and :data:`DEPTH_RADIUS` pixels; points are projected again with the grab's camera
    where it differs (the far plane may).

    Returns
    -------
    (k,) bool: in front of the camera and in sight.
    """
    if grab.size != tuple(size) or not np.allclose(grab.composite, composite, rtol=1e-9, atol=1e-12):
        display, in_front = project_points(points, grab.composite, grab.size)
    vis = visible_points(display, in_front, grab.depth, grab.origin, grab.composite, grab.size, tolerance,
                         DEPTH_RADIUS)
    return np.asarray(in_front, dtype=bool) & vis


def surface_point(at: tuple[float, float], grab) -> np.ndarray | None:
    """(3,) the world point the depth buffer of ``grab`` (a
    :class:`~hybridedit.viewer.render.depth_grab.DepthGrab`: its ``depth``, ``origin``, ``composite`` and
    ``size``) shows at display point ``at``; None over empty space or outside the buffer."""
    x, y = int(np.floor(at[0])) - grab.origin[0], int(np.floor(at[1])) - grab.origin[1]
    h, w = grab.depth.shape
    if 0 <= x < w and 0 <= y < h and grab.depth[y, x] < 1.0:
        return unproject(at[0], at[1], 2.0 * float(grab.depth[y, x]) - 1.0, grab.composite, grab.size)
    return None


def nearest_hit(display: np.ndarray, in_front: np.ndarray, center: tuple[float, float], radius: float) -> np.ndarray:
    """A click: the one projected point nearest to ``center`` within ``radius`` pixels, as a (k,) bool
    mask (all False when there is none); among points at the same pixel the one nearest the camera."""
    d = np.asarray(display)
    dist2 = (d[:, 0] - float(center[0])) ** 2 + (d[:, 1] - float(center[1])) ** 2
    ok = np.asarray(in_front, dtype=bool) & (dist2 <= float(radius) ** 2)
    out = np.zeros(len(d), dtype=bool)
    if ok.any():
        cand = np.flatnonzero(ok)
        out[cand[np.lexsort((d[cand, 2], np.round(dist2[cand], 6)))[0]]] = True
    return out


def rectangle_hits(display: np.ndarray, in_front: np.ndarray, corner_a: tuple[float, float],
                   corner_b: tuple[float, float]) -> np.ndarray:
    """Which projected points lie in the rectangle spanned by two corners (any order).

    Returns a (k,) bool mask; points behind the camera never hit.
    """
    x0, x1 = sorted((float(corner_a[0]), float(corner_b[0])))
    y0, y1 = sorted((float(corner_a[1]), float(corner_b[1])))
    d = np.asarray(display)
    return in_front & (d[:, 0] >= x0) & (d[:, 0] <= x1) & (d[:, 1] >= y0) & (d[:, 1] <= y1)


def brush_hits(display: np.ndarray, in_front: np.ndarray, center: tuple[float, float], radius: float) -> np.ndarray:
    """Which projected points lie within ``radius`` pixels of ``center``; a (k,) bool mask."""
    d = np.asarray(display)
    dx = d[:, 0] - float(center[0])
    dy = d[:, 1] - float(center[1])
    return in_front & (dx * dx + dy * dy <= float(radius) ** 2)


def stroke_hits(display: np.ndarray, in_front: np.ndarray, start: tuple[float, float],
                end: tuple[float, float], radius: float) -> np.ndarray:
    """Points within ``radius`` pixels of the segment start-end (a brush swept between two mouse events)."""
    d = np.asarray(display)[:, :2]
    a = np.asarray(start, dtype=np.float64)
    b = np.asarray(end, dtype=np.float64)
    ab = b - a
    L2 = float(ab @ ab)
    if L2 == 0.0:
        return brush_hits(display, in_front, tuple(a), radius)
    t = np.clip(((d - a) @ ab) / L2, 0.0, 1.0)
    nearest = a + t[:, None] * ab
    dist2 = np.sum((d - nearest) ** 2, axis=1)
    return in_front & (dist2 <= float(radius) ** 2)


def op_from_modifiers(shift: bool, ctrl: bool) -> str:
    """Shift adds, Ctrl removes, neither replaces (Shift wins when both are held)."""
    if shift:
        return ADD
    if ctrl:
        return REMOVE
    return REPLACE


def combine(current: np.ndarray, hits: np.ndarray, op: str) -> np.ndarray:
    """The new selection mask after applying ``hits`` to ``current`` with ``op``."""
    if op not in OPS:
        raise ValueError(f"op must be one of {OPS}, got {op!r}")
    cur = np.asarray(current, dtype=bool)
    h = np.asarray(hits, dtype=bool)
    if op == REPLACE:
        return h.copy()
    if op == ADD:
        return cur | h
    return cur & ~h


def selection_roles(roi: np.ndarray, handle_group: np.ndarray) -> np.ndarray:
    """Per cage vertex role (:mod:`hybridedit.deform.roles`) of a selection given as masks.

    Parameters
    ----------
    roi : (c,) bool, the region of interest.
    handle_group : (c,) int, the role of the handle group each vertex is in (``roles.handle(g)``),
        anything else (0) for none; or a (c,) bool handle mask, which is handle group 0.

    Returns
    -------
    (c,) int8: the handle group's role where there is one, else FREE in the ROI, else FIXED.

    Examples
    --------
    >>> selection_roles(np.array([1, 1, 0, 0], bool), np.array([0, 2, 0, 1])).tolist()
    [0, 2, -1, 1]
    """
    g = np.asarray(handle_group)
    r = np.where(np.asarray(roi, dtype=bool), FREE, FIXED).astype(np.int8)
    h = is_handle(g.astype(np.int64))
    r[h] = g[h]
    return r
