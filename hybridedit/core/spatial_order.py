"""Points in the order of a space-filling curve, so that points near in space are near in memory.

The cage's vertices come out of the simplifier in no spatial order: the few thousand a drag
frees lie scattered through the cage's arrays, and every gather of a frame (a vertex's
neighbours in the ARAP steps, the cage rows a shape vertex blends) misses the cache. In Morton
(Z-curve) order a region of the cage is a few runs of consecutive rows.
"""

from __future__ import annotations

import numpy as np

from .bounds import points_box

#: bits of each coordinate in the curve's key (3 x 21 = 63 bits)
BITS = 21


def _spread(q: np.ndarray) -> np.ndarray:
    """The 21 low bits of each uint64 of ``q`` moved to every third bit (bit k to bit 3k)."""
    q = q & np.uint64(0x1FFFFF)
    q = (q | (q << np.uint64(32))) & np.uint64(0x1F00000000FFFF)
    q = (q | (q << np.uint64(16))) & np.uint64(0x1F0000FF0000FF)
    q = (q | (q << np.uint64(8))) & np.uint64(0x100F00F00F00F00F)
    q = (q | (q << np.uint64(4))) & np.uint64(0x10C30C30C30C30C3)
    q = (q | (q << np.uint64(2))) & np.uint64(0x1249249249249249)
    return q


def morton_order(points: np.ndarray, *, bits: int = BITS, per_axis: bool = False) -> np.ndarray:
    """The permutation that puts ``points`` in Morton (Z-curve) order of their bounding box.

    Parameters
    ----------
    points : (n, 3) float array, finite
    bits : int in [1, 21]
        Bits of each coordinate in the key (the box cut into ``2**bits`` cells a side).
    per_axis : bool
        Scale each axis to the box's extent along it (cells shaped like the box) rather than
        all three by its largest extent (cubic cells).

    Returns
    -------
    order : (n,) int64
        ``points[order]`` follows the curve; points with the same key keep their order.

    Examples
    --------
    >>> morton_order(np.array([[1.0, 1.0, 1.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])).tolist()
    [1, 2, 0]
    """
    if not 1 <= bits <= BITS:
        raise ValueError(f"bits must lie in [1, {BITS}], got {bits}")
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if p.shape[0] == 0:
        return np.zeros(0, dtype=np.int64)
    lo, hi = points_box(p)
    ext = hi - lo
    if not per_axis:
        ext = np.full(3, ext.max())
    ext[ext <= 0.0] = 1.0
    top = 2**bits - 1
    q = np.clip(((p - lo) / ext * float(top)).astype(np.int64), 0, top).astype(np.uint64)
    key = _spread(q[:, 0]) | (_spread(q[:, 1]) << np.uint64(1)) | (_spread(q[:, 2]) << np.uint64(2))
    return np.argsort(key, kind="stable").astype(np.int64, copy=False)
