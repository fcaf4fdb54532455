"""When a kernel runs on every core: one table of sizes, one way to choose.

Many compiled kernels come in twins, one loop compiled serial and parallel
(:func:`hybridedit.core.twins.twins`). Starting numba's thread pool costs more than small work, so
each kind of work switches to its parallel twin from a size measured for it (:data:`THRESHOLDS`,
items of the loop: rows, vertices, faces). And a parallel pass ends when its slowest thread does:
on a machine whose other programs keep the cores busy, the second thread waits for a time slice and
a 5 ms frame takes 20 (the 173K armadillo's canonical edit beside a busy core). So a kind goes
parallel only where a second core is actually free (:func:`free_cores`: the cores the *other*
processes left idle over the last fraction of a second) and where the calling thread may use more
than one (``numba.get_num_threads``). Every caller chooses through :func:`pick`; a size of 0 means
parallel whatever the load, and :func:`all_parallel` sets every size to zero for a while
(``python -m hybridedit.warmup`` compiles the parallel twins that way, tests compare the twins so).

The waiting itself is passive: :mod:`hybridedit` sets ``OMP_WAIT_POLICY=passive`` (unless the
user set it) before the OpenMP runtime loads, so an idle worker sleeps instead of spinning on a
core the frame's other thread, or the user's other programs, need.

Examples
--------
>>> pick("propagate", "serial", "parallel", 10)
'serial'
>>> with all_parallel():
...     pick("propagate", "serial", "parallel", 10)
'parallel'
"""

from __future__ import annotations

import contextlib
import os
import threading
import time
from typing import Iterator, TypeVar

K = TypeVar("K")

THRESHOLDS: dict[str, int] = {
    # a cage vertex's rotation (a 3x3 polar decomposition) is work enough that two threads win from
    # about a thousand (a 2,163-vertex cage's local step in half the time)
    "rotations": 1_000,
    # the region step's right-hand side (rotation blend, then the ARAP right-hand side): two threads
    # gain little at 6K rows and halve the time at 12K (the 690K canonical edit's region)
    "region_step": 8_000,
    # constrained rows placed exactly: they lie scattered through the shape and two threads wait on
    # memory side by side (the 690K armadillo's 52K handle rows in half the time)
    "place": 20_000,
    # rows of x' = M y' (plus the rotated residual): a few multiply-adds each
    "propagate": 20_000,
    # faces tested for degeneracy while a mesh is checked
    "faces": 50_000,
    # the window's per-frame kernels (points, normals, edge error, stretch) run on its frame thread,
    # beside the software rasterizer: a parallel region there waits for its slowest thread (the 173K
    # armadillo's region normals: 31 ms in parallel, about 2 ms serial)
    "window": 50_000,
    # vertex normals of a whole shape (the window's full update, a file's normals)
    "normals": 50_000,
    # rows of a shape-sized array copied into new memory: on this VM a new page costs more than the
    # copy (numpy asks for huge pages), and two threads fault pages in side by side (half the time)
    "copy": 1_000_000,
}


#: fewer free cores than this (other processes' load subtracted): the serial twin
MIN_FREE_CORES = 1.8


def pick(kind: str, serial: K, parallel: K, n: int) -> K:
    """The parallel twin when ``n`` items reach ``THRESHOLDS[kind]``, the calling thread may use
    two threads or more and at least :data:`MIN_FREE_CORES` cores are free of other processes'
    work (:func:`free_cores`); else the serial one. A kind of size 0 is parallel regardless."""
    size = THRESHOLDS[kind]
    if size == 0:
        return parallel
    if n < size or _thread_count() < 2:
        return serial
    return parallel if free_cores() >= MIN_FREE_CORES else serial


def _thread_count() -> int:
    import numba  # (here: importing this module must stay cheap for the command line)

    return numba.get_num_threads()


class _Load:
    """The cores other processes keep busy, sampled from ``/proc/stat`` (every process's CPU
    time) less this process's own (``os.times``), over the last :data:`PERIOD` seconds or more."""

    #: seconds between samples (/proc/stat counts in 10 ms ticks: 0.2 s is 20 ticks a core)
    PERIOD = 0.2

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.cores = _usable_cores()
        self.free = float(self.cores)  # until two samples tell
        self.last: tuple[float, float, float] | None = None  # (wall, machine busy s, own s)

    def free_cores(self) -> float:
        now = time.monotonic()
        if self.last is not None and now - self.last[0] < self.PERIOD:
            return self.free
        if not self.lock.acquire(blocking=False):  # another thread is sampling
            return self.free
        try:
            busy = _machine_busy_seconds()
            own = sum(os.times()[:2])
            if busy is None:
                return self.free
            if self.last is not None:
                wall0, busy0, own0 = self.last
                others = max(0.0, (busy - busy0) - (own - own0)) / max(now - wall0, 1e-9)
                self.free = max(0.0, min(float(self.cores), os.cpu_count() - others))
            self.last = (now, busy, own)
            return self.free
        finally:
            self.lock.release()


def _usable_cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


_TICK = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100


def _machine_busy_seconds() -> float | None:
    """CPU seconds every process of the machine has spent since boot (None where unknown)."""
    try:
        with open("/proc/stat", "rb") as f:
            fields = f.readline().split()
    except OSError:
        return None
    if not fields or fields[0] != b"cpu":
        return None
    ticks = [int(x) for x in fields[1:9]]  # user nice system idle iowait irq softirq steal
    return (sum(ticks) - ticks[3] - ticks[4]) / _TICK


_LOAD = _Load()


def free_cores() -> float:
    """Cores that other processes left idle over the last fraction of a second (this process's own
    work counts as free: it is what the kernels would use), at most the cores this process may run
    on. Where the machine's load cannot be read (not Linux), every usable core.

    Examples
    --------
    >>> 0.0 <= free_cores() <= os.cpu_count()
    True
    """
    return _LOAD.free_cores()


@contextlib.contextmanager
def all_parallel() -> Iterator[None]:
    """Every kind runs its parallel twin inside the ``with`` block (sizes restored after)."""
    saved = dict(THRESHOLDS)
    try:
        THRESHOLDS.update(dict.fromkeys(THRESHOLDS, 0))
        yield
    finally:
        THRESHOLDS.update(saved)
