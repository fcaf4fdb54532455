"""The built zip installed through Blender's own extension installer, then used as a user would: the
extension enabled, a mesh bound, its Empty moved, the pose read back from what Blender evaluates.

    blender/.venv-bpy/bin/python blender/install_check.py [--zip blender/dist/hybridedit_blender-*-linux-x64.zip]
    blender/.venv-bpy-4.5/bin/python blender/install_check.py --zip ...

Without --zip the Linux zip is built first (build_extension.py --platform linux-x64). Blender's user
folders go to a temporary directory (BLENDER_USER_RESOURCES), so nothing of the machine's Blender is
touched. Prints one line per check and exits 1 on the first failure.
"""

from __future__ import annotations

import argparse
import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--zip", type=Path)
    args = ap.parse_args()
    zip_path = args.zip
    if zip_path is None:
        out = Path(tempfile.mkdtemp(prefix="hybridedit-zip-"))
        subprocess.run([sys.executable, str(HERE / "build_extension.py"), "--platform", "linux-x64", "--out", str(out)],
                       check=True)
        zip_path = next(out.glob("*.zip"))
    os.environ["BLENDER_USER_RESOURCES"] = tempfile.mkdtemp(prefix="hybridedit-user-")
    os.environ.setdefault("HYBRIDEDIT_BLENDER_CACHE", os.path.join(tempfile.gettempdir(), "hybridedit-blender-tests"))
    import bpy
    import numpy as np

    print("bpy", bpy.app.version_string, "zip", zip_path.name)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    r = bpy.ops.extensions.package_install_files(filepath=str(zip_path), repo="user_default", enable_on_install=True)
    ok = r == {"FINISHED"} and hasattr(bpy.types.Object, "hybrid_arap")
    print("installed by Blender's extension installer and registered:", ok)
    if not ok:
        os._exit(1)
    mod = sys.modules.get("bl_ext.user_default.hybridedit_blender")
    print("module:", mod.__name__ if mod else None, "engine:", sys.modules["hybridedit"].__file__ if "hybridedit" in
          sys.modules else "not loaded yet")
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=4)
    obj = bpy.context.object
    me = obj.data
    P = np.empty(len(me.vertices) * 3, np.float32)
    me.attributes["position"].data.foreach_get("vector", P)
    P = P.reshape(-1, 3)
    me.vertices.foreach_set("select", P[:, 2] > 0.75)
    bpy.ops.hybrid_arap.add_handle()
    me.vertices.foreach_set("select", P[:, 2] > -0.1)
    bpy.ops.hybrid_arap.roi_from_selection()
    ok = bpy.ops.hybrid_arap.bind() == {"FINISHED"}
    empty = obj.hybrid_arap.handles[0].empty
    empty.location.z += 0.3
    empty.rotation_euler.x = math.radians(20)
    bpy.context.view_layer.update()
    bpy.ops.hybrid_arap.settle()
    ev = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    E = np.empty(len(ev.vertices) * 3, np.float32)
    ev.attributes["position"].data.foreach_get("vector", E)
    B = np.empty_like(E)
    me.attributes["position"].data.foreach_get("vector", B)
    moved = float(np.abs(E.reshape(-1, 3) - P).max())
    fixed = P[:, 2] <= -0.1
    ok = ok and moved > 0.2 and np.array_equal(E.reshape(-1, 3)[fixed], P[fixed]) and np.array_equal(B.reshape(-1, 3), P)
    print(f"bound, posed through the Empty: shown {moved:.3f} moved, fixed rows bit-exact, base unchanged:", ok)
    sys.stdout.flush()
    os._exit(0 if ok else 1)


if __name__ == "__main__":
    sys.exit(main())
