"""Cage build time at scale, and what the cage does to loose parts, sheets and tiny meshes.

Usage: python benchmarks/cage_build.py [--smoke] [--code PATH] [--meshes DIR]

Table 1, cage build alone (repair pass + QEM per part, no binding) of the armadillo
Loop-subdivided once (173K) and twice (690K), written to ``--meshes`` (default: a
temporary folder) the first time, each with one QEM pass and with two halves
simplified at once (:mod:`hybridedit.cage.qem`), and how close each cage is to the
shape (libigl's point-mesh distance both ways, in % of the bounding-box
diagonal). ``--smoke`` uses a 10K ellipsoid instead.

Table 2, the part and sheet cases (each a translation-only edit, 30 frames of the
default settings), with what each figure means:

* overlapping spheres: two unit spheres 1.2 apart, the far cap of one dragged by 15%
  of the diagonal, the far cap of the other fixed: the largest displacement (% of
  the diagonal; 15 asked) and how many vertices move more than 1.05 times the drag;
* 2 mm beside 2 m: a 1 mm-radius sphere 0.5 m from a 1 m-radius one; the small one
  half dragged, half fixed, the big one fixed: the largest edge stretch on the small
  sphere, beside the same edit on the small sphere alone;
* eye in a head: a small sphere inside a bigger one near its top, the top cap of the
  head dragged, its bottom fixed, the eye unconstrained: the eye's mean displacement
  beside how the head's inside moves there (the mean value coordinates of the eye's
  vertices in the head's cage, rest and deformed; 1 x = it follows its host);
* loose part: a sphere far from the edited one, unconstrained: its largest
  displacement (% of the diagonal; 0 = it stays);
* 120x120 sheet: the left third fixed, the right strip lifted by 15% of the
  diagonal: fixed drift and handle error (% of the diagonal), largest stretch (%),
  largest dihedral angle (degrees) between neighbouring faces (kinks), nonzeros a row;
* scan with holes: a bumpy blob with three holes, one end lifted, the other fixed;
* tiny meshes: an 8-vertex cube and a 42-vertex sphere, one corner lifted.

``--code PATH`` imports hybridedit from another checkout (e.g. /work/main) to print the
figures before a change; a case the code refuses prints its one-line reason.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument("--smoke", action="store_true", help="small meshes only (CI)")
ap.add_argument("--code", help="import hybridedit from this checkout instead of this one")
ap.add_argument("--meshes", help="folder for the subdivided armadillos (kept between runs)")
args = ap.parse_args()
if args.code:
    sys.path.insert(0, str(Path(args.code).resolve()))
else:
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import hybridedit  # noqa: E402  (before common, which would put this checkout first)
import trimesh  # noqa: E402

from common import armadillo, machine  # noqa: E402

from hybridedit import HybridEditor, Mesh  # noqa: E402
from hybridedit.cage.build import build_cage  # noqa: E402
from hybridedit.core.mesh import edge_stretch  # noqa: E402


def sphere(center, radius: float, sub: int = 3) -> tuple[np.ndarray, np.ndarray]:
    s = trimesh.creation.icosphere(subdivisions=sub, radius=radius)
    return np.asarray(s.vertices) + np.asarray(center, float), np.asarray(s.faces)


def union(*parts) -> Mesh:
    vs, fs, k = [], [], 0
    for v, f in parts:
        vs.append(v)
        fs.append(f + k)
        k += len(v)
    return Mesh(np.vstack(vs), np.vstack(fs))


def drag(mesh: Mesh, handle, fixed, move, frames: int = 30) -> np.ndarray:
    ed = HybridEditor(mesh, 0.05)
    ed.set_selection(handle, fixed=fixed)
    for _ in range(frames):
        V = ed.drag(translate=move)
    return V


def case(name: str, fn) -> None:
    try:
        figures = fn()
    except Exception as e:  # noqa: BLE001 -- a refused case prints why
        figures = "refused: " + " ".join(str(e).split())[:110]
    print(f"| {name} | {figures} |", flush=True)


def subdivided(folder: Path, times: int) -> Mesh:
    p = folder / f"armadillo-loop{times}.npz"
    if not p.exists():
        a = armadillo()
        t = trimesh.Trimesh(a.vertices, a.faces, process=False)
        for _ in range(times):
            t = t.subdivide_loop(1)
        np.savez(p, v=np.asarray(t.vertices), f=np.asarray(t.faces))
    d = np.load(p)
    return Mesh(d["v"], d["f"].astype(np.int64), name=f"armadillo {len(d['v']) / 1000:.0f}K")


def cage_distances(m: Mesh, c: Mesh) -> str:
    """Mean and largest distance (% of the diagonal) from 20K shape vertices to the cage surface and
    from 20K cage vertices to the shape surface (libigl's point-mesh distance), or 'n/a'."""
    try:
        import igl
    except ImportError:
        return "n/a | n/a"
    rng = np.random.default_rng(0)
    diag = m.bbox_diagonal()
    cols = []
    for pts, target in ((m.vertices, c), (c.vertices, m)):
        sample = pts[rng.choice(len(pts), min(20000, len(pts)), replace=False)]
        d = np.sqrt(igl.point_mesh_squared_distance(sample, target.vertices, target.faces.astype(np.int32))[0])
        cols.append(f"{100 * d.mean() / diag:.4f} / {100 * d.max() / diag:.3f}")
    return " | ".join(cols)


def build_times() -> None:
    """One QEM pass against two halves on two cores (hybridedit.cage.qem), same process, best of 2."""
    from hybridedit.cage import qem

    print("| shape | vertices | QEM | cage vertices | cage build s (best of 2) "
          "| shape->cage mean / max % | cage->shape mean / max % |")
    print("|---|---|---|---|---|---|---|")
    if args.smoke:
        s = trimesh.creation.icosphere(subdivisions=5)
        shapes = [Mesh(np.asarray(s.vertices) * [2, 1, 1], np.asarray(s.faces), name="ellipsoid 10K")]
        halves_from = 0  # (too small to split by default: split anyway, so that the path runs)
    else:
        folder = Path(args.meshes) if args.meshes else Path(tempfile.mkdtemp())
        folder.mkdir(parents=True, exist_ok=True)
        shapes = [subdivided(folder, 1), subdivided(folder, 2)]
        halves_from = qem.SPLIT_MIN_FACES
    build_cage(shapes[0], 0.05)  # compile what is compiled
    default = qem.SPLIT_MIN_FACES
    try:
        for m in shapes:
            for label, limit in (("one pass", 1 << 62), ("two halves", halves_from)):
                qem.SPLIT_MIN_FACES = limit
                best = np.inf
                for _ in range(2):
                    t0 = time.perf_counter()
                    c = build_cage(m, 0.05)
                    best = min(best, time.perf_counter() - t0)
                print(f"| {m.name} | {m.n_vertices:,} | {label} | {c.n_vertices:,} | {best:.2f} "
                      f"| {cage_distances(m, c)} |", flush=True)
    finally:
        qem.SPLIT_MIN_FACES = default


def overlapping() -> str:
    a, b = sphere([0, 0, 0], 1.0), sphere([1.2, 0, 0], 1.0)
    m = union(a, b)
    x = m.vertices[:, 0]
    handle = np.flatnonzero((x < -0.7) & (np.arange(m.n_vertices) < len(a[0])))
    diag = m.bbox_diagonal()
    V = drag(m, handle, np.flatnonzero(x > 1.9), (0, 0.15 * diag, 0))
    d = np.linalg.norm(V - m.vertices, axis=1)
    return f"largest displacement {100 * d.max() / diag:.1f}% (15 asked), {int((d > 1.05 * 0.15 * diag).sum())} vertices past 1.05x"


def two_scales() -> str:
    big, small = sphere([0, 0, 0], 1.0), sphere([1.5, 0, 0], 0.001)
    m = union(big, small)
    nb = len(big[0])
    s = np.arange(nb, m.n_vertices)
    y = m.vertices[s, 1]
    V = drag(m, s[y > 0.0005], np.concatenate([np.arange(nb), s[y < -0.0005]]), (0.0005, 0, 0))
    e = m.edges()
    st = np.abs(edge_stretch(m.vertices, V, e))[e[:, 0] >= nb].max()
    alone = Mesh(*small)
    ya = alone.vertices[:, 1]
    V2 = drag(alone, np.flatnonzero(ya > 0.0005), np.flatnonzero(ya < -0.0005), (0.0005, 0, 0))
    st2 = np.abs(edge_stretch(alone.vertices, V2, alone.edges())).max()
    return f"largest stretch on the 2 mm sphere {100 * st:.1f}% (the same edit on it alone: {100 * st2:.1f}%)"


def eye_in_head() -> str:
    head, eye = sphere([0, 0, 0], 1.0), sphere([0, 0.6, 0.3], 0.15, sub=2)
    m = union(head, eye)
    nh = len(head[0])
    y = m.vertices[:nh, 1]
    ed = HybridEditor(m, 0.05)
    ed.set_selection(np.flatnonzero(y > 0.8), fixed=np.flatnonzero(y < -0.3))
    for _ in range(30):
        V = ed.drag(translate=(0, 0, 0.3))
    eye_d = np.linalg.norm((V - m.vertices)[nh:].mean(axis=0))
    # how the head's inside moves where the eye is: mean value coordinates of the eye's
    # vertices in the head's cage piece (the largest connected piece), rest and deformed
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    from hybridedit.binding.bind import bind

    cage = ed.cage
    f = cage.faces
    g = sp.coo_matrix((np.ones(3 * len(f)), (f.ravel(), f[:, [1, 2, 0]].ravel())), shape=(cage.n_vertices,) * 2)
    labels = connected_components(g, directed=False)[1]
    head_piece = labels == np.argmax(np.bincount(labels))
    loc = np.cumsum(head_piece) - 1
    Me = bind(m.vertices[nh:], Mesh(cage.vertices[head_piece], loc[f[head_piece[f[:, 0]]]]), truncation=0.0)
    cur = ed.arap.positions
    ref = np.linalg.norm((Me @ cur[head_piece] - Me @ cage.vertices[head_piece]).mean(axis=0))
    return f"eye moves {eye_d:.3f}, the head's inside at the eye {ref:.3f} ({eye_d / ref:.2f} x)"


def loose_part() -> str:
    a, b = sphere([0, 0, 0], 1.0), sphere([5, 0, 0], 0.5)
    m = union(a, b)
    na = len(a[0])
    y = m.vertices[:na, 1]
    V = drag(m, np.flatnonzero(y > 0.8), np.flatnonzero(y < -0.3), (0, 0.3, 0))
    return f"the far sphere moves {100 * np.abs(V[na:] - m.vertices[na:]).max() / m.bbox_diagonal():.2g}% of the diagonal"


def grid(n: int, size: float) -> Mesh:
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1))
    v = np.column_stack([i.ravel() * size / n, j.ravel() * size / n, np.zeros((n + 1) ** 2)])
    a = (j[:-1, :-1] * (n + 1) + i[:-1, :-1]).ravel()
    f = np.concatenate([np.stack([a, a + 1, a + n + 2], 1), np.stack([a, a + n + 2, a + n + 1], 1)])
    return Mesh(v, f)


def sheet() -> str:
    m = grid(120 if not args.smoke else 40, 120.0)
    x = m.vertices[:, 0]
    handle, fixed = np.flatnonzero(x > 110), np.flatnonzero(x < 40)
    diag = m.bbox_diagonal()
    ed = HybridEditor(m, 0.05)
    ed.set_selection(handle, fixed=fixed)
    for _ in range(30):
        V = ed.drag(translate=(0, 0, 0.15 * diag))
    drift = np.abs(V[fixed] - m.vertices[fixed]).max() / diag
    miss = np.linalg.norm(V[handle] - m.vertices[handle] - [0, 0, 0.15 * diag], axis=1).max() / diag
    st = np.abs(edge_stretch(m.vertices, V, m.edges())).max()
    ang = np.degrees(trimesh.Trimesh(V, m.faces, process=False).face_adjacency_angles.max())
    return (f"cage {ed.cage.n_vertices}: fixed drift {100 * drift:.2f}%, handle error {100 * miss:.2f}%, "
            f"largest stretch {100 * st:.1f}%, largest dihedral {ang:.1f} deg, {ed.nnz_per_row:.0f} nonzeros a row")


def scan_with_holes() -> str:
    s = trimesh.creation.icosphere(subdivisions=4)
    v = np.asarray(s.vertices) * [2, 1, 1]
    f = np.asarray(s.faces)
    c = v[f].mean(axis=1)
    keep = ~((np.linalg.norm(c - [0, 0, 1], axis=1) < 0.3) | (np.linalg.norm(c - [1, 0.6, 0.6], axis=1) < 0.25)
             | (np.linalg.norm(c - [-1, -0.6, 0.6], axis=1) < 0.25))
    m = Mesh(v, f[keep])
    x = v[:, 0]
    diag = m.bbox_diagonal()
    ed = HybridEditor(m, 0.05)
    handle, fixed = np.flatnonzero(x > 1.6), np.flatnonzero(x < -1.0)
    ed.set_selection(handle, fixed=fixed)
    for _ in range(30):
        V = ed.drag(translate=(0, 0.15 * diag, 0))
    used = np.unique(m.faces)
    drift = np.abs(V[np.intersect1d(fixed, used)] - v[np.intersect1d(fixed, used)]).max() / diag
    st = np.abs(edge_stretch(v, V, m.edges())).max()
    return f"cage {ed.cage.n_vertices}: fixed drift {100 * drift:.2f}%, largest stretch {100 * st:.1f}%"


def tiny(kind: str) -> str:
    if kind == "cube":
        b = trimesh.creation.box()
        m = Mesh(np.asarray(b.vertices), np.asarray(b.faces))
    else:
        s = trimesh.creation.icosphere(subdivisions=1)
        m = Mesh(np.asarray(s.vertices), np.asarray(s.faces))
    v = m.vertices
    top = int(np.argmax(v @ [1, 1, 1]))
    fixed = np.flatnonzero(v @ [1, 1, 1] < 0)
    diag = m.bbox_diagonal()
    V = drag(m, [top], fixed, (0, 0.1 * diag, 0))
    miss = np.linalg.norm(V[top] - v[top] - [0, 0.1 * diag, 0]) / diag
    return f"edited: the corner lands {100 * miss:.2g}% of the diagonal off its target"


print(f"# cage_build.py ({machine()}; hybridedit from {Path(hybridedit.__file__).parent.parent})")
build_times()
print()
print("| case | figures |")
print("|---|---|")
case("overlapping spheres", overlapping)
case("2 mm beside 2 m", two_scales)
case("eye in a head (unconstrained, follows its host)", eye_in_head)
case("loose part (unconstrained, no host)", loose_part)
case("120x120 sheet" if not args.smoke else "120x120 sheet (40x40 grid)", sheet)
case("scan with holes", scan_with_holes)
case("8-vertex cube", lambda: tiny("cube"))
case("42-vertex sphere", lambda: tiny("sphere"))
