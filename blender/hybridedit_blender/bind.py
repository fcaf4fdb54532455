"""Bind: the cage and binding built on a thread, with progress and Esc to cancel in the status bar.

Everything Blender is read on the main thread first (the rest: the shape-key mix
without the pose key; triangles, vertex groups, the Empties); the thread then only
runs hybridedit (``build_rig`` with its on-disk cache keyed by the mesh's content,
``HybridEditor``, ``set_selection``) and never touches bpy. The modal operator polls
it on a timer and installs the session when it is done. Called from a script
(``bpy.ops.hybrid_arap.bind()``) it runs the same jobs synchronously. Every selected
mesh is bound (the active one first).
"""

from __future__ import annotations

import os
import threading
import time
import uuid

import bpy
import numpy as np

from . import kernels
from . import session as S
from .engine import build_session

#: the bound objects' sessions, by their hybrid_arap.uid (kept through a rename)
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


def session_of(obj) -> S.Session | None:
    """The session of a mesh object (by its uid, so a renamed object keeps it)."""
    if obj is None or obj.type != "MESH":
        return None
    uid = obj.hybrid_arap.uid
    s = SESSIONS.get(uid) if uid else None
    if s is not None and s.object_name != obj.name:
        if bpy.data.objects.get(s.object_name) is not None and bpy.data.objects[s.object_name].hybrid_arap.uid == uid:
            return None  # a copy of the bound object (Duplicate): not bound itself
        s.object_name = obj.name  # renamed
    return s


def handle_rest(h) -> np.ndarray | None:
    """A handle's stored rest matrix (the Empty's world matrix at Bind or the last Apply), or None."""
    M = S.matrix_np(h.rest)
    return M if M[3, 3] == 1.0 else None


class BindJob:
    """One bind: read on the main thread in __init__, computed by run() (any thread), installed by
    install() on the main thread. Problems are BindError messages (one line).

    Each handle's rest is its stored rest (the object was bound before: the pose its key holds is
    kept and solved again at the Empties' current matrices) or the Empty's matrix now."""

    def __init__(self, obj, *, cancel_event: threading.Event | None = None) -> None:
        if obj is None or obj.type != "MESH":
            raise S.BindError("select a mesh object to bind")
        if obj.mode == "EDIT":
            raise S.BindError(f"'{obj.name}' is in Edit Mode: leave it to Bind")
        st = obj.hybrid_arap
        me = obj.data
        if len(me.vertices) < 4 or len(me.polygons) == 0:
            raise S.BindError(f"'{obj.name}' has no surface to bind ({len(me.vertices)} vertices, "
                              f"{len(me.polygons)} faces)")
        if len(st.handles) == 0:
            raise S.BindError(f"'{obj.name}': add a handle group (a vertex group and its Empty) before Bind")
        names = []
        for i, h in enumerate(st.handles):
            if not h.group:
                raise S.BindError(f"'{obj.name}': handle {i + 1} has no vertex group")
            if h.empty is None:
                raise S.BindError(f"'{obj.name}': handle '{h.group}' has no Empty")
            if h.empty.type != "EMPTY":
                raise S.BindError(f"'{obj.name}': '{h.empty.name}' driving '{h.group}' is not an Empty")
            names.append(h.group)
        if st.roi_group:
            names.append(st.roi_group)
        members = S.group_members(obj, names)
        for name, rows in members.items():
            if len(rows) == 0:
                raise S.BindError(f"'{obj.name}': vertex group '{name}' is empty")
        handle_rows = [members[h.group] for h in st.handles]
        for i in range(len(handle_rows)):
            for j in range(i):
                if np.intersect1d(handle_rows[i], handle_rows[j]).size:
                    raise S.BindError(f"'{obj.name}': handle groups '{st.handles[j].group}' and "
                                      f"'{st.handles[i].group}' share vertices")
        self.object_name = obj.name
        uid = st.uid
        if not uid or any(o.hybrid_arap.uid == uid for o in bpy.data.objects if o is not obj and o.type == "MESH"):
            uid = uuid.uuid4().hex  # new, or a copy of a bound object: an id of its own
        self.uid = uid
        self.rest, self.basis = S.rest_mix(obj)
        if not np.all(np.isfinite(self.rest)):
            raise S.BindError(f"'{obj.name}' has non-finite vertex positions")
        self.tris = S.read_triangles(me)
        self.counts = S.topology_counts(me)
        self.stretch = S.stretch_of(S.matrix_np(obj.matrix_world))
        self.handle_rows = handle_rows
        self.groups = [h.group for h in st.handles]
        self.roi = members[st.roi_group] if st.roi_group else None
        self.roi_group = st.roi_group
        stored = [handle_rest(h) for h in st.handles]
        self.kept_rests = S.pose_key(obj) is not None and all(r is not None for r in stored)
        self.rests = stored if self.kept_rests else [S.matrix_np(h.empty.matrix_world) for h in st.handles]
        self.cage_size = float(st.cage_size)
        self.iterations = int(st.iterations)
        self.cache_dir = user_folder("bindings")
        self.cancel = cancel_event or threading.Event()
        self.stage, self.fraction = "starting", 0.0
        self.first_compile = not kernels.ready()  # (and none is running: see status())
        self.session: S.Session | None = None
        self.error: str | None = None
        self.seconds = 0.0
        self.digest = S.fingerprint(self.rest, self.tris)

    def _progress(self, stage: str, fraction: float) -> None:
        self.stage, self.fraction = stage, float(fraction)
        if self.cancel.is_set():
            raise S.Cancelled()

    def run(self) -> None:
        t0 = time.perf_counter()
        try:
            if kernels.must_wait():  # load what it compiles rather than compile it beside it
                kernels.wait(self._progress)
                self.first_compile = not kernels.ready()  # (it failed or was killed: compiled here)
            self._progress("loading the engine", 0.0)
            s = build_session(uid=self.uid, object_name=self.object_name, rest32=self.rest, basis32=self.basis,
                              tris=self.tris, counts=self.counts, digest=self.digest, groups=self.groups,
                              handle_rows=self.handle_rows, roi=self.roi, roi_group=self.roi_group,
                              stretch=self.stretch, cage_size=self.cage_size, iterations=self.iterations,
                              cache_dir=self.cache_dir, progress=self._progress)
            s.bind_seconds = time.perf_counter() - t0
            self.session = s
        except S.Cancelled:
            self.error = "cancelled"
        except S.BindError as e:
            self.error = str(e)
        except Exception as e:  # noqa: BLE001 -- one line for the user; the type helps a bug report
            self.error = f"bind failed for '{self.object_name}': {type(e).__name__}: {e}".splitlines()[0]
        self.seconds = time.perf_counter() - t0

    def status(self) -> str:
        pct = int(round(100 * self.fraction))
        waiting = self.stage.startswith("waiting for the engine")
        first = " (first use: compiling the engine, a minute or two, once)" \
            if self.first_compile and not waiting and kernels.running() is None else ""
        return f"Hybrid ARAP: binding '{self.object_name}': {self.stage} {pct}%{first}. Esc to cancel"

    def install(self, context=None) -> tuple[set, str]:
        """Install the finished session (main thread); returns the report type and its line."""
        from . import live

        if self.session is None:
            return {"WARNING"} if self.error == "cancelled" else {"ERROR"}, f"Hybrid ARAP: {self.error}"
        obj = bpy.data.objects.get(self.object_name)
        if obj is None:
            return {"ERROR"}, f"Hybrid ARAP: '{self.object_name}' was removed or renamed during Bind: Bind again"
        if obj.mode == "EDIT":
            return {"ERROR"}, f"Hybrid ARAP: '{self.object_name}' went into Edit Mode during Bind: Bind again"
        rest, basis = S.rest_mix(obj)
        if S.topology_counts(obj.data) != self.counts or not np.array_equal(rest, self.rest) \
                or not np.array_equal(basis, self.basis):
            return {"ERROR"}, f"Hybrid ARAP: '{self.object_name}' changed during Bind: Bind again"
        s = self.session
        st = obj.hybrid_arap
        old = SESSIONS.pop(st.uid, None) if st.uid else None
        if old is not None:
            live.stop_worker(old)
        st.uid = self.uid
        st.problem = ""
        st.bound = self.digest
        st.stretch = [float(x) for x in (self.stretch if self.stretch is not None else np.eye(3)).T.ravel()]
        if obj.data.shape_keys is None:
            st.had_keys = False
        elif S.pose_key(obj) is None:
            st.had_keys = True
        kb = S.pose_key(obj)
        if self.kept_rests and kb is not None:
            s.buf = S.read_key(kb, s.n)  # the pose the file holds, shown until it is solved again
            s.written = s.buf.copy()
        S.ensure_pose_key(obj, s.base.basis32)
        for h, M in zip(st.handles, self.rests):
            h.rest = S.matrix_flat(M)
        SESSIONS[self.uid] = s
        if not self.kept_rests:
            s.write(obj)
        live.catch_up(s, obj)
        line = (f"Hybrid ARAP: bound '{self.object_name}' ({s.n:,} vertices, cage {s.editor.cage.n_vertices:,}) in "
                f"{s.bind_seconds:.1f} s{' from the cache' if s.cache_hit else ''}")
        if self.stretch is not None:
            line += "; solved in world space (non-uniform scale)"
        if s.notes:
            return {"WARNING"}, line + "; the cage was built on a repaired copy: " + "; ".join(s.notes)
        return {"INFO"}, line


def meshes_to_bind(context) -> list:
    """The selected meshes, the active one first (or the active one alone when nothing is selected)."""
    active = context.object
    out = [active] if active is not None and active.type == "MESH" else []
    out += [o for o in context.selected_objects if o.type == "MESH" and o is not active]
    return out


class HYBRIDARAP_OT_bind(bpy.types.Operator):
    """Build the cage and binding of every selected mesh (in the background, cached by the mesh's
    content) and set the selection from the ROI and handle vertex groups"""

    bl_idname = "hybrid_arap.bind"
    bl_label = "Bind"
    bl_options = {"REGISTER", "UNDO"}

    _jobs: list | None = None
    _thread: threading.Thread | None = None
    _timer = None

    @classmethod
    def poll(cls, context):
        return context.object is not None and context.object.type == "MESH"

    def _start(self, context) -> list[BindJob]:
        objs = meshes_to_bind(context)
        if any(o.mode == "EDIT" for o in objs):
            bpy.ops.object.mode_set(mode="OBJECT")
        jobs = []
        for obj in objs:
            try:
                jobs.append(BindJob(obj))
            except S.BindError as e:
                self.report({"ERROR"}, f"Hybrid ARAP: {e}")
        return jobs

    def _finish(self, jobs) -> set:
        ok = False
        for job in jobs:
            kind, line = job.install()
            self.report(kind, line)
            ok |= job.session is not None and kind != {"ERROR"}
        return {"FINISHED"} if ok else {"CANCELLED"}

    def execute(self, context):
        jobs = self._start(context)
        for job in jobs:
            job.run()
        return self._finish(jobs) if jobs else {"CANCELLED"}

    def invoke(self, context, event):
        jobs = self._start(context)
        if not jobs:
            return {"CANCELLED"}
        self._jobs = jobs

        def run_all():
            for job in jobs:
                if jobs[0].cancel.is_set():
                    job.error = "cancelled"
                    continue
                job.cancel = jobs[0].cancel
                job.run()

        self._thread = threading.Thread(target=run_all, name="hybridedit-bind", daemon=True)
        self._thread.start()
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.progress_begin(0, 100)
        wm.modal_handler_add(self)
        context.workspace.status_text_set(jobs[0].status())
        return {"RUNNING_MODAL"}

    def _current(self) -> BindJob:
        return next((j for j in self._jobs if j.session is None and j.error is None), self._jobs[-1])

    def modal(self, context, event):
        if event.type == "ESC" and event.value == "PRESS":
            self._jobs[0].cancel.set()
            context.workspace.status_text_set("Hybrid ARAP: cancelling the bind...")
            return {"RUNNING_MODAL"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        if self._thread.is_alive():
            job = self._current()
            context.window_manager.progress_update(int(100 * job.fraction))
            k = self._jobs.index(job)
            more = f" ({k + 1} of {len(self._jobs)})" if len(self._jobs) > 1 else ""
            context.workspace.status_text_set(job.status() + more)
            return {"RUNNING_MODAL"}
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        context.workspace.status_text_set(None)
        result = self._finish(self._jobs)
        for area in context.screen.areas if context.screen else ():
            area.tag_redraw()
        return result
