"""The "Hybrid ARAP" panel in the 3D view's sidebar (N), and the settings stored on each object."""

from __future__ import annotations

import bpy
from bpy.props import (BoolProperty, CollectionProperty, FloatProperty, FloatVectorProperty, IntProperty,
                       PointerProperty, StringProperty)

from . import kernels
from .bind import session_of
from .session import KEY


class HybridArapHandle(bpy.types.PropertyGroup):
    group: StringProperty(name="Vertex Group", description="Vertices that follow the Empty exactly")
    empty: PointerProperty(name="Empty", type=bpy.types.Object, poll=lambda self, ob: ob.type == "EMPTY",
                           description="Moving or rotating this Empty moves the group, as a Hook does")
    # the Empty's world matrix at Bind (or the last Apply): its motion since then moves the group.
    # Saved with the .blend (and restored by undo with the pose it belongs to); all zeros: not set
    rest: FloatVectorProperty(size=16, subtype="MATRIX", default=[0.0] * 16, options={"HIDDEN"})


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
    # saved with the .blend: what was bound, so that opening the file binds it again
    bound: StringProperty(options={"HIDDEN"})  # SHA-256 of the bound rest and triangles ("" when not bound)
    uid: StringProperty(options={"HIDDEN"})  # the binding's id (a rename keeps it, a copy gets its own)
    stretch: FloatVectorProperty(size=9, subtype="MATRIX", default=[1, 0, 0, 0, 1, 0, 0, 0, 1], options={"HIDDEN"})
    had_keys: BoolProperty(default=True, options={"HIDDEN"})  # shape keys before the first Bind (Apply keeps them)
    baked: BoolProperty(default=False, options={"HIDDEN"})  # Bake Animation wrote keyed shape keys
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
        c = kernels.running()
        if c is not None:
            layout.label(text=f"compiling the engine: {int(100 * c.fraction)}% (once)", icon="SORTTIME")
        s = session_of(obj)
        if s is not None:
            layout.prop(st, "live")
            row = layout.row(align=True)
            row.operator("hybrid_arap.apply", icon="CHECKMARK")
            row.operator("hybrid_arap.reset", icon="LOOP_BACK")
            layout.operator("hybrid_arap.bake_animation", icon="KEYINGSET")
            box = layout.box().column(align=True)
            box.label(text=f"{s.n:,} vertices, cage {s.editor.cage.n_vertices:,}", icon="INFO")
            box.label(text=f"bound in {s.bind_seconds:.1f} s{' (cache)' if s.cache_hit else ''}")
            box.label(text=f"pose in shape key '{KEY}'" + (", world space" if s.stretch is not None else ""))
            if s.busy:
                box.label(text=f"{s.busy} {int(100 * s.progress)}%", icon="SORTTIME")
            elif s.frames:
                box.label(text=f"frame: engine {s.last_engine_ms:.1f} ms, write {s.last_write_ms:.1f} ms")
            if st.baked:
                box.label(text="animation baked into shape keys", icon="KEYINGSET")
        elif st.problem:
            layout.label(text=st.problem, icon="ERROR")
        elif st.bound:
            layout.label(text="binding again...", icon="SORTTIME")


CLASSES = (HybridArapHandle, HybridArapSettings, HYBRIDARAP_UL_handles, VIEW3D_PT_hybrid_arap)
