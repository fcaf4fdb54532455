"""Speed and accuracy of bind(), exact, flat and fast (hierarchical) methods side by side.

Usage (from the repository root)::

    .venv/bin/python benchmarks/bind_speed.py            # the 43K armadillo, cages 1000/2000/5000
    .venv/bin/python benchmarks/bind_speed.py --large    # and the 173K armadillo with a 5% cage
    .venv/bin/python benchmarks/bind_speed.py --meshes /path/to/meshes --cages 1000 2000

The 173K shape is the armadillo Loop-subdivided once with trimesh
(``trimesh.Trimesh(v, f, process=False).subdivide_loop(1)``, 172,966
vertices); its cage is QEM-simplified to 5% of its vertices. Cages are made
with fast_simplification. ``bind(shape vertices, cage)`` is timed after a
warm-up call (compilation or cache load not counted), the minimum of
``--repeat`` runs. Columns, for each method:

* ``s``        wall-clock seconds of the call;
* ``ns/pair``  wall-clock ns per (point, cage face) pair;
* ``nnz/row``  mean nonzeros per row of the truncated matrix;
* ``rrms``     sqrt(mean |M @ cage - points|^2) / bbox diagonal of the shape;
* ``same``     (flat and fast) the fraction of rows keeping exactly the entries
  the exact method keeps;

and ``row diff``: the largest difference between the flat and the exact
un-truncated coordinates of a point, ``max_j |fast_j - exact_j| / sum_j
|exact_j|``, over the points of ``--sample-batches`` random batches of the
fast kernel (computed as bind computes them, with the linear precision
correction of un-truncated rows).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import fast_simplification  # noqa: E402
import numba  # noqa: E402

from hybridedit.binding import mvc  # noqa: E402
from hybridedit.binding.bind import bind  # noqa: E402
from hybridedit.core.mesh import Mesh  # noqa: E402


def load_mesh(path: Path) -> Mesh:
    """The mesh at ``path`` through hybridedit.fileio.meshfiles, or trimesh if that is missing."""
    try:
        from hybridedit.fileio.meshfiles import read_mesh
    except ImportError:
        read_mesh = None
    if read_mesh is not None:
        return read_mesh(path)
    import trimesh

    m = trimesh.load(path, process=False, force="mesh")
    return Mesh(np.asarray(m.vertices, dtype=float), np.asarray(m.faces, dtype=np.int64), name=path.name)


def subdivide(mesh: Mesh) -> Mesh:
    """One step of Loop subdivision (trimesh), as in the 173K benchmark shape."""
    import trimesh

    s = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False).subdivide_loop(1)
    return Mesh(np.asarray(s.vertices, dtype=float), np.asarray(s.faces, dtype=np.int64),
                name=f"{mesh.name} subdivided")


def simplify(mesh: Mesh, n_vertices: int) -> Mesh:
    reduction = 1.0 - n_vertices / mesh.n_vertices
    v, f = fast_simplification.simplify(mesh.vertices, mesh.faces, target_reduction=reduction)
    return Mesh(np.asarray(v, dtype=float), np.asarray(f, dtype=np.int64), name=f"cage{n_vertices}")


def timed_bind(pts, cage, method, truncation, repeat):
    best = np.inf
    M = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        M = bind(pts, cage, truncation=truncation, method=method)
        best = min(best, time.perf_counter() - t0)
    return best, M


def row_difference(pts, cage, n_batches, rng) -> float:
    """Largest fast-vs-exact row difference (relative to the row's magnitude)
    over the points of ``n_batches`` random batches of the fast kernel."""
    fast = mvc.prepare_fast_cage(cage.vertices, cage.faces)
    plan = mvc.plan_fast(np.ascontiguousarray(pts, dtype=float), fast)
    n_total = -(-len(pts) // mvc.LANES)
    worst = 0.0
    for b in rng.choice(n_total, size=min(n_batches, n_total), replace=False):
        start = int(b) * mvc.LANES
        stop = min(len(pts), start + mvc.LANES)
        rows = np.empty((stop - start, cage.n_vertices))
        mvc.compute_fast_sorted(plan, fast, start, stop, rows)
        f_rows = np.empty_like(rows)
        f_rows[:, fast.perm] = rows
        e_rows = mvc.mean_value_coordinates(pts[plan.order[start:stop]], cage.vertices, cage.faces)
        d = np.abs(f_rows - e_rows).max(axis=1) / np.abs(e_rows).sum(axis=1)
        worst = max(worst, float(d.max()))
    return worst


def stats(M, cage, pts, diag):
    err = np.linalg.norm(M @ cage.vertices - pts, axis=1)
    return M.nnz / M.shape[0], float(np.sqrt(np.mean(err**2)) / diag)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--meshes",
        type=Path,
        default=REPO.parent / "shared" / "meshes",
        help="folder holding the meshes (default: ../shared/meshes from the repository root)",
    )
    ap.add_argument("--mesh", default="armadillo43k.obj", help="mesh file name in --meshes")
    ap.add_argument("--cages", type=int, nargs="+", default=[1000, 2000, 5000],
                    help="cage vertex counts for the mesh itself (default: 1000 2000 5000)")
    ap.add_argument("--large", action="store_true",
                    help="also the mesh Loop-subdivided once with a 5%% cage (exact takes ~20-40 s)")
    ap.add_argument("--truncation", type=float, default=0.03)
    ap.add_argument("--repeat", type=int, default=2, help="timed runs per method (min is shown)")
    ap.add_argument("--sample-batches", type=int, default=40,
                    help="fast-kernel batches whose rows are compared with exact ones")
    ap.add_argument("--threads", type=int, default=None, help="numba threads (default: all)")
    args = ap.parse_args(argv)

    path = args.meshes / args.mesh
    if not path.exists():
        print(f"mesh not found: {path}", file=sys.stderr)
        return 2
    if args.threads:
        numba.set_num_threads(args.threads)

    mesh = load_mesh(path)
    cases = [(mesh, simplify(mesh, n)) for n in args.cages]
    if args.large:
        big = subdivide(mesh)
        cases.append((big, simplify(big, round(0.05 * big.n_vertices))))
    print(f"{path.name}: {mesh.n_vertices} vertices; truncation {args.truncation}; "
          f"{numba.get_num_threads()} threads ({os.cpu_count()} CPUs); fast: far ratio "
          f"{mvc.FAR_RATIO}, {mvc.LANES} points per batch")

    # Warm-up: compile (or load from the cache) every kernel once.
    t0 = time.perf_counter()
    small = simplify(mesh, 200)
    for method in ("exact", "flat", "fast"):
        bind(mesh.vertices[:64], small, truncation=args.truncation, method=method)
        bind(mesh.vertices[:64], small, truncation=0.0, method=method)
    print(f"warm-up (compile or cache load): {time.perf_counter() - t0:.2f} s\n")

    head = (f"{'shape V':>8} {'cage V':>6} {'cage F':>6} | {'exact s':>7} {'ns/pair':>7} "
            f"{'nnz/row':>7} {'rrms':>8} | {'flat s':>7} {'nnz/row':>7} {'rrms':>8} {'same':>5} | "
            f"{'fast s':>7} {'ns/pair':>7} {'nnz/row':>7} {'rrms':>8} {'same':>5} | {'speedup':>7} "
            f"{'row diff':>8}")
    print(head)
    print("-" * len(head))
    rng = np.random.default_rng(0)
    for shape, cage in cases:
        pts = shape.vertices
        diag = shape.bbox_diagonal()
        pairs = len(pts) * cage.n_faces
        cols = []
        exact_sets = None
        for method in ("exact", "flat", "fast"):
            secs, M = timed_bind(pts, cage, method, args.truncation, args.repeat)
            nnz, rrms = stats(M, cage, pts, diag)
            sets = np.split(M.indices, M.indptr[1:-1])
            if exact_sets is None:
                exact_sets, same = sets, 1.0
            else:
                same = float(np.mean([np.array_equal(a, b) for a, b in zip(sets, exact_sets)]))
            cols.append((secs, secs * 1e9 / pairs, nnz, rrms, same))
            del M
        diff = row_difference(pts, cage, args.sample_batches, rng)
        (es, ens, ennz, err, _), (ls, _, lnnz, lrr, lsame), (fs, fns, fnnz, frr, fsame) = cols
        print(f"{shape.n_vertices:>8} {cage.n_vertices:>6} {cage.n_faces:>6} | {es:>7.2f} {ens:>7.2f} "
              f"{ennz:>7.1f} {err:>8.2e} | {ls:>7.2f} {lnnz:>7.1f} {lrr:>8.2e} {lsame:>5.3f} | "
              f"{fs:>7.2f} {fns:>7.2f} {fnnz:>7.1f} {frr:>8.2e} {fsame:>5.3f} | "
              f"{es / fs:>7.1f} {diff:>8.1e}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
