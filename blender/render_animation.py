"""Render blender/docs/hybrid_arap_animation.png with Blender itself (Workbench, headless, bpy): the
armadillo's +X hand driven by a keyframed Empty (frame 1 at rest, frame 24 raised and turned),
rendered as an animation at frames 1, 12 and 24 (each frame's pose solved by the add-on's
frame_change_post handler as the render evaluates it), side by side.

    blender/.venv-bpy/bin/python blender/render_animation.py [--mesh PATH/armadillo43k.obj] [--out PNG]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))


def default_mesh() -> str:
    for root in (HERE.parents[1], HERE.parents[2]):
        p = root / "shared" / "meshes" / "armadillo43k.obj"
        if p.is_file():
            return str(p)
    return str(HERE.parents[1] / "shared" / "meshes" / "armadillo43k.obj")


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--mesh", default=default_mesh())
    ap.add_argument("--out", default=str(HERE / "docs" / "hybrid_arap_animation.png"))
    args = ap.parse_args()
    os.environ.setdefault("HYBRIDEDIT_BLENDER_CACHE", os.path.join(tempfile.gettempdir(), "hybridedit-blender-tests"))
    import bpy
    from mathutils import Euler, Vector

    import hybridedit_blender as hb
    from hybridedit_blender import session as S

    hb.register()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if not hasattr(bpy.types.Object, "hybrid_arap"):
        hb.register()
    bpy.ops.wm.obj_import(filepath=args.mesh)
    obj = bpy.context.selected_objects[0]
    bpy.context.view_layer.objects.active = obj
    bpy.context.view_layer.update()
    P = S.read_positions(obj.data).reshape(-1, 3)
    X, Y = P[:, 0], P[:, 1]  # Y is up in the OBJ's own frame (the importer turns the object)
    span = X.max() - X.min()
    upper = Y > Y.min() + 0.55 * (Y.max() - Y.min())
    handle = (X > X.max() - 0.06 * span) & upper
    roi = (X > X.max() - 0.35 * span) & upper
    col = obj.data.color_attributes.new("Role", "FLOAT_COLOR", "POINT")
    c = np.tile([0.62, 0.62, 0.62, 1.0], (len(P), 1))
    c[roi] = [0.35, 0.75, 0.35, 1.0]
    c[handle] = [0.95, 0.55, 0.15, 1.0]
    col.data.foreach_set("color", c.astype(np.float32).ravel())
    obj.data.vertices.foreach_set("select", handle)
    bpy.ops.hybrid_arap.add_handle()
    obj.data.vertices.foreach_set("select", roi)
    bpy.ops.hybrid_arap.roi_from_selection()
    assert bpy.ops.hybrid_arap.bind() == {"FINISHED"}
    empty = obj.hybrid_arap.handles[0].empty
    scene = bpy.context.scene
    scene.frame_set(1)
    empty.keyframe_insert("location", frame=1)
    empty.keyframe_insert("rotation_euler", frame=1)
    empty.location += Vector((-0.12 * span, 0.0, 0.30 * span))
    empty.rotation_euler = Euler((0.0, math.radians(-35), 0.0))
    empty.keyframe_insert("location", frame=24)
    empty.keyframe_insert("rotation_euler", frame=24)
    scene.frame_set(1)

    scene.render.engine = "BLENDER_WORKBENCH"
    sh = scene.display.shading
    sh.light, sh.color_type, sh.show_cavity, sh.show_shadows = "STUDIO", "VERTEX", True, False
    scene.render.resolution_x, scene.render.resolution_y = 360, 400
    scene.world = scene.world or bpy.data.worlds.new("World")
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGB"
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    scene.camera = cam
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = 1.25 * span
    centre = obj.matrix_world @ Vector(P.mean(axis=0).tolist())
    cam.location = (centre.x, centre.y - 4.0 * span, centre.z + 0.05 * span)
    cam.rotation_euler = (math.radians(90), 0, 0)
    tmp = tempfile.mkdtemp(prefix="hybridedit-anim-")
    scene.render.filepath = os.path.join(tmp, "f")
    panels = []
    for f in (1, 12, 24):
        scene.frame_start = scene.frame_end = f
        bpy.ops.render.render(animation=True)
        img = bpy.data.images.load(os.path.join(tmp, f"f{f:04d}.png"))
        w, h = img.size
        panels.append(np.array(img.pixels[:], dtype=np.float32).reshape(h, w, 4))
        bpy.data.images.remove(img)
    strip = np.concatenate(panels, axis=1)
    out = bpy.data.images.new("strip", strip.shape[1], strip.shape[0], alpha=False)
    out.pixels.foreach_set(strip.ravel())
    out.filepath_raw = args.out
    out.file_format = "PNG"
    out.save()
    print("wrote", args.out, os.path.getsize(args.out), "bytes")
    sys.stdout.flush()
    os._exit(0)


if __name__ == "__main__":
    sys.exit(main())
