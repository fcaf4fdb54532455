"""Operators besides Bind: Apply, Reset, Unbind, Settle, the ROI and handles from the edit-mode
selection, and a one-line report for problems found outside an operator."""

from __future__ import annotations

import bpy
import numpy as np
from bpy.props import EnumProperty, StringProperty
from mathutils import Matrix, Vector

from . import live
from . import session as S
from .bind import SESSIONS


def _session(op, context) -> S.Session | None:
    obj = context.object
    s = SESSIONS.get(obj.name) if obj is not None else None
    if s is None:
        if obj is not None and obj.hybrid_arap.problem:  # found while following the Empties
            op.report({"ERROR"}, f"Hybrid ARAP: {obj.hybrid_arap.problem}")
        else:
            op.report({"ERROR"}, f"Hybrid ARAP: '{obj.name if obj else '?'}' is not bound: Bind first")
    return s


def _checked(op, context) -> S.Session | None:
    s = _session(op, context)
    if s is None:
        return None
    obj = context.object
    if obj.mode == "EDIT":
        op.report({"ERROR"}, "Hybrid ARAP: leave Edit Mode first")
        return None
    problem = s.mesh_changed(obj.data, full=True)
    if problem:
        live.stop(s, problem)
        LAST = live.LAST_PROBLEMS
        if problem in LAST:
            LAST.remove(problem)  # reported here, not again by the timer
        op.report({"ERROR"}, f"Hybrid ARAP: {problem}")
        return None
    return s


def _mesh_poll(context):
    return context.object is not None and context.object.type == "MESH"


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


class HYBRIDARAP_OT_apply(bpy.types.Operator):
    """Bake the current pose into the mesh (one undo step): it becomes the pose that Reset returns
    to and that the next moves start from, the Empties where they are now"""

    bl_idname = "hybrid_arap.apply"
    bl_label = "Apply"
    bl_options = {"REGISTER", "UNDO"}

    poll = classmethod(lambda cls, context: _mesh_poll(context))

    def execute(self, context):
        s = _checked(self, context)
        if s is None:
            return {"CANCELLED"}
        me = context.object.data
        while not s.settle(me, budget_s=1.0):
            pass
        empties = live.empties_of(s)
        if isinstance(empties, str):
            self.report({"ERROR"}, f"Hybrid ARAP: {empties}")
            return {"CANCELLED"}
        s.write(me)
        try:
            s.rebase(S.read_positions(me), empties)
        except S.BindError as e:
            self.report({"ERROR"}, f"Hybrid ARAP: {e}")
            return {"CANCELLED"}
        self.report({"INFO"}, f"Hybrid ARAP: pose applied to '{context.object.name}'")
        return {"FINISHED"}


class HYBRIDARAP_OT_reset(bpy.types.Operator):
    """Return the mesh to the pose of Bind (or of the last Apply) and the Empties to where they were"""

    bl_idname = "hybrid_arap.reset"
    bl_label = "Reset"
    bl_options = {"REGISTER", "UNDO"}

    poll = classmethod(lambda cls, context: _mesh_poll(context))

    def execute(self, context):
        s = _checked(self, context)
        if s is None:
            return {"CANCELLED"}
        live._busy = True
        try:
            for h in s.handles:
                e = bpy.data.objects.get(h.empty)
                if e is not None:
                    e.matrix_world = Matrix(h.rest.tolist())
            s.reset(context.object.data)
            context.view_layer.update()
            # the Empties' matrices, read back from Blender, are what the next move is measured from
            empties = live.empties_of(s)
            if not isinstance(empties, str):
                for h in s.handles:
                    h.rest = empties[h.empty]
            s.last_transforms = s.transforms_from(S.matrix_np(context.object.matrix_world), empties) \
                if not isinstance(empties, str) else {}
        finally:
            live._busy = False
        return {"FINISHED"}


class HYBRIDARAP_OT_settle(bpy.types.Operator):
    """Solve the current pose to convergence now"""

    bl_idname = "hybrid_arap.settle"
    bl_label = "Settle"
    bl_options = {"REGISTER"}

    poll = classmethod(lambda cls, context: _mesh_poll(context))

    def execute(self, context):
        s = _session(self, context)
        if s is None:
            return {"CANCELLED"}
        live.step(s)
        while not s.settle(context.object.data, budget_s=1.0):
            pass
        return {"FINISHED"}


class HYBRIDARAP_OT_unbind(bpy.types.Operator):
    """Stop following the Empties (the mesh keeps its current shape)"""

    bl_idname = "hybrid_arap.unbind"
    bl_label = "Unbind"
    bl_options = {"REGISTER"}

    poll = classmethod(lambda cls, context: _mesh_poll(context))

    def execute(self, context):
        SESSIONS.pop(context.object.name, None)
        context.object.hybrid_arap.bound = ""
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
        rows = _selected_rows(obj)
        if len(rows) == 0:
            self.report({"ERROR"}, "Hybrid ARAP: no vertex selected for the ROI")
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
        rows = _selected_rows(obj)
        if len(rows) == 0:
            self.report({"ERROR"}, "Hybrid ARAP: no vertex selected for the handle")
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
           HYBRIDARAP_OT_unbind, HYBRIDARAP_OT_roi_from_selection, HYBRIDARAP_OT_add_handle,
           HYBRIDARAP_OT_remove_handle, HYBRIDARAP_OT_add_handle_slot)
