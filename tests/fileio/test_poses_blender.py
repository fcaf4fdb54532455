"""he.save_poses's .glb files read by Blender's own glTF importer: as many shape keys as poses, named as
given, each the pose; the basis the rest; the texture coordinates, material and vertex colours intact.

Blender (as a Python module) runs in a process of its own, the Python of blender/.venv-bpy
(blender/run_tests.sh makes it, and .ci/run runs that before this suite): it has the engine but not
the file formats, so this process writes the file and tests/support/blender_gltf_import.py imports it
(``bpy.ops.import_scene.gltf``, its default options, in an empty factory scene) and dumps the mesh. Where
that Python is missing the tests are skipped, unless HYBRIDEDIT_REQUIRE_VALIDATORS is set (.ci/run), where
they fail.

Matching Blender's mesh to the input: the importer makes one triangle per glTF triangle, in the file's
order, which is the document's (``doc.mesh.faces``); so loop 3t + c is corner c of triangle t, and its
vertex (``corner_vert``) holds each shape key's position there, whatever vertices the importer split (glTF's
own, at UV seams) or merged. Every position, UV and colour is compared corner by corner with the input's.
Positions go back from Blender's Z-up to glTF's Y-up: the object's matrix, then (x, y, z) -> (x, z, -y).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import plyfile
import pytest
from PIL import Image

import hybridedit as he
from hybridedit.fileio.meshfiles import read_document

from shapes import SPOT, textured_spot
from support.pose_files import blender_import, coloured_ply, region_poses, textured_tube


def engine_poses(path: Path, cage_size) -> tuple[list[np.ndarray], list[str]]:
    """Three poses the engine solves (``converge``): the end furthest along the longest axis lifted and
    turned, the other end lowered, each from the rest."""
    ed = he.open(path, cage_size)
    V = ed.mesh.vertices.copy()
    extent = np.ptp(V, axis=0)
    along = np.argmax(extent)
    side = ({0, 1, 2} - {along, 1}).pop()  # (y is up in both inputs)
    t = (V[:, along] - V[:, along].min()) / extent[along]
    d = float(np.linalg.norm(extent))
    up, turn = np.zeros(3), np.zeros(3)
    up[1], turn[side] = 1.0, 1.0
    edits = {"end up": (t > 0.85, t > 0.5, dict(translate=0.1 * d * up)),
             "end turned": (t > 0.85, t > 0.5, dict(rotate={"axis": turn, "degrees": 25.0})),
             "other end down (left)": (t < 0.15, t < 0.5, dict(translate=-0.06 * d * up))}
    poses = []
    for handle, roi, transform in edits.values():
        ed.reset()
        ed.set_selection(np.flatnonzero(handle), roi=np.flatnonzero(roi))
        result = ed.converge(**transform)
        assert result.converged
        poses.append(np.array(result.vertices))
        assert np.abs(poses[-1] - V).max() > 0.01 * d  # (a pose that moves)
    return poses, list(edits)


def loop_vertices(dump: dict) -> np.ndarray:
    """(l,) each loop's Blender vertex, having checked that the polygons are the file's triangles, in
    loop order."""
    assert np.all(dump["loop_total"] == 3)
    assert np.array_equal(dump["loop_start"], 3 * np.arange(dump["loop_start"].size))
    return dump["corner_vert"]


def gltf_frame(dump: dict, points: np.ndarray) -> np.ndarray:
    """(..., 3) float64: Blender object space ``points`` in glTF's Y-up frame."""
    M = dump["matrix_world"]
    world = points.astype(np.float64) @ M[:3, :3].T + M[:3, 3]
    return np.stack([world[..., 0], world[..., 2], -world[..., 1]], axis=-1)


def check_shape_keys(dump: dict, doc, poses: list[np.ndarray], names: list[str]) -> float:
    """Asserts Blender's shape keys are the rest (the basis, exactly as float32) and the poses; returns the
    largest pose error, a fraction of the diagonal."""
    assert dump["objects"].tolist() == ["MESH"]
    corners = doc.mesh.faces.ravel()
    loops = loop_vertices(dump)
    assert loops.size == corners.size
    assert dump["key_names"].tolist() == ["Basis", *names]
    assert set(dump["key_relative"].tolist()) == {"Basis"} and not dump["key_values"].any()  # (opens at rest)
    keys = gltf_frame(dump, dump["keys"][:, loops])  # (k + 1, l, 3) at each corner
    assert np.array_equal(keys[0], doc.mesh.vertices[corners].astype(np.float32))
    assert np.array_equal(gltf_frame(dump, dump["positions"][loops]), keys[0])
    diagonal = doc.mesh.bbox_diagonal()
    errors = [np.abs(key - pose[corners]).max() / diagonal for key, pose in zip(keys[1:], poses)]
    assert max(errors) <= 1e-6, errors
    return max(errors)


@pytest.mark.parametrize("mesh", ["tube", "spot"])
def test_blender_imports_a_textured_objs_poses_as_shape_keys_with_its_uvs(tmp_path, mesh):
    if mesh == "spot":
        if not (SPOT / "spot_quadrangulated.obj").exists():
            pytest.skip(f"{SPOT} not available")
        source, cage_size = textured_spot(tmp_path / "in"), he.defaults.CAGE_SIZE
    else:
        source, cage_size = textured_tube(tmp_path / "in"), 60
    poses, names = engine_poses(source, cage_size)
    doc = read_document(source)
    out = tmp_path / f"{mesh}_poses.glb"
    he.save_poses(out, doc, poses, names=names)
    dump = blender_import(out)
    error = check_shape_keys(dump, doc, poses, names)
    # texture coordinates at each corner as the OBJ's (glTF's v is 1 - the OBJ's, Blender's 1 - glTF's)
    tex = doc.textures()
    assert dump["uv_names"].tolist() == ["UVMap"]
    obj_uv = tex.uv[doc.fan_triangles(tex.corner_uv)].reshape(-1, 2)
    np.testing.assert_allclose(dump["uv_0"], obj_uv, rtol=0, atol=1e-6)
    assert dump["materials"].tolist() == [m.name for m in tex.materials]
    png = source.parent / ("textures/spot_texture.png" if mesh == "spot" else "skin.png")
    assert dump["image_sizes"].tolist() == [list(Image.open(png).size)]
    print(f"{mesh}: {doc.mesh.n_vertices} vertices, {len(dump['positions'])} in Blender, "
          f"largest pose error {error:.2g} of the diagonal")


def test_blender_imports_a_coloured_plys_poses_with_its_vertex_colours(tmp_path):
    source = coloured_ply(tmp_path / "ball.ply")
    doc = read_document(source)
    poses = region_poses(doc.mesh.vertices)  # (the third moves nothing: a target without data)
    out = tmp_path / "ball.glb"
    he.save_poses(out, doc, poses)
    dump = blender_import(out)
    error = check_shape_keys(dump, doc, poses, ["pose_1", "pose_2", "pose_3", "pose_4"])
    assert np.array_equal(dump["keys"][3], dump["keys"][0])
    assert dump["uv_names"].tolist() == []
    assert dump["color_names"].tolist() == ["Color"] and dump["color_types"].tolist() == ["BYTE_COLOR"]
    # Blender holds a byte colour as sRGB bytes (the importer encodes glTF's linear values): they are the
    # PLY's own bytes, within one, the alpha too
    colors = dump["color_srgb_0"]
    if dump["color_domains"][0] == "POINT":  # (the importer's are per corner; a vertex's would do too)
        colors = colors[loop_vertices(dump)]
    vertex = plyfile.PlyData.read(str(source))["vertex"].data
    ply_bytes = np.column_stack([vertex[c] for c in ("red", "green", "blue", "alpha")]).astype(np.float64)
    expected = ply_bytes[doc.mesh.faces.ravel()] / 255
    assert np.abs(colors - expected).max() <= 1 / 255 + 1e-6
    assert np.any(colors[:, 3] < 1)
    print(f"ball: largest pose error {error:.2g} of the diagonal, largest colour error "
          f"{np.abs(colors - expected).max() * 255:.2f} / 255")
