"""The canonical edit, shared by the tests and the benchmarks (``benchmarks/common.py`` re-exports it).

The tests import it as ``support.edits`` (tests/ is on their path); the benchmarks put tests/ on
``sys.path`` first.
"""

from __future__ import annotations

import numpy as np

from hybridedit import Mesh, rigid_transform

__all__ = ["canonical_edit"]


def canonical_edit(mesh: Mesh) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The benchmark edit on an armadillo-like shape (Y up, facing +Z).

    Handle: the hand on the +X side; region of interest: that arm from the
    shoulder; everything else is fixed. The hand swings up by 40 degrees about
    the +Z axis through the shoulder (the centroid of the region's vertices
    nearest the body), as a user raising the arm would. Defined relative to the
    bounding box, so it means the same on every resolution of the armadillo.

    Returns
    -------
    handle, roi : int64 shape vertex indices; T : (4, 4) float64 handle transform
    """
    v = mesh.vertices
    lo, hi = v.min(axis=0), v.max(axis=0)
    r = (v - lo) / (hi - lo)
    handle = np.flatnonzero((r[:, 0] > 0.877) & (r[:, 1] > 0.62))
    roi = np.flatnonzero((r[:, 0] > 0.70) & (r[:, 1] > 0.52))
    shoulder = v[roi[r[roi, 0] < 0.73]].mean(axis=0)
    return handle, roi, rigid_transform(axis=(0, 0, 1), degrees=40.0, center=shoulder)
