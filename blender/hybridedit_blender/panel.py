"""The "Hybrid ARAP" panel in the 3D view's sidebar (N), and the settings stored on each object."""

from __future__ import annotations

import bpy
from bpy.props import BoolProperty, CollectionProperty, FloatProperty, IntProperty, PointerProperty, StringProperty

from .bind import SESSIONS


class HybridArapHandle(bpy.types.PropertyGroup):
    group: StringProperty(name="Vertex Group", description="Vertices that follow the Empty exactly")
    empty: PointerProperty(name="Empty", type=bpy.types.Object, poll=lambda self, ob: ob.type == "EMPTY",
                           description="Moving or rotating this Empty moves the group, as a Hook does")


class HybridArapSettings(bpy.types.PropertyGroup):
    roi_group: StringProperty(name="ROI", description="Vertex group that may move (with the handles); everything "
                              "else stays fixed. Empty: nothing is fixed")
    handles: CollectionProperty(type=HybridArapHandle)
    active_handle: IntProperty(default=0)
    cage_size: FloatProperty(name="Cage Size", default=0.05, min=0.002, max=0.5, precision=3,
                             description="Cage vertices as a fraction of the mesh's vertices (smaller binds faster)")
    iterations: IntProperty(name="Iterations", default=2, min=1, max=16,
                            description="ARAP iterations per live frame")
    live: BoolProperty(name="Live", default=True, description="Follow the Empties as they move")
    bound: StringProperty(options={"HIDDEN"})  # fingerprint of the bound mesh ("" when not bound)
    problem: StringProperty(options={"HIDDEN"})  # the last problem found while following the Empties


class HYBRIDARAP_UL_handles(bpy.types.UIList):
    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index):
        row = layout.row(align=True)
        row.prop_search(item, "group", context.object, "vertex_groups", text="", icon="GROUP_VERTEX")
        row.prop(item, "empty", text="", icon="EMPTY_AXIS")


class VIEW3D_PT_hybrid_arap(bpy.types.Panel):
    bl_label = "Hybrid ARAP"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Hybrid ARAP"

    @classmethod
    def poll(cls, context):
        return context.object is not None and context.object.type == "MESH"

    def draw(self, context):
        obj = context.object
        st = obj.hybrid_arap
        layout = self.layout
        col = layout.column(align=True)
        col.prop_search(st, "roi_group", obj, "vertex_groups", icon="GROUP_VERTEX")
        col.operator("hybrid_arap.roi_from_selection", icon="RESTRICT_SELECT_OFF")
        layout.label(text="Handles (vertex group, Empty):")
        row = layout.row()
        row.template_list("HYBRIDARAP_UL_handles", "", st, "handles", st, "active_handle", rows=2)
        side = row.column(align=True)
        side.operator("hybrid_arap.add_handle_slot", icon="ADD", text="")
        side.operator("hybrid_arap.remove_handle", icon="REMOVE", text="")
        layout.operator("hybrid_arap.add_handle", icon="EMPTY_AXIS")
        col = layout.column(align=True)
        col.prop(st, "cage_size")
        col.prop(st, "iterations")
        row = layout.row(align=True)
        row.scale_y = 1.3
        row.operator("hybrid_arap.bind", icon="MOD_MESHDEFORM")
        row.operator("hybrid_arap.unbind", text="", icon="X")
        s = SESSIONS.get(obj.name)
        if s is not None:
            layout.prop(st, "live")
            row = layout.row(align=True)
            row.operator("hybrid_arap.apply", icon="CHECKMARK")
            row.operator("hybrid_arap.reset", icon="LOOP_BACK")
            box = layout.box().column(align=True)
            box.label(text=f"{s.n:,} vertices, cage {s.editor.cage.n_vertices:,}", icon="INFO")
            box.label(text=f"bound in {s.bind_seconds:.1f} s{' (cache)' if s.cache_hit else ''}")
            if s.frames:
                box.label(text=f"frame: engine {s.last_engine_ms:.1f} ms, write {s.last_write_ms:.1f} ms")
        elif st.problem:
            layout.label(text=st.problem, icon="ERROR")


CLASSES = (HybridArapHandle, HybridArapSettings, HYBRIDARAP_UL_handles, VIEW3D_PT_hybrid_arap)
