"""Render blender/docs/hybrid_arap.png with Blender itself (Workbench, headless, bpy): the armadillo
at rest (left) and posed by the extension (right: Empty moved and turned, the +X arm raised; the
ROI shown in green, the handle in orange, fixed in grey, as vertex colours).

    blender/.venv-bpy/bin/python blender/render_figure.py [--out blender/docs/hybrid_arap.png]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--mesh", default=str(HERE.parents[1] / "shared" / "meshes" / "armadillo43k.obj"))
    ap.add_argument("--out", default=str(HERE / "docs" / "hybrid_arap.png"))
    args = ap.parse_args()
    import bpy
    from mathutils import Euler, Vector

    import hybridedit_blender as hb
    from hybridedit_blender import session as S

    hb.register()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if not hasattr(bpy.types.Object, "hybrid_arap"):
        hb.register()
    objs = []
    for k in range(2):
        bpy.ops.wm.obj_import(filepath=args.mesh)
        objs.append(bpy.context.selected_objects[0])
    rest, posed = objs
    bpy.context.view_layer.update()
    P = S.read_positions(posed.data).reshape(-1, 3)
    X = P[:, 0]
    span = X.max() - X.min()
    Y = P[:, 1]  # up, in the OBJ's own frame (the importer turns the object, not the vertices)
    upper = Y > Y.min() + 0.55 * (Y.max() - Y.min())  # (the +X foot reaches as far out as the hand)
    handle = (X > X.max() - 0.06 * span) & upper  # the +X hand
    roi = (X > X.max() - 0.35 * span) & upper  # the +X arm
    for ob in objs:  # roles as a colour attribute (the extension never touches it)
        col = ob.data.color_attributes.new("Role", "FLOAT_COLOR", "POINT")
        c = np.tile([0.62, 0.62, 0.62, 1.0], (len(P), 1))
        c[roi] = [0.35, 0.75, 0.35, 1.0]
        c[handle] = [0.95, 0.55, 0.15, 1.0]
        col.data.foreach_set("color", c.astype(np.float32).ravel())
    rest.location.x -= 0.55 * span
    posed.location.x += 0.55 * span
    bpy.context.view_layer.objects.active = posed
    bpy.context.view_layer.update()
    posed.data.vertices.foreach_set("select", handle)
    bpy.ops.hybrid_arap.add_handle()
    posed.data.vertices.foreach_set("select", roi)
    bpy.ops.hybrid_arap.roi_from_selection()
    bpy.ops.hybrid_arap.bind()
    empty = posed.hybrid_arap.handles[0].empty
    empty.location += Vector((-0.12 * span, 0.0, 0.30 * span))
    empty.rotation_euler = Euler((0.0, math.radians(-35), 0.0))
    bpy.context.view_layer.update()
    bpy.ops.hybrid_arap.settle()

    scene = bpy.context.scene
    scene.render.engine = "BLENDER_WORKBENCH"
    sh = scene.display.shading
    sh.light = "STUDIO"
    sh.color_type = "VERTEX"
    sh.show_cavity = True
    sh.show_shadows = False
    scene.render.resolution_x, scene.render.resolution_y = 800, 400
    scene.render.film_transparent = False
    scene.world = scene.world or bpy.data.worlds.new("World")
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGB"
    scene.render.image_settings.compression = 100
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    scene.camera = cam
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = 2.45 * span
    cam.location = (0.0, -4.0 * span, 0.05 * span)
    cam.rotation_euler = (math.radians(90), 0, 0)
    scene.render.filepath = args.out
    bpy.ops.render.render(write_still=True)
    print("wrote", args.out, os.path.getsize(args.out), "bytes")
    sys.stdout.flush()
    os._exit(0)


if __name__ == "__main__":
    sys.exit(main())
