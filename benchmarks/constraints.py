"""How exactly edits do what was asked: fixed-vertex drift and handle error.

Usage: python benchmarks/constraints.py [--smoke] [--frames 30]

For each case, 30 frames of the default settings (5% cage, 2 iterations a frame,
residual propagation, cotangent weights), then:
  fixed drift  = max over the fixed shape vertices of |x' - x|,
  handle miss  = max over the handle shape vertices of |x' - T x|,
both in % of the bounding-box diagonal, and the relative RMS edge-length error
(RRMS-E, %) of the pose. Cases: the armadillo (../shared/meshes) with the
canonical arm swing (rotation) and a translation-only lift; a flat 120 x 120
sheet with a corner lifted; the armadillo with everything fixed but the handle.
Then symmetric editing: the result's asymmetry on an exactly mirror-symmetric
shape and on the near-symmetric default creature.
"""

from __future__ import annotations

import argparse

import numpy as np

from common import REPO, armadillo, canonical_edit, machine

from hybridedit import HybridEditor, Mesh, apply_transform, read_mesh, rigid_transform, rrms_edge_error


def sheet(k: int) -> Mesh:
    """A flat k x k grid of unit squares split into triangles, in the XY plane."""
    i, j = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
    v = np.stack([i.ravel(), j.ravel(), np.zeros(k * k)], axis=1).astype(np.float64) / (k - 1)
    a = (i[:-1, :-1] * k + j[:-1, :-1]).ravel()
    b, c, d = a + k, a + k + 1, a + 1
    f = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return Mesh(v, f, name=f"sheet {k}x{k}")


def symmetric_blob(subdivisions: int) -> Mesh:
    """An elongated, bent, bumpy sphere that is exactly mirror-symmetric across x = 0."""
    import trimesh

    s = trimesh.creation.icosphere(subdivisions=subdivisions)
    v = np.asarray(s.vertices).copy()
    x, y, z = v.T
    v *= (1.0 + 0.08 * np.cos(7 * x) * np.cos(5 * y) + 0.05 * np.sin(11 * z))[:, None]
    v[:, 0] *= 2.0
    v[:, 1] += 0.3 * np.cos(1.5 * v[:, 0])
    return Mesh(v, np.asarray(s.faces), name="symmetric blob")


def measure(mesh: Mesh, handle, T, *, roi=None, fixed=None, frames=30, cage=0.05):
    ed = HybridEditor(mesh, cage)
    ed.set_selection(handle, roi=roi, fixed=fixed)
    for _ in range(frames):
        V = ed.drag(transform=T)
    n = mesh.n_vertices
    if fixed is None:
        inside = np.zeros(n, dtype=bool)
        inside[roi] = True
        inside[handle] = True
        fixed = np.flatnonzero(~inside)
    x = mesh.vertices
    diag = mesh.bbox_diagonal()
    drift = float(np.linalg.norm(V[fixed] - x[fixed], axis=1).max(initial=0.0)) / diag * 100
    miss = float(np.linalg.norm(V[handle] - apply_transform(T, x[handle]), axis=1).max()) / diag * 100
    err = rrms_edge_error(x, V, mesh.edges())
    return ed.cage.n_vertices, drift, miss, err


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--smoke", action="store_true", help="tiny run for CI")
    args = ap.parse_args()
    frames = 3 if args.smoke else args.frames
    print(f"# constraints - {machine()}; {frames} frames, default settings; drift and miss in % of the diagonal")
    print(f"{'case':>34} {'verts':>7} {'cage':>6} {'fixed drift':>12} {'handle miss':>12} {'RRMS-E':>8}")
    rows = []
    k = 30 if args.smoke else 120
    s = sheet(k)
    v = s.vertices
    h = np.flatnonzero((v[:, 0] > 0.85) & (v[:, 1] > 0.85))
    roi = np.flatnonzero((v[:, 0] > 0.4) & (v[:, 1] > 0.4))
    rows.append((f"sheet {k}x{k}, corner lift", s, h, rigid_transform(translate=(0, 0, 0.2)), dict(roi=roi)))
    if not args.smoke:
        a = armadillo()
        handle, roi, T = canonical_edit(a)
        rows.append(("armadillo 43K, arm swing 40 deg", a, handle, T, dict(roi=roi)))
        lift = rigid_transform(translate=(0, 0.1 * a.bbox_diagonal(), 0))
        rows.append(("armadillo 43K, hand lift (transl.)", a, handle, lift, dict(roi=roi)))
        rest = np.setdiff1d(np.arange(a.n_vertices), handle)
        rows.append(("armadillo 43K, all fixed but hand", a, handle, lift, dict(fixed=rest)))
    for name, mesh, handle, T, sel in rows:
        c, drift, miss, err = measure(mesh, handle, T, frames=frames, **sel)
        print(f"{name:>34} {mesh.n_vertices:>7} {c:>6} {drift:>12.3g} {miss:>12.3g} {err:>8.3f}")
    print()
    print("# symmetric editing (symmetry='x'): asymmetry of the result and of the displacement, "
          "% of the diagonal (max over vertices)")
    print(f"{'case':>34} {'verts':>7} {'shape asym':>11} {'result asym':>12} {'displ asym':>11}")
    cases = [("mirror-symmetric blob", symmetric_blob(3 if args.smoke else 5))]
    if not args.smoke:
        cases.append(("creature (data/, near-symmetric)", read_mesh(REPO / "data" / "creature.ply")))
    for name, mesh in cases:
        v = mesh.vertices
        lo, hi = v.min(axis=0), v.max(axis=0)
        r = (v - lo) / (hi - lo)
        ed = HybridEditor(mesh, 0.05)
        ed.set_selection(np.flatnonzero(r[:, 0] > 0.92), roi=np.flatnonzero(r[:, 0] > 0.6), symmetry="x")
        T = rigid_transform(translate=0.05 * mesh.bbox_diagonal() * np.array([0.5, 1.0, 0.3]),
                            axis=(0, 0, 1), degrees=15, center=v[r[:, 0] > 0.92].mean(axis=0))
        for _ in range(frames):
            V = ed.drag(transform=T)
        mir = ed.symmetry
        S, m = mir.S, mir.map
        diag = mesh.bbox_diagonal()
        res = np.linalg.norm(V[m] @ S[:3, :3].T + S[:3, 3] - V, axis=1).max() / diag * 100
        u = V - v
        dis = np.linalg.norm(u[m] @ S[:3, :3].T - u, axis=1).max() / diag * 100
        print(f"{name:>34} {mesh.n_vertices:>7} {mir.asymmetry * 100:>11.3g} {res:>12.3g} {dis:>11.3g}")


if __name__ == "__main__":
    main()
