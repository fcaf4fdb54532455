"""Compile every numba kernel once, ahead of use: ``python -m hybridedit.warmup``.

``scripts/setup.sh`` runs this after installing, so that the first window,
the first ``hybridedit deform`` and the first drag find every kernel in
numba's on-disk cache instead of compiling it (tens of seconds on a small
machine). The window runs it too, in its build thread, when it finds that it
never ran for this code (a plain ``pip install``), and says so on screen.

It compiles by running the real public pipeline on small generated shapes:
cage (with its repair pass on a shape that needs one), binding (fast and
exact), both propagations, ARAP drags, polish, edit replay and the window's
own per-frame kernels. Several kernels switch to a parallel twin above a
size threshold (the one table :data:`hybridedit.core.parallel.THRESHOLDS`); the
pipeline runs a second time with every threshold at zero so the parallel twins
compile as well. :func:`uncovered` then lists any kernel the pipeline did not reach,
so a new kernel cannot be forgotten silently.

No Qt or VTK is imported.
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import importlib
import os
import sys
import time
from pathlib import Path
from typing import Callable, Iterator

import numpy as np

import hybridedit

PACKAGE_DIR = Path(hybridedit.__file__).resolve().parent

Progress = Callable[[str, float], None]


# ---------------------------------------------------------------------------- finding the kernels


def kernel_modules() -> list[str]:
    """Names of the hybridedit modules that define numba kernels or intrinsics
    (:func:`hybridedit.kernel_cache.kernel_files`)."""
    from .kernel_cache import kernel_files

    names = (p.relative_to(PACKAGE_DIR).with_suffix("").parts for p in kernel_files(PACKAGE_DIR))
    return sorted(".".join(("hybridedit", *parts)) for parts in names)


def kernels() -> dict[str, object]:
    """Every numba dispatcher defined at module level in :func:`kernel_modules`, by qualified name
    (a pair of :func:`~hybridedit.core.twins.twins` named ``k`` gives ``k.serial`` and ``k.parallel``)."""
    from numba.core.registry import CPUDispatcher

    from .core.twins import Twins

    out = {}
    for name in kernel_modules():
        mod = importlib.import_module(name)
        for attr, obj in vars(mod).items():
            pair = isinstance(obj, Twins)
            found = {f"{attr}.{twin}": d for twin, d in obj._asdict().items()} if pair else {attr: obj}
            for qual, disp in found.items():
                if isinstance(disp, CPUDispatcher) and getattr(disp, "__module__", name) == name:
                    out[f"{name}.{qual}"] = disp
    return out


def _code_names(code) -> set[str]:
    names = set(code.co_names)
    for c in code.co_consts:
        if hasattr(c, "co_names"):
            names |= _code_names(c)
    return names


def entry_kernels() -> dict[str, object]:
    """The kernels called from Python: neither inlined nor named inside another kernel.

    A kernel called only by other kernels is compiled into them, and a compiled
    caller loaded from the cache does not load it, so only entry kernels tell
    whether the pipeline reached everything.
    """
    ks = kernels()
    out = {}
    for qual, disp in ks.items():
        if disp.targetoptions.get("inline", "never") == "always":
            continue
        name = qual[len(disp.__module__) + 1:].split(".")[0]  # (the module's name for it)
        if any(name in _code_names(d.py_func.__code__) for q, d in ks.items() if q != qual):
            continue
        out[qual] = disp
    return out


def uncovered() -> list[str]:
    """Entry kernels with no compiled (or cache-loaded) version in this process."""
    return sorted(q for q, d in entry_kernels().items() if not d.overloads)


def cache_counts() -> tuple[int, int]:
    """(loaded from the cache, compiled) kernel versions in this process so far."""
    hits = misses = 0
    for d in kernels().values():
        hits += sum(d._cache_hits.values())
        misses += sum(d._cache_misses.values())
    return hits, misses


@contextlib.contextmanager
def record_compiles() -> Iterator[list]:
    """Collect numba's compile events (one per kernel version compiled, not loaded) in the block."""
    from numba.core import event

    with event.install_recorder("numba:compile") as rec:
        yield rec.buffer


@contextlib.contextmanager
def parallel_everywhere() -> Iterator[None]:
    """Every kernel takes its parallel twin inside the block: :func:`hybridedit.core.parallel.all_parallel`."""
    from .core.parallel import all_parallel

    with all_parallel():
        yield


# ---------------------------------------------------------------------------- the shapes


def blob(subdivisions: int = 3):
    """A closed bumpy capsule along X (642 vertices at subdivision 3)."""
    import trimesh

    from .core.mesh import Mesh

    s = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
    v = np.asarray(s.vertices, dtype=np.float64).copy()
    x, y, z = v.T
    v *= (1.0 + 0.06 * np.sin(6 * x) * np.cos(4 * y) + 0.04 * np.sin(9 * z))[:, None]
    v[:, 0] *= 2.0
    return Mesh(v, np.asarray(s.faces, dtype=np.int64), name="warmup")


def needs_repair(mesh):
    """The same shape with a duplicated vertex, some faces flipped and a hole (runs the repair pass
    and an open part's cage)."""
    from .core.mesh import Mesh

    v = np.vstack([mesh.vertices, mesh.vertices[:1]])
    f = mesh.faces.copy()
    f[f == 0] = len(v) - 1  # the copy of vertex 0 replaces it in its faces: a duplicate to merge
    f[::7] = f[::7, ::-1]  # inconsistent orientation
    f = np.delete(f, [len(f) // 2, len(f) // 2 + 1], axis=0)  # a hole
    return Mesh(v, f, name="warmup-repair")


# ---------------------------------------------------------------------------- the pipeline


def _selection(mesh):
    x = mesh.vertices[:, 0]
    lo, hi = x.min(), x.max()
    handle = np.flatnonzero(x > hi - 0.15 * (hi - lo))
    roi = np.flatnonzero(x > hi - 0.6 * (hi - lo))
    return handle, roi


def _edit_session(mesh, say: Progress, label: str) -> None:
    """Cage, binding, both propagations, drags, a converge, polish and the window's kernels on one shape."""
    from . import HybridEditor, rigid_transform
    from .binding.bind import bind
    from .deform.polish import ShapeARAP, polish
    from .core.bounds import points_box
    from .core.region_metrics import ShapeMetrics
    from .core.row_copy import copy_rows
    from .core.up_axis import guess_up_axis

    say(f"{label}: cage and binding", 0.0)
    from .cage.qem import presimplify

    presimplify(mesh.vertices, mesh.faces, mesh.n_faces // 8, min_faces=8)  # (a big surface cut in halves)
    guess_up_axis(mesh)  # (what the window asks of a shape it opens)
    import tempfile

    with tempfile.TemporaryDirectory() as folder:  # built, then opened from a cache (its checks' kernels)
        HybridEditor(mesh, 0.1, cache=folder)
        ed = HybridEditor(mesh, 0.1, cache=folder)
    handle, roi = _selection(mesh)
    center = mesh.vertices[handle].mean(axis=0)
    metrics = ShapeMetrics(mesh.vertices, mesh.faces)
    points = np.zeros((mesh.n_vertices, 3), dtype=np.float32)
    normals = np.zeros((mesh.n_vertices, 3), dtype=np.float32)
    stretch = np.zeros(mesh.n_vertices, dtype=np.float32)
    for propagation in ("residual", "linear"):
        say(f"{label}: drags ({propagation})", 0.3)
        e = HybridEditor(mesh, cage=ed.cage, binding=ed.M, propagation=propagation)
        e.set_selection(handle, roi=roi)
        moving = getattr(e, "moving_vertices", None)
        metrics.set_moving(moving if moving is not None else np.arange(mesh.n_vertices))
        for k in range(1, 4):
            V = e.drag(transform=rigid_transform(translate=(0.0, 0.05 * k, 0.0), axis=(0, 0, 1),
                                                 degrees=5.0 * k, center=center))
            metrics.write_points(V, points)
            metrics.write_normals(V, normals)
            copy_rows(normals, metrics.normal_vertices, points, metrics.normal_vertices)  # (into the parts)
            metrics.moving_box(points)
            metrics.update_error(V)
            metrics.write_stretch(stretch)
        e.converge(transform=rigid_transform(translate=(0.0, 0.2, 0.0), axis=(0, 0, 1), degrees=20.0,
                                             center=center), max_iterations=30)  # (the settle's history)
        metrics.update_error(V, everything=True)
        metrics.write_normals(V, normals, everything=True)
        points_box(points, skip=np.zeros(mesh.n_vertices, dtype=bool))  # (the window's boxes)
        points_box(V)
        e.reset()
    say(f"{label}: polish", 0.6)
    free = np.zeros(mesh.n_vertices, dtype=bool)
    free[roi] = True
    free[handle] = False
    polish(ShapeARAP(mesh), V, free, max_iterations=2)
    say(f"{label}: exact binding", 0.8)
    bind(mesh.vertices[:50], ed.cage, method="exact")


def engine_rare_paths(shape) -> None:
    """Compile the engine's paths that a small shape's edit does not take and a big shape's may:
    binding rows wider than the fast kernel's row buffer, points on the cage's faces, rows cut to
    their largest, rows interpolated from seeds' (a shape of millions of vertices), a big surface
    clustered and simplified in halves, a big region's band, rotations in lanes, the dominant cage
    vertices of a binding given with repeated entries.

    What :func:`run` compiles beyond its edit sessions, file formats apart; the Blender
    extension's background compile calls it too (its engine has no file formats).

    Parameters
    ----------
    shape : a small closed :class:`~hybridedit.core.mesh.Mesh` (e.g. :func:`blob`), of at least 32 faces.

    Examples
    --------
    >>> engine_rare_paths(blob(2))  # doctest: +SKIP
    """
    from .binding.bind import bind
    from .binding.mvc import atan2_pos_array
    from .cage.cluster import cluster_surface
    from .cage.qem import presimplify
    from .core.rotations import closest_rotation, closest_rotations

    presimplify(shape.vertices, shape.faces, shape.n_faces // 8, min_faces=8)  # (a big surface cut in halves)
    cluster_surface(shape.vertices, shape.faces, max(shape.n_vertices // 8, 4))  # (a very big one clustered first)
    bind(0.5 * shape.vertices[:8], shape, truncation=0.0)  # the shape as its own cage, untruncated
    bind(shape.vertices[shape.faces[:4]].mean(axis=1), shape)  # points on the cage's faces: their face's rows
    import scipy.sparse as sp

    from .binding.truncation import cap_rows

    wide = sp.csr_matrix(np.full((2, 6), 1.0 / 6.0))  # rows wider than the cap: cut to their largest, refitted
    wide.has_sorted_indices = True
    octahedron = np.vstack([np.eye(3), -np.eye(3)])
    cap_rows(wide, np.zeros((2, 3)), octahedron, 4)
    from .binding.bind import dominant_cage_vertex

    dominant_cage_vertex(wide)  # (a given binding with repeated entries: the set-up's own pass over it)
    from .binding.interpolated_rows import interpolated_binding

    def seed_rows(seeds):  # (the shape as its own cage: its seeds' unit rows)
        return bind(shape.vertices[seeds], shape)

    for twins in (contextlib.nullcontext(), parallel_everywhere()):
        with twins:
            interpolated_binding(shape.vertices, shape.faces, seed_rows, cage_vertices=shape.vertices, truncation=0.03)

    closest_rotations(np.tile(np.eye(3), (4, 1, 1)), np.empty((4, 3, 3)))
    closest_rotation(np.eye(3), np.empty((3, 3)))  # (the frames turn theirs in lanes)
    from .core.proximity import rows_near

    rows_near(np.eye(3), np.arange(3), np.array([0]), 0.5)  # (a big region's band, from 8,000 free rows)
    with parallel_everywhere():
        rows_near(np.eye(3), np.arange(3), np.array([0]), 0.5)
    atan2_pos_array(np.ones(4), np.ones(4))


def _file_format_paths() -> None:
    """The file readers' and writers' kernels the pipeline's in-memory shapes do not reach."""
    from .fileio.formats import obj

    # an OBJ's line scan, token counts, joined vertex text and face parser: an indented file with a
    # colour on one vertex, normals; then a plain one with a line led by a form feed
    obj.read(b"v 0 0 0\n  v 1 0 0\nv 0 1 0 1 1 1\nvn 0 0 1\nf 1//1 2//1 3//1\nf 1 2 3\n")
    obj.read(b"v 0 0 0\nv 1 0 0\nv 0 1 0\n\fo x\nf 1 2 3\n")
    # a plain OBJ written (a conversion's): its compiled vertex (not float32: 0.1) and face lines
    from dataclasses import replace

    obj.write(replace(obj.read(b"v 0.1 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n"), native=None))
    # and a plain OFF: its compiled face lines (vertices as the OBJ's)
    from .fileio.formats import off

    off.write(replace(obj.read(b"v 0.1 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"), native=None))

    import tempfile

    from .core.mesh import Mesh
    from .fileio.meshfiles import read_mesh, write_mesh

    # a binary PLY's triangles, cast off the file's mapping (int32 records into int64), on one
    # thread and on two (a big file's)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "warm.ply"
        write_mesh(path, Mesh(np.vstack([np.eye(3), np.ones(3)]), np.array([[0, 1, 2], [2, 1, 3]])))  # (strided)
        read_mesh(path)
        with parallel_everywhere():
            read_mesh(path)


def run(progress: Progress | None = None) -> dict:
    """Compile (or load from the cache) every kernel; returns what happened.

    Returns
    -------
    dict with ``seconds``, ``compiled`` and ``loaded`` (kernel versions) and
    ``uncovered`` (entry kernels the pipeline did not reach; empty when all is well).
    """
    say = progress or (lambda stage, fraction: None)
    t0 = time.perf_counter()
    with record_compiles() as compiled:
        shape = blob(3)
        _edit_session(needs_repair(shape), say, "serial kernels")
        with parallel_everywhere():
            _edit_session(shape, say, "parallel kernels")
        engine_rare_paths(shape)
        _file_format_paths()
    hits, _ = cache_counts()
    result = {"seconds": time.perf_counter() - t0, "compiled": len(compiled), "loaded": hits,
              "uncovered": uncovered()}
    if not result["uncovered"]:
        write_stamp()
    say("kernels ready", 1.0)
    return result


# ---------------------------------------------------------------------------- has it run for this code?


def stamp_path() -> Path:
    """The file that says the warm-up ran for this code, numba and Python (in the user cache folder)."""
    import numba

    from .core.cache_dir import default_cache_dir

    from .kernel_cache import sources_stamp

    h = hashlib.sha256()
    h.update(f"{numba.__version__} {sys.version} {sys.platform} {PACKAGE_DIR}".encode())
    h.update(os.environ.get("NUMBA_CACHE_DIR", "").encode())
    h.update(sources_stamp(PACKAGE_DIR).encode())
    return default_cache_dir() / f"kernels-{h.hexdigest()[:20]}.ready"


def write_stamp() -> None:
    p = stamp_path()
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text("compiled by hybridedit.warmup\n", encoding="utf-8")
    except OSError:
        pass  # then the window warms up again next time: slower, never wrong


def is_warm() -> bool:
    """The warm-up has run for this code (so no kernel compiles at run time)."""
    try:
        return stamp_path().is_file()
    except OSError:
        return False


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m hybridedit.warmup", description=__doc__.split("\n\n")[0])
    ap.add_argument("-q", "--quiet", action="store_true", help="print only the summary line")
    args = ap.parse_args(argv)
    last = [""]

    def say(stage: str, fraction: float) -> None:
        if not args.quiet and stage != last[0]:
            last[0] = stage
            print(f"warmup: {stage}", file=sys.stderr, flush=True)

    r = run(say)
    print(f"warmup: {r['compiled']} kernel versions compiled, {r['loaded']} loaded from the cache "
          f"in {r['seconds']:.1f} s", file=sys.stderr)
    if r["uncovered"]:
        print(f"warmup: error: not reached by the warm-up pipeline: {', '.join(r['uncovered'])}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
