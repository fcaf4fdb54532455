"""Bind: the cage and binding built on a thread, with progress and Esc to cancel in the status bar.

Everything Blender is read on the main thread first (positions, triangles, vertex
groups, the Empties); the thread then only runs hybridedit (``build_rig`` with its
on-disk cache keyed by the mesh's content, ``HybridEditor``, ``set_selection``) and
never touches bpy. The modal operator polls it on a timer and installs the session
when it is done. Called from a script (``bpy.ops.hybrid_arap.bind()``) it runs the
same job synchronously.
"""

from __future__ import annotations

import os
import threading
import time
from pathlib import Path

import bpy
import numpy as np

from . import session as S

SESSIONS: dict[str, S.Session] = {}


def user_folder(sub: str) -> str:
    """A user-writable folder of this extension (the extension's own folder may be read-only)."""
    override = os.environ.get("HYBRIDEDIT_BLENDER_CACHE")
    if override:
        path = os.path.join(override, sub)
    else:
        try:  # installed as an extension (Blender 4.2+)
            path = bpy.utils.extension_path_user(__package__, path=sub, create=True)
        except (ValueError, AttributeError):  # installed as a plain module (tests, legacy add-on)
            path = os.path.join(bpy.utils.user_resource("DATAFILES"), "hybridedit_blender", sub)
    os.makedirs(path, exist_ok=True)
    return path


def kernels_cached() -> bool:
    """True when numba's cache folder holds compiled kernels of hybridedit (else the first
    bind compiles them: a minute or two)."""
    folder = os.environ.get("NUMBA_CACHE_DIR")
    if not folder or not os.path.isdir(folder):
        return False
    return any("hybridedit" in str(p) or p.name.startswith(("binding", "arap", "mvc")) for p in Path(folder).rglob("*.nbi"))


class BindJob:
    """One bind: read on the main thread in __init__, computed by run() (any thread), installed by
    install() on the main thread. Problems are BindError messages (one line)."""

    def __init__(self, obj, *, cancel_event: threading.Event | None = None) -> None:
        if obj is None or obj.type != "MESH":
            raise S.BindError("select a mesh object to bind")
        if obj.mode == "EDIT":
            obj.update_from_editmode()
        st = obj.hybrid_arap
        me = obj.data
        if len(me.vertices) < 4 or len(me.polygons) == 0:
            raise S.BindError(f"'{obj.name}' has no surface to bind ({len(me.vertices)} vertices, "
                              f"{len(me.polygons)} faces)")
        if len(st.handles) == 0:
            raise S.BindError("add a handle group (a vertex group and its Empty) before Bind")
        names = []
        for i, h in enumerate(st.handles):
            if not h.group:
                raise S.BindError(f"handle {i + 1} has no vertex group")
            if h.empty is None:
                raise S.BindError(f"handle '{h.group}' has no Empty")
            if h.empty.type != "EMPTY":
                raise S.BindError(f"'{h.empty.name}' driving '{h.group}' is not an Empty")
            names.append(h.group)
        if st.roi_group:
            names.append(st.roi_group)
        members = S.group_members(obj, names)
        for name, rows in members.items():
            if len(rows) == 0:
                raise S.BindError(f"vertex group '{name}' is empty")
        handle_rows = [members[h.group] for h in st.handles]
        for i in range(len(handle_rows)):
            for j in range(i):
                if np.intersect1d(handle_rows[i], handle_rows[j]).size:
                    raise S.BindError(f"handle groups '{st.handles[j].group}' and '{st.handles[i].group}' "
                                      "share vertices")
        self.object_name = obj.name
        self.positions = S.read_positions(me)
        if not np.all(np.isfinite(self.positions)):
            raise S.BindError(f"'{obj.name}' has non-finite vertex positions")
        self.tris = S.read_triangles(me)
        self.counts = S.topology_counts(me)
        self.handle_rows = handle_rows
        self.roi = members[st.roi_group] if st.roi_group else None
        self.roi_group = st.roi_group
        self.handles = [S.Handle(h.group, h.empty.name, S.matrix_np(h.empty.matrix_world)) for h in st.handles]
        self.cage_size = float(st.cage_size)
        self.iterations = int(st.iterations)
        self.cache_dir = user_folder("bindings")
        self.cancel = cancel_event or threading.Event()
        self.stage, self.fraction = "starting", 0.0
        self.first_compile = not kernels_cached()
        self.session: S.Session | None = None
        self.error: str | None = None
        self.seconds = 0.0

    def _progress(self, stage: str, fraction: float) -> None:
        self.stage, self.fraction = stage, float(fraction)
        if self.cancel.is_set():
            raise S.Cancelled()

    def run(self) -> None:
        t0 = time.perf_counter()
        try:
            self._progress("loading the engine", 0.0)
            import hybridedit as he

            mesh = he.Mesh(self.positions.reshape(-1, 3).astype(np.float64), self.tris, name=self.object_name)
            rig = he.build_rig(mesh, cage_size=self.cage_size, cache=self.cache_dir, progress=self._progress)
            self._progress("preparing the editor", 0.0)
            ed = he.HybridEditor(rig, iterations=self.iterations)
            s = S.Session(self.object_name, ed, self.positions.copy(), S.triangles_digest(self.tris), self.counts,
                          handles=self.handles, roi_group=self.roi_group, roi=self.roi,
                          handle_rows=self.handle_rows, cage_size=self.cage_size, cache_hit=rig.cache_hit,
                          notes=tuple(rig.notes))
            self._progress("factoring the selection", 0.0)
            s.select()
            # compile the frame kernels now (first use), not at the first move of an Empty
            self._progress("compiling the frame", 0.0)
            ed.drag(transforms={g: np.eye(4) for g in range(len(self.handles))})
            ed.restore_state(s.base_state)
            s.bind_seconds = time.perf_counter() - t0
            self.session = s
        except S.Cancelled:
            self.error = "cancelled"
        except S.BindError as e:
            self.error = str(e)
        except Exception as e:  # noqa: BLE001 -- one line for the user; the type helps a bug report
            self.error = f"bind failed: {type(e).__name__}: {e}".splitlines()[0]
        self.seconds = time.perf_counter() - t0

    def status(self) -> str:
        pct = int(round(100 * self.fraction))
        first = " (first use: compiling the engine, a minute or two, once)" if self.first_compile else ""
        return f"Hybrid ARAP: binding '{self.object_name}': {self.stage} {pct}%{first}. Esc to cancel"

    def install(self, context) -> tuple[set, str]:
        """Install the finished session (main thread); returns the report type and its line."""
        if self.session is None:
            return {"WARNING"} if self.error == "cancelled" else {"ERROR"}, f"Hybrid ARAP: {self.error}"
        obj = bpy.data.objects.get(self.object_name)
        if obj is None:
            return {"ERROR"}, f"Hybrid ARAP: '{self.object_name}' was removed during Bind"
        if S.topology_counts(obj.data) != self.counts or not np.array_equal(S.read_positions(obj.data), self.positions):
            return {"ERROR"}, f"Hybrid ARAP: '{self.object_name}' changed during Bind: Bind again"
        s = self.session
        empties = {h.empty: S.matrix_np(bpy.data.objects[h.empty].matrix_world) for h in s.handles
                   if h.empty in bpy.data.objects}
        if len(empties) == len(s.handles):  # the Empties where they are now: no move yet
            s.last_transforms = s.transforms_from(S.matrix_np(obj.matrix_world), empties)
        SESSIONS[self.object_name] = s
        st = obj.hybrid_arap
        st.problem = ""
        st.bound = S.fingerprint(self.positions, self.tris)[:16]
        s = self.session
        line = (f"Hybrid ARAP: bound '{self.object_name}' ({s.n:,} vertices, cage {s.editor.cage.n_vertices:,}) in "
                f"{s.bind_seconds:.1f} s{' from the cache' if s.cache_hit else ''}")
        if s.notes:
            return {"WARNING"}, line + "; the cage was built on a repaired copy: " + "; ".join(s.notes)
        return {"INFO"}, line


class HYBRIDARAP_OT_bind(bpy.types.Operator):
    """Build the cage and binding of the active mesh (in the background, cached by the mesh's
    content) and set the selection from the ROI and handle vertex groups"""

    bl_idname = "hybrid_arap.bind"
    bl_label = "Bind"
    bl_options = {"REGISTER"}

    _job: BindJob | None = None
    _thread: threading.Thread | None = None
    _timer = None

    @classmethod
    def poll(cls, context):
        return context.object is not None and context.object.type == "MESH"

    def _start(self, context) -> BindJob | None:
        SESSIONS.pop(context.object.name, None)  # a new bind replaces the old session
        try:
            return BindJob(context.object)
        except S.BindError as e:
            self.report({"ERROR"}, f"Hybrid ARAP: {e}")
            return None

    def execute(self, context):
        job = self._start(context)
        if job is None:
            return {"CANCELLED"}
        job.run()
        kind, line = job.install(context)
        self.report(kind, line)
        return {"FINISHED"} if job.session is not None else {"CANCELLED"}

    def invoke(self, context, event):
        job = self._start(context)
        if job is None:
            return {"CANCELLED"}
        self._job = job
        self._thread = threading.Thread(target=job.run, name="hybridedit-bind", daemon=True)
        self._thread.start()
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.progress_begin(0, 100)
        wm.modal_handler_add(self)
        context.workspace.status_text_set(job.status())
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        job = self._job
        if event.type == "ESC" and event.value == "PRESS":
            job.cancel.set()
            context.workspace.status_text_set("Hybrid ARAP: cancelling the bind...")
            return {"RUNNING_MODAL"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        if self._thread.is_alive():
            context.window_manager.progress_update(int(100 * job.fraction))
            context.workspace.status_text_set(job.status())
            return {"RUNNING_MODAL"}
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        context.workspace.status_text_set(None)
        kind, line = job.install(context)
        self.report(kind, line)
        for area in context.screen.areas if context.screen else ():
            area.tag_redraw()
        return {"FINISHED"} if job.session is not None else {"CANCELLED"}
