"""One part of the shape simplified by quadric error metrics to a target vertex count.

:func:`simplify` clusters the vertices of a very big part first
(:func:`hybridedit.cage.cluster.cluster_surface`, in linear time), brings a big part near its
target on two cores (:func:`hybridedit.cage.qem.presimplify`), then runs fast-simplification until
the cleaned result (:func:`hybridedit.cage.clean.clean_surface`) is within 2% of the target.
"""

from __future__ import annotations

from typing import Callable

import fast_simplification
import numpy as np

from ..core.mesh import Mesh
from .clean import clean_surface
from .cluster import cluster_surface, clustered_size, clusters_first
from .qem import HalfWorker, presimplify
from .qem_worker import AGGRESSIVENESS
from ..core.bounds import points_box

__all__ = ["HALVES_SHARE", "simplify"]

#: progress share of the two halves of a big part in its simplification (the last pass takes
#: the rest), as measured at 690K-2.7M vertices
HALVES_SHARE = 0.75


def simplify(src: Mesh, target: int, *, progress: Callable[[float], None] | None = None,
             worker: HalfWorker | None = None) -> Mesh:
    """``src`` simplified to about ``target`` vertices, cleaned.

    Parameters
    ----------
    src : Mesh
        One part of the shape (n vertices, m faces), not modified.
    target : int
        The vertex count wanted (met within ``max(2, 2%)`` when the simplifier allows it).
    progress : callable(fraction), optional
        Told :data:`HALVES_SHARE` once the halves of a big part are done.
    worker : HalfWorker, optional
        A helper process started early (:func:`hybridedit.cage.qem.start_worker`) that
        simplifies half of a big part.

    Returns
    -------
    Mesh
        About ``target`` vertices; not necessarily closed (the caller closes its holes).
    """
    ratio = src.n_faces / max(src.n_vertices, 1)
    cage = None
    want_faces = max(4, int(round(target * ratio)))
    # the simplifier has absolute thresholds and loses precision far from the origin:
    # a shape of extreme size or offset is simplified centred and scaled to a unit
    # diagonal (shapes of ordinary size are simplified as they are)
    lo, hi = points_box(src.vertices)
    center = 0.5 * (lo + hi)
    scale = float(np.linalg.norm(hi - lo)) or 1.0
    if 1e-2 <= scale <= 1e4 and float(np.abs(center).max()) <= 1e3 * scale:
        center, scale = np.zeros(3), 1.0
        unit = src.vertices
    else:
        unit = (src.vertices - center) / scale
    faces = src.faces
    if clusters_first(src.n_faces, target):  # most of a big surface's simplification in linear time
        unit, faces = cluster_surface(unit, faces, clustered_size(target))
    # a big surface is first brought near the target on two cores (see hybridedit.cage.qem)
    base_v, base_f = presimplify(unit, faces, want_faces, worker=worker)
    if progress is not None and len(base_f) < src.n_faces:
        progress(HALVES_SHARE)
    for _ in range(3):
        want_faces = min(want_faces, len(base_f))
        v, f = fast_simplification.simplify(base_v, base_f, target_count=want_faces, agg=AGGRESSIVENESS)
        v = np.asarray(v, dtype=np.float64) * scale + center
        cage = clean_surface(v, np.asarray(f, dtype=np.int64))
        got = cage.n_vertices
        if abs(got - target) <= max(2, 0.02 * target) or got == 0:
            break
        want_faces = int(round(want_faces * target / got))
    assert cage is not None
    return cage
