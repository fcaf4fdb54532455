"""Plausible random poses: limbs found at the shape's extremities, each swung about its joint.

A shape's :class:`~hybridedit.deform.skeleton.Skeleton` is found once, on its cage
(:func:`hybridedit.deform.skeleton.find_skeleton`: its centre, its extremities and the geodesic
distances from each). A pose (:func:`draw_pose`) picks 1 to ``handles`` extremities; each one's region of interest is a
geodesic neighbourhood of it (a random fraction of its distance to the centre), its handle the inner
quarter of that neighbourhood, and its joint where the region meets the fixed part of the shape
(:func:`hybridedit.deform.skeleton.joint_centre`). The
handle turns about the joint's centre, about a random axis, by a random angle within
``max_degrees``: ARAP bends the region in between. The pose is an :class:`~hybridedit.Edit` (shape
vertex indices, one step with its iterations and cage), so ``hybridedit deform`` replays it.

Every random number comes from :func:`pose_rng`, derived from the seed, the input's content hash and
the pose index alone, never from a worker or the order poses run in.

Examples
--------
>>> a, b = pose_rng(7, "ab" * 32, 3), pose_rng(7, "ab" * 32, 3)
>>> float(a.random()) == float(b.random()) != float(pose_rng(7, "ab" * 32, 4).random())
True
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.index_sets import unique_in_range, unique_sorted
from ..deform.skeleton import Skeleton, joint_centre

__all__ = ["Limb", "draw_limbs", "draw_pose", "pose_rng", "limb_extremities", "limbs_only", "ROI_FRACTION",
           "HANDLE_FRACTION", "NECK_LEVER", "NECK_DIAGONAL"]

#: a region of interest's geodesic radius, as a fraction of its extremity's distance to the centre
ROI_FRACTION = (0.35, 0.6)
#: a handle's radius, as a fraction of its region's
HANDLE_FRACTION = 0.25
#: a limb's neck (its region's border ring, mean radius about the joint) is narrower than its lever
#: (the handle's distance to the joint) times this ...
NECK_LEVER = 1.0
#: ... and than the shape's bounding-box diagonal times this (a ball's caps past its equator narrow
#: too, but stay wide: 0.29 of its diagonal where a cow's stubby legs are 0.07 to 0.14)
NECK_DIAGONAL = 0.15


def pose_rng(seed: int, content_hash: str, index: int) -> np.random.Generator:
    """The random generator of pose ``index`` of the input whose content hash is ``content_hash``.

    Parameters
    ----------
    seed : int
        The batch's seed (>= 0).
    content_hash : str
        The input file's SHA-256, hex.
    index : int
        The pose index (>= 0).

    Returns
    -------
    numpy.random.Generator
        PCG64, seeded from (seed, hash, index) only.
    """
    words = [int(seed), *(int(content_hash[i:i + 8], 16) for i in range(0, len(content_hash), 8)), int(index)]
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(words)))


@dataclass(frozen=True)
class Limb:
    """One handle of a drawn pose, in shape vertex indices (h handle and r region vertices).

    Attributes
    ----------
    extremity : int
        Its cage vertex.
    handle : (h,) int64
    region : (r,) int64
        The region of interest (handle included).
    joint : (3,) float64
        The centre of the region's border with the fixed part: the rotation's centre.
    axis : (3,) float64 unit vector
    degrees : float
    """

    extremity: int
    handle: np.ndarray
    region: np.ndarray
    joint: np.ndarray
    axis: np.ndarray
    degrees: float


def _neck(region: np.ndarray, handle: np.ndarray, edges: np.ndarray, vertices: np.ndarray):
    """(the region's border ring's mean radius about its centre, the handle centroid's distance to
    that centre), or None when the region has no border."""
    a, b = region[edges[:, 0]], region[edges[:, 1]]
    border = unique_in_range(np.concatenate([edges[a & ~b, 0], edges[b & ~a, 1]]), len(region))
    if border.size == 0 or not handle.any():
        return None
    joint = vertices[border].mean(axis=0)
    ring = float(np.linalg.norm(vertices[border] - joint, axis=1).mean())
    return ring, float(np.linalg.norm(vertices[handle].mean(axis=0) - joint))


def limb_extremities(skeleton: Skeleton, *, dominant: np.ndarray, vertices: np.ndarray,
                     edges: np.ndarray) -> np.ndarray:
    """Which extremities are limbs: a region drawn about it (the smallest or the largest of
    :data:`ROI_FRACTION`) joins the shape through a neck, a border ring narrower than both the
    handle's lever (:data:`NECK_LEVER`) and a fraction of the shape's size (:data:`NECK_DIAGONAL`).

    A round shape's extremities are not: swinging one of its caps about the cap's border shears
    the ring around it over ``--max-stretch`` before the cap has moved 1% of the shape, so the poses
    kept barely move (a ball, a skull, a bowl: 0.2% to 0.5% of the diagonal).

    Parameters
    ----------
    skeleton : Skeleton
    dominant : (n,) int64
        Each shape vertex's dominant cage vertex.
    vertices : (n, 3) float64
    edges : (e, 2) int64

    Returns
    -------
    (k,) bool
        One flag per extremity of ``skeleton``.
    """
    size = float(np.linalg.norm(vertices.max(axis=0) - vertices.min(axis=0))) if len(vertices) else 0.0
    flags = np.zeros(len(skeleton.extremities), dtype=bool)
    for j in range(len(skeleton.extremities)):
        d = skeleton.distances[j]
        for fraction in ROI_FRACTION:
            radius = fraction * float(skeleton.reach[j])
            neck = _neck((d <= radius)[dominant], (d <= HANDLE_FRACTION * radius)[dominant], edges, vertices)
            if neck is not None and neck[0] < NECK_LEVER * neck[1] and neck[0] < NECK_DIAGONAL * size:
                flags[j] = True
                break
    return flags


def limbs_only(skeleton: Skeleton, limbs: np.ndarray) -> Skeleton:
    """The skeleton of the extremities flagged ``limbs`` (:func:`limb_extremities`) alone."""
    keep = np.flatnonzero(limbs)
    return Skeleton(skeleton.centre, skeleton.extremities[keep], skeleton.reach[keep], skeleton.distances[keep])


def draw_limbs(skeleton: Skeleton, rng: np.random.Generator, *, dominant: np.ndarray, vertices: np.ndarray,
               edges: np.ndarray, handles: int, max_degrees: float) -> list[Limb]:
    """Draw one pose's limbs: which extremities, how far each region reaches, each rotation.

    Parameters
    ----------
    skeleton : Skeleton
    rng : numpy.random.Generator
        The pose's (:func:`pose_rng`); every draw takes the same numbers from it.
    dominant : (n,) int64
        The cage vertex each shape vertex depends on most (its role follows that vertex's).
    vertices : (n, 3) float64
        The shape at rest.
    edges : (e, 2) int64
        The shape's edges.
    handles : int
        Most limbs moved.
    max_degrees : float
        Largest rotation angle.

    Returns
    -------
    list of Limb
        1 to ``handles`` limbs with disjoint regions (a region that would overlap an earlier one
        is left out); empty when the skeleton has no extremity.
    """
    k = len(skeleton.extremities)
    if k == 0:
        return []
    count = int(rng.integers(1, min(handles, k) + 1))
    chosen = rng.choice(k, size=count, replace=False)
    taken = np.zeros(len(vertices), dtype=bool)
    limbs: list[Limb] = []
    for j in chosen:
        radius = float(rng.uniform(*ROI_FRACTION)) * float(skeleton.reach[j])
        axis = rng.normal(size=3)
        degrees = float(rng.uniform(-max_degrees, max_degrees))
        d = skeleton.distances[j]
        region = (d <= radius)[dominant]
        handle = np.flatnonzero((d <= HANDLE_FRACTION * radius)[dominant])
        norm = float(np.linalg.norm(axis))
        if handle.size == 0 or not region.any() or (region & taken).any() or not norm > 0:
            continue
        joint = joint_centre(region, edges, vertices)
        if joint is None:
            continue
        taken |= region
        limbs.append(Limb(int(skeleton.extremities[j]), handle, np.flatnonzero(region), joint, axis / norm,
                          degrees))
    return limbs


def draw_pose(skeleton: Skeleton, rng: np.random.Generator, *, dominant: np.ndarray, vertices: np.ndarray,
              edges: np.ndarray, handles: int, max_degrees: float, iterations: int, cage: dict,
              fingerprint: dict):
    """Draw one pose as an edit (see :func:`draw_limbs` for the draw itself).

    Parameters
    ----------
    skeleton, rng, dominant, vertices, edges, handles, max_degrees
        As :func:`draw_limbs`.
    iterations : int
        ARAP iterations the step records (its settle).
    cage : dict
        ``{"size": ..., "vertices": ...}``, the cage the pose is made on.
    fingerprint : dict
        The mesh's fingerprint (:func:`hybridedit.fileio.editfile.mesh_fingerprint`).

    Returns
    -------
    Edit or None
        One step in shape space: each limb a handle group rotating about its joint, the union of
        the regions the region of interest; None when no limb could be drawn.
    """
    from ..fileio.editfile import Edit, HandleEdit

    limbs = draw_limbs(skeleton, rng, dominant=dominant, vertices=vertices, edges=edges, handles=handles,
                       max_degrees=max_degrees)
    if not limbs:
        return None
    groups = [HandleEdit(limb.handle, translate=np.zeros(3),
                         rotate={"axis": limb.axis, "degrees": limb.degrees, "center": limb.joint})
              for limb in limbs]
    region = unique_sorted(np.concatenate([limb.region for limb in limbs]))
    return Edit(handles=groups, roi=region, space="shape", iterations=int(iterations), cage=dict(cage),
                mesh=fingerprint)
