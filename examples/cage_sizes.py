"""Cage size trade-off: the same edit with cages of several sizes, plotted.

For each cage size the script builds the cage and binding from scratch (no
cache, so the bind time is real), raises the +X arm as in scripted_edit.py
(solved to convergence with pose, so that every size is compared at its own
finished pose), and records the relative RMS edge-length error of the result, with the default
"residual" propagation and with the paper's plain "linear" x' = M y' (same
cage and binding). A bigger cage follows the shape more closely and distorts
it less, but takes longer to bind and to solve each frame.

Run from the repository root (the default sizes bind the 100K-vertex creature
four times, under a minute in all):

    .venv/bin/python examples/cage_sizes.py
    .venv/bin/python examples/cage_sizes.py my.obj --out /tmp --cage 200 500 1000 2000

Writes ``cage_sizes.png`` to ``--out`` (default: the current folder).
"""

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import hybridedit as he  # noqa: E402
from hybridedit.cli import parse_cage_size  # noqa: E402

DEFAULT_MESH = Path(__file__).resolve().parent.parent / "data" / "creature.ply"

ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument("mesh", nargs="?", default=DEFAULT_MESH, help="input mesh (default data/creature.ply)")
ap.add_argument("--out", default=".", help="output folder (default: the current folder)")
ap.add_argument("--cage", type=parse_cage_size, nargs="+", default=[0.005, 0.01, 0.02, 0.05],
                help="cage sizes to compare: vertex counts (500) or fractions (0.01)")
ap.add_argument("--degrees", type=float, default=40.0, help="how far to raise the arm")
ap.add_argument("--tolerance", type=float, default=1e-6,
                help="solve until a frame moves less than this fraction of the bounding-box diagonal")
args = ap.parse_args()

mesh = he.read_mesh(args.mesh)
v, edges = mesh.vertices, mesh.edges()
lo, hi = mesh.bbox()
rel = (v - lo) / (hi - lo)
hand = np.flatnonzero(rel[:, 0] > 0.92)
arm = np.flatnonzero(rel[:, 0] > 0.65)
shoulder = v[arm[rel[arm, 0] < 0.68]].mean(axis=0)
raise_arm = he.rigid_transform(axis=(0, 0, 1), degrees=args.degrees, center=shoulder)


def edge_error(editor: he.HybridEditor) -> float:
    editor.set_selection(hand, roi=arm)
    deformed = editor.pose(transform=raise_arm, tolerance=args.tolerance)
    return he.rrms_edge_error(v, deformed, edges)


# Run the compiled kernels once on a tiny problem, so that just-in-time compilation
# (or loading the compiled code) is not counted in the first size's bind time.
he.bind(v[:: max(1, mesh.n_vertices // 200)], he.build_cage(mesh, 50))
print(f"{Path(args.mesh).name}: {mesh.n_vertices} vertices, the arm raised {args.degrees:g} degrees")
print(f"{'cage':>6} {'bind s':>7} {'frame ms':>8} {'residual %':>10} {'linear %':>8}")
rows = []
for size in sorted(args.cage, key=lambda s: s if isinstance(s, int) else s * mesh.n_vertices):
    ed = he.HybridEditor(mesh, size)
    err_residual = edge_error(ed)
    linear = he.HybridEditor(mesh, cage=ed.cage, binding=ed.M, propagation="linear")
    row = (ed.cage.n_vertices, ed.timings["bind_seconds"], np.median(ed.frame_seconds) * 1e3,
           err_residual, edge_error(linear))
    rows.append(row)
    print(f"{row[0]:6d} {row[1]:7.2f} {row[2]:8.2f} {row[3]:10.2f} {row[4]:8.2f}")

cage_n, bind_s, frame_ms, err_res, err_lin = np.array(rows).T
fig, (left, middle, right) = plt.subplots(1, 3, figsize=(13, 4), layout="constrained")
left.plot(cage_n, err_res, "o-", label="residual propagation (default)")
left.plot(cage_n, err_lin, "s--", label="linear x' = M y' (the paper)")
left.set(ylabel="RRMS edge-length error (%)", title=f"edge error, arm raised {args.degrees:g}\u00b0")
left.legend()
middle.plot(cage_n, bind_s, "o-", color="C2")
middle.set(ylabel="seconds", title="bind time (mean value coordinates)")
right.plot(cage_n, frame_ms, "o-", color="C3")
right.set(ylabel="milliseconds", title="frame time (median)")
for ax in (left, middle, right):
    ax.set(xscale="log", xlabel="cage vertices", ylim=(0, None))
    ax.minorticks_off()
    ax.set_xticks(cage_n, [str(int(n)) for n in cage_n])
fig.suptitle(f"{Path(args.mesh).name}: {mesh.n_vertices} vertices")
png = Path(args.out) / "cage_sizes.png"
png.parent.mkdir(parents=True, exist_ok=True)
fig.savefig(png, dpi=120)
print(f"wrote {png}")
