"""Scaling to millions of vertices: cold build, cached open, frame, memory, file I/O, libigl beside.

Usage: python benchmarks/scale.py [--smoke] [--frames 50] [--max-level 3] [--mesh-dir DIR]

Shapes: the armadillo (../shared/meshes/armadillo43k.obj) Loop-subdivided once,
twice, three and four times with trimesh (172,966 / 691,858 / 2,767,426 /
11,069,698 vertices; each level made from the previous level's file by one
more subdivision, in a process of its own, and written as binary PLY to a
temporary folder, or to ``--mesh-dir`` where a later run finds and reuses it;
making them is not timed) and the default mesh data/creature.ply, each with a
5% cage and the canonical arm edit of ``benchmarks/common.py``.

Each shape runs in processes of its own, so that "peak MB" is that process's
peak resident memory (VmHWM): the cold session (read the file, cage build and
bind with no cache, editor set-up, first selection and drag, the frames), the
cached session (read, cage + binding from the on-disk cache the cold session
stored, editor set-up, first selection and drag) and the file session (read
and write the binary PLY; at the largest level also write and read it as OBJ).

The first table (issue 14's columns): cage build seconds, bind seconds and
their sum (cold, no cache), the rig from the cache alone, frame ms (median
over the frames of the canonical edit: 2 ARAP iterations + propagation) split
into local step / global step / propagation, peak memory, and libigl's
full-mesh ARAP (one iteration per solve, same constraints) per iteration with
the ratio of its iteration to our whole frame (only up to 690K, where its
precomputation fits the time of a benchmark run).

The second table (issue 31's columns): cold open = read + cage + bind; cached
open = read + cache read + editor set-up; the first selection and drag; peak
memory of the cold and of the cached session; then the file times, where the
cold build and the cached open went (cold build stages from the build's
progress reports; cached open from timing the pieces of the cache read and of
the editor's set-up), the growth exponents of the cold build (least squares on
log time against log vertices: all armadillo sizes, 173K to 690K, and 690K to
the largest level run), the 690K breakdown of a cold ``hybridedit deform`` run,
and every target of issues 14 and 31 marked met or not.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import trimesh

from common import REPO, Timer, armadillo, canonical_edit, machine, mark, quarter_edit

from hybridedit import HybridEditor, Mesh, apply_transform, build_rig, read_mesh, write_mesh
from hybridedit.binding import cache as bindcache
from hybridedit.deform.shape_setup import wait_for_stores

#: Targets of issue 14 by armadillo level (1, 2, 3 Loop subdivisions).
TARGETS = {
    "cold cage + bind s": {1: 3.0, 2: 12.0, 3: 60.0},
    "cage build s": {1: 0.8, 2: 3.0, 3: 12.0},
    "cached open s": {1: 0.3, 2: 1.5, 3: 6.0},
    "frame ms": {1: 3.0, 2: 12.0, 3: 40.0},
    "peak MB": {2: 2048.0, 3: 8192.0},
}
#: Largest cold-build growth exponent from 173K to 690K (issue 14).
TARGET_EXPONENT = 1.2

#: Targets of issue 31 by armadillo level (3: 2.77M, 4: 11M); peak memory in GB (10^9 bytes).
TARGETS_31 = {
    "cold open s": {3: 25.0, 4: 90.0},
    "cached open s": {3: 3.0, 4: 5.0},
    "frame ms": {3: 15.0, 4: 60.0},
    "peak GB": {3: 3.0, 4: 12.0},
    "first selection + drag s": {4: 2.0},
    "binary PLY read s": {4: 5.0},
    "binary PLY write s": {4: 5.0},
    "OBJ read s": {4: 30.0},
    "OBJ write s": {4: 30.0},
}
#: Largest cold-build growth exponent from 690K to 11M (issue 31).
TARGET_EXPONENT_31 = 1.1
#: Targets of issue 47 by armadillo level: the cold open as that issue measures it, from the file to
#: the first drag (read, cage, bind, the editor's set-up, the first selection and drag), and the
#: frames of the big-region edit (a quarter of the shape moving, :func:`common.quarter_edit`).
TARGETS_47 = {
    "file to first drag s": {3: 15.0, 4: 60.0},
    "quarter frame ms": {3: 10.0, 4: 40.0},
}
#: Largest cold-build growth exponent from 690K to 11M (issue 47).
TARGET_EXPONENT_47 = 1.05
#: Vertex counts of the armadillo's Loop subdivisions, as the tables name them.
LEVEL_NAMES = {1: "173K", 2: "690K", 3: "2.77M", 4: "11M"}
#: The OBJ write and read of the largest level stop after this many seconds (reported as not finished).
IO_TIMEOUT = 1800


def peak_mb() -> float:
    """Peak resident memory of this process (VmHWM: unlike ru_maxrss it is not
    inherited from the parent that started the process)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return float(line.split()[1]) / 1024.0
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def subdivided_armadillo(level: int, folder: Path) -> Path:
    """The armadillo Loop-subdivided ``level`` times, as a binary PLY in ``folder``.

    Made once (a file already there is reused), from the ``level - 1`` file by one
    more subdivision, each in a process of its own: four subdivisions at once would
    hold the 11M mesh's temporaries beside the 2.77M mesh's in one process.
    The PLY keeps double coordinates, so this is the same mesh as
    ``subdivide_loop(level)`` of the armadillo."""
    path = folder / f"armadillo_loop{level}.ply"
    if not path.exists():
        src = subdivided_armadillo(level - 1, folder) if level > 1 else None
        subprocess.run([sys.executable, __file__, "--make", str(path), str(src or "")], check=True)
    return path


def make_level(dst: str, src: str) -> None:
    """One Loop subdivision of ``src`` (the armadillo when empty) written to ``dst`` (atomically)."""
    a = read_mesh(src) if src else armadillo()
    s = trimesh.Trimesh(a.vertices, a.faces, process=False).subdivide_loop(1)
    del a
    write_mesh(dst, Mesh(np.asarray(s.vertices), np.asarray(s.faces)))


def creature_edit(mesh: Mesh):
    """Raise the creature's +X hand: the handle is the outer 8% along +X, the ROI the arm."""
    v = mesh.vertices
    lo, hi = v.min(axis=0), v.max(axis=0)
    r = (v - lo) / (hi - lo)
    handle = np.flatnonzero(r[:, 0] > 0.92)
    roi = np.flatnonzero(r[:, 0] > 0.68)
    shoulder = v[roi[r[roi, 0] < 0.71]].mean(axis=0)
    from hybridedit import rigid_transform

    return handle, roi, rigid_transform(axis=(0, 0, 1), degrees=40.0, center=shoulder)


def libigl_iteration_ms(shape: Mesh, handle, roi, T, iterations: int) -> tuple[float, float] | None:
    if iterations < 1:
        return None
    try:
        import igl
    except ImportError:
        return None
    inside = np.zeros(shape.n_vertices, bool)
    inside[roi] = True
    inside[handle] = True
    b = np.union1d(handle, np.flatnonzero(~inside))
    target = shape.vertices[b].copy()
    hm = np.isin(b, handle)
    target[hm] = apply_transform(T, target[hm])
    data = igl.ARAPData()
    data.max_iter = 1
    data.energy = igl.ARAP_ENERGY_TYPE_SPOKES
    with Timer() as pre:
        igl.arap_precomputation(shape.vertices, shape.faces, 3, b.astype(np.int32), data)
    U = shape.vertices.copy()
    times = []
    for _ in range(iterations):
        with Timer() as t:
            U = igl.arap_solve(target, data, U)
        times.append(t.seconds)
    return 1e3 * float(np.median(times)), pre.seconds


# ---------------------------------------------------------------------- where the time goes
class StageClock:
    """A build's ``progress`` callback that keeps when each report came: (seconds, stage, fraction)."""

    def __init__(self) -> None:
        self.t0 = time.perf_counter()
        self.reports: list[tuple[float, str, float]] = []

    def __call__(self, stage: str, fraction: float) -> None:
        self.reports.append((time.perf_counter() - self.t0, stage, float(fraction)))

    def first(self, stage: str, at_least: float) -> float | None:
        for t, s, f in self.reports:
            if s == stage and f >= at_least:
                return t
        return None

    def last(self, stage: str) -> float | None:
        ts = [t for t, s, _ in self.reports if s == stage]
        return ts[-1] if ts else None

    def cold_stages(self) -> dict[str, float]:
        """The cold build by stage, from the progress reports of the cage build (repair done at
        REPAIR_SHARE, the first simplification at HALVES_SHARE of a one-part shape: a big shape's
        clusters, a smaller one's two-core QEM halves) and the binding."""
        from hybridedit.cage.parts import REPAIR_SHARE
        from hybridedit.cage.simplify import HALVES_SHARE

        c0, c1 = self.first("building the cage", 0.0), self.first("building the cage", 1.0)
        b0, b1 = self.first("binding", 0.0), self.last("binding")
        out: dict[str, float] = {}
        if c0 is None or c1 is None:
            return out
        rep = self.first("building the cage", REPAIR_SHARE)
        halves = self.first("building the cage", REPAIR_SHARE + (1.0 - REPAIR_SHARE) * HALVES_SHARE)
        if rep is not None and rep < c1:
            out["cage: repair pass"] = rep - c0
            if halves is not None and halves < c1:
                out["cage: clusters or QEM halves"] = halves - rep
                out["cage: final QEM, clean-up, closing"] = c1 - halves
            else:
                out["cage: QEM, clean-up, closing"] = c1 - rep
        else:
            out["cage build"] = c1 - c0
        if b0 is not None and b1 is not None:
            out["bind (blocks of rows)"] = b1 - b0
        return out


class PieceClock:
    """Times named module-level functions (or classes) wherever they are looked up: the pieces
    of the cache read and of the editor's set-up, measured without changing them."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}

    def wrap(self, module, attr: str, label: str) -> None:
        fn = getattr(module, attr, None)
        if fn is None:
            return
        clock = self

        def timed(*a, **k):
            t0 = time.perf_counter()
            try:
                return fn(*a, **k)
            finally:
                clock.seconds[label] = clock.seconds.get(label, 0.0) + time.perf_counter() - t0

        setattr(module, attr, timed)


def clocked_setup() -> tuple[PieceClock, PieceClock]:
    """Clocks on the pieces of the cache read (hash, load and check, usability) and of
    HybridEditor's set-up: the shape's set-up (residual top-k, cotangent Laplacian, KD-tree,
    dominant vertex; or their cache companion read and checked), the cage ARAP solver, the rest
    pose. Only names that exist are clocked (the editor's set-up moved into
    ``hybridedit.deform.shape_setup``; both places are looked at)."""
    import importlib

    from hybridedit.binding import rig as rig_mod
    from hybridedit.deform import editor as editor_mod

    cache, editor = PieceClock(), PieceClock()
    cache.wrap(bindcache, "cache_key", "hash the shape for the key")
    cache.wrap(bindcache, "load", "load + checksum + checks")
    cache.wrap(rig_mod, "_check_usable", "cage weights check")
    try:
        setup_mod = importlib.import_module("hybridedit.deform.shape_setup")
    except ImportError:
        setup_mod = None
    for mod in (editor_mod, setup_mod):
        if mod is None:
            continue
        editor.wrap(mod, "residual_setup", "residual + rotation blend (top-k)")
        editor.wrap(mod, "nearest_vertices", "KD-tree of the shape + nearest")
        editor.wrap(mod, "dominant_cage_vertex", "dominant cage vertex per row")
        editor.wrap(mod, "edge_weights", "shape cotangent weights")
        editor.wrap(mod, "laplacian", "shape Laplacian assembly")
    if setup_mod is not None:
        editor.wrap(setup_mod, "_checked", "set-up companion checks")
        # shape_setup reads and writes its companion through the cache module
        editor.wrap(bindcache, "load_arrays", "set-up companion read")
        editor.wrap(bindcache, "store_arrays", "set-up companion write (in the background)")
    editor.wrap(rig_mod.Rig, "nearest_shape_vertices", "nearest shape vertex per cage vertex (k-d tree)")
    editor.wrap(editor_mod, "ARAPSolver", "cage ARAP solver")
    editor.wrap(editor_mod, "rest_base", "rest pose")
    return cache, editor


def first_edit(ed: HybridEditor, edit) -> dict:
    handle, roi, T = edit
    with Timer() as sel:
        ed.set_selection(handle, roi=roi)
    with Timer() as drag:
        ed.drag(transform=T)
    return {"first_sel_s": sel.seconds, "first_drag_s": drag.seconds}


def quarter_frames(ed: HybridEditor, shape: Mesh, frames: int) -> dict:
    """The big-region edit (:func:`common.quarter_edit`, a quarter of the shape moving) after the
    canonical one: its selection's seconds and its frames' median milliseconds, split."""
    handle, roi, T = quarter_edit(shape)
    with Timer() as sel:
        ed.set_selection(handle, roi=roi)
    ed.drag(transform=T)  # (the first frame after a selection, as the window's press)
    out = frame_medians(ed, T, max(frames, 1))
    out["sel_s"] = sel.seconds
    return out


def frame_medians(ed: HybridEditor, T: np.ndarray, frames: int) -> dict:
    """``frames`` drags of the selection to ``T``: the median milliseconds of the frame and of its
    parts (cage local and global steps, the shape's steps), by ``frame_breakdown``'s names."""
    parts = {"local_seconds": [], "global_seconds": [], "propagate_seconds": [], "total_seconds": []}
    for _ in range(frames):
        ed.drag(transform=T)
        for k in parts:
            parts[k].append(ed.frame_breakdown[k])
    return {k: 1e3 * float(np.median(v)) for k, v in parts.items()}


def shape_edit(shape: Mesh, name: str):
    return creature_edit(shape) if name.startswith("creature") else canonical_edit(shape)


# ---------------------------------------------------------------------- the measured processes
def run_one(path: str, name: str, frames: int, igl_iters: int, breakdown: bool, cache: str) -> dict:
    """The cold session of one shape (in this process); returns its row as a dict. Stores
    the binding in ``cache`` for the cached session."""
    out: dict = {}
    _, pieces = clocked_setup()
    with Timer() as rd:
        shape = read_mesh(path)
    shape.name = name
    out["read_s"] = rd.seconds
    with Timer() as hs:
        bindcache.cache_key(shape, 0.05, 0.03)
    out["hash_s"] = hs.seconds
    edit = shape_edit(shape, name)
    clock = StageClock()
    with Timer() as whole:
        cold = build_rig(shape, cage_size=0.05, cache=cache, progress=clock)
    assert not cold.cache_hit
    out["cage_s"] = cold.timings["cage_seconds"]
    out["bind_s"] = cold.timings["bind_seconds"]
    out["cold_stages"] = clock.cold_stages()
    out["store_s"] = whole.seconds - out["cage_s"] - out["bind_s"]  # the key's hash and the cache write
    with Timer() as es:
        ed = HybridEditor(cold)
    out["editor_s"] = es.seconds
    out["editor_pieces"] = pieces.seconds
    out.update(first_edit(ed, edit))
    wait_for_stores()  # (the set-up's companion, written in the background: the frames are measured after it)
    out.update(frame_medians(ed, edit[2], frames))
    out["quarter"] = quarter_frames(ed, shape, frames)
    out["cage"] = ed.cage.n_vertices
    out["verts"] = shape.n_vertices
    out["nnz"] = ed.nnz_per_row
    out["peak_mb"] = peak_mb()
    if breakdown:
        out.update(cli_breakdown(path, shape, edit))
    del ed, cold
    ig = libigl_iteration_ms(shape, edit[0], edit[1], edit[2], igl_iters)
    out["igl_ms"], out["igl_pre_s"] = ig if ig else (float("nan"), float("nan"))
    return out


def run_cached(path: str, name: str, cache: str) -> dict:
    """The cached session of one shape: read, rig from the cache, editor, first selection and drag."""
    out: dict = {}
    cache_pieces, pieces = clocked_setup()
    with Timer() as rd:
        shape = read_mesh(path)
    shape.name = name
    out["read_s"] = rd.seconds
    with Timer() as op:
        rig = build_rig(shape, cage_size=0.05, cache=cache)
    assert rig.cache_hit, "the cold session's cache entry was not used"
    out["cache_s"] = op.seconds
    out["cache_pieces"] = cache_pieces.seconds
    with Timer() as es:
        ed = HybridEditor(rig)
    out["editor_s"] = es.seconds
    out["editor_pieces"] = pieces.seconds
    out["open_s"] = out["read_s"] + out["cache_s"] + out["editor_s"]
    out.update(first_edit(ed, shape_edit(shape, name)))
    out["peak_mb"] = peak_mb()
    return out


def run_io(path: str, obj: bool) -> None:
    """Read and write the binary PLY, then (``obj``) write and read it as OBJ; prints a
    RESULT line after each, so that a slow OBJ still leaves the PLY's times."""
    out: dict = {}
    with Timer() as rd:
        shape = read_mesh(path)
    out["ply_read_s"] = rd.seconds
    out["ply_mb"] = os.path.getsize(path) / 1e6
    with tempfile.TemporaryDirectory(dir=Path(path).parent) as tmp:
        p = Path(tmp) / "again.ply"
        with Timer() as wr:
            write_mesh(p, shape)
        out["ply_write_s"] = wr.seconds
        p.unlink()
        print("RESULT " + json.dumps(out), flush=True)
        if not obj:
            return
        p = Path(tmp) / "again.obj"
        with Timer() as wr:
            write_mesh(p, shape)
        out["obj_write_s"] = wr.seconds
        out["obj_mb"] = p.stat().st_size / 1e6
        print("RESULT " + json.dumps(out), flush=True)
        del shape
        with Timer() as rd:
            back = read_mesh(p)
        out["obj_read_s"] = rd.seconds
        out["obj_verts_back"] = int(back.n_vertices)
        out["io_peak_mb"] = peak_mb()
        print("RESULT " + json.dumps(out), flush=True)


def cli_breakdown(path: str, shape: Mesh, edit) -> dict:
    """A cold ``hybridedit deform --frames 1`` run, timed whole, with its stats."""
    handle, roi, T = edit
    with tempfile.TemporaryDirectory() as tmp:
        e = Path(tmp) / "edit.json"
        moved = apply_transform(T, shape.vertices[handle]).mean(axis=0) - shape.vertices[handle].mean(axis=0)
        e.write_text(json.dumps({"handle": handle.tolist(), "roi": roi.tolist(), "space": "shape",
                                 "translate": moved.tolist()}))
        out_path = Path(tmp) / "out.ply"
        stats = Path(tmp) / "stats.json"
        exe = Path(sys.executable).with_name("hybridedit")
        cmd = [str(exe), "deform", path, "-o", str(out_path), "--edit", str(e), "--frames", "1",
               "--no-cache", "--stats", str(stats), "-q"]
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True)
        total = time.perf_counter() - t0
        st = json.loads(stats.read_text())
        with Timer() as wr:
            write_mesh(Path(tmp) / "again.ply", shape)
    return {"cli_s": total, "cli_stats": st, "write_s": wr.seconds}


# ---------------------------------------------------------------------- the report
def child(cmd: list[str], timeout: float | None = None) -> tuple[dict | None, str]:
    """Run a measuring process; its last RESULT line as a dict (None if none) and why it failed ('' if not)."""
    try:
        res = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
        stdout, why = res.stdout, ""
        if res.returncode != 0:
            tail = res.stderr.strip().splitlines()[-1:] or [f"exit status {res.returncode}"]
            why = tail[0] if res.returncode > 0 else f"killed by signal {-res.returncode} (out of memory?)"
    except subprocess.TimeoutExpired as e:
        stdout = e.stdout.decode() if isinstance(e.stdout, bytes) else (e.stdout or "")
        why = f"stopped after {timeout:.0f} s"
    lines = [s for s in stdout.splitlines() if s.startswith("RESULT ")]
    return (json.loads(lines[-1][7:]) if lines else None), why


def exponent(rows: list[dict], value) -> float:
    n = np.log([r["verts"] for r in rows])
    t = np.log([value(r) for r in rows])
    return float(np.polyfit(n, t, 1)[0])


def print_parts(title: str, parts: dict[str, float], whole: float) -> None:
    shown = ", ".join(f"{k} {v:.2f}" for k, v in sorted(parts.items(), key=lambda kv: -kv[1]))
    rest = whole - sum(parts.values())
    if rest < -0.01:  # (pieces timed on two threads at once: their sum is more than the wall time)
        print(f"#   {title}: {shown} (some side by side on two threads: {sum(parts.values()):.2f} in all)")
    else:
        print(f"#   {title}: {shown}, the rest {rest:.2f}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=50)
    ap.add_argument("--smoke", action="store_true", help="CI smoke run: the 43K armadillo, 3 frames, no libigl")
    ap.add_argument("--max-level", type=int, default=3, help="most Loop subdivisions of the armadillo (1-4)")
    ap.add_argument("--mesh-dir", type=Path, default=None,
                    help="keep the subdivided armadillos here and reuse them in later runs "
                         "(default: a temporary folder)")
    ap.add_argument("--one", nargs=6, metavar=("PATH", "NAME", "FRAMES", "IGL", "BREAKDOWN", "CACHE"),
                    help=argparse.SUPPRESS)
    ap.add_argument("--cached", nargs=3, metavar=("PATH", "NAME", "CACHE"), help=argparse.SUPPRESS)
    ap.add_argument("--io", nargs=2, metavar=("PATH", "OBJ"), help=argparse.SUPPRESS)
    ap.add_argument("--make", nargs=2, metavar=("DST", "SRC"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.one:
        path, name, frames, igl, brk, cache = args.one
        r = run_one(path, name, int(frames), int(igl), brk == "1", cache)
        print("RESULT " + json.dumps(r, default=float), flush=True)
        return 0
    if args.cached:
        print("RESULT " + json.dumps(run_cached(*args.cached), default=float), flush=True)
        return 0
    if args.io:
        run_io(args.io[0], args.io[1] == "1")
        return 0
    if args.make:
        make_level(*args.make)
        return 0
    max_level = max(1, min(4, args.max_level))
    print(f"# scale — {machine()}; load average {os.getloadavg()[0]:.1f} at start")
    print("# frame = 2 ARAP iterations + propagation, median; local/global/prop split that frame; "
          "libigl = one full-mesh ARAP iteration; each shape in its own processes")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        meshes = folder
        if args.mesh_dir is not None and not args.smoke:
            meshes = args.mesh_dir
            meshes.mkdir(parents=True, exist_ok=True)
        jobs = []  # (path, name, level, frames, igl iterations, breakdown)
        if args.smoke:
            a = armadillo()
            p = folder / "armadillo43k.ply"
            write_mesh(p, a)
            jobs.append((p, "armadillo 43K", 0, 3, 0, False))
        else:
            with Timer() as made:
                for level in range(1, max_level + 1):
                    p = subdivided_armadillo(level, meshes)
                    jobs.append((p, f"armadillo {LEVEL_NAMES[level]}", level, args.frames,
                                 0 if level >= 3 else 5, level == 2))
                    if level == 1 and (REPO / "data" / "creature.ply").exists():
                        jobs.append((REPO / "data" / "creature.ply", "creature 100K", 0, args.frames, 5, False))
            print(f"# subdivided armadillos in {meshes} (made or found: {made.seconds:.0f} s, not counted)")
        top = max(j[2] for j in jobs)
        # Compile the kernels once (numba's on-disk cache), as a first run after
        # installing does: every measured process then loads them from the cache.
        warm = ("import numpy as np, trimesh; from hybridedit import build_rig, Mesh; "
                "s = trimesh.creation.icosphere(subdivisions=4); "
                "build_rig(Mesh(np.asarray(s.vertices), np.asarray(s.faces)), cage_size=0.05)")
        with Timer() as w:
            subprocess.run([sys.executable, "-c", warm], check=True, capture_output=True)
        print(f"# kernels compiled or loaded from the numba cache first: {w.seconds:.1f} s")
        head = (f"{'shape':>15} {'verts':>8} {'cage':>6} {'cage s':>6} {'bind s':>6} {'cold s':>6} "
                f"{'cached s':>8} {'nnz':>4} {'frame ms':>8} {'local':>6} {'global':>6} {'prop':>6} "
                f"{'peak MB':>7} {'igl it ms':>9} {'igl/frame':>9}")
        print(head)
        print("-" * len(head))
        rows = []
        for path, name, level, frames, igl, brk in jobs:
            cache = folder / f"cache-{len(rows)}-{level}"
            cmd = [sys.executable, __file__, "--one", str(path), name, str(frames), str(igl), "1" if brk else "0",
                   str(cache)]
            r, why = child(cmd)
            if r is None or why:
                print(f"{name:>15} failed: {why}", flush=True)
                continue
            r["name"], r["level"] = name, level
            c, why = child([sys.executable, __file__, "--cached", str(path), name, str(cache)])
            r["cached"] = c if c is not None and not why else None
            r["cached_why"] = why
            if level == top and (level >= 1 or args.smoke):
                io, why = child([sys.executable, __file__, "--io", str(path), "1"], timeout=IO_TIMEOUT)
                r["io"], r["io_why"] = io or {}, why
            rows.append(r)
            cold = r["cage_s"] + r["bind_s"]
            cached_s = r["cached"]["cache_s"] if r["cached"] else float("nan")
            if igl:
                igl_txt = f"{r['igl_ms']:>9.1f} {r['igl_ms'] / r['total_seconds']:>9.0f}"
            else:
                igl_txt = f"{'skipped':>9} {'':>9}"
            print(f"{name:>15} {r['verts']:>8d} {r['cage']:>6d} {r['cage_s']:>6.2f} {r['bind_s']:>6.2f} "
                  f"{cold:>6.2f} {cached_s:>8.3f} {r['nnz']:>4.1f} {r['total_seconds']:>8.3f} "
                  f"{r['local_seconds']:>6.3f} {r['global_seconds']:>6.3f} {r['propagate_seconds']:>6.3f} "
                  f"{r['peak_mb']:>7.0f} {igl_txt}", flush=True)
        if not args.smoke:
            print("# libigl from 2.77M: skipped (its precomputation alone takes minutes and several GB there)")
        print_issue31(rows, args.smoke)
        print_issue47(rows)
        if args.smoke:
            return 0
        arm = [r for r in rows if r["level"] >= 1]
        print()
        build = lambda r: r["cage_s"] + r["bind_s"]  # noqa: E731
        if len(arm) >= 2:
            print(f"# cold cage + bind growth exponent (least squares over {len(arm)} armadillo sizes): "
                  f"{exponent(arm, build):.2f}")
        a1 = [r for r in arm if r["level"] in (1, 2)]
        if len(a1) == 2:
            print(f"# from 173K to 690K: {exponent(a1, build):.2f}  {mark(exponent(a1, build), TARGET_EXPONENT)}")
        a2 = [r for r in arm if r["level"] >= 2]
        if len(a2) >= 2:
            e = exponent(a2, build)
            e_open = exponent(a2, lambda r: r["read_s"] + build(r))
            print(f"# from 690K to {a2[-1]['name'].split()[-1]} (issue 31; {len(a2)} sizes): {e:.2f}  "
                  f"{mark(e, TARGET_EXPONENT_31)}; with the read (cold open): {e_open:.2f}")
        for r in rows:
            if "cli_s" not in r:
                continue
            st = r["cli_stats"]
            frames = float(st.get("frame_ms_median", float("nan"))) * float(st.get("frames", 1)) / 1e3
            parts = {"read the file": r["read_s"], "hash for the cache key": r["hash_s"],
                     "cage build": st["cage_seconds"], "bind": st["bind_seconds"],
                     "frames": frames, "write the result": r["write_s"]}
            inside = st["total_seconds"]
            print(f"\n# {r['name']} breakdown of a cold `hybridedit deform --frames 1 --no-cache` "
                  f"(seconds; cage and bind from its stats, read/hash/write timed in-process)")
            for k, v in parts.items():
                print(f"#   {k:<44} {v:7.2f}")
            print(f"#   {'editor set-up, selection, factorization, stats':<44} "
                  f"{inside - sum(parts.values()):7.2f}")
            print(f"#   {'start-up and imports (wall - its total)':<44} {r['cli_s'] - inside:7.2f}")
            print(f"#   {'wall clock of the run':<44} {r['cli_s']:7.2f}")
        print("\n# targets (issue 14)")
        for r in arm:
            vals = {"cold cage + bind s": r["cage_s"] + r["bind_s"], "cage build s": r["cage_s"],
                    "frame ms": r["total_seconds"], "peak MB": r["peak_mb"]}
            if r["cached"]:
                vals["cached open s"] = r["cached"]["cache_s"]
            print_marked(r, vals, TARGETS, 20)
        print("\n# targets (issue 31)")
        for r in arm:
            print_marked(r, issue31_values(r), TARGETS_31, 26)
        if top < 4:
            print("#   (the 11M targets, the file times' and the first selection's need --max-level 4)")
    return 0


def cold_open(r: dict) -> float:
    """Seconds of a cold open (issue 31's): read the file, build the cage, bind."""
    return r["read_s"] + r["cage_s"] + r["bind_s"]


def print_marked(r: dict, values: dict[str, float], targets: dict[str, dict[int, float]], width: int) -> None:
    """One line per figure of row ``r`` that has a target at its level, marked met or not."""
    for k, v in values.items():
        tgt = targets.get(k, {}).get(r["level"])
        if tgt is not None:
            print(f"#   {r['name']:<15} {k:<{width}} {v:9.3f}  {mark(v, tgt)}")


def issue31_values(r: dict) -> dict[str, float]:
    nan = float("nan")
    c = r["cached"] or {}
    io = r.get("io") or {}
    first = [r["first_sel_s"] + r["first_drag_s"]]
    if c:
        first.append(c["first_sel_s"] + c["first_drag_s"])
    vals = {"cold open s": cold_open(r), "cached open s": c.get("open_s", nan),
            "frame ms": r["total_seconds"], "peak GB": max(r["peak_mb"], c.get("peak_mb", 0.0)) * 2**20 / 1e9,
            "first selection + drag s": max(first)}
    names = {"ply_read_s": "binary PLY read s", "ply_write_s": "binary PLY write s",
             "obj_read_s": "OBJ read s", "obj_write_s": "OBJ write s"}
    vals.update({names[k]: io[k] for k in names if k in io})
    return vals


def print_issue31(rows: list[dict], smoke: bool) -> None:
    """Issue 31's table: cold open, cached open, frame, peak memory, first selection and drag; then
    the file times and where the cold build and the cached open went."""
    print("\n# issue 31: cold open = read + cage + bind (no cache); cached open = read + cache read + editor "
          "set-up (a process of its own); first sel / drag: set_selection and the first drag after opening "
          "(cold session / cached session); peak = VmHWM of the cold / cached session")
    head = (f"{'shape':>15} {'verts':>8} {'read s':>6} {'cold open s':>11} {'editor s':>8} {'cached open s':>13} "
            f"{'frame ms':>8} {'first sel s':>11} {'first drag s':>12} {'peak GB':>11}")
    print(head)
    print("-" * len(head))
    for r in rows:
        c = r["cached"]
        cold = cold_open(r)
        gb = r["peak_mb"] * 2**20 / 1e9
        if c:
            ctxt = f"{c['open_s']:>13.2f}"
            sel = f"{r['first_sel_s']:.2f} / {c['first_sel_s']:.2f}"
            drag = f"{r['first_drag_s']:.2f} / {c['first_drag_s']:.2f}"
            peak = f"{gb:.2f} / {c['peak_mb'] * 2**20 / 1e9:.2f}"
        else:
            ctxt = f"{'failed':>13}"
            sel, drag, peak = f"{r['first_sel_s']:.2f}", f"{r['first_drag_s']:.2f}", f"{gb:.2f}"
        print(f"{r['name']:>15} {r['verts']:>8d} {r['read_s']:>6.2f} {cold:>11.2f} {r['editor_s']:>8.2f} {ctxt} "
              f"{r['total_seconds']:>8.2f} {sel:>11} {drag:>12} {peak:>11}", flush=True)
    for r in rows:
        if r.get("cached_why"):
            print(f"# {r['name']}: cached session failed: {r['cached_why']}")
        if "io" not in r:
            continue
        io = r["io"]
        txt = []
        if "ply_read_s" in io:
            txt.append(f"binary PLY ({io['ply_mb']:.0f} MB) read {io['ply_read_s']:.2f} s, "
                       f"write {io['ply_write_s']:.2f} s")
        if "obj_write_s" in io:
            txt.append(f"OBJ ({io['obj_mb']:.0f} MB) write {io['obj_write_s']:.2f} s")
        if "obj_read_s" in io:
            txt.append(f"read {io['obj_read_s']:.2f} s (peak {io['io_peak_mb'] * 2**20 / 1e9:.2f} GB)")
        if r.get("io_why"):
            txt.append(f"not finished: {r['io_why']}")
        print(f"# files, {r['name']}: " + "; ".join(txt))
    print("# where the time goes (seconds)")
    for r in rows:
        if r["level"] < 2 and not smoke:
            continue
        print(f"# {r['name']}:")
        print_parts(f"cold build {r['cage_s'] + r['bind_s']:.2f} (from the progress reports)",
                    r["cold_stages"], r["cage_s"] + r["bind_s"])
        print(f"#   cold session also: cache key hash + cache write {r['store_s']:.2f} (not in the cold open)")
        print_parts(f"editor set-up after the cold build {r['editor_s']:.2f}", r["editor_pieces"], r["editor_s"])
        c = r["cached"]
        if c:
            print(f"#   cached open {c['open_s']:.2f} = read {c['read_s']:.2f} + cache read {c['cache_s']:.2f} "
                  f"+ editor set-up {c['editor_s']:.2f}")
            print_parts(f"cache read {c['cache_s']:.2f}", c["cache_pieces"], c["cache_s"])
            print_parts(f"editor set-up {c['editor_s']:.2f}", c["editor_pieces"], c["editor_s"])


def to_first_drag(r: dict) -> float:
    """Seconds from the file to the first drag of a cold session: the cold open, the editor's
    set-up, the first selection and drag."""
    return cold_open(r) + r["editor_s"] + r["first_sel_s"] + r["first_drag_s"]


def print_issue47(rows: list[dict]) -> None:
    """Issue 47's table: the canonical arm edit's frame beside the big-region edit's (a quarter of
    the shape), the cold open and the time to the first drag, and each target marked."""
    print("\n# issue 47: cold open = read + cage + bind; to first drag = that + editor set-up + first "
          "selection and drag (cold session); arm = the canonical arm edit; quarter = a quarter of the "
          "shape moving (common.quarter_edit), its frames after the arm's; frame medians in ms")
    head = (f"{'shape':>15} {'verts':>8} {'cold open s':>11} {'to 1st drag s':>13} {'arm frame':>9} "
            f"{'quarter':>8} {'local':>6} {'global':>6} {'prop':>6} {'quarter sel s':>13}")
    print(head)
    print("-" * len(head))
    for r in rows:
        q = r.get("quarter") or {}
        if not q:
            continue
        print(f"{r['name']:>15} {r['verts']:>8d} {cold_open(r):>11.2f} {to_first_drag(r):>13.2f} {r['total_seconds']:>9.2f} "
              f"{q['total_seconds']:>8.2f} {q['local_seconds']:>6.2f} {q['global_seconds']:>6.2f} "
              f"{q['propagate_seconds']:>6.2f} {q['sel_s']:>13.2f}", flush=True)
    print("# targets (issue 47)")
    for r in rows:
        q = r.get("quarter") or {}
        vals = {"file to first drag s": to_first_drag(r), "quarter frame ms": q.get("total_seconds", float("nan"))}
        print_marked(r, vals, TARGETS_47, 26)
    a2 = [r for r in rows if r["level"] >= 2]
    if len(a2) >= 2:
        e = exponent(a2, lambda r: r["cage_s"] + r["bind_s"])
        print(f"#   cold cage + bind growth from 690K ({len(a2)} sizes): {e:.2f}  {mark(e, TARGET_EXPONENT_47)}")


if __name__ == "__main__":
    sys.exit(main())
