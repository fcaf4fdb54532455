"""3D mean value coordinates with respect to a closed triangle cage: the front.

The coordinates of Ju, Schaefer and Warren, "Mean value coordinates for
closed triangular meshes" (SIGGRAPH 2005), computed by one of three kernels:

* :mod:`hybridedit.binding.mvc_exact`: every face of the cage exactly, per point
  (the reference);
* :mod:`hybridedit.binding.mvc_flat`: exact for the faces near each point, a
  quadrature for the others, still every face per point;
* :mod:`hybridedit.binding.mvc_tree`: for truncated bindings, a hierarchy over the
  cage that accounts for far clusters of cage vertices in aggregate.

They share the layout of the cage and the points (:mod:`hybridedit.binding.mvc_layout`) and the per-face pieces
(:mod:`hybridedit.binding.mvc_faces`: the arctangent, one face's exact weights, the
on-cage cases). Which coordinates a binding keeps is decided in :mod:`hybridedit.binding.truncation`.
This module holds the one public entry point for whole (un-truncated) rows.
"""

from __future__ import annotations

import numpy as np

from ..core.topology import check_closed
from .mvc_exact import as_points, compute_into
from .mvc_faces import atan2_pos_array
from .mvc_flat import FAR_RATIO, check_far_ratio, compute_fast_sorted
from .mvc_layout import LANES, CageData, FastCageData, plan_fast, prepare_cage, prepare_fast_cage

__all__ = ["CageData", "FastCageData", "prepare_cage", "prepare_fast_cage",
           "mean_value_coordinates", "plan_fast", "compute_fast_sorted",
           "atan2_pos_array", "FAR_RATIO", "LANES"]


def mean_value_coordinates(points: np.ndarray, cage_vertices: np.ndarray,
                           cage_faces: np.ndarray, method: str = "exact",
                           far_ratio: float = FAR_RATIO) -> np.ndarray:
    """Un-truncated mean value coordinates of points w.r.t. a closed cage.

    Parameters
    ----------
    points : (n, 3) array
    cage_vertices : (c, 3) array
    cage_faces : (f, 3) int array
        A closed, consistently oriented triangle surface (either orientation).
    method : "exact" or "fast"
        "exact" evaluates every face exactly; "fast" integrates faces farther
        than ``far_ratio`` times their size by quadrature (see
        :mod:`hybridedit.binding.mvc_flat`), within about 1e-5 of the row's
        magnitude of the exact coordinates at the default ratio.
    far_ratio : float >= 1
        Only for "fast" (``inf`` makes it exact).

    Returns
    -------
    (n, c) float64 array
        Row ``i`` holds the coordinates of ``points[i]``; every row sums to 1 and
        ``coords @ cage_vertices`` reproduces ``points`` (to rounding, with
        either method).
    """
    p = as_points(points)
    if method == "exact":
        cage = prepare_cage(cage_vertices, cage_faces)
        check_closed(cage.faces)
        out = np.empty((p.shape[0], cage.n_vertices))
        compute_into(p, cage, out)
        return out
    if method != "fast":
        raise ValueError(f"method must be 'exact' or 'fast', got {method!r}")
    ratio = check_far_ratio(far_ratio)
    fast = prepare_fast_cage(cage_vertices, cage_faces)
    check_closed(fast.exact.faces)
    plan = plan_fast(p, fast)
    buf = np.empty((p.shape[0], fast.n_vertices))
    compute_fast_sorted(plan, fast, 0, p.shape[0], buf, ratio)
    out = np.empty_like(buf)
    out[np.ix_(plan.order, fast.perm)] = buf
    return out