"""he.save_poses: poses as glTF morph targets and USD blend shapes, read back by the real clients.

Each file is read back with pygltflib (the rest plus each target's deltas, sparse or not) or with
``pxr`` (UsdSkel's own blend shape query), and checked by the Khronos glTF Validator or USD's
validators (what ``usdchecker`` runs), through tests/support/pose_files.py (the batch's pack tests
read their packs with the same). The validator is an npm package (scripts/gltf-validator); where
node or it is missing its test is skipped, unless HYBRIDEDIT_REQUIRE_VALIDATORS is set (.ci/run sets
it), where that fails instead.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pygltflib
import pytest

import hybridedit as he
from hybridedit.core.normals import vertex_normals
from hybridedit.fileio.formats.srgb import srgb_to_linear
from hybridedit.fileio.meshfiles import MeshFileError, read_document, write_document

from shapes import textured_glb
from support.pose_files import (NAMES, _pxr, accessor, coloured_ply, morphed, region_poses, textured_tube,
                                usd_check, usd_poses, validate_gltf)


# --------------------------------------------------------------------------- glTF morph targets


@pytest.fixture
def tube(tmp_path: Path) -> Path:
    return textured_tube(tmp_path / "in")


def corner_uvs(doc) -> np.ndarray:
    """(t, 3, 2): the texture coordinates of each triangle corner, in the engine's triangle order."""
    tex = doc.textures()
    if doc.format == "glb":  # (its corners are the file's triangles' already)
        return tex.uv[tex.corner_uv].reshape(-1, 3, 2)
    return tex.uv[doc.fan_triangles(tex.corner_uv)]


@pytest.mark.parametrize("sparse", [True, False])
def test_textured_obj_poses_come_back_from_the_glb_with_uvs_material_and_texture(tube, tmp_path, sparse):
    doc = read_document(tube)
    V = doc.mesh.vertices
    poses = region_poses(V)
    out = tmp_path / "tube_poses.glb"
    notes = he.save_poses(out, doc, poses, names=NAMES, sparse=sparse)
    assert notes == [f"glTF binary cannot hold everything from the OBJ file; not written: "
                     f"polygons ({doc.polygons[0].size}; written as {doc.mesh.n_faces} triangles)"]
    gltf = pygltflib.GLTF2.load(str(out))
    # one mesh, its triangles once; a target per pose on every primitive, named, at weight 0
    assert len(gltf.meshes) == 1 and len(gltf.nodes) == 1
    mesh = gltf.meshes[0]
    assert sum(gltf.accessors[p.indices].count for p in mesh.primitives) == 3 * doc.mesh.n_faces
    assert mesh.extras["targetNames"] == NAMES and mesh.weights == [0.0] * 4
    assert all(len(p.targets) == 4 for p in mesh.primitives)
    back = read_document(out)  # the rest, welded at the UV seam again: the OBJ's vertices in order
    assert np.array_equal(back.mesh.faces, doc.mesh.faces)
    file_vertex = back.native.file_vertex
    diagonal = np.linalg.norm(np.ptp(V, axis=0))
    prim = mesh.primitives[0]
    for k, pose in enumerate(poses):
        assert np.abs(morphed(gltf, prim, k) - pose[file_vertex]).max() <= 1e-6 * diagonal
        n = morphed(gltf, prim, k, "NORMAL")
        truth = vertex_normals(pose, doc.mesh.faces)[file_vertex]
        assert np.abs(n - truth).max() < 1e-5
    # what moves nothing stores nothing; a region's pose only its rows, where sparse
    nothing = gltf.accessors[prim.targets[2]["POSITION"]]
    assert nothing.bufferView is None and nothing.sparse is None
    bend = gltf.accessors[prim.targets[0]["POSITION"]]
    assert (bend.sparse is not None, bend.bufferView is None) == (sparse, sparse)
    assert gltf.accessors[prim.targets[1]["POSITION"]].sparse is None  # (it moves every vertex)
    np.testing.assert_allclose(corner_uvs(back), corner_uvs(doc), atol=1e-7)
    tex = back.textures()
    assert [m.name for m in tex.materials] == ["skin"]
    assert tex.materials[0].image == (tube.parent / "skin.png").read_bytes()


def test_coloured_ply_poses_come_back_from_the_glb_with_their_colours(tmp_path):
    doc = read_document(coloured_ply(tmp_path / "ball.ply"))
    poses = region_poses(doc.mesh.vertices)
    out = tmp_path / "ball.glb"
    assert he.save_poses(out, doc, poses) == []
    gltf = pygltflib.GLTF2.load(str(out))
    assert gltf.meshes[0].extras["targetNames"] == ["pose_1", "pose_2", "pose_3", "pose_4"]
    prim = gltf.meshes[0].primitives[0]
    for k, pose in enumerate(poses):  # (no UVs: the glTF vertices are the PLY's, in order)
        assert np.abs(morphed(gltf, prim, k) - pose).max() <= 1e-6 * doc.mesh.bbox_diagonal()
    # COLOR_0 is linear: the PLY's display bytes decoded, the alpha as it is
    stored = accessor(gltf, prim.attributes.COLOR_0)
    assert np.array_equal(stored, srgb_to_linear(doc.colors).astype(np.float32))
    assert np.array_equal(stored[:, 3], doc.colors[:, 3].astype(np.float32))
    back = read_document(out)
    np.testing.assert_allclose(back.colors, doc.colors, atol=1e-6)
    assert np.any(back.colors[:, 3] < 1)


def test_a_coloured_glbs_poses_keep_its_colour_bytes(tmp_path):
    """A .glb's own COLOR_0 goes through save_poses as the file has it (not decoded and encoded again)."""
    write_document(tmp_path / "ball.glb", read_document(coloured_ply(tmp_path / "ball.ply")))
    doc = read_document(tmp_path / "ball.glb")
    out = tmp_path / "ball_poses.glb"
    assert he.save_poses(out, doc, region_poses(doc.mesh.vertices)) == []
    a, b = pygltflib.GLTF2.load(str(tmp_path / "ball.glb")), pygltflib.GLTF2.load(str(out))
    assert b.binary_blob()[: len(a.binary_blob())] == a.binary_blob()  # (COLOR_0's bytes among them)
    assert b.meshes[0].primitives[0].attributes.COLOR_0 == a.meshes[0].primitives[0].attributes.COLOR_0
    assert np.array_equal(read_document(out).colors, doc.colors)


def test_a_glb_keeps_its_own_file_and_gains_the_targets(tmp_path):
    """A .glb's poses go on the file itself: its node (placed at z = 2), material, texture and UVs are
    kept byte for byte, the deltas are in the node's space."""
    path = textured_glb(tmp_path / "ball.glb")
    doc = read_document(path)
    poses = region_poses(doc.mesh.vertices)
    out = tmp_path / "ball_poses.glb"
    assert he.save_poses(out, doc, poses, names=NAMES) == []
    a, b = pygltflib.GLTF2.load(str(path)), pygltflib.GLTF2.load(str(out))
    assert b.binary_blob()[: len(a.binary_blob())] == a.binary_blob()  # the file's data, then ours
    assert b.nodes == a.nodes and a.nodes[0].matrix[12:15] == [0.0, 0.0, 2.0]
    assert len(b.images) == len(a.images) == 1 and len(b.meshes) == len(a.meshes) == 1
    prim = b.meshes[0].primitives[0]
    assert b.meshes[0].extras["targetNames"] == NAMES
    nat = doc.native
    for k, pose in enumerate(poses):
        local = pose[nat.file_vertex] - [0.0, 0.0, 2.0]
        assert np.abs(morphed(b, prim, k) - local).max() <= 1e-6 * doc.mesh.bbox_diagonal()
        n = morphed(b, prim, k, "NORMAL")
        assert np.percentile(np.linalg.norm(n - vertex_normals(pose, doc.mesh.faces)[nat.file_vertex], axis=1),
                             99) < 0.05  # (the file's normals split at the seam: its own grouping)


def test_a_gltf_is_the_glb_with_its_buffer_inline(tube, tmp_path):
    doc = read_document(tube)
    poses = region_poses(doc.mesh.vertices)
    he.save_poses(tmp_path / "t.glb", doc, poses, names=NAMES)
    he.save_poses(tmp_path / "t.gltf", doc, poses, names=NAMES)
    text = json.loads((tmp_path / "t.gltf").read_text())
    assert text["buffers"][0]["uri"].startswith("data:application/octet-stream;base64,")
    a, b = pygltflib.GLTF2.load(str(tmp_path / "t.glb")), pygltflib.GLTF2.load(str(tmp_path / "t.gltf"))
    b.convert_buffers(pygltflib.BufferFormat.BINARYBLOB)
    assert b.binary_blob() == a.binary_blob()
    assert b.meshes[0].extras == a.meshes[0].extras


@pytest.mark.parametrize("case", ["obj", "obj dense", "obj no normals", "ply", "glb", "gltf"])
def test_the_khronos_validator_finds_no_error_and_no_warning(tube, tmp_path, case):
    source = {"ply": lambda: coloured_ply(tmp_path / "ball.ply"),
              "glb": lambda: textured_glb(tmp_path / "ball.glb")}.get(case.split()[0], lambda: tube)()
    doc = read_document(source)
    out = tmp_path / ("poses.gltf" if case == "gltf" else "poses.glb")
    he.save_poses(out, doc, region_poses(doc.mesh.vertices), names=NAMES, sparse="dense" not in case,
                  normals="no normals" not in case)
    report = validate_gltf(out)
    issues = report["issues"]
    shown = [(m["code"], m["pointer"]) for m in issues["messages"] if m["severity"] <= 1]
    print(case, {k: issues[k] for k in ("numErrors", "numWarnings", "numInfos", "numHints")})
    assert issues["numErrors"] == 0 and issues["numWarnings"] == 0, shown


# --------------------------------------------------------------------------- USD blend shapes


@pytest.mark.parametrize("suffix", [".usda", ".usdc"])
def test_textured_obj_poses_come_back_from_usd_with_polygons_and_uvs(tube, tmp_path, suffix):
    Usd, UsdGeom, UsdSkel, _ = _pxr()
    doc = read_document(tube)
    V = doc.mesh.vertices
    poses = region_poses(V)
    out = tmp_path / ("tube" + suffix)
    notes = he.save_poses(out, doc, poses, names=NAMES)
    assert notes == ["USD cannot hold everything from the OBJ file; not written: material libraries (1), "
                     "material references (1)"]
    names, posed, weights = usd_poses(out, V)
    assert names == ["bend_up", "swell", "rest_again", "twist__left_"] and weights.tolist() == [0.0] * 4
    for pose, got in zip(poses, posed):
        assert np.abs(got - pose).max() <= 1e-6 * doc.mesh.bbox_diagonal()
    stage = Usd.Stage.Open(str(out))
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/tube/Mesh"))
    counts, flat = doc.polygon_lists()
    assert list(mesh.GetFaceVertexCountsAttr().Get()) == counts.tolist() and set(counts.tolist()) == {4}
    assert list(mesh.GetFaceVertexIndicesAttr().Get()) == flat.tolist()
    assert mesh.GetSubdivisionSchemeAttr().Get() == "none"
    st = UsdGeom.PrimvarsAPI(mesh).GetPrimvar("st")
    assert st.GetInterpolation() == "faceVarying"
    tex = doc.textures()
    np.testing.assert_allclose(np.array(st.ComputeFlattened()), tex.uv[tex.corner_uv], atol=1e-7)
    shapes = [stage.GetPrimAtPath(f"/tube/Mesh/{n}") for n in names]
    assert [p.GetDisplayName() or p.GetName() for p in shapes] == NAMES
    # the region's pose stores its rows only; the one that moves nothing, none
    assert 0 < len(UsdSkel.BlendShape(shapes[0]).GetPointIndicesAttr().Get()) < 0.75 * doc.mesh.n_vertices
    assert len(UsdSkel.BlendShape(shapes[2]).GetOffsetsAttr().Get()) == 0
    normals = np.array(mesh.GetNormalsAttr().Get())
    np.testing.assert_allclose(normals, vertex_normals(V, doc.mesh.faces), atol=1e-6)
    for shape, pose in zip(shapes, poses):  # rest normals plus the normal offsets: the pose's normals
        b = UsdSkel.BlendShape(shape)
        rows = b.GetPointIndicesAttr().Get()
        rows = np.arange(len(V)) if rows is None else np.array(rows, dtype=np.int64)
        n = normals.copy()
        n[rows] += np.array(b.GetNormalOffsetsAttr().Get()).reshape(-1, 3)
        assert np.abs(n - vertex_normals(pose, doc.mesh.faces)).max() < 1e-5


def test_coloured_ply_poses_come_back_from_usd_with_their_colours(tmp_path):
    Usd, UsdGeom, _, _ = _pxr()
    doc = read_document(coloured_ply(tmp_path / "ball.ply"))
    poses = region_poses(doc.mesh.vertices)
    out = tmp_path / "ball.usd"
    assert he.save_poses(out, doc, poses) == []
    assert out.read_bytes()[:8] == b"PXR-USDC"  # .usd: the binary crate
    names, posed, _ = usd_poses(out, doc.mesh.vertices)
    assert names == ["pose_1", "pose_2", "pose_3", "pose_4"]
    assert np.abs(posed - np.array(poses)).max() <= 1e-6 * doc.mesh.bbox_diagonal()
    stage = Usd.Stage.Open(str(out))  # (held: a prim of a stage let go is invalid)
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/ball/Mesh"))
    # displayColor linear (USD's fallback colour space, none being authored, is linear Rec.709), opacity as is
    np.testing.assert_allclose(np.array(mesh.GetDisplayColorPrimvar().Get()), srgb_to_linear(doc.colors[:, :3]),
                               atol=1e-6)
    assert not np.allclose(np.array(mesh.GetDisplayColorPrimvar().Get()), doc.colors[:, :3], atol=1e-3)
    np.testing.assert_allclose(np.array(mesh.GetDisplayOpacityPrimvar().Get()), doc.colors[:, 3], atol=1e-6)
    assert mesh.GetDisplayColorPrimvar().GetInterpolation() == "vertex"


@pytest.mark.parametrize("suffix", [".usda", ".usdc"])
def test_usds_validators_find_nothing(tube, tmp_path, suffix):
    _pxr()
    out = tmp_path / ("tube" + suffix)
    doc = read_document(tube)
    he.save_poses(out, doc, region_poses(doc.mesh.vertices), names=NAMES)
    issues = usd_check(out)
    print(suffix, len(issues), "issues")
    assert issues == []


# --------------------------------------------------------------------------- editors, meshes, bad input


def test_an_editor_gives_its_document_as_the_rest_and_its_pose(tube, tmp_path):
    ed = he.open(tube, 60)
    x = ed.mesh.vertices[:, 0]
    ed.set_selection(np.flatnonzero(x > 1.5), roi=np.flatnonzero(x > 0.0))
    up = ed.drag(translate=(0.0, 0.5, 0.0)).copy()
    assert np.any(up != ed.mesh.vertices)
    out = tmp_path / "edited.glb"
    he.save_poses(out, ed, [up, ed, he.Mesh(up, ed.mesh.faces)], names=["up", "current", "as mesh"])
    gltf = pygltflib.GLTF2.load(str(out))
    prim = gltf.meshes[0].primitives[0]
    assert prim.attributes.TEXCOORD_0 is not None  # the document's, not a bare mesh
    file_vertex = read_document(out).native.file_vertex
    for k in range(3):
        assert np.abs(morphed(gltf, prim, k) - up[file_vertex]).max() <= 1e-6 * ed.mesh.bbox_diagonal()


def test_bad_input_is_one_line_naming_the_file_and_nothing_is_written(tube, tmp_path):
    doc = read_document(tube)
    V = doc.mesh.vertices
    out = tmp_path / "poses.glb"
    nan = V.copy()
    nan[7, 1] = np.nan
    cases = [
        (dict(poses=[V[:-1]]), "poses.glb: pose 1 ('pose_1') has shape"),
        (dict(poses=[V, nan], names=["a", "b"]), "poses.glb: pose 2 ('b') has non-finite coordinates (1 vertices, "
                                                  "the first 7)"),
        (dict(poses=[V, V], names=["a", "a"]), "poses.glb: pose names must be unique; 'a' is given twice"),
        (dict(poses=[V, V], names=["a"]), "poses.glb: 1 names for 2 poses"),
        (dict(poses=[]), "poses.glb: no poses to write"),
        (dict(poses=[he.Mesh(V, doc.mesh.faces[::-1])]), "poses.glb: pose 1 ('pose_1') is a mesh of other triangles"),
    ]
    for kwargs, start in cases:
        with pytest.raises(MeshFileError) as info:
            he.save_poses(out, doc, kwargs.pop("poses"), **kwargs)
        assert str(info.value).startswith(start) and "\n" not in str(info.value), str(info.value)
    with pytest.raises(MeshFileError, match=r"^poses\.obj: cannot write poses to a file of extension '\.obj' "
                                            r"\(use one of \.glb, \.gltf, \.usda, \.usdc, \.usd\)$"):
        he.save_poses(tmp_path / "poses.obj", doc, [V])
    assert list(tmp_path.iterdir()) == [tube.parent]


def test_without_usd_core_the_message_says_what_to_install(tube, tmp_path, monkeypatch):
    for name in [m for m in sys.modules if m == "pxr" or m.startswith("pxr.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "pxr", None)  # (an import of it raises ImportError)
    doc = read_document(tube)
    with pytest.raises(MeshFileError, match=r"^tube\.usda: writing USD needs usd-core, which is not installed: "
                                            r"pip install 'hybridedit\[usd\]'$"):
        he.save_poses(tmp_path / "tube.usda", doc, [doc.mesh.vertices])
    assert not (tmp_path / "tube.usda").exists()


def test_an_existing_file_is_replaced_only_by_a_complete_one(tube, tmp_path):
    out = tmp_path / "poses.glb"
    out.write_bytes(b"old")
    doc = read_document(tube)
    with pytest.raises(MeshFileError):
        he.save_poses(out, doc, [doc.mesh.vertices[:3]])
    assert out.read_bytes() == b"old"
    he.save_poses(out, doc, [doc.mesh.vertices * 2])
    assert out.read_bytes()[:4] == b"glTF"


# --------------------------------------------------------------------------- size


def grid_sphere(n_side: int) -> he.Mesh:
    """A sphere of about 2 n_side² vertices (a latitude-longitude grid, closed at the poles)."""
    import trimesh

    s = trimesh.creation.uv_sphere(radius=1.0, count=[n_side, n_side])
    return he.Mesh(np.asarray(s.vertices), np.asarray(s.faces))


@pytest.mark.slow
def test_twenty_poses_of_a_100k_mesh_cost_little_more_than_their_position_deltas(tmp_path):
    """20 poses of a 100K mesh, each moving a quarter of it (as an edit's region does), are at most
    1.15 times one mesh plus 20 full position deltas (12 bytes a vertex); 20 poses moving the whole
    mesh without normal deltas too."""
    mesh = grid_sphere(224)
    V = mesh.vertices
    assert 95_000 < mesh.n_vertices < 110_000
    one = tmp_path / "one.glb"
    write_document(one, he.Document.from_mesh(mesh))
    budget = 1.15 * (one.stat().st_size + 20 * 12 * mesh.n_vertices)
    rng = np.random.default_rng(0)
    regional, whole = [], []
    for k in range(20):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        h = V @ axis
        lift = np.maximum(h - np.quantile(h, 0.75), 0.0)  # the quarter of the mesh furthest along axis
        regional.append(V + 0.5 * lift[:, None] ** 2 * axis)
        whole.append(V * (1.0 + 0.1 * np.sin(3 * h + k))[:, None])
    sizes = {}
    for label, poses, normals in [("regional", regional, True), ("whole, no normals", whole, False),
                                  ("whole", whole, True)]:
        out = tmp_path / f"{label}.glb"
        he.save_poses(out, mesh, poses, normals=normals)
        sizes[label] = out.stat().st_size
    print({k: f"{v / 1e6:.2f} MB ({v / budget * 1.15:.3f} x)" for k, v in sizes.items()},
          f"one mesh {one.stat().st_size / 1e6:.2f} MB")
    assert sizes["regional"] <= budget and sizes["whole, no normals"] <= budget
    gltf = pygltflib.GLTF2.load(str(tmp_path / "regional.glb"))
    prim = gltf.meshes[0].primitives[0]
    assert np.abs(morphed(gltf, prim, 19) - regional[19]).max() <= 1e-6 * mesh.bbox_diagonal()
