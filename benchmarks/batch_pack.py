"""hybridedit batch --pack: 20 poses of a 100K-vertex skull-like shape in one file, against a file per pose.

The shape (made here, no data needed) is a closed sphere sampled as a cube's six grids, 99,848
vertices, stretched to an ellipsoid (0.9 x 1 x 1.15) with a jaw bulging at its front below: a round
shape without limbs, so every pose is a bend, twist or taper of its main axis. It is posed
``--poses`` times three ways with the batch's defaults (5% cage, 45 degrees, 50% stretch, 2% least
move) on a local cluster of ``--workers`` processes, the binding from a cache the first run fills:
a file per pose (binary PLY, the input's format), ``--pack glb`` and ``--pack usd`` (where usd-core is
installed). The same seed draws the same poses each time, so the runs hold the same shapes: the
glTF pack's targets are checked against the PLY outputs (to 1e-6 of the diagonal).

Printed: the manifest's ``moved`` column (percent of the diagonal, the largest vertex
displacement of each pose); per run its seconds and the bytes it wrote (the edit files apart, the
same in each run); the same poses as one .glb each (the PLY outputs rewritten) for a like-for-like
size; and each pack's size against the files per pose.

    python benchmarks/batch_pack.py [--poses 20] [--side 129] [--workers 1] [--seed 0] [--smoke]

``--smoke`` (CI): a 2,402-vertex shape (``--side 20``), 2 poses.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from common import machine  # noqa: E402 (common puts the repo on the path)

import hybridedit as he  # noqa: E402
from hybridedit.batching.api import run  # noqa: E402
from hybridedit.batching.cluster import open_client  # noqa: E402
from hybridedit.batching.settings import BatchSettings  # noqa: E402


def cube_sphere(side: int) -> he.Mesh:
    """A unit sphere sampled as the six faces of a cube, each a ``side`` x ``side`` grid of quads split
    into triangles (6 side² + 2 vertices), outward-facing."""
    t = np.linspace(-1.0, 1.0, side + 1)
    u, v = (a.ravel() for a in np.meshgrid(t, t, indexing="ij"))
    points, faces = [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            p = np.empty((u.size, 3))
            p[:, axis] = sign
            p[:, (axis + 1) % 3], p[:, (axis + 2) % 3] = u, v
            k = np.arange(side * side)
            i, j = k // side, k % side
            a = i * (side + 1) + j
            quads = np.stack([a, a + side + 1, a + side + 2, a + 1], axis=1) + len(points) * u.size
            tri = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
            faces.append(tri if sign > 0 else tri[:, ::-1])
            points.append(p)
    p = np.concatenate(points)
    key, index = np.unique(np.round(p, 9), axis=0, return_inverse=True)  # weld the cube's edges
    f = index.ravel()[np.concatenate(faces)]
    return he.Mesh(key / np.linalg.norm(key, axis=1, keepdims=True), f)


def skull_like(side: int) -> he.Mesh:
    """:func:`cube_sphere` as an ellipsoid with a jaw (tests/shapes.py's ``skull_like``, finer)."""
    s = cube_sphere(side)
    v = s.vertices * [0.9, 1.0, 1.15]
    d = np.linalg.norm(v - [0.0, -0.7, 0.7], axis=1)
    return he.Mesh(v + (0.35 * np.exp(-(d / 0.5) ** 2))[:, None] * s.vertices, s.faces)


def load() -> str:
    try:
        return "load average {:.1f} {:.1f} {:.1f}".format(*os.getloadavg())
    except (AttributeError, OSError):
        return "load average unknown"


def timed(path: Path, out: Path, settings: BatchSettings, workers: int):
    """(table, seconds) of one batch of ``path`` on a local cluster started before the clock."""
    with open_client(workers=workers) as client:
        client.wait_for_workers(workers, timeout=120)
        t0 = time.perf_counter()
        result = run([path], out, settings=settings, client=client, progress=False)
        return result.table, time.perf_counter() - t0


def written(out: Path) -> int:
    """Bytes of the outputs in ``out``: the meshes or packs, not the edit files or the manifest."""
    return sum(p.stat().st_size for p in out.iterdir() if p.is_file() and not p.name.endswith(".edit.json")
               and p.name != "manifest.parquet")


def mb(n: int) -> str:
    return f"{n / 1e6:.2f} MB"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--poses", type=int, default=20)
    ap.add_argument("--side", type=int, default=129, help="grid side of each cube face (129: 99,848 vertices)")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--smoke", action="store_true", help="CI smoke run: a 2,402-vertex shape, 2 poses")
    args = ap.parse_args()
    poses, side = (2, 20) if args.smoke else (args.poses, args.side)
    work = Path(tempfile.mkdtemp(prefix="hybridedit-pack-bench-"))
    os.environ["HYBRIDEDIT_CACHE_DIR"] = str(work / "cache")
    try:
        mesh = skull_like(side)
        path = work / "skull.ply"
        he.write_mesh(path, mesh)
        diagonal = mesh.bbox_diagonal()
        print(f"# hybridedit batch --pack - {machine()}; {load()}")
        print(f"# skull-like shape: {mesh.n_vertices:,} vertices, {mesh.n_faces:,} triangles ({mb(path.stat().st_size)}"
              f" as binary PLY); {poses} poses, seed {args.seed}, default pose settings, {args.workers} worker(s)")
        try:
            import pxr.Usd  # noqa: F401
            packs = ["glb", "usd"]
        except ImportError:
            packs = ["glb"]
        runs = {}
        for pack in [None, *packs]:
            out = work / (pack or "separate")
            table, seconds = timed(path, out, BatchSettings(poses=poses, seed=args.seed, pack=pack), args.workers)
            runs[pack] = (out, table.to_pylist(), seconds)
        out, rows, seconds = runs[None]
        moved = [r["moved"] for r in rows if r["status"] == "done"]
        print()
        print("moved, % of the diagonal (largest vertex displacement), pose by pose:")
        print("  " + " ".join(f"{m:.1f}" for m in moved))
        print(f"  least {min(moved):.2f}, median {statistics.median(moved):.2f}, most {max(moved):.2f}; "
              f"{sum(m >= 2.0 for m in moved)} of {len(rows)} poses move at least 2%; "
              f"{sum(r['status'] == 'done' for r in rows)} done")
        done = [r for r in rows if r["status"] == "done"]
        print(f"  draws a pose {statistics.mean(r['draws'] for r in done):.1f} on average (at most "
              f"{max(r['draws'] for r in done)}); stretch {min(r['max_stretch'] for r in done):.0f}% to "
              f"{max(r['max_stretch'] for r in done):.0f}%")
        separate = written(out)
        as_glb = work / "as-glb"
        as_glb.mkdir()
        doc = he.read_document(path)
        for r in rows:
            if r["status"] == "done":
                he.write_document(as_glb / (Path(r["output"]).stem + ".glb"),
                                  doc.with_vertices(he.read_mesh(out / r["output"]).vertices))
        print()
        print(f"{'run':>22} {'seconds':>8} {'files':>6} {'bytes':>11} {'vs a .ply each':>15} {'vs a .glb each':>15}")
        print(f"{'a .ply per pose':>22} {seconds:>8.1f} {len(moved):>6} {mb(separate):>11} {1.0:>15.2f}"
              f" {separate / written(as_glb):>15.2f}")
        print(f"{'(the same as .glb)':>22} {'':>8} {len(moved):>6} {mb(written(as_glb)):>11}"
              f" {written(as_glb) / separate:>15.2f} {1.0:>15.2f}")
        for pack in packs:
            pout, prow, pseconds = runs[pack]
            size = written(pout)
            print(f"{'--pack ' + pack:>22} {pseconds:>8.1f} {1:>6} {mb(size):>11} {size / separate:>15.2f}"
                  f" {size / written(as_glb):>15.2f}")
        import pygltflib

        pout, prow, _ = runs["glb"]
        gltf = pygltflib.GLTF2.load(str(pout / "skull-poses.glb"))
        worst = 0.0
        (prim,) = gltf.meshes[0].primitives
        file_vertex = he.read_document(pout / "skull-poses.glb").native.file_vertex
        blob = gltf.binary_blob()
        base = _accessor(gltf, blob, prim.attributes.POSITION)
        for k, r in enumerate(r for r in rows if r["status"] == "done"):
            target = base + _accessor(gltf, blob, prim.targets[k]["POSITION"])
            truth = he.read_mesh(out / r["output"]).vertices[file_vertex]
            worst = max(worst, float(np.abs(target - truth).max()))
        print(f"\nthe glTF pack's targets against the PLY outputs: largest difference {worst / diagonal:.1e} of the "
              f"diagonal; edit files identical in every run: "
              f"{all((runs[p][0] / r['edit']).read_bytes() == (out / r['edit']).read_bytes() for p in packs for r in rows)}")
        print(f"# {load()} at the end")
    finally:
        shutil.rmtree(work, ignore_errors=True)


def _accessor(gltf, blob: bytes, index: int) -> np.ndarray:
    """A float VEC3 accessor's rows (dense, or zeros with its sparse rows substituted)."""
    acc = gltf.accessors[index]
    out = np.zeros((acc.count, 3))
    if acc.bufferView is not None:
        view = gltf.bufferViews[acc.bufferView]
        out = np.frombuffer(blob, "<f4", acc.count * 3, (view.byteOffset or 0) + (acc.byteOffset or 0))
        out = out.reshape(-1, 3).astype(np.float64)
    if acc.sparse is not None:
        s = acc.sparse
        iv, vv = gltf.bufferViews[s.indices.bufferView], gltf.bufferViews[s.values.bufferView]
        dt = {5121: "u1", 5123: "<u2", 5125: "<u4"}[s.indices.componentType]
        rows = np.frombuffer(blob, dt, s.count, (iv.byteOffset or 0) + (s.indices.byteOffset or 0))
        out[rows] = np.frombuffer(blob, "<f4", s.count * 3, (vv.byteOffset or 0) + (s.values.byteOffset or 0)
                                  ).reshape(-1, 3)
    return out


if __name__ == "__main__":
    main()
