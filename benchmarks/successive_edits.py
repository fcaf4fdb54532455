"""Successive edits on the armadillo: each starts where the last ended, and the distortion does not pile up.

Five edits, one after another, as a user poses a scan: the right arm up, the left
arm up, the head turned, each foot kicked. Each is a new selection on the posed
shape followed by ``--frames`` drags (the window's settle, ``hybridedit deform``'s
default), optionally a polish. Printed per edit: the largest move of an identity
drag right after the new selection (what the user sees when the next edit
starts; it must be rounding), and the relative RMS edge-length error of the pose
after the edit.

The yardstick: converged full-resolution ARAP from the rest pose in one solve
(libigl, cotangent spokes; and this project's own ARAPSolver), with every handle
of the five edits at its final position and everything outside their regions of
interest held at rest.

    python benchmarks/successive_edits.py [--frames 30] [--polish] [--smoke]
"""

from __future__ import annotations

import argparse

import numpy as np

from common import Timer, armadillo, machine  # noqa: E402 (common puts the repo on the path)

import hybridedit as he  # noqa: E402
from hybridedit.deform.arap import ARAPSolver  # noqa: E402
from hybridedit.core.mesh import rrms_edge_error  # noqa: E402
from hybridedit.core.transforms import rigid_transform  # noqa: E402


def five_edits(mesh: he.Mesh) -> list[tuple[str, np.ndarray, np.ndarray, np.ndarray]]:
    """(name, handle, roi, transform) of each edit, in bounding-box terms (Y up, facing +Z)."""
    v = mesh.vertices
    lo, hi = v.min(axis=0), v.max(axis=0)
    r = (v - lo) / (hi - lo)
    edits = []
    for side, sign in (("right", 1), ("left", -1)):
        x = r[:, 0] if sign > 0 else 1.0 - r[:, 0]
        hand = np.flatnonzero((x > 0.877) & (r[:, 1] > 0.62))
        arm = np.flatnonzero((x > 0.70) & (r[:, 1] > 0.52))
        shoulder = v[arm[x[arm] < 0.73]].mean(axis=0)
        edits.append((f"{side} arm up 40°", hand, arm,
                      rigid_transform(axis=(0, 0, sign), degrees=40.0, center=shoulder)))
    head = np.flatnonzero((r[:, 1] > 0.90) & (np.abs(r[:, 0] - 0.5) < 0.2))
    neck_region = np.flatnonzero((r[:, 1] > 0.74) & (np.abs(r[:, 0] - 0.5) < 0.25))
    neck = v[neck_region[r[neck_region, 1] < 0.77]].mean(axis=0)
    edits.append(("head turned 25°", head, neck_region, rigid_transform(axis=(0, 1, 0), degrees=25.0, center=neck)))
    for side, cond in (("right", r[:, 0] > 0.5), ("left", r[:, 0] < 0.5)):
        foot = np.flatnonzero(cond & (r[:, 1] < 0.07))
        leg = np.flatnonzero(cond & (r[:, 1] < 0.33))
        hip = v[leg[r[leg, 1] > 0.30]].mean(axis=0)
        edits.append((f"{side} foot forward 20°", foot, leg,
                      rigid_transform(axis=(1, 0, 0), degrees=-20.0, center=hip)))
    return edits


def reference(mesh: he.Mesh, edits, V: np.ndarray, iterations: int):
    """Converged full ARAP from rest with the five handles at their final positions in ``V``."""
    handles = np.unique(np.concatenate([h for _, h, _, _ in edits]))
    inside = np.zeros(mesh.n_vertices, bool)
    for _, h, roi, _ in edits:
        inside[roi] = True
        inside[h] = True
    b = np.union1d(handles, np.flatnonzero(~inside))
    target = np.where(np.isin(b, handles)[:, None], V[b], mesh.vertices[b])
    out = {}
    s = ARAPSolver(mesh.vertices, mesh.faces, weights="cotangent")
    s.set_constrained(b)
    out["ours"] = rrms_edge_error(mesh.vertices, s.solve(target, iterations), mesh.edges())
    try:
        import igl
    except ImportError:
        return out
    data = igl.ARAPData()
    data.max_iter = iterations
    data.energy = igl.ARAP_ENERGY_TYPE_SPOKES
    igl.arap_precomputation(mesh.vertices, mesh.faces, 3, b.astype(np.int32), data)
    U = igl.arap_solve(target, data, mesh.vertices.copy())
    out["libigl"] = rrms_edge_error(mesh.vertices, U, mesh.edges())
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=30, help="drags per edit (hybridedit deform's default)")
    ap.add_argument("--cage", type=float, default=0.05, help="cage size (fraction of the shape's vertices)")
    ap.add_argument("--polish", action="store_true", help="polish after each edit (until converged, as the window does)")
    ap.add_argument("--smoke", action="store_true", help="tiny run for CI: 2%% cage, 3 frames, short references")
    args = ap.parse_args(argv)
    frames = 3 if args.smoke else args.frames
    cage = 0.02 if args.smoke else args.cage
    mesh = armadillo()
    edges = mesh.edges()
    diag = mesh.bbox_diagonal()
    print(f"# Successive edits — {machine()}")
    print(f"# {mesh.name}, {mesh.n_vertices:,} vertices, cage {cage:g}, {frames} frames per edit"
          f"{', polished after each' if args.polish else ''}")
    ed = he.HybridEditor(he.build_rig(mesh, cage_size=cage, cache=True))
    edits = five_edits(mesh)
    head = f"{'edit':>22} {'handle':>7} {'ROI':>7} {'jump at start':>14} {'RRMS-E %':>9} {'ms/frame':>9}"
    print(head)
    print("-" * len(head))
    for name, handle, roi, T in edits:
        before = ed.deformed_vertices.copy()
        ed.set_selection(handle, roi=roi)
        jump = np.abs(ed.drag(translate=(0.0, 0.0, 0.0)) - before).max() / diag
        with Timer() as t:
            for _ in range(frames):
                ed.drag(transform=T)
        if args.polish:
            ed.polish()
        err = rrms_edge_error(mesh.vertices, ed.deformed_vertices, edges)
        print(f"{name:>22} {handle.size:>7,} {roi.size:>7,} {jump:>14.1e} {err:>9.3f} "
              f"{1e3 * t.seconds / frames:>9.2f}", flush=True)
    final = rrms_edge_error(mesh.vertices, ed.deformed_vertices, edges)
    ref = reference(mesh, edits, ed.deformed_vertices, 20 if args.smoke else 300)
    print("-" * len(head))
    for who, e in ref.items():
        print(f"converged full ARAP from rest, same final handles ({who}): RRMS-E {e:.3f} %; "
              f"five successive edits {final:.3f} % = {final / e:.2f}x")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
