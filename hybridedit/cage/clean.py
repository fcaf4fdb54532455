"""What a simplifier leaves behind, cleaned: :func:`clean_surface`, and whether the result can be a
cage piece (:func:`is_usable_piece`: closed, oriented, with a volume)."""

from __future__ import annotations

import numpy as np

from ..core.face_geometry import signed_volume
from ..core.index_sets import unique_sorted
from ..core.mesh import Mesh
from ..core.topology import check_closed, degenerate_faces, repeats_a_face

__all__ = ["clean_surface", "is_usable_piece"]


def is_usable_piece(cage: Mesh) -> bool:
    """Closed, oriented, with a volume that is not negligible for its size.

    Parameters
    ----------
    cage : Mesh
        A candidate cage piece (c vertices, m faces).
    """
    if cage.n_faces < 4:
        return False
    try:
        check_closed(cage.faces)
    except ValueError:
        return False
    v = cage.vertices
    vol = signed_volume(v, cage.faces)
    d = float(np.linalg.norm(np.ptp(v, axis=0)))
    return bool(np.isfinite(vol) and vol > 1e-6 * d ** 3)



def clean_surface(vertices: np.ndarray, faces: np.ndarray) -> Mesh:
    """Remove what a simplifier can leave behind.

    Drops degenerate faces (:func:`hybridedit.core.topology.degenerate_faces`), duplicate faces, pairs of
    coincident faces of opposite orientation (zero-volume fins), and then
    vertices no face uses (indices are compacted, order kept).

    Parameters
    ----------
    vertices : (n, 3) float64 array
    faces : (m, 3) int array
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    while True:
        m0 = len(f)
        f = f[~degenerate_faces(v, f)]
        if len(f) and repeats_a_face(f, len(v)):
            key, axis = np.sort(f, axis=1), 0
            if len(v) < 2**21:  # the three indices packed in one int64, in the same order (rows of 3 sort
                # as a structured type: 0.85 s for the 11M armadillo's 1.1M cage faces)
                key, axis = (key[:, 0] << 42) | (key[:, 1] << 21) | key[:, 2], None
            _, first, inverse, counts = np.unique(key, axis=axis, return_index=True, return_inverse=True,
                                                  return_counts=True)
            inverse = inverse.reshape(-1)
            # a vertex set used twice: same orientation is a duplicate (keep one),
            # opposite orientation is a fin (drop both)
            keep = np.zeros(len(f), dtype=bool)
            keep[first] = True
            multi = counts[inverse] > 1
            if np.any(multi):
                for g in unique_sorted(inverse[multi]):
                    idx = np.flatnonzero(inverse == g)
                    orient = [_parity(f[i]) for i in idx]
                    if len(set(orient)) > 1:
                        keep[idx] = False
            f = f[keep]
        if len(f) == m0:
            break
    used = np.zeros(len(v), dtype=bool)
    used[f.reshape(-1)] = True
    remap = np.cumsum(used) - 1
    return Mesh(v[used], remap[f])


def _parity(tri: np.ndarray) -> int:
    """+1 if the triangle's cyclic order is an even rotation of its sorted order."""
    a, b, c = (int(x) for x in tri)
    lo = min(a, b, c)
    while a != lo:
        a, b, c = b, c, a
    return 1 if b < c else -1
