"""The first Bind right after installing: the extension enabled with an empty kernel cache and an
empty user folder, in Blender itself (bpy, headless), each case in a fresh process.

    blender/.venv-bpy/bin/python blender/bench_first_bind.py [--vertices 50000] [--cases during after thread]
        [--addon DIR]   # the extension's package from DIR (e.g. an older commit's, for "today";
                        # or the built Linux zip unpacked into DIR/hybridedit_blender: its portable kernels)

Cases:
  during  Bind right after enabling (the background compile is still running: Bind waits for it,
          unless the zip's portable kernels serve)
  after   the background compile left to finish first (its time), then the first Bind
  thread  (for comparison) the same compile run on a thread of Blender's process, then the first Bind

Meanwhile the main thread runs slices of pure Python work (about 5 ms each, calibrated when the
slices start: what drawing panels and running handlers cost Blender), and their duration says how
much the compile takes from it (the GIL).
The Bind is counted: kernel versions compiled in Blender's process during it (numba's compile
events) and loaded from the cache. The mesh: a bumpy UV sphere made by Blender's operator, the
handle its top 5% along Z, the ROI its top 30% (as bench_live.py). numba is imported before the
Bind's timer starts (to count its compiles), in every case.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def python_slices(stop: threading.Event, out: list) -> None:
    """5 ms slices of pure Python work on this thread until ``stop``, each slice's duration in ms
    appended to ``out`` (idle: 5 ms; beside a thread holding the GIL: more)."""
    t = time.perf_counter()
    for _ in range(200):  # how many loop turns make 5 ms here, idle
        sum(i * i for i in range(100))
    n = max(1, int(round(200 * 0.005 / (time.perf_counter() - t))))
    while not stop.is_set():
        t0 = time.perf_counter()
        for _ in range(n):
            sum(i * i for i in range(100))
        out.append((time.perf_counter() - t0) * 1e3)
        time.sleep(0.005)


def dispatcher_counts() -> tuple[int, int]:
    """(loaded from the cache, compiled) kernel versions of hybridedit's modules in this process."""
    from numba.core.registry import CPUDispatcher

    from hybridedit.core.twins import Twins

    hits = misses = 0
    for name, mod in list(sys.modules.items()):
        if not name.startswith("hybridedit.") or mod is None:
            continue
        for obj in list(vars(mod).values()):
            for d in (obj._asdict().values() if isinstance(obj, Twins) else (obj,)):
                if isinstance(d, CPUDispatcher) and getattr(d, "__module__", None) == name:
                    hits += sum(d._cache_hits.values())
                    misses += sum(d._cache_misses.values())
    return hits, misses


def child(case: str, n: int) -> dict:
    import bpy

    import hybridedit_blender as hb

    out = {"case": case, "bpy": bpy.app.version_string}
    bpy.ops.wm.read_factory_settings(use_empty=True)
    t0 = time.perf_counter()
    hb.register()  # what enabling the extension runs
    out["register_s"] = time.perf_counter() - t0
    from hybridedit_blender import session as S

    seg = int(round(math.sqrt(n)))
    bpy.ops.mesh.primitive_uv_sphere_add(segments=seg, ring_count=max(3, (n - 2) // seg + 1))
    obj = bpy.context.object
    me = obj.data
    P = S.read_positions(me).reshape(-1, 3)
    P *= (1 + 0.05 * np.sin(9 * P[:, :1]) * np.sin(7 * P[:, 1:2]))
    me.vertices.foreach_set("co", P.ravel())
    me.update()
    z = P[:, 2]
    me.vertices.foreach_set("select", z > np.quantile(z, 0.95))
    bpy.ops.hybrid_arap.add_handle()
    me.vertices.foreach_set("select", z > np.quantile(z, 0.70))
    bpy.ops.hybrid_arap.roi_from_selection()
    out["vertices"] = len(me.vertices)
    kern = getattr(hb, "kernels", None)
    bg = kern.CURRENT if kern is not None else None
    out["background"] = bg is not None
    if case in ("after", "thread"):
        stop, slices = threading.Event(), []
        t0 = time.perf_counter()
        if case == "thread":
            if bg is not None:
                bg.kill()  # (this case compiles on a thread instead)
            from hybridedit_blender import precompile

            th = threading.Thread(target=precompile.rehearse)
            th.start()
            watcher = threading.Thread(target=lambda: (th.join(), stop.set()))
        else:
            watcher = threading.Thread(target=lambda: (bg.done.wait(), stop.set()))
        watcher.start()
        python_slices(stop, slices)
        out["compile_s"] = time.perf_counter() - t0
        out["compile_ok"] = bg.ok if case == "after" else True
        out["slice_ms"] = [float(np.median(slices)), float(np.percentile(slices, 99)), float(max(slices))]
    idle = []
    stop = threading.Event()
    threading.Timer(1.0, stop.set).start()
    python_slices(stop, idle)
    out["idle_slice_ms"] = [float(np.median(idle)), float(max(idle))]
    from numba.core import event

    class Count(event.Listener):
        n = 0

        def on_start(self, ev):
            pass

        def on_end(self, ev):
            Count.n += 1

    with event.install_listener("numba:compile", Count()):
        t0 = time.perf_counter()
        r = bpy.ops.hybrid_arap.bind()
        out["bind_s"] = time.perf_counter() - t0
    out["bind_ok"] = r == {"FINISHED"}
    out["compiled_in_blender"] = Count.n
    portable = getattr(hb, "portable_kernels", None)
    out["kernels"] = "portable" if portable is not None and portable.IN_USE else "this CPU's"
    out["loaded_from_cache"] = dispatcher_counts()[0]
    if bg is not None and case == "during":
        out["compile_running"] = bg.running  # (the portable kernels served: the Bind did not wait)
        out["compile_s"] = bg.seconds if not bg.running else time.monotonic() - bg.started
        out["compile_ok"] = bg.ok or bg.running
    if bg is not None and case != "thread":  # the compile's own CPU time (its log's last line)
        import re

        m = re.search(r"\(([\d.]+) s of CPU\)", Path(bg.log_path).read_text())
        out["compile_cpu_s"] = float(m.group(1)) if m else None
    elif case == "thread":
        out["compile_cpu_s"] = None
    out["load"] = os.getloadavg()[0]
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--vertices", type=int, default=50_000)
    ap.add_argument("--cases", nargs="*", default=["during", "after", "thread"], choices=["during", "after", "thread"])
    ap.add_argument("--addon", type=Path, default=HERE, help="the folder holding hybridedit_blender/")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        sys.path.insert(0, str(args.addon))
        print("RESULT " + json.dumps(child(args.child, args.vertices)), flush=True)
        os._exit(0)  # (bpy 4.2 may crash in the interpreter's teardown)
    rows = []
    for case in args.cases:
        with tempfile.TemporaryDirectory(prefix="hybrid-arap-first-bind-") as fresh:
            env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
            env["HYBRIDEDIT_BLENDER_CACHE"] = fresh  # the extension's user folder: kernels and bindings
            r = subprocess.run([sys.executable, __file__, "--child", case, "--vertices", str(args.vertices),
                                "--addon", str(args.addon)], env=env, capture_output=True, text=True)
            line = next((ln for ln in r.stdout.splitlines() if ln.startswith("RESULT ")), None)
            if line is None:
                print(r.stdout[-3000:], r.stderr[-3000:], file=sys.stderr)
                return 1
            res = json.loads(line[7:])
            print(json.dumps(res), flush=True)
            rows.append(res)
    head = ("case", "vertices", "background compile", "compile (s)", "its CPU time (s)", "load average",
            "main thread: Python slices took (median / p99 / max ms)", "the same, 1 s before Bind", "kernels",
            "first Bind (s)", "compiled in Blender's process during Bind", "loaded from the cache")
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for r in rows:
        sl = r.get("slice_ms")
        print("| " + " | ".join([
            r["case"], f"{r['vertices']:,}", "yes" if r["background"] else "no",
            (f"{r['compile_s']:.1f}" + (" (still running)" if r.get("compile_running") else "")
             + ("" if r.get("compile_ok", True) else " (failed)")) if "compile_s" in r else "-",
            f"{r['compile_cpu_s']:.1f}" if r.get("compile_cpu_s") else "-", f"{r['load']:.1f}",
            " / ".join(f"{x:.1f}" for x in sl) if sl else "-", " / ".join(f"{x:.1f}" for x in r["idle_slice_ms"]),
            r.get("kernels", "-"),
            f"{r['bind_s']:.1f}" + ("" if r["bind_ok"] else " (failed)"), str(r["compiled_in_blender"]),
            str(r["loaded_from_cache"])]) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
