"""A batch on a cluster started with the ordinary commands (`dask scheduler`, two `dask worker`) on
localhost: one worker is killed mid-run, and every output is still made (with a pack too: the packs
hold every pose)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pyarrow.parquet as pq
import pytest

import hybridedit as he

from shapes import REPO


def dask_command(*args: str) -> list[str]:
    """``dask ARGS``: the environment's ``dask`` command (beside this interpreter), else the same
    entry point run by this interpreter."""
    script = Path(sys.executable).with_name("dask")
    if script.is_file():
        return [str(script), *args]
    return [sys.executable, "-c", "import sys; from dask.__main__ import main; sys.argv[0] = 'dask'; main()", *args]


def start(args: list[str], log: Path) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")])),
           "NUMBA_NUM_THREADS": "1"}
    return subprocess.Popen(args, stdout=log.open("w"), stderr=subprocess.STDOUT, env=env, cwd=REPO,
                            start_new_session=True)  # a process group of its own: killed with its children


def stop(p: subprocess.Popen) -> None:
    if p.poll() is None:
        os.killpg(p.pid, signal.SIGKILL)
    p.wait(timeout=30)


def wait_for(what, timeout: float, step: float = 0.1):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        got = what()
        if got:
            return got
        time.sleep(step)
    raise AssertionError(f"timed out after {timeout} s")


@pytest.mark.slow
@pytest.mark.parametrize("pack", [None, "glb"])
def test_a_worker_killed_mid_run_loses_no_output(inputs, tmp_path, cage, pack):
    from distributed import Client

    scheduler_file = tmp_path / "scheduler.json"
    procs = [start(dask_command("scheduler", "--host", "127.0.0.1", "--port", "0", "--dashboard-address", ":0",
                                "--scheduler-file", str(scheduler_file)), tmp_path / "scheduler.log")]
    try:
        wait_for(lambda: scheduler_file.exists() and scheduler_file.stat().st_size > 0, 60)
        address = json.loads(scheduler_file.read_text())["address"]
        for k in (1, 2):
            procs.append(start(dask_command("worker", address, "--nthreads", "1", "--nworkers", "1",
                                            "--name", f"w{k}", "--no-dashboard"), tmp_path / f"worker{k}.log"))
        with Client(address, timeout=60) as client:
            client.wait_for_workers(2, timeout=120)
            out = tmp_path / "out"
            done: dict = {}
            run = threading.Thread(target=lambda: done.update(table=he.batch(
                [inputs], out, poses=8, seed=3, scheduler=address, cage_size=cage,
                output_format=None if pack else "ply", pack=pack, progress=False)))
            run.start()
            # the first outputs are in: kill a worker (and its nanny) while the rest are being made
            made_before = wait_for(lambda: len(list(out.glob("*-pose*.edit.json"))), 120, 0.02)
            stop(procs[1])
            run.join(timeout=300)
            assert not run.is_alive()
        table = done["table"]
        assert made_before < table.num_rows == 16
        statuses = table.column("status").to_pylist()
        messages = table.column("message").to_pylist()
        assert statuses == ["done"] * 16, [(k, m) for k, (st, m) in enumerate(zip(statuses, messages)) if st != "done"]
        assert pq.read_table(out / "manifest.parquet").num_rows == 16
        if pack:
            import pygltflib

            for stem in ("blob", "long"):
                gltf = pygltflib.GLTF2.load(str(out / f"{stem}-poses.glb"))
                assert gltf.meshes[0].extras["targetNames"] == [f"pose-00{k}" for k in range(8)]
            assert set(table.column("pack").to_pylist()) == {"blob-poses.glb", "long-poses.glb"}
        else:
            assert all((out / name).is_file() for name in table.column("output").to_pylist())
    finally:
        for p in procs:
            stop(p)
