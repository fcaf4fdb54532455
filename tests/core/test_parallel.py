import os
import subprocess
import sys
import time

import pytest

from hybridedit.core import parallel


def test_pick_switches_at_the_kinds_size_and_all_parallel_restores_it(monkeypatch):
    import numba

    if numba.get_num_threads() < 2:
        pytest.skip("one thread: every kind is serial")
    monkeypatch.setattr(parallel, "free_cores", lambda: 2.0)  # (whatever else runs on the machine)
    size = parallel.THRESHOLDS["propagate"]
    assert parallel.pick("propagate", "s", "p", size - 1) == "s"
    assert parallel.pick("propagate", "s", "p", size) == "p"
    with parallel.all_parallel():
        assert all(v == 0 for v in parallel.THRESHOLDS.values())
        assert parallel.pick("propagate", "s", "p", 0) == "p"
    assert parallel.THRESHOLDS["propagate"] == size
    with pytest.raises(KeyError):
        parallel.pick("no such kind", "s", "p", 1)


def test_pick_is_serial_where_no_second_core_is_free(monkeypatch):
    import numba

    if numba.get_num_threads() < 2:
        pytest.skip("one thread: every kind is serial")
    size = parallel.THRESHOLDS["propagate"]
    monkeypatch.setattr(parallel, "free_cores", lambda: 1.0)
    assert parallel.pick("propagate", "s", "p", 10 * size) == "s"
    monkeypatch.setattr(parallel, "free_cores", lambda: 2.0)
    assert parallel.pick("propagate", "s", "p", 10 * size) == "p"


def test_pick_is_serial_on_a_thread_limited_to_one():
    import numba

    size = parallel.THRESHOLDS["propagate"]
    before = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        assert parallel.pick("propagate", "s", "p", 10 * size) == "s"
    finally:
        numba.set_num_threads(before)


def test_a_size_of_zero_is_parallel_whatever_the_load(monkeypatch):
    monkeypatch.setattr(parallel, "free_cores", lambda: 0.0)
    with parallel.all_parallel():
        assert parallel.pick("rotations", "s", "p", 1) == "p"


@pytest.mark.skipif(not os.path.exists("/proc/stat"), reason="the machine's load is read from /proc/stat")
def test_busy_neighbours_leave_no_core_free():
    """As many spinning processes as cores: what this process sees free drops below one core
    (however loaded the machine already was, never above)."""
    cores = os.cpu_count()
    procs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(cores)]
    try:
        time.sleep(0.3)
        load = parallel._Load()
        load.free_cores()
        time.sleep(0.5)
        assert load.free_cores() < 1.0
    finally:
        for p in procs:
            p.kill()
            p.wait()


def test_importing_hybridedit_makes_openmp_threads_wait_asleep():
    code = "import os, hybridedit; print(os.environ['OMP_WAIT_POLICY'])"
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "passive"
    env["OMP_WAIT_POLICY"] = "active"  # the user's own choice wins
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "active"


TWINS_FROM_THE_CACHE = """
import json, numba, numpy as np
from hybridedit.core.region_metrics import _write_rows
def layer():
    try:
        return numba.threading_layer()
    except ValueError:  # (no parallel kernel has run)
        return None
V, rows, seen = np.arange(12.0).reshape(4, 3), np.array([3, 1]), []
for twin in _write_rows:
    out = np.zeros((4, 3))
    twin(V, rows, out)
    seen.append([out.tolist(), sum(twin._cache_hits.values()), layer() is not None])
print(json.dumps(seen))
"""


def test_each_twin_has_its_own_cache_entry_and_the_parallel_one_runs_in_parallel():
    """numba names a cache entry by the function, not its flags: the parallel twin is a renamed
    copy (core.twins), so that in a fresh process each loads its own code."""
    import json

    for _ in range(2):  # (the first run may compile them)
        r = subprocess.run([sys.executable, "-c", TWINS_FROM_THE_CACHE], capture_output=True, text=True, check=True)
    (serial, hits_s, pool_s), (parallel, hits_p, pool_p) = json.loads(r.stdout)
    want = [[0.0] * 3, [3.0, 4.0, 5.0], [0.0] * 3, [9.0, 10.0, 11.0]]
    assert serial == parallel == want
    assert (hits_s, hits_p) == (1, 1)  # both loaded from the cache
    assert (pool_s, pool_p) == (False, True)  # only the parallel one started numba's threads
