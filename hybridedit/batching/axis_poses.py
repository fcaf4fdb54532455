"""Poses of a shape without limbs: bends, twists and tapers of its main axis.

A round or compact shape (a skull, a bust, a ball, a bowl) has extremities but no limbs: a cap of
it swung about its joint shears the ring around it before it moves far, so the poses of
:mod:`hybridedit.batching.poses` that stay within the stretch allowed barely move it. Such a shape
is posed along its *main axis* instead (:class:`MainAxis`, the direction its surface spreads
along most): one end is held, the other turned or scaled about the middle of the axis, and ARAP
bends the part in between. A pose (:func:`draw_axis_pose`) is one of:

- a *bend*: the moving end rotates about an axis across the main axis, through its middle;
- a *twist*: the moving end rotates about the main axis itself;
- a *taper*: the moving end is scaled across the main axis, about it, by ``1 +- 0.4 a / 45``
  for a drawn angle ``a``.

Each is an :class:`~hybridedit.Edit` of two handle groups (the held end with no transform, the
moving end with its rotation or matrix) and nothing fixed besides, so ``hybridedit deform``
replays it as it replays a limb pose.

Examples
--------
The corners of a 4 x 1 x 0.5 box spread along x:

>>> import itertools
>>> box = np.array(list(itertools.product([0.0, 4.0], [0.0, 1.0], [0.0, 0.5])))
>>> a = main_axis(box, np.ones(8))
>>> a.direction.tolist(), a.length, a.middle.tolist()
([1.0, 0.0, 0.0], 4.0, [2.0, 0.5, 0.25])
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["MainAxis", "main_axis", "vertex_areas", "draw_axis_pose", "AXIS_KINDS", "END_FRACTION",
           "ANGLE_FLOOR", "TAPER_PER_45"]

#: the kinds of axis pose, drawn with equal odds
AXIS_KINDS = ("bend", "twist", "taper")
#: each end (the held one, the moving one) spans this fraction of the axis's length
END_FRACTION = (0.2, 0.35)
#: an axis pose's angle is at least this fraction of --max-degrees (a smaller one barely moves)
ANGLE_FLOOR = 0.25
#: a taper's scale change at an angle of 45 degrees
TAPER_PER_45 = 0.4


@dataclass(frozen=True)
class MainAxis:
    """The line a shape spreads along most (n shape vertices).

    Attributes
    ----------
    centre : (3,) float64
        The shape's area-weighted centroid, on the axis.
    direction : (3,) float64 unit vector
        The principal direction of largest spread (its sign: the largest component positive).
    t : (n,) float64
        Each vertex's coordinate along the axis, from ``centre``.
    length : float
        ``t.max() - t.min()``.
    """

    centre: np.ndarray
    direction: np.ndarray
    t: np.ndarray
    length: float

    @property
    def middle(self) -> np.ndarray:
        """(3,) the point on the axis halfway between the shape's two ends."""
        return self.centre + self.direction * 0.5 * (float(self.t.min()) + float(self.t.max()))


def vertex_areas(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(n,) each vertex's share of the surface: a third of the area of every triangle it is a
    corner of (a scan's dense patches do not pull the axis towards them)."""
    from ..core.face_geometry import face_areas

    w = np.zeros(len(vertices))
    np.add.at(w, np.asarray(faces, dtype=np.int64).ravel(), np.repeat(face_areas(vertices, faces) / 3.0, 3))
    return w


def main_axis(vertices: np.ndarray, weights: np.ndarray) -> MainAxis:
    """The main axis of a shape: the weighted principal direction of its vertices.

    Parameters
    ----------
    vertices : (n, 3) float64
    weights : (n,) float64
        Each vertex's weight (:func:`vertex_areas`); all zero: every vertex alike.

    Returns
    -------
    MainAxis
        For a shape that spreads alike in several directions (a ball), one of them, the same on
        every run.
    """
    v = np.asarray(vertices, dtype=np.float64)
    w = np.asarray(weights, dtype=np.float64)
    if not w.sum() > 0:
        w = np.ones(len(v))
    w = w / w.sum()
    centre = w @ v
    d = v - centre
    _, vectors = np.linalg.eigh((d * w[:, None]).T @ d)
    direction = vectors[:, -1]
    direction = direction if direction[np.argmax(np.abs(direction))] > 0 else -direction
    t = d @ direction
    return MainAxis(centre, direction, t, float(t.max() - t.min()))


def _across(direction: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A random unit vector at right angles to ``direction``."""
    while True:
        u = rng.normal(size=3)
        u -= (u @ direction) * direction
        n = float(np.linalg.norm(u))
        if n > 1e-6:
            return u / n


def draw_axis_pose(axis: MainAxis, rng: np.random.Generator, *, max_degrees: float, iterations: int, cage: dict,
                   fingerprint: dict):
    """Draw one bend, twist or taper of the main axis as an edit.

    Parameters
    ----------
    axis : MainAxis
    rng : numpy.random.Generator
        The pose's (:func:`hybridedit.batching.poses.pose_rng`); every draw takes the same numbers
        from it.
    max_degrees : float
        Largest angle; each is drawn in ``ANGLE_FLOOR`` to 1 times it, either way.
    iterations : int
        ARAP iterations the step records.
    cage : dict
        ``{"size": ..., "vertices": ...}``, the cage the pose is made on.
    fingerprint : dict
        The mesh's fingerprint.

    Returns
    -------
    (Edit, str) or (None, str)
        The edit and what it is ("bend 23 degrees"); None when an end holds no vertex (a shape of
        no length).
    """
    from ..fileio.editfile import Edit, HandleEdit

    kind = AXIS_KINDS[int(rng.integers(len(AXIS_KINDS)))]
    fraction = float(rng.uniform(*END_FRACTION))
    held_low = bool(rng.integers(2))
    degrees = float(rng.uniform(ANGLE_FLOOR, 1.0)) * float(max_degrees) * (1.0 if rng.integers(2) else -1.0)
    across = _across(axis.direction, rng)
    lo, hi = float(axis.t.min()), float(axis.t.max())
    low = np.flatnonzero(axis.t <= lo + fraction * axis.length)
    high = np.flatnonzero(axis.t >= hi - fraction * axis.length)
    held, moving = (low, high) if held_low else (high, low)
    if not axis.length > 0 or held.size == 0 or moving.size == 0:
        return None, "the shape has no length along its main axis"
    middle = axis.middle
    if kind == "taper":
        scale = 1.0 + TAPER_PER_45 * degrees / 45.0
        a = axis.direction
        T = np.eye(4)
        T[:3, :3] = np.outer(a, a) + scale * (np.eye(3) - np.outer(a, a))
        T[:3, 3] = middle - T[:3, :3] @ middle
        group = HandleEdit(moving, matrix=T)
        what = f"taper x{scale:.2f}"
    else:
        turn = across if kind == "bend" else axis.direction
        group = HandleEdit(moving, translate=np.zeros(3), rotate={"axis": turn, "degrees": degrees, "center": middle})
        what = f"{kind} {degrees:.0f} degrees"
    edit = Edit(handles=[HandleEdit(held, translate=np.zeros(3)), group], space="shape", iterations=int(iterations),
                cage=dict(cage), mesh=fingerprint)
    return edit, what
