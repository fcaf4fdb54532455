"""The extension driven as a user would, in Blender itself (bpy): meshes made by Blender's own
operators and importer, vertex groups, Bind, the Empty moved and rotated, the depsgraph evaluated.

Tolerances: Blender holds positions as float32. The add-on's pose (float64, the engine's) is
compared with hybridedit's own API at 1e-9 of the diagonal, and the mesh must hold exactly that
pose rounded to float32; rows that may not move must hold their original float32 bits.
"""

from __future__ import annotations

import math

import bpy
import numpy as np
import pytest
from conftest import ARMADILLO
from mathutils import Euler, Vector

from hybridedit_blender import live
from hybridedit_blender import session as S
from hybridedit_blender.bind import session_of


def positions(me) -> np.ndarray:
    """The mesh's own (base) coordinates."""
    return S.read_positions(me).reshape(-1, 3)


def evaluated(obj) -> np.ndarray:
    """What Blender shows: the object's evaluated positions (shape keys and modifiers applied), local."""
    dg = bpy.context.evaluated_depsgraph_get()
    ev = obj.evaluated_get(dg).data
    buf = np.empty(len(ev.vertices) * 3, dtype=np.float32)
    ev.attributes["position"].data.foreach_get("vector", buf)
    return buf.reshape(-1, 3)


def key_positions(obj) -> np.ndarray:
    return S.read_key(S.pose_key(obj), len(obj.data.vertices)).reshape(-1, 3)


def world(obj, P) -> np.ndarray:
    M = S.matrix_np(obj.matrix_world)
    return P.astype(np.float64) @ M[:3, :3].T + M[:3, 3]


def select_rows(obj, mask: np.ndarray) -> None:
    obj.data.vertices.foreach_set("select", mask.astype(bool))


def rig_up(obj, handle_mask, roi_mask, cage_size=0.05):
    """Handle group + Empty and ROI group from 'edit-mode selections' (the panel's buttons)."""
    obj.hybrid_arap.cage_size = cage_size
    select_rows(obj, handle_mask)
    assert bpy.ops.hybrid_arap.add_handle() == {"FINISHED"}
    select_rows(obj, roi_mask)
    assert bpy.ops.hybrid_arap.roi_from_selection() == {"FINISHED"}
    return obj.hybrid_arap.handles[-1].empty


def rig_cap(obj, roi_z=-0.1):
    """The tests' usual edit: the cap above z = 0.75 a handle, everything above ``roi_z`` the ROI.
    Returns (rest positions (n, 3) float32, handle mask, roi mask, the handle's Empty)."""
    rest = positions(obj.data).copy()
    Z = rest[:, 2]
    handle, roi = Z > 0.75, Z > roi_z
    return rest, handle, roi, rig_up(obj, handle, roi)


def icosphere(subdivisions=4):
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=subdivisions, radius=1.0)
    obj = bpy.context.object
    me = obj.data
    # a colour attribute and the UV map the primitive made: neither may change
    col = me.color_attributes.new("Col", "FLOAT_COLOR", "POINT")
    rgba = np.random.default_rng(1).random(len(me.vertices) * 4).astype(np.float32)
    col.data.foreach_set("color", rgba)
    return obj


def attribute_snapshot(me) -> dict[str, np.ndarray]:
    """Every attribute but the positions, as arrays (UVs, colours, edges, corners, flags...)."""
    out = {}
    for a in me.attributes:
        if a.name == "position":
            continue
        field = {"FLOAT_VECTOR": "vector", "FLOAT_COLOR": "color", "BYTE_COLOR": "color", "FLOAT2": "vector",
                 "INT32_2D": "value", "QUATERNION": "value", "FLOAT4X4": "value"}.get(a.data_type, "value")
        width = {"FLOAT_VECTOR": 3, "FLOAT_COLOR": 4, "BYTE_COLOR": 4, "FLOAT2": 2, "INT32_2D": 2}.get(a.data_type, 1)
        dtype = {"BOOLEAN": bool, "INT": np.int32, "INT8": np.int8, "INT32_2D": np.int32}.get(a.data_type, np.float32)
        arr = np.empty(len(a.data) * width, dtype=dtype)
        a.data.foreach_get(field, arr)
        out[a.name] = arr
    return out


def local_T(obj, empty, rest_world):
    """The Empty's motion since rest in the mesh's local space, as a Hook applies it (written out here
    independently of the add-on's own formula)."""
    O = S.matrix_np(obj.matrix_world)
    return np.linalg.inv(O) @ S.matrix_np(empty.matrix_world) @ np.linalg.inv(rest_world) @ O


def reference_editor(rest32: np.ndarray, tris: np.ndarray, roi, handles, cage_size):
    """hybridedit's own API on the same mesh and the same selection (the same on-disk cache)."""
    import hybridedit as he

    from hybridedit_blender.bind import user_folder

    mesh = he.Mesh(rest32.astype(np.float64), tris)
    ed = he.HybridEditor(he.build_rig(mesh, cage_size=cage_size, cache=user_folder("bindings")))
    ed.set_selection(handle=handles, roi=roi)
    return ed


def check_pose(obj, s, ref_V, rest32, roi_rows, handle_rows, T):
    """The pose key holds the add-on's pose in float32 (float32 is Blender's); it equals the API's; fixed rows
    untouched; the handle exactly at the Empty's transform; Blender shows the key (evaluated positions, to float32
    rounding of basis + (key - basis)) and the base coordinates never change."""
    me = obj.data
    diag = float(np.linalg.norm(np.ptp(rest32, axis=0)))
    ours = np.asarray(s.editor.deformed_vertices)
    assert np.abs(ours - ref_V).max() <= 1e-9 * diag
    assert np.array_equal(positions(me), rest32)  # the base mesh is never written while posed
    P = key_positions(obj)
    ev = evaluated(obj)
    assert np.abs(ev - P).max() <= 1e-7 * diag  # (Blender adds key - basis to the basis, in float32)
    still = np.ones(len(P), bool)
    still[s.moving] = False
    assert np.array_equal(ev[still], rest32[still])  # what Blender shows keeps the rest's bits there
    # the rows a drag can move hold the pose in float32; the others keep their own bits (the
    # engine's float64 rest differs from them by ~1e-18 there, which the add-on never writes)
    still = np.ones(len(P), bool)
    still[s.moving] = False
    assert np.array_equal(P[s.moving], ours[s.moving].astype(np.float32))
    assert np.array_equal(P[still], rest32[still])
    fixed = np.ones(len(P), bool)
    fixed[roi_rows] = False
    fixed[handle_rows] = False
    assert np.array_equal(P[fixed], rest32[fixed])  # bit for bit (<= 1e-9 of the diagonal a fortiori)
    target = rest32[handle_rows].astype(np.float64) @ T[:3, :3].T + T[:3, 3]
    assert np.abs(ours[handle_rows] - target).max() <= 1e-9 * diag
    moved = np.abs(P - rest32).max(axis=1) > 0
    assert not moved[fixed].any() and moved[handle_rows].all()


def test_icosphere_live_edit_matches_api_and_keeps_attributes(scene):
    obj = icosphere(4)
    me = obj.data
    rest32, handle_mask, roi_mask, empty = rig_cap(obj)
    attrs = attribute_snapshot(me)
    assert "UVMap" in attrs and "Col" in attrs
    assert bpy.ops.hybrid_arap.bind() == {"FINISHED"}
    s = session_of(obj)
    assert s.n == len(me.vertices) and obj.hybrid_arap.bound
    rest_world = S.matrix_np(empty.matrix_world)
    handle_rows, roi_rows = np.flatnonzero(handle_mask), np.flatnonzero(roi_mask)
    ref = reference_editor(rest32, S.read_triangles(me), roi_rows, [handle_rows], 0.05)

    # move, then rotate the Empty, one depsgraph evaluation per step (a viewport drag's frames)
    steps = [(Vector((0, 0.1 * k, 0.08 * k)), Euler((0, 0, 0))) for k in range(1, 4)]
    steps += [(Vector((0, 0.3, 0.24)), Euler((math.radians(10 * k), 0, math.radians(5 * k)))) for k in range(1, 4)]
    loc0 = empty.location.copy()
    k_step = 0
    for d, rot in steps:
        empty.location = loc0 + d
        empty.rotation_euler = rot
        bpy.context.view_layer.update()  # the live frame (HybridEditor.drag), on Blender's main thread
        T = local_T(obj, empty, rest_world)
        V = ref.drag(transforms={0: T})  # the live frame, written before the worker settles it: the API's drag
        assert np.array_equal(key_positions(obj)[s.moving], V[s.moving].astype(np.float32))
        # the worker settles from there (what it does when the Empty stops) = the API's converge from it
        assert bpy.ops.hybrid_arap.settle() == {"FINISHED"}
        assert s.settled and 0 < s.last_distance <= 1e-6 and s.iterations > 0
        r = ref.converge(transforms={0: T})
        assert r.converged
        check_pose(obj, s, r.vertices, rest32, roi_rows, handle_rows, T)
        k_step += 1
    assert s.frames >= len(steps)
    assert all(np.array_equal(v, attribute_snapshot(me)[k]) for k, v in attrs.items())

    # an evaluation with nothing moved computes nothing
    n = s.frames
    bpy.context.view_layer.update()
    assert s.frames == n

    # Reset: the rest pose exactly, the Empty back where it was
    assert bpy.ops.hybrid_arap.reset() == {"FINISHED"}
    assert np.array_equal(evaluated(obj), rest32) and np.array_equal(key_positions(obj), rest32)
    assert np.allclose(S.matrix_np(empty.matrix_world), rest_world, atol=1e-6)
    assert all(np.array_equal(v, attribute_snapshot(me)[k]) for k, v in attrs.items())


def test_apply_persists_and_undo_restores(scene, tmp_path):
    obj = icosphere(3)
    name = obj.name
    rest32 = positions(obj.data).copy()
    Z = rest32[:, 2]
    empty = rig_up(obj, Z > 0.75, Z > -0.1)
    empty_name = empty.name
    assert bpy.ops.hybrid_arap.bind() == {"FINISHED"}
    attrs = attribute_snapshot(obj.data)
    bpy.ops.ed.undo_push(message="bound")
    empty.location.z += 0.4
    empty.rotation_euler.x = math.radians(25)
    bpy.context.view_layer.update()
    assert bpy.ops.hybrid_arap.apply() == {"FINISHED"}
    live.finish()
    posed = positions(obj.data).copy()  # Apply writes the pose into the base mesh
    assert np.abs(posed - rest32).max() > 0.1
    assert obj.data.shape_keys is None  # the mesh had no shape keys: Apply leaves none
    assert np.array_equal(evaluated(obj), posed)

    # Apply persists: Reset now returns to the applied pose, and the pose is in the saved file
    empty.location.z += 0.2
    bpy.context.view_layer.update()
    assert not np.array_equal(evaluated(obj), posed) and np.array_equal(positions(obj.data), posed)
    assert bpy.ops.hybrid_arap.reset() == {"FINISHED"}
    assert np.array_equal(evaluated(obj), posed)
    path = str(tmp_path / "posed.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    live.finish()
    assert np.array_equal(evaluated(bpy.data.objects[name]), posed)
    assert all(np.array_equal(v, attribute_snapshot(bpy.data.objects[name].data)[k]) for k, v in attrs.items())

    # Undo: Apply, then Ctrl+Z gives back the mesh and the Empty as they were.
    # bpy.ops called from a script push no undo step; the UI pushes one after an operator with
    # the UNDO option, as Apply has: the test pushes it the same way (ed.undo_push).
    from hybridedit_blender.ops import HYBRIDARAP_OT_apply

    assert "UNDO" in HYBRIDARAP_OT_apply.bl_options
    obj = bpy.data.objects[name]
    bpy.context.view_layer.objects.active = obj
    assert session_of(obj) is not None  # bound again on opening
    bpy.ops.ed.undo_push(message="opened")
    e = bpy.data.objects[empty_name]
    e.location.x += 0.3
    bpy.context.view_layer.update()
    live.finish()
    bpy.ops.ed.undo_push(message="moved")
    assert bpy.ops.hybrid_arap.apply() == {"FINISHED"}
    live.finish()
    bpy.ops.ed.undo_push(message="Apply")
    applied = positions(bpy.data.objects[name].data).copy()
    assert not np.array_equal(applied, posed)
    bpy.ops.ed.undo()
    live.finish()
    obj = bpy.data.objects[name]
    assert np.array_equal(positions(obj.data), posed)  # the base as it was before Apply
    # the pose key holds the pose of the moved Empty (the settled one, from the cache), which Blender
    # shows as the base plus the key's offset (float32 rounding of basis + (key - basis))
    assert np.array_equal(key_positions(obj), applied), np.abs(key_positions(obj) - applied).max()
    assert np.abs(evaluated(obj) - applied).max() <= 1e-7 * np.linalg.norm(np.ptp(posed, axis=0))
    # the session goes on from what undo restored: the Empty moved again deforms from there
    s = session_of(obj)
    e = bpy.data.objects[empty_name]
    frames = s.frames
    e.location.x += 0.1
    bpy.context.view_layer.update()
    live.finish()
    assert s.frames > frames and not np.array_equal(evaluated(obj), applied)
    assert np.array_equal(positions(obj.data), posed)


def _report_of(op, *args, **kw) -> str:
    """The one-line ERROR report of an operator (bpy.ops raises it as a RuntimeError)."""
    with pytest.raises(RuntimeError) as info:
        op(*args, **kw)
    text = str(info.value).strip()
    assert text.startswith("Error: Hybrid ARAP:") and "Traceback" not in text
    assert len(text.splitlines()) == 1, text
    return text


def test_problems_are_one_line_reports(scene, capfd):
    obj = icosphere(3)
    Z = positions(obj.data)[:, 2]
    # not bound yet
    assert "not bound" in _report_of(bpy.ops.hybrid_arap.apply)
    # no handle
    assert "add a handle group" in _report_of(bpy.ops.hybrid_arap.bind)
    empty = rig_up(obj, Z > 0.75, Z > -0.1)
    # an empty group
    vg = obj.vertex_groups[obj.hybrid_arap.roi_group]
    vg.remove(list(range(len(obj.data.vertices))))
    assert "is empty" in _report_of(bpy.ops.hybrid_arap.bind)
    # a group that is not there
    obj.hybrid_arap.roi_group = "Nope"
    assert "no vertex group 'Nope'" in _report_of(bpy.ops.hybrid_arap.bind)
    obj.hybrid_arap.roi_group = ""
    # a handle without its Empty
    obj.hybrid_arap.handles[0].empty = None
    assert "has no Empty" in _report_of(bpy.ops.hybrid_arap.bind)
    obj.hybrid_arap.handles[0].empty = empty
    assert bpy.ops.hybrid_arap.bind() == {"FINISHED"}  # no ROI: nothing fixed

    # the mesh changed since Bind (a vertex edited behind the add-on's back; then one more vertex)
    obj.data.shape_keys.reference_key.data[0].co.x += 0.5  # (the basis: what Edit Mode edits)
    assert "edited since Bind (1 vertices moved)" in _report_of(bpy.ops.hybrid_arap.apply)
    assert session_of(obj) is None and obj.hybrid_arap.problem
    assert bpy.ops.hybrid_arap.bind() == {"FINISHED"}
    obj.data.vertices.add(1)
    assert "changed since Bind" in _report_of(bpy.ops.hybrid_arap.reset)

    # found while following the Empty: said in the info log in one line, not as a traceback
    live.finish()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj = icosphere(3)
    Z = positions(obj.data)[:, 2]
    empty = rig_up(obj, Z > 0.75, Z > -0.1)
    assert bpy.ops.hybrid_arap.bind() == {"FINISHED"}
    obj.data.vertices.add(3)
    empty.location.z += 0.3
    capfd.readouterr()
    bpy.context.view_layer.update()
    assert live.LAST_PROBLEMS and session_of(obj) is None
    live._say()
    out = capfd.readouterr()
    assert "changed since Bind" in out.out + out.err and "Traceback" not in out.out + out.err


def test_non_manifold_mesh_binds_with_a_one_line_warning(scene, capfd):
    # a fin welded onto an edge: that edge has three faces
    import bmesh

    obj = icosphere(3)
    me = obj.data
    bm = bmesh.new()
    bm.from_mesh(me)
    bm.edges.ensure_lookup_table()
    e = bm.edges[0]
    v = bm.verts.new((e.verts[0].co + e.verts[1].co) * 0.75)
    bm.faces.new((e.verts[0], e.verts[1], v))
    bm.to_mesh(me)
    bm.free()
    Z = positions(me)[:, 2]
    rig_up(obj, Z > 0.75, Z > -0.1)
    capfd.readouterr()
    assert bpy.ops.hybrid_arap.bind() == {"FINISHED"}
    out = capfd.readouterr().out
    line = [ln for ln in out.splitlines() if "Hybrid ARAP: bound" in ln]
    assert line and "non-manifold" in line[0] and "Warning" in line[0], out


@pytest.mark.skipif(not ARMADILLO.is_file(), reason="../shared/meshes/armadillo43k.obj not present")
def test_armadillo_imported_by_blender_matches_api(scene):
    bpy.ops.wm.obj_import(filepath=str(ARMADILLO))
    obj = bpy.context.selected_objects[0]
    bpy.context.view_layer.objects.active = obj
    me = obj.data
    rest32 = positions(me).copy()
    X = rest32[:, 0]
    span = X.max() - X.min()
    Y = rest32[:, 1]  # up in the OBJ's frame (the importer turns the object, not the vertices)
    upper = Y > Y.min() + 0.55 * (Y.max() - Y.min())  # (the +X foot reaches as far out as the hand)
    handle_mask = (X > X.max() - 0.06 * span) & upper  # the +X hand
    roi_mask = (X > X.max() - 0.35 * span) & upper  # the +X arm
    empty = rig_up(obj, handle_mask, roi_mask)
    attrs = attribute_snapshot(me)
    assert bpy.ops.hybrid_arap.bind() == {"FINISHED"}
    s = session_of(obj)
    rest_world = S.matrix_np(empty.matrix_world)
    hr, rr = np.flatnonzero(handle_mask), np.flatnonzero(roi_mask)
    ref = reference_editor(rest32, S.read_triangles(me), rr, [hr], 0.05)
    loc0 = empty.location.copy()
    for k in range(1, 4):  # up and round, about the Empty
        empty.location = loc0 + Vector((0, 0.01 * k * span, 0.03 * k * span))
        empty.rotation_euler = Euler((0, math.radians(4 * k), math.radians(3 * k)))
        bpy.context.view_layer.update()
        T = local_T(obj, empty, rest_world)
        assert bpy.ops.hybrid_arap.settle() == {"FINISHED"}
        ref.drag(transforms={0: T})  # the live frame, then the settle's converge from it
        r = ref.converge(transforms={0: T})
        assert r.converged and s.settled
        check_pose(obj, s, r.vertices, rest32, rr, hr, T)
    assert all(np.array_equal(v, attribute_snapshot(me)[k]) for k, v in attrs.items())


def test_bind_job_cancels_and_reports_progress(scene):
    """The background bind's job (what the modal operator runs on a thread): progress, then cancel."""
    import threading

    from hybridedit_blender.bind import BindJob

    obj = icosphere(5)
    Z = positions(obj.data)[:, 2]
    rig_up(obj, Z > 0.75, Z > -0.1, cage_size=0.0731)  # a size not in the cache: a cold bind
    seen = []
    job = BindJob(obj)
    real = job._progress

    def spy(stage, fraction):
        seen.append(stage)
        if len(seen) == 3:
            job.cancel.set()
        real(stage, fraction)

    job._progress = spy
    t = threading.Thread(target=job.run)
    t.start()
    t.join(timeout=300)
    assert not t.is_alive()
    assert job.session is None and job.error == "cancelled"
    assert "Esc to cancel" in job.status()
    kind, line = job.install(bpy.context)
    assert kind == {"WARNING"} and "cancelled" in line and session_of(obj) is None
