"""Timings of the extension in Blender itself (bpy, headless): Bind cold and from the cache, a live
frame split into the engine's frame (HybridEditor.drag + the moving rows into the float32 buffer),
the edit check (every basis and pose-key position compared), the pose key's foreach_set and
Mesh.update; then, after the Empty stops, the settle on the worker thread (wall time from the last
move to converged, while the main thread is free), Apply (main thread) and the worker's
preparation of the next pose after it, and one animation frame solved from the base pose.
Blender's own redraw is not part of it (no window).

    blender/.venv-bpy/bin/python blender/bench_live.py [--sizes 100000 1000000] [--mesh PATH.obj ...] [--frames 20]

Meshes: a bumpy UV sphere made by Blender's operator (about the size asked); handle = the top 5%
along Z, ROI = the top 30%. --mesh adds OBJ files imported with Blender's importer (e.g. the
armadillo Loop-subdivided); handle = its +X hand, ROI = that arm (the README figure's rule). The
Empty is moved and turned a little each frame (moves in proportion to the mesh's size).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=int, nargs="*", default=[100_000, 1_000_000])
    ap.add_argument("--mesh", nargs="*", default=[], help="OBJ files, imported with Blender's importer")
    ap.add_argument("--frames", type=int, default=20)
    args = ap.parse_args()
    cache = tempfile.mkdtemp(prefix="hybridedit-bench-")
    numba_dir = os.environ.get("NUMBA_CACHE_DIR") or os.path.join(tempfile.gettempdir(), "hybridedit-blender-tests", "numba")
    os.environ["NUMBA_CACHE_DIR"] = numba_dir  # compiled kernels kept (as the tests keep them)
    os.environ["HYBRIDEDIT_BLENDER_CACHE"] = cache  # bindings: a fresh folder, so the first bind is cold
    import bpy

    import hybridedit_blender as hb
    from hybridedit_blender import live
    from hybridedit_blender import session as S
    from hybridedit_blender.bind import session_of

    hb.register()
    rows = []
    for n in [*args.sizes, *args.mesh]:
        bpy.ops.wm.read_factory_settings(use_empty=True)
        if not hasattr(bpy.types.Object, "hybrid_arap"):
            hb.register()
        if isinstance(n, int):
            seg = int(round(math.sqrt(n)))
            bpy.ops.mesh.primitive_uv_sphere_add(segments=seg, ring_count=max(3, (n - 2) // seg + 1))
            obj = bpy.context.object
            me = obj.data
            P = S.read_positions(me).reshape(-1, 3)
            P *= (1 + 0.05 * np.sin(9 * P[:, :1]) * np.sin(7 * P[:, 1:2]))  # bumps: not a perfect sphere
            me.vertices.foreach_set("co", P.ravel())
            me.update()
            z = P[:, 2]
            handle, roi = z > np.quantile(z, 0.95), z > np.quantile(z, 0.70)
            name = "UV sphere"
        else:
            t0 = time.perf_counter()
            bpy.ops.wm.obj_import(filepath=n)
            print(f"imported {Path(n).name} in {time.perf_counter() - t0:.1f} s", flush=True)
            obj = bpy.context.selected_objects[0]
            bpy.context.view_layer.objects.active = obj
            me = obj.data
            P = S.read_positions(me).reshape(-1, 3)
            X, Y = P[:, 0], P[:, 1]  # Y is up in the OBJ's own frame (the importer turns the object)
            span = X.max() - X.min()
            upper = Y > Y.min() + 0.55 * (Y.max() - Y.min())
            handle = (X > X.max() - 0.06 * span) & upper
            roi = (X > X.max() - 0.35 * span) & upper
            name = Path(n).stem
        unit = float(np.linalg.norm(np.ptp(P, axis=0))) / (2 * math.sqrt(3))  # 1 for the unit sphere
        me.vertices.foreach_set("select", handle)
        bpy.ops.hybrid_arap.add_handle()
        me.vertices.foreach_set("select", roi)
        bpy.ops.hybrid_arap.roi_from_selection()
        t0 = time.perf_counter()
        bpy.ops.hybrid_arap.bind()
        cold = time.perf_counter() - t0
        t0 = time.perf_counter()
        bpy.ops.hybrid_arap.bind()
        cached = time.perf_counter() - t0
        s = session_of(obj)
        assert s.cache_hit
        empty = obj.hybrid_arap.handles[0].empty
        loc0 = empty.location.copy()
        eng, drag, fset, whole, check = [], [], [], [], []
        edited = s.edited
        timed = {}

        def timed_edited(o):
            t = time.perf_counter()
            r = edited(o)
            timed["check"] = (time.perf_counter() - t) * 1e3
            return r

        s.edited = timed_edited
        for k in range(1, args.frames + 1):
            empty.location.z = loc0.z + 0.01 * k * unit
            empty.rotation_euler.x = math.radians(0.5 * k)
            t0 = time.perf_counter()
            bpy.context.view_layer.update()
            whole.append((time.perf_counter() - t0) * 1e3)
            eng.append(s.last_engine_ms)
            drag.append(s.editor.frame_breakdown["total_seconds"] * 1e3)
            fset.append(s.last_write_ms)
            check.append(timed.get("check", 0.0))
        # the Empty stops: the worker settles (the main thread is free meanwhile)
        t0 = time.perf_counter()
        live.finish(s)
        settle = time.perf_counter() - t0
        settle_its = s.iterations
        # a big move, released at once: the worker settles it
        empty.location.z = loc0.z + 0.3 * unit
        empty.rotation_euler.x = math.radians(30)
        bpy.context.view_layer.update()
        t0 = time.perf_counter()
        live.finish(s)
        big_settle = time.perf_counter() - t0
        big_its = s.iterations
        t0 = time.perf_counter()
        assert bpy.ops.hybrid_arap.apply() == {"FINISHED"}
        apply_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        live.finish(s)
        prepare = time.perf_counter() - t0
        # one animation frame: solved from the base pose to converged (the same whatever came before)
        scene = bpy.context.scene
        empty.keyframe_insert("location", frame=1)
        empty.location.z += 0.05 * unit
        empty.keyframe_insert("location", frame=2)
        t0 = time.perf_counter()
        scene.frame_set(2)
        anim = time.perf_counter() - t0
        anim_its = s.iterations
        t0 = time.perf_counter()
        scene.frame_set(1)
        scene.frame_set(2)
        anim_cached = time.perf_counter() - t0
        med = lambda a: f"{np.median(a[2:]):.1f} ({min(a[2:]):.1f}-{max(a[2:]):.1f})"  # noqa: E731 (first frames warm up)
        rows.append((name, f"{len(me.vertices):,}", f"{len(s.moving):,}", f"{s.editor.cage.n_vertices:,}", f"{cold:.1f} s",
                     f"{cached:.2f} s", med(eng), med(drag), med(check), med(fset),
                     f"{np.median(np.add(np.add(eng, fset), check)[2:]):.1f}", med(whole),
                     f"{settle:.1f} s ({settle_its})", f"{big_settle:.1f} s ({big_its})", f"{apply_s:.2f} s",
                     f"{prepare:.1f} s", f"{anim:.1f} s ({anim_its})", f"{anim_cached:.2f} s"))
        live.unregister()
        live.register()
    head = ("mesh", "vertices", "moving rows", "cage", "Bind (cold)", "Bind (cached)", "engine frame ms",
            "of which HybridEditor.drag ms", "edit check ms", "pose key write ms", "frame total ms",
            "whole depsgraph update ms", "settle after the drag (cage iterations)", "settle after a big move (cage iterations)",
            "Apply", "next pose ready after Apply", "animation frame solved (cage iterations)", "same frame again (cache)")
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for r in rows:
        print("| " + " | ".join(r) + " |")
    sys.stdout.flush()
    os._exit(0)  # (bpy 4.2 may crash in the interpreter's teardown)


if __name__ == "__main__":
    sys.exit(main())
