"""What an editor derives from a rig once, made or read from the on-disk cache.

An editor needs, besides its cage and binding, what depends only on the shape, its cage and its
binding: the residual and the rotation blend of the residual propagation (the top k coordinates
of each row), the cage vertex each shape vertex depends on most and the shape vertex nearest each
cage vertex (a KD-tree over the shape). Rebuilt at every open, they would be most of a cached open
at 2.77M vertices. The shape's cotangent Laplacian (the region step's matrix) is not made here: a
:class:`~hybridedit.core.cotangent_laplacian.ShapeLaplacian` makes the rows a selection solves
for when it is made.
:func:`shape_setup` makes them once and keeps them beside the rig's cache entry
(:func:`hybridedit.binding.cache.store_arrays`, checksummed like the entry); the next open reads
them.

Pure compute; no Qt or VTK.
"""

from __future__ import annotations

import threading
import warnings
from dataclasses import dataclass

import numpy as np

from ..binding import cache as bindcache
from ..binding.bind import dominant_cage_vertex
from ..binding.rig import Rig
from ..core.cotangent_laplacian import ShapeLaplacian
from .residual import DEFAULT_K, residual_setup

__all__ = ["ShapeSetup", "shape_setup", "make_shape_setup", "wait_for_stores", "KIND"]

#: the cache companion's name: bump the number when any of these arrays is made another way
KIND = "setup2"
#: companions of earlier versions, deleted when this one is written (setup1 held the Laplacian too:
#: 420 MB at 11M vertices)
_OLD_KINDS = ("setup1",)

_NAMES = ("blend_idx", "blend_w", "dominant", "nearest", "residual")


@dataclass(frozen=True)
class ShapeSetup:
    """What an editor derives from a shape (n vertices), its cage (c) and binding M.

    Attributes
    ----------
    residual : (n, 3) float64, the shape less M times the cage.
    blend_idx, blend_w : (n, k) int32 and float32, each shape vertex's blended cage rotations
        (:func:`hybridedit.deform.residual.residual_setup`).
    dominant : (n,) int64, the cage vertex each shape vertex depends on most.
    nearest : (c,) int64, the shape vertex nearest each cage vertex.
    laplacian : the shape's cotangent Laplacian, its rows made when a selection asks for them.
    from_cache : bool, read from the cache rather than made.
    """

    residual: np.ndarray
    blend_idx: np.ndarray
    blend_w: np.ndarray
    dominant: np.ndarray
    nearest: np.ndarray
    laplacian: ShapeLaplacian
    from_cache: bool = False

    def arrays(self) -> dict[str, np.ndarray]:
        """The arrays as the cache stores them."""
        return {"residual": self.residual, "blend_idx": self.blend_idx, "blend_w": self.blend_w,
                "dominant": self.dominant, "nearest": self.nearest}


def make_shape_setup(rig: Rig, *, k: int = DEFAULT_K) -> ShapeSetup:
    """Make the :class:`ShapeSetup` of ``rig`` (no cache).

    Examples
    --------
    >>> import hybridedit as he, trimesh, numpy as np
    >>> s = trimesh.creation.icosphere(subdivisions=2)
    >>> rig = he.build_rig(he.Mesh(np.asarray(s.vertices), np.asarray(s.faces)), cage_size=40)
    >>> setup = make_shape_setup(rig)
    >>> setup.laplacian.shape, setup.blend_idx.shape
    ((162, 162), (162, 4))
    """
    from concurrent.futures import ThreadPoolExecutor

    mesh, cage, M = rig.mesh, rig.cage, rig.M

    # the shape vertex nearest each cage vertex on a second thread beside the binding's rows (scipy
    # builds and queries its k-d tree without the GIL; the kernels are compiled nogil)
    with ThreadPoolExecutor(max_workers=1) as pool:
        near = pool.submit(rig.nearest_shape_vertices)
        d, idx, w = residual_setup(M, mesh.vertices, cage.vertices, k=k)
        # the rows' sorted, repeat-free entries: the top-k's first is the dominant one (the largest
        # magnitude, the lowest column of equal ones): no second pass over M (0.3 s at 11M)
        dominant = idx[:, 0].astype(np.int64) if M.has_canonical_format else dominant_cage_vertex(M)
        nearest = near.result()
    return ShapeSetup(residual=d, blend_idx=idx, blend_w=w, dominant=dominant, nearest=nearest,
                      laplacian=ShapeLaplacian(mesh.vertices, mesh.faces))


def shape_setup(rig: Rig) -> ShapeSetup:
    """The :class:`ShapeSetup` of ``rig``: read from the cache companion of its entry when the rig
    has one (:attr:`~hybridedit.binding.rig.Rig.cache_key`), else made, and then stored there
    in the background (:func:`wait_for_stores`).

    A companion that does not fit the rig (sizes, indices out of range, non-finite values) is
    deleted with a :class:`~hybridedit.binding.cache.CacheEntryDiscarded` warning and made again.
    """
    if rig.cache_dir is None or rig.cache_key is None:
        return make_shape_setup(rig)
    folder, key = rig.cache_dir, rig.cache_key
    _wait_for_store(folder, key)
    arrays = bindcache.load_arrays(folder, key, KIND, _NAMES)
    if arrays is not None:
        try:
            return _checked(arrays, rig)
        except ValueError as e:
            bindcache.discard_arrays(folder, key, KIND)
            warnings.warn(f"hybridedit: the cached set-up of {key[:12]} not used ({e}); it is made again",
                          bindcache.CacheEntryDiscarded, stacklevel=2)
    setup = make_shape_setup(rig)
    for old in _OLD_KINDS:
        bindcache.discard_arrays(folder, key, old)
    _store_in_background(folder, key, setup.arrays())
    return setup


# companion writes under way: (folder, key) -> the thread writing it
_stores: dict[tuple[str, str], threading.Thread] = {}
_stores_lock = threading.Lock()


def _store_in_background(folder, key: str, arrays: dict[str, np.ndarray]) -> None:
    """Write the companion on a thread of its own: the editor does not need the file, and at
    11M vertices its checksum and write are 2-5 s the first drag would otherwise wait for. The
    thread is not a daemon (the interpreter waits for it at exit) and the write is atomic, so
    an interrupted one leaves no file; the arrays are never written to after they are made."""
    thread = threading.Thread(target=bindcache.store_arrays, args=(folder, key, KIND, arrays),
                              name="hybridedit set-up write")
    with _stores_lock:
        for done in [k for k, t in _stores.items() if not t.is_alive()]:
            del _stores[done]
        _stores[(str(folder), key)] = thread
    thread.start()


def _wait_for_store(folder, key: str) -> None:
    """Let a companion write of this process for ``key`` finish before the companion is read."""
    with _stores_lock:
        thread = _stores.pop((str(folder), key), None)
    if thread is not None:
        thread.join()


def wait_for_stores() -> None:
    """Wait for every companion write this process started (:func:`shape_setup` writes them in
    the background)."""
    with _stores_lock:
        threads = list(_stores.values())
        _stores.clear()
    for thread in threads:
        thread.join()


def _checked(a: dict[str, np.ndarray], rig: Rig) -> ShapeSetup:
    """The setup in ``a`` when it fits ``rig`` (ValueError saying why not)."""
    n, c = rig.M.shape
    idx, w = a["blend_idx"], a["blend_w"]
    if a["residual"].shape != (n, 3) or idx.ndim != 2 or idx.shape[0] != n or w.shape != idx.shape:
        raise ValueError("sizes")
    if a["dominant"].shape != (n,) or a["nearest"].shape != (c,):
        raise ValueError("sizes")
    for name, hi, kind in (("blend_idx", c, np.int32), ("dominant", c, np.int64), ("nearest", n, np.int64)):
        v = a[name]
        if v.dtype != kind:
            raise ValueError(f"{name} is {v.dtype}, this version keeps {np.dtype(kind)}")
        if v.size and (v.min() < 0 or v.max() >= hi):
            raise ValueError(f"{name} out of range")
    if w.dtype != np.float32:
        raise ValueError(f"blend_w is {w.dtype}, this version keeps float32")
    if not (np.isfinite(a["residual"]).all() and np.isfinite(w).all() and (w.size == 0 or w.min() >= 0.0)):
        raise ValueError("non-finite or negative values")
    return ShapeSetup(residual=a["residual"], blend_idx=idx, blend_w=w, dominant=a["dominant"],
                      nearest=a["nearest"], laplacian=ShapeLaplacian(rig.mesh.vertices, rig.mesh.faces),
                      from_cache=True)
