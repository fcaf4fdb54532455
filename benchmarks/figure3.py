"""The paper's Figure 3: edge error relative to full-mesh ARAP, against cage size.

Usage: python benchmarks/figure3.py [--out figure3.png] [--smoke]

For the armadillo at 21.6K and 43K vertices and a range of cage sizes, run the
canonical edit (benchmarks/common.py) for 30 frames of 2 iterations with the
paper's propagation x' = M y' and with the residual propagation, and divide the
RRMS-E by that of converged full-mesh ARAP (500 iterations, cotangent weights)
on the same edit. Draws both shapes and both modes to a PNG with the one point
of the paper's figure we have (43K, 5,000-vertex cage: 2.25x) and prints the
values.
"""

from __future__ import annotations

import argparse
import sys

from common import REPO, armadillo, armadillo_21k, machine
from table1 import full_constraints, run_hybrid

from hybridedit import rrms_edge_error
from hybridedit.deform.arap import ARAPSolver

PAPER_POINTS = {"43K": [(5000, 2.25)]}
SIZES = {"21K": (250, 500, 1000, 1500, 2000, 3000, 4000), "43K": (500, 1000, 1500, 2000, 3000, 5000)}


def converged(shape, iterations=500) -> float:
    b, target = full_constraints(shape)
    s = ARAPSolver(shape.vertices, shape.faces, weights="cotangent")
    s.set_constrained(b)
    return rrms_edge_error(shape.vertices, s.solve(target, iterations), shape.edges())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(REPO / "benchmarks" / "figure3.png"))
    ap.add_argument("--smoke", action="store_true", help="two small cages on the 21.6K shape only")
    args = ap.parse_args(argv)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    full = armadillo()
    shapes = {"21K": armadillo_21k(full), "43K": full}
    sizes = dict(SIZES)
    if args.smoke:
        shapes = {"21K": shapes["21K"]}
        sizes = {"21K": (200, 400)}
    print(f"# Figure 3 — {machine()}")
    print(f"{'shape':>16} {'cage':>6} {'cage %':>7} {'linear':>8} {'residual':>9}   (RRMS-E / converged full ARAP)")
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for key, shape in shapes.items():
        ref = converged(shape, 30 if args.smoke else 500)
        xs, lin, res = [], [], []
        for n in sizes[key]:
            rows = run_hybrid(shape, n, 30, variants=(("uniform", "linear"), ("uniform", "residual")))
            pct = rows[0]["cage_pct"]
            xs.append(pct)
            lin.append(rows[0]["rrms30"] / ref)
            res.append(rows[1]["rrms30"] / ref)
            print(f"{shape.name:>16} {rows[0]['cage']:>6d} {pct:>7.2f} {lin[-1]:>8.2f} {res[-1]:>9.2f}", flush=True)
        ax.plot(xs, lin, "o-", label=f"{shape.name}, x' = M y' (paper's method)")
        ax.plot(xs, res, "s--", label=f"{shape.name}, residual propagation")
        for n, ratio in PAPER_POINTS.get(key, []):
            ax.plot([100.0 * n / shape.n_vertices], [ratio], "k*", markersize=12,
                    label=f"paper, {shape.name} (the point we have)")
    ax.axhline(1.0, color="gray", lw=0.8)
    ax.set_xlabel("cage size (% of shape vertices)")
    ax.set_ylabel("RRMS-E / converged full-mesh ARAP")
    ax.set_title("Edge error of hybrid editing vs. cage size (canonical arm edit)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(args.out, dpi=120)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
