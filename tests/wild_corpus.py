"""The wild corpus: real scans made into the meshes people bring (holes, parts, soups, ngons, fins,
doubled sheets), for the binding's tests and ``benchmarks/wild.py``.

Every case is made from the shared armadillo (``../shared/meshes/armadillo43k.obj``) or spot
(``../shared/meshes/spot/``), or Loop-subdivisions of them, by a deterministic recipe: nothing is
stored. A case is a :class:`hybridedit.Mesh` (polygons fan-triangulated, as the readers give them).

    python tests/wild_corpus.py OUT_DIR      writes every case as an OBJ (to look at them)
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from hybridedit.core.mesh import Mesh  # noqa: E402

SHARED = HERE.parent.parent / "shared" / "meshes"
ARMADILLO = SHARED / "armadillo43k.obj"
SPOT_QUADS = SHARED / "spot" / "spot_quadrangulated.obj"
SPOT = SHARED / "spot" / "spot_triangulated.obj"
MOUNTAIN = SHARED / "mountain" / "mountain.obj"


def available() -> bool:
    """The shared meshes the corpus is made from are here."""
    return ARMADILLO.is_file() and SPOT_QUADS.is_file()


def _edges_once(faces: np.ndarray) -> int:
    e = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    _, counts = np.unique(e, axis=0, return_counts=True)
    return int(np.count_nonzero(counts == 1))


def compact(v: np.ndarray, f: np.ndarray, name: str) -> Mesh:
    """The mesh of faces ``f`` on the vertices they use (order kept)."""
    used = np.zeros(len(v), dtype=bool)
    used[f.ravel()] = True
    remap = np.cumsum(used) - 1
    return Mesh(v[used], remap[f], name=name)


def punched(mesh: Mesh, boundary_edges: int, *, seed: int = 0) -> Mesh:
    """``mesh`` with holes punched (faces removed around random vertices) until it has about
    ``boundary_edges`` boundary edges: one hole for 10, a few for 100, many small ones for 1,000."""
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(seed)
    v, f = mesh.vertices, mesh.faces
    holes = max(1, boundary_edges // 40)
    centres = v[rng.choice(len(v), holes, replace=False)]
    dist, _ = cKDTree(centres).query(v[f].mean(axis=1))
    mean_edge = float(np.linalg.norm(v[f[:, 0]] - v[f[:, 1]], axis=1).mean())
    # the hole radius that gives the boundary wanted: at most three times that of round holes whose rims
    # share it (the boundary grows with the radius until holes meet)
    lo, hi = 0.0, 3.0 * mean_edge * boundary_edges / holes / (2.0 * np.pi)
    for _ in range(40):
        r = 0.5 * (lo + hi)
        if _edges_once(f[dist > r]) < boundary_edges:
            lo = r
        else:
            hi = r
    return compact(v, f[dist > hi], f"{mesh.name}-holes{boundary_edges}")


def cut_into_parts(mesh: Mesh, parts: int = 4) -> Mesh:
    """``mesh`` cut into ``parts`` open pieces by planes across its height, with a gap of about a
    face between pieces (the faces across each cut are left out): separate parts with open rims,
    as a character made of body, clothes and hair is."""
    v, f = mesh.vertices, mesh.faces
    y = v[f].mean(axis=1)[:, 1]
    cuts = np.quantile(y, np.linspace(0, 1, parts + 1)[1:-1])
    mean_edge = float(np.linalg.norm(v[f[:, 0]] - v[f[:, 1]], axis=1).mean())
    lo, hi = v[f][:, :, 1].min(axis=1), v[f][:, :, 1].max(axis=1)
    across = np.zeros(len(f), dtype=bool)
    for c in cuts:
        across |= (lo <= c + 0.5 * mean_edge) & (hi >= c - 0.5 * mean_edge)
    return compact(v, f[~across], f"{mesh.name}-{parts}parts")


def soup(mesh: Mesh) -> Mesh:
    """Every face with three vertices of its own (an unwelded triangle soup, as STL exporters give)."""
    f = mesh.faces
    return Mesh(mesh.vertices[f.reshape(-1)], np.arange(f.size).reshape(-1, 3), name=f"{mesh.name}-soup")


def fins(mesh: Mesh, count: int = 200, *, seed: int = 1) -> Mesh:
    """``mesh`` with ``count`` fins: a triangle on an existing edge, standing out of the surface (that
    edge then has three faces: non-manifold)."""
    rng = np.random.default_rng(seed)
    v, f = mesh.vertices, mesh.faces
    pick = rng.choice(len(f), count, replace=False)
    a, b = f[pick, 0], f[pick, 1]
    normal = np.cross(v[f[pick, 1]] - v[f[pick, 0]], v[f[pick, 2]] - v[f[pick, 0]])
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    length = np.linalg.norm(v[b] - v[a], axis=1)[:, None]
    tips = 0.5 * (v[a] + v[b]) + length * normal
    new = len(v) + np.arange(count)
    return Mesh(np.vstack([v, tips]), np.vstack([f, np.stack([b, a, new], axis=1)]), name=f"{mesh.name}-fins")


def doubled_sheet(mesh: Mesh, *, share: float = 0.15, gap: float = 0.003) -> Mesh:
    """``mesh`` with a second, separate copy of a patch of its surface lying over it, ``gap`` of the
    diagonal out along the normals (a duplicated or layered sheet: a scan's second pass, a garment
    over a body): the top ``share`` of the shape along Y."""
    v, f = mesh.vertices, mesh.faces
    y = v[f].mean(axis=1)[:, 1]
    patch = compact(v, f[y > np.quantile(y, 1.0 - share)], "")
    pv, pf = patch.vertices, patch.faces
    fn = np.cross(pv[pf[:, 1]] - pv[pf[:, 0]], pv[pf[:, 2]] - pv[pf[:, 0]])
    vn = np.zeros_like(pv)
    for k in range(3):
        np.add.at(vn, pf[:, k], fn)
    vn /= np.maximum(np.linalg.norm(vn, axis=1), 1e-300)[:, None]
    lifted = pv + gap * mesh.bbox_diagonal() * vn
    return Mesh(np.vstack([v, lifted]), np.vstack([f, pf + len(v)]), name=f"{mesh.name}-doubled")


def ngons(path: Path = SPOT_QUADS) -> Mesh:
    """Spot's quads merged in pairs into hexagons where two share an edge (the rest stay quads), then
    read as a reader gives them (fan-triangulated): a quad- and ngon-dominant asset."""
    from hybridedit.fileio.meshfiles import read_document
    import tempfile

    lines = path.read_text().splitlines()
    verts = [ln for ln in lines if ln.startswith("v ")]
    quads = [[int(t.split("/")[0]) for t in ln.split()[1:]] for ln in lines if ln.startswith("f ")]
    used = np.zeros(len(quads), dtype=bool)
    edge_of: dict[tuple[int, int], int] = {}
    polys = []
    for k, q in enumerate(quads):
        for i in range(len(q)):
            edge_of.setdefault((q[i], q[(i + 1) % len(q)]), k)
    for k, q in enumerate(quads):
        if used[k]:
            continue
        used[k] = True
        merged = None
        for i in range(len(q)):
            a, b = q[i], q[(i + 1) % len(q)]
            j = edge_of.get((b, a))
            if j is not None and not used[j] and len(quads[j]) == 4 and len(q) == 4:
                r = quads[j]
                s = r.index(a)  # r runs ... b, a ...: insert r's other two corners between a and b
                others = [r[(s + 1) % 4], r[(s + 2) % 4]]
                merged = q[: i + 1] + others + q[i + 1:]
                used[j] = True
                break
        polys.append(merged or q)
    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / "spot-ngons.obj"
        p.write_text("\n".join(verts + ["f " + " ".join(map(str, poly)) for poly in polys]) + "\n")
        mesh = read_document(p).mesh
    return Mesh(mesh.vertices, mesh.faces, name="spot-ngons")


def read(path: Path, name: str) -> Mesh:
    from hybridedit.fileio.meshfiles import read_mesh

    m = read_mesh(path)
    return Mesh(m.vertices, m.faces, name=name)


def subdivided(mesh: Mesh, times: int) -> Mesh:
    """Loop-subdivided ``times`` (trimesh): 43K -> 173K -> 690K for the armadillo."""
    import trimesh

    v, f = mesh.vertices, mesh.faces
    for _ in range(times):
        v, f = trimesh.remesh.subdivide_loop(v, f, iterations=1)
    return Mesh(np.asarray(v, dtype=np.float64), np.asarray(f, dtype=np.int64),
                name=f"{mesh.name}-x{4 ** times}")


CASES = ("closed", "holes10", "holes100", "holes1000", "parts", "soup", "fins", "doubled", "spot", "ngons",
         "mountain")
"""The corpus's cases, in order; :func:`case` makes one."""


def case(name: str, *, base: Mesh | None = None) -> Mesh:
    """One case of the corpus, made from ``base`` (default: the shared armadillo) or its own source
    (ngons: spot; mountain: the shared terrain)."""
    if name == "ngons":
        return ngons()
    if name == "spot":  # (closed: the ngons' reference)
        return read(SPOT, "spot")
    if name == "mountain":
        return read(MOUNTAIN, "mountain")
    arm = base if base is not None else read(ARMADILLO, "armadillo")
    if name == "closed":
        return arm
    if name.startswith("holes"):
        return punched(arm, int(name[5:]))
    return {"parts": cut_into_parts, "soup": soup, "fins": fins, "doubled": doubled_sheet}[name](arm)


def main(argv: list[str]) -> None:
    from hybridedit.fileio.meshfiles import write_mesh

    out = Path(argv[0]) if argv else Path("wild")
    out.mkdir(parents=True, exist_ok=True)
    for name in CASES:
        m = case(name)
        write_mesh(out / f"{name}.obj", m)
        print(f"{name:>10}: {m.n_vertices:,} vertices, {m.n_faces:,} faces, {_edges_once(m.faces):,} boundary edges")


if __name__ == "__main__":
    main(sys.argv[1:])
