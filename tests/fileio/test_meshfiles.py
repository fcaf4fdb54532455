"""Tests for hybridedit.fileio.meshfiles (mesh file reading/writing) and hybridedit.fileio.atomic."""

from __future__ import annotations

import errno
import os
import stat
import struct
import tempfile
from pathlib import Path

import numpy as np
import pytest

from hybridedit.fileio import atomic
from hybridedit.fileio.formats import common
from hybridedit.fileio.atomic import WriteError, atomic_write
from hybridedit.fileio.meshfiles import MeshFileError, read_mesh, write_mesh
from hybridedit.core.mesh import Mesh, MeshError

from shapes import SHARED_MESHES

ARMADILLO = SHARED_MESHES / "armadillo43k.obj"


# --------------------------------------------------------------------------- fixtures


def icosphere(subdivisions: int = 1) -> Mesh:
    """A closed, consistently oriented (outward) unit icosphere."""
    t = (1 + 5 ** 0.5) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
         (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
         (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
         (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    verts = [np.array(p, dtype=float) / np.linalg.norm(p) for p in v]
    faces = list(f)
    for _ in range(subdivisions):
        midpoint: dict[tuple[int, int], int] = {}

        def mid(a: int, b: int) -> int:
            key = (min(a, b), max(a, b))
            if key not in midpoint:
                p = verts[a] + verts[b]
                verts.append(p / np.linalg.norm(p))
                midpoint[key] = len(verts) - 1
            return midpoint[key]

        new = []
        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            new += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = new
    return Mesh(np.array(verts), np.array(faces), name="icosphere")


@pytest.fixture
def sphere() -> Mesh:
    """Icosphere with awkward float64 coordinates (not representable in few digits)."""
    m = icosphere(2)
    rng = np.random.default_rng(7)
    v = m.vertices * (1 + rng.uniform(-1e-3, 1e-3, size=(len(m.vertices), 1)))
    v[0] = [-0.0, 1e-300, 123456789.123456789]  # signed zero, tiny and large values
    return Mesh(v, m.faces, name="sphere")


def first_occurrence_order(mesh: Mesh) -> Mesh:
    """Renumber vertices in order of first use by the faces (the order STL gives back)."""
    _, first = np.unique(mesh.faces.ravel(), return_index=True)
    order = mesh.faces.ravel()[np.sort(first)]
    new_index = np.empty(mesh.n_vertices, dtype=np.int64)
    new_index[order] = np.arange(len(order))
    return Mesh(mesh.vertices[order], new_index[mesh.faces], name=mesh.name)


def write_bytes(path: Path, data: bytes | str) -> Path:
    path.write_bytes(data.encode() if isinstance(data, str) else data)
    return path


def assert_same(mesh: Mesh, vertices, faces) -> None:
    np.testing.assert_array_equal(mesh.vertices, np.asarray(vertices, dtype=float))
    np.testing.assert_array_equal(mesh.faces, np.asarray(faces))
    assert mesh.vertices.dtype == np.float64 and mesh.faces.dtype == np.int64


def read_error(path: Path) -> str:
    with pytest.raises(MeshFileError) as info:
        read_mesh(path)
    message = str(info.value)
    assert message.startswith(path.name + ":"), message
    return message


# --------------------------------------------------------------------------- round trips


@pytest.mark.parametrize("ext", [".obj", ".ply", ".off", ".OBJ", ".Ply"])
def test_round_trip_is_exact(tmp_path: Path, sphere: Mesh, ext: str) -> None:
    path = tmp_path / f"out{ext}"
    write_mesh(path, sphere)
    back = read_mesh(path)
    assert back.name == path.name
    assert np.array_equal(back.vertices, sphere.vertices)  # bit-exact, order kept
    assert np.signbit(back.vertices[0, 0])  # even -0.0 survives
    assert np.array_equal(back.faces, sphere.faces)


def test_stl_round_trip_float32_and_first_use_order(tmp_path: Path, sphere: Mesh) -> None:
    mesh = first_occurrence_order(sphere)
    write_mesh(tmp_path / "out.stl", mesh)
    back = read_mesh(tmp_path / "out.stl")
    assert np.array_equal(back.vertices, mesh.vertices.astype(np.float32).astype(np.float64))
    assert np.array_equal(back.faces, mesh.faces)


def test_stl_welds_to_the_same_triangles_in_any_order(tmp_path: Path, sphere: Mesh) -> None:
    write_mesh(tmp_path / "out.stl", sphere)
    back = read_mesh(tmp_path / "out.stl")
    assert back.n_vertices == sphere.n_vertices and back.n_faces == sphere.n_faces
    expected = sphere.vertices.astype(np.float32).astype(np.float64)[sphere.faces]
    assert np.array_equal(back.vertices[back.faces], expected)


def test_binary_stl_normals_and_header(tmp_path: Path) -> None:
    mesh = Mesh(np.array([[0, 0, 0], [2, 0, 0], [0, 3, 0], [1, 1, 1.0]]),
                np.array([[0, 1, 2], [0, 1, 1]]))
    write_mesh(tmp_path / "n.stl", mesh)
    data = (tmp_path / "n.stl").read_bytes()
    assert len(data) == 84 + 50 * 2 and not data.startswith(b"solid")
    assert struct.unpack_from("<I", data, 80) == (2,)
    assert struct.unpack_from("<3f", data, 84) == (0.0, 0.0, 1.0)
    assert struct.unpack_from("<3f", data, 84 + 50) == (0.0, 0.0, 0.0)  # degenerate


def test_written_ply_header_and_obj_text(tmp_path: Path) -> None:
    mesh = Mesh(np.array([[0.1, 0.2, 0.3], [1, 0, 0], [0, 1, 0.0]]), np.array([[0, 1, 2]]))
    write_mesh(tmp_path / "t.ply", mesh)
    head = (tmp_path / "t.ply").read_bytes().split(b"end_header\n")[0].decode()
    assert "format binary_little_endian 1.0" in head
    assert "property double x" in head and "property list uchar int vertex_indices" in head
    write_mesh(tmp_path / "t.obj", mesh)
    lines = (tmp_path / "t.obj").read_text().splitlines()
    assert "v 0.1 0.2 0.3" in lines  # the shortest text that reads back exactly
    assert lines[-1] == "f 1 2 3"


def test_armadillo(tmp_path: Path) -> None:
    if not ARMADILLO.exists():
        pytest.skip(f"{ARMADILLO} not available")
    mesh = read_mesh(ARMADILLO)
    assert (mesh.n_vertices, mesh.n_faces) == (43243, 86482)
    assert mesh.name == "armadillo43k.obj"
    assert mesh.faces.min() == 0 and mesh.faces.max() == 43242
    write_mesh(tmp_path / "a.ply", mesh)
    back = read_mesh(tmp_path / "a.ply")
    assert np.array_equal(back.vertices, mesh.vertices)
    assert np.array_equal(back.faces, mesh.faces)


# --------------------------------------------------------------------------- OBJ


def test_obj_polygons_slashes_negative_indices_and_noise(tmp_path: Path) -> None:
    text = (
        "# comment\r\n"
        "mtllib scene.mtl\r\n"
        "o thing\r\n"
        "\r\n"
        "v 0 0 0\r\n"
        "v 1 0 0 1.0\r\n"  # w coordinate
        "v 1 1 0 0.5 0.5 0.5\r\n"  # vertex colour
        "  v 0 1 0\r\n"  # indented
        "vt 0 0\r\nvn 0 0 1\r\ng group\r\ns 1\r\nusemtl red\r\n"
        "f 1/1/1 2/2/1 3/3/1 4/4/1\r\n"  # quad with i/t/n
        "l 1 2\r\n"
        "v 0 0 1\r\n"
        "f -5//1 -4//1 -1//1\r\n"  # i//n, relative to the 5 vertices so far
        "f 2/1 3/1 5/1\r\n"  # i/t
        "v 2 2 2\r\n"
        "f 1 2 3 4 6\r\n"  # pentagon
    )
    mesh = read_mesh(write_bytes(tmp_path / "m.obj", text))
    assert_same(
        mesh,
        [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [2, 2, 2]],
        [[0, 1, 2], [0, 2, 3], [0, 1, 4], [1, 2, 4], [0, 1, 2], [0, 2, 3], [0, 3, 5]],
    )
    assert mesh.name == "m.obj"


def test_obj_without_trailing_newline_and_tabs(tmp_path: Path) -> None:
    mesh = read_mesh(write_bytes(tmp_path / "t.obj", "v\t0 0 0\nv 1 0 0\nv 0 1 0\nf\t1 2 3"))
    assert_same(mesh, [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])


# --------------------------------------------------------------------------- OFF


def test_off_polygons_comments_and_colours(tmp_path: Path) -> None:
    text = """OFF
# a unit cube with a quad, two triangles and a pentagon face
6 4 0

0 0 0
1 0 0   # trailing comment
1 1 0
0 1 0
0.5 0.5 1
2 2 2
4 0 1 2 3 255 0 0
3 0 1 4
3 1 2 4 0.5 0.5 0.5 1.0
5 0 1 2 3 5
"""
    mesh = read_mesh(write_bytes(tmp_path / "p.off", text))
    assert_same(
        mesh,
        [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1], [2, 2, 2]],
        [[0, 1, 2], [0, 2, 3], [0, 1, 4], [1, 2, 4], [0, 1, 2], [0, 2, 3], [0, 3, 5]],
    )


@pytest.mark.parametrize("head", ["OFF\n3 1 0\n", "OFF 3 1 0\n", "3 1\n", "COFF\n3 1 0\n",
                                  "NOFF\r\n3 1 3\r\n"])
def test_off_header_variants(tmp_path: Path, head: str) -> None:
    extra = " 0.1 0.2 0.3 1" if head.startswith(("COFF", "NOFF")) else ""
    text = head + "".join(f"{x} {y} 0{extra}\n" for x, y in [(0, 0), (1, 0), (0, 1)])
    mesh = read_mesh(write_bytes(tmp_path / "h.off", text + "3 0 1 2\n"))
    assert_same(mesh, [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])


# --------------------------------------------------------------------------- PLY

# A square pyramid: 5 vertices, a quad base and 4 triangles.
PYRAMID_V = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0.5, 0.5, 1.25)]
PYRAMID_F = [(3, 2, 1, 0), (0, 1, 4), (1, 2, 4), (2, 3, 4), (3, 0, 4)]
PYRAMID_TRI = [(3, 2, 1), (3, 1, 0), (0, 1, 4), (1, 2, 4), (2, 3, 4), (3, 0, 4)]

PLY_HEADER = """ply
format {fmt} 1.0
comment made by hand
obj_info a pyramid
element vertex 5
property float nx
property double x
property float y
property uchar red
property float z
property int id
element face 5
property uchar flags
property list ushort uint vertex_index
property short tag
element edge 2
property int vertex1
property int vertex2
element material 1
property list uchar float diffuse
end_header
"""


def pyramid_ply(fmt: str) -> bytes:
    """The pyramid written by hand with extra properties and elements around the mesh."""
    header = PLY_HEADER.format(fmt=fmt).encode()
    if fmt == "ascii":
        body = "".join(f"0.5 {x} {y} 200 {z} {i}\n" for i, (x, y, z) in enumerate(PYRAMID_V))
        body += "".join(f"7 {len(f)} {' '.join(map(str, f))} -3\n" for f in PYRAMID_F)
        body += "0 1\n1 2\n3 0.25 0.5 0.75\n"
        return header + body.encode()
    o = "<" if fmt == "binary_little_endian" else ">"
    body = b"".join(struct.pack(o + "fdfBfi", 0.5, x, y, 200, z, i)
                    for i, (x, y, z) in enumerate(PYRAMID_V))
    body += b"".join(struct.pack(o + f"BH{len(f)}Ih", 7, len(f), *f, -3) for f in PYRAMID_F)
    body += struct.pack(o + "iiii", 0, 1, 1, 2) + struct.pack(o + "B3f", 3, 0.25, 0.5, 0.75)
    return header + body


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian", "binary_big_endian"])
def test_ply_formats_agree(tmp_path: Path, fmt: str) -> None:
    mesh = read_mesh(write_bytes(tmp_path / "p.ply", pyramid_ply(fmt)))
    assert_same(mesh, PYRAMID_V, PYRAMID_TRI)


def test_ply_crlf_ascii(tmp_path: Path) -> None:
    data = pyramid_ply("ascii").replace(b"\n", b"\r\n")
    assert_same(read_mesh(write_bytes(tmp_path / "p.ply", data)), PYRAMID_V, PYRAMID_TRI)


@pytest.mark.parametrize("order", ["<", ">"])
def test_ply_binary_fast_path_with_scalar_after_list(tmp_path: Path, order: str) -> None:
    """All-triangle faces with an int8 count and a float after the list."""
    rng = np.random.default_rng(1)
    v = rng.normal(size=(50, 3)).astype(np.float32)
    f = rng.integers(0, 50, size=(80, 3))
    fmt = "binary_little_endian" if order == "<" else "binary_big_endian"
    header = (f"ply\nformat {fmt} 1.0\nelement vertex 50\nproperty float x\n"
              "property float y\nproperty float z\nelement face 80\n"
              "property list char short vertex_indices\nproperty float quality\nend_header\n")
    body = v.astype(order + "f4").tobytes()
    body += b"".join(struct.pack(order + "b3hf", 3, *row, 0.5) for row in f.tolist())
    mesh = read_mesh(write_bytes(tmp_path / "fast.ply", header.encode() + body))
    assert_same(mesh, v.astype(np.float64), f)


def test_ply_ascii_all_triangles_matches_binary(tmp_path: Path, sphere: Mesh) -> None:
    header = ("ply\nformat ascii 1.0\nelement vertex {}\nproperty double x\nproperty double y\n"
              "property double z\nproperty uchar alpha\nelement face {}\n"
              "property list uchar int vertex_indices\nproperty float weight\nend_header\n")
    text = header.format(sphere.n_vertices, sphere.n_faces)
    text += "".join(f"{x!r} {y!r} {z!r} 255\n" for x, y, z in sphere.vertices.tolist())
    text += "".join(f"3 {a} {b} {c} 0.5\n" for a, b, c in sphere.faces.tolist())
    from_ascii = read_mesh(write_bytes(tmp_path / "a.ply", text))
    write_mesh(tmp_path / "b.ply", sphere)
    from_binary = read_mesh(tmp_path / "b.ply")
    assert np.array_equal(from_ascii.vertices, from_binary.vertices)
    assert np.array_equal(from_ascii.faces, from_binary.faces)
    assert np.array_equal(from_ascii.faces, sphere.faces)


def strip_ply(strips: list[list[int]], vertices, faces=()) -> str:
    lines = ["ply", "format ascii 1.0", f"element vertex {len(vertices)}",
             "property float x", "property float y", "property float z"]
    if faces:
        lines += [f"element face {len(faces)}", "property list uchar int vertex_indices"]
    lines += [f"element tristrips {len(strips)}", "property list int int vertex_indices",
              "end_header"]
    lines += [" ".join(map(str, p)) for p in vertices]
    lines += [f"{len(f)} " + " ".join(map(str, f)) for f in faces]
    lines += [f"{len(s)} " + " ".join(map(str, s)) for s in strips]
    return "\n".join(lines) + "\n"


def test_ply_tristrips_square(tmp_path: Path) -> None:
    square = [(0, 0, 0), (0, 1, 0), (1, 0, 0), (1, 1, 0)]
    mesh = read_mesh(write_bytes(tmp_path / "s.ply", strip_ply([[0, 1, 2, 3]], square)))
    # second triangle flips its first two corners so both face the same way
    assert_same(mesh, square, [[0, 1, 2], [2, 1, 3]])
    normals = np.cross(mesh.vertices[mesh.faces[:, 1]] - mesh.vertices[mesh.faces[:, 0]],
                       mesh.vertices[mesh.faces[:, 2]] - mesh.vertices[mesh.faces[:, 0]])
    assert np.all(normals[:, 2] < 0)


def test_ply_tristrips_cube_with_restart_and_degenerates(tmp_path: Path) -> None:
    cube = [(x, y, z) for x in (0, 1) for y in (0, 1) for z in (0, 1)]  # index = 4x + 2y + z
    # the four sides as one strip, a -1 restart, the x=0 side ending in a
    # degenerate pair (repeated index), then the x=1 side as a second record
    strips = [[0, 4, 1, 5, 3, 7, 2, 6, 0, 4, -1, 0, 1, 2, 3, 3, 4], [4, 6, 5, 7]]
    mesh = read_mesh(write_bytes(tmp_path / "c.ply", strip_ply(strips, cube)))
    expected = [[0, 4, 1], [1, 4, 5], [1, 5, 3], [3, 5, 7], [3, 7, 2], [2, 7, 6], [2, 6, 0],
                [0, 6, 4], [0, 1, 2], [2, 1, 3], [4, 6, 5], [5, 6, 7]]
    assert_same(mesh, cube, expected)
    # closed and consistently oriented: every directed edge appears exactly once
    directed = {(int(a), int(b)) for f in mesh.faces for a, b in zip(f, np.roll(f, -1))}
    assert len(directed) == 3 * len(expected)
    assert all((b, a) in directed for a, b in directed)


def test_ply_faces_then_tristrips(tmp_path: Path) -> None:
    quad = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0)]
    text = strip_ply([[1, 4, 2]], quad, faces=[(0, 1, 2, 3)])
    assert_same(read_mesh(write_bytes(tmp_path / "fs.ply", text)), quad,
                [[0, 1, 2], [0, 2, 3], [1, 4, 2]])


def test_ply_unsigned_strip_restart(tmp_path: Path) -> None:
    square = np.array([(0, 0, 0), (0, 1, 0), (1, 0, 0), (1, 1, 0)], dtype="<f4")
    header = ("ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\n"
              "property float y\nproperty float z\nelement tristrips 1\n"
              "property list uint uint vertex_indices\nend_header\n").encode()
    strip = struct.pack("<8I", 7, 0, 1, 2, 0xFFFFFFFF, 1, 3, 2)
    mesh = read_mesh(write_bytes(tmp_path / "u.ply", header + square.tobytes() + strip))
    assert_same(mesh, square.astype(float), [[0, 1, 2], [1, 3, 2]])


# --------------------------------------------------------------------------- STL


def test_binary_stl_starting_with_solid(tmp_path: Path) -> None:
    tri = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], "<f4")
    data = b"solid but actually binary".ljust(80, b"\0") + struct.pack("<I", 2)
    for k in range(2):
        data += struct.pack("<3f", 0, 0, 1) + tri[3 * k: 3 * k + 3].tobytes() + b"\0\0"
    mesh = read_mesh(write_bytes(tmp_path / "b.stl", data))
    assert_same(mesh, [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], [[0, 1, 2], [1, 3, 2]])


def test_ascii_stl_welds_in_first_occurrence_order(tmp_path: Path) -> None:
    text = """solid square
  facet normal 0 0 1
    outer loop
      vertex 1 1 0
      vertex 0 1 0
      vertex 1 0 0
    endloop
  endfacet
  facet normal 0 0 1
    outer loop
      vertex 0 0 0
      vertex 1 0 0
      vertex -0 1 0
    endloop
  endfacet
endsolid square
"""
    mesh = read_mesh(write_bytes(tmp_path / "a.STL", text))
    assert_same(mesh, [[1, 1, 0], [0, 1, 0], [1, 0, 0], [0, 0, 0]], [[0, 1, 2], [3, 2, 1]])


# --------------------------------------------------------------------------- errors

TRIANGLE_OBJ = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"


@pytest.mark.parametrize("ext", [".obj", ".ply", ".stl", ".off"])
def test_empty_file(tmp_path: Path, ext: str) -> None:
    assert "empty" in read_error(write_bytes(tmp_path / f"empty{ext}", b""))
    assert "empty" in read_error(write_bytes(tmp_path / f"blank{ext}", b"\n  \r\n"))


@pytest.mark.parametrize("ext", [".obj", ".ply", ".stl", ".off"])
@pytest.mark.parametrize("seed", range(5))
def test_random_bytes(tmp_path: Path, ext: str, seed: int) -> None:
    data = np.random.default_rng(seed).integers(0, 256, size=1000 + 37 * seed, dtype=np.uint8)
    read_error(write_bytes(tmp_path / f"noise{ext}", data.tobytes()))


@pytest.mark.parametrize("ext", [".obj", ".ply", ".off"])
def test_random_text(tmp_path: Path, ext: str) -> None:
    read_error(write_bytes(tmp_path / f"words{ext}", "this is\nnot a mesh file at all\n"))


def test_missing_file(tmp_path: Path) -> None:
    assert "file not found" in read_error(tmp_path / "nothing.obj")


def test_folder_instead_of_file(tmp_path: Path) -> None:
    (tmp_path / "dir.obj").mkdir()
    assert "folder" in read_error(tmp_path / "dir.obj")


@pytest.mark.parametrize("name", ["mesh.xyz", "mesh", "mesh.obj.gz"])
def test_unsupported_extension(tmp_path: Path, sphere: Mesh, name: str) -> None:
    path = write_bytes(tmp_path / name, TRIANGLE_OBJ)
    message = read_error(path)
    assert ".obj" in message and ".ply" in message  # lists what is supported
    target = tmp_path / ("new_" + name)
    with pytest.raises(MeshFileError, match=f"^new_{name}:"):
        write_mesh(target, sphere)
    assert not target.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]


def test_truncated_binary_ply(tmp_path: Path) -> None:
    data = pyramid_ply("binary_little_endian")
    end = data.index(b"end_header\n") + len(b"end_header\n")
    vertex_bytes = 29  # float, double, float, uchar, float, int
    cut = end + 2 * vertex_bytes + 10
    message = read_error(write_bytes(tmp_path / "cut.ply", data[:cut]))
    assert "header says 5 vertices but file ends after 2" in message
    message = read_error(write_bytes(tmp_path / "cut2.ply", data[: end + 5 * vertex_bytes + 30]))
    assert "header says 5 faces but file ends after" in message


def test_a_ply_larger_than_the_head_the_registry_reads(tmp_path: Path, monkeypatch) -> None:
    # the registry reads a PLY's first bytes only (plyfile maps the body): a binary file's counts are
    # checked against its size, a text file is read whole by the PLY reader
    from hybridedit.fileio.formats import FORMATS, ply

    monkeypatch.setitem(FORMATS, ".ply", FORMATS[".ply"].__class__(**{**FORMATS[".ply"].__dict__, "head": 600}))
    mesh = icosphere(3)  # 642 vertices: files of several kilobytes
    for encoding in ("binary", "ascii"):
        path = tmp_path / f"{encoding}.ply"
        write_mesh(path, mesh) if encoding == "binary" else path.write_bytes(
            b"ply\nformat ascii 1.0\nelement vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
            b"element face %d\nproperty list uchar int vertex_indices\nend_header\n" % (mesh.n_vertices, mesh.n_faces)
            + b"".join(b"%r %r %r\n" % tuple(float(np.float32(c)) for c in v) for v in mesh.vertices)
            + b"".join(b"3 %d %d %d\n" % tuple(f) for f in mesh.faces))
        assert path.stat().st_size > 4 * 600
        back = read_mesh(path)
        assert np.array_equal(back.faces, mesh.faces)
        assert np.allclose(back.vertices, mesh.vertices, atol=1e-6)
        data = path.read_bytes()
        if encoding == "binary":
            assert "file ends after" in read_error(write_bytes(tmp_path / "cut.ply", data[:-40]))
        else:
            assert "face" in read_error(write_bytes(tmp_path / "cut.ply", data[:-12]))
    assert ply.HEAD_BYTES >= 1 << 20  # (a header must end within them: _check_start's own limit)


def test_ply_header_lying_about_counts(tmp_path: Path) -> None:
    more = pyramid_ply("binary_little_endian").replace(b"element face 5", b"element face 500")
    # refused from the header: 500 faces need more bytes than the file has after it
    assert "header says 500 faces but the file has room for at most 23 (118 bytes left, at least 5 bytes " \
        "each; the header's element counts are wrong)" in read_error(write_bytes(tmp_path / "more.ply", more))
    mesh = icosphere(0)
    write_mesh(tmp_path / "ico.ply", mesh)
    lying = (tmp_path / "ico.ply").read_bytes().replace(b"element face 20", b"element face 21")
    assert "header says 21 faces but file ends after 20" in read_error(
        write_bytes(tmp_path / "ico21.ply", lying))
    lying = (tmp_path / "ico.ply").read_bytes().replace(b"element vertex 12", b"element vertex 13")
    assert "counts may be wrong" in read_error(write_bytes(tmp_path / "ico13.ply", lying))
    fewer = pyramid_ply("binary_little_endian").replace(b"element material 1",
                                                        b"element material 0")
    assert "after the last element" in read_error(write_bytes(tmp_path / "fewer.ply", fewer))
    ascii_more = pyramid_ply("ascii").replace(b"element vertex 5", b"element vertex 6")
    read_error(write_bytes(tmp_path / "vmore.ply", ascii_more))
    ascii_fewer = pyramid_ply("ascii").replace(b"element vertex 5", b"element vertex 4")
    read_error(write_bytes(tmp_path / "vfewer.ply", ascii_fewer))
    ascii_edges = pyramid_ply("ascii").replace(b"element edge 2", b"element edge 20")
    assert read_error(write_bytes(tmp_path / "edges.ply", ascii_edges)) == \
        "edges.ply: header says 20 'edge' records but file ends after 3"  # checked against the lines at once


@pytest.mark.parametrize("header, problem", [
    ("plyx\nformat ascii 1.0\nend_header\n", "not a PLY file"),
    ("ply\nformat ascii 1.0\nelement vertex 3\n", "no 'end_header'"),
    ("ply\nelement vertex 0\nend_header\n", "expected one of {format"),
    ("ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n",
     "field type 'quad' not in"),
    ("ply\nformat ascii 1.0\nelement vertex x\nend_header\n", "not a valid PLY header"),
    ("ply\nformat text 1.0\nend_header\n", "don't understand format 'text'"),
    ("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
     "end_header\n0 0\n", "no 'z' property"),
    ("ply\nformat ascii 1.0\nelement face 0\nend_header\n", "no 'vertex' element"),
])
def test_bad_ply_headers(tmp_path: Path, header: str, problem: str) -> None:
    assert problem in read_error(write_bytes(tmp_path / "bad.ply", header))


@pytest.mark.parametrize("name, text, index, count", [
    ("big.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9001\n", 9001, "3 vertices"),
    ("neg.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n", -4, "3 vertices"),
    ("big.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 800\n", 800, "3 vertices"),
    ("big.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
     "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
     "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", 3, "3 vertices"),
    ("neg.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
     "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
     "0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n", -1, "3 vertices"),
])
def test_face_index_out_of_range(tmp_path: Path, name: str, text: str, index: int,
                                 count: str) -> None:
    message = read_error(write_bytes(tmp_path / name, text))
    assert f"face index {index} out of range" in message and count in message


def test_obj_index_zero(tmp_path: Path) -> None:
    assert "index 0" in read_error(write_bytes(tmp_path / "z.obj", "v 0 0 0\nf 0 1 1\n"))


@pytest.mark.parametrize("name, text", [
    ("nan.obj", "v 0 0 0\nv nan 0 0\nv 0 inf 0\nf 1 2 3\n"),
    ("nan.off", "OFF\n3 1 0\n0 0 0\nnan 0 0\n0 -inf 0\n3 0 1 2\n"),
    ("nan.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
     "property double z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
     "0 0 0\nnan 0 0\n0 inf 0\n3 0 1 2\n"),
])
def test_non_finite_coordinates(tmp_path: Path, name: str, text: str) -> None:
    assert "2 vertices have NaN or infinite coordinates" in read_error(
        write_bytes(tmp_path / name, text))


@pytest.mark.parametrize("name, text", [
    ("points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n"),
    ("points.off", "OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n"),
    ("solid.stl", "solid nothing\nendsolid nothing\n"),
])
def test_no_faces(tmp_path: Path, name: str, text: str) -> None:
    assert "no faces" in read_error(write_bytes(tmp_path / name, text))


@pytest.mark.parametrize("name, text, problem", [
    ("short.obj", "v 0 0\nf 1 1 1\n", "line 1: vertex has 2 coordinates"),
    ("word.obj", "v 0 0 0\nv 1 0 0\nv 0 x 0\nf 1 2 3\n", "line 3: cannot read vertex"),
    ("edge.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2\n", "line 5: face has 2 vertices"),
    ("word2.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 b 3\n", "line 5: cannot read face"),
    ("zero.obj", "v 0 0 0\n\nf 0 1 1\n", "line 3: face index 0 is invalid"),
    ("before.obj", "v 0 0 0\nv 1 0 0\n# c\nf -1 -2 -3\n",
     "line 4: face index -3 out of range (only 2 vertices defined before this line)"),
    ("vn.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\ng x\nf 1//-2 2//-1 3//-1\n",
     "line 6: face index -2 out of range (only 1 'normal' record defined before this line)"),
    ("cut.off", "OFF\n4 2 0\n0 0 0\n1 0 0\n", "header says 4 vertices but file ends after 2"),
    ("cutf.off", "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
     "header says 2 faces but file ends after 1"),
    ("more.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 2 1\n", "unexpected line"),
    ("counts.off", "OFF\nthree 1\n", "line 2: expected 'vertices faces"),
    ("size.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n", "line 6: face says 4 vertices"),
])
def test_text_format_problems_name_the_line(tmp_path: Path, name: str, text: str,
                                            problem: str) -> None:
    assert problem in read_error(write_bytes(tmp_path / name, text))


def test_truncated_binary_stl(tmp_path: Path, sphere: Mesh) -> None:
    write_mesh(tmp_path / "full.stl", sphere)
    data = (tmp_path / "full.stl").read_bytes()
    message = read_error(write_bytes(tmp_path / "cut.stl", data[: 84 + 50 * 7 + 20]))
    assert f"header says {sphere.n_faces} triangles but file ends after 7" in message
    assert "not an STL" in read_error(write_bytes(tmp_path / "tiny.stl", b"\x01\x02\x03"))


def test_errors_are_mesh_errors_and_chain_nothing_raw(tmp_path: Path) -> None:
    path = write_bytes(tmp_path / "x.ply", b"ply\nformat binary_little_endian 1.0\n"
                       b"element vertex 1\nproperty list uchar float x\nend_header\n\x01")
    with pytest.raises(MeshError) as info:
        read_mesh(path)
    assert isinstance(info.value, MeshFileError) and isinstance(info.value, ValueError)


@pytest.mark.parametrize("ext", [".obj", ".ply", ".stl", ".off"])
def test_truncated_files_fail_cleanly(tmp_path: Path, ext: str) -> None:
    """Cut a written file anywhere: a MeshFileError naming the file, never a raw error."""
    mesh = first_occurrence_order(icosphere(1))
    write_mesh(tmp_path / f"full{ext}", mesh)
    data = (tmp_path / f"full{ext}").read_bytes()
    for cut in np.linspace(1, len(data) - 2, 40).astype(int):
        path = write_bytes(tmp_path / f"cut{ext}", data[:cut])
        try:
            back = read_mesh(path)
        except MeshFileError as exc:
            assert str(exc).startswith(f"cut{ext}: ")
            continue
        # text formats: a cut inside the last face's last number is undetectable,
        # and OBJ has no counts, so a cut in its face list leaves a shorter mesh
        assert ext in (".obj", ".off") and 0 < back.n_faces <= mesh.n_faces
        if ext == ".off":
            assert cut >= data.rindex(b"\n3 ")
        assert np.array_equal(back.vertices, mesh.vertices)
        assert np.array_equal(back.faces[:-1], mesh.faces[: back.n_faces - 1])


# --------------------------------------------------------------------------- atomic writing


def listing(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def test_atomic_write_text_and_binary(tmp_path: Path) -> None:
    with atomic_write(tmp_path / "t.txt", "w") as f:
        f.write("grüße\n")
    assert (tmp_path / "t.txt").read_bytes() == "grüße\n".encode("utf-8")
    with atomic_write(str(tmp_path / "t.txt")) as f:
        f.write(b"\x00\x01")
    assert (tmp_path / "t.txt").read_bytes() == b"\x00\x01"
    assert listing(tmp_path) == ["t.txt"]


def test_failure_inside_block_leaves_target_untouched(tmp_path: Path) -> None:
    target = write_bytes(tmp_path / "keep.obj", "old content")
    with pytest.raises(RuntimeError, match="boom"):
        with atomic_write(target) as f:
            f.write(b"new partial content")
            raise RuntimeError("boom")
    assert target.read_text() == "old content"
    assert listing(tmp_path) == ["keep.obj"]


def test_write_mesh_failing_midway_keeps_old_file(tmp_path: Path, sphere: Mesh,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    target = tmp_path / "keep.ply"
    write_mesh(target, sphere)
    before = target.read_bytes()

    def full_disk(fd: int) -> None:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(atomic.os, "fsync", full_disk)
    small = Mesh(sphere.vertices[:3], np.array([[0, 1, 2]]))
    with pytest.raises(WriteError) as info:
        write_mesh(target, small)
    assert str(info.value) == f"cannot write {target}: no space left on device"
    assert info.value.errno == errno.ENOSPC and isinstance(info.value, OSError)
    assert target.read_bytes() == before
    assert listing(tmp_path) == ["keep.ply"]


def test_other_file_errors_inside_block_pass_through(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError):
        with atomic_write(tmp_path / "out.bin") as f:
            f.write(b"x")
            open(tmp_path / "missing-input.txt", "rb")
    assert listing(tmp_path) == []


def test_write_into_missing_folder(tmp_path: Path, sphere: Mesh) -> None:
    target = tmp_path / "no" / "such" / "out.obj"
    with pytest.raises(WriteError) as info:
        write_mesh(target, sphere)
    assert str(target) in str(info.value) and "does not exist" in str(info.value)


def test_write_below_a_regular_file(tmp_path: Path, sphere: Mesh) -> None:
    blocker = write_bytes(tmp_path / "file", "x")
    with pytest.raises(WriteError, match="is not a folder") as info:
        write_mesh(blocker / "out.stl", sphere)
    assert info.value.filename == str(blocker / "out.stl")


def test_write_onto_a_folder(tmp_path: Path, sphere: Mesh) -> None:
    (tmp_path / "dir.off").mkdir()
    with pytest.raises(WriteError, match="dir.off: it is a folder"):
        write_mesh(tmp_path / "dir.off", sphere)


def test_read_only_folder_simulated(tmp_path: Path, sphere: Mesh,
                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """chmod does not stop root, so make creating the temp file fail as it would."""

    def denied(*args, **kwargs):
        raise PermissionError(errno.EACCES, "Permission denied", str(tmp_path))

    monkeypatch.setattr(tempfile, "mkstemp", denied)
    target = tmp_path / "out.obj"
    with pytest.raises(WriteError) as info:
        write_mesh(target, sphere)
    assert str(info.value) == f"cannot write {target}: permission denied"
    assert not target.exists()


def test_permissions(tmp_path: Path, sphere: Mesh) -> None:
    existing = write_bytes(tmp_path / "private.obj", "old")
    existing.chmod(0o600)
    write_mesh(existing, sphere)
    assert stat.S_IMODE(existing.stat().st_mode) == 0o600
    old_mask = os.umask(0o027)
    try:
        write_mesh(tmp_path / "fresh.obj", sphere)
    finally:
        os.umask(old_mask)
    assert stat.S_IMODE((tmp_path / "fresh.obj").stat().st_mode) == 0o640


def test_write_through_symlink_keeps_the_link(tmp_path: Path, sphere: Mesh) -> None:
    real = write_bytes(tmp_path / "real.off", "old")
    link = tmp_path / "link.off"
    link.symlink_to(real)
    write_mesh(link, sphere)
    assert link.is_symlink()
    assert np.array_equal(read_mesh(real).vertices, sphere.vertices)
    assert listing(tmp_path) == ["link.off", "real.off"]


def test_atomic_write_rejects_other_modes(tmp_path: Path) -> None:
    with pytest.raises(ValueError):
        with atomic_write(tmp_path / "a", "a"):
            pass
    assert listing(tmp_path) == []


def test_helpers_fan_and_weld() -> None:
    tri = common.fan_triangles(np.array([3, 5, 4]), np.arange(12))
    assert tri.tolist() == [[0, 1, 2], [3, 4, 5], [3, 5, 6], [3, 6, 7], [8, 9, 10], [8, 10, 11]]
    pts = np.array([[1, 0, 0], [0, 0, 0], [1, 0, 0], [-0.0, 0, 0], [2, 0, 0], [1, 0, 0.0]])
    v, f = common._weld(pts)
    assert v.tolist() == [[1, 0, 0], [0, 0, 0], [2, 0, 0]]
    assert f.tolist() == [[0, 1, 0], [1, 2, 0]]
