"""The engine's kernels compiled before the first Bind, in a process of its own (no bpy here).

Enabling the extension starts this file (:mod:`.kernels`) with Blender's own Python, Blender's
import path and the extension's ``NUMBA_CACHE_DIR``. It rehearses on small generated shapes what
the extension asks of the engine: Bind (:func:`.engine.build_session`, a shape that needs repair
too, then the same shapes from the binding cache), a live frame, the settle, an animation frame
solved from the base pose, Apply's new base, Reset; serial twins first, then the parallel twins
(every size threshold at zero), then the engine's rarer binding paths a big mesh takes. numba
writes each kernel into the cache folder, and Blender's process then only loads them.

A process rather than a thread: numba types and lowers a kernel in Python, holding the GIL that
Blender's main thread needs to draw its panels and run handlers, and a kernel called on Blender's
side would wait for numba's compiler lock. This process holds neither, runs at a lower priority
(nice 5) and, on a machine of two cores or more, leaves Blender a core.

It prints ``progress FRACTION STAGE`` lines, writes :func:`stamp_path` when everything compiled
(the sources the cache was compiled for), and ends when its stdin closes (Blender quit).

    python precompile.py        # (with the extension's import path and NUMBA_CACHE_DIR)
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import sys
import tempfile
import threading
import time
from typing import Callable

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
#: the extension's files whose change changes what the rehearsal reaches
OWN_FILES = ("engine.py", "session.py", "precompile.py")

Say = Callable[[str, float], None]


# ------------------------------------------------------------------ the stamp (cheap: at every register)
def sources_digest() -> str | None:
    """A digest of what the cached kernels were compiled from: Python, numba and llvmlite's
    versions, where hybridedit is and the size and time of each of its files (and of the files of
    this extension that drive the rehearsal). None when hybridedit cannot be found. Finding it
    does not import it (nor numba): a few milliseconds."""
    spec = importlib.util.find_spec("hybridedit")
    if spec is None or not spec.submodule_search_locations:
        return None
    package = os.path.realpath(list(spec.submodule_search_locations)[0])
    h = hashlib.sha256(f"{sys.version} {sys.platform} {package}".encode())
    for dist in ("numba", "llvmlite"):
        try:
            from importlib.metadata import version

            h.update(f" {dist} {version(dist)}".encode())
        except Exception:  # noqa: BLE001 -- no metadata: the files' times still say a change
            pass
    files = [os.path.join(HERE, f) for f in OWN_FILES]
    for folder, dirs, names in os.walk(package):
        dirs[:] = sorted(d for d in dirs if d != "__pycache__")
        files += [os.path.join(folder, n) for n in sorted(names) if n.endswith(".py")]
    for path in files:
        try:
            st = os.stat(path)
        except OSError:
            continue
        h.update(f"\0{path}\0{st.st_size}\0{st.st_mtime_ns}".encode())
    return h.hexdigest()[:20]


def stamp_path(cache_dir: str) -> str | None:
    """The file in numba's cache folder that says every kernel is compiled there for these sources."""
    digest = sources_digest()
    return os.path.join(cache_dir, f"hybrid-arap-kernels-{digest}.ready") if digest else None


def write_stamp(cache_dir: str, seconds: float) -> None:
    path = stamp_path(cache_dir)
    if path is None:
        return
    tmp = f"{path}.{os.getpid()}.tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(f"compiled by the Hybrid ARAP extension's background compile in {seconds:.1f} s\n")
    os.replace(tmp, path)  # (atomic: a half-written stamp is never read)


# ------------------------------------------------------------------ the shapes
def bumpy_sphere(rings: int = 24, segments: int = 32) -> tuple[np.ndarray, np.ndarray]:
    """A closed bumpy UV sphere: (n*3,) float32 positions (as Blender holds them) and (m, 3) int64
    triangles (as Bind reads them)."""
    th = np.linspace(0, np.pi, rings + 1)[1:-1]
    ph = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    T, P = np.meshgrid(th, ph, indexing="ij")
    ring = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], axis=-1).reshape(-1, 3)
    V = np.vstack([[0.0, 0.0, 1.0], ring, [0.0, 0.0, -1.0]])
    V *= (1.0 + 0.05 * np.sin(7 * V[:, :1]) * np.cos(5 * V[:, 1:2]))
    idx = 1 + np.arange((rings - 1) * segments).reshape(rings - 1, segments)
    nxt = np.roll(idx, -1, axis=1)
    tris = [np.stack([np.zeros(segments, int), idx[0], nxt[0]], axis=1)]
    a, b, c, d = idx[:-1], nxt[:-1], nxt[1:], idx[1:]
    tris += [np.stack([a, d, b], axis=-1).reshape(-1, 3), np.stack([b, d, c], axis=-1).reshape(-1, 3)]
    south = len(V) - 1
    tris.append(np.stack([np.full(segments, south), nxt[-1], idx[-1]], axis=1))
    return V.astype(np.float32).ravel(), np.vstack(tris).astype(np.int64)


def needs_repair(rest32: np.ndarray, tris: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The same shape with a duplicated vertex, some faces flipped and a hole (the repair pass)."""
    V = rest32.reshape(-1, 3)
    V = np.vstack([V, V[:1]])
    f = tris.copy()
    f[f == 0] = len(V) - 1  # the copy of vertex 0 replaces it in its faces: a duplicate to merge
    f[::7] = f[::7, ::-1]  # inconsistent orientation
    f = np.delete(f, [len(f) // 2, len(f) // 2 + 1], axis=0)  # a hole
    return V.astype(np.float32).ravel(), f


# ------------------------------------------------------------------ the rehearsal
def _turn(k: int, degrees: float, lift: float) -> np.ndarray:
    """A handle's transform: turned about a tilted axis through the origin and lifted."""
    import hybridedit as he

    return he.rigid_transform(translate=(0.0, 0.3 * lift, lift), axis=(1.0, 0.3, 0.2 * k), degrees=degrees)


def _session_pass(label: str, rest32, tris, groups: dict[str, np.ndarray], roi, stretch, cache_dir, say: Say) -> None:
    """Bind (cold, then from the binding cache), a live frame and its settle, a frame from the
    cache, an animation frame solved from the base pose, Apply's new base and Reset."""
    from . import session as S
    from .engine import build_session

    def bind(stage):
        return build_session(
            uid=label, object_name=label, rest32=rest32, basis32=rest32, tris=tris,
            counts=(len(rest32) // 3, 0, len(tris)), digest=S.fingerprint(rest32, tris), groups=list(groups),
            handle_rows=list(groups.values()), roi=roi, roi_group="ROI" if roi is not None else "",
            stretch=stretch, cage_size=0.05, iterations=2, cache_dir=cache_dir,
            progress=lambda st, f: say(f"{label}: {stage} ({st})", f))

    s = bind("bind")
    s = bind("bind from the cache")
    assert s.cache_hit
    say(f"{label}: live frames and the settle", 0.0)
    T = {g: _turn(g, 20.0, 0.2) for g in range(len(groups))}
    with S.ENGINE:
        s.live_frame(T)
        s.settle(T)  # (live.settle_async)
        assert s.from_cache(T)
        say(f"{label}: an animation frame", 0.0)
        s.solve({g: _turn(g, 35.0, 0.3) for g in range(len(groups))})  # (live.pose_frame)
        say(f"{label}: Apply and Reset", 0.0)
        V = s.editor.deformed_vertices.copy()  # (ops.rebase_async)
        s.editor.set_pose(V)
        s.base = S.Base(s.base.digest + "+", rest32.copy(), rest32.copy())
        s.select()
        s.live_frame(T)
        s.zero()


def _rare_paths(rest32, tris) -> None:
    """The engine's binding paths that a small shape does not take and a big one may (as
    hybridedit.warmup compiles them: :func:`hybridedit.warmup.engine_rare_paths`)."""
    import hybridedit as he
    from hybridedit.warmup import engine_rare_paths

    engine_rare_paths(he.Mesh(rest32.reshape(-1, 3).astype(np.float64), tris, name="rare paths"))


#: each part and where it starts in the progress (its share of the time, measured)
PARTS = (("serial kernels", 0.0), ("parallel kernels", 0.50), ("rare paths", 0.63))
#: kernel versions the whole rehearsal compiles into an empty cache (measured; the progress
#: counts them, and holds below 1 should the engine gain more)
VERSIONS = 180


def rehearse(say: Say | None = None) -> None:
    """Everything the extension asks of the engine, on small shapes; ``say(stage, fraction)`` as it
    goes (fraction of the whole, 0-1: kernel versions compiled over :data:`VERSIONS`, at least
    where its part starts)."""
    from numba.core import event

    from hybridedit.core.parallel import all_parallel

    report = say or (lambda stage, fraction: None)

    class Count(event.Listener):
        n = 0

        def on_start(self, ev):
            pass

        def on_end(self, ev):
            Count.n += 1

    def part(k: int) -> Say:
        lo = PARTS[k][1]
        hi = PARTS[k + 1][1] if k + 1 < len(PARTS) else 1.0
        return lambda stage, f: report(f"{PARTS[k][0]}: {stage}", min(max(lo, Count.n / VERSIONS), hi, 0.99))

    rest32, tris = bumpy_sphere()
    z = rest32.reshape(-1, 3)[:, 2]
    top, bottom = np.flatnonzero(z > 0.7), np.flatnonzero(z < -0.7)
    roi = np.flatnonzero(z > -0.3)
    stretch = np.diag([1.3, 0.8, 1.0])
    with event.install_listener("numba:compile", Count()), \
            tempfile.TemporaryDirectory(prefix="hybrid-arap-precompile-") as cache:
        bad32, bad_tris = needs_repair(rest32, tris)
        _session_pass("a shape to repair", bad32, bad_tris, {"top": top}, roi, None, cache, part(0))
        _session_pass("two handles", rest32, tris, {"top": top, "bottom": bottom}, None, stretch, cache, part(0))
        with all_parallel():
            _session_pass("one handle", rest32, tris, {"top": top}, roi, None, os.path.join(cache, "p"), part(1))
        part(2)("binding", 0.0)
        _rare_paths(rest32, tris)
    report(f"done ({Count.n} kernel versions compiled)", 1.0)


# ------------------------------------------------------------------ the process
def _end_with_the_parent() -> None:
    """Exit when stdin closes: Blender quit (or was killed), so nobody waits for these kernels."""
    def watch():
        try:
            while sys.stdin.buffer.read(1 << 16):
                pass
        except (OSError, ValueError):
            pass
        os._exit(3)

    threading.Thread(target=watch, name="parent-watch", daemon=True).start()


def main() -> int:
    if hasattr(os, "nice"):
        try:
            os.nice(5)  # (Windows: the parent starts it below normal priority)
        except OSError:
            pass
    _end_with_the_parent()
    cache_dir = os.environ.get("NUMBA_CACHE_DIR")
    if not cache_dir:
        print("precompile: NUMBA_CACHE_DIR is not set", file=sys.stderr)
        return 2
    t0 = time.perf_counter()
    last = [-1.0]

    part = [""]

    def say(stage: str, fraction: float) -> None:
        if fraction - last[0] >= 0.005 or stage.startswith("done"):
            last[0] = fraction
            print(f"progress {fraction:.3f} {stage}", flush=True)
        head = stage.split(" (")[0]
        if head != part[0]:  # (the log: where the time goes)
            part[0] = head
            print(f"precompile: {time.perf_counter() - t0:6.1f} s {fraction:.2f} {head}", file=sys.stderr, flush=True)

    say("loading the engine", 0.0)
    rehearse(say)
    seconds = time.perf_counter() - t0
    import hybridedit.warmup as hw

    missed = _not_reached(hw)
    print(f"precompile: {hw.cache_counts()[0]} kernel versions loaded from the cache; in {seconds:.1f} s "
          f"({time.process_time():.1f} s of CPU); entry "
          f"kernels not reached: {', '.join(missed) or 'none'}", file=sys.stderr, flush=True)
    write_stamp(cache_dir, seconds)
    return 0


def _not_reached(hw) -> list[str]:
    """Entry kernels no call reached, among the modules this Python can import (the extension has no
    file-format packages: their readers' kernels are not the extension's)."""
    modules = []
    for name in hw.kernel_modules():
        try:
            importlib.import_module(name)
            modules.append(name)
        except ImportError:
            pass
    hw.kernel_modules = lambda: modules  # (this process ends next)
    return hw.uncovered()


def _as_package():
    """This folder imported as a package of its own name (its relative imports then work), without
    Blender: ``__init__`` imports nothing at the top."""
    name = "_hybrid_arap_precompile"
    spec = importlib.util.spec_from_file_location(name, os.path.join(HERE, "__init__.py"),
                                                  submodule_search_locations=[HERE])
    pkg = importlib.util.module_from_spec(spec)
    sys.modules[name] = pkg
    spec.loader.exec_module(pkg)
    return importlib.import_module(f"{name}.precompile")


if __name__ == "__main__":
    code = _as_package().main()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)  # (not the interpreter's teardown: the stdin watcher is blocked in a read)
