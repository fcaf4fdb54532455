"""A shape's limbs, found from its geometry on its cage, and the parts a limb is posed by.

A limb runs from one of the shape's extremities (:func:`~hybridedit.deform.skeleton.find_skeleton`)
to its joint, where it meets the body. Walking from the tip, the level sets of the geodesic distance
from it (the points of the cage's edges at distance t, :func:`cross_sections`) are the limb's
cross-sections: their spread about their centroid (the RMS radius) stays about the limb's radius
along it, then grows fast where the level set leaves the limb for the body around it. The joint is
where that growth starts; a head's, at its neck, the narrowest cross-section between the head and
the body (:func:`find_limbs` says the rules and why). A limb is posed by its
:meth:`Limb.parts`: the limb beyond a free band around the joint turns rigidly (the handle) about
the centre of the cross-section there, ARAP bends the band (:meth:`hybridedit.HybridEditor.pose_limb`).

Everything is measured on the cage at rest, from distances and centroids only: a rigid motion of the
shape moves its limbs with it.

Examples
--------
A bottle (a body of radius 1, 2 high, a neck of radius 0.25 from 2.6 to 5): its neck is its limb,
joined at the shoulder:

>>> import trimesh
>>> z = [0, 0, 2, 2.6, 3, 3.5, 4, 4.5, 5, 5.2]
>>> r = [0, 1, 1, 0.25, 0.25, 0.25, 0.25, 0.25, 0.25, 0]
>>> bottle = trimesh.creation.revolve(np.c_[r, z], sections=16)
>>> v, e = np.asarray(bottle.vertices), np.asarray(bottle.edges_unique)
>>> [neck] = find_limbs(v, e, centre_point=np.array([0, 0, 1.5]), cage_faces=bottle.faces)
>>> neck.tip.tolist(), (neck.joint.round(1) + 0.0).tolist(), round(neck.radius, 2)
([0.0, 0.0, 5.2], [0.0, 0.0, 2.6], 0.27)
>>> part = neck.parts(at=1.0)
>>> bool(part.cage_handle[np.argmax(v[:, 2])]), bool(part.cage_roi[np.argmin(v[:, 2])])
(True, False)
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components, dijkstra

from ..core.facing import conventional_front
from ..core.up_axis import axis_vector
from .roles import FIXED, FREE, handle as handle_role
from .skeleton import edge_graph, find_skeleton

__all__ = ["Limb", "LimbPose", "CrossSections", "cross_sections", "find_limbs", "limb_at", "swing_axis",
           "MAX_LIMB_EXTREMITIES", "ELONGATION", "JUMP", "AHEAD", "GROWTH", "MAX_SHARE", "NECK_SHARE", "MIN_POINTS",
           "MIN_VERTICES", "RETIP", "HEAD_TIPS", "HOVER_MARGIN", "STEP"]

#: extremities of the skeleton looked at for limbs (fingers, ears and bumps come after the limbs)
MAX_LIMB_EXTREMITIES = 16
#: a limb is at least this many of its radii long from its tip to its joint
ELONGATION = 2.0
#: beyond the joint the cross-section grows to at least this many times the limb's radius ...
JUMP = 1.6
#: ... within this many of the limb's radii
AHEAD = 2.0
#: the joint is the last cross-section within this fraction of the thinnest-looking one's radius
GROWTH = 0.1
#: a limb holds at most this fraction of the cage's surface (more is the body, not a limb)
MAX_SHARE = 0.25
#: ... but a head on its neck (:func:`find_limbs`) up to this fraction (more is the rest of the shape)
NECK_SHARE = 0.5
#: a cross-section is measured from at least this many points
MIN_POINTS = 3
#: a limb holds at least this many cage vertices (fewer is a bump too small to bend)
MIN_VERTICES = 5
#: :func:`limb_at` takes a vertex to lie on a limb up to this many times the limb's length from its tip
HOVER_MARGIN = 1.15
#: the tip moves to the limb's point farthest from its joint when its joint's cross-section is then
#: narrower than this fraction of the first one's (it was askew)
RETIP = 0.95
#: a head's tip is looked for among this many of its points, spread over those farther from its joint
#: than its tip (from an extremity with no neck, a quarter as many spread round it find the head first)
HEAD_TIPS = 16
#: cross-sections are taken this fraction of the cage's median edge length apart
STEP = 0.25


@dataclass(frozen=True, eq=False)
class CrossSections:
    """The level sets of a geodesic distance on a cage's edges, at t = 0, step, 2 step, ... (m of them).

    Attributes
    ----------
    t : (m,) float64
        The distances.
    radius : (m,) float64
        RMS distance of each level set's points from their centroid (0 where it has no point).
    centre : (m, 3) float64
        Their centroid (0 where there is no point).
    count : (m,) int64
        How many edges the level set crosses.
    """

    t: np.ndarray
    radius: np.ndarray
    centre: np.ndarray
    count: np.ndarray


def _crossings(distance: np.ndarray, edges: np.ndarray):
    """The edges a distance changes along, with the distances at their two ends (finite, different)."""
    e = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    da, db = distance[e[:, 0]], distance[e[:, 1]]
    ok = np.isfinite(da) & np.isfinite(db) & (da != db)
    return e[ok], da[ok], db[ok]


def cross_sections(distance: np.ndarray, vertices: np.ndarray, edges: np.ndarray, *, step: float) -> CrossSections:
    """The level sets of ``distance`` (linear along each edge) at every multiple of ``step``.

    Parameters
    ----------
    distance : (c,) float64
        A distance per vertex (inf: unreachable, no level set goes through it).
    vertices : (c, 3) float64
    edges : (e, 2) int64
        The surface's edges (an edge that is not on the surface, e.g. a link between cage parts, would
        put points inside it).
    step : float
        Distance between two level sets (> 0).

    Returns
    -------
    CrossSections
        Up to the largest finite distance.

    Examples
    --------
    A square tube of side 2 along x: every level set of x is a square of 4 corners, radius sqrt(2):

    >>> v = np.array([[x, y, z] for x in (0, 1, 2) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    >>> e = [[i, j] for i in range(12) for j in range(i + 1, 12)
    ...      if np.sum(v[i] != v[j]) == 1 and abs(v[i, 0] - v[j, 0]) <= 1]
    >>> cs = cross_sections(v[:, 0], v, np.array(e), step=0.5)
    >>> cs.t.tolist(), cs.radius.round(3).tolist(), cs.count.tolist()
    ([0.0, 0.5, 1.0, 1.5], [1.414, 1.414, 1.414, 1.414], [4, 4, 4, 4])
    """
    if not step > 0:
        raise ValueError(f"step must be > 0, got {step!r}")
    d = np.asarray(distance, dtype=np.float64)
    p = np.asarray(vertices, dtype=np.float64)
    e, da, db = _crossings(d, edges)
    lo, hi = np.minimum(da, db), np.maximum(da, db)
    first = np.ceil(lo / step).astype(np.int64)
    n = np.maximum(np.ceil(hi / step).astype(np.int64) - first, 0)  # the samples k with lo <= k step < hi
    which = np.repeat(np.arange(len(e)), n)
    k = np.repeat(first, n) + (np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n))
    m = int(k.max()) + 1 if k.size else (1 if np.isfinite(d).any() else 0)
    w = (k * step - da[which]) / (db[which] - da[which])
    a, b = p[e[which, 0]], p[e[which, 1]]
    x = a + w[:, None] * (b - a)
    count = np.bincount(k, minlength=m)
    per = np.maximum(count, 1).astype(np.float64)
    centre = np.stack([np.bincount(k, x[:, j], m) for j in range(3)], axis=1) / per[:, None]
    square = np.bincount(k, np.einsum("ij,ij->i", x, x), m) / per
    radius = np.sqrt(np.maximum(square - np.einsum("ij,ij->i", centre, centre), 0.0))
    return CrossSections(np.arange(m) * float(step), radius, centre, count.astype(np.int64))


def _level_weights(distance: np.ndarray, edges: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray] | None:
    """The centroid of the level set at ``t`` as an affine combination of vertices: (j,) indices and
    (j,) weights summing to 1; None when no edge crosses ``t``."""
    e, da, db = _crossings(distance, edges)
    lo, hi = np.minimum(da, db), np.maximum(da, db)
    crossing = (lo <= t) & (t < hi)
    if not crossing.any():
        return None
    e, da, db = e[crossing], da[crossing], db[crossing]
    w = (t - da) / (db - da)
    idx, inverse = np.unique(e, return_inverse=True)
    weights = np.bincount(inverse.reshape(-1, 2)[:, 0], 1.0 - w, len(idx)) \
        + np.bincount(inverse.reshape(-1, 2)[:, 1], w, len(idx))
    return idx.astype(np.int64), weights / len(e)


def _filled(values: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """``values`` with each invalid entry replaced by the last valid one before it (0 before any)."""
    last = np.where(valid, np.arange(len(values)), -1)
    np.maximum.accumulate(last, out=last)
    return np.where(last >= 0, values[np.maximum(last, 0)], 0.0)


def _loop_radius(distance: np.ndarray, vertices: np.ndarray, edges: np.ndarray, faces: np.ndarray, *,
                 step: float, m: int) -> np.ndarray:
    """(m,) the RMS radius of each level set's longest loop, as :func:`cross_sections` samples them (0
    where there is none): a level set that crosses other limbs besides the part walked (the loops round
    a cat's front legs beside the one round its chest) counts its main loop only.

    A triangle the level set crosses joins its points on two of its sides (the side between its lowest
    and highest corner, and one of the two others): a loop is a connected set of points."""
    d = np.asarray(distance, dtype=np.float64)
    p = np.asarray(vertices, dtype=np.float64)
    e, da, db = _crossings(d, edges)
    lo, hi = np.minimum(da, db), np.maximum(da, db)
    first = np.ceil(lo / step).astype(np.int64)
    n = np.maximum(np.ceil(hi / step).astype(np.int64) - first, 0)  # (as cross_sections: lo <= k step < hi)
    start = np.cumsum(n) - n  # (edge i's points are start[i] ... start[i] + n[i] - 1, k = first[i] on)
    which = np.repeat(np.arange(len(e)), n)
    k = np.repeat(first, n) + (np.arange(int(n.sum())) - np.repeat(start, n))
    out = np.zeros(m)
    if not k.size:
        return out
    w = (k * step - da[which]) / (db[which] - da[which])
    x = p[e[which, 0]] + w[:, None] * (p[e[which, 1]] - p[e[which, 0]])
    nv = len(p)
    key = np.minimum(e[:, 0], e[:, 1]) * nv + np.maximum(e[:, 0], e[:, 1])
    by_key = np.argsort(key)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    f = f[np.isfinite(d[f]).all(axis=1)]
    f = np.take_along_axis(f, np.argsort(d[f], axis=1, kind="stable"), axis=1)  # (lowest, middle, highest)

    def side(i: int, j: int) -> np.ndarray:  # (the crossing edge between two of its corners, -1: none)
        q = np.minimum(f[:, i], f[:, j]) * nv + np.maximum(f[:, i], f[:, j])
        at = np.minimum(np.searchsorted(key, q, sorter=by_key), len(key) - 1)
        return np.where(key[by_key[at]] == q, by_key[at], -1)

    across, low, high = side(0, 2), side(0, 1), side(1, 2)
    has = across >= 0
    across, low, high = across[has], low[has], high[has]
    count = n[across]  # (each of the long side's points is joined to the one of the same level on a short side)
    kf = np.repeat(first[across], count) + (np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count))
    across, low, high = np.repeat(across, count), np.repeat(low, count), np.repeat(high, count)
    other = np.where((low >= 0) & (kf < first[np.maximum(low, 0)] + n[np.maximum(low, 0)]), low, high)
    o = np.maximum(other, 0)
    ok = (other >= 0) & (kf >= first[o]) & (kf < first[o] + n[o])
    a = start[across[ok]] + kf[ok] - first[across[ok]]
    b = start[other[ok]] + kf[ok] - first[other[ok]]
    count, label = connected_components(sp.coo_matrix((np.ones(len(a)), (a, b)), shape=(len(k), len(k))),
                                        directed=False)
    size = np.bincount(label, minlength=count)
    level = np.zeros(count, dtype=np.int64)
    level[label] = k
    centre = np.stack([np.bincount(label, x[:, j], count) for j in range(3)], axis=1) / size[:, None]
    square = np.bincount(label, np.einsum("ij,ij->i", x, x), count) / size
    radius = np.sqrt(np.maximum(square - np.einsum("ij,ij->i", centre, centre), 0.0))
    by = np.lexsort((size, level))  # (by level, then size: each level's longest loop last)
    longest = by[np.r_[level[by][1:] != level[by][:-1], True]]
    longest = longest[(level[longest] < m) & (size[longest] >= MIN_POINTS)]
    out[level[longest]] = radius[longest]
    return out


@dataclass(frozen=True, eq=False)
class _Joint:
    """Where a walk found its joint: the cross-section's ``index``; ``neck`` when it is a head's neck
    (:func:`find_limbs`), and then ``clear`` when the head, up to its widest cross-section, holds at
    most :data:`MAX_SHARE` of the surface (a limb's share)."""

    index: int
    neck: bool = False
    clear: bool = True


def _joint_index(cs: CrossSections, share: np.ndarray, *, edge: float, loops=None) -> _Joint | None:
    """The cross-section at the joint (see :func:`find_limbs`), or None when the profile has none;
    ``loops()`` gives the radius of each cross-section's longest loop (:func:`_loop_radius`), to look
    for a neck when there is no other joint (None: no neck)."""
    t, r = cs.t, cs.radius
    measured = cs.count >= MIN_POINTS
    rf = _filled(r, measured)
    valid = measured & (t > 0) & (r > 0) & (share <= MAX_SHARE)
    ahead = np.minimum(np.searchsorted(t, t + AHEAD * np.maximum(r, 0.5 * edge)), len(t) - 1)
    candidate = valid & (t >= ELONGATION * r) & (rf[ahead] >= JUMP * r)
    if candidate.any():
        elongation = np.where(candidate, t / np.where(r > 0, r, 1.0), -np.inf)
        best = int(np.argmax(elongation))  # (the candidate runs' best overall: the run with the most elongated limb)
        return _Joint(_grown(best, rf, share, measured, MAX_SHARE))
    if loops is None:
        return None
    # a head on its neck (see find_limbs): the narrowest cross-section narrower by more than GROWTH than
    # the widest one before it (the head) with a wider one than that head within AHEAD of its radii (the
    # body), and so on the level sets' longest loops too (a "head" may be the loops round other limbs)
    head = np.maximum.accumulate(rf)
    widest = np.maximum.accumulate(np.where(rf >= head, np.arange(len(t)), 0))  # (where the head is widest)
    wider = np.searchsorted(head, head, side="right") <= ahead  # (the first cross-section wider than the head)
    neck = (measured & (t > 0) & (r > 0) & (share <= NECK_SHARE) & (t >= ELONGATION * r)
            & (head > (1.0 + GROWTH) * r) & wider)
    if not neck.any():
        return None
    rl = loops()
    rl = _filled(rl, measured & (rl > 0))
    neck &= np.maximum.accumulate(rl) > (1.0 + GROWTH) * rl
    if not neck.any():
        return None
    best = int(np.argmin(np.where(neck, r, np.inf)))
    return _Joint(_grown(best, rf, share, measured, NECK_SHARE), True, bool(share[widest[best]] <= MAX_SHARE))


def _grown(best: int, rf: np.ndarray, share: np.ndarray, measured: np.ndarray, cap: float) -> int:
    """The last measured cross-section from ``best`` on whose radius is within GROWTH of its."""
    j = best
    limit = (1.0 + GROWTH) * rf[best]
    while j + 1 < len(rf) and rf[j + 1] <= limit and share[j + 1] <= cap:
        j += 1
    while not measured[j]:
        j -= 1
    return j


@dataclass(frozen=True, eq=False)
class LimbPose:
    """How a limb is posed with its joint at ``at`` times its length from the tip (c cage vertices).

    Attributes
    ----------
    limb : int
        The limb's :attr:`Limb.index`.
    at : float
        Where the joint is, as a fraction of the limb's length from its tip.
    distance : float
        The joint's geodesic distance from the tip (``at`` times the length).
    half_width : float
        The free band's half-width about the joint: about the limb's radius there.
    inner, outer : float
        The band's ends, in distance from the tip: the handle is what lies at most ``inner`` from the
        tip, the region of interest what lies at most ``outer`` (``distance`` -+ ``half_width``, but
        for a band widened to hold a vertex or cut short of the shape's centre).
    cage_handle : (c,) bool
        The cage vertices that turn rigidly: the limb beyond the free band (``cage_distance <= inner``).
    cage_roi : (c,) bool
        The region of interest: the handle and the free band around the joint (``cage_distance <=
        outer``; the rest is fixed).
    joint : (3,) float64
        The pivot: the centre of the limb's cross-section at the joint.
    axis : (3,) float64
        Unit vector from the joint to the tip.
    extremity : int
        The cage vertex at the tip.
    joint_vertices : (j,) int64
    joint_weights : (j,) float64
        The joint as an affine combination of cage vertices (weights summing to 1), so that
        :meth:`placed` finds it in any pose of the cage.
    """

    limb: int
    at: float
    distance: float
    half_width: float
    inner: float
    outer: float
    cage_handle: np.ndarray = field(repr=False)
    cage_roi: np.ndarray = field(repr=False)
    joint: np.ndarray
    axis: np.ndarray
    extremity: int
    joint_vertices: np.ndarray = field(repr=False)
    joint_weights: np.ndarray = field(repr=False)

    @property
    def cage_roles(self) -> np.ndarray:
        """(c,) int8 role of each cage vertex (:mod:`hybridedit.deform.roles`): the handle is group 0."""
        roles = np.full(len(self.cage_roi), FIXED, dtype=np.int8)
        roles[self.cage_roi] = FREE
        roles[self.cage_handle] = handle_role(0)
        return roles

    def placed(self, cage_positions: np.ndarray) -> "LimbPose":
        """The same parts with :attr:`joint` and :attr:`axis` where a pose of the cage puts them.

        Parameters
        ----------
        cage_positions : (c, 3) float64
            The cage in some pose (at rest, the cage's vertices: the same parts).

        Returns
        -------
        LimbPose
        """
        y = np.asarray(cage_positions, dtype=np.float64)
        joint = self.joint_weights @ y[self.joint_vertices]
        return replace(self, joint=joint, axis=_unit(y[self.extremity] - joint, self.axis))


def _unit(v: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    n = float(np.linalg.norm(v))
    return v / n if n > 0 and np.isfinite(n) else np.asarray(fallback, dtype=np.float64)


@dataclass(frozen=True, eq=False)
class Limb:
    """One limb of a shape, on its cage at rest (c cage vertices, m cross-sections).

    Attributes
    ----------
    index : int
        Its place in :func:`find_limbs`' list.
    extremity : int
        The cage vertex at its tip.
    tip : (3,) float64
        That vertex's position.
    length : float
        Geodesic distance from the tip to the joint.
    radius : float
        The RMS radius of its cross-section at the joint.
    joint : (3,) float64
        The centre of that cross-section: where the limb meets the body.
    cage_distance : (c,) float64
        Geodesic distance of every cage vertex from the tip (inf: unreachable).
    reach : float
        Geodesic distance from the tip to the shape's centre (no part reaches it).
    edge_length : float
        The cage's median edge length (the finest a band is measured).
    profile_t, profile_radius : (m,) float64
        The radius of its cross-sections from the tip on (those measured).
    cage_vertices : (c, 3) float64
    cage_edges : (e, 2) int64
        The cage the limb was found on (the surface's edges).
    """

    index: int
    extremity: int
    tip: np.ndarray
    length: float
    radius: float
    joint: np.ndarray
    cage_distance: np.ndarray = field(repr=False)
    reach: float = field(repr=False)
    edge_length: float = field(repr=False)
    profile_t: np.ndarray = field(repr=False)
    profile_radius: np.ndarray = field(repr=False)
    cage_vertices: np.ndarray = field(repr=False)
    cage_edges: np.ndarray = field(repr=False)

    @property
    def cage_region(self) -> np.ndarray:
        """(c,) bool: the cage vertices from the tip to the joint."""
        return self.cage_distance <= self.length

    def radius_at(self, t: float) -> float:
        """The RMS radius of the limb's cross-section ``t`` from its tip (interpolated)."""
        return float(np.interp(t, self.profile_t, self.profile_radius))

    def parts(self, at: float = 1.0) -> LimbPose:
        """The handle, region of interest and pivot that pose the limb with its joint at ``at`` times
        its length from the tip.

        The free band about the joint is the radius of the cross-section there each side (an elbow
        bends over about its thickness; past the limb's joint, the cut through the body is as wide as
        the body there), at least half a cage edge and at most half the way back to the tip, so that
        it is never empty and never the whole limb; it stops short of the shape's centre, so that
        something stays fixed.

        Parameters
        ----------
        at : float
            The joint's place along the limb from the tip, as a fraction of its length (> 0; the
            window moves it in steps of 0.1 in about [0.2, 1.5]).

        Returns
        -------
        LimbPose
            In the rest pose (:meth:`LimbPose.placed` puts it in another).

        Raises
        ------
        ValueError
            ``at`` not a positive number.
        """
        at = float(at)
        if not (np.isfinite(at) and at > 0):
            raise ValueError(f"at must be a positive number, got {at!r}")
        d = self.cage_distance
        t = at * self.length
        # (beyond the joint the cross-section is the body's, wider: so is the band, the cut through
        # the body bending over as much as its thickness)
        w = min(max(self.radius_at(t), 0.5 * self.edge_length), 0.5 * t)
        inner = t - w
        outer = max(min(t + w, np.nextafter(self.reach, 0.0)), inner)
        handle = d <= inner
        roi = d <= outer
        if not (roi & ~handle).any():  # (a band between two cage vertices: out to the next one)
            beyond = d[~handle & np.isfinite(d)]
            if beyond.size:
                outer = float(beyond.min())
                roi = d <= outer
        level = _level_weights(d, self.cage_edges, t)
        if level is None:  # (no edge crosses t: the band's vertices stand for the cross-section)
            idx = np.flatnonzero(roi & ~handle)
            level = idx, np.full(len(idx), 1.0 / len(idx))
        joint = level[1] @ self.cage_vertices[level[0]]
        axis = _unit(self.tip - joint, _unit(self.tip - self.joint, np.array([0.0, 0.0, 1.0])))
        return LimbPose(self.index, at, t, w, float(inner), float(outer), handle, roi, joint, axis, self.extremity,
                        *level)


def find_limbs(cage_vertices: np.ndarray, cage_edges: np.ndarray, *, centre_point: np.ndarray,
               cage_faces: np.ndarray | None = None, links: np.ndarray | None = None,
               max_extremities: int = MAX_LIMB_EXTREMITIES) -> list[Limb]:
    """A shape's limbs, from its cage at rest.

    Each extremity of the skeleton (:func:`~hybridedit.deform.skeleton.find_skeleton`) is walked
    from its tip through the cross-sections of the geodesic distance from it (:func:`cross_sections`,
    a quarter of a cage edge apart). The rule for its joint: a cross-section is a joint candidate when
    the part from the tip to it is at least :data:`ELONGATION` of its radii long and, :data:`AHEAD`
    radii further on, the cross-section is :data:`JUMP` times as wide (the level set has left the
    limb: on the body around it, it grows about as fast as the distance). Among the candidates the
    most elongated (length over radius) is taken: a finger's joint on a hand or a horn's on a head
    loses to the arm's or the head's. The joint is put at the last cross-section after it whose
    radius is within :data:`GROWTH` of its, where the growth starts, so that a limb that thickens
    slowly keeps its thick part. On the creature (``data/creature.ply``, its default cage) the right
    arm's radius is 0.05 to 0.08 from the wrist (0.4 from the fingertip) to 0.8, 0.087 at 0.86, then
    0.16 at 1.0 and 0.34 at 1.3 on the chest: its joint is at 0.86, the shoulder (x = -0.34, the
    hand at -1.15). A radius that only grows as fast as the distance from the start (a point on the
    body, a belly, a back) is no limb, nor is a region holding more than :data:`MAX_SHARE` of the
    cage's surface or fewer than :data:`MIN_VERTICES` of its vertices.

    The tip is then put at the limb's point farthest from its joint and the walk made again from
    there, kept when the joint's cross-section comes out narrower and the walk reaches the first tip
    (an extremity is the farthest point from the centre: on a foot's side as often as on its sole, and
    cross-sections from the side run askew across the limb, wider than it).

    A head on a neck about as wide as it has no such jump, and with its neck it holds more than
    :data:`MAX_SHARE` of the surface; a walk with no joint looks for one as a neck instead: the
    narrowest cross-section narrower by more than :data:`GROWTH` than the widest before it (the head),
    with a wider one than that head within :data:`AHEAD` of its radii (the body: however gradual the
    widening), holding at most :data:`NECK_SHARE` of the surface, and so too on the level sets' longest
    loops (a level set that spans the loops round other limbs is wide by them, not by a head). Its
    tip is then the point from which the neck is narrowest, of :data:`HEAD_TIPS` spread over the head
    farther from its joint than the tip, again while narrower by :data:`RETIP` (the extremities on a
    head are a horn's, an ear's or a side of its face, from which the cross-sections run askew across
    the neck); from an extremity with no neck, a quarter as many spread over the quarter of the
    surface around it find the head first. The head is kept when, from its best tip, its part up to
    its widest cross-section holds at most :data:`MAX_SHARE` of the surface (a body's front walked
    from a point on it is widest past that). On Spot (``spot_triangulated.obj``, its default cage of
    148 vertices) the extremity on the head is a corner of the muzzle, from which the radius is 0.44
    at 0.95 and 0.39 at 1.05; from the top of the face it is 0.39 at 0.63 (the head), 0.26 at 0.95 (the
    neck), 0.31 at 1.16, 0.44 at 1.47 (the body): the joint is at 1.05, between the withers and the
    brisket (y = 0.18, the back at 0.35 and the chin at 0.1), the head a third of the surface.

    An extremity that lies on a limb found before (a second finger of a hand, a point half way along
    a tail), or whose limb holds the tip of one found before, is left out; but for a part of a head
    (an ear, a horn): wholly on it, away from its tip and :data:`JUMP` times thinner than its neck
    (the head is to it what the body is to a limb).

    Parameters
    ----------
    cage_vertices : (c, 3) float64
        The cage at rest.
    cage_edges : (e, 2) int64
        The cage's surface edges (its faces').
    centre_point : (3,) float64
        The shape's centre of mass.
    cage_faces : (f, 3) int64, optional
        The cage's triangles, to measure a limb's share of the surface by their areas and to find a
        head's neck (by its level sets' loops); without them each vertex counts a quarter of its
        edges' squared lengths (about its area on a mesh of triangles alike, far from it on long thin
        ones), and there is no head on a neck.
    links : (k, 2) int64, optional
        Extra edges tying separate cage parts together (:attr:`hybridedit.Rig.links`): they carry the
        geodesic distance from part to part, but no cross-section is measured on them.
    max_extremities : int
        Extremities of the skeleton looked at.

    Returns
    -------
    list of Limb
        In the skeleton's order (farthest extremity first); each :attr:`Limb.index` its place.

    Examples
    --------
    >>> import hybridedit as he
    >>> ed = he.open("creature.ply")  # doctest: +SKIP
    >>> limbs = find_limbs(ed.cage.vertices, ed.cage.edges(), cage_faces=ed.cage.faces,
    ...                    centre_point=ed.mesh.vertices.mean(axis=0), links=ed.rig.links)  # doctest: +SKIP
    >>> [limb.tip.round(1).tolist() for limb in limbs]  # doctest: +SKIP
    [[0.0, 0.0, -1.0], [-0.2, 1.1, -0.2], [-1.1, 0.2, 0.0], [1.1, 0.2, 0.0], ...]
    """
    v = np.asarray(cage_vertices, dtype=np.float64)
    surface = np.asarray(cage_edges, dtype=np.int64).reshape(-1, 2)
    extra = np.zeros((0, 2), dtype=np.int64) if links is None else np.asarray(links, dtype=np.int64).reshape(-1, 2)
    skeleton = find_skeleton(v, np.concatenate([surface, extra]), centre_point, max_extremities=max_extremities)
    if len(surface) == 0 or len(skeleton.extremities) == 0:
        return []
    lengths = np.linalg.norm(v[surface[:, 0]] - v[surface[:, 1]], axis=1)
    edge = float(np.median(lengths[lengths > 0])) if (lengths > 0).any() else 0.0
    if not edge > 0:
        return []
    cage = _Cage(v, surface, None if cage_faces is None else np.asarray(cage_faces, dtype=np.int64).reshape(-1, 3),
                 _vertex_areas(v, surface, lengths, cage_faces), edge, edge_graph(v, np.concatenate([surface, extra])))
    limbs: list[Limb] = []
    heads: list[bool] = []
    for k, x in enumerate(skeleton.extremities):
        x, d = int(x), skeleton.distances[k]
        found = _walk(d, cage)
        if found is not None and not found.neck:
            x, d, found = _retip(x, d, found, cage)
        else:
            if cage.faces is None or any(prev.cage_distance[x] <= prev.length and not heads[prev.index]
                                         for prev in limbs):
                continue  # (no head without triangles, nor from a point on a limb found before)
            head = _head(x, d, found, cage)
            if head is None or not head[2].clear:  # (from its best tip, its widest part is the body's)
                continue
            x, d, found = head
        length, radius, cs, (ring, weights) = found.length, found.radius, found.cs, found.level
        if np.count_nonzero(d <= length) < MIN_VERTICES:
            continue
        if any(not _nested(d, x, length, radius, found.neck, prev, heads[prev.index]) for prev in limbs
               if prev.cage_distance[x] <= prev.length or d[prev.extremity] <= length):
            continue
        measured = cs.count >= MIN_POINTS
        limbs.append(Limb(len(limbs), x, v[x].copy(), length, radius, weights @ v[ring], d,
                          float(d[skeleton.centre]), edge, cs.t[measured], cs.radius[measured], v, surface))
        heads.append(found.neck)
    return limbs


@dataclass(frozen=True, eq=False)
class _Cage:
    """What a walk reads of the cage: vertices (c, 3), surface edges (e, 2), triangles (f, 3) or None,
    each vertex's area (c,), the median edge length and the edge graph (links included)."""

    v: np.ndarray
    surface: np.ndarray
    faces: np.ndarray | None
    area: np.ndarray
    edge: float
    graph: object


@dataclass(frozen=True, eq=False)
class _Found:
    """A walk's limb: its length, its radius at the joint, its cross-sections, the joint's level set as
    (vertices, weights), and whether the joint is a neck, and a clear one (:class:`_Joint`)."""

    length: float
    radius: float
    cs: CrossSections
    level: tuple
    neck: bool
    clear: bool


def _walk(d: np.ndarray, cage: _Cage) -> _Found | None:
    """Walk a limb from its tip (``d``, the distance from it); None when it has no joint."""
    finite = np.isfinite(d)
    order = np.argsort(d[finite], kind="stable")
    held = np.cumsum(cage.area[finite][order])
    step = STEP * cage.edge
    cs = cross_sections(d, cage.v, cage.surface, step=step)
    at = np.searchsorted(d[finite][order], cs.t, side="right")
    share = np.where(at > 0, held[np.maximum(at - 1, 0)], 0.0) / max(float(held[-1]), np.finfo(float).tiny)
    loops = None if cage.faces is None else (lambda: _loop_radius(d, cage.v, cage.surface, cage.faces, step=step,
                                                                   m=len(cs.t)))
    joint = _joint_index(cs, share, edge=cage.edge, loops=loops)
    if joint is None:
        return None
    length = float(cs.t[joint.index])
    level = _level_weights(d, cage.surface, length)
    if level is None:  # (a measured cross-section has points: never)
        return None
    return _Found(length, float(cs.radius[joint.index]), cs, level, joint.neck, joint.clear)


def _retip(x: int, d: np.ndarray, found: _Found, cage: _Cage) -> tuple[int, np.ndarray, _Found]:
    """The tip again, as the limb's point farthest from its joint: (the tip, the distance from it, its
    walk). An extremity is the farthest point from the centre, on a foot's side as often as on its sole,
    and the cross-sections from a point on the side run askew across the limb (a curled tail's farthest
    point from its base may be on the curl: then the cross-sections are no narrower and the tip stays);
    the walk from there is kept when narrower and the same limb's (it reaches the first tip: not a
    finger's or a horn's on it)."""
    ring, weights = found.level
    far = int(np.argmax(np.where(d <= found.length, np.linalg.norm(cage.v - weights @ cage.v[ring], axis=1),
                                 -np.inf)))
    if far != x:
        d_far = dijkstra(cage.graph, indices=far)
        again = _walk(d_far, cage)
        if again is not None and not again.neck and again.radius < RETIP * found.radius and d_far[x] <= again.length:
            return far, d_far, again  # (square across the limb: narrower)
    return x, d, found


def _head(x: int, d: np.ndarray, found: _Found | None, cage: _Cage) -> tuple[int, np.ndarray, _Found] | None:
    """The head the tip ``x`` lies on (see :func:`find_limbs`), walked from its best tip: (the tip, the
    distance from it, its walk); None when no walk from near ``x`` finds a neck."""
    if found is None:  # (no neck from x: from points spread over the quarter of the surface around it)
        order = np.argsort(d, kind="stable")
        held = np.cumsum(cage.area[order])
        reach = d[order][min(int(np.searchsorted(held, MAX_SHARE * held[-1])), len(order) - 1)]
        best = _narrowest(x, _spread(cage.v, np.flatnonzero(d <= reach), cage.v[x], HEAD_TIPS // 4), cage, np.inf)
    else:
        best = (x, d, found)
    while best is not None:  # (then from points spread over the head beyond its tip, from its joint)
        y, d_y, walk = best
        ring, weights = walk.level
        far = np.where(d_y <= walk.length, np.linalg.norm(cage.v - weights @ cage.v[ring], axis=1), -np.inf)
        better = _narrowest(y, _spread(cage.v, np.flatnonzero(far > far[y]), weights @ cage.v[ring], HEAD_TIPS),
                            cage, RETIP * walk.radius)
        if better is None:
            return best
        best = better
    return None


def _narrowest(x: int, tries: list[int], cage: _Cage, below: float) -> tuple[int, np.ndarray, _Found] | None:
    """Of the walks from ``tries`` that find a neck holding ``x`` narrower than ``below``, the one
    whose neck is narrowest: (its tip, the distance from it, the walk); None when there is none."""
    best = None
    for y in tries:
        if y == x:
            continue
        d_y = dijkstra(cage.graph, indices=y)
        walk = _walk(d_y, cage)
        if walk is None or not walk.neck or d_y[x] > walk.length or not walk.radius < below:
            continue  # (no neck, or another limb's: a horn on the head)
        if best is None or walk.radius < best[2].radius:
            best = (y, d_y, walk)
    return best


def _nested(d: np.ndarray, x: int, length: float, radius: float, head: bool, prev: Limb, prev_head: bool) -> bool:
    """Whether a limb from ``x`` (``d`` the distance from it, ``length``, ``radius``, ``head`` if it is a
    head on a neck) and ``prev``, found before, one of which holds the other's tip, nest: a head and a
    part wholly on it, away from its tip and :data:`JUMP` times thinner than its neck (an ear, a horn:
    the head is to it what a body is to a limb)."""
    region = d <= length
    if prev.cage_distance[x] <= prev.length:  # (its tip on prev: the part)
        return (prev_head and bool(prev.cage_region[region].all()) and not d[prev.extremity] <= length
                and JUMP * radius <= prev.radius)
    return head and bool(region[prev.cage_region].all()) and JUMP * prev.radius <= radius


def _spread(v: np.ndarray, idx: np.ndarray, start: np.ndarray, n: int) -> list[int]:
    """Up to ``n`` of the vertices ``idx`` spread over them: the farthest from the point ``start``, then
    each the farthest from those before."""
    p = v[idx]
    gap = np.linalg.norm(p - start, axis=1)
    out: list[int] = []
    while len(out) < n and len(gap):
        i = int(np.argmax(gap))
        if not gap[i] > 0:
            break
        out.append(int(idx[i]))
        gap = np.minimum(gap, np.linalg.norm(p - p[i], axis=1))
    return out


def _vertex_areas(v: np.ndarray, edges: np.ndarray, lengths: np.ndarray, faces: np.ndarray | None) -> np.ndarray:
    """(c,) each vertex's share of the surface: a third of its triangles' areas; without triangles,
    a quarter of its edges' squared lengths (a regular mesh's vertex has 6 edges of length l and
    0.87 l^2 of area: the factor cancels in a share)."""
    if faces is None:
        return np.bincount(edges.ravel(), np.repeat(lengths ** 2, 2), len(v)) / 4.0
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    area = 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)
    return np.bincount(f.ravel(), np.repeat(area / 3.0, 3), len(v))


def limb_at(limbs: list[Limb], cage_vertex: int, *, margin: float = HOVER_MARGIN) -> Limb | None:
    """The limb a cage vertex lies on (for a hover): of the limbs it is at most ``margin`` times
    their length from the tip of, the one it is the smallest fraction of the length along.

    Parameters
    ----------
    limbs : list of Limb
    cage_vertex : int
    margin : float

    Returns
    -------
    Limb or None

    Examples
    --------
    >>> import trimesh
    >>> bottle = trimesh.creation.revolve(np.c_[[0, 1, 1, 0.25, 0.25, 0.25, 0], [0, 0, 2, 2.6, 4, 5, 5.2]], sections=16)
    >>> v, e = np.asarray(bottle.vertices), np.asarray(bottle.edges_unique)
    >>> limbs = find_limbs(v, e, centre_point=np.array([0, 0, 1.5]), cage_faces=bottle.faces)
    >>> limb_at(limbs, int(np.argmax(v[:, 2]))).index, limb_at(limbs, int(np.argmin(v[:, 2])))
    (0, None)
    """
    best, along = None, np.inf
    for limb in limbs:
        f = float(limb.cage_distance[int(cage_vertex)]) / limb.length if limb.length > 0 else np.inf
        if f <= margin and f < along:
            best, along = limb, f
    return best


def swing_axis(axis: np.ndarray, *, up: str = "+Y") -> np.ndarray:
    """The axis a limb swings about by default: perpendicular to the limb and the up axis (unit
    ``axis`` x ``up``: an arm held out sideways swings up and down, positive degrees raising it); a
    limb within 30 degrees of the vertical (a leg, a neck) swings about ``axis`` x front instead, the
    front being the up axis's conventional one (+Z for +Y up: a leg swings forward, a head nods).

    Parameters
    ----------
    axis : (3,) float64
        The limb's direction, from its joint to its tip.
    up : str
        The shape's up axis (:data:`hybridedit.core.up_axis.AXES`).

    Returns
    -------
    (3,) float64 unit vector

    Examples
    --------
    >>> swing_axis(np.array([1.0, 0, 0])).tolist(), swing_axis(np.array([0.0, -1, 0])).tolist()
    ([0.0, 0.0, 1.0], [-1.0, 0.0, 0.0])
    """
    a = _unit(np.asarray(axis, dtype=np.float64), np.array([1.0, 0.0, 0.0]))
    side = np.cross(a, axis_vector(up))
    if np.linalg.norm(side) < 0.5:  # (sin 30 degrees)
        side = np.cross(a, conventional_front(up))
    return _unit(side, np.array([1.0, 0.0, 0.0]))
