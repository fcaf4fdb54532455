"""Scaling to 100K+ vertices: bind (cold and cached), frame breakdown, memory, libigl beside.

Usage: python benchmarks/scale.py [--smoke] [--frames 50]

Shapes: the armadillo Loop-subdivided once (172,966 vertices) and the default
mesh data/creature.ply (generated, ~100K vertices), each with a 5% cage. For
each: cage build seconds, cold bind seconds (no cache), cached load seconds (cage
+ binding from the on-disk cache), frame ms (median over the frames of the
canonical edit: 2 ARAP iterations + propagation) split into local step / global
step / propagation, the peak resident memory of the process so far, and libigl's
full-mesh ARAP (one iteration per solve, same constraints) per iteration on the
same mesh, with the ratio of its iteration to our whole frame.
"""

from __future__ import annotations

import argparse
import resource
import sys
import tempfile

import numpy as np
import trimesh

from common import REPO, Timer, armadillo, canonical_edit, machine

from hybridedit import HybridEditor, Mesh, apply_transform, read_mesh


def peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def subdivided_armadillo() -> Mesh:
    a = armadillo()
    s = trimesh.Trimesh(a.vertices, a.faces, process=False).subdivide_loop(1)
    return Mesh(np.asarray(s.vertices), np.asarray(s.faces), name=f"armadillo {len(s.vertices) / 1000:.0f}K")


def creature() -> Mesh | None:
    p = REPO / "data" / "creature.ply"
    if not p.exists():
        return None
    m = read_mesh(p)
    m.name = f"creature {m.n_vertices / 1000:.0f}K"
    return m


def creature_edit(mesh: Mesh):
    """Raise the creature's +X hand: the handle is the outer 8% along +X, the ROI the arm."""
    v = mesh.vertices
    lo, hi = v.min(axis=0), v.max(axis=0)
    r = (v - lo) / (hi - lo)
    handle = np.flatnonzero(r[:, 0] > 0.92)
    roi = np.flatnonzero(r[:, 0] > 0.68)
    shoulder = v[roi[r[roi, 0] < 0.71]].mean(axis=0)
    from hybridedit import rigid_transform

    return handle, roi, rigid_transform(axis=(0, 0, 1), degrees=40.0, center=shoulder)


def libigl_iteration_ms(shape: Mesh, handle, roi, T, iterations: int) -> tuple[float, float] | None:
    if iterations < 1:
        return None
    try:
        import igl
    except ImportError:
        return None
    inside = np.zeros(shape.n_vertices, bool)
    inside[roi] = True
    inside[handle] = True
    b = np.union1d(handle, np.flatnonzero(~inside))
    target = shape.vertices[b].copy()
    hm = np.isin(b, handle)
    target[hm] = apply_transform(T, target[hm])
    data = igl.ARAPData()
    data.max_iter = 1
    data.energy = igl.ARAP_ENERGY_TYPE_SPOKES
    with Timer() as pre:
        igl.arap_precomputation(shape.vertices, shape.faces, 3, b.astype(np.int32), data)
    U = shape.vertices.copy()
    times = []
    for _ in range(iterations):
        with Timer() as t:
            U = igl.arap_solve(target, data, U)
        times.append(t.seconds)
    return 1e3 * float(np.median(times)), pre.seconds


def run(shape: Mesh, edit, frames: int, igl_iters: int) -> dict:
    handle, roi, T = edit
    with tempfile.TemporaryDirectory() as cache:
        cold = HybridEditor(shape, 0.05, cache=cache)
        cached = HybridEditor(shape, 0.05, cache=cache)
        assert cached.cache_hit
    ed = cold
    ed.set_selection(handle, roi=roi)
    parts = {"local_seconds": [], "global_seconds": [], "propagate_seconds": [], "total_seconds": []}
    for _ in range(frames):
        ed.drag(transform=T)
        for k in parts:
            parts[k].append(ed.frame_breakdown[k])
    med = {k: 1e3 * float(np.median(v)) for k, v in parts.items()}
    out = {
        "cage": ed.cage.n_vertices,
        "cage_s": cold.timings["cage_seconds"],
        "bind_s": cold.timings["bind_seconds"],
        "cached_s": cached.timings["cage_seconds"] + cached.timings["bind_seconds"],
        "nnz": ed.nnz_per_row,
        "rows": len(ed.moving_vertices),
        **med,
        "peak_mb": peak_mb(),
    }
    ig = libigl_iteration_ms(shape, handle, roi, T, igl_iters)
    out["igl_ms"], out["igl_pre_s"] = ig if ig else (np.nan, np.nan)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=50)
    ap.add_argument("--smoke", action="store_true", help="CI smoke run: the 43K armadillo, 3 frames, no libigl")
    args = ap.parse_args(argv)
    print(f"# scale — {machine()}")
    print("# frame = 2 ARAP iterations + propagation, median; local/global/prop split that frame; "
          "libigl = one full-mesh ARAP iteration")
    if args.smoke:
        a = armadillo()
        shapes = [(a, canonical_edit(a))]
        frames, igl_iters = 3, 0
    else:
        big = subdivided_armadillo()
        shapes = [(big, canonical_edit(big))]
        c = creature()
        if c is not None:
            shapes.append((c, creature_edit(c)))
        frames, igl_iters = args.frames, 5
    head = (f"{'shape':>16} {'verts':>7} {'cage':>5} {'cage s':>6} {'bind s':>6} {'cached s':>8} {'nnz':>5} "
            f"{'moving':>7} {'frame ms':>8} {'local':>6} {'global':>6} {'prop':>6} {'peak MB':>7} "
            f"{'igl it ms':>9} {'igl/frame':>9}")
    print(head)
    print("-" * len(head))
    for shape, edit in shapes:
        r = run(shape, edit, frames, igl_iters)
        ratio = r["igl_ms"] / r["total_seconds"] if igl_iters else np.nan
        print(f"{shape.name:>16} {shape.n_vertices:>7d} {r['cage']:>5d} {r['cage_s']:>6.2f} {r['bind_s']:>6.2f} "
              f"{r['cached_s']:>8.3f} {r['nnz']:>5.1f} {r['rows']:>7d} {r['total_seconds']:>8.3f} "
              f"{r['local_seconds']:>6.3f} {r['global_seconds']:>6.3f} {r['propagate_seconds']:>6.3f} "
              f"{r['peak_mb']:>7.0f} {r['igl_ms']:>9.1f} {ratio:>9.0f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
