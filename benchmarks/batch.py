"""hybridedit batch: poses per minute on one and two Dask workers, and the scaling efficiency.

Every mesh of ../shared/meshes (the armadillo, spot as triangles and as quads, the mountain; set
HYBRIDEDIT_MESHES to another folder) is posed ``--poses`` times with the batch's defaults (5% cage,
45 degrees, 50% stretch, the 60-iteration settle), first on a local cluster of one worker process,
then of two. Each run writes to a folder of its own (nothing is skipped as done) on a cluster
already started, the engine imported on its workers; the bindings come from a cache a warm-up
batch filled first (one pose of each mesh). So what is timed is what a batch over a dataset spends
per pose: the workers reading each mesh and its cached binding once, then drawing, solving, judging
and writing its poses. A single worker's kernels use every core (``NUMBA_NUM_THREADS`` is the cores
per worker), so two workers on two cores gain only what one worker leaves idle. The outputs of the
two runs are compared: the same seed must make the same bytes.

Printed: per run the poses made, the seconds, poses per minute and the manifest's medians per mesh;
then the efficiency, (rate with 2 workers) / (2 x rate with 1 worker).

    python benchmarks/batch.py [--poses 24] [--seed 0] [--out DIR] [--smoke]

``--smoke`` (CI): spot's triangles only, 2 poses a run.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import tempfile
import time
from pathlib import Path

from common import MESHES, machine  # noqa: E402 (common puts the repo on the path)

from hybridedit.batching.api import run  # noqa: E402
from hybridedit.batching.cluster import open_client  # noqa: E402
from hybridedit.batching.plan import MESH_EXTENSIONS  # noqa: E402
from hybridedit.batching.settings import BatchSettings  # noqa: E402


def shared_meshes(smoke: bool) -> list[Path]:
    """The mesh files of ``MESHES`` (searched below), or spot's triangles alone for ``smoke``."""
    if smoke:
        found = [MESHES / "spot" / "spot_triangulated.obj"]
    else:
        found = sorted(p for p in MESHES.rglob("*") if p.suffix.lower() in MESH_EXTENSIONS and p.is_file())
    missing = [p for p in found if not p.is_file()]
    if not found or missing:
        raise SystemExit(f"benchmark needs the meshes of {MESHES} (set HYBRIDEDIT_MESHES to their folder)")
    return found


def _import_engine() -> None:
    """Run on each worker before the clock starts: the engine's modules imported."""
    import importlib

    for name in ("hybridedit.batching.tasks", "hybridedit.deform.editor", "hybridedit.binding.rig"):
        importlib.import_module(name)


def load() -> str:
    """The machine's load average (other processes share the cores the workers are timed on)."""
    try:
        return "load average {:.1f} {:.1f} {:.1f}".format(*os.getloadavg())
    except (AttributeError, OSError):
        return "load average unknown"


def timed_batch(meshes: list[Path], out: Path, settings: BatchSettings, workers: int):
    """(pyarrow table, seconds) of one batch on a local cluster of ``workers`` processes, started
    (and the engine imported on each) before the clock starts."""
    with open_client(workers=workers) as client:
        client.wait_for_workers(workers, timeout=120)
        client.run(_import_engine)
        t0 = time.perf_counter()
        result = run(meshes, out, settings=settings, client=client, progress=False)
        seconds = time.perf_counter() - t0
    return result.table, seconds


def per_mesh(table) -> list[str]:
    """One line a mesh: its outputs done and failed, the median pose seconds, draws and edge error."""
    lines = []
    rows = table.to_pylist()
    for path in dict.fromkeys(r["input"] for r in rows):
        mine = [r for r in rows if r["input"] == path]
        done = [r for r in mine if r["status"] == "done"]
        med = (lambda key: statistics.median(r[key] for r in done) if done else float("nan"))
        lines.append(f"{Path(path).name:>28} {len(done):>5} {len(mine) - len(done):>7} {med('pose_seconds'):>9.2f}"
                     f" {med('draws'):>6.1f} {med('edge_error'):>8.2f} {med('max_stretch'):>9.1f}")
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--poses", type=int, default=24, help="poses of each mesh per run (default 24)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, help="keep the runs' outputs and manifests here (default: a temporary folder)")
    ap.add_argument("--smoke", action="store_true", help="CI smoke run: spot's triangles, 2 poses a run")
    args = ap.parse_args()
    meshes = shared_meshes(args.smoke)
    poses = 2 if args.smoke else args.poses
    work = Path(tempfile.mkdtemp(prefix="hybridedit-batch-bench-"))
    out = args.out if args.out is not None else work / "out"
    os.environ["HYBRIDEDIT_CACHE_DIR"] = str(work / "cache")  # a cache of its own, warmed below
    try:
        print(f"# hybridedit batch - {machine()}; {load()}")
        print(f"# {len(meshes)} mesh{'es' if len(meshes) != 1 else ''} from {MESHES}: {', '.join(p.name for p in meshes)}; {poses} poses each, "
              f"seed {args.seed}, default pose settings; bindings from a warm cache, clusters started beforehand")
        warm, _ = timed_batch(meshes, work / "warm-up", BatchSettings(poses=1, seed=args.seed), 2)
        print(f"# warm-up (one pose of each mesh, binding into the cache): "
              f"{sum(s == 'done' for s in warm.column('status').to_pylist())} done")
        settings = BatchSettings(poses=poses, seed=args.seed)
        rates, hashes = {}, {}
        for workers in (1, 2):
            table, seconds = timed_batch(meshes, out / f"{workers}-worker{'s' if workers > 1 else ''}", settings,
                                         workers)
            done = sum(s == "done" for s in table.column("status").to_pylist())
            rates[workers] = done / seconds * 60.0
            hashes[workers] = dict(zip(table.column("output").to_pylist(), table.column("output_sha256").to_pylist()))
            print()
            print(f"{workers} worker{'s' if workers > 1 else ' '}: {done} poses done of {table.num_rows} in "
                  f"{seconds:.1f} s: {rates[workers]:.1f} poses per minute")
            print(f"{'mesh':>28} {'done':>5} {'failed':>7} {'pose s':>9} {'draws':>6} {'RRMS-E%':>8} {'stretch%':>9}")
            print("\n".join(per_mesh(table)))
        print()
        made = [k for k in hashes[1] if hashes[1][k] is not None]
        same = sum(hashes[1][k] == hashes[2].get(k) for k in made)
        print(f"the same files with 1 and 2 workers: {same} of the {len(made)} outputs made bit-identical")
        print(f"scaling efficiency, 1 -> 2 workers: {rates[2] / (2 * rates[1]) * 100:.0f}% "
              f"(speed-up {rates[2] / rates[1]:.2f}x on {os.cpu_count()} cores; {load()} at the end)")
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
