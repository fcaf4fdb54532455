"""A pose solved to convergence three ways, side by side: frames, plain cage iterations, the converge.

Usage: python benchmarks/converge.py [--smoke] [--shapes 173k,692k,sphere] [--mesh-dir DIR]

On the armadillo Loop-subdivided once and twice (173K, 692K vertices, made by ``scale.py``'s
``subdivided_armadillo`` into ``--mesh-dir``, a temporary folder by default) and a bumped,
elongated UV sphere of 1M vertices, each with a 5% cage (as the Blender add-on binds it; the
cage and binding come from the user cache, ``cache=True``, so a second run builds fast), the
issue's edit: the +X hand (the upper-right 6% along X; its arm, 35%, the region) moved up 12%
of the diagonal and turned 30 degrees about X and 20 about Y about its centre. Two starts:

``jump``
    from the pose the selection was set in (an animation frame solved from the bound rest);
``settle``
    after 30 live frames (2 iterations each) along the way to the edit: what a window's or
    the add-on's settle starts from when the handles stop.

Each is solved three ways:

(a) ``frames``: today's rule, :meth:`~hybridedit.HybridEditor.pose`: whole frames (2 cage
    iterations and a propagation each) until one moves no vertex by more than 1e-6 of the
    diagonal;
(b) ``plain``: cage-only iterations (one ``solve_cage`` each) until the distance they estimate
    (the last move times r / (1 - r), r the ratio of the last two moves) is 1e-6 of the
    diagonal, then one propagation;
(c) ``converge``: :meth:`~hybridedit.HybridEditor.converge` (L-BFGS with a line search, a bound on
    the distance; tolerance 1e-6 of the diagonal).

"true" is the largest distance of a cage vertex (and of a shape vertex) from the fixed point, a
fraction of the diagonal, and "energy" the cage's ARAP energy against the fixed point's (relative:
below 0 where a run found a lower minimum than the plain iterations' from the same start); the fixed point is the plain iterations run from the same start until
50 of them move no cage vertex by more than 1e-12 of the diagonal (then within about 1e-11). The
settle's fixed point can differ from the jump's: the energy has more than one minimum there.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from common import machine
from scale import subdivided_armadillo

from hybridedit import HybridEditor, Mesh, read_mesh
from hybridedit.deform.frame_steps import cage_targets, solve_cage

TOLERANCE = 1e-6
LIVE_FRAMES = 30


def bumped_sphere(n: int) -> Mesh:
    """A sphere of 6 n^2 + 2 vertices (a cube's faces cut in n x n squares, pushed out to the sphere:
    no poles, triangles of about one size), bumped and elongated along X as the tests' blob.

    (Not trimesh's UV sphere: its poles gather a thousand slivers each, and the QEM cage of one
    keeps its vertices there, 3 of 50K at the +X end.)"""
    import trimesh

    t = np.linspace(-1.0, 1.0, n + 1)
    a, b = (g.ravel() for g in np.meshgrid(t, t, indexing="ij"))
    one = np.ones_like(a)
    k = np.arange(n * (n + 1)).reshape(n, n + 1)[:, :n].ravel()  # each square's corner (i, j)
    quad = np.stack([k, k + n + 1, k + n + 2, k + 1], axis=1)
    tris = np.concatenate([quad[:, [0, 1, 2]], quad[:, [0, 2, 3]]])
    verts, faces = [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            p = np.empty((a.size, 3))
            p[:, axis] = sign * one
            p[:, (axis + 1) % 3], p[:, (axis + 2) % 3] = a, b
            faces.append((tris if sign > 0 else tris[:, ::-1]) + len(verts) * a.size)
            verts.append(p)
    s = trimesh.Trimesh(np.concatenate(verts), np.concatenate(faces), process=False)
    s.merge_vertices()
    v = np.asarray(s.vertices) / np.linalg.norm(s.vertices, axis=1)[:, None]
    x, y, z = v.T
    v *= (1.0 + 0.08 * np.sin(7 * x) * np.cos(5 * y) + 0.05 * np.sin(11 * z))[:, None]
    v[:, 0] *= 2.0
    v[:, 1] += 0.3 * np.cos(1.5 * v[:, 0])
    return Mesh(v, np.asarray(s.faces), name=f"bumped sphere {len(v) / 1e6:.1f}M")


def issue_edit(mesh: Mesh, *, upper: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The +X hand (the outer 6% along X; with ``upper``, of the top 45% only), its arm (35%) the region,
    and the hand's transform: up 12% of the diagonal, turned 30 degrees about X and 20 about Y."""
    P = mesh.vertices
    X, Y = P[:, 0], P[:, 1]
    keep = Y > Y.min() + 0.55 * np.ptp(Y) if upper else np.ones(len(P), dtype=bool)
    handle = np.flatnonzero((X > X.max() - 0.06 * np.ptp(X)) & keep)
    roi = np.flatnonzero((X > X.max() - 0.35 * np.ptp(X)) & keep)
    c = P[handle].mean(axis=0)
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("xy", [30, 20], degrees=True).as_matrix()
    T[:3, 3] = c - T[:3, :3] @ c + np.array([0.0, 0.12 * mesh.bbox_diagonal(), 0.0])
    return handle, roi, T


def live_frames(ed: HybridEditor, T: np.ndarray, c: np.ndarray, frames: int) -> None:
    """``frames`` drags (2 iterations each) along the way from the identity to ``T`` (the rotation
    slerped about the handle's centre ``c``, the translation in proportion), the last at ``T``."""
    turn = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([np.eye(3), T[:3, :3]])))
    move = T[:3, 3] - (c - T[:3, :3] @ c)
    for k in range(1, frames + 1):
        a = k / frames
        Tk = np.eye(4)
        Tk[:3, :3] = turn(a).as_matrix()
        Tk[:3, 3] = c - Tk[:3, :3] @ c + a * move
        ed.drag(transforms={0: T if k == frames else Tk})


def targets(ed: HybridEditor, T: np.ndarray):
    """(slots, target) of the cage's held vertices at ``T`` (what each iteration is given)."""
    return cage_targets(ed._base.cage, ed._sel, ed._sel.group_transforms([T]), scale=ed._scale)


def fixed_point(ed: HybridEditor, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(cage, shape) at the fixed point of the plain iterations from the editor's current state: drags
    of 50 iterations until one moves no cage vertex by more than 1e-12 of the diagonal."""
    diag = ed.mesh.bbox_diagonal()
    before = ed.cage_positions
    while True:
        ed.drag(transforms={0: T}, iterations=50)
        now = ed.cage_positions
        if np.abs(now - before).max() <= 1e-12 * diag:
            return now, ed.deformed_vertices.copy()
        before = now


def plain(ed: HybridEditor, T: np.ndarray) -> tuple[int, float]:
    """(b): cage-only iterations until the estimated distance (last move * r / (1 - r)) is under the
    tolerance, then one propagation. Returns (iterations, seconds)."""
    diag = ed.mesh.bbox_diagonal()
    slots, target = targets(ed, T)
    t0 = time.perf_counter()
    prev = ed.arap.positions.copy()
    last = None
    it = 0
    while it < 100000:
        solve_cage(ed.arap, slots, target, iterations=1)
        it += 1
        move = float(np.abs(ed.arap.positions - prev).max())
        prev[:] = ed.arap.positions
        if last:
            r = min(move / last, 0.9999)
            if move * r / (1 - r) <= TOLERANCE * diag:
                break
        last = move
    ed.drag(transforms={0: T}, iterations=0)  # the one propagation
    return it, time.perf_counter() - t0


def run_shape(mesh: Mesh, *, upper: bool, smoke: bool) -> list[tuple]:
    t0 = time.perf_counter()
    ed = HybridEditor(mesh, 0.05, cache=True)
    print(f"\n{mesh.name}: {mesh.n_vertices:,} vertices, cage {ed.cage.n_vertices:,} "
          f"({'cached' if ed.cache_hit else 'built'} in {time.perf_counter() - t0:.1f} s)", flush=True)
    handle, roi, T = issue_edit(mesh, upper=upper)
    ed.set_selection(handle, roi=roi)
    print(f"  handle {handle.size:,}, region {roi.size:,} shape vertices; {ed.arap.free.size:,} free cage "
          "vertices", flush=True)
    diag = mesh.bbox_diagonal()
    bound = ed.save_state()
    ed.converge(transforms={0: T})  # (the kernels warm, the metric made)
    rows = []
    for start in ("jump", "settle"):
        ed.restore_state(bound)
        if start == "settle":
            live_frames(ed, T, mesh.vertices[handle].mean(axis=0), 5 if smoke else LIVE_FRAMES)
        begin = ed.save_state()
        cage_ref, shape_ref = fixed_point(ed, T)
        energy_ref = ed.arap.energy()

        def true() -> tuple[float, float, float]:
            return (float(np.abs(ed.cage_positions - cage_ref).max()) / diag,
                    float(np.abs(ed.deformed_vertices - shape_ref).max()) / diag,
                    ed.arap.energy() / energy_ref - 1.0)

        ed.restore_state(begin)
        frames0 = len(ed.frame_seconds)
        t = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            ed.pose(transforms={0: T}, tolerance=TOLERANCE, max_frames=50 if smoke else 100000)
        frames = len(ed.frame_seconds) - frames0
        rows.append((mesh.name, start, "(a) frames", 2 * frames, f"{frames} frames", time.perf_counter() - t, *true()))
        ed.restore_state(begin)
        it, sec = plain(ed, T)
        rows.append((mesh.name, start, "(b) plain", it, "", sec, *true()))
        ed.restore_state(begin)
        r = ed.converge(transforms={0: T}, tolerance=TOLERANCE)
        note = f"bound {r.distance:.1e}, {r.rejected} rejected" + ("" if r.converged else f", {r.stopped}")
        rows.append((mesh.name, start, "(c) converge", r.iterations, note, r.seconds, *true()))
        for row in rows[-3:]:
            print("  " + format_row(row), flush=True)
    return rows


def format_row(row) -> str:
    name, start, how, iterations, note, seconds, cage, shape, energy = row
    return (f"{start:<7} {how:<13} {iterations:>7,} it {seconds:>8.2f} s   true: cage {cage:.1e}, shape {shape:.1e}"
            f"  energy {energy:+.1e}  {note}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--smoke", action="store_true", help="a run of seconds: the 43K armadillo subdivided 0 times")
    ap.add_argument("--shapes", default="173k,692k,sphere",
                    help="which shapes, comma-separated (default: 173k,692k,sphere)")
    ap.add_argument("--mesh-dir", type=Path, help="where the subdivided armadillos are (made if missing)")
    a = ap.parse_args(argv)
    print(machine())
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = a.mesh_dir or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        if a.smoke:
            from common import armadillo

            rows += run_shape(armadillo(), upper=True, smoke=True)
        else:
            shapes = set(a.shapes.lower().split(","))
            for level, key in ((1, "173k"), (2, "692k")):
                if key in shapes:
                    m = read_mesh(subdivided_armadillo(level, folder))
                    m.name = f"armadillo {key.upper()}"
                    rows += run_shape(m, upper=True, smoke=False)
                    del m
            if "sphere" in shapes:
                rows += run_shape(bumped_sphere(408), upper=False, smoke=False)
    print(f"\nto {TOLERANCE:g} of the diagonal; true: distance to the fixed point (fractions of the diagonal); "
          "energy: the cage's ARAP energy against the fixed point's (relative; below 0: a lower minimum)")
    print(f"{'shape':<22} {'start':<7} {'how':<13} {'iterations':>10} {'seconds':>8} {'true cage':>10} "
          f"{'true shape':>10} {'energy':>9}  note")
    for name, start, how, iterations, note, seconds, cage, shape, energy in rows:
        print(f"{name:<22} {start:<7} {how:<13} {iterations:>10,} {seconds:>8.2f} {cage:>10.1e} {shape:>10.1e} "
              f"{energy:>+9.1e}  {note}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
