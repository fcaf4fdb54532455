"""Import a glTF file with Blender's own importer and dump what it made, for tests/support/pose_files.py.

Run by the Python of a venv with Blender as a module (bpy), never imported by the suite:
``python blender_gltf_import.py IN.glb OUT.npz``. It needs nothing but bpy and numpy. Blender is reset to
its factory settings with an empty scene, the file imported with ``bpy.ops.import_scene.gltf`` and its
default options, and OUT.npz gets, as Blender holds them (its Z-up object space; the importer turns
glTF's Y-up into it), with ``l`` loops (triangle corners), ``n`` vertices and ``k`` shape keys:

- ``objects``: every object's type; ``matrix_world`` (4, 4) the mesh object's,
- ``key_names`` (k,), ``key_relative`` (k,) each key's reference key, ``key_values`` (k,),
  ``keys`` (k, n, 3) float32 each key's positions (the first is the basis),
- ``positions`` (n, 3) float32 the mesh's own vertices, ``loop_start``, ``loop_total`` per polygon,
  ``corner_vert`` (l,) each loop's vertex,
- ``uv_names``, ``uv_<i>`` (l, 2) float32 each UV layer,
- ``color_names``, ``color_domains``, ``color_types``, ``color_<i>`` and ``color_srgb_<i>`` (l or n, 4)
  float32 each colour attribute (linear, and as sRGB: a byte colour's stored values over 255),
- ``materials`` the mesh's material names, ``image_names``, ``image_sizes`` (m, 2) the images.
"""

import sys

import bpy
import numpy as np


def floats(collection, attribute: str, width: int) -> np.ndarray:
    values = np.empty(len(collection) * width, dtype=np.float32)
    collection.foreach_get(attribute, values)
    return values.reshape(-1, width)


def ints(collection, attribute: str) -> np.ndarray:
    values = np.empty(len(collection), dtype=np.int32)
    collection.foreach_get(attribute, values)
    return values


def main(source: str, out: str) -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if bpy.ops.import_scene.gltf(filepath=source) != {"FINISHED"}:
        raise SystemExit(f"{source}: Blender's glTF importer did not finish")
    objects = list(bpy.context.scene.objects)
    meshes = [o for o in objects if o.type == "MESH"]
    if len(meshes) != 1:
        raise SystemExit(f"{source}: {len(meshes)} mesh objects imported, expected 1")
    ob = meshes[0]
    mesh = ob.data
    blocks = mesh.shape_keys.key_blocks if mesh.shape_keys is not None else []
    dump = {
        "objects": np.array([o.type for o in objects]),
        "matrix_world": np.array(ob.matrix_world, dtype=np.float64),
        "key_names": np.array([b.name for b in blocks], dtype=str),
        "key_relative": np.array([b.relative_key.name for b in blocks], dtype=str),
        "key_values": np.array([b.value for b in blocks], dtype=np.float64),
        "keys": np.array([floats(b.data, "co", 3) for b in blocks], np.float32).reshape(-1, len(mesh.vertices), 3),
        "positions": floats(mesh.vertices, "co", 3),
        "loop_start": ints(mesh.polygons, "loop_start"),
        "loop_total": ints(mesh.polygons, "loop_total"),
        "corner_vert": ints(mesh.loops, "vertex_index"),
        "uv_names": np.array([layer.name for layer in mesh.uv_layers], dtype=str),
        "color_names": np.array([a.name for a in mesh.color_attributes], dtype=str),
        "color_domains": np.array([a.domain for a in mesh.color_attributes], dtype=str),
        "color_types": np.array([a.data_type for a in mesh.color_attributes], dtype=str),
        "materials": np.array([m.name for m in mesh.materials if m is not None], dtype=str),
        "image_names": np.array([i.name for i in bpy.data.images], dtype=str),
        "image_sizes": np.array([tuple(i.size) for i in bpy.data.images], dtype=np.int64).reshape(-1, 2),
    }
    for i, layer in enumerate(mesh.uv_layers):
        dump[f"uv_{i}"] = floats(layer.data, "uv", 2)
    for i, attribute in enumerate(mesh.color_attributes):
        dump[f"color_{i}"] = floats(attribute.data, "color", 4)
        dump[f"color_srgb_{i}"] = floats(attribute.data, "color_srgb", 4)
    np.savez(out, **dump)
    print(f"{source}: {len(mesh.vertices)} vertices, {len(mesh.loops)} loops, {len(blocks)} shape keys "
          f"(Blender {bpy.app.version_string})")


if __name__ == "__main__":
    main(*sys.argv[1:3])
