"""One bound mesh object: hybridedit's editor, its rest pose and the Empties that drive it.

Everything here reaches hybridedit through its public API only (``Mesh``,
``build_rig``, ``HybridEditor``: ``set_selection``, ``drag``, ``reset``,
``moving_vertices``, ``vertex_roles``, ``save_state`` / ``restore_state``) and
Blender through plain RNA reads and ``foreach_get`` / ``foreach_set``.

Positions go to Blender as float32 (the mesh's own type) through one
``foreach_set`` of a float32 buffer that keeps every row: a frame converts only
the rows the selection can move (``HybridEditor.moving_vertices``), so the
fixed rows stay bit for bit what they were.
"""

from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass, field

import numpy as np


class BindError(Exception):
    """A problem to report to the user in one line (self.report), never a traceback."""


class Cancelled(Exception):
    """The user cancelled a bind."""


# ------------------------------------------------------------------ reading Blender data
def _position_data(me):
    """The "position" attribute's data (Blender 3.5+: one memcpy-like foreach for a float32 buffer,
    0.5-1.2 ms at 1M vertices in bpy 4.2, against 35 ms through ``vertices.foreach_set("co")``),
    or the vertices (older Blender)."""
    attr = me.attributes.get("position")
    return (attr.data, "vector") if attr is not None and attr.data_type == "FLOAT_VECTOR" else (me.vertices, "co")


def read_positions(me) -> np.ndarray:
    """(n*3,) float32 positions of a mesh, in one foreach_get."""
    buf = np.empty(len(me.vertices) * 3, dtype=np.float32)
    data, key = _position_data(me)
    data.foreach_get(key, buf)
    return buf


def write_positions(me, buf: np.ndarray) -> None:
    """Write a (n*3,) float32 buffer (Blender's own type: no conversion) into the mesh's positions."""
    data, key = _position_data(me)
    data.foreach_set(key, buf)
    me.update()


def read_triangles(me) -> np.ndarray:
    """(m, 3) int64 triangles of Blender's own triangulation of the polygons."""
    me.calc_loop_triangles()
    tris = np.empty(len(me.loop_triangles) * 3, dtype=np.int32)
    me.loop_triangles.foreach_get("vertices", tris)
    return tris.reshape(-1, 3).astype(np.int64)


def topology_counts(me) -> tuple[int, int, int]:
    return len(me.vertices), len(me.edges), len(me.polygons)


def fingerprint(positions32: np.ndarray, tris: np.ndarray) -> str:
    """SHA-256 of the positions (float32, as Blender holds them) and the triangles."""
    h = hashlib.sha256()
    h.update(np.int64(len(positions32) // 3).tobytes())
    h.update(np.ascontiguousarray(positions32, dtype="<f4").tobytes())
    h.update(np.ascontiguousarray(tris, dtype="<i8").tobytes())
    return h.hexdigest()


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
    """A mathutils 4x4 Matrix as a float64 (4, 4) array."""
    return np.array([list(row) for row in m], dtype=np.float64)


def local_transform(obj_world: np.ndarray, empty_now: np.ndarray, empty_rest: np.ndarray) -> np.ndarray:
    """The Empty's motion since its rest matrix, in the mesh object's local space (as a Hook's):
    O^-1 . E_now . E_rest^-1 . O."""
    return np.linalg.solve(obj_world, empty_now @ np.linalg.solve(empty_rest, obj_world))


# ------------------------------------------------------------------ the bound state
@dataclass
class Handle:
    group: str
    empty: str  # the Empty's object name
    rest: np.ndarray  # its world matrix when the selection was set (identity transform there), (4, 4)
    bind_rest: np.ndarray = None  # its world matrix at Bind (where Reset puts it back)

    def __post_init__(self) -> None:
        if self.bind_rest is None:
            self.bind_rest = self.rest.copy()


@dataclass
class Session:
    """hybridedit's editor for one mesh object, and the buffer written into the mesh."""

    object_name: str
    editor: object  # hybridedit.HybridEditor
    rest32: np.ndarray  # (n*3,) float32 positions at Bind
    tris_digest: str
    counts: tuple[int, int, int]
    handles: list[Handle] = field(default_factory=list)
    roi_group: str = ""
    roi: np.ndarray | None = None  # shape vertex indices of the ROI group (None: nothing fixed)
    handle_rows: list = field(default_factory=list)  # shape vertex indices of each handle group
    base_state: object = None  # HybridEditor.save_state() where Reset returns (Bind or the last Apply)
    base32: np.ndarray = None  # (n*3,) float32 positions of that pose
    needs_rebase: bool = False  # an undo or redo restored the mesh and the Empties
    problem: str = ""  # the last problem found while following the Empties (one line)
    cage_size: float = 0.05
    cache_hit: bool = False
    bind_seconds: float = 0.0
    notes: tuple[str, ...] = ()
    buf: np.ndarray = None  # (n*3,) float32: what the mesh holds after our last write
    moving: np.ndarray = None  # (k,) int64 rows a drag can move
    last_transforms: dict = field(default_factory=dict)
    last_engine_ms: float = 0.0
    last_write_ms: float = 0.0
    frames: int = 0
    settled: bool = True
    epoch: int = 0
    _probe: np.ndarray = None  # a few rows checked every frame for edits made behind our back

    def __post_init__(self) -> None:
        if self.buf is None:
            self.buf = self.rest32.copy()
        if self.base32 is None:
            self.base32 = self.rest32.copy()
        n = len(self.rest32) // 3
        rng = np.random.default_rng(0)
        self._probe = np.unique(rng.integers(0, n, size=min(n, 32))) if n else np.zeros(0, np.int64)

    @property
    def n(self) -> int:
        return len(self.rest32) // 3

    @property
    def diagonal(self) -> float:
        V = self.rest32.reshape(-1, 3)
        return float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))) if len(V) else 0.0

    # -------------------------------------------------------------- selection
    def select(self) -> None:
        """Set the engine's selection from ``roi`` and ``handle_rows``: the current pose becomes
        the base of the next drags and the pose Reset returns to."""
        from hybridedit import SelectionError

        try:
            self.editor.set_selection(handle=list(self.handle_rows), roi=self.roi)
        except SelectionError as e:
            raise BindError(f"selection refused: {e}") from None
        self.moving = np.asarray(self.editor.moving_vertices, dtype=np.int64)
        # a frame's scratch, made once per selection: the moving rows now and before (swapped each
        # frame), their difference, and their places in the flat float32 buffer
        k = len(self.moving)
        self._now, self._before, self._diff = np.empty((k, 3)), np.empty((k, 3)), np.empty((k, 3))
        self._flat = (self.moving[:, None] * 3 + np.arange(3)).ravel()
        self.base_state = self.editor.save_state()
        self.base32 = self.buf.copy()
        self.last_transforms = {}
        self.settled = True
        self._previous = None

    # -------------------------------------------------------------- frames
    def transforms_from(self, obj_world: np.ndarray, empties: dict[str, np.ndarray]) -> dict[int, np.ndarray]:
        """Each group's transform in the mesh's local space from its Empty's world matrix now."""
        return {g: local_transform(obj_world, empties[h.empty], h.rest) for g, h in enumerate(self.handles)}

    def changed(self, transforms: dict[int, np.ndarray]) -> bool:
        if transforms.keys() != self.last_transforms.keys():
            return True
        return any(not np.array_equal(transforms[g], self.last_transforms[g]) for g in transforms)

    def frame(self, transforms: dict[int, np.ndarray]) -> float:
        """One interactive frame (``HybridEditor.drag``) into the float32 buffer, only the rows the
        selection can move converted; returns the largest coordinate change of the frame."""
        t0 = time.perf_counter()
        V = self.editor.drag(transforms=transforms)
        # in place, no temporaries (at 1M vertices with 300K moving, 5 ms against 9-14 ms)
        now = np.take(V, self.moving, axis=0, out=self._now)
        if self._previous is not None:
            np.subtract(now, self._previous, out=self._diff)
            moved = float(np.abs(self._diff, out=self._diff).max(initial=0.0))
        else:
            moved = np.inf
        self._now, self._before = self._before, now  # this frame's rows are the next one's "before"
        self._previous = now
        np.put(self.buf, self._flat, now)  # (float64 -> float32, as an assignment rounds)
        self.last_engine_ms = (time.perf_counter() - t0) * 1e3
        self.last_transforms = {g: T.copy() for g, T in transforms.items()}
        self.frames += 1
        return moved

    _previous: np.ndarray = None  # the moving rows of the pose before the last frame
    _settle_frames: int = 0
    tolerance: float = 1e-6  # HybridEditor.pose's: a frame moving no vertex by more than this x diagonal

    #: at most this many frames per settle (HybridEditor.pose's max_frames): a pose that does not
    #: converge stops there instead of keeping a core busy
    max_frames: int = 1000

    def _converged(self, moved: float) -> bool:
        diag = max(float(self.editor.mesh.bbox_diagonal()), np.finfo(float).tiny)
        return moved <= self.tolerance * diag or self._settle_frames >= self.max_frames

    last_set_ms: float = 0.0  # foreach_set alone
    last_update_ms: float = 0.0  # Mesh.update (tags the mesh for Blender's redraw)

    def write(self, me) -> None:
        t0 = time.perf_counter()
        data, key = _position_data(me)
        data.foreach_set(key, self.buf)
        t1 = time.perf_counter()
        me.update()
        t2 = time.perf_counter()
        self.last_set_ms, self.last_update_ms = (t1 - t0) * 1e3, (t2 - t1) * 1e3
        self.last_write_ms = (t2 - t0) * 1e3

    def live(self, me, transforms: dict[int, np.ndarray]) -> None:
        """A live frame for new Empty transforms: drag, write; the settle follows on a timer.
        The frame is the first of HybridEditor.pose's loop for these transforms."""
        self._previous = np.take(self.editor.deformed_vertices, self.moving, axis=0, out=self._before)
        self._settle_frames = 1
        self.settled = self._converged(self.frame(transforms))
        self.write(me)

    def settle(self, me, budget_s: float = 0.04) -> bool:
        """Frames at the last transforms until one moves no vertex by more than ``tolerance`` times
        the diagonal (``HybridEditor.pose``'s rule, its loop continued from the live frame), at
        most ``budget_s`` seconds per call; True once settled. Writes the mesh."""
        if self.settled or not self.last_transforms:
            self.settled = True
            return True
        t0 = time.perf_counter()
        while True:
            moved = self.frame(self.last_transforms)
            self._settle_frames += 1
            if self._converged(moved):
                self.settled = True
                break
            if time.perf_counter() - t0 > budget_s:
                break
        self.write(me)
        return self.settled

    # -------------------------------------------------------------- checks
    def mesh_changed(self, me, full: bool = False) -> str | None:
        """Why the mesh no longer is the one bound (one line), or None. Cheap unless ``full``:
        counts and a few probe rows every frame; every position and the triangles on ``full``."""
        counts = topology_counts(me)
        if counts != self.counts:
            return (f"'{self.object_name}' changed since Bind ({counts[0]:,} vertices, {counts[2]:,} faces; "
                    f"bound {self.counts[0]:,}, {self.counts[2]:,}): Bind again")
        if full:
            now = read_positions(me)
            if not np.array_equal(now, self.buf) or fingerprint(np.zeros(0, np.float32), read_triangles(me)) != self.tris_digest:
                return f"'{self.object_name}' was edited since Bind: Bind again"
        else:
            for i in self._probe:
                co = me.vertices[int(i)].co
                if (co[0], co[1], co[2]) != tuple(float(x) for x in self.buf[3 * i:3 * i + 3]):
                    return f"'{self.object_name}' was edited since Bind: Bind again"
        return None

    def reset(self, me) -> None:
        """Back to the pose of Bind (or of the last Apply), exactly; the selection is kept."""
        self.editor.restore_state(self.base_state)
        self.buf[:] = self.base32
        self.last_transforms = {}
        self.settled = True
        self._previous = None
        self.write(me)

    def rebase(self, positions32: np.ndarray, empties: dict[str, np.ndarray]) -> None:
        """Take ``positions32`` (what the mesh holds, e.g. after Apply or an undo) as the pose the
        next drags start from, with each Empty's current matrix as its rest."""
        if not np.array_equal(positions32, self.buf):
            self.editor.set_pose(positions32.reshape(-1, 3).astype(np.float64))
            self.buf[:] = positions32
        for h in self.handles:
            h.rest = empties[h.empty].copy()
        self.select()


def triangles_digest(tris: np.ndarray) -> str:
    return fingerprint(np.zeros(0, np.float32), tris)
