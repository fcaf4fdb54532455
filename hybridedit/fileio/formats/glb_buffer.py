"""A glTF's binary buffer being written: arrays and images appended as buffer views and accessors.

:mod:`.glb` writes a new .glb with it and :mod:`.glb_morphs` adds morph targets, plain or sparse, to a
new or an existing one. Every view starts on a 4-byte boundary (the largest component is 4 bytes).
"""

from __future__ import annotations

import numpy as np
import pygltflib

__all__ = ["GltfBuffer"]

_COMPONENT = {np.dtype("u1"): pygltflib.UNSIGNED_BYTE, np.dtype("<u2"): pygltflib.UNSIGNED_SHORT,
              np.dtype("<u4"): pygltflib.UNSIGNED_INT, np.dtype("<f4"): pygltflib.FLOAT}
_KIND = {1: pygltflib.SCALAR, 2: pygltflib.VEC2, 3: pygltflib.VEC3, 4: pygltflib.VEC4}


class GltfBuffer:
    """The binary chunk (buffer 0) of ``gltf``, appended to; :meth:`finish` gives the .glb bytes.

    Parameters
    ----------
    gltf : pygltflib.GLTF2
        Changed in place: views, accessors and images are appended to its lists.
    blob : bytes, optional
        The binary chunk it already has (an existing file's), kept as it is at the front.
    """

    def __init__(self, gltf: pygltflib.GLTF2, blob: bytes = b"") -> None:
        self.gltf = gltf
        self.blob = bytearray(blob)

    def view(self, data: bytes, target: int | None = None) -> int:
        """A buffer view of ``data`` (``target``: ARRAY_BUFFER or ELEMENT_ARRAY_BUFFER, None for
        images and sparse parts); returns its index."""
        self.blob.extend(b"\0" * (-len(self.blob) % 4))
        self.gltf.bufferViews.append(pygltflib.BufferView(buffer=0, byteOffset=len(self.blob),
                                                          byteLength=len(data), target=target))
        self.blob.extend(data)
        return len(self.gltf.bufferViews) - 1

    def accessor(self, array: np.ndarray, *, target: int | None = pygltflib.ARRAY_BUFFER,
                 minmax: bool = False) -> int:
        """An accessor of ``array`` ((count,) or (count, 1-4), float32 or unsigned integers) in a view
        of its own; ``minmax``: with its per-component bounds (POSITION's, as the spec requires)."""
        array = np.ascontiguousarray(array)
        rows = array.reshape(len(array), -1)
        acc = pygltflib.Accessor(bufferView=self.view(array.tobytes(), target),
                                 componentType=_COMPONENT[array.dtype], count=len(array), type=_KIND[rows.shape[1]])
        if minmax:
            acc.min, acc.max = _bounds(rows)
        return self._add(acc)

    def delta_accessor(self, delta: np.ndarray, *, sparse: bool, minmax: bool) -> int:
        """A float32 VEC3 accessor of ``delta`` ((count, 3) float32), a morph target's: no data at all
        when every row is zero (an accessor without a view reads as zeros), with ``sparse`` only its
        non-zero rows where that is smaller than every row, else every row."""
        moved = np.flatnonzero(np.any(delta != 0, axis=1))
        index_dtype = np.dtype("u1") if len(delta) <= 256 else np.dtype("<u2") if len(delta) <= 65536 \
            else np.dtype("<u4")
        sparse_bytes = len(moved) * (12 + index_dtype.itemsize)
        if len(moved) and not (sparse and sparse_bytes < delta.nbytes):
            return self.accessor(delta, minmax=minmax)
        acc = pygltflib.Accessor(byteOffset=None, componentType=pygltflib.FLOAT, count=len(delta),
                                 type=pygltflib.VEC3)  # (no byteOffset without a view)
        if minmax:
            acc.min, acc.max = _bounds(delta)
        if len(moved):
            acc.sparse = pygltflib.Sparse(
                count=len(moved),
                indices=pygltflib.AccessorSparseIndices(bufferView=self.view(moved.astype(index_dtype).tobytes()),
                                                        componentType=_COMPONENT[index_dtype]),
                values=pygltflib.AccessorSparseValues(bufferView=self.view(
                    np.ascontiguousarray(delta[moved]).tobytes())))
        return self._add(acc)

    def image(self, data: bytes, name: str | None) -> int:
        """An embedded PNG or JPEG image; returns its index."""
        mime = "image/jpeg" if data[:2] == b"\xff\xd8" else "image/png"
        self.gltf.images.append(pygltflib.Image(bufferView=self.view(data), mimeType=mime, name=name))
        return len(self.gltf.images) - 1

    def finish(self) -> bytes:
        """The .glb: the JSON and the binary chunk, buffer 0's length set to it."""
        self.blob.extend(b"\0" * (-len(self.blob) % 4))
        if not self.gltf.buffers:
            self.gltf.buffers.append(pygltflib.Buffer())
        self.gltf.buffers[0].byteLength = len(self.blob)
        self.gltf.set_binary_blob(bytes(self.blob))
        return b"".join(self.gltf.save_to_bytes())

    def _add(self, acc: pygltflib.Accessor) -> int:
        self.gltf.accessors.append(acc)
        return len(self.gltf.accessors) - 1


def _bounds(rows: np.ndarray) -> tuple[list[float], list[float]]:
    """(min, max) of each column, exactly the stored values (float32 widened to float: the validator
    compares them with what it reads)."""
    return rows.min(axis=0).astype(float).tolist(), rows.max(axis=0).astype(float).tolist()
