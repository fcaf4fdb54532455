"""Speed and accuracy of bind() on a real mesh with QEM cages of several sizes.

Usage (from the repository root)::

    .venv/bin/python benchmarks/bind_speed.py
    .venv/bin/python benchmarks/bind_speed.py --meshes /path/to/meshes --cages 1000 2000 5000

For every cage size the shape is simplified with fast_simplification, then
``bind(shape vertices, cage)`` is timed once (after a warm-up call on a tiny
input, so that compilation is not counted). Columns:

* ``bind s``      wall-clock seconds of the call, ``cpu s`` the process CPU time
  in it (cpu / wall shows how many cores actually worked);
* ``ns/pair``     wall-clock ns per (point, cage face) pair, and the same in CPU
  time (``cpu ns/pair``, i.e. per core);
* ``nnz/row``     mean and max nonzeros per row of the truncated matrix;
* ``rrms``        sqrt(mean |M @ cage - points|^2) / bbox diagonal of the shape,
  ``max`` the largest |M @ cage - points| / diagonal.
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

from hybridedit.binding import bind  # noqa: E402
from hybridedit.mesh import Mesh  # noqa: E402


def load_mesh(path: Path) -> Mesh:
    """The mesh at ``path`` through hybridedit.io, or trimesh if that is missing."""
    try:
        from hybridedit.io import read_mesh
    except ImportError:
        read_mesh = None
    if read_mesh is not None:
        return read_mesh(path)
    import trimesh

    m = trimesh.load(path, process=False, force="mesh")
    return Mesh(np.asarray(m.vertices, dtype=float), np.asarray(m.faces, dtype=np.int64), name=path.name)


def simplify(mesh: Mesh, n_vertices: int) -> Mesh:
    reduction = 1.0 - n_vertices / mesh.n_vertices
    v, f = fast_simplification.simplify(mesh.vertices, mesh.faces, target_reduction=reduction)
    return Mesh(np.asarray(v, dtype=float), np.asarray(f, dtype=np.int64), name=f"cage{n_vertices}")


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
                    help="cage vertex counts (default: 1000 2000 5000)")
    ap.add_argument("--truncation", type=float, default=0.03)
    ap.add_argument("--threads", type=int, default=None, help="numba threads (default: all)")
    args = ap.parse_args(argv)

    path = args.meshes / args.mesh
    if not path.exists():
        print(f"mesh not found: {path}", file=sys.stderr)
        return 2
    if args.threads:
        numba.set_num_threads(args.threads)

    mesh = load_mesh(path)
    pts = mesh.vertices
    diag = mesh.bbox_diagonal()
    print(f"{path.name}: {mesh.n_vertices} vertices, {mesh.n_faces} faces; "
          f"truncation {args.truncation}; {numba.get_num_threads()} threads "
          f"({os.cpu_count()} CPUs)")

    # Warm-up: compile (or load from the cache) every kernel once.
    t0 = time.perf_counter()
    bind(pts[:64], simplify(mesh, 200), truncation=args.truncation)
    print(f"warm-up (compile or cache load): {time.perf_counter() - t0:.2f} s\n")

    head = (f"{'cage V':>7} {'cage F':>7} {'bind s':>7} {'cpu s':>7} {'ns/pair':>8} "
            f"{'cpu ns/pair':>11} {'nnz/row':>8} {'max':>5} {'rrms':>9} {'max':>9}")
    print(head)
    print("-" * len(head))
    for target in args.cages:
        cage = simplify(mesh, target)
        t0 = time.perf_counter()
        c0 = time.process_time()
        M = bind(pts, cage, truncation=args.truncation)
        wall = time.perf_counter() - t0
        cpu = time.process_time() - c0
        pairs = len(pts) * cage.n_faces
        nnz = np.diff(M.indptr)
        err = np.linalg.norm(M @ cage.vertices - pts, axis=1)
        rrms = float(np.sqrt(np.mean(err**2)) / diag)
        print(f"{cage.n_vertices:>7} {cage.n_faces:>7} {wall:>7.2f} {cpu:>7.2f} "
              f"{wall * 1e9 / pairs:>8.2f} {cpu * 1e9 / pairs:>11.2f} {nnz.mean():>8.1f} "
              f"{nnz.max():>5} {rrms:>9.2e} {err.max() / diag:>9.2e}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
