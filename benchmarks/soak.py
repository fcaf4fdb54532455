"""Long-session soak test: thousands of drag frames on the armadillo, then back to rest.

Usage: python benchmarks/soak.py [--frames 10000] [--extra-max 20000]
       python benchmarks/soak.py --frames 500        # CI smoke run

The canonical handle and region of interest (the +X arm, see common.canonical_edit)
with a 5% cage; the handle moves along a smooth closed path, a circle of radius 5%
of the bounding-box diagonal in the view plane (XY), one turn every 500 frames, for
``--frames`` frames (two ARAP iterations each, as in the window). Then the handle
goes back to the identity transform and frames continue until the shape is back at
its rest pose within 1e-9 of the diagonal (or ``--extra-max`` frames pass).

Checks: every frame finite; the final pose equals the rest pose within 1e-9 of the
diagonal; memory flat (resident set size at frame 1,000 and at the end). Prints a
table; exit status 1 if a check fails.
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import time

import numpy as np

from common import armadillo, canonical_edit, machine

from hybridedit import HybridEditor, rigid_transform

TURN = 500  # frames per turn of the circle
TOL = 1e-9  # of the bbox diagonal


def rss_mb() -> float:
    """Current resident set size, MB (Linux; falls back to the peak)."""
    try:
        with open("/proc/self/statm") as fh:
            pages = int(fh.read().split()[1])
        return pages * os.sysconf("SC_PAGE_SIZE") / 2**20
    except (OSError, ValueError, IndexError):
        return peak_mb()


def peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=10000, help="drag frames along the path (default 10,000)")
    ap.add_argument("--extra-max", type=int, default=20000, help="most frames allowed to settle back at rest")
    ap.add_argument("--iterations", type=int, default=2, help="ARAP iterations per frame (default 2)")
    args = ap.parse_args(argv)

    mesh = armadillo()
    rest = mesh.vertices.copy()
    diag = mesh.bbox_diagonal()
    t0 = time.perf_counter()
    ed = HybridEditor(mesh, 0.05, iterations=args.iterations)
    setup = time.perf_counter() - t0
    handle, roi, _ = canonical_edit(mesh)
    ed.set_selection(handle, roi=roi)
    radius = 0.05 * diag

    finite = True
    rss_1000 = peak_1000 = None
    t_path = time.perf_counter()
    for i in range(1, args.frames + 1):
        th = 2 * np.pi * i / TURN
        t = (radius * (np.cos(th) - 1.0), radius * np.sin(th), 0.0)  # starts and ends each turn at 0
        V = ed.drag(transform=rigid_transform(translate=t))
        if not np.isfinite(V).all():
            finite = False
            print(f"non-finite positions at frame {i}", file=sys.stderr)
            break
        if i == 1000 or (args.frames < 1000 and i == args.frames):
            rss_1000, peak_1000 = rss_mb(), peak_mb()
    path_seconds = time.perf_counter() - t_path
    frames_done = i
    dev_end_of_path = float(np.abs(ed.deformed_vertices - rest).max() / diag)

    # back to rest: identity transform until converged
    extra = 0
    dev = float("inf")
    history = []
    ident = np.eye(4)
    while extra < args.extra_max:
        V = ed.drag(transform=ident)
        extra += 1
        if not np.isfinite(V).all():
            finite = False
            break
        dev = float(np.abs(V - rest).max() / diag)
        if extra in (1, 10, 100, 1000, 10000):
            history.append((extra, dev))
        if dev <= TOL:
            break
    history.append((extra, dev))
    rss_end, peak_end = rss_mb(), peak_mb()
    ft = np.asarray(ed.frame_seconds) * 1e3

    print(f"soak: {mesh.name}, {mesh.n_vertices:,} vertices, cage {ed.cage.n_vertices:,} "
          f"(5%), {args.iterations} ARAP iterations a frame; {machine()}")
    print(f"setup (cage + bind) {setup:.2f} s; handle {ed.handle.size} / fixed {ed.fixed.size} cage vertices")
    rows = [
        ("path frames (circle r = 5% diag, 1 turn / 500)", f"{frames_done:,}"),
        ("path wall time", f"{path_seconds:.1f} s"),
        ("median / max frame", f"{np.median(ft):.2f} / {ft.max():.2f} ms"),
        ("all positions finite", "yes" if finite else "NO"),
        ("max |x - rest| at the end of the path", f"{dev_end_of_path:.3g} diag"),
    ]
    rows += [(f"  after {k:,} frame{'s' if k != 1 else ''} at identity", f"{d:.3g} diag") for k, d in history]
    rows += [
        (f"frames back to rest within {TOL:g} diag", f"{extra:,}" + ("" if dev <= TOL else " (NOT converged)")),
        ("RSS at frame 1,000 / end", f"{rss_1000:.0f} / {rss_end:.0f} MB"),
        ("peak RSS at frame 1,000 / end", f"{peak_1000:.0f} / {peak_end:.0f} MB"),
        ("frame times kept", f"{len(ed.frame_seconds):,}"),
    ]
    w = max(len(a) for a, _ in rows)
    for a, b in rows:
        print(f"  {a:<{w}}  {b}")
    ok = finite and dev <= TOL and rss_end <= rss_1000 * 1.05 + 20
    if not ok:
        print("soak: FAILED", file=sys.stderr)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
