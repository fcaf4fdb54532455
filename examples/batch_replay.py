"""Batch replay: write an edit file, then let the `hybridedit deform` command apply it.

The edit is the one of scripted_edit.py (raise the +X arm by swinging the hand
about the shoulder), stored as JSON with save_edit, the format the editor
window's "Save edit" writes. The command is run as a separate process,
exactly as on the command line, with --stats; the stats JSON is printed.

Run from the repository root:

    .venv/bin/python examples/batch_replay.py                     # data/creature.ply
    .venv/bin/python examples/batch_replay.py my.obj --out /tmp --cage 1000

Writes ``arm_edit.json``, ``<mesh name>_replayed.<same extension>`` (the input file
with the new positions: texture coordinates, polygons, materials and colours kept)
and ``stats.json`` to ``--out`` (default: the current folder). The same replay by hand:

    .venv/bin/hybridedit deform MESH -o OUT.obj --edit arm_edit.json --stats stats.json

In a script, the same replay without the command: ``ed = he.open(MESH)``,
``ed.apply_edit(he.load_edit("arm_edit.json"), frames=0)``, ``ed.pose(transforms=
ed.edit_transforms(edit))``, ``ed.save(OUT)``.
"""

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

import hybridedit as he
from hybridedit.cli import parse_cage_size

DEFAULT_MESH = Path(__file__).resolve().parent.parent / "data" / "creature.ply"

ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument("mesh", nargs="?", default=DEFAULT_MESH, help="input mesh (default data/creature.ply)")
ap.add_argument("--out", default=".", help="output folder (default: the current folder)")
ap.add_argument("--cage", default="0.05", help="cage vertices (2000) or fraction (0.05); default 0.05")
ap.add_argument("--degrees", type=float, default=40.0, help="how far to raise the arm")
ap.add_argument("--frames", type=int, default=30, help="ARAP frames the command runs")
args = ap.parse_args()
parse_cage_size(args.cage)  # fail here, with a clear message, rather than in the child
out = Path(args.out)
out.mkdir(parents=True, exist_ok=True)

# The selection, by bounding-box-relative coordinates: hand = handle, arm = ROI.
mesh = he.read_mesh(args.mesh)
v = mesh.vertices
lo, hi = mesh.bbox()
rel = (v - lo) / (hi - lo)
hand = np.flatnonzero(rel[:, 0] > 0.92)
arm = np.flatnonzero(rel[:, 0] > 0.65)
shoulder = v[arm[rel[arm, 0] < 0.68]].mean(axis=0)

edit = he.Edit(handle=hand, roi=arm, space="shape",
               rotate={"axis": [0, 0, 1], "degrees": args.degrees, "center": shoulder})
edit_path = out / "arm_edit.json"
he.save_edit(edit_path, edit)
assert np.allclose(he.load_edit(edit_path).transform(), edit.transform())  # round-trips
print(f"wrote {edit_path}: handle {hand.size}, ROI {arm.size} shape vertices, "
      f"{args.degrees:g} degrees about {np.round(shoulder, 3).tolist()}")

result = out / f"{Path(args.mesh).stem}_replayed{Path(args.mesh).suffix}"  # same format: nothing dropped
stats_path = out / "stats.json"
cmd = [sys.executable, "-m", "hybridedit", "deform", str(args.mesh), "-o", str(result),
       "--edit", str(edit_path), "--cage", args.cage, "--frames", str(args.frames),
       "--stats", str(stats_path)]
print("$ hybridedit " + " ".join(cmd[3:]), flush=True)
done = subprocess.run(cmd)
if done.returncode != 0:
    sys.exit(f"hybridedit deform failed (exit status {done.returncode})")

stats = json.loads(stats_path.read_text())
print(json.dumps(stats, indent=1))
print(f"RRMS edge error {stats['rrms_edge_error_percent']:.2f}% with a {stats['cage_vertices']}-vertex cage, "
      f"median frame {stats['frame_ms_median']:.2f} ms; wrote {result}")
