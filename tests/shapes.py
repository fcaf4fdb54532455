"""Shapes and paths the tests share (import them with ``from shapes import ...``).

Kept out of conftest.py: tests/viewer has a conftest.py of its own, and which one
``import conftest`` finds depends on the order pytest loads them.
"""

from __future__ import annotations

import itertools
import shutil
from pathlib import Path

import numpy as np
import trimesh

from hybridedit.core.mesh import Mesh

REPO = Path(__file__).resolve().parent.parent
SHARED_MESHES = REPO.parent / "shared" / "meshes"
SPOT = SHARED_MESHES / "spot"


def icosphere(subdivisions: int = 3, radius: float = 1.0) -> Mesh:
    s = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    return Mesh(np.asarray(s.vertices), np.asarray(s.faces), name="sphere")


def bumpy_blob(subdivisions: int = 4) -> Mesh:
    """A closed, non-convex, elongated shape with bumps: a stand-in for a scan."""
    s = icosphere(subdivisions)
    v = s.vertices.copy()
    x, y, z = v.T
    r = 1.0 + 0.08 * np.sin(7 * x) * np.cos(5 * y) + 0.05 * np.sin(11 * z)
    v = v * r[:, None]
    v[:, 0] *= 2.0  # elongate along x: two "limbs" to bend
    v[:, 1] += 0.3 * np.cos(1.5 * v[:, 0])  # and bend it, so it is not convex
    return Mesh(v, s.faces, name="blob")


def skull_like(subdivisions: int = 3) -> Mesh:
    """A closed round shape without limbs: an ellipsoid (0.9 x 1 x 1.15) with a jaw bulging at its
    front below (642 vertices at subdivision 3)."""
    s = icosphere(subdivisions)
    v = s.vertices * [0.9, 1.0, 1.15]
    d = np.linalg.norm(v - [0.0, -0.7, 0.7], axis=1)
    v = v + (0.35 * np.exp(-(d / 0.5) ** 2))[:, None] * s.vertices
    return Mesh(v, s.faces, name="skull")


def bowl(subdivisions: int = 3) -> Mesh:
    """An open hemisphere shell of radius 1, its rim at z = 0 and its bottom at z = -1 (the triangles of
    an icosphere below z = 0.05)."""
    s = icosphere(subdivisions)
    faces = s.faces[(s.vertices[s.faces][:, :, 2] < 0.05).all(axis=1)]
    used = np.unique(faces)
    index = np.full(s.n_vertices, -1)
    index[used] = np.arange(used.size)
    return Mesh(s.vertices[used], index[faces], name="bowl")


def capsule_blob(subdivisions: int = 4):
    """A closed, bumpy capsule about 4 long along X, 2.5K vertices at subdivision 4."""
    import trimesh

    from hybridedit.core.mesh import Mesh

    s = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
    v = np.asarray(s.vertices).copy()
    x, y, z = v.T
    r = 1.0 + 0.06 * np.sin(6 * x) * np.cos(4 * y) + 0.04 * np.sin(9 * z)
    v *= r[:, None]
    v[:, 0] *= 2.0
    v[:, 1] += 0.15 * np.cos(1.2 * v[:, 0])
    return Mesh(v, np.asarray(s.faces), name="blob")


def arm_edit(ed, blob: Mesh) -> dict:
    """On ``ed`` editing ``blob`` (:func:`bumpy_blob`), select the +x end as the handle and the
    arm from about x = 0.3 as the region, and return the drag's keyword arguments: the end swung
    up about where the arm starts."""
    x = blob.vertices[:, 0]
    hand, arm = np.flatnonzero(x > 1.6), np.flatnonzero(x > 0.3)
    ed.set_selection(hand, roi=arm)
    return {"rotate": {"axis": (0, 0, 1), "degrees": 35, "center": blob.vertices[arm].mean(axis=0)},
            "translate": (0.0, 0.2, 0.0)}


def capsule_distance(p: np.ndarray, a, b, radius: float) -> np.ndarray:
    """Signed distance from points ``p`` (..., 3) to the capsule of ``radius`` about segment a-b."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    t = np.clip((p - a) @ (b - a) / np.dot(b - a, b - a), 0.0, 1.0)
    return np.linalg.norm(p - (a + t[..., None] * (b - a)), axis=-1) - radius


def smooth_union(d1: np.ndarray, d2: np.ndarray, k: float) -> np.ndarray:
    """The union of two signed distances, filleted over about ``k``."""
    h = np.maximum(k - np.abs(d1 - d2), 0.0) / k
    return np.minimum(d1, d2) - h * h * k / 4


def surface_nets(f: np.ndarray, lo: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    """The closed surface f = 0 of samples f (f < 0 inside) at lo + h (i, j, k), by surface nets:
    a vertex per grid cell the surface crosses (the mean of its edges' crossings), a quad (two
    triangles) per grid edge it crosses, between the four cells around that edge."""
    n = np.array(f.shape)
    cells = n - 1
    corners = list(itertools.product((0, 1), repeat=3))
    inside = f < 0
    count = sum(inside[i:i + cells[0], j:j + cells[1], k:k + cells[2]].astype(np.int8) for i, j, k in corners)
    active = (count > 0) & (count < 8)
    vid = np.full(cells, -1, dtype=np.int64)
    vid[active] = np.arange(int(active.sum()))
    at = np.argwhere(active)
    total, hits = np.zeros((len(at), 3)), np.zeros(len(at))
    for a in range(3):
        step = np.eye(3, dtype=np.int64)[a]
        for u, w in itertools.product((0, 1), repeat=2):
            o = np.zeros(3, dtype=np.int64)
            o[(a + 1) % 3], o[(a + 2) % 3] = u, w
            p0 = at + o
            f0, f1 = f[tuple(p0.T)], f[tuple((p0 + step).T)]
            x = (f0 < 0) != (f1 < 0)
            total[x] += p0[x] + (f0[x] / (f0[x] - f1[x]))[:, None] * step
            hits[x] += 1
    quads = []
    for a in range(3):
        b, c = (a + 1) % 3, (a + 2) % 3
        head = [slice(None)] * 3
        head[a] = slice(0, n[a] - 1)
        tail = list(head)
        tail[a] = slice(1, n[a])
        p = np.argwhere(inside[tuple(head)] != inside[tuple(tail)])
        p = p[(p[:, b] >= 1) & (p[:, c] >= 1) & (p[:, b] < n[b] - 1) & (p[:, c] < n[c] - 1)]
        around = []
        for db, dc in ((1, 1), (0, 1), (0, 0), (1, 0)):
            q = p.copy()
            q[:, b] -= db
            q[:, c] -= dc
            around.append(vid[tuple(q.T)])
        q = np.stack(around, axis=1)
        q[inside[tuple(p.T)]] = q[inside[tuple(p.T)]][:, ::-1]  # (outward)
        quads.append(q)
    q = np.concatenate(quads)
    return lo + h * total / hits[:, None], np.concatenate([q[:, [0, 2, 1]], q[:, [0, 3, 2]]])


#: where the figure's limbs end and where they leave the body (the arms at shoulder height)
ARM_TIPS = np.array([[-2.04, 0.6, 0.0], [2.04, 0.6, 0.0]])
FEET = np.array([[-0.25, -1.98, 0.0], [0.25, -1.98, 0.0]])
SHOULDERS = np.array([[-0.45, 0.6, 0.0], [0.45, 0.6, 0.0]])
HIPS = np.array([[-0.25, -0.97, 0.0], [0.25, -0.97, 0.0]])


def figure(h: float = 0.05) -> Mesh:
    """A standing figure as benchmarks/select_tear.py's, as one closed surface: a capsule body (radius
    0.45, y in [-1.05, 1.05]), two arms out to the sides at the shoulders (radius 0.14, tips at
    x = +-2.04), two legs (radius 0.18, feet at y = -1.98), filleted where they meet; sampled every
    ``h`` (5,708 vertices)."""
    lo = np.array([-2.25, -2.2, -0.65]) + [0.0131, 0.0077, 0.0113]  # (off the grid: no sample on the surface)
    axes = [np.arange(lo[i], hi + h / 2, h) for i, hi in enumerate((2.25, 1.3, 0.65))]
    p = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)
    d = capsule_distance(p, (0, -0.6, 0), (0, 0.6, 0), 0.45)
    for sx in (-1, 1):
        d = smooth_union(d, capsule_distance(p, (sx * 0.3, 0.6, 0), (sx * 1.9, 0.6, 0), 0.14), 0.1)
        d = smooth_union(d, capsule_distance(p, (sx * 0.25, -0.9, 0), (sx * 0.25, -1.8, 0), 0.18), 0.1)
    v, f = surface_nets(d, lo, h)
    return Mesh(v, f, name="figure")


def textured_glb(path: Path) -> Path:
    """A UV-mapped sphere with a material and an embedded PNG texture, split at its UV seam."""
    from PIL import Image

    sphere = trimesh.creation.uv_sphere(radius=1.0, count=[16, 16])
    sphere = trimesh.Trimesh(sphere.vertices, sphere.faces, process=False)
    uv = np.column_stack([np.arctan2(sphere.vertices[:, 1], sphere.vertices[:, 0]) / (2 * np.pi) + 0.5,
                          np.arccos(np.clip(sphere.vertices[:, 2], -1, 1)) / np.pi])
    image = Image.fromarray((np.random.default_rng(0).random((8, 8, 3)) * 255).astype(np.uint8))
    material = trimesh.visual.material.PBRMaterial(baseColorTexture=image, name="skin")
    sphere.visual = trimesh.visual.TextureVisuals(uv=uv, material=material)
    scene = trimesh.Scene()
    scene.add_geometry(sphere, transform=trimesh.transformations.translation_matrix([0, 0, 2]))
    path.write_bytes(scene.export(file_type="glb", include_normals=True))
    return path


def textured_spot(folder: Path) -> Path:
    """spot's quad mesh (SPOT, where present) with a material library and its texture, in ``folder``."""
    folder.mkdir(parents=True)
    lines = (SPOT / "spot_quadrangulated.obj").read_bytes().splitlines(keepends=True)
    first_f = next(i for i, line in enumerate(lines) if line.startswith(b"f "))
    lines[first_f:first_f] = [b"o spot\n", b"g body\n", b"usemtl spot_material\n", b"s 1\n"]
    (folder / "spot.obj").write_bytes(b"# spot, with a material\nmtllib spot.mtl\n" + b"".join(lines))
    (folder / "spot.mtl").write_text("newmtl spot_material\nKd 1 1 1\nmap_Kd textures/spot_texture.png\n")
    (folder / "textures").mkdir()
    shutil.copy(SPOT / "spot_texture.png", folder / "textures" / "spot_texture.png")
    return folder / "spot.obj"
