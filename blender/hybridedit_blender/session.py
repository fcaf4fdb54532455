"""One bound mesh object: hybridedit's editor, its rest pose and the Empties that drive it.

Everything here reaches hybridedit through its public API (``Mesh``,
``build_rig``, ``HybridEditor``: ``set_selection``, ``drag``, ``set_pose``,
``moving_vertices``, ``save_state`` / ``restore_state``) and its shape fingerprint
(:mod:`hybridedit.core.fingerprint`), and Blender through plain RNA reads and
``foreach_get`` / ``foreach_set``.

The pose lives beside the mesh, in a shape key (``KEY``) relative to the basis: the
base coordinates never change until Apply. The key holds ``basis + (pose - rest)``
where the rest is the shape-key mix the mesh had at Bind (without this key), so
with the key at 1 Blender shows the pose whatever other keys the mesh has. Rows
that cannot move keep the basis' own float32 bits, so they add exactly zero.

Space: the engine solves in the object's world shape. The object's matrix is split
into a rotation and a stretch (polar decomposition, ``O3 = R P``); the engine's
rest is ``P`` times the local rest (what Blender's Apply Scale gives), its handle
transforms are the Hook's local transform conjugated by ``P``, and its pose goes
back to local coordinates by ``P^-1``. With a uniform scale ``P`` is left out.
"""

from __future__ import annotations

import threading
import time
from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np

#: the shape key holding the live pose
KEY = "Hybrid ARAP"
_EYE = np.eye(4)
#: one lock for every call into the engine, from any thread (the bind worker, the settle worker,
#: Blender's main thread, a render thread): the engine's compiled kernels are not to be entered
#: from two threads at once
ENGINE = threading.RLock()


class BindError(Exception):
    """A problem to report to the user in one line (self.report), never a traceback."""


class Cancelled(Exception):
    """The user cancelled a bind."""


# ------------------------------------------------------------------ reading and writing Blender data
def _position_data(me):
    """The "position" attribute's data (Blender 3.5+: 0.5-1.2 ms at 1M vertices against 35 ms
    through ``vertices.foreach_set("co")``), or the vertices (older Blender)."""
    attr = me.attributes.get("position")
    return (attr.data, "vector") if attr is not None and attr.data_type == "FLOAT_VECTOR" else (me.vertices, "co")


def read_positions(me) -> np.ndarray:
    """(n*3,) float32 base positions of a mesh (its own coordinates, not its shape keys), one foreach_get."""
    buf = np.empty(len(me.vertices) * 3, dtype=np.float32)
    data, key = _position_data(me)
    data.foreach_get(key, buf)
    return buf


def write_positions(me, buf: np.ndarray) -> None:
    data, key = _position_data(me)
    data.foreach_set(key, buf)
    me.update()


def key_points(kb):
    """A shape key's points: ``ShapeKey.points`` (4.1+: 2 ms at 1M vertices) or ``data`` (45 ms)."""
    return kb.points if hasattr(kb, "points") else kb.data


def read_key(kb, n: int) -> np.ndarray:
    buf = np.empty(n * 3, dtype=np.float32)
    key_points(kb).foreach_get("co", buf)
    return buf


def write_key(kb, buf: np.ndarray) -> None:
    key_points(kb).foreach_set("co", buf)


def pose_key(obj):
    """The object's pose shape key, or None."""
    keys = obj.data.shape_keys
    return keys.key_blocks.get(KEY) if keys is not None else None


def ensure_pose_key(obj, basis32: np.ndarray):
    """The pose shape key, made if missing (with a Basis first on a mesh without shape keys), relative
    to the reference key, at 1, not the active key (so Edit Mode edits the basis, never the pose)."""
    kb = pose_key(obj)
    if kb is None:
        active = obj.active_shape_key_index
        had = obj.data.shape_keys is not None
        if not had:
            obj.shape_key_add(name="Basis", from_mix=False)
        kb = obj.shape_key_add(name=KEY, from_mix=False)
        write_key(kb, basis32)
        obj.active_shape_key_index = active if had else 0
    keys = obj.data.shape_keys
    if kb.relative_key != keys.reference_key:
        kb.relative_key = keys.reference_key
    if kb.value != 1.0:
        kb.value = 1.0
    if kb.mute:
        kb.mute = False
    if obj.active_shape_key == kb:
        obj.active_shape_key_index = 0
    return kb


def rest_mix(obj) -> tuple[np.ndarray, np.ndarray]:
    """(rest, basis), float32 (n*3,): the shape-key mix the mesh shows without the pose key (Blender's
    own mix, ``shape_key_add(from_mix=True)`` with the pose key muted), and the reference key's
    positions (the mesh's own positions when it has no shape keys)."""
    me = obj.data
    n = len(me.vertices)
    keys = me.shape_keys
    if keys is None:
        base = read_positions(me)
        return base, base
    basis = read_key(keys.reference_key, n)
    others = [kb for kb in keys.key_blocks[1:] if kb.name != KEY]
    if keys.use_relative and not any(not kb.mute and kb.value != 0.0 for kb in others):
        return basis, basis
    ours = keys.key_blocks.get(KEY)
    was_mute = ours.mute if ours is not None else False
    active = obj.active_shape_key_index
    if ours is not None:
        ours.mute = True
    tmp = obj.shape_key_add(name="Hybrid ARAP mix", from_mix=True)
    try:
        mix = read_key(tmp, n)
    finally:
        obj.shape_key_remove(tmp)
        if ours is not None:
            ours.mute = was_mute
        obj.active_shape_key_index = active
    return mix, basis


def read_triangles(me) -> np.ndarray:
    """(m, 3) int64 triangles of Blender's own triangulation of the polygons."""
    me.calc_loop_triangles()
    tris = np.empty(len(me.loop_triangles) * 3, dtype=np.int32)
    me.loop_triangles.foreach_get("vertices", tris)
    return tris.reshape(-1, 3).astype(np.int64)


def topology_counts(me) -> tuple[int, int, int]:
    return len(me.vertices), len(me.edges), len(me.polygons)


def fingerprint(positions32: np.ndarray, tris: np.ndarray) -> str:
    """SHA-256 of the positions (float32, as Blender holds them) and the triangles: the engine's
    one shape fingerprint (:func:`hybridedit.core.fingerprint.shape_digest`), as .blend files
    already store it in ``hybrid_arap.bound``."""
    from hybridedit.core.fingerprint import shape_digest

    return shape_digest(positions32, tris, "<f4")


def triangles_digest(tris: np.ndarray) -> str:
    return fingerprint(np.zeros(0, np.float32), tris)


def group_members(obj, names: list[str]) -> dict[str, np.ndarray]:
    """Sorted vertex indices of each named vertex group (weight > 0), in one pass over the mesh.

    A name with no such group is a BindError naming it."""
    index = {}
    for name in names:
        vg = obj.vertex_groups.get(name)
        if vg is None:
            raise BindError(f"'{obj.name}' has no vertex group '{name}'")
        index[vg.index] = name
    found: dict[int, list[int]] = {k: [] for k in index}
    for v in obj.data.vertices:
        for g in v.groups:
            lst = found.get(g.group)
            if lst is not None and g.weight > 0.0:
                lst.append(v.index)
    return {index[k]: np.asarray(v, dtype=np.int64) for k, v in found.items()}


def matrix_np(m) -> np.ndarray:
    """A mathutils 4x4 Matrix (or 16 floats, column-major as Blender stores a matrix property) as a
    float64 (4, 4) array."""
    if hasattr(m, "row"):
        return np.array([list(row) for row in m], dtype=np.float64)
    return np.array(list(m), dtype=np.float64).reshape(4, 4).T.copy()


def matrix_flat(M: np.ndarray) -> list[float]:
    """A (4, 4) array as 16 floats column-major (a FloatVectorProperty of subtype MATRIX)."""
    return [float(x) for x in np.asarray(M, dtype=np.float64).T.ravel()]


def local_transform(obj_world: np.ndarray, empty_now: np.ndarray, empty_rest: np.ndarray) -> np.ndarray:
    """The Empty's motion since its rest matrix, in the mesh object's local space (as a Hook's):
    O^-1 . E_now . E_rest^-1 . O."""
    return np.linalg.solve(obj_world, empty_now @ np.linalg.solve(empty_rest, obj_world))


def stretch_of(obj_world: np.ndarray) -> np.ndarray | None:
    """The stretch P of the object's matrix (O3 = R P, R orthogonal, P symmetric positive definite),
    or None when P is a multiple of the identity (a uniform scale: the engine's pose is the same)."""
    L = np.asarray(obj_world, dtype=np.float64)[:3, :3]
    U, sig, Vt = np.linalg.svd(L)
    if sig.min() <= 0.0 or not np.all(np.isfinite(sig)):
        raise BindError("the object's matrix is singular (a zero scale): it cannot be posed")
    if sig.max() - sig.min() <= 1e-6 * sig.max():  # (a float32 matrix rounds at 6e-8)
        return None
    P = (Vt.T * sig) @ Vt
    return (P + P.T) / 2


# ------------------------------------------------------------------ poses by transforms
def transforms_key(T: dict[int, np.ndarray]) -> bytes:
    return b"".join(np.int64(g).tobytes() + np.ascontiguousarray(T[g], dtype=np.float64).tobytes() for g in sorted(T))


class PoseCache:
    """Converged poses by their transforms (the moving rows of the key, float32), oldest dropped first
    past ``max_bytes``; the newest few also keep the editor's state (to go on from it after an undo)."""

    def __init__(self, max_bytes: int = 1 << 30, max_states: int = 4) -> None:
        self.rows: OrderedDict[bytes, np.ndarray] = OrderedDict()
        self.states: OrderedDict[bytes, object] = OrderedDict()
        self.max_bytes, self.max_states, self.bytes = max_bytes, max_states, 0

    def get(self, key: bytes):
        r = self.rows.get(key)
        if r is not None:
            self.rows.move_to_end(key)
        return r, self.states.get(key)

    def put(self, key: bytes, rows: np.ndarray, state=None) -> None:
        if key in self.rows:
            self.bytes -= self.rows.pop(key).nbytes
        self.rows[key] = rows
        self.bytes += rows.nbytes
        while self.bytes > self.max_bytes and len(self.rows) > 1:
            k, r = self.rows.popitem(last=False)
            self.bytes -= r.nbytes
            self.states.pop(k, None)
        if state is not None:
            self.states[key] = state
            self.states.move_to_end(key)
            while len(self.states) > self.max_states:
                self.states.popitem(last=False)

    def clear(self) -> None:
        self.rows.clear()
        self.states.clear()
        self.bytes = 0

    def __len__(self) -> int:
        return len(self.rows)


@dataclass
class Base:
    """A pose the drags start from (Bind's rest, or the pose of an Apply)."""

    digest: str  # fingerprint of the rest (its float32 mix) and the triangles: the object's ``bound``
    rest32: np.ndarray  # (n*3,) float32 local rest (the shape-key mix without the pose key)
    basis32: np.ndarray  # (n*3,) float32 the reference key's (or the mesh's) positions
    state: object = None  # HybridEditor.save_state() right after set_selection


# ------------------------------------------------------------------ the bound state
@dataclass
class Session:
    """hybridedit's editor for one mesh object, and the buffer written into its pose key."""

    uid: str  # the object's hybrid_arap.uid: finds it again after a rename
    object_name: str
    editor: object  # hybridedit.HybridEditor
    base: Base
    tris_digest: str
    counts: tuple[int, int, int]
    groups: list[str] = field(default_factory=list)  # the handle groups' names, in order
    roi_group: str = ""
    roi: np.ndarray | None = None  # shape vertex indices of the ROI group (None: nothing fixed)
    handle_rows: list = field(default_factory=list)  # shape vertex indices of each handle group
    stretch: np.ndarray | None = None  # P (3, 3), or None (see the module's docstring)
    cage_size: float = 0.05
    cache_hit: bool = False
    bind_seconds: float = 0.0
    notes: tuple[str, ...] = ()
    buf: np.ndarray = None  # (n*3,) float32: the pose key's positions (what we will write)
    written: np.ndarray = None  # (n*3,) float32: what we last wrote into the pose key
    moving: np.ndarray = None  # (k,) int64 rows a drag can move
    last_transforms: dict = field(default_factory=dict)  # the transforms the engine's pose is at
    last_engine_ms: float = 0.0
    last_write_ms: float = 0.0
    frames: int = 0
    settled: bool = True
    problem: str = ""
    cache: PoseCache = field(default_factory=PoseCache)
    bases: dict = field(default_factory=dict)  # digest -> Base: the bases an undo may come back to

    # the worker (live.py): a settle or a solve running on a thread, and what it leaves for the main thread
    thread: threading.Thread | None = None
    cancel: threading.Event | None = None
    dirty: bool = False  # buf changed on a thread: the main thread writes it
    busy: str = ""  # what the worker does ("settling", "preparing the next pose", ...)
    progress: float = 0.0
    needs_restore: bool = False  # an undo or redo restored the key and the Empties
    settle_due: float = 0.0  # time.monotonic() after which the worker settles (0: nothing to settle)
    said: set = field(default_factory=set)  # one-time messages already said (Edit Mode...)

    #: a settled pose is within this fraction of the diagonal of converged (HybridEditor.converge's
    #: bound on the cage's distance to its fixed point; None: the engine's default)
    tolerance: float | None = None
    #: at most this many of the cage's iterations per settle or solve, then said in ``note`` (None:
    #: the engine's default)
    max_iterations: int | None = None
    iterations: int = 0  # the last settle's or solve's
    last_distance: float = 0.0  # its bound on the distance to converged, a fraction of the diagonal
    note: str = ""  # a warning for the status bar (a cap reached), taken by the timer

    def __post_init__(self) -> None:
        if self.buf is None:
            self.buf = self.base.basis32.copy()
        if self.written is None:
            self.written = self.buf.copy()
        self.bases[self.base.digest] = self.base
        if self.stretch is not None:
            self._Pinv_T = np.linalg.inv(self.stretch).T
            self._P4, self._P4inv = np.eye(4), np.eye(4)
            self._P4[:3, :3] = self.stretch
            self._P4inv[:3, :3] = np.linalg.inv(self.stretch)

    @property
    def n(self) -> int:
        return len(self.base.rest32) // 3

    @property
    def diagonal(self) -> float:
        return max(float(self.editor.mesh.bbox_diagonal()), np.finfo(float).tiny)

    # -------------------------------------------------------------- selection
    def select(self) -> None:
        """Set the engine's selection from ``roi`` and ``handle_rows``: the engine's current pose
        becomes the base of the next drags (``self.base.state``)."""
        from hybridedit import SelectionError

        try:
            self.editor.set_selection(handle=list(self.handle_rows), roi=self.roi)
        except SelectionError as e:
            raise BindError(f"selection refused: {e}") from None
        self.moving = np.asarray(self.editor.moving_vertices, dtype=np.int64)
        # a frame's scratch, made once per selection (in place: at 1M vertices with 300K moving,
        # 5 ms against 9-14 ms with temporaries)
        k = len(self.moving)
        self._now, self._local = np.empty((k, 3)), np.empty((k, 3))
        self._flat = (self.moving[:, None] * 3 + np.arange(3)).ravel()
        self._set_offset()
        self.base.state = self.editor.save_state()
        self.last_transforms = {}
        self.settled = True

    def _set_offset(self) -> None:
        """The key holds basis + (pose - rest): the moving rows' basis - rest (None where they are equal)."""
        d = (self.base.basis32.astype(np.float64) - self.base.rest32).reshape(-1, 3)[self.moving]
        self._offset = d if np.any(d) else None

    # -------------------------------------------------------------- transforms
    def engine_transforms(self, obj_world: np.ndarray, empties: list[np.ndarray],
                          rests: list[np.ndarray]) -> dict[int, np.ndarray]:
        """Each group's transform in the engine's space from its Empty's world matrix now and at rest."""
        out = {}
        for g, (E, E0) in enumerate(zip(empties, rests)):
            if np.array_equal(E, E0):  # at rest: exactly (O^-1 E E0^-1 O would round)
                out[g] = np.eye(4)
                continue
            T = local_transform(obj_world, E, E0)
            if self.stretch is not None:
                T = self._P4 @ T @ self._P4inv
            out[g] = T
        return out

    def changed(self, transforms: dict[int, np.ndarray]) -> bool:
        if transforms.keys() != self.last_transforms.keys():
            return True
        return any(not np.array_equal(transforms[g], self.last_transforms[g]) for g in transforms)

    def cache_key(self, transforms: dict[int, np.ndarray]) -> bytes:
        return self.base.digest.encode() + transforms_key(transforms)

    # -------------------------------------------------------------- frames (callers hold ENGINE)
    def _to_key_rows(self, V: np.ndarray) -> None:
        """The engine's shape (n, 3) -> the key's float32 buffer: only the moving rows, in local
        space, plus the basis offset."""
        now = np.take(V, self.moving, axis=0, out=self._now)
        if self.stretch is not None:
            now = np.matmul(now, self._Pinv_T, out=self._local)
        if self._offset is not None:
            now = np.add(now, self._offset, out=self._local)
        np.put(self.buf, self._flat, now)  # (float64 -> float32, as an assignment rounds)
        self.dirty = True

    def live_frame(self, transforms: dict[int, np.ndarray]) -> None:
        """One interactive frame (``HybridEditor.drag``) from the current pose into the buffer; the
        pose is not settled until :meth:`settle` converges it."""
        t0 = time.perf_counter()
        self._to_key_rows(self.editor.drag(transforms=transforms))
        self.last_engine_ms = (time.perf_counter() - t0) * 1e3
        self.last_transforms = {g: T.copy() for g, T in transforms.items()}
        self.frames += 1
        self.settled = False
        self.progress = 0.0

    def _progress(self, stage: str, fraction: float) -> None:
        self.progress = fraction

    def _converge(self, transforms: dict[int, np.ndarray], start: str, cancel) -> bool:
        """``HybridEditor.converge`` at these transforms (the cage alone, propagated once) into the
        buffer; False when cancelled (nothing changed)."""
        from hybridedit.defaults import CONVERGE_MAX_ITERATIONS, CONVERGE_TOLERANCE

        tol = CONVERGE_TOLERANCE if self.tolerance is None else self.tolerance
        cap = CONVERGE_MAX_ITERATIONS if self.max_iterations is None else self.max_iterations
        r = self.editor.converge(transforms=transforms, start=start, tolerance=tol, max_iterations=cap,
                                 cancel=cancel, progress=self._progress)
        if r.stopped == "cancelled":
            return False
        self._to_key_rows(r.vertices)
        self.last_transforms = {g: T.copy() for g, T in transforms.items()}
        self.iterations, self.last_distance = r.iterations, r.distance
        self.settled, self.progress = True, 1.0
        if r.converged:
            self.remember(transforms)
        else:  # kept (the best there is), said, and not cached: a solve may try again
            self.note = (f"'{self.object_name}': the pose stopped {r.distance:.1e} of the diagonal from converged "
                         f"after {r.iterations:,} iterations (at most {cap:,}, tolerance {tol:g})")
        return True

    def settle(self, transforms: dict[int, np.ndarray], cancel=None) -> bool:
        """The pose at these transforms converged from where it is (after live frames: where the
        user dragged it); False when cancelled."""
        return self._converge(transforms, "current", cancel)

    def remember(self, transforms: dict[int, np.ndarray]) -> None:
        self.cache.put(self.cache_key(transforms), self.buf[self._flat].copy(), self.editor.save_state())

    def start_from_base(self) -> None:
        """The engine back at the base pose (before a solve that must not depend on earlier frames)."""
        self.editor.restore_state(self.base.state)
        self.last_transforms = {}
        self.settled = False

    def from_cache(self, transforms: dict[int, np.ndarray]) -> bool:
        """The cached converged pose for these transforms into the buffer (and the engine's state when
        kept); False when there is none."""
        rows, state = self.cache.get(self.cache_key(transforms))
        if rows is None:
            return False
        np.put(self.buf, self._flat, rows)
        # the engine goes on from that pose when its state was kept, else from the base pose
        self.editor.restore_state(state if state is not None else self.base.state)
        self.last_transforms = {g: T.copy() for g, T in transforms.items()}
        self.settled = True
        self.dirty = True
        return True

    def solve(self, transforms: dict[int, np.ndarray], cancel=None) -> bool:
        """The converged pose for these transforms from the base pose (``converge(start="base")``:
        the same bit for bit whatever frames came before), or the cached one; False when
        cancelled."""
        if self.from_cache(transforms):
            return True
        if all(np.array_equal(M, _EYE) for M in transforms.values()):
            self.zero()  # every Empty at its rest: the base pose itself (Bind's rest, or the pose applied)
            self.last_transforms = {g: T.copy() for g, T in transforms.items()}
            return True
        self.start_from_base()
        return self._converge(transforms, "base", cancel)

    # -------------------------------------------------------------- Blender side (main thread)
    def write(self, obj) -> None:
        """The buffer into the pose key (one foreach_set), the mesh tagged for evaluation."""
        t0 = time.perf_counter()
        kb = ensure_pose_key(obj, self.base.basis32)
        write_key(kb, self.buf)
        np.copyto(self.written, self.buf)
        obj.data.update()
        self.last_write_ms = (time.perf_counter() - t0) * 1e3
        self.dirty = False

    def edited(self, obj) -> str | None:
        """Why the mesh no longer is the one bound (one line), or None: the counts, every base
        position (a full comparison, not a sample) and every position of the pose key."""
        me = obj.data
        counts = topology_counts(me)
        if counts != self.counts:
            return (f"'{obj.name}' changed since Bind ({counts[0]:,} vertices, {counts[2]:,} faces; "
                    f"bound {self.counts[0]:,}, {self.counts[2]:,}): Bind again")
        keys = me.shape_keys
        basis = read_key(keys.reference_key, self.n) if keys is not None else read_positions(me)
        if not np.array_equal(basis, self.base.basis32):
            k = int(np.count_nonzero(np.any(basis.reshape(-1, 3) != self.base.basis32.reshape(-1, 3), axis=1)))
            return (f"'{obj.name}' was edited since Bind ({k:,} vertices moved): the edit is kept and the pose "
                    "stopped; Bind again to pose the edited mesh")
        kb = pose_key(obj)
        if kb is not None:
            now = read_key(kb, self.n)
            if not np.array_equal(now, self.written):
                k = int(np.count_nonzero(np.any(now.reshape(-1, 3) != self.written.reshape(-1, 3), axis=1)))
                return (f"the '{KEY}' shape key of '{obj.name}' was edited ({k:,} vertices): it is kept as it is and "
                        "the pose stopped; Apply it or Bind again")
        return None

    def zero(self) -> None:
        """The buffer at the base pose (the key adds nothing), the engine back at its base."""
        with ENGINE:
            self.editor.restore_state(self.base.state)
        self.buf[:] = self.base.basis32
        self.last_transforms = {}
        self.settled = True
        self.dirty = True
