"""Building step: the cage and binding of a shape, as one value the editor takes.

:func:`build_rig` does everything slow that an edit needs before the first drag
(cage by QEM, binding by truncated mean value coordinates, the on-disk cache)
and returns a :class:`Rig`. The editor (:class:`hybridedit.HybridEditor`) only
reads a rig, so the same rig can serve several editors (different ARAP weights,
propagation), be rebuilt in a worker thread, or come from the cache.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
import scipy.sparse as sp

from ..defaults import CAGE_SIZE, TRUNCATION, check_cage_size
from . import cache as bindcache
from .assemble import cage_and_binding
from ..cage.links import cage_links
from ..core.cache_dir import default_cache_dir
from ..core.edge_weights import edge_weights
from ..core.mesh import Mesh
from ..core.nearest_points import NearestPoints, nearest_points

Progress = Callable[[str, float], None]
"""progress(stage, fraction): stage is a short message, fraction in [0, 1] of that
stage. A callback may raise (e.g. to cancel); the exception propagates."""


@dataclass(frozen=True)
class Rig:
    """A shape bound to its cage.

    Attributes
    ----------
    mesh : Mesh
        The shape (n vertices), never modified.
    cage : Mesh
        The control mesh at rest (c vertices).
    M : (n, c) scipy.sparse.csr_matrix, float64
        The binding: row i holds the coordinates of shape vertex i, summing to 1.
    notes : tuple of str
        Plain-word sentences about what was repaired or adjusted to build the cage.
    timings : dict
        ``cage_seconds`` and ``bind_seconds`` (a cache hit counts in ``cage_seconds``).
    cache_hit : bool
        True when cage and binding came from the on-disk cache.
    cage_size, truncation
        The settings the rig was built with.
    cache_dir, cache_key : Path and str, or None
        Where the on-disk cache keeps this rig's entry (None: built without the cache), so that
        what is derived from it later (an editor's set-up) is kept beside it.
    """

    mesh: Mesh
    cage: Mesh
    M: sp.csr_matrix
    notes: tuple[str, ...] = ()
    timings: dict = field(default_factory=dict)
    cache_hit: bool = False
    cage_size: int | float = CAGE_SIZE
    truncation: float = TRUNCATION
    cache_dir: Path | None = None
    cache_key: str | None = None

    def __post_init__(self) -> None:
        M = sp.csr_matrix(self.M, dtype=np.float64)
        if M.shape != (self.mesh.n_vertices, self.cage.n_vertices):
            raise ValueError(f"binding must be {(self.mesh.n_vertices, self.cage.n_vertices)}, got {M.shape}")
        M.sort_indices()
        object.__setattr__(self, "M", M)
        object.__setattr__(self, "notes", tuple(self.notes))

    @property
    def links(self) -> np.ndarray:
        """(k, 2) int64 extra cage edges for ARAP tying separate cage parts to the
        part that holds them (see :func:`hybridedit.cage.links.cage_links`)."""
        cached = self.__dict__.get("_links")
        if cached is None:
            cached = cage_links(self.cage)
            object.__setattr__(self, "_links", cached)
        return cached

    @property
    def cage_weights(self) -> tuple[np.ndarray, np.ndarray]:
        """The cage's edges (e, 2) int64 and their cotangent ARAP weights (e,) float64
        (:func:`hybridedit.core.edge_weights.edge_weights`), made once: a cached rig checks them on
        loading and its editor's ARAP solver takes the same arrays."""
        cached = self.__dict__.get("_cage_weights")
        if cached is None:
            cached = edge_weights(self.cage.vertices, self.cage.faces, "cotangent")
            object.__setattr__(self, "_cage_weights", cached)
        return cached

    def __getstate__(self) -> dict:
        # a pickled or copied rig leaves the pending k-d tree behind (a thread's future: the copy
        # makes its own tree if it is asked)
        state = dict(self.__dict__)
        state.pop("_shape_tree", None)
        return state

    def nearest_shape_vertices(self) -> np.ndarray:
        """(c,) int64: the shape vertex nearest each cage vertex. From the shape's k-d tree that a
        cold build started beside the cage (:class:`~hybridedit.core.nearest_points.NearestPoints`,
        asked once and let go), else from one made now."""
        pending = self.__dict__.pop("_shape_tree", None)
        if pending is not None:
            return pending.query(self.cage.vertices)
        return nearest_points(self.mesh.vertices, self.cage.vertices)

    @property
    def nnz_per_row(self) -> float:
        """Mean number of cage vertices each shape vertex depends on."""
        return self.M.nnz / max(self.M.shape[0], 1)


def _check_usable(rig: Rig) -> None:
    """Raise if a rig cannot serve an editor: the cage's ARAP weights and links must
    be computable and finite (what a cached entry is first used for)."""
    _, w = rig.cage_weights
    if not np.all(np.isfinite(w)) or not np.all(np.isfinite(rig.M.data)):
        raise ValueError("the cage or binding has non-finite values")
    rig.links  # noqa: B018 -- computed here, so that a bad cage fails now


def build_rig(
    mesh: Mesh,
    *,
    cage_size: int | float = CAGE_SIZE,
    cage: Mesh | None = None,
    binding: sp.spmatrix | None = None,
    truncation: float = TRUNCATION,
    cache: bool | str | Path = False,
    progress: Progress | None = None,
) -> Rig:
    """Build (or load from the cache) the cage and binding of ``mesh``.

    Parameters
    ----------
    mesh : Mesh
        The shape (n vertices).
    cage_size : int, float or str
        Cage vertex count (int) or fraction of the shape's vertices (float), or either as text
        ("2000", "0.05", "5%": :func:`hybridedit.defaults.check_cage_size`).
    cage : Mesh, optional
        Use this cage instead of simplifying the shape.
    binding : (n, c) scipy sparse matrix, optional
        Use this binding (rows summing to 1) instead of computing it; needs ``cage``.
    truncation : float
        Fraction of each row's coordinate magnitude dropped (the paper: 0.03).
    cache : bool or path
        Reuse cage and binding from the on-disk cache (True: the user cache folder,
        :func:`hybridedit.core.cache_dir.default_cache_dir`; a path: that folder), keyed by
        the shape and the settings; store them there after computing them. Ignored
        when ``cage`` or ``binding`` is given.
    progress : callable(stage, fraction), optional
        Called during the slow steps; it may raise to cancel them.

    Returns
    -------
    Rig

    Examples
    --------
    >>> import hybridedit as he
    >>> rig = he.build_rig(he.read_mesh("data/creature.ply"), cage_size=0.05, cache=True)  # doctest: +SKIP
    >>> ed = he.HybridEditor(rig)  # doctest: +SKIP
    """
    if binding is not None and cage is None:
        raise ValueError("a binding needs its cage")
    if cage is None:
        cage_size = check_cage_size(cage_size)  # ("0.05" from a config file: the cache key of 0.05)
    say = progress or (lambda stage, fraction: None)
    t0 = time.perf_counter()
    notes: list[str] = []
    discarded: list[str] = []  # cache entries not used: said on this rig only, never stored with the entry
    folder = key = None
    if cache and cage is None:
        folder = default_cache_dir() if cache is True else Path(cache)
        key = bindcache.cache_key(mesh, cage_size, float(truncation))
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", bindcache.CacheEntryDiscarded)
            hit = bindcache.load(folder, key, mesh)
        for w in caught:  # said again (the CLI prints it), and kept as a note for the window
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
            if issubclass(w.category, bindcache.CacheEntryDiscarded):
                discarded.append(str(w.message).removeprefix("hybridedit: "))
        if hit is not None:
            c, M, cached_notes, links = hit
            try:
                rig = Rig(mesh, c, M, tuple(cached_notes), {"cage_seconds": 0.0, "bind_seconds": 0.0}, True,
                          cage_size, float(truncation), folder, key)
                object.__setattr__(rig, "_links", links)  # (stored with the entry: no search among the pieces)
                _check_usable(rig)
            except Exception:  # noqa: BLE001 -- an entry that fails in any way is rebuilt, never trusted
                bindcache.discard(folder, key)
            else:
                rig.timings["cage_seconds"] = time.perf_counter() - t0
                return rig
    timings: dict[str, float] = {}
    # the shape's k-d tree (an editor's set-up asks it for the vertex nearest each cage vertex) is
    # built on a thread of its own while the cage is: in the cage build's one-core stretches
    tree = NearestPoints(mesh.vertices) if binding is None else None
    c, M = cage_and_binding(mesh, cage_size, truncation=float(truncation), cage=cage, binding=binding,
                            notes=notes, timings=timings, progress=say)
    timings.setdefault("cage_seconds", 0.0)
    timings.setdefault("bind_seconds", time.perf_counter() - t0 - timings["cage_seconds"])
    rig = Rig(mesh, c, M, tuple(discarded + notes), timings, False, cage_size, float(truncation))
    if tree is not None:
        object.__setattr__(rig, "_shape_tree", tree)
    if folder is not None and key is not None and bindcache.store(folder, key, c, M, notes, rig.links) is not None:
        object.__setattr__(rig, "cache_dir", folder)
        object.__setattr__(rig, "cache_key", key)
    return rig
