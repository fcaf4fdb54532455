"""Documents: everything but the positions survives a deform, in every format."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import plyfile
import pygltflib
import pytest
import trimesh

from hybridedit import HybridEditor
from hybridedit.core.normals import vertex_normals
from hybridedit.fileio.formats.srgb import linear_to_srgb, srgb_to_linear
from hybridedit.fileio.meshfiles import read_document, read_mesh, write_document

from shapes import SPOT, bumpy_blob, icosphere, textured_glb, textured_spot


def bend(V: np.ndarray) -> np.ndarray:
    """A smooth non-rigid edit of the +x half: (n, 3) new positions, the -x half unmoved."""
    out = V.copy()
    x = np.maximum(V[:, 0], 0.0)
    out[:, 1] += 0.3 * x ** 2
    out[:, 2] += 0.1 * x * V[:, 1]
    return out


def angle_degrees(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    cos = np.einsum("ij,ij->i", a, b) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
    return np.degrees(np.arccos(np.clip(cos, -1, 1)))


def non_vertex_lines(data: bytes) -> list[bytes]:
    return [line for line in data.splitlines() if not line.startswith((b"v ", b"vn "))]


# --------------------------------------------------------------------------- OBJ: spot


@pytest.fixture
def spot(tmp_path: Path) -> Path:
    """spot's quad mesh with a material library and its texture, in a folder of their own."""
    if not (SPOT / "spot_quadrangulated.obj").exists():
        pytest.skip(f"{SPOT} not available")
    return textured_spot(tmp_path / "in")


def test_obj_without_edit_is_the_same_file(spot: Path, tmp_path: Path) -> None:
    doc = read_document(spot)
    assert doc.polygons is not None and set(doc.polygons[0].tolist()) == {4}
    assert doc.extras["texture coordinates"] == 3225
    out = tmp_path / "same" / "spot.obj"
    out.parent.mkdir()
    assert write_document(out, doc) == []
    assert out.read_bytes() == spot.read_bytes()


def test_spot_deformed_keeps_quads_uvs_material_and_texture(spot: Path, tmp_path: Path) -> None:
    doc = read_document(spot)
    mesh = doc.mesh
    ed = HybridEditor(mesh, 150, cache=False)
    z = mesh.vertices[:, 2]
    ed.set_selection(np.flatnonzero(z > z.max() - 0.15), roi=np.flatnonzero(z > z.max() - 0.5))
    for _ in range(5):
        V = ed.drag(translate=(0.0, 0.2, 0.05))
    moved = np.any(V != mesh.vertices, axis=1)
    assert 0 < moved.sum() < mesh.n_vertices
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    out = out_dir / "spot_edited.obj"
    write_document(out, doc.with_vertices(V))
    before, after = spot.read_bytes(), out.read_bytes()
    assert non_vertex_lines(after) == non_vertex_lines(before)  # quads, vt indices, usemtl, ...
    back = read_document(out)
    # moved where edited, to spot's own 6 significant digits (what %g writes): see test_moved_...
    assert np.all(np.abs(back.mesh.vertices - V) <= 0.5e-5 * np.abs(V) + 1e-300)
    assert np.array_equal(back.mesh.faces, mesh.faces)
    v_before = [line for line in before.splitlines() if line.startswith(b"v ")]
    v_after = [line for line in after.splitlines() if line.startswith(b"v ")]
    assert all(a == b for a, b, m in zip(v_after, v_before, moved) if not m)
    # what the OBJ references is in the output folder
    assert (out_dir / "spot.mtl").read_bytes() == (spot.parent / "spot.mtl").read_bytes()
    texture = out_dir / "textures" / "spot_texture.png"
    assert texture.read_bytes() == (SPOT / "spot_texture.png").read_bytes()
    # an edit of the copy writes it back without touching the existing texture
    write_document(out, read_document(out).with_vertices(bend(V)))
    assert texture.read_bytes() == (SPOT / "spot_texture.png").read_bytes()


def _bumpy_obj(path: Path, fmt: str) -> Path:
    m = bumpy_blob(3)
    text = "".join(("v " + " ".join([fmt] * 3) + "\n") % tuple(r) for r in m.vertices.tolist())
    path.write_text(text + "".join("f %d %d %d\n" % tuple(f) for f in (m.faces + 1).tolist()))
    return path


def _written(data: bytes, head: bytes, columns: slice) -> list[list[bytes]]:
    return [line.split()[columns] for line in data.splitlines() if line.startswith(head)]


@pytest.mark.parametrize("case", ["spot %g", "%.6f", "%.9g", "repr"])
def test_moved_coordinates_are_written_with_the_files_own_precision(spot: Path, tmp_path: Path, case: str) -> None:
    """An edit does not inflate a file: a moved coordinate has at most the digits the input's have, and
    is within half a unit of its last digit of the engine's value (exact for a repr-written file)."""
    path = spot if case == "spot %g" else _bumpy_obj(tmp_path / "blob.obj", {"repr": "%r"}.get(case, case))
    doc = read_document(path)
    V = bend(doc.mesh.vertices)
    moved = np.any(V != doc.mesh.vertices, axis=1)
    assert moved.sum() > 0.3 * len(V)
    out = tmp_path / "bent.obj"
    write_document(out, doc.with_vertices(V))
    before, after = path.read_bytes(), out.read_bytes()
    growth = len(after) / len(before) - 1
    print(f"{case}: {moved.sum()} of {len(V)} vertices moved, file {len(before):,} -> {len(after):,} bytes "
          f"({100 * growth:+.3f}%)")
    assert abs(growth) < 0.01
    tokens = np.array(_written(after, b"v ", slice(1, 4)))[moved]
    written = tokens.astype(np.float64)
    err = np.abs(written - V[moved])
    if case == "repr":
        assert np.array_equal(written, V[moved])  # the shortest exact form: exact
        return
    digits = {"%.6f": None, "%.9g": 9}.get(case, 6)
    if digits is None:  # 6 decimals: within 0.5e-6, and never more decimals than the input's
        assert err.max() <= 0.5e-6 * (1 + 1e-9)
        assert max(len(t.partition(b".")[2]) for t in tokens.ravel()) <= 6
    else:  # s significant digits: within half a unit of the s-th digit, never more digits
        unit = 10.0 ** (np.floor(np.log10(np.abs(V[moved]))) - digits + 1)
        assert np.all(err <= 0.5 * unit * (1 + 1e-9))
        significant = [len(t.lstrip(b"-").partition(b"e")[0].replace(b".", b"").lstrip(b"0")) for t in tokens.ravel()]
        assert max(significant) <= digits
    # a second edit of the written file starts from what it holds
    again = read_document(out)
    assert np.array_equal(again.mesh.vertices[moved], written)


def test_moved_off_and_ascii_ply_coordinates_keep_the_files_precision(tmp_path: Path) -> None:
    m = bumpy_blob(3)
    off = tmp_path / "blob.off"
    off.write_text(f"OFF\n{len(m.vertices)} {len(m.faces)} 0\n"
                   + "".join("%.6f %.6f %.6f\n" % tuple(r) for r in m.vertices.tolist())
                   + "".join("3 %d %d %d\n" % tuple(f) for f in m.faces.tolist()))
    ply = coloured_ply(tmp_path / "blob.ply", "ascii")  # float32 x y z, written by plyfile with 18 digits
    for path in (off, ply):
        doc = read_document(path)
        V = bend(doc.mesh.vertices)
        out = tmp_path / ("bent" + path.suffix)
        write_document(out, doc.with_vertices(V))
        before, after = path.read_bytes(), out.read_bytes()
        moved = np.any(V != doc.mesh.vertices, axis=1)
        print(f"{path.name}: file {len(before):,} -> {len(after):,} bytes")
        back = read_document(out).mesh.vertices
        if path is off:
            assert abs(len(after) / len(before) - 1) < 0.01
            assert np.abs(back - V).max() <= 0.5e-6 * (1 + 1e-9)
        else:  # float32 properties: the shortest text of the float32 value, exactly that value
            assert np.array_equal(back[moved], V[moved].astype(np.float32).astype(np.float64))
            assert len(after) < len(before)  # 9 digits at most where plyfile had written 18
            rows = after.split(b"end_header\n", 1)[1].splitlines()[:len(V)]
            assert max(len(t.lstrip(b"-").partition(b"e")[0].replace(b".", b"").lstrip(b"0"))
                       for line, m in zip(rows, moved) if m for t in line.split()[:3]) <= 9


def test_an_existing_different_material_or_texture_is_never_replaced(spot: Path, tmp_path: Path) -> None:
    out_dir = tmp_path / "out"
    (out_dir / "textures" / "spot_texture.png").mkdir(parents=True)  # a folder where the image would go
    (out_dir / "spot.mtl").write_text("newmtl mine\n")  # the user's own, different material library
    doc = read_document(spot)
    notes = write_document(out_dir / "spot.obj", doc)
    assert (out_dir / "spot.mtl").read_text() == "newmtl mine\n"
    assert (out_dir / "textures" / "spot_texture.png").is_dir()
    assert any("spot.mtl kept as it is: it differs from" in n for n in notes)
    assert any("spot_texture.png not copied:" in n and "is a folder" in n for n in notes)
    assert read_document(out_dir / "spot.obj").mesh.n_vertices == doc.mesh.n_vertices  # written all the same


def _written_corner_normals(data: bytes) -> tuple[np.ndarray, np.ndarray]:
    """(corner normals (3m, 3) of the triangle faces 'f a//k b//k c//k', their vertices (3m,))."""
    lines = data.splitlines()
    vn = np.array([[float(x) for x in line.split()[1:4]] for line in lines if line.startswith(b"vn ")])
    corners = [tok.split(b"/") for line in lines if line.startswith(b"f ") for tok in line.split()[1:]]
    return vn[[int(c[2]) - 1 for c in corners]], np.array([int(c[0]) - 1 for c in corners])


@pytest.mark.parametrize("relative", [False, True])
def test_a_normal_shared_between_vertices_is_split_where_the_edit_bends_it(tmp_path: Path, relative) -> None:
    # a flat-shaded box as exporters write it: one vn for each side, shared by all its corners
    box = trimesh.creation.box(extents=(2.0, 1.0, 1.0)).subdivide().subdivide()
    box = trimesh.Trimesh(box.vertices, box.faces, process=False)
    sides, side_of = np.unique(np.round(box.face_normals, 6), axis=0, return_inverse=True)
    lines = [f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in box.vertices]
    lines += [f"vn {x:.6g} {y:.6g} {z:.6g}" for x, y, z in sides]
    ref = (lambda k: k - len(sides)) if relative else (lambda k: k + 1)
    lines += ["f " + " ".join(f"{v + 1}//{ref(k)}" for v in tri) for tri, k in zip(box.faces, side_of.ravel())]
    src = tmp_path / "box.obj"
    src.write_text("\n".join(lines) + "\n")
    doc = read_document(src)
    V = bend(doc.mesh.vertices)
    write_document(tmp_path / "bent.obj", doc.with_vertices(V))
    data = (tmp_path / "bent.obj").read_bytes()
    normals, _ = _written_corner_normals(data.replace(b"//-", b"//") if not relative else
                                         _absolute(data, len(sides)))
    # each corner's normal: its vertex's angle-weighted normal over the faces of its side (smooth
    # within a side, split at the box's edges); one normal shared by a whole side is 16 degrees off
    bent = trimesh.Trimesh(V, doc.mesh.faces, process=False)
    side = np.repeat(side_of.ravel(), 3)
    key = side * len(V) + bent.faces.ravel()
    weighted = np.repeat(bent.face_normals, 3, axis=0) * bent.face_angles.reshape(-1, 1)
    _, group = np.unique(key, return_inverse=True)
    expect = np.stack([np.bincount(group, weighted[:, a]) for a in range(3)], axis=1)[group]
    assert angle_degrees(normals, expect).max() < 1e-3
    # no normal is written twice, the unmoved half stays, the faces are the same
    left = V[:, 0] < -0.05
    assert len(set(line for line in data.splitlines() if line.startswith(b"vn "))) == \
        sum(1 for line in data.splitlines() if line.startswith(b"vn "))
    back = read_document(tmp_path / "bent.obj")
    assert np.array_equal(back.mesh.vertices[left], doc.mesh.vertices[left])
    assert np.array_equal(back.mesh.faces, doc.mesh.faces)


def _absolute(data: bytes, n_file_normals: int) -> bytes:
    """The relative normal references of the original faces made absolute (they count from the file's
    normals, which come before the faces)."""
    out = []
    for line in data.splitlines():
        if line.startswith(b"f "):
            words = [w.split(b"/") for w in line.split()[1:]]
            for w in words:
                k = int(w[2])
                w[2] = b"%d" % (k + n_file_normals + 1 if k < 0 else k)
            line = b"f " + b" ".join(b"/".join(w) for w in words)
        out.append(line)
    return b"\n".join(out)


#: what each format holds of another's document; what spot's file in that format has
HOLDS = {"obj": {"polygons", "uv", "image"}, "ply": {"polygons", "uv", "image"}, "off": {"polygons"},
         "stl": set(), "glb": {"uv", "image"}}


@pytest.fixture
def spot_in_every_format(spot: Path, tmp_path: Path) -> dict[str, Path]:
    """spot converted from its OBJ into each format, each in a folder of its own."""
    doc = read_document(spot)
    paths = {"obj": spot}
    for ext in ("ply", "off", "stl", "glb"):
        folder = tmp_path / f"src_{ext}"
        folder.mkdir()
        write_document(folder / f"spot.{ext}", doc)
        paths[ext] = folder / f"spot.{ext}"
    return paths


def _corner_uvs(doc) -> np.ndarray | None:
    """The texture coordinates of the engine's triangle corners, (m, 3, 2), or None."""
    from hybridedit.fileio.formats.common import fan_triangles

    tex = doc.textures()
    if tex is None or tex.uv is None:
        return None
    counts, _ = doc.polygon_lists()
    corner = fan_triangles(counts, np.arange(len(tex.corner_uv)))
    return tex.uv[tex.corner_uv[corner]]


@pytest.mark.parametrize("source, target", [(a, b) for a in sorted(HOLDS) for b in sorted(HOLDS) if a != b])
def test_conversions_keep_what_the_target_holds(spot_in_every_format, tmp_path: Path, source, target) -> None:
    """Every pair of formats, from spot (quads, UVs, a textured material): polygons, texture coordinates
    and the texture image are kept when the source has them and the target holds them, positions and
    triangles always; the one note names what is not kept, and only that."""
    src = read_document(spot_in_every_format[source])
    has = {"polygons": src.polygons is not None, "uv": _corner_uvs(src) is not None,
           "image": any(m.image is not None for m in (src.textures().materials if src.textures() else []))}
    assert has == {k: k in HOLDS[source] for k in has}, has  # what each source has
    out = tmp_path / "out" / f"converted.{target}"
    out.parent.mkdir()
    notes = write_document(out, src)
    back = read_document(out)
    float32 = {source, target} & {"ply", "stl", "glb"} - ({"ply"} if source == "ply" or target == "ply" else set())
    tol = 1e-6 if float32 else 0.0
    if target == "stl":  # a facet list: its vertices are welded in first-use order, the triangles are the same
        assert np.abs(back.mesh.vertices[back.mesh.faces] - src.mesh.vertices[src.mesh.faces]).max() <= tol * 2
    else:  # vertex and triangle order kept
        assert np.abs(back.mesh.vertices - src.mesh.vertices).max() <= tol * 2
        assert np.array_equal(back.mesh.faces, src.mesh.faces)
    keep = {k for k, v in has.items() if v} & HOLDS[target]
    lost = {k for k, v in has.items() if v} - HOLDS[target]
    if "polygons" in keep:
        assert np.array_equal(back.polygons[0], src.polygons[0]) and np.array_equal(back.polygons[1], src.polygons[1])
    if "uv" in keep:  # equal to float32 precision where either side stores float32 (PLY, glTF)
        assert np.abs(_corner_uvs(back) - _corner_uvs(src)).max() < 1e-7
    if "image" in keep:
        image = (SPOT / "spot_texture.png").read_bytes()
        assert [m.image for m in back.textures().materials if m.image is not None] == [image]
        if target != "glb":  # written beside the file
            assert (out.parent / "spot_texture.png").read_bytes() == image
    note = " ".join(notes)
    assert ("polygons (2,928; written as 5,856 triangles)" in note) == ("polygons" in lost)
    assert ("texture coordinates (" in note) == ("uv" in lost)
    if "image" in lost:
        assert "material" in note or "image" in note or "texture files" in note
    assert len(notes) <= 1
    if not lost and source != "obj":  # only a PLY's own header comment, or materials whose images are kept
        rest = note.replace("header comments (1)", "").replace("materials (1; their texture images are kept)", "")
        assert not any(word in rest for word in ("polygons", "texture", "material", "image")), note
    print(f"{source} -> {target}: kept {sorted(keep) or '-'}; note: {note or '-'}")


def test_spot_round_trips_through_ply_and_glb_keep_uvs_quads_and_texture(spot: Path, tmp_path: Path) -> None:
    doc = read_document(spot)
    for ext in ("ply", "glb"):
        mid, back_path = tmp_path / ext / f"spot.{ext}", tmp_path / ext / "back" / "spot.obj"
        back_path.parent.mkdir(parents=True)
        write_document(mid, doc)
        assert write_document(back_path, read_document(mid)) == [] or ext == "ply"
        back = read_document(back_path)
        assert np.abs(back.mesh.vertices - doc.mesh.vertices).max() <= (0 if ext == "ply" else 1e-7)
        assert np.abs(_corner_uvs(back) - _corner_uvs(doc)).max() < 1e-7
        if ext == "ply":  # PLY holds polygons: still quads; glTF has triangles only
            assert np.array_equal(back.polygons[0], doc.polygons[0])
        assert (back_path.parent / "spot_texture.png").read_bytes() == (SPOT / "spot_texture.png").read_bytes()
        assert "map_Kd spot_texture.png" in (back_path.parent / "spot.mtl").read_text()


# --------------------------------------------------------------------------- OBJ normals


def smooth_obj(tmp_path: Path) -> Path:
    """A blob with one normal per vertex (f v//v) and a colour on every v line."""
    m = bumpy_blob(2)
    n = vertex_normals(m.vertices, m.faces)
    rgb = (m.vertices - m.vertices.min(0)) / np.ptp(m.vertices, axis=0)
    text = "".join(f"v {a!r} {b!r} {c!r} {r:.3f} {g:.3f} {bb:.3f}\n"
                   for (a, b, c), (r, g, bb) in zip(m.vertices.tolist(), rgb.tolist()))
    text += "".join(f"vn {a:.6f} {b:.6f} {c:.6f}\n" for a, b, c in n.tolist())
    text += "".join(f"f {a}//{a} {b}//{b} {c}//{c}\n" for a, b, c in (m.faces + 1).tolist())
    path = tmp_path / "smooth.obj"
    path.write_text(text)
    return path


def test_smooth_normals_stay_smooth_and_follow_the_surface(tmp_path: Path) -> None:
    path = smooth_obj(tmp_path)
    doc = read_document(path)
    assert doc.colors is not None and doc.normals
    V = bend(doc.mesh.vertices)
    write_document(tmp_path / "out.obj", doc.with_vertices(V))
    lines = (tmp_path / "out.obj").read_bytes().splitlines()
    normals = np.array([[float(x) for x in line.split()[1:]] for line in lines if line.startswith(b"vn ")])
    assert len(normals) == doc.mesh.n_vertices
    assert np.allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-5)
    truth = vertex_normals(V, doc.mesh.faces)
    assert angle_degrees(normals, truth).max() < 0.01
    colours = [line.split()[4:] for line in lines if line.startswith(b"v ")]
    original = [line.split()[4:] for line in path.read_bytes().splitlines() if line.startswith(b"v ")]
    assert colours == original
    assert non_vertex_lines((tmp_path / "out.obj").read_bytes()) == non_vertex_lines(path.read_bytes())


def test_split_corner_normals_stay_split(tmp_path: Path) -> None:
    """A box whose corners use their face's normal (hard edges): still one normal a face."""
    box = trimesh.creation.box(extents=(2.0, 1.0, 1.0))
    box = trimesh.Trimesh(box.vertices, box.faces, process=False)
    box = box.subdivide().subdivide()
    V, F = np.asarray(box.vertices), np.asarray(box.faces)
    fn = np.asarray(box.face_normals)
    text = "".join(f"v {a!r} {b!r} {c!r}\n" for a, b, c in V.tolist())
    text += "".join(f"vn {a:.6f} {b:.6f} {c:.6f}\n" for a, b, c in fn.tolist())
    text += "".join(f"f {a}//{k} {b}//{k} {c}//{k}\n"
                    for k, (a, b, c) in enumerate((F + 1).tolist(), start=1))
    path = tmp_path / "box.obj"
    path.write_text(text)
    doc = read_document(path)
    W = bend(doc.mesh.vertices)
    write_document(tmp_path / "bent.obj", doc.with_vertices(W))
    out = (tmp_path / "bent.obj").read_bytes().splitlines()
    normals = np.array([[float(x) for x in line.split()[1:]] for line in out if line.startswith(b"vn ")])
    assert len(normals) == len(F)  # the index structure is the file's
    bent = trimesh.Trimesh(W, F, process=False)
    assert angle_degrees(normals, np.asarray(bent.face_normals)).max() < 0.01
    untouched = ~np.any(W != V, axis=1)[F].any(axis=1)
    assert np.array_equal(normals[untouched], np.round(fn[untouched], 6))


# --------------------------------------------------------------------------- PLY


def coloured_ply(path: Path, fmt: str) -> Path:
    """Colours, normals, a float property, a face property, an extra element and comments."""
    m = bumpy_blob(2)
    n = len(m.vertices)
    normals = vertex_normals(m.vertices, m.faces)
    vertex = np.empty(n, dtype=[("x", "f4"), ("y", "f4"), ("z", "f4"), ("nx", "f4"), ("ny", "f4"),
                                ("nz", "f4"), ("red", "u1"), ("green", "u1"), ("blue", "u1"),
                                ("alpha", "u1"), ("quality", "f4")])
    for k, name in enumerate("xyz"):
        vertex[name] = m.vertices[:, k]
        vertex["n" + name] = normals[:, k]
    rng = np.random.default_rng(1)
    for name in ("red", "green", "blue", "alpha"):
        vertex[name] = rng.integers(0, 256, n)
    vertex["quality"] = rng.random(n)
    faces = np.empty(len(m.faces), dtype=[("vertex_indices", "i4", (3,)), ("flags", "u2")])
    faces["vertex_indices"] = m.faces
    faces["flags"] = np.arange(len(m.faces)) % 7
    camera = np.array([(1.5, -2.0, 0.25, 35.0)],
                      dtype=[("px", "f8"), ("py", "f8"), ("pz", "f8"), ("fov", "f4")])
    data = plyfile.PlyData(
        [plyfile.PlyElement.describe(vertex, "vertex"),
         plyfile.PlyElement.describe(faces, "face", len_types={"vertex_indices": "u1"}),
         plyfile.PlyElement.describe(camera, "camera")],
        text=fmt == "ascii", byte_order={"ascii": "=", "binary_little_endian": "<",
                                         "binary_big_endian": ">"}[fmt],
        comments=["scanned by hand", "units: metres"], obj_info=["a coloured blob"])
    data.write(str(path))
    return path


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian", "binary_big_endian"])
def test_ply_keeps_every_element_property_and_type(tmp_path: Path, fmt: str) -> None:
    path = coloured_ply(tmp_path / "blob.ply", fmt)
    doc = read_document(path)
    assert doc.colors is not None and doc.normals and "'camera' records" in doc.extras
    write_document(tmp_path / "same.ply", doc)
    assert (tmp_path / "same.ply").read_bytes() == path.read_bytes()  # ASCII too: given back line by line
    V = bend(doc.mesh.vertices)
    write_document(tmp_path / "bent.ply", doc.with_vertices(V))
    a, b = plyfile.PlyData.read(str(path)), plyfile.PlyData.read(str(tmp_path / "bent.ply"))
    assert (b.text, b.byte_order, b.comments, b.obj_info) == (a.text, a.byte_order, a.comments, a.obj_info)
    assert [e.name for e in b.elements] == [e.name for e in a.elements]
    for ea, eb in zip(a.elements, b.elements):
        assert str(eb.header) == str(ea.header)  # names and types
    va, vb = a["vertex"].data, b["vertex"].data
    moved = np.any(V != doc.mesh.vertices, axis=1)
    assert moved.any() and not moved.all()
    for k, name in enumerate("xyz"):
        assert np.array_equal(vb[name], V[:, k].astype(np.float32))
    for name in ("red", "green", "blue", "alpha", "quality"):
        assert np.array_equal(vb[name], va[name])
    assert np.array_equal(b["camera"].data, a["camera"].data)
    assert np.array_equal(np.stack(b["face"].data["vertex_indices"]), np.stack(a["face"].data["vertex_indices"]))
    assert np.array_equal(b["face"].data["flags"], a["face"].data["flags"])
    n = np.column_stack([vb["nx"], vb["ny"], vb["nz"]]).astype(np.float64)
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-5)
    assert angle_degrees(n, vertex_normals(V, doc.mesh.faces)).max() < 0.01
    far = ~moved & ~np.isin(np.arange(len(V)), doc.mesh.faces[moved[doc.mesh.faces].any(axis=1)])
    assert np.array_equal(n[far], np.column_stack([va["nx"], va["ny"], va["nz"]])[far])


def _mapped(a: np.ndarray) -> bool:
    """Whether ``a`` is or sees a memory mapping (of the file it was read from)."""
    while a is not None:
        if isinstance(a, np.memmap) or type(a).__name__ == "mmap":
            return True
        a = getattr(a, "base", None)
    return False


@pytest.mark.parametrize("order", ["<", ">"])
@pytest.mark.parametrize("index", ["i4", "u4", "u2"])
@pytest.mark.parametrize("coords", ["f8", "f4"])
def test_binary_ply_triangles_read_off_the_mapping_and_written_back_the_same(tmp_path: Path, order: str,
                                                                            index: str, coords: str) -> None:
    # a binary file of triangles only (and x y z only) is read straight off its mapping: the same
    # triangles and positions as plyfile's own record-by-record read, nothing left mapped, and
    # written back byte for byte (the index type, count type and byte order kept)
    m = bumpy_blob(2)
    vertex = np.empty(m.n_vertices, dtype=[(a, order + coords) for a in "xyz"])
    for k, a in enumerate("xyz"):
        vertex[a] = m.vertices[:, k]
    faces = np.empty(len(m.faces), dtype=[("vertex_indices", order + index, (3,))])
    faces["vertex_indices"] = m.faces[:, ::-1]
    path = tmp_path / "tri.ply"
    plyfile.PlyData([plyfile.PlyElement.describe(vertex, "vertex"),
                     plyfile.PlyElement.describe(faces, "face", len_types={"vertex_indices": "u1"})],
                    byte_order=order).write(str(path))
    ref = plyfile.PlyData.read(str(path))  # (no known list length: plyfile's record loop)
    doc = read_document(path)
    assert np.array_equal(doc.mesh.faces, np.stack(ref["face"].data["vertex_indices"]).astype(np.int64))
    assert np.array_equal(doc.mesh.vertices, np.column_stack([ref["vertex"].data[a] for a in "xyz"]))
    assert doc.mesh.faces.dtype == np.int64 and doc.mesh.vertices.dtype == np.float64
    assert not _mapped(doc.mesh.faces) and not _mapped(doc.mesh.vertices)
    assert not any(_mapped(el.data) for el in doc.native.data.elements)
    write_document(tmp_path / "same.ply", doc)
    assert (tmp_path / "same.ply").read_bytes() == path.read_bytes()
    V = bend(doc.mesh.vertices)
    write_document(tmp_path / "bent.ply", doc.with_vertices(V))
    back = read_document(tmp_path / "bent.ply")
    assert np.array_equal(back.mesh.faces, doc.mesh.faces)
    assert np.array_equal(back.mesh.vertices, V.astype(coords).astype(np.float64))
    assert np.array_equal(doc.mesh.vertices, read_document(path).mesh.vertices)  # (the read pose kept)
    header = path.read_bytes().split(b"end_header")[0]
    assert (tmp_path / "bent.ply").read_bytes().split(b"end_header")[0] == header


def test_ply_polygons_and_strips_round_trip(tmp_path: Path) -> None:
    head = ("ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\n"
            "property float z\nelement face 2\nproperty list uchar int vertex_indices\n"
            "element tristrips 1\nproperty list int int vertex_indices\nend_header\n")
    body = "0 0 0\n1 0 0\n1 1 0\n0 1 0\n0.5 0.5 1\n4 0 1 2 3\n3 0 1 4\n4 1 2 4 3\n"
    (tmp_path / "p.ply").write_text(head + body)
    doc = read_document(tmp_path / "p.ply")
    V = doc.mesh.vertices + np.array([[0, 0, 0]] * 4 + [[0, 0, 0.5]])
    write_document(tmp_path / "q.ply", doc.with_vertices(V))
    back = read_document(tmp_path / "q.ply")
    assert np.array_equal(back.mesh.faces, doc.mesh.faces)
    assert np.array_equal(back.mesh.vertices, V)
    data = plyfile.PlyData.read(str(tmp_path / "q.ply"))
    assert [len(f) for f in data["face"].data["vertex_indices"]] == [4, 3]
    assert list(data["tristrips"].data["vertex_indices"][0]) == [1, 2, 4, 3]


# --------------------------------------------------------------------------- OFF and STL


def test_off_keeps_colours_polygons_and_comments(tmp_path: Path) -> None:
    text = ("COFF\n# a house\n5 2 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n1 1 0 0 0 255 255\n"
            "0 1 0 9 9 9 255  # corner\n0.5 0.5 1 1 2 3 255\n4 0 1 2 3 200 10 10\n3 0 1 4\n")
    (tmp_path / "h.off").write_text(text)
    doc = read_document(tmp_path / "h.off")
    assert doc.colors is not None and np.allclose(doc.colors[0], [1, 0, 0, 1])
    write_document(tmp_path / "same.off", doc)
    assert (tmp_path / "same.off").read_text() == text
    V = doc.mesh.vertices.copy()
    V[3] += [0.25, 0, 0]
    write_document(tmp_path / "moved.off", doc.with_vertices(V))
    out = (tmp_path / "moved.off").read_text().splitlines()
    assert out[6] == "0.25 1.0 0.0 9 9 9 255 # corner"
    assert [line for i, line in enumerate(out) if i != 6] == [
        line for i, line in enumerate(text.splitlines()) if i != 6]
    assert np.array_equal(read_mesh(tmp_path / "moved.off").vertices, V)


@pytest.mark.parametrize("kind", ["binary", "ascii"])
def test_stl_round_trip(tmp_path: Path, kind: str) -> None:
    m = icosphere(2)
    tm = trimesh.Trimesh(m.vertices, m.faces, process=False)
    path = tmp_path / "s.stl"
    path.write_bytes(trimesh.exchange.stl.export_stl(tm) if kind == "binary"
                     else trimesh.exchange.stl.export_stl_ascii(tm).encode())
    doc = read_document(path)
    write_document(tmp_path / "same.stl", doc)
    if kind == "binary":
        assert (tmp_path / "same.stl").read_bytes() == path.read_bytes()
    else:
        assert (tmp_path / "same.stl").read_bytes().startswith(b"solid")
    V = bend(doc.mesh.vertices)
    write_document(tmp_path / "bent.stl", doc.with_vertices(V))
    back = read_mesh(tmp_path / "bent.stl")
    expect = V.astype(np.float32).astype(np.float64) if kind == "binary" else V
    assert np.array_equal(back.vertices[back.faces], expect[doc.mesh.faces])


# --------------------------------------------------------------------------- glTF binary


def _accessor(gltf: pygltflib.GLTF2, index: int) -> np.ndarray:
    acc = gltf.accessors[index]
    view = gltf.bufferViews[acc.bufferView]
    comps = {"VEC2": 2, "VEC3": 3}[acc.type]
    start = (view.byteOffset or 0) + (acc.byteOffset or 0)
    return np.frombuffer(gltf.binary_blob(), "<f4", acc.count * comps, start).reshape(-1, comps)


def test_glb_keeps_uvs_material_and_texture(tmp_path: Path) -> None:
    path = textured_glb(tmp_path / "ball.glb")
    doc = read_document(path)
    assert doc.extras["materials"] == 1 and doc.extras["embedded images"] == 1
    write_document(tmp_path / "same.glb", doc)
    a = pygltflib.GLTF2.load(str(path))
    same = pygltflib.GLTF2.load(str(tmp_path / "same.glb"))
    assert same.binary_blob() == a.binary_blob()
    V = bend(doc.mesh.vertices - [0, 0, 2]) + [0, 0, 2]
    write_document(tmp_path / "bent.glb", doc.with_vertices(V))
    b = pygltflib.GLTF2.load(str(tmp_path / "bent.glb"))
    assert len(b.images) == len(a.images) and len(b.materials) == len(a.materials)
    prim_a, prim_b = a.meshes[0].primitives[0], b.meshes[0].primitives[0]
    assert np.array_equal(_accessor(b, prim_b.attributes.TEXCOORD_0), _accessor(a, prim_a.attributes.TEXCOORD_0))
    image = lambda g: g.binary_blob()[g.bufferViews[g.images[0].bufferView].byteOffset or 0:][
        :g.bufferViews[g.images[0].bufferView].byteLength]
    assert image(b) == image(a)
    back = read_document(tmp_path / "bent.glb")
    assert np.allclose(back.mesh.vertices, V, atol=1e-6)
    assert np.array_equal(back.mesh.faces, doc.mesh.faces)
    assert prim_a.attributes.NORMAL is not None and prim_b.attributes.NORMAL is not None
    n = _accessor(b, prim_b.attributes.NORMAL).astype(np.float64)
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-5)
    truth = vertex_normals(V, doc.mesh.faces)[back.native.file_vertex]
    assert np.percentile(angle_degrees(n, truth), 99) < 3.0
    assert not np.allclose(n, _accessor(a, prim_a.attributes.NORMAL), atol=1e-3)  # they were rewritten


def test_any_document_converts_to_glb_with_normals_and_colours(tmp_path: Path) -> None:
    s = trimesh.creation.icosphere(subdivisions=2)
    rgb = (np.random.default_rng(3).random((len(s.vertices), 3)) * 255).astype(np.uint8)
    lines = [f"v {x:.6f} {y:.6f} {z:.6f} {r / 255:.6f} {g / 255:.6f} {b / 255:.6f}"
             for (x, y, z), (r, g, b) in zip(s.vertices, rgb)]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in s.faces]
    src = tmp_path / "ball.obj"
    src.write_text("\n".join(lines) + "\n")
    doc = read_document(src)
    V = bend(doc.mesh.vertices)
    notes = write_document(tmp_path / "ball.glb", doc.with_vertices(V))
    assert notes == []  # positions, triangles and colours: a .glb holds them all
    back = read_document(tmp_path / "ball.glb")
    assert np.allclose(back.mesh.vertices, V, atol=1e-6)
    assert np.array_equal(back.mesh.faces, doc.mesh.faces)
    assert np.allclose(back.colors[:, :3] * 255, rgb, atol=1.0)
    gltf = pygltflib.GLTF2.load(str(tmp_path / "ball.glb"))
    n = _accessor(gltf, gltf.meshes[0].primitives[0].attributes.NORMAL).astype(np.float64)
    assert np.percentile(angle_degrees(n, vertex_normals(V, doc.mesh.faces)), 99) < 1e-3


def every_byte_ply(path: Path) -> tuple[Path, np.ndarray]:
    """A sphere (642 vertices) whose RGBA bytes take every value 0..255 in each channel; and them, (n, 4)."""
    m = icosphere(3)
    k = np.arange(m.n_vertices)
    rgba = np.column_stack([k % 256, (7 * k + 3) % 256, 255 - k % 256, (11 * k) % 256]).astype(np.uint8)
    vertex = np.empty(m.n_vertices, dtype=[("x", "f4"), ("y", "f4"), ("z", "f4"), ("red", "u1"), ("green", "u1"),
                                            ("blue", "u1"), ("alpha", "u1")])
    for j, axis in enumerate("xyz"):
        vertex[axis] = m.vertices[:, j]
    for j, channel in enumerate(["red", "green", "blue", "alpha"]):
        vertex[channel] = rgba[:, j]
    face = np.empty(m.n_faces, dtype=[("vertex_indices", "i4", (3,))])
    face["vertex_indices"] = m.faces
    plyfile.PlyData([plyfile.PlyElement.describe(vertex, "vertex"),
                     plyfile.PlyElement.describe(face, "face")]).write(str(path))
    return path, rgba


def color_0(path: Path) -> tuple[np.ndarray, bytes]:
    """The first primitive's COLOR_0 of a .glb: its values as stored (normalized integers over their
    maximum) and its bytes."""
    gltf = pygltflib.GLTF2.load(str(path))
    acc = gltf.accessors[gltf.meshes[0].primitives[0].attributes.COLOR_0]
    view = gltf.bufferViews[acc.bufferView]
    dtype = {pygltflib.FLOAT: "<f4", pygltflib.UNSIGNED_BYTE: "u1"}[acc.componentType]
    comps = {"VEC3": 3, "VEC4": 4}[acc.type]
    start = (view.byteOffset or 0) + (acc.byteOffset or 0)
    size = np.dtype(dtype).itemsize * comps * acc.count
    assert view.byteStride in (None, np.dtype(dtype).itemsize * comps)
    raw = gltf.binary_blob()[start: start + size]
    values = np.frombuffer(raw, dtype).reshape(-1, comps).astype(np.float64)
    return (values / 255 if dtype == "u1" else values), raw


def test_ply_byte_colours_are_linear_in_the_glb_and_come_back_as_the_same_bytes(tmp_path: Path) -> None:
    """glTF's COLOR_0 is linear, a PLY's bytes display (sRGB) values: the .glb holds them decoded
    (alpha as it is), and PLY -> GLB -> PLY gives every byte back."""
    source, rgba = every_byte_ply(tmp_path / "ball.ply")
    doc = read_document(source)
    write_document(tmp_path / "ball.glb", doc)
    stored, _ = color_0(tmp_path / "ball.glb")
    assert np.array_equal(stored, srgb_to_linear(rgba / 255).astype(np.float32))
    assert np.array_equal(stored[:, 3], (rgba[:, 3] / 255).astype(np.float32))
    mid = np.flatnonzero(rgba[:, 0] == 128)[0]  # 128/255 shown is 21.6% of the light
    assert abs(stored[mid, 0] - 0.2158605) < 1e-6
    glb = read_document(tmp_path / "ball.glb")
    assert np.array_equal(np.rint(glb.colors * 255), rgba)
    write_document(tmp_path / "back.ply", glb)
    vertex = plyfile.PlyData.read(str(tmp_path / "back.ply"))["vertex"].data
    back = np.column_stack([vertex[c] for c in ("red", "green", "blue", "alpha")])
    assert back.dtype == np.uint8 and np.array_equal(back, rgba)


@pytest.mark.parametrize("maker", ["hybridedit", "trimesh"])
def test_a_glb_written_back_keeps_its_colour_bytes(tmp_path: Path, maker: str) -> None:
    """A .glb's own COLOR_0 (float from a PLY conversion, or normalized bytes from trimesh) is decoded for
    the document once and never encoded again: an edited file written back has the same bytes there."""
    if maker == "hybridedit":
        write_document(tmp_path / "ball.glb", read_document(every_byte_ply(tmp_path / "ball.ply")[0]))
    else:
        s = trimesh.creation.icosphere(subdivisions=2)
        s.visual.vertex_colors = (np.random.default_rng(2).random((len(s.vertices), 4)) * 255).astype(np.uint8)
        (tmp_path / "ball.glb").write_bytes(s.export(file_type="glb"))
    linear, raw = color_0(tmp_path / "ball.glb")
    doc = read_document(tmp_path / "ball.glb")
    file_first = doc.native.file_vertex  # (each engine vertex's colour is its first file vertex's)
    first = np.full(doc.mesh.n_vertices, len(file_first))
    np.minimum.at(first, file_first, np.arange(len(file_first)))
    np.testing.assert_allclose(doc.colors, linear_to_srgb(linear[first]), rtol=0, atol=1e-12)
    V = bend(doc.mesh.vertices)
    assert np.any(V != doc.mesh.vertices)
    write_document(tmp_path / "edited.glb", doc.with_vertices(V))
    assert color_0(tmp_path / "edited.glb")[1] == raw
    again = read_document(tmp_path / "edited.glb")
    assert np.array_equal(again.colors, doc.colors)
    assert np.abs(again.mesh.vertices - V).max() < 1e-6  # (the edit is there)


# --------------------------------------------------------------------------- progress


def _progress_log():
    seen = []
    return seen, lambda step, fraction: seen.append((step, fraction))


def test_reading_and_writing_an_obj_report_their_progress(tmp_path: Path, monkeypatch) -> None:
    from hybridedit.fileio.formats import common

    monkeypatch.setattr(common, "_ROWS_PER_CHUNK", 500)  # several chunks for a small mesh
    mesh = bumpy_blob(4)
    path = tmp_path / "blob.obj"
    seen, progress = _progress_log()
    write_document(path, read_document(_write_plain(tmp_path, mesh)), progress=progress)
    steps = {s for s, _ in seen}
    assert steps == {"writing blob.obj"}
    fractions = [f for _, f in seen]
    assert fractions[0] == 0.0 and fractions[-1] == 1.0 and fractions == sorted(fractions)
    assert len([f for f in fractions if 0.0 < f < 1.0]) >= 5  # chunk by chunk
    seen.clear()
    doc = read_document(path, progress=progress)
    assert np.allclose(doc.mesh.vertices, mesh.vertices)
    fractions = [f for s, f in seen if s == "reading blob.obj"]
    assert fractions[0] == 0.0 and fractions[-1] == 1.0 and fractions == sorted(fractions)
    assert any(0.0 < f < 1.0 for f in fractions)
    # an OBJ written in its own structure (its moved vertices' lines rewritten) reports too
    from hybridedit.fileio.formats import obj

    monkeypatch.setattr(obj, "_ROWS_PER_CHUNK", 300)
    seen.clear()
    write_document(tmp_path / "moved.obj", doc.with_vertices(doc.mesh.vertices * 1.5), progress=progress)
    fractions = [f for _, f in seen]
    assert fractions[0] == 0.0 and fractions[-1] == 1.0 and fractions == sorted(fractions)
    assert len([f for f in fractions if 0.0 < f < 0.6]) >= 5


def _write_plain(folder: Path, mesh) -> Path:
    from hybridedit.fileio.meshfiles import write_mesh

    p = folder / "plain.ply"
    write_mesh(p, mesh)
    return p


def test_a_cancelled_write_leaves_the_target_as_it_was(tmp_path: Path) -> None:
    mesh = bumpy_blob(3)
    path = tmp_path / "kept.obj"
    path.write_bytes(b"# the old file\n")

    class Cancelled(Exception):
        pass

    def cancel(step, fraction):
        if fraction > 0.0:
            raise Cancelled

    with pytest.raises(Cancelled):
        write_document(path, read_document(_write_plain(tmp_path, mesh)), progress=cancel)
    assert path.read_bytes() == b"# the old file\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["kept.obj", "plain.ply"]  # no stray temporary


@pytest.mark.parametrize("text", [b"", b"   ", b"v 1 2 3\nf 1 2 3", b"\tv 1\x0b2\x0c3\r\n  f 1 2 3 \n",
                                  b"a\x01b c", bytes(range(1, 128)) * 3])
def test_token_count_agrees_with_bytes_split(text: bytes) -> None:
    from hybridedit.fileio.formats.common import _token_count

    assert _token_count(text) == len(text.split())


def test_an_ascii_stl_with_a_word_for_a_coordinate_is_refused_in_one_line(tmp_path):
    from hybridedit.fileio.meshfiles import MeshFileError, read_mesh

    p = tmp_path / "bad.stl"
    p.write_text("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 zz\nvertex 1 0 0\nvertex 0 1 0\n"
                 "endloop\nendfacet\nendsolid x\n")
    with pytest.raises(MeshFileError) as err:
        read_mesh(p)
    assert "bad.stl" in str(err.value) and "vertex 0 0 zz" in str(err.value) and "\n" not in str(err.value)


# --------------------------------------------------------------------------- OBJ: compiled scans

#: lines an OBJ reader meets, odd ones included: tabs, \v and \f, indentation, comments between
#: vertices, relative indices, v/t/n corners, texture lines written three ways
ODD_OBJ_LINES = [
    "# made by hand", "mtllib a.mtl", "o thing", "", "v 0 0 0", "v\t1 0 0", "  v 1 1 0", "\tv 0 1 0 1.0",
    "# between vertices", "v +0.5 -2.5e-1 1e0", "vt 0 0", "vt\t1 0", "vt", "vn 0 0 1", "vn 0 1 0", "g group",
    "s 1", "usemtl red", "f 1/1/1 2/2/1 3/3/1 4/1/2", "f -5//1 -4//2 -1//-1", "f 2/1 3/1 5/1",
    " f\t1 2 3 ", "f 1/2/ 2// 3/1", "\x0cv 3 3 3", "l 1 2", "f +1 02 3",
]


def _scan_cases() -> list[bytes]:
    body = ODD_OBJ_LINES
    return [("\n".join(body) + "\n").encode(), ("\r\n".join(body)).encode(), ("\r".join(body) + "\r").encode(),
            "".join(line + ["\n", "\r\n", "\r"][i % 3] for i, line in enumerate(body)).encode(),
            b"", b"\n", b"\r\n\r\n", b"x", b"\n\nv 1 2 3", b"\r\n\n\r\r"]


def _reference_kinds(lines: list[bytes]) -> list[int]:
    """The kind of each line (stripped when the file is indented), as the reader found them in
    Python before (its three first bytes, in numpy); ``vt``: the first word is vt."""
    from hybridedit.fileio.formats.text_scan import BLANK, COMMENT, F, OTHER, V, VN, VT

    head = np.array([line[:3] for line in lines], dtype="S3").view(np.uint8).reshape(-1, 3)
    ws1 = (head[:, 1] == 32) | (head[:, 1] == 9)
    ws2 = (head[:, 2] == 32) | (head[:, 2] == 9)
    kinds = np.full(len(lines), OTHER, dtype=np.int8)
    kinds[head[:, 0] == 0] = BLANK
    kinds[head[:, 0] == ord("#")] = COMMENT
    v = head[:, 0] == ord("v")
    kinds[v & ws1] = V
    kinds[v & (head[:, 1] == ord("n")) & ws2] = VN
    kinds[(head[:, 0] == ord("f")) & ws1] = F
    kinds[[line[:2] == b"vt" and line.split()[0] == b"vt" for line in lines]] = VT
    return kinds.tolist()


@pytest.mark.parametrize("case", range(len(_scan_cases()) + 1))
def test_line_spans_cut_lines_as_splitlines(case: int) -> None:
    from hybridedit.fileio.formats.text_scan import CR, CRLF, LF, line_spans

    data = _scan_cases()[case] if case < len(_scan_cases()) else b"v 1 2 3\n\x0bv 1 2 3\n\x0cf 1 2 3\n\x0bvt 1 2\n"
    starts, ends, heads, kinds, endings, indented = line_spans(np.frombuffer(data, dtype=np.uint8))
    lines = data.splitlines()
    assert [data[a:b] for a, b in zip(starts.tolist(), ends.tolist())] == lines
    assert indented == any(line[:1] in (b" ", b"\t") for line in lines)
    read = [line.lstrip() for line in lines] if indented else lines  # (\v and \f: no indentation)
    assert [data[a:b] for a, b in zip(heads.tolist(), ends.tolist())] == read
    assert kinds.tolist() == _reference_kinds(read)
    ends_kept = data.splitlines(keepends=True)
    assert endings[CRLF] == sum(line.endswith(b"\r\n") for line in ends_kept)
    assert endings[CR] == sum(line.endswith(b"\r") for line in ends_kept)
    assert endings[LF] == sum(line.endswith(b"\n") and not line.endswith(b"\r\n") for line in ends_kept)


def test_line_spans_grow_past_their_estimate() -> None:
    """The arrays are sized from the first MiB's lines; a file with more lines after it gets them all."""
    from hybridedit.fileio.formats.text_scan import line_spans

    data = b"# " + b"x" * (1 << 20) + b"\n" + b"v 1 2 3\n" * 5000
    starts, ends, heads, kinds, _, _ = line_spans(np.frombuffer(data, dtype=np.uint8))
    assert len(starts) == len(kinds) == 5001 and ends[-1] == len(data) - 1


def _face_lines(lines: list[str]) -> tuple[bytes, np.ndarray, np.ndarray]:
    data = "\n".join(lines).encode()
    starts, ends = [], []
    at = 0
    for line in lines:
        starts.append(at + 1)  # after the "f"
        ends.append(at + len(line))
        at += len(line) + 1
    return data, np.array(starts, dtype=np.int64), np.array(ends, dtype=np.int64)


@pytest.mark.parametrize("want_normals", [False, True])
def test_face_corners_match_the_python_reading(want_normals: bool) -> None:
    from hybridedit.fileio.formats.obj import _corner_normal_refs, _obj_corners
    from hybridedit.fileio.formats.text_scan import face_corners

    lines = ["f 1 2 3", "f\t1/1/1 2/2/1 3/3/1 4/1/2", "f -5//1 -4//2 -1//-1 ", "f 2/1 3/1 5/1",
             "f +1 02 3", "f 1/2/ 2// 3/1", "f 123456789012345678 1 -1", "f", "f 7 8\x0b9\x0c10"]
    data, lo, hi = _face_lines(lines)
    counts, idx, refs = face_corners(np.frombuffer(data, dtype=np.uint8), lo, hi, want_normals)
    flines = [line.encode() for line in lines]
    old_counts, old_idx = _obj_corners(flines, np.arange(len(lines)))
    assert counts.tolist() == old_counts.tolist() and idx.tolist() == old_idx.tolist()
    if want_normals:
        assert refs.tolist() == _corner_normal_refs(flines, len(idx)).tolist()
    else:
        assert refs is None


def test_face_corners_grow_past_room_for_triangles() -> None:
    """Room is made for triangles; polygons grow it, and the arrays hold just the corners."""
    from hybridedit.fileio.formats.text_scan import face_corners

    lines = [f"f {i + 1}//1 {i + 2}//2 {i + 3}//3 {i + 4}//4 {i + 5}//5" for i in range(2000)] + ["f 1//1 2//2 3//3"]
    data, lo, hi = _face_lines(lines)
    counts, idx, refs = face_corners(np.frombuffer(data, dtype=np.uint8), lo, hi, True)
    assert counts.tolist() == [5] * 2000 + [3] and len(idx) == len(refs) == 10003
    assert idx[:5].tolist() == [1, 2, 3, 4, 5] and idx[-8:].tolist() == [2000, 2001, 2002, 2003, 2004, 1, 2, 3]
    assert refs[:5].tolist() == [1, 2, 3, 4, 5] and refs[-3:].tolist() == [1, 2, 3]


@pytest.mark.parametrize("line", ["f 1 2 x", "f /1 2 3", "f 1.0 2 3", "f 1_0 2 3", "f 1 2 3#c",
                                  "f 1234567890123456789 2 3", "f - 2 3", "f 1/2/3/4 2 3", "f 1//x 2 3"])
def test_face_corners_leave_uncommon_lines_to_python(line: str) -> None:
    """A line not in the common form is found (the reader then takes the Python path, which names
    the problem): the normal part only when normals are read."""
    from hybridedit.fileio.formats.text_scan import face_corners

    data, lo, hi = _face_lines(["f 1 2 3", line])
    got = face_corners(np.frombuffer(data, dtype=np.uint8), lo, hi, True)
    assert got == 1
    if line in ("f 1/2/3/4 2 3", "f 1//x 2 3"):  # normals not read: the part after the vertex is skipped
        counts, idx, refs = face_corners(np.frombuffer(data, dtype=np.uint8), lo, hi, False)
        assert idx.tolist() == [1, 2, 3, 1, 2, 3] and refs is None


def test_gathered_text_parses_like_the_joined_lines() -> None:
    """gather is ``b"\\n".join`` of the pieces, and ends in a NUL that stops np.fromstring: without
    it, the parser read the bytes after the text and lost its last number."""
    from hybridedit.fileio.formats.common import _numbers
    from hybridedit.fileio.formats.text_scan import gather

    data = b"v 0.1 2 3.5e0\r\nv\t4 5 6\n# no\nv 7 8 0.25999"
    b = np.frombuffer(data, dtype=np.uint8)
    lo, hi = np.array([1, 16, 29]), np.array([13, 22, 38])  # (the last piece stops inside 0.25999)
    text = gather(b, lo, hi)
    assert text.tobytes() == b"\n".join(data[a:z] for a, z in zip(lo, hi)) == b" 0.1 2 3.5e0\n\t4 5 6\n 7 8 0.25"
    assert _numbers(text, np.float64, 9).tolist() == [0.1, 2, 3.5, 4, 5, 6, 7, 8, 0.25]


def _odd_obj(tmp_path: Path, newline: str, final: bool) -> Path:
    lines = ["# odd", "mtllib a.mtl", "v 0 0 0", "v\t1 0 0", "# between", "v 1 1 0", "v 0 1 0",
             "  v 0.5 0.5 1", "vt 0 0", "vt 1 0", "vn 0 0 1", "vn 0 0 -1", "usemtl red",
             "f 1/1/1 2/2/1 3/1/1", "f -5//1 -2//1 -1//1", "\tf 1 3 4", "f 2/2/2 3/2/2 5/1/2 \\", "",
             "g end"]
    text = newline.join(lines) + (newline if final else "")
    path = tmp_path / f"odd{len(newline)}{int(final)}.obj"
    path.write_bytes(text.encode())
    return path


@pytest.mark.parametrize("newline,final", [("\n", True), ("\r\n", False), ("\r", True), ("\n", False)])
def test_obj_compiled_reading_matches_the_python_path(tmp_path: Path, monkeypatch, newline: str,
                                                      final: bool) -> None:
    """The compiled face reading gives what the Python path gives (forced here by a kernel that
    finds every file uncommon), and writing the document back is the same either way."""
    from hybridedit.fileio.formats import obj

    path = _odd_obj(tmp_path, newline, final)
    fast = read_document(path)
    with monkeypatch.context() as m:
        m.setattr(obj, "face_corners", lambda *args: 0)
        slow = read_document(path)
    assert np.array_equal(fast.mesh.vertices, slow.mesh.vertices)
    assert np.array_equal(fast.mesh.faces, slow.mesh.faces)
    assert np.array_equal(fast.native.corner_vn, slow.native.corner_vn)
    assert fast.extras == slow.extras == {"material libraries": 1, "texture coordinates": 2,
                                          "material references": 1, "group names": 1}
    assert path.read_bytes().replace(b"\\" + newline.encode(), b" ") == obj.write(fast)  # untouched: as read
    V = bend(fast.mesh.vertices) + 0.25
    assert obj.write(fast.with_vertices(V)) == obj.write(slow.with_vertices(V))


@pytest.mark.parametrize("text", [b"a\nb\nc\n", b"a\r\nb\r\nc", b"a\rb\rc\r", b"a\nb\r\nc\n", b"a\r\rb\n\nc"])
def test_file_lines_join_like_the_list_of_lines(text: bytes) -> None:
    """FileLines.joined (the text between replaced lines kept as it is) is the list of lines with
    the replacements and insertion, joined by the file's newline."""
    from hybridedit.fileio.formats.obj import FileLines
    from hybridedit.fileio.formats.text_scan import CR, CRLF, LF, line_spans

    starts, ends, _, _, endings, _ = line_spans(np.frombuffer(text, dtype=np.uint8))
    newline = b"\r\n" if b"\r\n" in text else (b"\r" if b"\n" not in text else b"\n")
    kind = {b"\n": LF, b"\r": CR, b"\r\n": CRLF}[newline]
    lines = FileLines(text, starts, ends, newline, int(endings.sum()) == int(endings[kind]))
    final = text[-1:] in (b"\n", b"\r")
    for new, at, added in [({}, 1, []), ({0: b"A", 2: b"C"}, 1, []), ({1: b"B"}, 2, [b"x", b"y"]),
                           ({}, len(lines), [b"z"]), ({len(lines) - 1: b"L"}, len(lines), [b"z"])]:
        out = text.splitlines()
        for i, line in new.items():
            out[i] = line
        out[at:at] = added
        expected = newline.join(out) + (newline if final else b"")
        rows = np.array(sorted(new), dtype=np.int64)
        assert lines.joined(rows, [new[i] for i in rows.tolist()], at, added, final) == expected


@pytest.mark.parametrize("name, text, says", [
    ("a.obj", b"v 0 0 0\nv 1 0 0 0.5\nv 0 1 x\nf 1 2 3\n", "line 3: cannot read vertex coordinates 'v 0 1 x'"),
    ("b.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 z\n", "line 5: cannot read face indices 'f 1 2 z'"),
    ("c.off", b"OFF\n3 1 0\n0 0 0\n1 0 0 7\n0 q 0\n3 0 1 2\n", "line 5: cannot read vertex coordinates '0 q 0'"),
])
def test_the_text_formats_slow_path_names_the_line_that_is_not_numbers(tmp_path, name, text, says):
    """Rows of different widths leave the compiled reader for the one slow path OBJ and OFF share
    (common._token_rows), which names the first bad line."""
    from hybridedit.fileio.formats.common import MeshFileError

    (tmp_path / name).write_bytes(text)
    with pytest.raises(MeshFileError, match=f"{name}: {says}"):
        read_mesh(tmp_path / name)
    good = text.replace(b" x", b" 0").replace(b" z", b" 3").replace(b" q", b" 1")
    (tmp_path / name).write_bytes(good)
    assert read_mesh(tmp_path / name).vertices.tolist() == [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
