"""Operators besides Bind: Apply (the pose key baked into the basis), Reset (the pose key zeroed),
Bake Animation (a frame range into keyed shape keys), Unbind, Settle, the ROI and handles from the
edit-mode selection, and a one-line report for problems found outside an operator."""

from __future__ import annotations

import bpy
import numpy as np
from bpy.props import EnumProperty, IntProperty, StringProperty
from mathutils import Matrix, Vector

from . import live
from . import session as S
from .bind import SESSIONS, session_of


def _session(op, context) -> S.Session | None:
    obj = context.object
    s = session_of(obj)
    if s is None:
        if obj is not None and obj.hybrid_arap.problem:  # found while following the Empties
            op.report({"ERROR"}, f"Hybrid ARAP: {obj.hybrid_arap.problem}")
        else:
            op.report({"ERROR"}, f"Hybrid ARAP: '{obj.name if obj else '?'}' is not bound: Bind first")
    return s


def _settled_and_checked(op, context) -> S.Session | None:
    """The active object's session with its pending settle finished, then :func:`_checked`
    (None, reported, when it is not bound or not usable)."""
    s = _session(op, context)
    if s is None:
        return None
    live.finish(s)
    return _checked(op, context)


def _checked(op, context) -> S.Session | None:
    s = _session(op, context)
    if s is None:
        return None
    obj = context.object
    if obj.mode == "EDIT":
        op.report({"ERROR"}, f"Hybrid ARAP: '{obj.name}' is in Edit Mode: leave it first")
        return None
    live.stop_worker(s)
    problem = s.edited(obj)
    if problem:
        live.stop(s, problem)
        live.LAST_PROBLEMS[:] = [p for p in live.LAST_PROBLEMS if p[1] != problem]  # reported here instead
        op.report({"ERROR"}, f"Hybrid ARAP: {problem}")
        return None
    return s


def _mesh_poll(context):
    return context.object is not None and context.object.type == "MESH"


def _empties_rest_here(obj) -> None:
    """Each handle's rest is its Empty's matrix now (as Blender holds it: it rounds what was set)."""
    for h in obj.hybrid_arap.handles:
        if h.empty is not None:
            h.rest = S.matrix_flat(S.matrix_np(h.empty.matrix_world))


def _selection(op, obj, what: str) -> np.ndarray | None:
    """The selected vertices of ``obj`` (edit mode's selection), or None, reported, when there are none."""
    rows = _selected_rows(obj)
    if len(rows) == 0:
        op.report({"ERROR"}, f"Hybrid ARAP: no vertex selected for the {what}")
        return None
    return rows


class HYBRIDARAP_OT_report(bpy.types.Operator):
    """Report a message (used for problems found while following the Empties)"""

    bl_idname = "hybrid_arap.report"
    bl_label = "Hybrid ARAP Report"
    bl_options = {"INTERNAL"}

    message: StringProperty()
    level: EnumProperty(items=[(k, k, "") for k in ("INFO", "WARNING", "ERROR")], default="ERROR")

    def execute(self, context):
        self.report({self.level}, f"Hybrid ARAP: {self.message}")
        return {"FINISHED"}


def bake_into_basis(s: S.Session, obj) -> str:
    """The pose key into the mesh: the basis (and the mesh's own positions) take it, every other key
    relative to the basis keeps its offset, the pose key adds nothing; a mesh that had no shape keys
    before the first Bind gets none. Returns the new rest's digest (main thread, a few foreach calls)."""
    me = obj.data
    n = s.n
    pose = s.buf.copy()
    delta = pose - s.base.basis32
    keys = me.shape_keys
    if keys is not None:
        ref, ours = keys.reference_key, S.pose_key(obj)
        for kb in keys.key_blocks[1:]:
            if kb != ours and kb.relative_key == ref:
                S.write_key(kb, S.read_key(kb, n) + delta)
        S.write_key(ref, pose)
        if ours is not None:
            S.write_key(ours, pose)
        if not obj.hybrid_arap.had_keys and all(kb in (ref, ours) for kb in keys.key_blocks):
            obj.shape_key_clear()
    S.write_positions(me, pose)
    rest, basis = S.rest_mix(obj)
    return S.fingerprint(rest, S.read_triangles(me)), rest, basis


def rebase_async(s: S.Session, obj, digest: str, rest: np.ndarray, basis: np.ndarray) -> None:
    """After Apply: the engine takes its current pose as the base of the next drags (set_pose,
    set_selection) on the worker; the Empties' matrices now are their rests."""
    with S.ENGINE:
        V = s.editor.deformed_vertices.copy()
    s.buf[:] = basis
    s.written[:] = basis
    T = live.transforms_now(s, obj)

    def work(cancel):
        with S.ENGINE:
            s.editor.set_pose(V)
            s.base = S.Base(digest, rest.copy(), basis.copy())
            s.bases[digest] = s.base
            s.select()
            if isinstance(T, dict):
                s.last_transforms = T

    live.start_worker(s, "preparing the next pose after Apply for", work)


class HYBRIDARAP_OT_apply(bpy.types.Operator):
    """Bake the pose into the mesh (one undo step): the basis takes it, the pose key is zeroed, and it
    is the pose the next moves start from, the Empties where they are now"""

    bl_idname = "hybrid_arap.apply"
    bl_label = "Apply"
    bl_options = {"REGISTER", "UNDO"}

    poll = classmethod(lambda cls, context: _mesh_poll(context))
    _timer = None
    _s = None

    def execute(self, context):
        return self._apply(context)

    def _apply(self, context):
        """Apply once any settle has finished (the session checked, reported when unusable)."""
        s = _settled_and_checked(self, context)
        if s is None:
            return {"CANCELLED"}
        obj = context.object
        with live.own_writes():
            digest, rest, basis = bake_into_basis(s, obj)
            T = live.transforms_now(s, obj)
            if isinstance(T, str):
                self.report({"ERROR"}, f"Hybrid ARAP: {T}")
                return {"CANCELLED"}
            _empties_rest_here(obj)
            obj.hybrid_arap.bound = digest
            rebase_async(s, obj, digest, rest, basis)
        self.report({"INFO"}, f"Hybrid ARAP: pose applied to '{obj.name}'")
        return {"FINISHED"}

    def invoke(self, context, event):
        s = _session(self, context)
        if s is None:
            return {"CANCELLED"}
        if s.thread is None or not s.thread.is_alive():
            return self._apply(context)
        self._s = s  # a settle is running: wait for it with its progress in the status bar
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        s = self._s
        if event.type == "ESC" and event.value == "PRESS":
            context.window_manager.event_timer_remove(self._timer)
            context.workspace.status_text_set(None)
            self.report({"WARNING"}, "Hybrid ARAP: Apply cancelled (the pose goes on settling)")
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        if s.thread is not None and s.thread.is_alive():
            context.workspace.status_text_set(
                f"Hybrid ARAP: Apply waits for '{s.object_name}' to settle: {int(100 * s.progress)}%. Esc to cancel")
            return {"RUNNING_MODAL"}
        context.window_manager.event_timer_remove(self._timer)
        context.workspace.status_text_set(None)
        return self._apply(context)


class HYBRIDARAP_OT_reset(bpy.types.Operator):
    """Return the mesh to the pose of Bind (or of the last Apply): the pose key adds nothing, the
    Empties go back to where they were"""

    bl_idname = "hybrid_arap.reset"
    bl_label = "Reset"
    bl_options = {"REGISTER", "UNDO"}

    poll = classmethod(lambda cls, context: _mesh_poll(context))

    def execute(self, context):
        s = _settled_and_checked(self, context)
        if s is None:
            return {"CANCELLED"}
        obj = context.object
        with live.own_writes():
            for h in obj.hybrid_arap.handles:
                if h.empty is not None:
                    h.empty.matrix_world = Matrix(S.matrix_np(h.rest).tolist())
            s.zero()
            s.write(obj)
            context.view_layer.update()
            _empties_rest_here(obj)
            T = live.transforms_now(s, obj)
            s.last_transforms = T if isinstance(T, dict) else {}
        return {"FINISHED"}


class HYBRIDARAP_OT_settle(bpy.types.Operator):
    """Solve the current pose to convergence now (waits for the background work)"""

    bl_idname = "hybrid_arap.settle"
    bl_label = "Settle"
    bl_options = {"REGISTER"}

    poll = classmethod(lambda cls, context: _mesh_poll(context))

    def execute(self, context):
        live.finish()
        s = _session(self, context)
        if s is None:
            return {"CANCELLED"}
        live.step(s)
        live.finish(s)
        return {"FINISHED"}


class HYBRIDARAP_OT_unbind(bpy.types.Operator):
    """Stop following the Empties (the pose stays in its shape key)"""

    bl_idname = "hybrid_arap.unbind"
    bl_label = "Unbind"
    bl_options = {"REGISTER", "UNDO"}

    poll = classmethod(lambda cls, context: _mesh_poll(context))

    def execute(self, context):
        s = session_of(context.object)
        if s is not None:
            live.finish(s)
            SESSIONS.pop(s.uid, None)
        context.object.hybrid_arap.bound = ""
        self.report({"INFO"}, f"Hybrid ARAP: '{context.object.name}' unbound; its pose stays in the '{S.KEY}' "
                              "shape key")
        return {"FINISHED"}


def _constant_interpolation(keys, names: set[str]) -> None:
    """Keyframes of these shape keys' values held until the next (CONSTANT), through the action's
    F-curves (4.2-4.5: action.fcurves; layered actions: the slot's channelbag)."""
    ad = keys.animation_data
    act = ad.action if ad is not None else None
    if act is None:
        return
    curves = []
    try:
        curves = list(act.fcurves)
    except AttributeError:
        for layer in getattr(act, "layers", ()):
            for strip in layer.strips:
                bag = strip.channelbag(ad.action_slot) if ad.action_slot is not None else None
                curves += list(bag.fcurves) if bag is not None else []
    paths = {f'key_blocks["{n}"].value' for n in names}
    for fc in curves:
        if fc.data_path in paths:
            for kp in fc.keyframe_points:
                kp.interpolation = "CONSTANT"


class HYBRIDARAP_OT_bake_animation(bpy.types.Operator):
    """Bake the pose of every frame of the range into shape keys keyed on their frames, so the file
    plays and renders without the add-on (frames with the same pose share a key); Live is then off"""

    bl_idname = "hybrid_arap.bake_animation"
    bl_label = "Bake Animation"
    bl_options = {"REGISTER", "UNDO"}

    frame_start: IntProperty(name="Start", default=1)
    frame_end: IntProperty(name="End", default=250)

    poll = classmethod(lambda cls, context: _mesh_poll(context))

    def invoke(self, context, event):
        self.frame_start, self.frame_end = context.scene.frame_start, context.scene.frame_end
        return self.execute(context)

    def execute(self, context):
        s = _settled_and_checked(self, context)
        if s is None:
            return {"CANCELLED"}
        obj, scene = context.object, context.scene
        if self.frame_end < self.frame_start:
            self.report({"ERROR"}, "Hybrid ARAP: the frame range is empty")
            return {"CANCELLED"}
        st = obj.hybrid_arap
        st.live = True
        f_now = scene.frame_current
        wm = context.window_manager
        wm.progress_begin(self.frame_start, self.frame_end)
        runs, made = [], set()
        prev, start = None, None

        def close(end):
            kb = obj.shape_key_add(name=f"{S.KEY} {start:04d}", from_mix=False)
            S.write_key(kb, prev)
            kb.relative_key = obj.data.shape_keys.reference_key
            for f, v in ((start - 1, 0.0), (start, 1.0), (end, 1.0), (end + 1, 0.0)):
                kb.value = v
                kb.keyframe_insert("value", frame=f)
            made.add(kb.name)
            runs.append((start, end))

        active = obj.active_shape_key_index
        try:
            for f in range(self.frame_start, self.frame_end + 1):
                scene.frame_set(f)
                live.finish(s)
                if s.uid not in SESSIONS:
                    self.report({"ERROR"}, f"Hybrid ARAP: {s.problem or 'the bake stopped'}")
                    return {"CANCELLED"}
                if prev is not None and np.array_equal(prev, s.buf):
                    continue
                if prev is not None:
                    close(f - 1)
                prev, start = s.buf.copy(), f
                wm.progress_update(f)
                live.status(f"Hybrid ARAP: baking '{obj.name}': frame {f} of {self.frame_start}-{self.frame_end}")
            close(self.frame_end)
            _constant_interpolation(obj.data.shape_keys, made)
        finally:
            wm.progress_end()
            live.status(None)
            obj.active_shape_key_index = active
        st.live = False  # the keys play the animation now; the pose key adds nothing
        st.baked = True
        s.zero()
        s.write(obj)
        scene.frame_set(f_now)
        self.report({"INFO"}, f"Hybrid ARAP: baked frames {self.frame_start}-{self.frame_end} of '{obj.name}' into "
                              f"{len(runs)} shape keys; Live is off")
        return {"FINISHED"}


def _selected_rows(obj) -> np.ndarray:
    was_edit = obj.mode == "EDIT"
    if was_edit:
        obj.update_from_editmode()
    sel = np.zeros(len(obj.data.vertices), dtype=bool)
    obj.data.vertices.foreach_get("select", sel)
    return np.flatnonzero(sel)


def _assign_group(obj, name: str, rows: np.ndarray):
    """Make vertex group ``name`` exactly ``rows`` (weight 1), creating it if needed."""
    was_edit = obj.mode == "EDIT"
    if was_edit:
        bpy.ops.object.mode_set(mode="OBJECT")
    vg = obj.vertex_groups.get(name) or obj.vertex_groups.new(name=name)
    vg.remove(list(range(len(obj.data.vertices))))
    vg.add(rows.tolist(), 1.0, "REPLACE")
    if was_edit:
        bpy.ops.object.mode_set(mode="EDIT")
    return vg


class HYBRIDARAP_OT_roi_from_selection(bpy.types.Operator):
    """Make the ROI vertex group (the region that may move) the selected vertices"""

    bl_idname = "hybrid_arap.roi_from_selection"
    bl_label = "ROI from Selection"
    bl_options = {"REGISTER", "UNDO"}

    poll = classmethod(lambda cls, context: _mesh_poll(context))

    def execute(self, context):
        obj = context.object
        rows = _selection(self, obj, "ROI")
        if rows is None:
            return {"CANCELLED"}
        st = obj.hybrid_arap
        name = st.roi_group or "Hybrid ROI"
        _assign_group(obj, name, rows)
        st.roi_group = name
        self.report({"INFO"}, f"Hybrid ARAP: ROI '{name}' = {len(rows):,} vertices; Bind to use it")
        return {"FINISHED"}


class HYBRIDARAP_OT_add_handle(bpy.types.Operator):
    """Make the selected vertices a handle group driven by a new Empty at their centre"""

    bl_idname = "hybrid_arap.add_handle"
    bl_label = "Add Handle from Selection"
    bl_options = {"REGISTER", "UNDO"}

    poll = classmethod(lambda cls, context: _mesh_poll(context))

    def execute(self, context):
        obj = context.object
        rows = _selection(self, obj, "handle")
        if rows is None:
            return {"CANCELLED"}
        st = obj.hybrid_arap
        taken = {h.group for h in st.handles}
        k = 1
        while f"Hybrid Handle {k}" in taken or obj.vertex_groups.get(f"Hybrid Handle {k}") is not None:
            k += 1
        name = f"Hybrid Handle {k}"
        _assign_group(obj, name, rows)
        context.view_layer.update()  # matrix_world as evaluated (e.g. right after an import set a rotation)
        co = np.empty(len(obj.data.vertices) * 3, dtype=np.float32)
        obj.data.vertices.foreach_get("co", co)
        P = co.reshape(-1, 3)
        centre = obj.matrix_world @ Vector(P[rows].mean(axis=0).tolist())
        size = float(np.linalg.norm(np.ptp(P, axis=0))) * 0.05 * max(obj.matrix_world.to_scale())
        empty = bpy.data.objects.new(f"{obj.name} {name}", None)
        empty.empty_display_type = "SPHERE"
        empty.empty_display_size = max(size, 1e-3)
        empty.location = centre
        for coll in obj.users_collection[:1] or [context.scene.collection]:
            coll.objects.link(empty)
        h = st.handles.add()
        h.group = name
        h.empty = empty
        st.active_handle = len(st.handles) - 1
        self.report({"INFO"}, f"Hybrid ARAP: handle '{name}' = {len(rows):,} vertices, driven by '{empty.name}'; "
                              "Bind to use it")
        return {"FINISHED"}


class HYBRIDARAP_OT_remove_handle(bpy.types.Operator):
    """Remove the active handle from the list (its vertex group and Empty are kept)"""

    bl_idname = "hybrid_arap.remove_handle"
    bl_label = "Remove Handle"
    bl_options = {"REGISTER", "UNDO"}

    poll = classmethod(lambda cls, context: _mesh_poll(context) and len(context.object.hybrid_arap.handles) > 0)

    def execute(self, context):
        st = context.object.hybrid_arap
        st.handles.remove(st.active_handle)
        st.active_handle = max(0, min(st.active_handle, len(st.handles) - 1))
        return {"FINISHED"}


class HYBRIDARAP_OT_add_handle_slot(bpy.types.Operator):
    """Add an empty handle row (choose its vertex group and Empty)"""

    bl_idname = "hybrid_arap.add_handle_slot"
    bl_label = "Add Handle"
    bl_options = {"REGISTER", "UNDO"}

    poll = classmethod(lambda cls, context: _mesh_poll(context))

    def execute(self, context):
        st = context.object.hybrid_arap
        st.handles.add()
        st.active_handle = len(st.handles) - 1
        return {"FINISHED"}


CLASSES = (HYBRIDARAP_OT_report, HYBRIDARAP_OT_apply, HYBRIDARAP_OT_reset, HYBRIDARAP_OT_settle,
           HYBRIDARAP_OT_unbind, HYBRIDARAP_OT_bake_animation, HYBRIDARAP_OT_roi_from_selection, HYBRIDARAP_OT_add_handle,
           HYBRIDARAP_OT_remove_handle, HYBRIDARAP_OT_add_handle_slot)
