"""Scripted edit through the Python API: raise the creature's +X arm.

Opens a mesh file for editing (he.open: the file's texture coordinates, polygons,
materials and colours are kept; the cage is built by QEM and bound by truncated
mean value coordinates), selects the +X hand as the handle and the +X arm as the
region of interest (both by coordinates relative to the bounding box, so any
shape elongated along X works), solves the hand swung up about the shoulder to
convergence (pose), saves the edited file with everything it had (save) and
prints the edge-length error and the timings.

Run from the repository root:

    .venv/bin/python examples/scripted_edit.py                     # data/creature.ply
    .venv/bin/python examples/scripted_edit.py my.obj --out /tmp --cage 1000 --degrees 60

Writes ``<mesh name>_raised.<same extension>`` to ``--out`` (default: the current folder).
"""

import argparse
from pathlib import Path

import numpy as np

import hybridedit as he
from hybridedit.cli import parse_cage_size
from hybridedit.core.mesh import edge_stretch

DEFAULT_MESH = Path(__file__).resolve().parent.parent / "data" / "creature.ply"

ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument("mesh", nargs="?", default=DEFAULT_MESH, help="input mesh (default data/creature.ply)")
ap.add_argument("--out", default=".", help="output folder (default: the current folder)")
ap.add_argument("--cage", type=parse_cage_size, default=0.05, help="cage vertices (2000) or fraction (0.05)")
ap.add_argument("--degrees", type=float, default=40.0, help="how far to raise the arm")
ap.add_argument("--tolerance", type=float, default=1e-6,
                help="solve until a frame moves less than this fraction of the bounding-box diagonal")
ap.add_argument("--no-cache", action="store_true", help="do not reuse or store the cage and binding")
args = ap.parse_args()

editor = he.open(args.mesh, args.cage, cache=not args.no_cache)
mesh = editor.mesh
print(f"{Path(args.mesh).name}: {mesh.n_vertices} vertices; cage {editor.cage.n_vertices} vertices, "
      f"{editor.nnz_per_row:.1f} coordinates a vertex{' (from the cache)' if editor.cache_hit else ''}")

# Bounding-box-relative coordinates in [0, 1]: the hand is the last 8% along +X,
# the arm everything past 65% (on the creature: outward of the shoulder joint).
v = mesh.vertices
lo, hi = mesh.bbox()
rel = (v - lo) / (hi - lo)
hand = np.flatnonzero(rel[:, 0] > 0.92)
arm = np.flatnonzero(rel[:, 0] > 0.65)
shoulder = v[arm[rel[arm, 0] < 0.68]].mean(axis=0)  # where the arm meets the fixed part
editor.set_selection(hand, roi=arm)
print(f"handle: {hand.size} vertices -> {editor.handle.size} cage vertices; "
      f"{editor.fixed.size} cage vertices fixed")

# Rotate the hand about +Z through the shoulder: +X swings towards +Y (up). pose() runs
# drag frames (the window's step, one a mouse event) until the shape stops moving.
deformed = editor.pose(rotate={"axis": (0, 0, 1), "degrees": args.degrees, "center": shoulder},
                       tolerance=args.tolerance)

# save() writes the opened file back with the new positions: UVs, quads, materials
# (and their images, copied next to it) survive, unlike he.write_mesh(out, editor.deformed).
out = Path(args.out) / f"{Path(args.mesh).stem}_raised{Path(args.mesh).suffix}"
out.parent.mkdir(parents=True, exist_ok=True)
for note in editor.save(out):
    print(f"note: {note}")

edges = mesh.edges()
stretch = edge_stretch(v, deformed, edges)
ms = np.array(editor.frame_seconds) * 1e3
print(f"hand moved by {np.linalg.norm(deformed[hand].mean(0) - v[hand].mean(0)):.3f} "
      f"(bbox diagonal {mesh.bbox_diagonal():.3f})")
print(f"RRMS edge error {he.rrms_edge_error(v, deformed, edges):.2f}%, "
      f"largest stretch {np.abs(stretch).max() * 100:.1f}%")
print(f"cage {editor.timings['cage_seconds']:.2f} s, bind {editor.timings['bind_seconds']:.2f} s, "
      f"frame median {np.median(ms):.2f} ms (max {ms.max():.2f} ms), converged in {ms.size} frames")
print("last frame: " + ", ".join(f"{k.removesuffix('_seconds')} {s * 1e3:.2f} ms"
                                 for k, s in editor.frame_breakdown.items()))
print(f"wrote {out}")
