"""A fresh install in a process of its own (run by test_kernels.py): the extension enabled with an
empty kernel cache and user folder, a mesh bound at once (the Bind waits for the background
compile, its progress read on the way, unless the zip's portable kernels serve), then a live
frame, the settle, Apply and an animation frame, every numba compile in this process counted,
then the end of the background compile. Writes one JSON file.

    python fresh_install.py OUT.json [ZIP]   # ZIP: installed by Blender's extension installer
"""

from __future__ import annotations

import json
import math
import os
import sys
import tempfile
import threading
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def main() -> None:
    out_path, zip_path = sys.argv[1], (sys.argv[2] if len(sys.argv) > 2 else None)
    if zip_path:
        os.environ["BLENDER_USER_RESOURCES"] = tempfile.mkdtemp(prefix="hybridedit-user-")
    else:
        sys.path.insert(0, str(HERE.parent))
    import bpy
    import numpy as np
    from numba.core import event  # (numba itself, not hybridedit: to count its compiles from the start)

    class Count(event.Listener):
        n = 0

        def on_start(self, ev):
            pass

        def on_end(self, ev):
            Count.n += 1

    listener = Count()
    event.register("numba:compile", listener)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    t_enable = time.monotonic()
    if zip_path:
        r = bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default", enable_on_install=True)
        assert r == {"FINISHED"}
        pkg = sys.modules["bl_ext.user_default.hybridedit_blender"]
    else:
        import hybridedit_blender as pkg

        pkg.register()
    import importlib

    kernels = importlib.import_module(pkg.__name__ + ".kernels")
    bind = importlib.import_module(pkg.__name__ + ".bind")
    portable = importlib.import_module(pkg.__name__ + ".portable_kernels")
    res = {"compiling_at_enable": kernels.running() is not None, "ready_at_enable": kernels.native_ready(),
           "portable": portable.IN_USE is not None}
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=5)
    obj = bpy.context.object
    me = obj.data
    P = np.empty(len(me.vertices) * 3, np.float32)
    me.attributes["position"].data.foreach_get("vector", P)
    Z = P.reshape(-1, 3)[:, 2]
    me.vertices.foreach_set("select", Z > 0.75)
    bpy.ops.hybrid_arap.add_handle()
    me.vertices.foreach_set("select", Z > -0.1)
    bpy.ops.hybrid_arap.roi_from_selection()
    # the modal Bind's job, on its thread, right away: it waits for the compile, with its progress
    job = bind.BindJob(obj)
    seen = []
    t = threading.Thread(target=job.run)
    t.start()
    while t.is_alive():
        seen.append((job.stage, job.fraction, job.status()))
        t.join(0.05)
    kind, line = job.install(bpy.context)
    waits = [x for x in seen if x[0].startswith("waiting for the engine's kernels")]
    res.update(bind_report=line, bind_kind=sorted(kind), waited_polls=len(waits),
               wait_fractions=sorted({round(f, 2) for _, f, _ in waits}),
               wait_status=waits[-1][2] if waits else "", compile_ok=bool(kernels.CURRENT and kernels.CURRENT.ok),
               compile_seconds=kernels.CURRENT.seconds if kernels.CURRENT else None, ready_after=kernels.ready(),
               compiled_during_bind=Count.n, seconds_since_enable=time.monotonic() - t_enable)
    # then what a user does next: moves the Empty (a live frame), the settle, Apply, an animation frame
    empty = obj.hybrid_arap.handles[0].empty
    empty.location.z += 0.3
    empty.rotation_euler.x = math.radians(20)
    bpy.context.view_layer.update()
    assert bpy.ops.hybrid_arap.settle() == {"FINISHED"}
    assert bpy.ops.hybrid_arap.apply() == {"FINISHED"}
    empty.keyframe_insert("location", frame=1)
    empty.location.z += 0.2
    empty.keyframe_insert("location", frame=2)
    bpy.context.scene.frame_set(2)
    live = importlib.import_module(pkg.__name__ + ".live")
    live.finish()
    ev = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    E = np.empty(len(ev.vertices) * 3, np.float32)
    ev.attributes["position"].data.foreach_get("vector", E)
    res.update(compiled_in_all=Count.n, moved=float(np.abs(E - P).max()))
    if kernels.CURRENT is not None:  # (with the portable kernels, nothing waited for the compile)
        kernels.CURRENT.done.wait(1800)
    res.update(compile_ok=bool(kernels.CURRENT and kernels.CURRENT.ok), ready_after=kernels.native_ready(),
               compile_seconds=kernels.CURRENT.seconds if kernels.CURRENT else None)
    Path(out_path).write_text(json.dumps(res))
    sys.stdout.flush()
    os._exit(0)  # (bpy 4.2 may crash in the interpreter's teardown)


if __name__ == "__main__":
    main()
