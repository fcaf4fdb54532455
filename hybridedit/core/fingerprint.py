"""What names a shape: its vertex count, its vertices and its faces, as fixed little-endian bytes.

Every key hybridedit makes of a shape starts from :func:`shape_bytes`, so a shape is one shape
to all of them (the same vertices in float64 or float32, the same faces in int32 or int64). Each
key is kept on disk, so each keeps the digest it always had:

- the up axis remembered per shape (:func:`hybridedit.fileio.up_axes.shape_key`): the SHA-256 of
  all three (:func:`shape_digest`), 40 hex digits;
- a binding cache entry (:func:`hybridedit.binding.cache.cache_key`): the count, then the
  SHA-256 of the vertices' and of the faces' bytes (digested in pieces on two threads), after
  the cache format and the settings;
- an edit file's ``mesh`` fingerprint (:func:`hybridedit.fileio.editfile.mesh_fingerprint`): the
  SHA-256 of the faces' bytes, 16 hex digits (the positions are compared with a tolerance there);
- the shape a Blender object is bound to (the extension's ``session.fingerprint``): the SHA-256
  of all three, the positions in float32 as Blender holds them.
"""

from __future__ import annotations

import hashlib

import numpy as np

__all__ = ["shape_bytes", "shape_digest"]


def shape_bytes(vertices, faces, vertex_dtype: str = "<f8") -> tuple[bytes, np.ndarray, np.ndarray]:
    """The three parts that name a shape, in the order every key hashes them.

    Parameters
    ----------
    vertices : (n, 3) or (3 n,) float array
    faces : (m, 3) or (3 m,) int array
    vertex_dtype : str
        ``"<f8"`` (the engine's positions) or ``"<f4"`` (Blender's).

    Returns
    -------
    count : bytes
        n as an int64.
    vertices : contiguous array of ``vertex_dtype``
    faces : contiguous ``<i8`` array
        Both views of the input when it already has that type.

    Examples
    --------
    >>> count, v, f = shape_bytes(np.zeros((4, 3)), np.array([[0, 1, 2]], dtype=np.int32))
    >>> int(np.frombuffer(count, np.int64)[0]), v.dtype.str, f.dtype.str
    (4, '<f8', '<i8')
    """
    v = np.ascontiguousarray(vertices, dtype=vertex_dtype)
    return np.int64(v.size // 3).tobytes(), v, np.ascontiguousarray(faces, dtype="<i8")


def shape_digest(vertices, faces, vertex_dtype: str = "<f8") -> str:
    """SHA-256 (hex) of a shape's :func:`shape_bytes`: the count, the vertices, the faces.

    Examples
    --------
    >>> v, f = np.eye(3), np.array([[0, 1, 2]])
    >>> shape_digest(v, f) == shape_digest(v, f.astype(np.int32)) != shape_digest(v + 1e-12, f)
    True
    """
    h = hashlib.sha256()
    for part in shape_bytes(vertices, faces, vertex_dtype):
        h.update(part)
    return h.hexdigest()
