"""A drag's frames with fewer cage iterations: frame time and the edge error of what is shown.

Usage: python benchmarks/drag_preview.py [--smoke] [--max-level 2] [--mesh-dir DIR] [--frames 30]

A user's drag is a run of frames, each a small step from the last; the window shows every one,
and at release it settles the final transform from the drag's start with the batch settings
(what ``hybridedit deform`` computes), so the pose left on screen does not depend on the frames.
This runs such a drag: the handle turned from the identity to the edit's transform in
``--frames`` equal steps (the transform's matrix logarithm scaled), for the canonical arm edit and
for the big-region edit (a quarter of the shape, ``common.quarter_edit``), on the armadillo
Loop-subdivided ``--max-level`` times (5% cage, as ``scale.py``). Each drag is run with 2 cage
ARAP iterations a frame (``hybridedit.defaults.ITERATIONS``) and with 1, alternated, twice each.

Printed per shape, edit and iterations: the frame's median milliseconds (the engine's
``frame_breakdown``: cage local and global steps, the shape's steps), and the edge error of each
shown frame over the edges of the moving region (relative RMS, %): its mean and its worst over the
drag, and at the last frame; then the ratio of the one-iteration drag's errors to the two's.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np
from scipy.linalg import expm, logm

from common import armadillo, canonical_edit, machine, quarter_edit
from scale import subdivided_armadillo

from hybridedit import HybridEditor, build_rig, read_mesh
from hybridedit.core.mesh import edge_error_stats
from hybridedit.core.topology import edge_index

#: the one-iteration drag's edge error over the two-iteration one's, at most (mean over a drag)
ERROR_RATIO = 1.05


def drag_steps(T: np.ndarray, frames: int) -> list[np.ndarray]:
    """``frames`` transforms from (near) the identity to ``T`` (4, 4), equal steps of its screw motion."""
    L = np.real(logm(T))
    return [expm(L * (k / frames)) for k in range(1, frames + 1)]


def region_edges(edges: np.ndarray, roi: np.ndarray, n: int) -> np.ndarray:
    """The edges with an end in ``roi`` (the edges a drag can stretch)."""
    inside = np.zeros(n, dtype=bool)
    inside[roi] = True
    return edges[inside[edges[:, 0]] | inside[edges[:, 1]]]


def one_drag(ed: HybridEditor, handle, roi, steps, iterations: int, rest, edges) -> dict:
    """The drag from the rest pose with ``iterations`` a frame: medians (ms) and edge errors (%)."""
    ed.reset()
    ed.set_selection(handle, roi=roi)
    parts = {"local_seconds": [], "global_seconds": [], "propagate_seconds": [], "total_seconds": []}
    errs = []
    for T in steps:
        V = ed.drag(transform=T, iterations=iterations)
        for k in parts:
            parts[k].append(ed.frame_breakdown[k])
        errs.append(edge_error_stats(rest, V, edges)[0])
    out = {k: 1e3 * float(np.median(v)) for k, v in parts.items()}
    out.update(mean_err=float(np.mean(errs)), worst_err=float(np.max(errs)), last_err=errs[-1])
    return out


def run_shape(shape, frames: int, cache: str) -> list[tuple]:
    rig = build_rig(shape, cage_size=0.05, cache=cache)
    ed = HybridEditor(rig)
    edges = edge_index(shape.faces, shape.n_vertices)[0]
    rows = []
    for name, edit in (("arm", canonical_edit), ("quarter", quarter_edit)):
        handle, roi, T = edit(shape)
        steps = drag_steps(T, frames)
        e = region_edges(edges, roi, shape.n_vertices)
        got: dict[int, list[dict]] = {2: [], 1: []}
        for iterations in (2, 1, 2, 1):  # (alternated: both see the same machine)
            got[iterations].append(one_drag(ed, handle, roi, steps, iterations, shape.vertices, e))
        for iterations in (2, 1):
            runs = got[iterations]
            merged = {k: float(np.median([r[k] for r in runs])) for k in runs[0]}
            rows.append((shape.name, name, iterations, merged))
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--smoke", action="store_true", help="CI smoke run: the 43K armadillo, 8 frames")
    ap.add_argument("--max-level", type=int, default=2, help="Loop subdivisions of the armadillo (0-4)")
    ap.add_argument("--mesh-dir", default=None, help="where the subdivided armadillos are kept (scale.py's)")
    ap.add_argument("--frames", type=int, default=30)
    args = ap.parse_args()
    frames = 8 if args.smoke else args.frames
    print(f"# {machine()}")
    print(f"# a drag of {frames} frames from the identity to the edit's transform, 2 and 1 cage iterations "
          "a frame; frame medians in ms; edge error of the shown frames over the moving region's edges, %")
    with tempfile.TemporaryDirectory() as tmp:
        cache = tmp + "/cache"
        if args.smoke or args.max_level == 0:
            shape = armadillo()
        else:
            shape = read_mesh(subdivided_armadillo(args.max_level, Path(args.mesh_dir or tmp)))
            shape.name = f"armadillo {shape.n_vertices / 1e6:.2f}M" if shape.n_vertices >= 1e6 \
                else f"armadillo {shape.n_vertices // 1000}K"
        rows = run_shape(shape, frames, cache)
    head = (f"{'shape':>16} {'edit':>8} {'it':>3} {'frame':>7} {'local':>6} {'global':>6} {'shape':>6} "
            f"{'mean err':>9} {'worst':>7} {'last':>7}")
    print(head)
    print("-" * len(head))
    for shape_name, edit, it, r in rows:
        print(f"{shape_name:>16} {edit:>8} {it:>3} {r['total_seconds']:>7.2f} {r['local_seconds']:>6.2f} "
              f"{r['global_seconds']:>6.2f} {r['propagate_seconds']:>6.2f} {r['mean_err']:>9.3f} "
              f"{r['worst_err']:>7.3f} {r['last_err']:>7.3f}")
    worst = 0.0
    for (s2, e2, _, two), (_, _, _, one) in zip(rows[0::2], rows[1::2]):
        ratio = one["mean_err"] / two["mean_err"]
        worst = max(worst, ratio)
        print(f"# {s2} {e2}: 1 iteration / 2, mean error {ratio:.3f}, worst {one['worst_err'] / two['worst_err']:.3f}, "
              f"frame {one['total_seconds'] / two['total_seconds']:.2f}")
    print(f"# worst mean-error ratio {worst:.3f} ({'within' if worst <= ERROR_RATIO else 'NOT within'} "
          f"{ERROR_RATIO:g})")


if __name__ == "__main__":
    sys.exit(main())
