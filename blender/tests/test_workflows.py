"""Blender's own workflows around a posed mesh, in Blender itself (bpy): shape keys, animation and
renders, save and reopen, rename and duplicate, undo after a settle, Edit Mode, non-uniform scale,
several selected meshes. Each test prints its figure (run with -s to see them)."""

from __future__ import annotations

import math

import bmesh
import bpy
import numpy as np
from mathutils import Vector
from test_blender import evaluated, icosphere, key_positions, positions, rig_cap, rig_up, world

import hybridedit_blender
from hybridedit_blender import live
from hybridedit_blender import session as S
from hybridedit_blender.bind import session_of


def diag_of(P) -> float:
    return float(np.linalg.norm(np.ptp(np.asarray(P, dtype=np.float64), axis=0)))


def handle_target(obj, empty, rest_world, P_local, rows) -> np.ndarray:
    """Where the handle rows must be in the object's local space: the Empty's world motion since
    rest applied to their world positions (written out here, independently of the add-on)."""
    O = S.matrix_np(obj.matrix_world)
    W = world(obj, P_local[rows])
    M = S.matrix_np(empty.matrix_world) @ np.linalg.inv(rest_world)
    W2 = W @ M[:3, :3].T + M[:3, 3]
    return (W2 - O[:3, 3]) @ np.linalg.inv(O[:3, :3]).T


def test_shape_key_mesh_shows_pose_and_keeps_its_base(scene):
    obj = icosphere(3)
    me = obj.data
    rest = positions(me).copy()
    obj.shape_key_add(name="Basis", from_mix=False)
    bulge = obj.shape_key_add(name="Bulge", from_mix=False)
    B = rest * np.where(rest[:, :1] > 0, 1.15, 1.0).astype(np.float32)
    S.write_key(bulge, B.ravel())
    bulge.value = 0.5
    mix = evaluated(obj).copy()  # what Blender shows before Bind: the mix
    assert np.abs(mix - rest).max() > 0.05
    Z = rest[:, 2]
    handle, roi = Z > 0.75, Z > -0.1
    empty = rig_up(obj, handle, roi)
    rest_world = S.matrix_np(empty.matrix_world)
    assert bpy.ops.hybrid_arap.bind() == {"FINISHED"}
    s = session_of(obj)
    assert np.array_equal(s.base.rest32.reshape(-1, 3), mix)  # the rest is Blender's own mix
    empty.location += Vector((0.1, 0.2, 0.3))
    empty.rotation_euler.x = math.radians(20)
    bpy.context.view_layer.update()
    assert bpy.ops.hybrid_arap.settle() == {"FINISHED"}
    ev = evaluated(obj).copy()
    d = diag_of(mix)
    fixed = ~(handle | roi)
    assert np.array_equal(ev[fixed], mix[fixed])  # bit for bit
    h_err = np.abs(ev[handle] - handle_target(obj, empty, rest_world, mix, handle)).max() / d
    assert h_err <= 1e-7
    shown = np.abs(ev - mix).max()
    assert shown > 0.1 * d
    # the base never changes: the mesh, the basis and the other key
    base_change = float(np.abs(positions(me) - rest).max())
    assert np.array_equal(positions(me), rest)
    assert np.array_equal(S.read_key(me.shape_keys.reference_key, len(rest)).reshape(-1, 3), rest)
    assert np.array_equal(S.read_key(bulge, len(rest)).reshape(-1, 3), B) and bulge.value == 0.5
    # Tab into Edit Mode and out: the pose stays
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.object.mode_set(mode="OBJECT")
    assert np.array_equal(evaluated(obj), ev)
    # Apply: the base takes the pose, what Blender shows stays, the other key keeps its offset
    offset = B - rest
    assert bpy.ops.hybrid_arap.apply() == {"FINISHED"}
    live.finish()
    after = evaluated(obj)
    a_err = np.abs(after - ev).max() / d
    assert a_err <= 1e-7
    base = positions(me)
    assert np.abs(base - rest).max() > 0.1 * d
    assert np.allclose(S.read_key(bulge, len(rest)).reshape(-1, 3) - base, offset, rtol=0, atol=1e-6)
    assert np.array_equal(key_positions(obj), S.read_key(me.shape_keys.reference_key, len(rest)).reshape(-1, 3))
    print(f"\nFIGURE shape keys: pose shown {shown / d:.3f} of the diagonal, handle error {h_err:.1e}, fixed rows "
          f"bit-exact, base coordinates changed {base_change} while posed, after Apply {a_err:.1e}")


def test_the_pose_under_other_modifiers(scene):
    """The pose key comes first in the stack: a Subdivision modifier after it works on the posed mesh,
    as it would on a mesh whose own coordinates were the pose."""
    obj = icosphere(2)
    rest, handle, roi, empty = rig_cap(obj)
    obj.modifiers.new("Subdivision", "SUBSURF").levels = 1
    unposed = evaluated(obj).copy()
    assert len(unposed) > len(rest)
    assert bpy.ops.hybrid_arap.bind() == {"FINISHED"}
    empty.location += Vector((0.1, 0.2, 0.3))
    empty.rotation_euler.x = math.radians(25)
    bpy.context.view_layer.update()
    assert bpy.ops.hybrid_arap.settle() == {"FINISHED"}
    shown = evaluated(obj).copy()
    d = diag_of(unposed)
    # the reference: a copy whose own coordinates are the pose, no shape keys, the same modifier
    ref = obj.copy()
    ref.data = obj.data.copy()
    ref.shape_key_clear()
    ref.data.vertices.foreach_set("co", key_positions(obj).ravel())
    ref.data.update()
    bpy.context.scene.collection.objects.link(ref)
    bpy.context.view_layer.update()
    err = np.abs(shown - evaluated(ref)).max() / d
    assert err <= 1e-6
    moved = np.abs(shown - unposed).max() / d
    assert moved > 0.05
    assert np.array_equal(positions(obj.data), rest)
    print(f"\nFIGURE modifiers: a Subdivision modifier shows the pose ({len(shown)} evaluated vertices moved up to "
          f"{moved:.3f} of the diagonal), = the same modifier on the posed coordinates to {err:.1e}")


def test_a_constrained_and_driven_empty_drives_the_pose_on_frame_change(scene):
    """The Empty's location from a Copy Location constraint on an animated target, its rotation from a
    driver on the frame: each frame poses the mesh, the same whichever frame came before."""
    obj = icosphere(3)
    rest, handle, roi, empty = rig_cap(obj)
    rest_world = S.matrix_np(empty.matrix_world)
    assert bpy.ops.hybrid_arap.bind() == {"FINISHED"}
    s = session_of(obj)
    scene.frame_start, scene.frame_end = 1, 20
    scene.frame_set(1)
    target = bpy.data.objects.new("Target", None)
    scene.collection.objects.link(target)
    target.keyframe_insert("location", frame=1)
    target.location = (0.0, 0.3, 0.4)
    target.keyframe_insert("location", frame=20)
    c = empty.constraints.new("COPY_LOCATION")
    c.target, c.use_offset = target, True
    drv = empty.driver_add("rotation_euler", 0).driver
    drv.type, drv.expression = "SCRIPTED", "(frame - 1) * 0.03"  # a simple expression: no Python needed
    scene.frame_set(1)
    d = diag_of(rest)
    assert np.abs(evaluated(obj) - rest).max() <= 1e-6 * d
    scene.frame_set(10)
    direct = evaluated(obj).copy()
    assert abs(empty.matrix_world.to_euler().x - 0.27) < 1e-5  # the driver ran
    h_err = np.abs(direct[handle] - handle_target(obj, empty, rest_world, rest, handle)).max() / d
    moved = np.abs(direct - rest).max() / d
    assert h_err <= 1e-7 and moved > 0.05
    s.cache.clear()
    scene.frame_set(20)
    scene.frame_set(10)
    assert np.array_equal(evaluated(obj), direct)
    print(f"\nFIGURE constraint and driver: frame 10 moved {moved:.3f} of the diagonal, handle error {h_err:.1e}, "
          "the same bit for bit from frame 20")


def _animated_empty(scene, empty):
    scene.frame_start, scene.frame_end = 1, 20
    scene.frame_set(1)
    empty.keyframe_insert("location", frame=1)
    empty.keyframe_insert("rotation_euler", frame=1)
    empty.location += Vector((0.0, 0.3, 0.4))
    empty.rotation_euler.x = math.radians(35)
    empty.keyframe_insert("location", frame=20)
    empty.keyframe_insert("rotation_euler", frame=20)


def _render(scene, frame: int, path: str) -> np.ndarray:
    """A Workbench render of one frame (as an animation render of that frame alone: Blender
    evaluates the frame for the render), read back as pixels."""
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.render.resolution_x = scene.render.resolution_y = 64
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = path
    keep = scene.frame_start, scene.frame_end
    scene.frame_start = scene.frame_end = frame
    bpy.ops.render.render(animation=True)
    scene.frame_start, scene.frame_end = keep
    img = bpy.data.images.load(path + f"{frame:04d}.png")
    px = np.array(img.pixels[:], dtype=np.float32)
    bpy.data.images.remove(img)
    return px


def test_keyframed_empty_is_deterministic_and_a_baked_animation_plays_without_the_addon(scene, tmp_path):
    obj = icosphere(3)
    rest, handle, roi, empty = rig_cap(obj)
    rest_world = S.matrix_np(empty.matrix_world)
    assert bpy.ops.hybrid_arap.bind() == {"FINISHED"}
    s = session_of(obj)
    _animated_empty(scene, empty)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    scene.camera = cam
    cam.location = (0, -6, 0.5)
    cam.rotation_euler = (math.radians(90), 0, 0)

    scene.frame_set(10)  # directly
    direct = evaluated(obj).copy()
    d = diag_of(rest)
    assert s.settled
    h_err = np.abs(direct[handle] - handle_target(obj, empty, rest_world, rest, handle)).max() / d
    assert h_err <= 1e-7 and np.abs(direct - rest).max() > 0.05 * d
    s.cache.clear()  # solved again, not read back
    scene.frame_set(20)
    f20 = evaluated(obj).copy()
    scene.frame_set(10)  # from frame 20
    again = evaluated(obj).copy()
    assert np.array_equal(again, direct)
    assert np.abs(f20 - direct).max() > 0.05 * d
    scene.frame_set(1)
    assert np.abs(evaluated(obj) - rest).max() <= 1e-6 * d
    # a render evaluates its frame: the viewport at frame 20, frame 10 rendered
    scene.frame_set(20)
    live_px = _render(scene, 10, str(tmp_path / "live_"))
    px20 = _render(scene, 20, str(tmp_path / "live_"))
    assert np.abs(live_px - px20).max() > 0.1  # (the two poses look different)

    assert bpy.ops.hybrid_arap.bake_animation(frame_start=1, frame_end=20) == {"FINISHED"}
    keys = [kb.name for kb in obj.data.shape_keys.key_blocks if kb.name.startswith(S.KEY + " ")]
    hybridedit_blender.unregister()  # the add-on disabled: its handlers are gone
    try:
        assert live.on_frame_change not in bpy.app.handlers.frame_change_post
        scene.frame_set(10)
        b10 = evaluated(obj).copy()
        scene.frame_set(20)
        b20 = evaluated(obj).copy()
        b_err = max(np.abs(b10 - direct).max(), np.abs(b20 - f20).max()) / d
        assert b_err <= 1e-7
        scene.frame_set(20)
        baked_px = _render(scene, 10, str(tmp_path / "baked_"))
        assert np.array_equal(baked_px, live_px)
    finally:
        hybridedit_blender.register()
    print(f"\nFIGURE animation: frame 10 from 20 = directly, bit for bit; handle error {h_err:.1e}; "
          f"baked into {len(keys)} keys, played without the add-on within {b_err:.1e} of the diagonal; "
          "the render of frame 10 baked = live, pixel for pixel")


def test_save_reopen_rename_duplicate_and_the_original_rest(scene, tmp_path):
    obj = icosphere(3)
    name = obj.name
    rest, handle, roi, empty = rig_cap(obj)
    empty_name = empty.name
    assert bpy.ops.hybrid_arap.bind() == {"FINISHED"}
    empty.location.z += 0.4
    bpy.context.view_layer.update()
    live.finish()
    posed = evaluated(obj).copy()
    path = str(tmp_path / "bound.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    live.finish()  # bound again in the background on opening
    obj = bpy.data.objects[name]
    s = session_of(obj)
    assert s is not None and np.array_equal(evaluated(obj), posed)
    assert np.array_equal(s.base.rest32.reshape(-1, 3), rest)  # the original rest, not the pose
    assert np.array_equal(positions(obj.data), rest)  # the base as it was
    # the Empty moved right after reopening (no Bind by hand): the mesh follows
    e = bpy.data.objects[empty_name]
    rest_world = S.matrix_np(obj.hybrid_arap.handles[0].rest)
    e.location.x += 0.15
    bpy.context.view_layer.update()
    live.finish()
    reopened = evaluated(obj).copy()
    r_err = np.abs(reopened[handle] - handle_target(obj, e, rest_world, rest, handle)).max() / diag_of(rest)
    assert r_err <= 1e-7 and np.abs(reopened - posed).max() > 0.1
    # Bind again after reopening: still the original rest, the pose as it was
    bpy.context.view_layer.objects.active = obj
    assert bpy.ops.hybrid_arap.bind() == {"FINISHED"}
    live.finish()
    s = session_of(obj)
    assert np.array_equal(s.base.rest32.reshape(-1, 3), rest)
    assert np.abs(evaluated(obj) - reopened).max() <= 1e-6 * diag_of(rest)
    posed = reopened
    # renamed: the Empty still drives it
    obj.name = "Renamed"
    e.location.y += 0.2
    bpy.context.view_layer.update()
    live.finish()
    ev = evaluated(obj)
    assert session_of(obj) is s and s.object_name == "Renamed"
    h_err = np.abs(ev[handle] - handle_target(obj, e, rest_world, rest, handle)).max() / diag_of(rest)
    assert h_err <= 1e-7 and np.abs(ev - posed).max() > 0.1
    # a copy is told it is not bound; the original goes on
    live.LAST_PROBLEMS.clear()
    copy = obj.copy()
    copy.data = obj.data.copy()
    bpy.context.scene.collection.objects.link(copy)
    bpy.context.view_layer.update()
    e.location.y += 0.1
    bpy.context.view_layer.update()
    assert session_of(copy) is None and copy.hybrid_arap.uid == "" and "is a copy" in copy.hybrid_arap.problem
    assert any("is a copy" in m for _, m in live.LAST_PROBLEMS)
    assert session_of(obj) is s
    # Reset: the original rest, bit for bit
    bpy.context.view_layer.objects.active = obj
    live.finish()
    assert bpy.ops.hybrid_arap.reset() == {"FINISHED"}
    assert np.array_equal(evaluated(obj), rest) and np.array_equal(positions(obj.data), rest)
    print(f"\nFIGURE save and reopen: the pose shown as saved (bit for bit), base unchanged; the Empty moved "
          f"after reopening: followed (handle error {r_err:.1e}); rest kept after Bind again, renamed object "
          f"follows (handle error {h_err:.1e}), Reset = original rest bit for bit")


def test_undo_after_the_settle_gives_the_settled_pose(scene):
    obj = icosphere(4)
    name = obj.name
    rest = positions(obj.data).copy()
    Z = rest[:, 2]
    empty = rig_up(obj, Z > 0.75, Z > -0.1)
    assert bpy.ops.hybrid_arap.bind() == {"FINISHED"}
    s = session_of(obj)
    bpy.ops.ed.undo_push(message="bound")
    empty.location += Vector((0.0, 0.5, 0.5))
    empty.rotation_euler.x = math.radians(40)
    bpy.context.view_layer.update()  # one live frame written; the worker settles on
    bpy.ops.ed.undo_push(message="moved")  # the undo step holds the first live frame
    first = key_positions(obj).copy()
    live.finish()
    settled = key_positions(obj).copy()
    gap = np.abs(first - settled).max() / diag_of(rest)
    assert gap > 1e-3
    bpy.ops.object.empty_add(location=(5, 5, 5))  # another action
    bpy.ops.ed.undo_push(message="another")
    bpy.ops.ed.undo()
    live.finish()
    obj = bpy.data.objects[name]
    assert np.array_equal(key_positions(obj), settled)
    assert s.settled
    # and the next edit starts from the settled pose
    frames = s.frames
    obj.hybrid_arap.handles[0].empty.location.x += 0.05
    bpy.context.view_layer.update()
    live.finish()
    assert s.frames > frames
    print(f"\nFIGURE undo: the undone step held a live frame {gap:.3f} of the diagonal from the settled pose; "
          "after Ctrl+Z the key is the settled pose bit for bit")


def test_edit_mode_changes_are_never_lost(scene):
    obj = icosphere(4)
    me = obj.data
    rest, handle, roi, empty = rig_cap(obj, roi_z=-0.3)
    assert bpy.ops.hybrid_arap.bind() == {"FINISHED"}
    empty.location.z += 0.3
    bpy.context.view_layer.update()
    live.finish()
    posed = key_positions(obj).copy()
    # an Empty moved in Edit Mode: nothing is written (Blender would throw it away); the pose follows on leaving
    live.LAST_PROBLEMS.clear()
    bpy.ops.object.mode_set(mode="EDIT")
    empty.location.x += 0.1
    bpy.context.view_layer.update()
    assert any("Edit Mode" in m for _, m in live.LAST_PROBLEMS)
    bpy.ops.object.mode_set(mode="OBJECT")
    bpy.context.view_layer.update()
    live.finish()
    assert session_of(obj) is not None and not np.array_equal(key_positions(obj), posed)
    shown = evaluated(obj).copy()
    # 300 ROI vertices moved in Edit Mode, the Empty moved too before leaving it
    region = np.flatnonzero(roi & ~handle)[:300]
    assert len(region) == 300
    bpy.ops.object.mode_set(mode="EDIT")
    bm = bmesh.from_edit_mesh(me)
    bm.verts.ensure_lookup_table()
    for i in region:
        bm.verts[int(i)].co.z += 0.05
    bmesh.update_edit_mesh(me)
    empty.location.x += 0.1
    bpy.context.view_layer.update()
    live.LAST_PROBLEMS.clear()
    bpy.ops.object.mode_set(mode="OBJECT")
    bpy.context.view_layer.update()
    live.finish()
    basis = S.read_key(me.shape_keys.reference_key, len(rest)).reshape(-1, 3)
    moved_rows = np.flatnonzero(np.any(basis != rest, axis=1))
    assert np.array_equal(moved_rows, region)  # the edit is in the mesh
    now = evaluated(obj)
    assert np.allclose(now[region, 2] - shown[region, 2], 0.05, atol=1e-5)  # and shown, on top of the pose
    msgs = [m for _, m in live.LAST_PROBLEMS]
    assert any("300 vertices moved" in m and "the edit is kept" in m for m in msgs), msgs
    assert session_of(obj) is None
    # the Empty moved again: nothing overwrites the edit
    empty.location.x += 0.1
    bpy.context.view_layer.update()
    assert np.array_equal(evaluated(obj), now)
    # Bind again: the edited mesh is the new rest, and the pose follows the Empty again
    assert bpy.ops.hybrid_arap.bind() == {"FINISHED"}
    live.finish()
    s = session_of(obj)
    assert np.array_equal(s.base.rest32.reshape(-1, 3)[region], basis[region])
    after = evaluated(obj)
    assert np.abs(after[region] - basis[region]).max() > 0.05  # posed again, from the edited rest
    print("\nFIGURE Edit Mode: an Empty moved in Edit Mode is followed on leaving it; 300 vertices moved in "
          "Edit Mode: all 300 found, kept in the mesh and shown, the pose stopped with a message, never overwritten")


def test_non_uniform_scale_equals_the_applied_scale_result(scene):
    a = icosphere(3)
    a.scale = (2.0, 0.5, 1.3)
    a.rotation_euler = (math.radians(15), 0.0, math.radians(30))
    bpy.context.view_layer.update()
    b = a.copy()
    b.data = a.data.copy()
    bpy.context.scene.collection.objects.link(b)
    for o in bpy.context.view_layer.objects:
        o.select_set(o is b)
    bpy.context.view_layer.objects.active = b
    bpy.ops.object.transform_apply(location=False, rotation=False, scale=True)
    local = positions(a.data).copy()
    Z = local[:, 2]
    handle, roi = Z > 0.75, Z > -0.1
    empties = []
    for o in (a, b):
        for x in bpy.context.view_layer.objects:
            x.select_set(x is o)
        bpy.context.view_layer.objects.active = o
        empties.append(rig_up(o, handle, roi))
        assert bpy.ops.hybrid_arap.bind() == {"FINISHED"}
    assert session_of(a).stretch is not None and session_of(b).stretch is None
    Wa0, Wb0 = world(a, evaluated(a)), world(b, evaluated(b))
    d = diag_of(Wa0)
    assert np.abs(Wa0 - Wb0).max() <= 1e-6 * d  # the same shape in the world
    for e in empties:
        e.location += Vector((0.3, 0.2, 0.5))
        e.rotation_euler = (math.radians(25), math.radians(-10), 0.0)
    bpy.context.view_layer.update()
    live.finish()
    Wa, Wb = world(a, evaluated(a)), world(b, evaluated(b))
    err = np.abs(Wa - Wb).max() / d
    assert np.abs(Wa - Wa0).max() > 0.1 * d
    assert err <= 1e-5
    print(f"\nFIGURE non-uniform scale (2, 0.5, 1.3): world pose - applied-scale world pose = {err:.1e} of the diagonal")


def test_bind_binds_every_selected_mesh(scene):
    objs = []
    for x in (-3.0, 3.0):
        o = icosphere(3)
        o.location.x = x
        Z = positions(o.data)[:, 2]
        rig_up(o, Z > 0.75, Z > -0.1)
        objs.append(o)
    for o in objs:
        o.select_set(True)
    assert bpy.ops.hybrid_arap.bind() == {"FINISHED"}
    assert all(session_of(o) is not None for o in objs)
    assert len({session_of(o).uid for o in objs}) == 2


def test_a_settle_stopped_at_its_cap_is_said_and_not_called_converged(scene, capfd):
    """The settle converges on the cage alone to the tolerance; one that reaches its iteration cap
    keeps its pose, says so in one line, and is not cached as converged (a solve tries again)."""
    obj = icosphere(4)
    rest = positions(obj.data).copy()
    Z = rest[:, 2]
    empty = rig_up(obj, Z > 0.75, Z > -0.1)
    assert bpy.ops.hybrid_arap.bind() == {"FINISHED"}
    s = session_of(obj)
    empty.location += Vector((0.0, 0.4, 0.3))
    empty.rotation_euler.x = math.radians(30)
    bpy.context.view_layer.update()
    live.finish()
    full = s.iterations
    assert s.settled and 0 < s.last_distance <= 1e-6 and len(s.cache) == 1
    s.cache.clear()
    s.max_iterations = 3
    empty.location.z += 0.05
    bpy.context.view_layer.update()
    capfd.readouterr()
    live.finish()
    live._say()
    out = capfd.readouterr()
    said = out.out + out.err
    assert s.iterations == 3 and s.last_distance > 1e-6 and len(s.cache) == 0
    assert "from converged after 3 iterations (at most 3" in said and "Traceback" not in said
    moved = np.abs(key_positions(obj) - rest).max() / diag_of(rest)
    assert moved > 0.05  # the pose there is kept
    print(f"\nFIGURE settle: converged in {full} of the cage's iterations to {1e-6:g} of the diagonal; "
          f"capped at 3: said, {s.last_distance:.1e} from converged, not cached")
