"""Generate the catalog of troublesome mesh files the robustness tests feed to hybridedit.

    python tests/data/make_bad.py OUT_FOLDER [--big]

Every file is small and made from scratch (an icosphere, a box, a random soup),
except ``big_2m_faces.ply`` (--big or ``make_big``): about two million faces,
written as binary PLY with numpy in a few seconds.  Nothing here is committed;
the tests write the catalog into a temporary folder.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import trimesh

# name -> short description (what the file is)
CATALOG: dict[str, str] = {}


def _entry(name: str, what: str):
    def deco(fn):
        CATALOG[name] = what
        fn.file_name = name
        _MAKERS[name] = fn
        return fn
    return deco


_MAKERS: dict = {}


def sphere(subdivisions: int = 2, radius: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    s = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    v = np.asarray(s.vertices, dtype=np.float64).copy()
    v[:, 0] *= 1.6  # a little elongated, so "the +x end" is a clear handle
    return v, np.asarray(s.faces, dtype=np.int64).copy()


def obj_text(v: np.ndarray, faces) -> str:
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in np.asarray(v, dtype=np.float64).tolist()]
    lines += ["f " + " ".join(str(int(i) + 1) for i in f) for f in faces]
    return "\n".join(lines) + "\n"


def ply_binary(v: np.ndarray, f: np.ndarray, n_vertices: int | None = None, n_faces: int | None = None) -> bytes:
    """Binary little-endian PLY; the header may state other counts than the data has."""
    nv = len(v) if n_vertices is None else n_vertices
    nf = len(f) if n_faces is None else n_faces
    head = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {nv}\nproperty float x\nproperty float y\nproperty float z\n"
        f"element face {nf}\nproperty list uchar int vertex_indices\nend_header\n"
    ).encode()
    vb = np.asarray(v, dtype="<f4").tobytes()
    rec = np.zeros(len(f), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    rec["n"] = 3
    rec["i"] = f
    return head + vb + rec.tobytes()


def _w(folder: Path, name: str, data: bytes | str) -> Path:
    p = folder / name
    p.write_bytes(data.encode() if isinstance(data, str) else data)
    return p


@_entry("empty.obj", "an empty file")
def _empty(folder):
    return _w(folder, "empty.obj", b"")


@_entry("random_bytes.ply", "random bytes")
def _random(folder):
    return _w(folder, "random_bytes.ply", np.random.default_rng(1).bytes(4096))


@_entry("truncated.ply", "a binary PLY cut off in the middle of its faces")
def _truncated(folder):
    v, f = sphere()
    data = ply_binary(v, f)
    return _w(folder, "truncated.ply", data[: len(data) - 7 * len(f) // 2])


@_entry("lying_header.ply", "a binary PLY whose header promises more vertices than it has")
def _lying(folder):
    v, f = sphere()
    return _w(folder, "lying_header.ply", ply_binary(v, f, n_vertices=len(v) + 500))


@_entry("nan_inf.obj", "NaN and inf coordinates")
def _nan(folder):
    v, f = sphere()
    v[3] = [np.nan, 0, 0]
    v[7] = [0, np.inf, 0]
    return _w(folder, "nan_inf.obj", obj_text(v, f))


@_entry("index_past_end.obj", "a face indexing past the vertex list")
def _past(folder):
    v, f = sphere()
    f = f.copy()
    f[5, 1] = len(v) + 10
    return _w(folder, "index_past_end.obj", obj_text(v, f))


@_entry("negative_index.off", "a negative face index")
def _negative(folder):
    v, f = sphere()
    lines = ["OFF", f"{len(v)} {len(f)} 0"] + [f"{x!r} {y!r} {z!r}" for x, y, z in v.tolist()]
    lines += [f"3 {a} {b} {c}" for a, b, c in f.tolist()]
    lines[2 + len(v) + 4] = "3 0 -5 1"
    return _w(folder, "negative_index.off", "\n".join(lines) + "\n")


PROMISE = 10 ** 12  # elements a lying header promises: far more than any file or memory holds


@_entry("promises_1e12_faces.ply", "a tiny binary PLY whose header promises 10^12 faces")
def _promise_ply(folder):
    v, f = sphere(0)
    return _w(folder, "promises_1e12_faces.ply", ply_binary(v, f, n_faces=PROMISE))


@_entry("promises_1e12_vertices_ascii.ply", "a tiny ASCII PLY whose header promises 10^12 vertices")
def _promise_ply_ascii(folder):
    head = ("ply\nformat ascii 1.0\nelement vertex %d\nproperty float x\nproperty float y\n"
            "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n" % PROMISE)
    return _w(folder, "promises_1e12_vertices_ascii.ply", head + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")


@_entry("promises_1e12_faces.off", "a tiny OFF whose counts line promises 10^12 faces")
def _promise_off(folder):
    return _w(folder, "promises_1e12_faces.off", "OFF\n3 %d 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n" % PROMISE)


@_entry("promises_max_triangles.stl", "a binary STL whose count promises 2^32-1 triangles (its largest)")
def _promise_stl(folder):
    rec = np.zeros(1, dtype=[("n", "<f4", 3), ("c", "<f4", (3, 3)), ("a", "<u2")])
    rec["c"] = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
    return _w(folder, "promises_max_triangles.stl",
              b"binary".ljust(80, b" ") + np.uint32(2 ** 32 - 1).tobytes() + rec.tobytes())


@_entry("quads_ngons.obj", "a box of quads with pentagon and hexagon caps")
def _quads(folder):
    # a hexagonal prism: two hexagons and six quads, then a pentagon-capped block
    ang = np.linspace(0, 2 * np.pi, 7)[:-1]
    ring = np.stack([2.0 * np.cos(ang), np.sin(ang)], axis=1)
    v = np.vstack([np.column_stack([ring, np.full(6, -0.5)]), np.column_stack([ring, np.full(6, 0.5)])])
    faces = [list(range(5, -1, -1)), list(range(6, 12))]
    for i in range(6):
        j = (i + 1) % 6
        faces.append([i, j, 6 + j, 6 + i])
    return _w(folder, "quads_ngons.obj", obj_text(v, faces))


@_entry("degenerate_faces.obj", "zero-area (collinear) and repeated-vertex faces in a sphere")
def _degenerate(folder):
    v, f = sphere()
    a, b = f[0, 0], f[0, 1]
    mid = len(v)
    v = np.vstack([v, (v[a] + v[b]) / 2])  # on edge a-b: (a, b, mid) has zero area
    extra = np.array([[a, b, mid], [a, mid, b], [f[1, 0], f[1, 0], f[1, 1]], [f[2, 2], f[2, 1], f[2, 2]]])
    return _w(folder, "degenerate_faces.obj", obj_text(v, np.vstack([f, extra])))


@_entry("duplicate_vertices.stl", "a sphere as a triangle soup with every corner repeated (STL welds exact ones)")
def _dup_stl(folder):
    v, f = sphere()
    t = trimesh.Trimesh(v, f, process=False)
    return _w(folder, "duplicate_vertices.stl", trimesh.exchange.stl.export_stl(t))


@_entry("duplicate_vertices.obj", "a sphere whose faces use separate copies of the same positions")
def _dup(folder):
    v, f = sphere()
    nv = len(v)
    v2 = np.vstack([v, v[:40]])
    f2 = f.copy()
    # faces that use vertex i < 40 on their first corner use the copy instead
    sel = f2[:, 0] < 40
    f2[sel, 0] += nv
    return _w(folder, "duplicate_vertices.obj", obj_text(v2, f2))


@_entry("unreferenced_vertices.obj", "a sphere plus vertices no face uses")
def _unref(folder):
    v, f = sphere()
    extra = np.array([[5.0, 5.0, 5.0], [0.0, 0.0, 0.0], [-3.0, 0.5, 0.2]])
    return _w(folder, "unreferenced_vertices.obj", obj_text(np.vstack([v, extra]), f))


@_entry("nonmanifold.obj", "two spheres sharing a vertex, plus a fin on an edge (non-manifold edges and vertices)")
def _nonmanifold(folder):
    v, f = sphere()
    i = int(np.argmax(v[:, 1]))
    v2 = v.copy()
    v2[:, 1] += v[i, 1] - v[:, 1].min()  # second sphere touches the first at its top vertex
    j = int(np.argmin(v2[:, 1]))
    f2 = f + len(v)
    f2[f2 == len(v) + j] = i  # share the vertex
    V = np.vstack([v, v2])
    F = np.vstack([f, f2])
    # a fin: a third face on edge f[0][0]-f[0][1]
    a, b = f[0, 0], f[0, 1]
    V = np.vstack([V, (V[a] + V[b]) / 2 + [0, 0, 0.7]])
    F = np.vstack([F, [[a, b, len(V) - 1]]])
    return _w(folder, "nonmanifold.obj", obj_text(V, F))


@_entry("components.obj", "three separate spheres side by side")
def _components(folder):
    v, f = sphere()
    V, F = [], []
    for k in range(3):
        V.append(v + [0, 3.0 * k, 0])
        F.append(f + k * len(v))
    return _w(folder, "components.obj", obj_text(np.vstack(V), np.vstack(F)))


@_entry("holes.obj", "a sphere with three holes (open boundaries)")
def _holes(folder):
    v, f = sphere(3)
    c = v[f].mean(axis=1)
    drop = np.zeros(len(f), dtype=bool)
    for d in ([0, 0, 1], [0, 0, -1], [0, 1, 0]):
        drop |= c @ np.asarray(d, float) > 0.9
    return _w(folder, "holes.obj", obj_text(v, f[~drop]))


@_entry("inconsistent_orientation.obj", "a sphere with a third of its faces flipped")
def _inconsistent(folder):
    v, f = sphere()
    f = f.copy()
    flip = np.arange(len(f)) % 3 == 0
    f[flip] = f[flip][:, [0, 2, 1]]
    return _w(folder, "inconsistent_orientation.obj", obj_text(v, f))


@_entry("inside_out.obj", "a closed sphere oriented inward")
def _inside_out(folder):
    v, f = sphere()
    return _w(folder, "inside_out.obj", obj_text(v, f[:, [0, 2, 1]]))


@_entry("fewer_than_cage.obj", "an icosahedron (12 vertices), fewer than the cage asks for")
def _few(folder):
    t = trimesh.creation.icosphere(subdivisions=0)
    return _w(folder, "fewer_than_cage.obj", obj_text(t.vertices * [1.6, 1, 1], t.faces))


@_entry("single_triangle.obj", "one triangle")
def _single(folder):
    return _w(folder, "single_triangle.obj", obj_text(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float), [[0, 1, 2]]))


@_entry("huge_scale.ply", "a sphere with coordinates around 1e8")
def _huge(folder):
    v, f = sphere()
    return _w(folder, "huge_scale.ply", ply_binary_double(v * 1e8 + 3e8, f))


@_entry("tiny_scale.obj", "a sphere with coordinates around 1e-8")
def _tiny(folder):
    v, f = sphere()
    return _w(folder, "tiny_scale.obj", obj_text(v * 1e-8 + 2e-8, f))


def ply_binary_double(v: np.ndarray, f: np.ndarray) -> bytes:
    head = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {len(v)}\nproperty double x\nproperty double y\nproperty double z\n"
        f"element face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n"
    ).encode()
    rec = np.zeros(len(f), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    rec["n"] = 3
    rec["i"] = f
    return head + np.asarray(v, dtype="<f8").tobytes() + rec.tobytes()


def big_mesh(n_faces: int = 2_000_000) -> tuple[np.ndarray, np.ndarray]:
    """A closed UV-sphere-like grid torus with about ``n_faces`` faces, made with numpy."""
    k = int(np.sqrt(n_faces / 4))
    nu, nv = 2 * k, k // 2 * 2
    nu = max(nu, 3)
    u = np.linspace(0, 2 * np.pi, nu, endpoint=False)
    w = np.linspace(0, 2 * np.pi, nv, endpoint=False)
    U, W = np.meshgrid(u, w, indexing="ij")
    R, r = 2.0, 0.7
    x = (R + r * np.cos(W)) * np.cos(U)
    y = (R + r * np.cos(W)) * np.sin(U)
    z = r * np.sin(W)
    v = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    i = np.arange(nu)[:, None]
    j = np.arange(nv)[None, :]
    a = (i * nv + j).ravel()
    b = (((i + 1) % nu) * nv + j).ravel()
    c = (((i + 1) % nu) * nv + (j + 1) % nv).ravel()
    d = (i * nv + (j + 1) % nv).ravel()
    f = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return v, f


def make_big(folder: Path, n_faces: int = 2_000_000) -> Path:
    v, f = big_mesh(n_faces)
    return _w(Path(folder), "big_2m_faces.ply", ply_binary(v, f))


def make_catalog(folder: str | Path) -> dict[str, Path]:
    """Write every catalog file (not the big one) into ``folder``; name -> path."""
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    return {name: maker(out) for name, maker in _MAKERS.items()}


if __name__ == "__main__":
    if len(sys.argv) < 2:
        print(__doc__)
        sys.exit(2)
    paths = make_catalog(sys.argv[1])
    if "--big" in sys.argv:
        paths["big_2m_faces.ply"] = make_big(Path(sys.argv[1]))
    for name, p in paths.items():
        print(f"{p}  {CATALOG.get(name, 'about two million faces')}")
