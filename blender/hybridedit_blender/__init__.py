"""Hybrid ARAP: pose dense meshes live in Blender with hybridedit's cage-based ARAP.

ROI and handle groups come from vertex groups; each handle group follows an Empty
(as a Hook does). Bind builds the cage and binding in the background (cached by the
mesh's content); moving or rotating an Empty (by hand, keyframes, constraints or
drivers) poses the mesh live in a shape key ("Hybrid ARAP") beside the base mesh;
Apply bakes it into the mesh (one undo step), Reset zeroes it, Bake Animation turns a
frame range into keyed shape keys. The binding is saved with the .blend and bound
again on opening. Only positions are written: UVs, colours, custom normals and every
other attribute are untouched.

Enabling the extension starts compiling the engine's kernels in a background process
(:mod:`.kernels`), so that the first Bind loads them instead of compiling them.
"""

from __future__ import annotations

import os


def _numba_cache() -> None:
    """Compiled kernels go to a user-writable folder (an extension's own folder may be read-only),
    so that they compile once, not at every start, and the background compile writes them where
    Blender's process looks. Numba reads the setting when a kernel is defined; if numba was
    imported already (another add-on), its setting is changed too. Until the background compile
    has finished, the zip's portable kernels serve where it has them (:mod:`.portable_kernels`)."""
    import sys

    from . import kernels, portable_kernels
    from .bind import user_folder

    if portable_kernels.IN_USE is not None:  # (enabled again in this Blender: as chosen the first time)
        return
    if not os.environ.get("NUMBA_CACHE_DIR"):
        os.environ["NUMBA_CACHE_DIR"] = folder = user_folder("numba")
        if "numba" in sys.modules:
            sys.modules["numba"].config.CACHE_DIR = folder
    kernels.NATIVE_DIR = os.environ["NUMBA_CACHE_DIR"]
    portable_kernels.choose(user_folder("numba-portable"), native_ready=kernels.native_ready())


def register():
    import bpy

    from . import bind, live, ops, panel

    _numba_cache()
    for cls in panel.CLASSES + (bind.HYBRIDARAP_OT_bind,) + ops.CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Object.hybrid_arap = bpy.props.PointerProperty(type=panel.HybridArapSettings)
    live.register()
    from . import kernels

    kernels.start()  # (returns at once: the kernels compile in a process of their own)


def unregister():
    import bpy

    from . import bind, live, ops, panel

    live.unregister()
    del bpy.types.Object.hybrid_arap
    for cls in reversed(panel.CLASSES + (bind.HYBRIDARAP_OT_bind,) + ops.CLASSES):
        bpy.utils.unregister_class(cls)
